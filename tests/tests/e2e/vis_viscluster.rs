//! `sightline vis` on a Quake 1 `.bsp` honours a `func_viscluster` of its entity text (`"model"
//! "*N"`): on dm1 with one added naming model 1, whose stored box is widened over half the
//! world, the leaves whose bounds' centre lies in that box (computed here) share one PVS row,
//! which holds what each of them saw before, every other row only grows, and vis says how many
//! leaves it merged.

use std::path::{Path, PathBuf};
use std::process::Command;

use sightline_formats::bsp::{self, Bsp, lump};

/// `bytes` with `extra` appended to its entity text (the lump moved to the end of the file).
fn with_entities(bytes: &[u8], b: &Bsp, extra: &str) -> Vec<u8> {
    let text = format!("{}{extra}", b.entities.trim_end_matches('\0'));
    let mut out = bytes.to_vec();
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
    let offset = out.len();
    out.extend_from_slice(text.as_bytes());
    out.push(0);
    let dir = 4 + 8 * lump::ENTITIES;
    out[dir..dir + 4].copy_from_slice(&(offset as i32).to_le_bytes());
    out[dir + 4..dir + 8].copy_from_slice(&((text.len() + 1) as i32).to_le_bytes());
    out
}

/// Vis on a copy of `bytes` named `name` (with `prt` beside): the vised rows and stderr.
fn vis(dir: &Path, name: &str, bytes: &[u8], prt: &Path) -> (Vec<Vec<u8>>, String) {
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
    let b = bsp::read(&std::fs::read(&path).expect("read")).expect("vised file reads");
    ((1..=b.visleafs()).map(|l| b.decode_leaf_pvs(l).expect("row")).collect(), stderr)
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
    let (before, _) = vis(&dir, "plain", &plain, &prt);
    let mut rows: Vec<&Vec<u8>> = merged.iter().map(|&l| &before[l]).collect();
    rows.sort();
    rows.dedup();
    assert!(rows.len() >= 2, "the box's leaves saw alike before");
    let extra = "{\n\"classname\" \"func_viscluster\"\n\"model\" \"*1\"\n}\n";
    let (after, stderr) = vis(&dir, "merged", &with_entities(&plain, &b, extra), &prt);
    assert!(
        stderr.contains(&format!("func_viscluster 1 (by entity order) merged {} vis leaves", merged.len())),
        "{stderr}"
    );
    assert_eq!(before.len(), after.len());
    let covers = |a: &[u8], b: &[u8]| a.iter().zip(b).all(|(x, y)| x & y == *y);
    for (l, (a, o)) in after.iter().zip(&before).enumerate() {
        assert!(covers(a, o), "leaf {l} lost sight of a leaf");
    }
    for &l in &merged {
        assert_eq!(after[l], after[merged[0]], "merged leaves share one row");
    }
    let _ = std::fs::remove_dir_all(PathBuf::from(&dir));
}
