//! `sightline bench` through its library entry point: every backend a level supports runs, the
//! GVS backend only on a level with GVS cells, and asking for an unsupported one is an error.

use sightline::cli::Outcome;
use sightline::cmd::bench::{Args, run};
use sightline_formats::level::GvsCell;
use sightline_formats::slvl;
use sightline_runtime::{backend, load};
use sightline_tests::synth;

fn args(path: &std::path::Path, backends: &[&str]) -> Args {
    Args {
        input: path.to_path_buf(),
        frames: 40,
        seed: 3,
        backends: backends.iter().map(|b| b.to_string()).collect(),
        json: true,
        no_pvs_trees: backends.is_empty(),
        cull_back_faces: !backends.is_empty(),
    }
}

#[test]
fn bench_runs_the_gvs_backend_only_when_the_level_has_cells() {
    let dir = std::env::temp_dir().join(format!("sightline-runtime-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut level = synth::grid_level([6, 5, 2], 64.0, true, |x, y, _| (x + 2 * y) % 5 == 0);
    let plain = dir.join("plain.slvl");
    std::fs::write(&plain, slvl::write(&level, &slvl::WriteOptions { compress: true })).expect("write");
    let faces = level.faces.len() as u32;
    level.gvs_faces = (0..faces).collect();
    level.gvs_cells =
        vec![GvsCell { mins: [0.0; 3], maxs: [384.0, 320.0, 128.0], first_face: 0, num_faces: faces }];
    let with_cells = dir.join("cells.slvl");
    std::fs::write(&with_cells, slvl::write(&level, &slvl::WriteOptions { compress: true })).expect("write");

    let gvs = backend::by_name("gvs").expect("gvs backend");
    assert!(!gvs.supports(&load::load_path(&plain).expect("loads")));
    assert!(gvs.supports(&load::load_path(&with_cells).expect("loads")));
    assert!(matches!(run(&args(&plain, &[])), Ok(Outcome::Clean)));
    assert!(matches!(run(&args(&with_cells, &["gvs", "pvs"])), Ok(Outcome::Clean)));
    let err = run(&args(&plain, &["gvs"])).expect_err("no cells, no GVS backend");
    assert!(err.to_string().contains("no GVS cells"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
