//! `sightline trace` on meshes and along walks: the picture traced against the GVS set of the
//! eye's grid cell against the whole mesh's (GVS is sampled, so the gate's count of differing
//! pixels is what is checked, and a set missing a seen triangle is caught), and the walkthrough's
//! per-step report against the path it walked.

use std::collections::HashSet;
use std::process::Command;

use glam::DVec3;
use sightline_gvs::cells::Grid;
use sightline_validate::trace::Camera;
use sightline_validate::trace::mesh::{MeshCellSet, MeshCells, MeshScene, SetSource, trace_mesh_camera};

/// A small generated city (12 × 12 blocks, about 13 K triangles).
const CITY: &str = "gen:city:12";
/// Its grid's cell side (the command's default for a city: half a block).
const CELL: f32 = 5.0;

fn trace_json(args: &[&str]) -> (Option<i32>, serde_json::Value, String) {
    let out = Command::new(sightline_tests::sightline_binary())
        .arg("trace")
        .args(args)
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let v = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {stderr}"));
    (out.status.code(), v, stderr)
}

#[test]
fn mesh_gate_counts_every_pixel_and_its_verdict_is_the_exit_code() {
    let (code, v, stderr) = trace_json(&[CITY, "--poses", "6", "--seed", "2", "--size", "64x48", "--json"]);
    assert_eq!(v["scene"], "mesh");
    assert_eq!(v["gvs_sampled"], true);
    let poses = v["poses"].as_array().unwrap();
    assert_eq!(poses.len() as u64 + v["poses_skipped"].as_u64().unwrap(), 6);
    assert!(poses.len() >= 5, "city street poses are open: {stderr}");
    let (mut differ, mut listed) = (0, 0);
    for p in poses {
        let n = |k: &str| p[k].as_u64().unwrap_or_else(|| panic!("{k} in {p}"));
        assert_eq!(n("same") + n("ties") + n("mismatches"), 64 * 48, "{p}");
        assert_eq!(n("grazes"), 0, "a mesh has no grazes");
        assert_eq!(p["listed"].as_array().unwrap().len() as u64, n("mismatches").min(16), "{p}");
        assert!(
            n("set_triangles") < v["scene_triangles"].as_u64().unwrap() / 2,
            "a street sees little of the city"
        );
        assert!(n("set_triangles") > 0);
        differ += n("mismatches");
        listed += n("mismatches").min(16);
    }
    // GVS is sampled; on the city its misses are rare (a handful of pixels at most).
    assert!(differ * 100 < (poses.len() * 64 * 48) as u64, "{differ} differing pixels");
    assert_eq!(v["passed"], differ == 0);
    assert_eq!(code, Some(if differ == 0 { 0 } else { 1 }), "{stderr}");
    assert_eq!(stderr.matches("is missing from the cell set").count() as u64, listed);
}

#[test]
fn a_cell_set_without_a_seen_triangle_fails_the_gate_on_its_pixels() {
    let (scene, _) = sightline_gvs::scene::load(CITY, 1, &sightline_gvs::NoProgress).unwrap();
    let mesh =
        MeshScene::new(&scene.triangles, &scene.bounds(), CELL, sightline_gvs::Params::default()).unwrap();
    let eyes = mesh.random_eyes(&scene.open, 4, 9);
    assert_eq!(eyes.len(), 4);
    for (eye, yaw, pitch) in eyes {
        let cam = Camera { eye, yaw, pitch, fov: 90.0, width: 48, height: 32 };
        let good = trace_mesh_camera(&mesh, &mut MeshCells::default(), &cam, None).unwrap();
        // The triangle most pixels show: drop it from the cell's set.
        let mut counts = std::collections::HashMap::new();
        for h in good.full.hits.iter().flatten() {
            *counts.entry(h.triangle).or_insert(0usize) += 1;
        }
        let (&gone, &shown) = counts.iter().max_by_key(|(t, c)| (**c, std::cmp::Reverse(**t))).unwrap();
        let mut pvs = good.set.pvs.clone();
        pvs.entries.retain(|e| e.tri != gone);
        let mut cache = MeshCells::default();
        cache.insert(MeshCellSet::from_pvs(&mesh, good.cell, pvs, SetSource::Given, Default::default()));
        let bad = trace_mesh_camera(&mesh, &mut cache, &cam, None).unwrap();
        assert!(bad.cached && bad.set.source == SetSource::Given);
        // Every pixel of the dropped triangle now differs, except one the good set already missed
        // or a tie; no other pixel changes verdict.
        let before = good.gate.mismatches;
        assert!(bad.gate.mismatches + bad.gate.ties >= before + shown - good.gate.ties, "{:?}", bad.gate);
        assert!(bad.gate.mismatches <= before + shown);
        assert!(bad.gate.listed.iter().any(|m| m.full.triangle == gone), "the dropped triangle is named");
        let text = bad.gate.listed[0].to_string();
        assert!(text.starts_with("pixel (") && text.contains("missing from the cell set"), "{text}");
    }
}

#[test]
fn mesh_walk_reports_one_entry_per_step_with_cells_matching_the_eyes() {
    let (code, v, stderr) = trace_json(&[CITY, "--walk", "16", "--seed", "3", "--size", "32x24", "--json"]);
    assert!(code == Some(0) || code == Some(1), "{stderr}");
    let steps = v["steps"].as_array().unwrap();
    assert_eq!(steps.len() as u64 + v["steps_skipped"].as_u64().unwrap(), 16);
    assert_eq!(v["steps_skipped"], 0, "a street walk stays on the grid: {stderr}");
    let (scene, _) = sightline_gvs::scene::load(CITY, 1, &sightline_gvs::NoProgress).unwrap();
    let grid = Grid::new(&scene.bounds(), v["cell_size"].as_f64().unwrap() as f32).unwrap();
    let mut seen = HashSet::new();
    let mut previous = None;
    for (i, s) in steps.iter().enumerate() {
        assert_eq!(s["index"], i);
        let eye: Vec<f64> = s["eye"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let cell = grid.cell_of(DVec3::new(eye[0], eye[1], eye[2]).as_vec3()).unwrap() as u64;
        assert_eq!(s["cell"], cell, "step {i}");
        assert_eq!(s["cell_changed"], previous != Some(cell), "step {i}");
        for k in ["set_ms", "bvh_ms", "full_ms", "pvs_ms"] {
            assert!(s[k].as_f64().unwrap() >= 0.0, "step {i}: {k}");
        }
        let source = s["set_source"].as_str().unwrap();
        // A cell's set is made when the walk first enters it (a fresh run for the first, then
        // updates of the cell walked from), and looked up after that.
        let first = seen.insert(cell);
        let want = match (first, i) {
            (false, _) => "cached",
            (true, 0) => "gvs",
            (true, _) => "update",
        };
        assert_eq!(source, want, "step {i}");
        if !first {
            assert_eq!(s["set_ms"], 0.0);
            assert_eq!(s["bvh_ms"], 0.0);
        }
        if let Some(p) = previous.filter(|&p| p != cell) {
            assert!(s["cell_changed"].as_bool().unwrap() && p != cell);
        }
        previous = Some(cell);
    }
    assert_eq!(v["sets_built"].as_u64().unwrap() as usize, seen.len());
    assert!(seen.len() >= 3, "the walk crosses cells");
    // Steps go half a cell at a time, horizontally at eye height.
    for w in steps.windows(2) {
        let e = |s: &serde_json::Value| {
            let a: Vec<f64> = s["eye"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            DVec3::new(a[0], a[1], a[2])
        };
        let d = e(&w[1]) - e(&w[0]);
        assert!(d.z == 0.0 && (d.length() == 0.0 || (d.length() - 2.5).abs() < 1e-6), "{d}");
    }
}

#[test]
fn level_walk_cells_are_the_eyes_clusters() {
    let Some(path) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let p = path.to_str().unwrap();
    let (code, v, stderr) = trace_json(&[p, "--walk", "12", "--size", "32x24", "--json"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(v["scene"], "level");
    let level = sightline_validate::load::load_level(&path, &sightline_validate::NoProgress).unwrap();
    let tree = sightline_validate::bsp::BspTree::new(&level).unwrap();
    let steps = v["steps"].as_array().unwrap();
    assert_eq!(steps.len() as u64 + v["steps_skipped"].as_u64().unwrap(), 12);
    let mut previous = None;
    let mut seen = HashSet::new();
    for s in steps {
        let eye: Vec<f64> = s["eye"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let cluster = tree.cluster(tree.leaf_at(DVec3::new(eye[0], eye[1], eye[2]))).map(u64::from);
        assert_eq!(s["cell"].as_u64(), cluster);
        assert_eq!(s["cell_changed"], previous != cluster);
        assert_eq!(s["set_source"], if seen.insert(cluster) { "pvs row" } else { "cached" });
        assert_eq!(s["mismatches"], 0);
        previous = cluster;
    }
}

#[test]
fn bad_walk_arguments_are_refused_before_any_work() {
    for bad in [
        &[CITY, "--path", "1,2"][..],
        &[CITY, "--path", "1,2,3;;"],
        &[CITY, "--path", "1,2,3", "--view", "1,2,3"],
        &[CITY, "--walk", "3", "--poses", "2"],
        &[CITY, "--walk", "0"],
        &[CITY, "--pose", "player_start"],
    ] {
        let out = Command::new(sightline_tests::sightline_binary()).arg("trace").args(bad).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {stderr}");
        assert!(stderr.contains("--"), "{bad:?}: the error names the flag: {stderr}");
    }
}
