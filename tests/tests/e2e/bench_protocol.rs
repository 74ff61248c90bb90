//! `sightline bench`'s saved-poses protocol (the real binary) and the baseline backends: a saved
//! poses file reads back to the same poses, a malformed one is refused naming the file and the
//! line, and on real maps the frustum-only backend outputs every leaf and face the PVS walk does
//! (and the no-culling backend every face the frustum-only one does).

use std::path::Path;
use std::process::{Command, Output};

use sightline_runtime::backend::{Backend, frustum::FrustumOnly, none::NoCulling, pvs::Pvs};
use sightline_runtime::poses::random_cameras;
use sightline_runtime::{Scratch, Visible, load};

fn bench(args: &[&str]) -> Output {
    Command::new(sightline_tests::sightline_binary()).arg("bench").args(args).output().expect("run sightline")
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-bench-protocol-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The `poses` of a protocol report (`--json`): eye, yaw and pitch of each, in order.
fn reported_poses(out: &Output) -> Vec<serde_json::Value> {
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    j["poses"]
        .as_array()
        .expect("poses")
        .iter()
        .map(|p| serde_json::json!([p["eye"], p["yaw"], p["pitch"], p["pvs_leaves"], p["visible_faces"]]))
        .collect()
}

#[test]
fn saved_poses_read_back_as_the_same_poses() {
    let dir = temp_dir("roundtrip");
    for rel in ["ericw/e1m1.vis.bsp", "hl/dm2.sdhlt.vis.bsp"] {
        let Some(map) = sightline_tests::shared_map(rel) else { continue };
        let file = dir.join("poses.txt");
        let (m, f) = (map.to_str().expect("utf-8"), file.to_str().expect("utf-8"));
        let common = ["--repeats", "1", "--backend", "pvs", "--backend", "frustum", "--json"];
        let saved = bench(&[&[m, "--save-poses", f, "--frames", "300", "--seed", "5"], &common[..]].concat());
        let first = reported_poses(&saved);
        assert_eq!(first.len(), 2, "{rel}: an occluded and an open pose");
        // The occluded pose's PVS is no larger than the open one's.
        assert!(first[0][3].as_u64() <= first[1][3].as_u64(), "{rel}: {first:?}");
        let read = bench(&[&[m, "--poses-file", f], &common[..]].concat());
        assert_eq!(reported_poses(&read), first, "{rel}: the file gives back the poses it saved");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_malformed_poses_file_exits_2_naming_the_file_and_line() {
    let Some(map) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let dir = temp_dir("malformed");
    let good = "# a comment\n\n480 -352 88 90 0 # start\n";
    let bad = [
        "480 -352 88 90",
        "480 -352 88 90 0 1",
        "480 -352 eighty 90 0",
        "480 NaN 88 90 0",
        "inf 0 0 0 0",
        "1e39 0 0 0 0",
    ];
    for (k, line) in bad.iter().enumerate() {
        let file = dir.join(format!("bad{k}.txt"));
        // The bad line after the good ones: line 4.
        std::fs::write(&file, format!("{good}{line}\n")).expect("write");
        let out = bench(&[map.to_str().expect("utf-8"), "--poses-file", file.to_str().expect("utf-8")]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "`{line}`: {stderr}");
        assert!(stderr.contains(&format!("{}: line 4", file.display())), "`{line}`: {stderr}");
    }
    let empty = dir.join("empty.txt");
    std::fs::write(&empty, "# nothing\n").expect("write");
    let out = bench(&[map.to_str().expect("utf-8"), "--poses-file", empty.to_str().expect("utf-8")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains(&empty.display().to_string()));
    let _ = std::fs::remove_dir_all(&dir);
}

/// True when every element of `small` is in `big` (both short lists of ids).
fn subset(small: &[u32], big: &[u32]) -> bool {
    let mut big = big.to_vec();
    big.sort_unstable();
    small.iter().all(|x| big.binary_search(x).is_ok())
}

#[test]
fn frustum_only_outputs_a_superset_of_the_pvs_walk_on_real_maps() {
    let maps = ["ericw/e1m1.vis.bsp", "ericw/dm2.vis.bsp", "q2/e1m1.ericw.t1.bsp", "hl/dm2.sdhlt.vis.bsp"];
    for rel in maps {
        let Some(path) = sightline_tests::shared_map(rel) else { continue };
        check_superset(&path, rel);
    }
}

fn check_superset(path: &Path, rel: &str) {
    let world = load::load_path(path).unwrap_or_else(|e| panic!("{rel}: {e}"));
    assert!(world.has_vis(), "{rel}: vised");
    let mut scratch = Scratch::new(&world);
    let (mut pvs, mut frustum, mut none) =
        (Visible::for_world(&world), Visible::for_world(&world), Visible::for_world(&world));
    let mut strictly = 0;
    for (i, cam) in random_cameras(&world, 23, 300).iter().enumerate() {
        for cull in [false, true] {
            let view = cam.view().with_back_face_culling(cull);
            Pvs.cull(&world, &view, &mut scratch, &mut pvs);
            FrustumOnly.cull(&world, &view, &mut scratch, &mut frustum);
            NoCulling.cull(&world, &view, &mut scratch, &mut none);
            assert!(
                subset(&pvs.leaves, &frustum.leaves),
                "{rel}: pose {i}: a PVS leaf outside the frustum walk"
            );
            assert!(
                subset(&pvs.faces, &frustum.faces),
                "{rel}: pose {i}: a PVS face outside the frustum walk"
            );
            assert!(subset(&frustum.faces, &none.faces), "{rel}: pose {i}: a frustum face not in no culling");
            assert_eq!(
                none.leaves.len(),
                world.open_leaves().len(),
                "{rel}: no culling lists every open leaf"
            );
            strictly += usize::from(frustum.leaves.len() > pvs.leaves.len());
        }
    }
    // The PVS hides something on a vised map, so the property is not met by equal outputs.
    assert!(strictly > 0, "{rel}: the frustum walk never output more than the PVS walk");
}
