//! `sightline validate` on the reference compiler's vis-ed BSPs: no misses on a correct PVS, every
//! removed visible pair found, and the detection rate on clearly visible (portal-adjacent) pairs.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use glam::DVec3;
use sightline_formats::{bsp, prt, rle};
use sightline_validate::bsp::BspTree;
use sightline_validate::pvs::{BitMatrix, level_pvs};
use sightline_validate::rng::Rng;
use sightline_validate::{NoProgress, Options, OracleChoice, load, validate};

fn ericw(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(&format!("ericw/{name}"))
}

#[test]
fn reference_pvs_has_no_misses_at_the_default_budget() {
    for (name, oracle) in [("dm1.vis.bsp", OracleChoice::Both), ("e1m1.vis.bsp", OracleChoice::Both)] {
        let Some(path) = ericw(name) else { return };
        let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
        let pvs = level_pvs(&level).unwrap();
        let v = validate(&level, &pvs, &Options { oracle, ..Options::default() }, &NoProgress).unwrap();
        eprint!("{}", v.report.text());
        assert_eq!(v.report.misses(), 0, "{name}: {}", v.report.text());
        for o in &v.report.oracles {
            // The reference PVS is conservative and reasonably tight: between 1 and 3 times the
            // sampled set.
            assert!(
                o.tightness >= 1.0 && o.tightness < 3.0,
                "{name} [{}] tightness {}",
                o.oracle,
                o.tightness
            );
            let c: Vec<u64> = o.coverage.iter().map(|c| c.pairs).collect();
            assert!(c.windows(2).all(|w| w[0] <= w[1]), "coverage must grow: {c:?}");
        }
    }
}

/// `count` pairs of `pvs` that `sampled` proved, off the diagonal, chosen by `seed`.
fn proved_pairs(pvs: &BitMatrix, sampled: &BitMatrix, count: usize, seed: u64) -> Vec<(usize, usize)> {
    let n = pvs.len();
    let mut rng = Rng::for_key(seed, 0, 0);
    let mut out = BTreeSet::new();
    for _ in 0..1_000_000 {
        if out.len() == count {
            break;
        }
        let (a, b) = ((rng.next_u64() % n as u64) as usize, (rng.next_u64() % n as u64) as usize);
        if a != b && pvs.get(a, b) && sampled.get(a, b) {
            out.insert((a, b));
        }
    }
    out.into_iter().collect()
}

#[test]
fn removed_pairs_are_each_reported_with_a_segment_that_proves_them() {
    let Some(path) = ericw("dm1.vis.bsp") else { return };
    let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
    let pvs = level_pvs(&level).unwrap();
    let opts = Options { rays: 2_000_000, oracle: OracleChoice::Tree, ..Options::default() };
    let clean = validate(&level, &pvs, &opts, &NoProgress).unwrap();
    assert_eq!(clean.report.misses(), 0);
    let sampled = clean.sampled[0].last().unwrap();
    let removed = proved_pairs(&pvs, sampled, 12, 7);
    assert_eq!(removed.len(), 12);
    let mut mutated = pvs.clone();
    for &(a, b) in &removed {
        mutated.clear(a, b);
    }
    let v = validate(&level, &mutated, &opts, &NoProgress).unwrap();
    let misses = &v.report.oracles[0].misses;
    let found: Vec<(usize, usize)> =
        misses.iter().map(|m| (m.from_cluster as usize, m.to_cluster as usize)).collect();
    assert_eq!(found, removed, "exactly the removed pairs are misses");
    let tree = BspTree::new(&level).unwrap();
    for m in misses {
        let (from, to) = (DVec3::from(m.from), DVec3::from(m.to));
        assert_eq!(tree.leaf_at(from), m.from_leaf as usize);
        assert_eq!(tree.leaf_at(to), m.to_leaf as usize);
        assert_eq!(tree.cluster(m.from_leaf as usize), Some(m.from_cluster));
        assert_eq!(tree.cluster(m.to_leaf as usize), Some(m.to_cluster));
        let (mut out, mut stack) = (Vec::new(), Vec::new());
        assert!(tree.trace(from, to, &mut out, &mut stack).is_none(), "the segment of {m:?} must be open");
    }
}

/// Rewrite a BSP's visdata with one bit cleared in every row that holds it.
fn bsp_without_pair(bytes: &[u8], a: usize, b: usize) -> Vec<u8> {
    let file = bsp::read(bytes).unwrap_or_else(|e| panic!("{e}"));
    let visleafs = file.visleafs();
    let mut visdata = Vec::new();
    let mut visofs = vec![-1i32; file.leaves.len()];
    for (leaf, ofs) in visofs.iter_mut().enumerate().take(visleafs + 1).skip(1) {
        let mut row = file.decode_leaf_pvs(leaf).unwrap_or_else(|e| panic!("{e}"));
        if leaf - 1 == a {
            row[b >> 3] &= !(1 << (b & 7));
        }
        *ofs = visdata.len() as i32;
        rle::encode_row(&row, &mut visdata);
    }
    bsp::write_with_visdata(bytes, &visdata, &visofs, None).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn cli_exits_with_a_finding_on_a_bsp_missing_one_visible_pair() {
    let Some(path) = ericw("dm1.vis.bsp") else { return };
    let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
    let pvs = level_pvs(&level).unwrap();
    let opts = Options { rays: 1_000_000, oracle: OracleChoice::Tree, ..Options::default() };
    let sampled = validate(&level, &pvs, &opts, &NoProgress).unwrap().sampled.remove(0).pop().unwrap();
    let (a, b) = proved_pairs(&pvs, &sampled, 1, 3)[0];
    let dir = std::env::temp_dir().join(format!("sightline-validate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("dm1_mutated.bsp");
    std::fs::write(&out, bsp_without_pair(&std::fs::read(&path).unwrap(), a, b)).unwrap();
    // The real binary: exit 1 for a finding (a miss), 0 for a clean PVS.
    let exit_code = |input: &Path| {
        let out = std::process::Command::new(sightline_tests::sightline_binary())
            .arg("validate")
            .arg(input)
            .args(["--rays", "1000000", "--seed", "1", "--threads", "2", "--offset", "0.25"])
            .args(["--oracle", "tree", "--json"])
            .output()
            .unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, stderr) = exit_code(&out);
    assert_eq!(code, Some(1), "the mutated file is a finding: {stderr}");
    let (code, stderr) = exit_code(&path);
    assert_eq!(code, Some(0), "the reference file is clean: {stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Cluster pairs joined by a portal of at least `min_area` square units (PRT1: leaves are
/// clusters).
fn adjacent_pairs(prt_path: &Path, min_area: f64) -> Vec<(usize, usize)> {
    let text = std::fs::read_to_string(prt_path).unwrap_or_else(|e| panic!("{}: {e}", prt_path.display()));
    let file = prt::read(&text, &prt_path.display().to_string()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(file.format, prt::PrtFormat::Prt1);
    let mut out = BTreeSet::new();
    for p in &file.portals {
        if p.winding.area() >= min_area {
            let [a, b] = p.leaves.map(|l| l as usize);
            out.insert((a, b));
            out.insert((b, a));
        }
    }
    out.into_iter().collect()
}

#[test]
fn detection_rate_on_portal_adjacent_pairs() {
    let (Some(bsp_path), Some(prt_path)) = (ericw("e1m1_nodetail.vis.bsp"), ericw("e1m1_nodetail.prt"))
    else {
        return;
    };
    let level = load::load_level(&bsp_path, &sightline_validate::NoProgress).unwrap();
    let pvs = level_pvs(&level).unwrap();
    // Sky blocks sight (as in Quake's vis), so pairs inside sky are never sampled: leave them out.
    let tree = BspTree::new(&level).unwrap();
    let all_adjacent = adjacent_pairs(&prt_path, 64.0);
    let adjacent: Vec<(usize, usize)> =
        all_adjacent.iter().copied().filter(|&(a, b)| tree.is_open(a + 1) && tree.is_open(b + 1)).collect();
    eprintln!("{} adjacent pairs, {} outside sky", all_adjacent.len(), adjacent.len());
    assert!(adjacent.len() > 1000, "{} adjacent pairs", adjacent.len());
    assert!(adjacent.iter().all(|&(a, b)| pvs.get(a, b)), "portal neighbours are always in the PVS");
    let opts = Options { rays: 4_000_000, oracle: OracleChoice::Tree, ..Options::default() };
    let v = validate(&level, &pvs, &opts, &NoProgress).unwrap();
    let mut rates = Vec::new();
    let last = v.sampled[0].last().unwrap();
    let lost: Vec<_> = adjacent.iter().filter(|&&(a, b)| !last.get(a, b)).take(10).collect();
    eprintln!("adjacent pairs never sampled (first 10): {lost:?}");
    for (step, m) in v.sampled[0].iter().enumerate() {
        let found = adjacent.iter().filter(|&&(a, b)| m.get(a, b)).count();
        let rate = found as f64 / adjacent.len() as f64;
        let any = m.count() as f64 / pvs.count() as f64;
        eprintln!(
            "e1m1_nodetail {}: {} rays: detection {:.4} on {} adjacent pairs, {:.4} on all PVS pairs",
            v.report.oracles[0].coverage[step].fraction,
            v.report.oracles[0].coverage[step].rays,
            rate,
            adjacent.len(),
            any
        );
        rates.push(rate);
    }
    assert!(rates.windows(2).all(|w| w[0] <= w[1]));
    assert!(rates[rates.len() - 1] >= 0.97, "detection rate on adjacent pairs {rates:?}");
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let Some(path) = ericw("dm1.vis.bsp") else { return };
    let level = load::load_level(&path, &sightline_validate::NoProgress).unwrap();
    let mut pvs = level_pvs(&level).unwrap();
    // A few removed pairs so that misses (and their segments) are compared too.
    let opts = Options { rays: 600_000, oracle: OracleChoice::Both, ..Options::default() };
    let first = validate(&level, &pvs, &opts, &NoProgress).unwrap();
    for (a, b) in proved_pairs(&pvs, first.sampled[0].last().unwrap(), 5, 11) {
        pvs.clear(a, b);
    }
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| validate(&level, &pvs, &opts, &NoProgress).unwrap())
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.sampled, two.sampled);
    let json = |v: &sightline_validate::Validation| {
        v.report
            .oracles
            .iter()
            .map(|o| serde_json::to_string(&(&o.misses, &o.coverage)).unwrap())
            .collect::<Vec<_>>()
    };
    assert_eq!(json(&one), json(&two));
    assert_eq!(one.report.misses(), 10, "5 removed pairs, found by both oracles");
}

#[test]
fn validation_code_never_uses_the_compiler() {
    let krate = sightline_tests::workspace_root().join("tools/validate");
    let manifest = std::fs::read_to_string(krate.join("Cargo.toml")).unwrap();
    assert!(!manifest.contains("sightline-compiler"), "sightline-validate depends on the compiler");
    let mut files = 0;
    let mut dirs = vec![krate.join("src")];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            assert!(
                !text.contains("sightline_compiler") && !text.contains("compiler::"),
                "{} uses the compiler",
                path.display()
            );
            files += 1;
        }
    }
    assert!(files >= 8, "found only {files} validator files");
}
