//! Half-Life (BSP30) vis on the shared maps in `hl/`: ericw-tools' `-hlbsp` output with its PRT2,
//! and SDHLT's with its VHLT portal file (per-portal-leaf leaf counts). The written file keeps
//! every byte but the visibility lump and the leaves' `visofs` and ambient levels; our PVS has no
//! more pairs than the reference vis that ran on the same file; the BSP leaves of one portal
//! leaf share its row; the result is the same for 1 and 2 threads; ray sampling finds no miss.

use std::path::{Path, PathBuf};
use std::time::Instant;

use sightline_compiler::dropin::{self, DropInOptions};
use sightline_compiler::vis::VisOptions;
use sightline_formats::bsp::{self, Bsp, BspVersion};
use sightline_formats::prt;
use sightline_validate::pvs::level_pvs;
use sightline_validate::{NoProgress, Options, OracleChoice, load, validate};

fn hl_map(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(&format!("hl/{name}"))
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-vis-hl-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Copies shared `hl/BASE.bsp` and `hl/PRT` into `dir` as `BASE.bsp` and `BASE.prt`.
fn copy_in(dir: &Path, base: &str, prt: &str) -> Option<PathBuf> {
    let (src, prt_src) = (hl_map(&format!("{base}.bsp"))?, hl_map(prt)?);
    let bsp = dir.join(format!("{base}.bsp"));
    std::fs::write(&bsp, std::fs::read(src).expect("read .bsp")).expect("write .bsp copy");
    std::fs::write(dir.join(format!("{base}.prt")), std::fs::read(prt_src).expect("read .prt"))
        .expect("write .prt copy");
    Some(bsp)
}

/// The drop-in vis of `bsp` (its `.prt` beside it) with `threads` worker threads, written back
/// into it.
fn vis(bsp: &Path, threads: usize) -> anyhow::Result<()> {
    let opts =
        DropInOptions { vis: VisOptions { threads, ..VisOptions::default() }, ..DropInOptions::default() };
    dropin::run(bsp, &opts, &NoProgress, Instant::now())?;
    Ok(())
}

fn read(path: &Path) -> (Vec<u8>, Bsp) {
    let bytes = std::fs::read(path).expect("read .bsp");
    let b = bsp::read(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (bytes, b)
}

/// Ordered visible vis-leaf pairs, self included.
fn pairs(b: &Bsp) -> usize {
    (1..=b.visleafs())
        .map(|l| b.decode_leaf_pvs(l).expect("row").iter().map(|x| x.count_ones() as usize).sum::<usize>())
        .sum()
}

/// Every lump but visibility and leaves by content, and the leaves without `visofs` and ambient
/// levels.
fn kept(bytes: &[u8], b: &Bsp) -> (Vec<Vec<u8>>, Vec<Vec<u8>>) {
    let lumps = (0..bsp::NUM_LUMPS)
        .filter(|&i| i != bsp::lump::VISIBILITY && i != bsp::lump::LEAVES)
        .map(|i| bytes[b.lumps[i].offset..b.lumps[i].end()].to_vec())
        .collect();
    let leaves = b.lumps[bsp::lump::LEAVES];
    let leaves =
        bytes[leaves.offset..leaves.end()].chunks_exact(28).map(|l| [&l[..4], &l[8..24]].concat()).collect();
    (lumps, leaves)
}

#[test]
fn hl_vis_keeps_other_bytes_and_is_no_looser_than_the_reference() {
    // (base, portal file, reference vised file): start and e1m1 take seconds each.
    let cases = [
        ("dm2", "dm2.prt", "dm2.ericw.bsp"),
        ("dm2.sdhlt", "dm2.sdhlt.prt", "dm2.sdhlt.vis.bsp"),
        ("lq_e0m1.sdhlt", "lq_e0m1.sdhlt.prt", "lq_e0m1.sdhlt.vis.bsp"),
    ];
    let dir = temp_dir("refs");
    for (base, prt_name, reference) in cases {
        let Some(path) = copy_in(&dir, base, prt_name) else { return };
        let Some(reference) = hl_map(reference) else { return };
        let (before, old) = read(&path);
        assert_eq!(old.version, BspVersion::Bsp30, "{base}");
        vis(&path, 2).unwrap_or_else(|e| panic!("{base}: {e:#}"));
        let (after, new) = read(&path);
        assert_eq!(kept(&before, &old), kept(&after, &new), "{base}: bytes vis must not touch");
        assert!(!new.visdata.is_empty(), "{base}: visdata written");
        let (_, theirs) = read(&reference);
        let (ours, theirs) = (pairs(&new), pairs(&theirs));
        eprintln!("{base}: PVS pairs {ours}, reference {theirs} ({:.4})", ours as f64 / theirs as f64);
        assert!(ours <= theirs, "{base}: {ours} pairs, more than the reference's {theirs}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sdhlt_portal_leaves_expand_to_their_bsp_leaves_and_threads_do_not_matter() {
    let dir = temp_dir("expand");
    let Some(one) = copy_in(&dir, "lq_e0m1.sdhlt", "lq_e0m1.sdhlt.prt") else { return };
    let two_dir = dir.join("two");
    std::fs::create_dir_all(&two_dir).expect("dir");
    let two = copy_in(&two_dir, "lq_e0m1.sdhlt", "lq_e0m1.sdhlt.prt").expect("present above");
    vis(&one, 1).expect("vis, 1 thread");
    vis(&two, 2).expect("vis, 2 threads");
    let bytes = std::fs::read(&one).expect("read");
    assert!(bytes == std::fs::read(&two).expect("read"), "1 and 2 threads write the same bytes");

    let text = std::fs::read(dir.join("lq_e0m1.sdhlt.prt")).expect("read .prt");
    let file = prt::read_bytes(&text, "lq_e0m1.sdhlt.prt").expect("VHLT portal file");
    assert_eq!(file.format, prt::PrtFormat::Vhlt);
    assert_eq!((file.num_clusters, file.num_leaves), (371, 658));
    let b = bsp::read(&bytes).expect("written file reads");
    // Every BSP leaf of a portal leaf points at the portal leaf's row; different portal leaves
    // have different rows unless the rows are equal.
    let mut several = 0;
    for c in 0..file.num_clusters {
        let leaves: Vec<usize> =
            (0..file.num_leaves as usize).filter(|&j| file.leaf_clusters[j] == c).map(|j| j + 1).collect();
        several += usize::from(leaves.len() > 1);
        let ofs: Vec<i32> = leaves.iter().map(|&l| b.leaves[l].visofs).collect();
        assert!(ofs.windows(2).all(|w| w[0] == w[1]), "portal leaf {c}: leaves {leaves:?} rows {ofs:?}");
        // A portal leaf sees all its own BSP leaves.
        let row = b.decode_leaf_pvs(leaves[0]).expect("row");
        assert!(leaves.iter().all(|&l| row[(l - 1) / 8] & (1 << ((l - 1) % 8)) != 0), "portal leaf {c}");
    }
    assert_eq!(several, 38, "the README's 38 portal leaves of 2-16 BSP leaves");

    // No miss at a moderate budget, by either oracle.
    let level = load::load_level(&one, &sightline_validate::NoProgress).expect("level");
    let pvs = level_pvs(&level).expect("pvs");
    let opts = Options { rays: 300_000, oracle: OracleChoice::Both, ..Options::default() };
    let v = validate(&level, &pvs, &opts, &NoProgress).expect("validate");
    assert_eq!(v.report.misses(), 0, "{}", v.report.text());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_fixed_portal_file_works_only_when_each_portal_leaf_is_one_bsp_leaf() {
    let dir = temp_dir("fixed");
    // lq_e0m1 after hlvis's FixPrt: 371 portal leaves for 658 BSP leaves cannot be matched.
    let Some(lq) = copy_in(&dir, "lq_e0m1.sdhlt", "lq_e0m1.sdhlt.fixed.prt") else { return };
    let err = format!("{:#}", vis(&lq, 2).expect_err("refused"));
    assert!(err.contains("lq_e0m1.sdhlt.prt") && err.contains("FixPrt") && err.contains("371"), "{err}");

    // dm2 through SDHLT has one BSP leaf per portal leaf: without the count lines vis writes the
    // same file as with them.
    let Some(with) = copy_in(&dir, "dm2.sdhlt", "dm2.sdhlt.prt") else { return };
    vis(&with, 2).expect("vis with counts");
    let counted = std::fs::read(&with).expect("read");
    let without_dir = dir.join("fixed");
    std::fs::create_dir_all(&without_dir).expect("dir");
    let bare = copy_in(&without_dir, "dm2.sdhlt", "dm2.sdhlt.prt").expect("present above");
    let text = std::fs::read_to_string(without_dir.join("dm2.sdhlt.prt")).expect("read");
    let lines: Vec<&str> = text.lines().collect();
    let n: usize = lines[0].trim().parse().expect("count");
    let fixed = [&lines[..2], &lines[2 + n..]].concat().join("\n") + "\n";
    assert_eq!(prt::PrtFormat::of_text(&fixed), Some(prt::PrtFormat::VhltFixed));
    std::fs::write(without_dir.join("dm2.sdhlt.prt"), fixed).expect("write");
    vis(&bare, 2).expect("vis without counts");
    assert!(std::fs::read(&bare).expect("read") == counted, "same bytes with or without the count lines");
    let _ = std::fs::remove_dir_all(&dir);
}
