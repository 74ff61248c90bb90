//! Exit codes: 0 success, 1 a finding (a leak, a PVS miss), 2 an error naming the file;
//! `--json` that parses.

use std::path::Path;

use crate::support::{code, compile, maps, run, s, stderr, stdout_json, temp_dir};
use serde_json::Value;

#[test]
fn missing_and_malformed_inputs_exit_2_and_name_the_file() {
    let dir = temp_dir("errors");
    let missing = dir.join("nowhere.map");
    for cmd in ["compile", "vis", "validate", "info", "bench"] {
        let o = run(&[cmd, s(&missing)]);
        assert_eq!(code(&o), 2, "{cmd} on a missing file: {}", stderr(&o));
        assert!(stderr(&o).contains("nowhere.map"), "{cmd} names the file: {}", stderr(&o));
        assert!(o.stdout.is_empty(), "{cmd} prints nothing on stdout when it fails");
    }
    let bad = dir.join("bad.map");
    std::fs::write(&bad, "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 0 0 ) oops\n}\n}\n")
        .expect("write");
    let o = run(&["compile", s(&bad), "-o", s(&dir.join("bad.slvl"))]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("bad.map:"), "a parse error carries file:line: {}", stderr(&o));
    assert!(!dir.join("bad.slvl").exists(), "nothing written on error");
    let garbage = dir.join("garbage.bsp");
    std::fs::write(&garbage, b"IBSP\x1d\0\0\0 not a real header").expect("write");
    for cmd in ["vis", "info", "validate", "bench"] {
        let o = run(&[cmd, s(&garbage)]);
        assert_eq!(code(&o), 2, "{cmd} on a damaged BSP: {}", stderr(&o));
        assert!(stderr(&o).contains("garbage.bsp"), "{cmd} names the file: {}", stderr(&o));
    }
}

#[test]
fn a_leak_is_a_finding_exit_1_with_json_and_a_pointfile() {
    let dir = temp_dir("leak");
    let out = dir.join("leak.slvl");
    let o = run(&["compile", s(&maps().join("leak.map")), "-o", s(&out), "--json"]);
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let j = stdout_json(&o);
    assert!(j["leak"].is_object(), "leak reported: {j}");
    let pts = j["leak"]["pointfile"].as_str().expect("leak.pointfile");
    assert!(Path::new(pts).is_file(), "pointfile {pts} written");
    assert!(!out.exists(), "no level written for a leaking map");
}

#[test]
fn compile_info_validate_bench_and_vis_succeed_with_json() {
    let dir = temp_dir("ok");
    let level = compile(&dir, "two_rooms.map");

    let info = run(&["info", "--json", s(&level)]);
    assert_eq!(code(&info), 0, "{}", stderr(&info));
    let j = stdout_json(&info);
    assert!(j.is_object() && !j.as_object().expect("object").is_empty());

    let val = run(&["validate", s(&level), "--rays", "20000", "--json"]);
    assert_eq!(code(&val), 0, "{}", stderr(&val));
    let j = stdout_json(&val);
    let text = j.to_string();
    assert!(text.contains("misses"), "the report lists misses: {text}");

    let bench = run(&["bench", s(&level), "--frames", "50", "--json"]);
    assert_eq!(code(&bench), 0, "{}", stderr(&bench));
    let plain = stdout_json(&bench);
    // Back faces culled in the walk: fewer faces on the same poses, the same leaves.
    let culled =
        run(&["bench", s(&level), "--frames", "50", "--json", "--cull-back-faces", "--backend", "pvs"]);
    assert_eq!(code(&culled), 0, "{}", stderr(&culled));
    let culled = stdout_json(&culled);
    assert_eq!(culled["cull_back_faces"], true);
    let pvs = |j: &Value, key: &str| j["backends"][0][key].as_f64().expect(key);
    assert!(pvs(&culled, "visible_faces_avg") < pvs(&plain, "visible_faces_avg"));
    assert_eq!(pvs(&culled, "visible_leaves_avg"), pvs(&plain, "visible_leaves_avg"));

    let prt = level.with_extension("prt");
    assert!(prt.is_file(), "compile wrote the portal file");
    let vis = run(&["vis", s(&prt), "--json", "--threads", "2"]);
    assert_eq!(code(&vis), 0, "{}", stderr(&vis));
    stdout_json(&vis);

    let png = dir.join("plan.png");
    let render = run(&["render", s(&level), "--plan", "--size", "64x48", "-o", s(&png)]);
    assert_eq!(code(&render), 0, "{}", stderr(&render));
    let bytes = std::fs::read(&png).expect("png written");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"));

    let gvs = run(&["gvs", "gen:city:2", "--max-cells", "2", "--views", "0", "--json"]);
    assert_eq!(code(&gvs), 0, "{}", stderr(&gvs));
    stdout_json(&gvs);
}

#[test]
fn a_pvs_that_hides_a_visible_leaf_is_a_finding_exit_1() {
    use sightline_formats::{rle, slvl};
    let dir = temp_dir("miss");
    let level_path = compile(&dir, "two_rooms.map");
    let mut level = slvl::read(&std::fs::read(&level_path).expect("read level")).expect("our own level");
    assert!(level.num_clusters > 1, "two rooms make more than one cluster");
    // Every cluster sees only itself: the two rooms see each other through the doorway, so
    // ray sampling must find pairs this PVS hides.
    let row_bytes = (level.num_clusters as usize).div_ceil(8);
    level.pvs_data.clear();
    level.pvs_offsets.clear();
    for c in 0..level.num_clusters as usize {
        let mut row = vec![0u8; row_bytes];
        row[c / 8] |= 1 << (c % 8);
        level.pvs_offsets.push(level.pvs_data.len() as u32);
        rle::encode_row(&row, &mut level.pvs_data);
    }
    let bad = dir.join("blind.slvl");
    std::fs::write(&bad, slvl::write(&level, &slvl::WriteOptions::default())).expect("write");
    let o = run(&["validate", s(&bad), "--rays", "20000", "--json"]);
    assert_eq!(code(&o), 1, "a miss is a finding: {}", stderr(&o));
    stdout_json(&o);
}

#[test]
fn zero_rays_is_an_argument_error() {
    let dir = temp_dir("rays");
    let level = compile(&dir, "room.map");
    for args in [
        &["validate", s(&level), "--rays", "0"][..],
        &["render", s(&level), "--pvs-matrix", "--rays", "0", "-o", s(&dir.join("m.png"))],
    ] {
        let o = run(args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("--rays"), "names the argument: {}", stderr(&o));
        assert!(
            o.stdout.is_empty(),
            "nothing validated, nothing reported: {}",
            String::from_utf8_lossy(&o.stdout)
        );
    }
    let o = run(&["validate", s(&level), "--rays", "1", "--json"]);
    assert_eq!(code(&o), 0, "one ray is a budget: {}", stderr(&o));
}
