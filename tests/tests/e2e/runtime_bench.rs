//! `sightline bench`, the real binary ([`sightline_tests::sightline_binary`]): every backend a
//! level supports runs, the GVS backend only on a level with GVS cells, and asking for an
//! unsupported one is an error (exit 2, the reason on stderr).

use std::process::Command;

use sightline_formats::level::GvsCell;
use sightline_formats::slvl;
use sightline_runtime::{backend, load};
use sightline_tests::synth;

/// Runs `sightline bench` on `path` over `backends` (none: every backend the level supports):
/// `Ok` on exit 0, `Err` with its stderr on exit 2; any other exit fails the test.
fn run(path: &std::path::Path, backends: &[&str]) -> Result<(), String> {
    let mut cmd = Command::new(sightline_tests::sightline_binary());
    cmd.arg("bench").arg(path).args(["--frames", "40", "--seed", "3", "--json"]);
    for b in backends {
        cmd.arg("--backend").arg(b);
    }
    cmd.arg(if backends.is_empty() { "--no-pvs-trees" } else { "--cull-back-faces" });
    let out = cmd.output().expect("run sightline");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    match out.status.code() {
        Some(0) => Ok(()),
        Some(2) => Err(stderr),
        _ => panic!("{cmd:?}: {}\n{stderr}", out.status),
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
    assert_eq!(run(&plain, &[]), Ok(()));
    assert_eq!(run(&with_cells, &["gvs", "pvs"]), Ok(()));
    let err = run(&plain, &["gvs"]).expect_err("no cells, no GVS backend");
    assert!(err.contains("no GVS cells"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
