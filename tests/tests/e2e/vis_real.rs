//! Vis on real portal files: identical output for any thread count, resume after an interrupt
//! gives the uninterrupted result, the drop-in `.bsp` writer produces a file our reader loads
//! whose rows are our PVS with every other lump unchanged, the PVS is no looser than the
//! reference's, and ray sampling finds no visible pair it misses.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use glam::DVec3;
use sightline_job::rng::SplitMix64;

use sightline_compiler::dropin::{self, DropInOptions};
use sightline_compiler::vis::{self, VisError, VisOptions, VisResult};
use sightline_formats::bsp::{self, lump};
use sightline_formats::prt::{self, PortalFile};
use sightline_job::cancel::Cancel;
use sightline_job::progress::Progress;
use sightline_validate::pvs::level_pvs;
use sightline_validate::{NoProgress, Options, OracleChoice, load, validate};

/// The drop-in vis of the `.bsp` at `path` (its `.prt` beside it) with these vis options, written
/// back into it.
fn drop_in(path: &Path, vis: VisOptions) {
    let opts = DropInOptions { vis, ..DropInOptions::default() };
    dropin::run(path, &opts, &NoProgress, Instant::now())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

fn ericw(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(&format!("ericw/{name}"))
}

fn portal_file(name: &str) -> Option<PortalFile> {
    let path = ericw(name)?;
    let text = std::fs::read_to_string(&path).expect("read .prt");
    Some(prt::read(&text, name).expect("parse .prt"))
}

/// Every leaf's uncompressed row, back to back.
fn leaf_rows(r: &VisResult) -> Vec<u8> {
    let mut all = Vec::new();
    let mut row = Vec::new();
    for leaf in 0..r.num_leaves() {
        r.leaf_row_bytes(leaf, &mut row);
        all.extend_from_slice(&row);
    }
    all
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-vis-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

#[test]
fn same_pvs_for_1_2_and_8_threads() {
    let Some(prt) = portal_file("dm1.prt") else { return };
    for fast in [false, true] {
        let runs: Vec<Vec<u8>> = [1, 2, 8]
            .iter()
            .map(|&threads| {
                leaf_rows(
                    &vis::run(&prt, &VisOptions { threads, fast, ..VisOptions::default() }, &NoProgress)
                        .unwrap(),
                )
            })
            .collect();
        assert!(runs.iter().all(|r| *r == runs[0]), "fast={fast}: rows differ between thread counts");
        assert!(runs[0].iter().any(|&b| b != 0));
    }
}

/// Visible (leaf, leaf) pairs of a result.
fn pairs(r: &VisResult) -> u64 {
    leaf_rows(r).iter().map(|b| u64::from(b.count_ones())).sum()
}

#[test]
fn certified_seeds_save_work_and_keep_every_pair() {
    // Seeds are clusters known visible, so a seeded run keeps every pair of an unseeded one; it
    // may keep a few more (the beam cull depends on the order clusters are found in) and must
    // visit fewer chains.
    for name in ["dm1.prt", "lq_e0m1.prt", "e1m1.prt"] {
        let Some(prt) = portal_file(name) else { return };
        let run =
            |seeds| vis::run(&prt, &VisOptions { threads: 2, seeds, ..VisOptions::default() }, &NoProgress);
        let (with, without) = (run(true).unwrap(), run(false).unwrap());
        assert!(with.stats.chains < without.stats.chains, "{name}: seeds saved no work");
        let (rw, ro) = (leaf_rows(&with), leaf_rows(&without));
        assert!(rw.iter().zip(&ro).all(|(w, o)| w & o == *o), "{name}: a seeded run lost a pair");
        let (pw, po) = (pairs(&with), pairs(&without));
        assert!(pw as f64 <= po as f64 * 1.001, "{name}: seeds added {} pairs to {po}", pw - po);
        eprintln!("{name}: chains {} -> {}, pairs {po} -> {pw}", without.stats.chains, with.stats.chains);
    }
}

#[test]
fn resumed_run_equals_uninterrupted_run() {
    let Some(prt) = portal_file("dm1.prt") else { return };
    let dir = temp_dir("resume");
    let state = dir.join("dm1.state");
    let whole = vis::run(&prt, &VisOptions { threads: 2, ..VisOptions::default() }, &NoProgress).unwrap();
    let opts =
        VisOptions { threads: 2, state: Some(state.clone()), stop_after: Some(700), ..VisOptions::default() };
    match vis::run(&prt, &opts, &NoProgress) {
        Err(VisError::Interrupted { done, total }) => assert!(done >= 700 && done < total),
        other => panic!("expected an interruption, got {other:?}"),
    }
    assert!(state.is_file());
    // Another input refuses the state.
    let mut other = prt.clone();
    other.portals.pop();
    assert!(matches!(
        vis::run(&other, &VisOptions { stop_after: None, ..opts.clone() }, &NoProgress),
        Err(VisError::State(_))
    ));
    let resumed = vis::run(&prt, &VisOptions { stop_after: None, ..opts }, &NoProgress).unwrap();
    assert!(resumed.stats.resumed_portals >= 700);
    assert_eq!(leaf_rows(&resumed), leaf_rows(&whole));
    assert_eq!(resumed.stats.chains, whole.stats.chains, "work is counted across the resume");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn cancelled_run_saves_its_state_and_resumes_to_the_same_pvs() {
    // What Ctrl-C does to `sightline vis --state`: the flag turns on mid-flow.
    let Some(prt) = portal_file("dm1.prt") else { return };
    let dir = temp_dir("cancel");
    let state = dir.join("dm1.state");
    let whole = vis::run(&prt, &VisOptions { threads: 2, ..VisOptions::default() }, &NoProgress).unwrap();
    let cancel = Cancel::new();
    let opts = VisOptions {
        threads: 2,
        state: Some(state.clone()),
        cancel: cancel.clone(),
        ..VisOptions::default()
    };
    /// Cancels once 500 flows are done, as a Ctrl-C handler would.
    struct CancelAt500 {
        cancel: Cancel,
        flow: AtomicBool,
        done: AtomicUsize,
    }
    impl Progress for CancelAt500 {
        fn begin(&self, phase: &str, _: u64) {
            self.flow.store(phase == "vis flow", Ordering::Relaxed);
        }
        fn advance(&self, n: u64) {
            let done = self.done.fetch_add(n as usize, Ordering::Relaxed) + n as usize;
            if self.flow.load(Ordering::Relaxed) && done >= 500 {
                self.cancel.cancel();
            }
        }
        fn end(&self) {
            self.done.store(0, Ordering::Relaxed);
        }
    }
    let on_progress = CancelAt500 { cancel, flow: AtomicBool::new(false), done: AtomicUsize::new(0) };
    match vis::run(&prt, &opts, &on_progress) {
        Err(VisError::Interrupted { done, total }) => {
            assert!(done >= 500 && done < total, "{done} of {total}")
        }
        other => panic!("expected an interruption, got {other:?}"),
    }
    assert!(state.is_file());
    let resumed = vis::run(&prt, &VisOptions { cancel: Cancel::new(), ..opts }, &NoProgress).unwrap();
    assert!(resumed.stats.resumed_portals >= 500);
    assert_eq!(leaf_rows(&resumed), leaf_rows(&whole));
    assert!(!state.exists(), "a finished run removes its state");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pvs_is_no_looser_than_the_reference_on_every_shared_map() {
    // The reference's `.vis.bsp` rows against ours, leaf pair by leaf pair counted.
    let names = [
        "dm1",
        "dm2",
        "dm3",
        "start",
        "e1m1",
        "e1m2",
        "e1m3",
        "lqdm1",
        "lq_e0m1",
        "lq_e1m1",
        "dm2_nodetail",
        "e1m1_nodetail",
    ];
    let mut checked = 0;
    for name in names {
        let (Some(prt), Some(reference)) =
            (portal_file(&format!("{name}.prt")), ericw(&format!("{name}.vis.bsp")))
        else {
            continue;
        };
        let ours = vis::run(&prt, &VisOptions { threads: 2, ..VisOptions::default() }, &NoProgress).unwrap();
        let theirs = bsp_pairs(&reference);
        let mine = ours.stats.visible_pairs;
        eprintln!(
            "{name}: visible pairs ours {mine}, reference {theirs}, ratio {:.4}",
            mine as f64 / theirs as f64
        );
        assert!(mine <= theirs, "{name}: ours {mine} > reference {theirs}");
        checked += 1;
    }
    eprintln!("{checked} maps checked");
}

#[test]
fn vis_survives_bent_and_broken_windings() {
    // Parsed but geometrically hostile portal files: corners dragged off their plane or across
    // the winding (non-convex), far away, or onto another corner. Vis must finish with a result
    // or an error, never panic, and stay deterministic.
    let Some(prt) = portal_file("lqdm1.prt") else { return };
    let mut rng = SplitMix64::new(41);
    for round in 0..24 {
        let mut bad = prt.clone();
        for _ in 0..1 + rng.below(6) {
            let line = rng.below(bad.portals.len());
            let pts = &mut bad.portals[line].winding.points;
            let k = rng.below(pts.len());
            let other = pts[rng.below(pts.len())];
            let jolt =
                DVec3::new(rng.range_f64(-1.0, 1.0), rng.range_f64(-1.0, 1.0), rng.range_f64(-1.0, 1.0));
            pts[k] = match rng.below(4) {
                0 => pts[k] + jolt * 0.5,
                1 => pts[k] + jolt * 400.0,
                2 => other,
                _ => pts[k] * 1e5,
            };
        }
        let opts = |threads| VisOptions { threads, ..VisOptions::default() };
        let one = vis::run(&bad, &opts(1), &NoProgress);
        let two = vis::run(&bad, &opts(2), &NoProgress);
        match (one, two) {
            (Ok(a), Ok(b)) => assert_eq!(leaf_rows(&a), leaf_rows(&b), "round {round}: thread counts differ"),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            (a, b) => panic!("round {round}: {:?} vs {:?}", a.is_ok(), b.is_ok()),
        }
    }
}

/// Total visible leaf pairs stored in a BSP.
fn bsp_pairs(path: &Path) -> u64 {
    let b = bsp::read(&std::fs::read(path).expect("read .bsp")).expect("parse .bsp");
    let s = b.pvs_stats().expect("decode rows").expect("vis leaves");
    (s.avg_visible * s.visleafs as f64).round() as u64
}

fn lump_bytes(file: &[u8], b: &bsp::Bsp, i: usize) -> Vec<u8> {
    let l = b.lumps[i];
    file[l.offset..l.end()].to_vec()
}

#[test]
fn drop_in_bsp_is_readable_exact_and_leaves_other_lumps_alone() {
    let (Some(src_bsp), Some(src_prt), Some(reference)) =
        (ericw("dm1.bsp"), ericw("dm1.prt"), ericw("dm1.vis.bsp"))
    else {
        return;
    };
    let dir = temp_dir("dropin");
    let (bsp_path, prt_path) = (dir.join("dm1.bsp"), dir.join("dm1.prt"));
    std::fs::copy(&src_bsp, &bsp_path).unwrap();
    std::fs::copy(&src_prt, &prt_path).unwrap();
    let original = std::fs::read(&bsp_path).unwrap();
    drop_in(&bsp_path, VisOptions { threads: 2, ..VisOptions::default() });
    let written = std::fs::read(&bsp_path).unwrap();
    let (old, new) = (bsp::read(&original).unwrap(), bsp::read(&written).unwrap());

    // Rows decode to the PVS vis computes (leaf j + 1 owns row j).
    let prt = prt::read(&std::fs::read_to_string(&prt_path).unwrap(), "dm1.prt").unwrap();
    let ours = vis::run(&prt, &VisOptions::default(), &NoProgress).unwrap();
    let mut row = Vec::new();
    for j in 0..ours.num_leaves() {
        ours.leaf_row_bytes(j, &mut row);
        assert_eq!(new.decode_leaf_pvs(j + 1).unwrap(), row, "row of leaf {}", j + 1);
    }
    // Leaves of a cluster share one row.
    let clusters = ours.leaf_clusters();
    for j in 1..ours.num_leaves() {
        if clusters[j] == clusters[j - 1] {
            assert_eq!(new.leaves[j + 1].visofs, new.leaves[j].visofs);
        }
    }
    // Every lump but visibility and leaves is byte-identical; leaves differ only in visofs/ambient.
    for i in 0..bsp::NUM_LUMPS {
        if i != lump::VISIBILITY && i != lump::LEAVES {
            assert_eq!(lump_bytes(&original, &old, i), lump_bytes(&written, &new, i), "lump {i}");
        }
    }
    assert_eq!(old.leaves.len(), new.leaves.len());
    for (a, b) in old.leaves.iter().zip(&new.leaves) {
        assert_eq!(
            (a.contents, a.mins, a.maxs, a.first_marksurface, a.num_marksurfaces),
            (b.contents, b.mins, b.maxs, b.first_marksurface, b.num_marksurfaces)
        );
        assert!(b.ambient.iter().all(|&v| v == 0 || v == 255));
    }
    // No looser than the reference compiler's PVS.
    let (mine, theirs) = (bsp_pairs(&bsp_path), bsp_pairs(&reference));
    eprintln!("dm1 visible pairs: ours {mine}, reference {theirs}, ratio {:.4}", mine as f64 / theirs as f64);
    assert!(mine <= theirs, "ours {mine} > reference {theirs}");

    // Ray sampling finds no visible pair missing from the written PVS.
    let level = load::load_level(&bsp_path, &sightline_validate::NoProgress).unwrap();
    let pvs = level_pvs(&level).unwrap();
    let opts = Options { rays: 400_000, oracle: OracleChoice::Both, ..Options::default() };
    let v = validate(&level, &pvs, &opts, &NoProgress).unwrap();
    eprint!("{}", v.report.text());
    assert_eq!(v.report.misses(), 0, "{}", v.report.text());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A coarsened vis (clusters merged to fit a memory or a work limit) is checked against sight
/// lines themselves rather than against the fine run (whose order-dependent narrowing keeps a few
/// pairs no line reaches): ray sampling with both oracles finds no visible pair it misses, and
/// it is looser than the fine PVS.
#[test]
fn coarsened_vis_hides_no_leaf_a_ray_reaches() {
    let (Some(src_bsp), Some(src_prt)) = (ericw("dm1.bsp"), ericw("dm1.prt")) else { return };
    let prt = portal_file("dm1.prt").expect("dm1.prt");
    let single = VisOptions { threads: 1, ..VisOptions::default() };
    let memory = vis::memory_estimate(&prt, &single) / 3;
    let work = vis::work_estimate(&prt, &single) / 4;
    let dir = temp_dir("coarse-rays");
    let fine_path = dir.join("fine.bsp");
    std::fs::copy(&src_bsp, &fine_path).unwrap();
    std::fs::copy(&src_prt, dir.join("fine.prt")).unwrap();
    drop_in(&fine_path, VisOptions { threads: 2, ..VisOptions::default() });
    let fine = bsp_pairs(&fine_path);
    let limits = [
        ("memory", VisOptions { max_memory: Some(memory), coarsen: true, ..VisOptions::default() }),
        ("work", VisOptions { max_work: Some(work), coarsen: true, ..VisOptions::default() }),
    ];
    for (tag, vis) in limits {
        let bsp_path = dir.join(format!("{tag}.bsp"));
        std::fs::copy(&src_bsp, &bsp_path).unwrap();
        std::fs::copy(&src_prt, dir.join(format!("{tag}.prt"))).unwrap();
        // One thread: merges are sized for one, and a second thread's rows may not fit the limit.
        drop_in(&bsp_path, VisOptions { threads: 1, ..vis });
        let coarse = bsp_pairs(&bsp_path);
        assert!(coarse > fine, "{tag}: {coarse} pairs, fine {fine}: nothing was merged");
        let level = load::load_level(&bsp_path, &sightline_validate::NoProgress).unwrap();
        let pvs = level_pvs(&level).unwrap();
        let opts = Options { rays: 400_000, oracle: OracleChoice::Both, ..Options::default() };
        let v = validate(&level, &pvs, &opts, &NoProgress).unwrap();
        assert_eq!(v.report.misses(), 0, "{tag}: {}", v.report.text());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
