//! End-to-end tests over the crates and the binary, in one test binary (one link instead of one
//! per file). `hostile_inputs` stays a binary of its own: it installs a counting global allocator.

mod brace_scan;
mod bsp_roundtrip;
mod bundled_expectations;
mod cancel;
mod capi_install;
mod compile_cli;
mod compile_maps;
mod family_runtime;
mod ffi_header;
mod gvs_visibility;
mod info_cli;
mod map_parse;
mod mapgen;
mod mesh_validate;
mod render_pixels;
mod revis;
mod runtime_bench;
mod runtime_compiled;
mod runtime_draw;
mod runtime_ffi;
mod runtime_hostile;
mod runtime_real_maps;
mod tb_layers;
mod unusable_bounds;
mod validate_compiled;
mod validate_reference;
mod vis_hl;
mod vis_prt;
mod vis_q2;
mod vis_q3;
mod vis_real;
mod vis_shapes;
mod vis_shards;
mod vis_viscluster;
mod viscluster;
