//! The C ABI: compile a small C program against `runtime/include/sightline.h` and the runtime's
//! shared library (built with feature `ffi` as a dev-dependency of this crate), run it on a level
//! written by the test (and on E1M1 when the shared maps are present), and compare its answers
//! with the Rust API.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use sightline_formats::slvl;
use sightline_runtime::backend::{Backend, pvs::Pvs};
use sightline_runtime::{Camera, Scratch, Visible, World, load, synth};

const PROGRAM: &str = r#"
#include <stdio.h>
#include <stdlib.h>
#include "sightline.h"

int main(int argc, char **argv) {
    if (argc != 5) return 90;
    SlWorld *world = NULL;
    if (sl_world_load_file("/nonexistent/level.slvl", &world) != SL_ERR_IO || sl_last_error()[0] == 0) return 91;
    int rc = sl_world_load_file(argv[1], &world);
    if (rc != SL_OK) { fprintf(stderr, "load: %d %s\n", rc, sl_last_error()); return 92; }
    float eye[3] = { (float)atof(argv[2]), (float)atof(argv[3]), (float)atof(argv[4]) };
    uint32_t leaf = 0;
    if (sl_leaf_at(world, eye, &leaf) != SL_OK) return 93;
    printf("leaf %u\n", leaf);
    float to[3] = { eye[0] + 5000.0f, eye[1] + 1000.0f, eye[2] + 500.0f };
    SlTrace tr;
    if (sl_trace(world, eye, to, &tr) != SL_OK) return 94;
    printf("trace %d %.4f %u\n", tr.hit, tr.fraction, tr.leaf);
    SlScratch *scratch = sl_scratch_new(world);
    SlCamera cam = { { eye[0], eye[1], eye[2] }, 30.0f, 0.0f, 0.0f, 73.74f, 4.0f / 3.0f, 1.0f, 65536.0f };
    size_t count = 0;
    if (sl_visible_leaves(world, scratch, &cam, SL_BACKEND_PVS, NULL, 0, &count) != SL_OK) return 95;
    uint32_t *leaves = malloc((count + 1) * sizeof(uint32_t));
    size_t again = 0;
    if (sl_visible_leaves(world, scratch, &cam, SL_BACKEND_PVS, leaves, count, &again) != SL_OK || again != count) return 96;
    printf("visible %zu:", count);
    for (size_t i = 0; i < count; i++) printf(" %u", leaves[i]);
    printf("\n");
    if (sl_visible_leaves(world, scratch, &cam, 7, leaves, count, &again) != SL_ERR_BACKEND) return 97;
    free(leaves);
    sl_scratch_free(scratch);
    sl_world_free(world);
    return 0;
}
"#;

/// The shared library cargo built next to this test executable, copied away so a concurrent build
/// cannot swap it mid-test.
fn library(tmp: &Path) -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?;
    let name =
        if cfg!(target_os = "macos") { "libsightline_runtime.dylib" } else { "libsightline_runtime.so" };
    let src = [dir.join(name), dir.join("..").join(name)].into_iter().find(|p| p.is_file())?;
    let dst = tmp.join(name);
    std::fs::copy(&src, &dst).ok()?;
    Some(dst)
}

fn expected(world: &World, eye: Vec3) -> String {
    let leaf = world.leaf_at(eye);
    let to = eye + Vec3::new(5000.0, 1000.0, 500.0);
    let trace = match world.trace(eye, to) {
        Some(h) => format!("trace 1 {:.4} {}", h.fraction, h.leaf),
        None => "trace 0 1.0000 0".to_string(),
    };
    let cam = Camera { yaw: 30.0, fov_y: 73.74, ..Camera::quake(eye, 30.0, 0.0) };
    let mut out = Visible::default();
    Pvs.cull(world, &cam.view(), &mut Scratch::new(world), &mut out);
    let list: String = out.leaves.iter().map(|l| format!(" {l}")).collect();
    format!("leaf {leaf}\n{trace}\nvisible {}:{list}\n", out.leaves.len())
}

#[test]
fn c_program_agrees_with_the_rust_api() {
    if Command::new("cc").arg("--version").output().is_err() {
        eprintln!("skipped: no system C compiler `cc` on PATH");
        return;
    }
    let tmp = std::env::temp_dir().join(format!("sightline-ffi-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let lib = library(&tmp).expect("libsightline_runtime shared library next to the test executable");
    let src = tmp.join("prog.c");
    std::fs::write(&src, PROGRAM).expect("write C source");
    let include = sightline_tests::workspace_root().join("runtime/include");
    let prog = tmp.join("prog");
    let cc = Command::new("cc")
        .arg(&src)
        .arg("-std=c99")
        .arg("-Wall")
        .arg("-Werror")
        .arg(format!("-I{}", include.display()))
        .arg(&lib)
        .arg(format!("-Wl,-rpath,{}", tmp.display()))
        .arg("-o")
        .arg(&prog)
        .output()
        .expect("run cc");
    assert!(cc.status.success(), "cc failed: {}", String::from_utf8_lossy(&cc.stderr));

    // A level built here, written as .slvl.
    let level = synth::grid_level([6, 5, 2], 64.0, true, |x, y, _| x == 3 && y != 2);
    slvl::validate(&level).expect("synthetic level is valid");
    let path = tmp.join("grid.slvl");
    std::fs::write(&path, slvl::write(&level, &slvl::WriteOptions { compress: true })).expect("write level");
    let mut cases = vec![(path.clone(), World::new(&level).expect("world"), Vec3::new(40.0, 40.0, 40.0))];
    if let Some(maps) = sightline_tests::shared_maps() {
        let bsp = maps.join("ericw/e1m1.vis.bsp");
        let world = load::load_path(&bsp).expect("e1m1 loads");
        cases.push((bsp, world, Vec3::new(480.0, -352.0, 88.0)));
    }
    for (path, world, eye) in cases {
        let run = Command::new(&prog)
            .arg(&path)
            .args([eye.x, eye.y, eye.z].map(|v| v.to_string()))
            .output()
            .expect("run the C program");
        assert!(
            run.status.success(),
            "C program failed ({:?}): {}",
            run.status,
            String::from_utf8_lossy(&run.stderr)
        );
        let got = String::from_utf8_lossy(&run.stdout).to_string();
        assert_eq!(got, expected(&world, eye), "{}", path.display());
        assert!(got.lines().nth(2).is_some_and(|l| l != "visible 0:"), "something is visible: {got}");
    }
    let _ = std::fs::remove_dir_all(&tmp);
}
