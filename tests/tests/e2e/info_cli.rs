//! `sightline info`, the real binary ([`sightline_tests::sightline_binary`]): snapshots of the
//! JSON report for every bundled map, counts checked against an independent brace scan and
//! against the reference compiler's published numbers.

use std::path::Path;

use serde_json::{Value, json};

use crate::brace_scan;
use brace_scan::brace_scan;

/// `sightline info PATH --json`: the report on exit 0 (its `file` is the path as given), or what
/// it printed on stderr on exit 2. Any other exit fails the test.
pub(crate) fn info_report(path: &Path) -> Result<Value, String> {
    let out = std::process::Command::new(sightline_tests::sightline_binary())
        .arg("info")
        .arg(path)
        .arg("--json")
        .output()
        .expect("run sightline");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    match out.status.code() {
        Some(0) => {
            let report: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
                panic!(
                    "{}: stdout is not JSON ({e}): {}",
                    path.display(),
                    String::from_utf8_lossy(&out.stdout)
                )
            });
            assert_eq!(report["file"], json!(path.display().to_string()));
            Ok(report)
        }
        Some(2) => Err(stderr),
        _ => panic!("sightline info {}: {}\n{stderr}", path.display(), out.status),
    }
}

/// [`info_report`] of a file that must read.
pub(crate) fn info(path: &Path) -> Value {
    info_report(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn details_json(path: &Path) -> Value {
    let mut object = info(path).as_object().expect("an object").clone();
    // The path depends on the checkout; everything else is stable.
    object.remove("file");
    Value::Object(object)
}

#[test]
fn bundled_files_snapshot() {
    let dir = sightline_tests::bundled_maps();
    for name in [
        "room.map",
        "two_rooms.map",
        "lbend.map",
        "leak.map",
        "angled.map",
        "stairs_pillars.map",
        "thin_leaf.map",
        "coplanar.map",
        "valve220.map",
        "detail_water.map",
        "scene.obj",
    ] {
        insta::assert_json_snapshot!(name, details_json(&dir.join(name)));
    }
}

#[test]
fn map_counts_match_an_independent_scan() {
    let mut paths = vec![sightline_tests::bundled_maps().join("detail_water.map")];
    if let Some(root) = sightline_tests::shared_maps() {
        paths.extend(["id/e1m1.map", "id/dm2.map", "librequake/lqdm1.map"].map(|p| root.join(p)));
    }
    for path in paths {
        let text = std::fs::read_to_string(&path).expect("readable");
        let expect = brace_scan(&text);
        let report = info(&path);
        assert_eq!(report["kind"], "map", "{}: not reported as a map", path.display());
        assert_eq!(
            (&report["entities"], &report["brushes"], &report["sides"]),
            (&json!(expect.entities), &json!(expect.brushes), &json!(expect.sides))
        );
    }
}

#[test]
fn e1m1_matches_the_reference_numbers() {
    let Some(root) = sightline_tests::shared_maps() else { return };
    // anchors.md: ericw-tools on E1M1 gives 1,344 leaves, 1,167 clusters, 3,062 portals,
    // average 164.8 visible leaves, max 401, visdata 48,908 bytes; the map has 1,257 brushes.
    let report = info(&root.join("ericw/e1m1.vis.bsp"));
    let pvs = &report["pvs"];
    assert!(report["kind"] == "bsp" && pvs.is_object(), "not a vis-ed BSP: {report}");
    assert_eq!(
        [&report["version"], &report["visleafs"], &report["visdata_bytes"], &report["has_vis"]],
        [&json!("BSP29"), &json!(1344), &json!(48_908), &json!(true)]
    );
    assert_eq!(format!("{:.1}", pvs["avg_visible_leaves"].as_f64().expect("number")), "164.8");
    assert_eq!(pvs["max_visible_leaves"], 401);

    let report = info(&root.join("ericw/e1m1.prt"));
    assert_eq!(
        [&report["kind"], &report["format"], &report["leaves"], &report["clusters"], &report["portals"]],
        [&json!("prt"), &json!("prt2"), &json!(1344), &json!(1167), &json!(3062)],
        "{report}"
    );

    let report = info(&root.join("id/e1m1.map"));
    assert_eq!(
        [&report["kind"], &report["brushes"], &report["format"]],
        [&json!("map"), &json!(1257), &json!("standard")],
        "{report}"
    );
}

#[test]
fn slvl_statistics_equal_the_bsp_they_came_from() {
    let Some(root) = sightline_tests::shared_maps() else { return };
    let bytes = std::fs::read(root.join("ericw/dm1.vis.bsp")).expect("readable");
    let bsp = sightline_formats::bsp::read(&bytes).expect("valid");
    let level = sightline_formats::bsp::to_level(&bsp);
    let dir = std::env::temp_dir().join(format!("sightline-info-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    // No extension: the kind must come from the magic bytes.
    let slvl = dir.join("dm1_level");
    std::fs::write(&slvl, sightline_formats::slvl::write(&level, &Default::default())).expect("writable");
    let from_slvl = info(&slvl);
    let from_bsp = info(&root.join("ericw/dm1.vis.bsp"));
    std::fs::remove_dir_all(&dir).ok();
    let (a, b) = (&from_slvl["pvs"], &from_bsp["pvs"]);
    assert!(
        from_slvl["kind"] == "slvl"
            && from_slvl["has_vis"] == true
            && a.is_object()
            && from_bsp["kind"] == "bsp"
            && b.is_object(),
        "{from_slvl} / {from_bsp}"
    );
    assert_eq!(from_slvl["vis_leaves"], from_bsp["visleafs"]);
    assert_eq!(a["max_visible_leaves"], b["max_visible_leaves"]);
    let avg = |v: &Value| v["avg_visible_leaves"].as_f64().expect("number");
    assert!((avg(a) - avg(b)).abs() < 1e-9);
}

#[test]
fn kind_comes_from_magic_without_an_extension() {
    let dir = std::env::temp_dir().join(format!("sightline-info-magic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bundled = sightline_tests::bundled_maps();
    let map = dir.join("a_map");
    std::fs::copy(bundled.join("room.map"), &map).expect("copy");
    let obj = dir.join("a_mesh.txt");
    std::fs::copy(bundled.join("scene.obj"), &obj).expect("copy");
    let junk = dir.join("junk.bin");
    std::fs::write(&junk, [0xde, 0xad, 0xbe, 0xef, 0, 1, 2]).expect("write");
    let results = (info_report(&map), info_report(&obj), info_report(&junk));
    std::fs::remove_dir_all(&dir).ok();
    let map = results.0.expect("map");
    assert!(map["kind"] == "map" && map["brushes"] == 6, "{map}");
    let obj = results.1.expect("obj");
    assert!(obj["kind"] == "obj" && obj["triangles"] == 48, "{obj}");
    let err = results.2.expect_err("unknown kind");
    assert!(err.contains("unknown file kind"), "{err}");
}

#[test]
fn errors_name_the_file_and_place() {
    let dir = std::env::temp_dir().join(format!("sightline-info-err-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bad = dir.join("bad.map");
    std::fs::write(&bad, "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 1 1 ) ( 2 2 2 ) T 0 0 0 1 1\n")
        .expect("write");
    let msg = info_report(&bad).expect_err("degenerate side");
    std::fs::remove_dir_all(&dir).ok();
    assert!(msg.contains("bad.map:4:1: entity 0 brush 0 side 0: degenerate plane"), "{msg}");
}
