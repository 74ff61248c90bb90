//! `sightline info`: snapshots of the JSON report for every bundled map, counts checked against an
//! independent brace scan and against the reference compiler's published numbers.

use std::path::Path;

use sightline::cmd::info::{self, Details};

use crate::brace_scan;
use brace_scan::brace_scan;

fn details_json(path: &Path) -> serde_json::Value {
    let report = info::report(path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
    assert_eq!(report.file, path.display().to_string());
    let json = serde_json::to_value(&report).expect("serializable");
    let mut object = json.as_object().expect("an object").clone();
    // The path depends on the checkout; everything else is stable.
    object.remove("file");
    serde_json::Value::Object(object)
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
        let report = info::report(&path).expect("parses");
        let Details::Map { entities, brushes, sides, .. } = report.details else {
            panic!("{}: not reported as a map", path.display())
        };
        assert_eq!((entities, brushes, sides), (expect.entities, expect.brushes, expect.sides));
    }
}

#[test]
fn e1m1_matches_the_reference_numbers() {
    let Some(root) = sightline_tests::shared_maps() else { return };
    // anchors.md: ericw-tools on E1M1 gives 1,344 leaves, 1,167 clusters, 3,062 portals,
    // average 164.8 visible leaves, max 401, visdata 48,908 bytes; the map has 1,257 brushes.
    let report = info::report(&root.join("ericw/e1m1.vis.bsp")).expect("reads");
    let Details::Bsp { version, visleafs, visdata_bytes, has_vis, pvs: Some(pvs), .. } = report.details
    else {
        panic!("not a vis-ed BSP: {report:?}")
    };
    assert_eq!((version, visleafs, visdata_bytes, has_vis), ("BSP29", 1344, 48_908, true));
    assert_eq!(format!("{:.1}", pvs.avg_visible_leaves), "164.8");
    assert_eq!(pvs.max_visible_leaves, 401);

    let report = info::report(&root.join("ericw/e1m1.prt")).expect("reads");
    assert!(
        matches!(
            report.details,
            Details::Prt { format: "prt2", leaves: 1344, clusters: 1167, portals: 3062, .. }
        ),
        "{report:?}"
    );

    let report = info::report(&root.join("id/e1m1.map")).expect("reads");
    assert!(matches!(report.details, Details::Map { brushes: 1257, format: "standard", .. }), "{report:?}");
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
    let from_slvl = info::report(&slvl).expect("reads");
    let from_bsp = info::report(&root.join("ericw/dm1.vis.bsp")).expect("reads");
    std::fs::remove_dir_all(&dir).ok();
    let (
        Details::Slvl { vis_leaves, pvs: Some(a), has_vis: true, .. },
        Details::Bsp { visleafs, pvs: Some(b), .. },
    ) = (&from_slvl.details, &from_bsp.details)
    else {
        panic!("{from_slvl:?} / {from_bsp:?}")
    };
    assert_eq!(vis_leaves, visleafs);
    assert_eq!(a.max_visible_leaves, b.max_visible_leaves);
    assert!((a.avg_visible_leaves - b.avg_visible_leaves).abs() < 1e-9);
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
    let results = (info::report(&map), info::report(&obj), info::report(&junk));
    std::fs::remove_dir_all(&dir).ok();
    assert!(matches!(results.0.expect("map").details, Details::Map { brushes: 6, .. }));
    assert!(matches!(results.1.expect("obj").details, Details::Obj { triangles: 48, .. }));
    let err = results.2.expect_err("unknown kind");
    assert!(err.to_string().contains("unknown file kind"), "{err}");
}

#[test]
fn errors_name_the_file_and_place() {
    let dir = std::env::temp_dir().join(format!("sightline-info-err-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bad = dir.join("bad.map");
    std::fs::write(&bad, "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 1 1 ) ( 2 2 2 ) T 0 0 0 1 1\n")
        .expect("write");
    let err = info::report(&bad).expect_err("degenerate side");
    std::fs::remove_dir_all(&dir).ok();
    let msg = format!("{err:#}");
    assert!(msg.contains("bad.map:4:1: entity 0 brush 0 side 0: degenerate plane"), "{msg}");
}
