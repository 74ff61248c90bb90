//! Quake 2 (`IBSP` 38) vis on the shared maps in `q2/`: the written file reads back with every
//! other lump unchanged, the PHS is the brute-force union of PVS rows, our PVS has no more pairs
//! than the one-thread references, and `--phs-only` repairs ericw-tools' PHS without touching a
//! PVS byte.

use std::path::{Path, PathBuf};
use std::time::Instant;

use sightline_compiler::dropin::{self, DropInOptions};
use sightline_compiler::vis::VisOptions;
use sightline_formats::bsp::q2::{self, Q2Bsp, Q2Row};
use sightline_job::progress::NoProgress;

fn q2_map(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(&format!("q2/{name}"))
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-vis-q2-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The drop-in vis of `input` with two threads (only its PHS under `phs_only`), written back into
/// it.
fn vis(input: &Path, phs_only: bool) {
    let opts = DropInOptions {
        vis: VisOptions { threads: 2, ..VisOptions::default() },
        phs_only,
        ..DropInOptions::default()
    };
    dropin::run(input, &opts, &NoProgress, Instant::now())
        .unwrap_or_else(|e| panic!("{}: {e}", input.display()));
}

/// Copies `name` (and, when given, the `.prt`) into a fresh folder as `base.bsp`, writable.
fn copy_in(dir: &Path, name: &str, prt: Option<&Path>, base: &str) -> Option<PathBuf> {
    let src = q2_map(name)?;
    let bsp = dir.join(format!("{base}.bsp"));
    std::fs::write(&bsp, std::fs::read(src).expect("read shared .bsp")).expect("write .bsp copy");
    if let Some(p) = prt {
        std::fs::write(dir.join(format!("{base}.prt")), std::fs::read(p).expect("read .prt"))
            .expect("write .prt copy");
    }
    Some(bsp)
}

/// The PHS by brute force over byte rows: row c ORs the PVS rows of every cluster c sees.
fn brute_phs(pvs: &[u8], n: usize) -> Vec<u8> {
    let rb = n.div_ceil(8);
    let mut out = pvs.to_vec();
    for c in 0..n {
        for j in 0..n {
            if pvs[c * rb + j / 8] & (1 << (j % 8)) != 0 {
                for k in 0..rb {
                    out[c * rb + k] |= pvs[j * rb + k];
                }
            }
        }
    }
    out
}

fn pairs(rows: &[u8]) -> u32 {
    rows.iter().map(|b| b.count_ones()).sum()
}

/// Checks PHS rows against the brute force; returns the decoded PVS.
fn check_phs(file: &Q2Bsp, what: &str) -> Vec<u8> {
    let vis = file.vis.as_ref().expect("visibility lump");
    let n = vis.num_clusters;
    let pvs = vis.decode_all(Q2Row::Pvs).expect("PVS rows");
    let phs = vis.decode_all(Q2Row::Phs).expect("PHS rows");
    let brute = brute_phs(&pvs, n);
    let rb = vis.row_bytes().max(1);
    for (c, (a, b)) in phs.chunks(rb).zip(brute.chunks(rb)).enumerate() {
        assert_eq!(a, b, "{what}: PHS row of cluster {c}");
    }
    pvs
}

/// Every lump but visibility, by content.
fn other_lumps(bytes: &[u8], file: &Q2Bsp) -> Vec<Vec<u8>> {
    (0..q2::NUM_LUMPS)
        .filter(|&i| i != q2::lump::VISIBILITY)
        .map(|i| bytes[file.lumps[i].offset..file.lumps[i].end()].to_vec())
        .collect()
}

#[test]
fn q2_vis_writes_pvs_and_true_phs_no_looser_than_the_references() {
    // start and e1m1 take seconds each; dm2 and the test maps cover the same paths.
    for map in ["q2_func_illusionary_visblocker", "q2_detail_leak_test", "dm2"] {
        let (Some(prt), Some(_)) = (q2_map(&format!("{map}.prt")), q2_map(&format!("{map}.bsp"))) else {
            return;
        };
        let dir = temp_dir(map);
        let bsp = copy_in(&dir, &format!("{map}.bsp"), Some(&prt), map).unwrap();
        let original = std::fs::read(&bsp).unwrap();
        vis(&bsp, false);
        let written = std::fs::read(&bsp).unwrap();
        let (old, new) = (q2::read(&original).unwrap(), q2::read(&written).unwrap());
        assert_eq!(other_lumps(&original, &old), other_lumps(&written, &new), "{map}: other lumps");
        assert!(new.lumps.iter().all(|l| l.length == 0 || l.offset % 4 == 0), "{map}: alignment");
        let vis = new.vis.as_ref().unwrap();
        assert_eq!(vis.num_clusters, old.leaf_cluster_count());
        let pvs = check_phs(&new, map);
        for c in 0..vis.num_clusters {
            assert!(pvs[c * vis.row_bytes() + c / 8] & (1 << (c % 8)) != 0, "{map}: cluster {c} sees itself");
        }
        for reference in ["ericw.t1", "q2tools.t1"] {
            let Some(r) = q2_map(&format!("{map}.{reference}.bsp")) else { continue };
            let r = q2::read(&std::fs::read(r).unwrap()).unwrap();
            let theirs = r.vis.unwrap().decode_all(Q2Row::Pvs).unwrap();
            let (ours, theirs) = (pairs(&pvs), pairs(&theirs));
            eprintln!(
                "{map}: PVS pairs {ours}, {reference} {theirs} ({:.4})",
                f64::from(ours) / f64::from(theirs)
            );
            assert!(ours <= theirs, "{map}: {ours} PVS pairs, more than {reference}'s {theirs}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn phs_only_repairs_ericw_phs_and_keeps_every_pvs_byte() {
    let dir = temp_dir("phs-only");
    // (file, PHS rows ericw-tools got wrong on LP64), as the README of `q2/` measures them.
    let cases = [
        ("start.ericw.t1", 0),
        ("e1m1.ericw", 353),
        ("e1m1.ericw.t1", 353),
        ("dm2.ericw", 512),
        ("dm2.ericw.t1", 512),
        ("q2_detail_leak_test.ericw", 15),
        ("q2_func_illusionary_visblocker.ericw", 0),
    ];
    for (name, wrong) in cases {
        let Some(bsp) = copy_in(&dir, &format!("{name}.bsp"), None, name) else { return };
        let original = std::fs::read(&bsp).unwrap();
        let old = q2::read(&original).unwrap();
        let (fixed, report) = sightline_compiler::phs::repair_phs(&original).unwrap();
        assert_eq!(report.rows_fixed, wrong, "{name}: rows fixed");
        assert_eq!(report.bits_removed, 0, "{name}: ericw's PHS only misses bits");
        vis(&bsp, true);
        let written = std::fs::read(&bsp).unwrap();
        assert_eq!(written, fixed, "{name}: the CLI writes what the library returns");
        let new = q2::read(&written).unwrap();
        assert_eq!(other_lumps(&original, &old), other_lumps(&written, &new), "{name}: other lumps");
        let (ov, nv) = (old.vis.as_ref().unwrap(), new.vis.as_ref().unwrap());
        // Every PVS row's compressed bytes, and here (ericw writes PVS rows first, unshared) the
        // whole PVS part of the lump with its offsets, are unchanged.
        for c in 0..ov.num_clusters {
            assert_eq!(ov.compressed_row(c, Q2Row::Pvs), nv.compressed_row(c, Q2Row::Pvs), "{name}: PVS {c}");
            assert_eq!(ov.offsets[c][0], nv.offsets[c][0], "{name}: PVS offset {c}");
        }
        let pvs_end = ov.offsets.iter().map(|o| o[1]).min().unwrap_or(4) as usize;
        assert_eq!(ov.data[4..pvs_end].len(), nv.data[4..pvs_end].len());
        let strip = |d: &[u8]| -> Vec<u8> {
            // PVS rows, without the PHS offsets that sit among the header's pairs.
            d[4 + 8 * ov.num_clusters..pvs_end].to_vec()
        };
        assert_eq!(strip(&ov.data), strip(&nv.data), "{name}: PVS bytes");
        check_phs(&new, name);
        // A second repair changes nothing.
        assert_eq!(sightline_compiler::phs::repair_phs(&written).unwrap().0, written, "{name}: idempotent");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Vis and `--phs-only` take exactly the Quake 2 files the other readers take: a non-finite plane,
/// an edge naming a vertex past the vertices and a face naming edges past the surfedges are each
/// refused by vis and `--phs-only`, before anything is written, with the error every reader gives
/// (naming the file and the record's byte).
#[test]
fn vis_refuses_what_every_reader_refuses() {
    let (Some(plain), Some(vised), Some(prt)) =
        (q2_map("start.bsp"), q2_map("start.ericw.bsp"), q2_map("start.prt"))
    else {
        return;
    };
    let dir = temp_dir("refuses");
    for (name, source, phs_only) in [("plain", &plain, false), ("vised", &vised, true)] {
        let bytes = std::fs::read(source).expect("read");
        let file = q2::read(&bytes).expect("the shared file reads");
        let lump = |i: usize| file.lumps[i].offset;
        let (planes, edges, faces) = (lump(1), lump(11), lump(6));
        let vertices = file.lumps[2].length / 12;
        let surfedges = file.lumps[12].length / 4;
        let spoilers: [(&str, usize, Vec<u8>); 3] = [
            ("plane 0", planes, f32::NAN.to_le_bytes().to_vec()),
            ("edge 0", edges, (vertices as u16).to_le_bytes().to_vec()),
            ("face 0", faces + 4, (surfedges as i32).to_le_bytes().to_vec()),
        ];
        for (what, at, value) in spoilers {
            let mut bad = bytes.clone();
            bad[at..at + value.len()].copy_from_slice(&value);
            let expected =
                sightline_formats::bsp::CompiledMap::read(bad.clone()).expect_err(what).to_string();
            assert!(expected.contains(what), "{expected}");
            let path = dir.join(format!("{name}.bsp"));
            std::fs::write(&path, &bad).expect("write");
            std::fs::copy(&prt, dir.join(format!("{name}.prt"))).expect("copy .prt");
            let opts = DropInOptions { phs_only, ..DropInOptions::default() };
            let e = dropin::run(&path, &opts, &NoProgress, Instant::now()).expect_err(what);
            let chain = format!("{:#}", anyhow::Error::from(e));
            assert_eq!(chain, format!("{}: {expected}", path.display()), "{name} {what}");
            assert_eq!(std::fs::read(&path).expect("read"), bad, "{name} {what}: nothing written");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
