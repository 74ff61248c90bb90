//! `sightline-runtime`: load a compiled level and answer, every frame, what can be seen.
//!
//! ```no_run
//! use sightline_runtime::{Camera, Scratch, Visible, World, backend::{Backend, pvs::Pvs}};
//! # fn frame(world: &World, cam: &Camera) {
//! let mut scratch = Scratch::new(world);
//! let mut visible = Visible::for_world(world);
//! Pvs.cull(world, &cam.view(), &mut scratch, &mut visible);
//! for &leaf in &visible.leaves { /* draw front to back */ }
//! # }
//! ```
//!
//! A [`World`] is validated once at load ([`World::new`], [`load::load_path`], [`load::load_bytes`]);
//! afterwards no query can panic. It is immutable and `Send + Sync`; per-caller state lives in a
//! [`Scratch`], so culling allocates nothing per frame.

#![forbid(unsafe_code)]

// Layers, bottom up (a module imports only from layers below it):
// 1. `error`, `camera`: no crate imports.
// 2. `tree` (the level's validated tables), `gvs_cells` (the level's GVS cells).
// 3. `locate`, `layout`, `draw` (built from `tree`); then `pvs` (rows, PHS, per-cluster trees
//    over `layout`).
// 4. `world`: owns all of the above; knows no query module and no backend.
// 5. `scratch`, `trace`, `load`, `query`; then `walk`; then `backend::*`; then `poses` (benchmark
//    input). The C ABI is the crate `sightline-capi` (`runtime/capi`); the brute-force reference
//    walk and synthetic levels are in the test-support crate `sightline-tests`.

pub mod backend;
pub mod camera;
pub mod draw;
pub mod error;
pub mod gvs_cells;
pub(crate) mod layout;
pub mod load;
pub(crate) mod locate;
pub mod poses;
pub mod pvs;
pub mod query;
pub mod scratch;
pub mod trace;
pub(crate) mod tree;
pub mod walk;
pub mod world;

pub use camera::{Camera, ClipDepth, Frustum, View};
pub use draw::{BrushModel, DrawData, FaceView};
pub use error::{GvsError, LoadError};
pub use gvs_cells::GvsCells;
pub use pvs::Bitset;
pub use scratch::{FrameStats, Scratch, Visible};
pub use trace::TraceHit;
pub use world::{Bounds, LeafId, Node, World};
