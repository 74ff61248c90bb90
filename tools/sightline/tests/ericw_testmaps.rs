//! ericw-tools' own vis test maps (`ericw-testmaps/` in the shared maps), vised by the real
//! `sightline` binary called the way ericw-tools' build scripts call `vis` (a base name,
//! single-dash flags), then held to the point assertions of ericw-tools' `tests/test_vis.cc`
//! (transcribed into `assertions.json` beside the maps): which point sees which, leaf contents,
//! ambient sound levels (Quake 2 leaf contents are qbsp's, which vis leaves byte for byte, so only
//! the Quake 1 ones are checked here). On top of those, our own stricter check: ray validation finds no pair
//! the written PVS misses, on every map whose source has no `func_illusionary_visblocker` (a
//! brush the mapper asks vis to treat as opaque although sight passes through it: qbsp writes no
//! portals there, so rays find, by design, pairs that the PVS leaves out).

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use sightline_formats::bsp::{self, Bsp};
use sightline_runtime::{Bitset, World, load};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sightline"))
}

fn testmaps() -> Option<PathBuf> {
    let dir = sightline_tests::shared_maps()?.join("ericw-testmaps");
    if dir.join("assertions.json").is_file() {
        Some(dir)
    } else {
        eprintln!("note: {} missing; ericw test-map checks are not run", dir.display());
        None
    }
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-ericw-testmaps-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Copies `stem.{bsp,prt,texinfo.json}` (those that exist) from `from` into `to`.
fn copy_map(from: &Path, to: &Path, stem: &str) {
    for ext in ["bsp", "prt", "texinfo.json"] {
        let src = from.join(format!("{stem}.{ext}"));
        if src.is_file() {
            std::fs::copy(&src, to.join(format!("{stem}.{ext}"))).expect("copy test map file");
        }
    }
}

/// Runs `sightline vis -threads 2 -nopercent STEM` in `dir`, as a build script would.
fn vis_like_ericw(dir: &Path, stem: &str) {
    let out =
        bin().current_dir(dir).args(["vis", "-threads", "2", "-nopercent", stem]).output().expect("runs");
    assert_eq!(
        out.status.code(),
        Some(0),
        "vis {stem}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn point(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("a point is [x, y, z]");
    [0, 1, 2].map(|i| a[i].as_f64().expect("a coordinate"))
}

/// The leaf of model 0 holding `p` (points on a plane go to the front child, as in the tests).
fn q1_leaf_at(b: &Bsp, p: [f64; 3]) -> usize {
    let mut child = b.models[0].head_nodes[0];
    while child >= 0 {
        let node = &b.nodes[child as usize];
        let plane = &b.planes[node.plane as usize];
        let d = (0..3).map(|i| f64::from(plane.normal[i]) * p[i]).sum::<f64>() - f64::from(plane.dist);
        child = node.children[usize::from(d < 0.0)];
    }
    (-1 - child) as usize
}

/// Quake 1 "sees": bit `to - 1` of the row at `from`'s `visofs`.
fn q1_sees(b: &Bsp, from: usize, to: usize) -> bool {
    let row = b.decode_leaf_pvs(from).expect("row decodes");
    to >= 1 && row.get((to - 1) / 8).is_some_and(|byte| byte & (1 << ((to - 1) % 8)) != 0)
}

/// Every assertion of one Quake 1 map; returns the failures.
fn check_q1(spec: &Value, codes: &Value, b: &Bsp) -> Vec<String> {
    let leaf = |name: &str| q1_leaf_at(b, point(&spec["points"][name]));
    let mut failed = Vec::new();
    for (name, want) in spec["leaf_contents"].as_object().into_iter().flatten() {
        let code = codes[want.as_str().expect("a contents name")].as_i64().expect("a contents code");
        let got = i64::from(b.leaves[leaf(name)].contents);
        if got != code {
            failed.push(format!("contents({name}) = {got}, want {want}"));
        }
    }
    for s in spec["sees"].as_array().into_iter().flatten() {
        let (from, to) = (s["from"].as_str().expect("from"), s["to"].as_str().expect("to"));
        let got = q1_sees(b, leaf(from), leaf(to));
        if Some(got) != s["expect"].as_bool() {
            failed.push(format!("{from} sees {to} = {got}"));
        }
    }
    for a in spec["ambient"].as_array().into_iter().flatten() {
        let at = a["point"].as_str().expect("point");
        let channel = a["index"].as_u64().expect("index") as usize;
        let got = b.leaves[leaf(at)].ambient[channel];
        if Some(u64::from(got)) != a["expect"].as_u64() {
            failed.push(format!("ambient[{}]({at}) = {got}, want {}", a["channel"], a["expect"]));
        }
    }
    failed
}

/// Quake 2 "sees": the bit of `to`'s cluster in the PVS row of `from`'s cluster.
fn q2_sees(world: &World, from: [f64; 3], to: [f64; 3]) -> Option<bool> {
    let at = |p: [f64; 3]| world.leaf_cluster(world.leaf_at(p.map(|c| c as f32)));
    let (a, b) = (at(from)?, at(to)?);
    let mut row = Bitset::new(0);
    world.decode_pvs(a, &mut row);
    Some(row.get(b as usize))
}

/// The "sees" assertions of one Quake 2 map, through the runtime; returns the failures.
fn check_q2(spec: &Value, world: &World) -> Vec<String> {
    let mut failed = Vec::new();
    for s in spec["sees"].as_array().into_iter().flatten() {
        let (from, to) = (s["from"].as_str().expect("from"), s["to"].as_str().expect("to"));
        let got = q2_sees(world, point(&spec["points"][from]), point(&spec["points"][to]));
        if got != s["expect"].as_bool() {
            failed.push(format!("{from} sees {to} = {got:?}"));
        }
    }
    failed
}

#[test]
fn ericw_vis_test_assertions_hold_with_our_vis_and_rays_find_no_miss() {
    let Some(maps) = testmaps() else { return };
    let spec: Value =
        serde_json::from_slice(&std::fs::read(maps.join("assertions.json")).expect("read")).expect("JSON");
    let (mut checked, mut validated) = (0, 0);
    for (name, m) in spec["maps"].as_object().expect("maps") {
        let quake2 = match m["game"].as_str() {
            Some("quake") => false,
            Some("quake2") => true,
            other => panic!("{name}: unknown game {other:?}"),
        };
        // The ambient test needs texture names; the stand-in compile has them (see the README).
        let standin = format!("{name}.standin");
        let stem = if m.get("ambient").is_some() && maps.join(format!("{standin}.bsp")).is_file() {
            standin.as_str()
        } else {
            name.as_str()
        };
        let dir = temp_dir(name);
        copy_map(&maps, &dir, stem);
        vis_like_ericw(&dir, stem);
        let bsp_path = dir.join(format!("{stem}.bsp"));
        let bytes = std::fs::read(&bsp_path).expect("read vised .bsp");
        let failed = if quake2 {
            check_q2(m, &load::load_bytes(&bytes).expect("vised Quake 2 .bsp loads"))
        } else {
            check_q1(m, &spec["contents_codes"]["q1"], &bsp::read(&bytes).expect("vised .bsp reads"))
        };
        assert!(failed.is_empty(), "{stem} ({}): {failed:?}", m["test"]);
        let source = std::fs::read(maps.join(format!("{name}.map"))).unwrap_or_default();
        if source.windows(27).any(|w| w == b"func_illusionary_visblocker") {
            eprintln!("{name}: has a vis blocker; assertions only, no ray validation");
            let _ = std::fs::remove_dir_all(&dir);
            checked += 1;
            continue;
        }
        let v = bin()
            .args(["validate", bsp_path.to_str().expect("UTF-8 path"), "--rays", "200000", "--json"])
            .output()
            .expect("runs");
        assert_eq!(v.status.code(), Some(0), "validate {stem}: {}", String::from_utf8_lossy(&v.stderr));
        let report: Value = serde_json::from_slice(&v.stdout).expect("validate --json");
        let oracles = report["oracles"].as_array().expect("oracles");
        assert!(!oracles.is_empty(), "{stem}: no oracle ran");
        for o in oracles {
            let misses = o["misses"].as_array().expect("misses").len();
            assert_eq!(misses, 0, "{stem}: the {} oracle found misses: {o}", o["oracle"]);
        }
        checked += 1;
        validated += 1;
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(
        checked >= 3 && validated >= 1,
        "only {checked} Quake 1 test maps checked, {validated} ray-validated"
    );
}
