//! Files other tools write and engines load, with stored bounds no code may use as they are and
//! without clip hulls, are taken: ericw-tools' qbsp has written `±inf` bounds on the world model,
//! nodes and a leaf of a BSP2, and `qbsp -noclip` writes no clipnodes (every clip hull root 0).
//! A real BSP29 and its BSP2 re-encoding are spoiled that way (inverted integer boxes for BSP29,
//! `±inf` and NaN for BSP2); `vis`, `validate`, `info` and the runtime take them, vis writes the
//! PVS it writes for the unspoiled file, and each use of a repaired box is said as a warning.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

use sightline_formats::bsp::{self, Bsp, BspVersion, CompiledMap, lump};
use sightline_job::progress::Progress;

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-unusable-bounds-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// `sightline ARGS`, with its exit code checked.
fn run(args: &[&str], path: &Path, code: i32) -> Output {
    let out = Command::new(sightline_tests::sightline_binary())
        .args(args)
        .arg(path)
        .output()
        .expect("run sightline");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "sightline {args:?} {}: {stderr}", path.display());
    out
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Where record `i` of lump `which` (records of `size` bytes) starts.
fn at(b: &Bsp, which: usize, size: usize, i: usize) -> usize {
    b.lumps[which].offset + i * size
}

fn put_f32(bytes: &mut [u8], at: usize, v: [f32; 3]) {
    for (k, c) in v.iter().enumerate() {
        bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&c.to_le_bytes());
    }
}

fn put_i16(bytes: &mut [u8], at: usize, v: [i16; 3]) {
    for (k, c) in v.iter().enumerate() {
        bytes[at + 2 * k..at + 2 * k + 2].copy_from_slice(&c.to_le_bytes());
    }
}

/// What [`spoil`] changed.
struct Spoiled {
    bytes: Vec<u8>,
    nodes: Vec<usize>,
    /// An open vis leaf.
    leaf: usize,
}

/// `bytes` (read as `b`, BSP29 or BSP2) with unusable bounds on the world model, 15 nodes, the
/// solid leaf 0 and an open vis leaf (`±inf` and NaN where the records hold floats, inverted boxes
/// where they hold integers), and without clip hulls: the clipnodes lump empty, every model's
/// clip hull roots 0.
fn spoil(bytes: &[u8], b: &Bsp) -> Spoiled {
    let mut out = bytes.to_vec();
    let (inf, nan) = (f32::INFINITY, f32::NAN);
    let model = at(b, lump::MODELS, 64, 0);
    put_f32(&mut out, model, [inf, inf, nan]);
    put_f32(&mut out, model + 12, [-inf; 3]);
    let wide = b.version == BspVersion::Bsp2;
    let spoil_box = |out: &mut Vec<u8>, mins_at: usize, k: usize| {
        if wide {
            let (mins, maxs) =
                [([inf; 3], [-inf; 3]), ([nan; 3], [1.0; 3]), ([-inf; 3], [inf, nan, inf])][k % 3];
            put_f32(out, mins_at, mins);
            put_f32(out, mins_at + 12, maxs);
        } else {
            put_i16(out, mins_at, [i16::MAX; 3]);
            put_i16(out, mins_at + 6, [i16::MIN; 3]);
        }
    };
    let (node_size, leaf_size) = (b.version.node_bytes(), b.version.leaf_bytes());
    // Node children and leaf contents sit before the bounds: 4 + 2 * child size, and 8.
    let node_bounds = if wide { 12 } else { 8 };
    let nodes: Vec<usize> = (0..15).map(|k| k * (b.nodes.len() / 15)).collect();
    for (k, &n) in nodes.iter().enumerate() {
        spoil_box(&mut out, at(b, lump::NODES, node_size, n) + node_bounds, k);
    }
    let leaf = (1..=b.visleafs()).find(|&l| b.leaves[l].contents != -2).expect("an open vis leaf");
    spoil_box(&mut out, at(b, lump::LEAVES, leaf_size, leaf) + 8, 0);
    spoil_box(&mut out, at(b, lump::LEAVES, leaf_size, 0) + 8, 1);
    // No clip hulls.
    let entry = 4 + 8 * lump::CLIPNODES + 4;
    out[entry..entry + 4].copy_from_slice(&0i32.to_le_bytes());
    for m in 0..b.models.len() {
        let heads = at(b, lump::MODELS, 64, m) + 36;
        out[heads + 4..heads + 16].fill(0);
    }
    Spoiled { bytes: out, nodes, leaf }
}

/// Warnings given to a [`Progress`].
#[derive(Default)]
struct Warnings(Mutex<Vec<String>>);

impl Progress for Warnings {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
    fn warn(&self, message: &str) {
        self.0.lock().expect("lock").push(message.to_string());
    }
}

/// The decoded PVS row and ambient levels of every vis leaf of the file at `path`.
fn rows(path: &Path) -> Vec<(Vec<u8>, [u8; 4])> {
    let b = bsp::read(&std::fs::read(path).expect("read")).expect("vised file reads");
    (1..=b.visleafs()).map(|l| (b.decode_leaf_pvs(l).expect("row"), b.leaves[l].ambient)).collect()
}

/// Runs vis with `flags` on a copy of `bytes` (and dm1's portal file) named `name` in `dir`;
/// returns the copy's path and what vis printed on stderr.
fn vis(dir: &Path, name: &str, bytes: &[u8], prt: &Path, flags: &[&str]) -> (PathBuf, String) {
    let path = dir.join(format!("{name}.bsp"));
    std::fs::write(&path, bytes).expect("write");
    std::fs::copy(prt, dir.join(format!("{name}.prt"))).expect("copy the portal file");
    let mut args = vec!["vis", "--no-progress", "--threads", "2"];
    args.extend_from_slice(flags);
    let out = run(&args, &path, 0);
    (path, stderr(&out))
}

fn check(version: BspVersion, original: &[u8], prt: &Path) {
    let b = bsp::read(original).expect("reads");
    assert_eq!(b.version, version);
    let spoiled = spoil(original, &b);
    let name = version.name();
    let dir = temp_dir(name);

    // The readers take it; the stored values stay as they are.
    let s = bsp::read(&spoiled.bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(s.num_clipnodes, 0);
    assert!(!bsp::bounds::usable(s.models[0].mins, s.models[0].maxs));
    assert!(spoiled.nodes.iter().all(|&n| !bsp::bounds::usable(s.nodes[n].mins, s.nodes[n].maxs)));
    assert!(!bsp::bounds::usable(s.leaves[spoiled.leaf].mins, s.leaves[spoiled.leaf].maxs));

    // The level repairs every box, conservatively, and says which used ones it repaired.
    let map = CompiledMap::read(spoiled.bytes.clone()).expect("reads");
    let (level, repairs) = map.to_level_with_repairs();
    sightline_formats::slvl::validate(&level).unwrap_or_else(|e| panic!("{name}: {e}"));
    let said: Vec<(&str, Vec<u32>)> = repairs.iter().map(|r| (r.record, r.indices.clone())).collect();
    assert_eq!(said, [("leaf", vec![spoiled.leaf as u32]), ("model", vec![0])], "{name}");
    let clean = bsp::to_level(&b);
    let holds = |outer: ([f32; 3], [f32; 3]), inner: ([f32; 3], [f32; 3])| {
        (0..3).all(|k| outer.0[k] <= inner.0[k] && inner.1[k] <= outer.1[k])
    };
    let leaf = |l: &sightline_formats::Leaf| (l.mins, l.maxs);
    assert!(holds(leaf(&level.leaves[spoiled.leaf]), leaf(&clean.leaves[spoiled.leaf])), "{name}");
    // The world's box, recomputed from its faces, holds every corner of them.
    let world_model = level.models[0];
    let w = world_model;
    let corners = level.faces[w.first_face as usize..(w.first_face + w.num_faces) as usize]
        .iter()
        .flat_map(|f| &level.vertices[f.first_vertex as usize..(f.first_vertex + f.num_vertices) as usize]);
    assert!(corners.into_iter().all(|&v| holds((w.mins, w.maxs), (v, v))), "{name}");
    assert_eq!(level.leaves[spoiled.leaf + 1], clean.leaves[spoiled.leaf + 1], "usable boxes are kept");

    // The runtime loads it and warns, naming the file, about the boxes it uses.
    let path = dir.join("spoiled.bsp");
    std::fs::write(&path, &spoiled.bytes).expect("write");
    let warnings = Warnings::default();
    let world = sightline_runtime::load::load_path_with(&path, &warnings).expect("the runtime loads it");
    let warnings = warnings.0.into_inner().expect("lock");
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings.iter().all(|w| w.starts_with(&path.display().to_string())), "{warnings:?}");
    let culled = world.leaf_bounds(spoiled.leaf as u32).expect("leaf");
    let clean_leaf = &clean.leaves[spoiled.leaf];
    assert!(holds((culled.mins().to_array(), culled.maxs().to_array()), (clean_leaf.mins, clean_leaf.maxs)));

    // `info` reads it, prints the world bounds recomputed from the faces, and says so.
    let out = run(&["info", "--json"], &path, 0);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(report["bounds"]["mins"], serde_json::json!(world_model.mins.map(f64::from)));
    assert_eq!(report["bounds"]["maxs"], serde_json::json!(world_model.maxs.map(f64::from)));
    let err = stderr(&out);
    assert!(err.contains("warning:") && err.contains("model 0: bounds not finite or inverted"), "{err}");
    assert!(err.contains(&format!("leaf {}: bounds", spoiled.leaf)), "{err}");

    // vis uses no bounds: no warning, and the PVS and ambient levels of the unspoiled file.
    let (vised, err) = vis(&dir, "spoiled", &spoiled.bytes, prt, &[]);
    assert!(!err.contains("warning"), "{err}");
    let (clean_vised, _) = vis(&dir, "clean", original, prt, &[]);
    assert_eq!(rows(&vised), rows(&clean_vised), "{name}: the PVS of the unspoiled file");
    // So do the portals rebuilt from the tree (their box holds every vertex).
    let (rebuilt, _) = vis(&dir, "spoiled-tree", &spoiled.bytes, prt, &["--portals-from-bsp"]);
    let (clean_rebuilt, _) = vis(&dir, "clean-tree", original, prt, &["--portals-from-bsp"]);
    assert_eq!(rows(&rebuilt), rows(&clean_rebuilt), "{name}: the PVS of the unspoiled file");
    // The far plane uses leaf boxes: the spoiled leaf's cluster is not culled, which is said,
    // and nothing the unspoiled file's far plane keeps is hidden.
    let (far, err) = vis(&dir, "spoiled-far", &spoiled.bytes, prt, &["--farplane", "600"]);
    assert!(err.contains(&format!("warning: {}", far.display())), "{err}");
    assert!(err.contains(&format!("leaf {}: bounds not finite or inverted", spoiled.leaf)), "{err}");
    let (clean_far, _) = vis(&dir, "clean-far", original, prt, &["--farplane", "600"]);
    let (far, clean_far) = (rows(&far), rows(&clean_far));
    assert_ne!(clean_far, rows(&clean_vised), "the far plane hides something");
    for ((row, _), (clean_row, _)) in far.iter().zip(&clean_far) {
        assert!(row.iter().zip(clean_row).all(|(a, c)| a & c == *c), "{name}: a pair hidden");
    }

    // `validate` samples the vised file and finds no miss; it too warns about the leaf it samples.
    let out = run(&["validate", "--rays", "100000"], &vised, 0);
    let err = stderr(&out);
    assert!(err.contains(&format!("leaf {}: bounds not finite or inverted", spoiled.leaf)), "{err}");

    // What cannot be used is still refused: a node child out of range, and with clipnodes
    // present a clip hull root past them.
    let mut bad = spoiled.bytes.clone();
    let child = at(&b, lump::NODES, b.version.node_bytes(), 0) + 4;
    if version == BspVersion::Bsp2 {
        bad[child..child + 4].copy_from_slice(&(b.nodes.len() as i32 + 5).to_le_bytes());
    } else {
        bad[child..child + 2].copy_from_slice(&(b.nodes.len() as u16 + 5).to_le_bytes());
    }
    let e = bsp::read(&bad).expect_err("a child out of range");
    assert!(e.to_string().contains("node 0: bad child"), "{e}");
    let mut bad = original.to_vec();
    let heads = at(&b, lump::MODELS, 64, 0) + 36;
    bad[heads + 4..heads + 8].copy_from_slice(&(b.num_clipnodes as i32).to_le_bytes());
    let e = bsp::read(&bad).expect_err("a clip hull root out of range");
    assert!(e.to_string().contains("clip hull root"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unusable_bounds_and_missing_clip_hulls_are_taken_by_every_reader() {
    let (Some(bsp_path), Some(prt)) =
        (sightline_tests::shared_map("ericw/dm1.bsp"), sightline_tests::shared_map("ericw/dm1.prt"))
    else {
        return;
    };
    let bytes = std::fs::read(&bsp_path).expect("read");
    check(BspVersion::Bsp29, &bytes, &prt);
    let b = bsp::read(&bytes).expect("reads");
    check(BspVersion::Bsp2, &sightline_tests::widen_bsp(&bytes, &b, false), &prt);
}
