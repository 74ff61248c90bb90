//! `sightline vis` on a Quake 1 `.bsp` honours a `func_viscluster` of its entity text (`"model"
//! "*N"`): on dm1 with one added naming model 1, whose stored box is widened over half the
//! world, the leaves whose bounds' centre lies in that box (computed here) share one PVS row,
//! which holds what each of them saw before, every other row only grows, and vis says how many
//! leaves it merged. The same on a Quake 2 file (e1m1) and a Quake 3 one (dm17ish), whose portal
//! files are over clusters: the clusters with a leaf centre in the box share one row.

use std::path::{Path, PathBuf};
use std::process::Command;

use sightline_formats::bsp::{self, CompiledMap, lump, q2};

/// `bytes` with `extra` appended to the entity text `text`, the lump moved to the end of the file
/// and its directory entry (at byte `dir`: offset, then length) rewritten.
fn with_entities(bytes: &[u8], dir: usize, text: &str, extra: &str) -> Vec<u8> {
    let text = format!("{}{extra}", text.trim_end_matches('\0'));
    let mut out = bytes.to_vec();
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
    let offset = out.len();
    out.extend_from_slice(text.as_bytes());
    out.push(0);
    out[dir..dir + 4].copy_from_slice(&(offset as i32).to_le_bytes());
    out[dir + 4..dir + 8].copy_from_slice(&((text.len() + 1) as i32).to_le_bytes());
    out
}

/// The entity this test adds: a `func_viscluster` naming model 1.
const VISCLUSTER: &str = "{\n\"classname\" \"func_viscluster\"\n\"model\" \"*1\"\n}\n";

/// Vis on a copy of `bytes` named `name` (with `prt` beside): the vised rows (`rows` reads them
/// from the file) and stderr.
fn vis(
    dir: &Path,
    name: &str,
    bytes: &[u8],
    prt: &Path,
    rows: fn(&[u8]) -> Vec<Vec<u8>>,
) -> (Vec<Vec<u8>>, String) {
    let path = dir.join(format!("{name}.bsp"));
    std::fs::write(&path, bytes).expect("write");
    std::fs::copy(prt, dir.join(format!("{name}.prt"))).expect("copy the portal file");
    let out = Command::new(sightline_tests::sightline_binary())
        .args(["vis", "--threads", "2"])
        .arg(&path)
        .output()
        .expect("run sightline");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    (rows(&std::fs::read(&path).expect("read")), stderr)
}

/// Every vis leaf's row of a vised Quake 1 file.
fn q1_rows(bytes: &[u8]) -> Vec<Vec<u8>> {
    let b = bsp::read(bytes).expect("vised file reads");
    (1..=b.visleafs()).map(|l| b.decode_leaf_pvs(l).expect("row")).collect()
}

/// `merged` (rows of the portal file, vis leaves or clusters) saw alike before, share one row
/// after, which covers what each saw; every other row only grows.
fn assert_merged(what: &str, before: &[Vec<u8>], after: &[Vec<u8>], merged: &[usize]) {
    let mut rows: Vec<&Vec<u8>> = merged.iter().map(|&r| &before[r]).collect();
    rows.sort();
    rows.dedup();
    assert!(rows.len() >= 2, "{what}: the box's rows differed before");
    assert_eq!(before.len(), after.len());
    let covers = |a: &[u8], b: &[u8]| a.iter().zip(b).all(|(x, y)| x & y == *y);
    for (r, (a, o)) in after.iter().zip(before).enumerate() {
        assert!(covers(a, o), "{what}: row {r} lost sight of a row");
    }
    for &r in merged {
        assert_eq!(after[r], after[merged[0]], "{what}: merged rows share one row");
    }
}

fn centre(mins: [f32; 3], maxs: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|k| (mins[k] as f64 + maxs[k] as f64) / 2.0)
}

#[test]
fn a_func_viscluster_in_a_quake_bsp_merges_the_leaves_in_its_model_box() {
    let (Some(bsp_path), Some(prt)) =
        (sightline_tests::shared_map("ericw/dm1.bsp"), sightline_tests::shared_map("ericw/dm1.prt"))
    else {
        return;
    };
    let original = std::fs::read(&bsp_path).expect("read");
    let o = bsp::read(&original).expect("reads");
    // Model 1's stored box widened over the world's −x half (a file as valid as before).
    let (wmin, wmax) = (o.models[0].mins, o.models[0].maxs);
    let boxed = [wmin, [(wmin[0] + wmax[0]) / 2.0, wmax[1], wmax[2]]];
    let mut plain = original.clone();
    let at = o.lumps[lump::MODELS].offset + 64;
    for (k, v) in boxed.iter().flatten().enumerate() {
        plain[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let b = bsp::read(&plain).expect("reads");
    let model = &b.models[1];
    let merged: Vec<usize> = (1..=b.visleafs())
        .filter(|&l| {
            let c = centre(b.leaves[l].mins, b.leaves[l].maxs);
            (0..3).all(|k| model.mins[k] as f64 <= c[k] && c[k] <= model.maxs[k] as f64)
        })
        .map(|l| l - 1)
        .collect();
    let dir = std::env::temp_dir().join(format!("sightline-vis-viscluster-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (before, _) = vis(&dir, "plain", &plain, &prt, q1_rows);
    let with = with_entities(&plain, 4 + 8 * lump::ENTITIES, &b.entities, VISCLUSTER);
    let (after, stderr) = vis(&dir, "merged", &with, &prt, q1_rows);
    assert!(
        stderr.contains(&format!("func_viscluster 1 (by entity order) merged {} vis leaves", merged.len())),
        "{stderr}"
    );
    assert_merged("dm1", &before, &after, &merged);
    let _ = std::fs::remove_dir_all(PathBuf::from(&dir));
}

/// An `IBSP` file's lump `index` (Quake 2 and 3 share the header layout), as (offset, length).
fn ibsp_lump(bytes: &[u8], index: usize) -> (usize, usize) {
    let at = 8 + 8 * index;
    let word = |k: usize| i32::from_le_bytes(bytes[k..k + 4].try_into().expect("4 bytes")) as usize;
    (word(at), word(at + 4))
}

/// Every cluster's PVS row of a vised Quake 2 file.
fn q2_rows(bytes: &[u8]) -> Vec<Vec<u8>> {
    let b = q2::read(bytes).expect("vised file reads");
    let v = b.vis.as_ref().expect("a visibility lump");
    let all = v.decode_all(q2::Q2Row::Pvs).expect("rows");
    all.chunks(v.row_bytes().max(1)).take(v.num_clusters).map(<[u8]>::to_vec).collect()
}

/// Every cluster's PVS row of a vised Quake 3 file (lump 16: cluster count, row bytes, rows).
fn q3_rows(bytes: &[u8]) -> Vec<Vec<u8>> {
    let (at, _) = ibsp_lump(bytes, 16);
    let word = |k: usize| i32::from_le_bytes(bytes[k..k + 4].try_into().expect("4 bytes")) as usize;
    let (n, row) = (word(at), word(at + 4));
    (0..n).map(|c| bytes[at + 8 + c * row..at + 8 + (c + 1) * row].to_vec()).collect()
}

/// A Quake 2 or 3 game as this test edits it: its models lump and record size, how to read the
/// vised rows.
struct Ibsp {
    models_lump: usize,
    model_bytes: usize,
    rows: fn(&[u8]) -> Vec<Vec<u8>>,
}

/// On the shared map `name` (`.bsp` and `.prt`) of an `IBSP` game: widen model 1's stored box
/// over the world's −x half, vis it, add a `func_viscluster` naming model 1, vis again: the
/// clusters with a leaf centre in the box share one row after, which covers what each saw, and
/// every other row only grows.
fn merges_clusters_in_model_box(name: &str, game: Ibsp) {
    let (Some(bsp_path), Some(prt)) = (
        sightline_tests::shared_map(&format!("{name}.bsp")),
        sightline_tests::shared_map(&format!("{name}.prt")),
    ) else {
        return;
    };
    let original = std::fs::read(&bsp_path).expect("read");
    let (models, _) = ibsp_lump(&original, game.models_lump);
    let float = |k: usize| f32::from_le_bytes(original[k..k + 4].try_into().expect("4 bytes"));
    let (wmin, wmax): ([f32; 3], [f32; 3]) =
        (std::array::from_fn(|k| float(models + 4 * k)), std::array::from_fn(|k| float(models + 12 + 4 * k)));
    let boxed = [wmin, [(wmin[0] + wmax[0]) / 2.0, wmax[1], wmax[2]]];
    let mut plain = original.clone();
    for (k, v) in boxed.iter().flatten().enumerate() {
        let at = models + game.model_bytes + 4 * k;
        plain[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
    let level = CompiledMap::read(plain.clone()).expect("reads").to_level();
    let mut merged: Vec<usize> = level
        .leaves
        .iter()
        .filter(|l| {
            let c = centre(l.mins, l.maxs);
            (0..3).all(|k| boxed[0][k] as f64 <= c[k] && c[k] <= boxed[1][k] as f64)
        })
        .filter_map(|l| usize::try_from(l.cluster).ok())
        .collect();
    merged.sort_unstable();
    merged.dedup();
    let dir = std::env::temp_dir().join(format!(
        "sightline-vis-viscluster-{}-{}",
        name.replace('/', "-"),
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (before, _) = vis(&dir, "plain", &plain, &prt, game.rows);
    let (at, len) = ibsp_lump(&plain, 0);
    let text = String::from_utf8_lossy(&plain[at..at + len]).into_owned();
    let (after, stderr) = vis(&dir, "merged", &with_entities(&plain, 8, &text, VISCLUSTER), &prt, game.rows);
    assert!(
        stderr.contains(&format!("func_viscluster 1 (by entity order) merged {} clusters", merged.len())),
        "{name}: {stderr}"
    );
    assert_merged(name, &before, &after, &merged);
    let _ = std::fs::remove_dir_all(PathBuf::from(&dir));
}

#[test]
fn a_func_viscluster_in_a_quake2_bsp_merges_the_clusters_in_its_model_box() {
    merges_clusters_in_model_box("q2/e1m1", Ibsp { models_lump: 13, model_bytes: 48, rows: q2_rows });
}

#[test]
fn a_func_viscluster_in_a_quake3_bsp_merges_the_clusters_in_its_model_box() {
    merges_clusters_in_model_box("q3/dm17ish", Ibsp { models_lump: 7, model_bytes: 40, rows: q3_rows });
}
