//! Re-vis without source: `portals`, `vis --portals-from-bsp`, `--external-vis` (one map, a
//! folder).

use std::path::{Path, PathBuf};

use crate::support::{bin, code, pvs_rows, read_bsp, run, s, shared_map, stderr, stdout_json, temp_dir};

/// A fresh temp dir `tag` holding the shared `.bsp` at `bsp` alone (no `.prt`), as `NAME.bsp`.
fn bsp_alone(bsp: &Path, tag: &str, name: &str) -> PathBuf {
    let dir = temp_dir(tag);
    std::fs::copy(bsp, dir.join(format!("{name}.bsp"))).expect("copy .bsp");
    dir
}

#[test]
fn portals_rebuilds_a_prt1_over_the_bsps_vis_leaves() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "portals", "dm1");
    let o = run(&["portals", &dir.join("dm1.bsp").to_string_lossy(), "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let report = stdout_json(&o);
    let prt = std::fs::read_to_string(dir.join("dm1.prt")).expect("dm1.prt written beside the .bsp");
    let prt = sightline_formats::prt::read(&prt, "dm1.prt").expect("a valid portal file");
    assert_eq!(prt.format, sightline_formats::prt::PrtFormat::Prt1);
    assert_eq!(prt.num_leaves as usize, read_bsp(&dm1).visleafs());
    assert_eq!(report["portals"]["portals"].as_u64(), Some(prt.portals.len() as u64));
    // ericw-tools' qbsp wrote 983 cluster portals for the same tree.
    assert!((950..1050).contains(&prt.portals.len()), "{} portals", prt.portals.len());
    // Opaque water leaves out the liquid surfaces; -o names the file.
    let opaque = dir.join("opaque.prt");
    let o = run(&[
        "portals",
        &dir.join("dm1.bsp").to_string_lossy(),
        "--water",
        "opaque",
        "-o",
        &opaque.to_string_lossy(),
    ]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let fewer = sightline_formats::prt::read(&std::fs::read_to_string(&opaque).expect("opaque.prt"), "o")
        .expect("prt");
    assert!(fewer.portals.len() < prt.portals.len());
    // Not a BSP: exit 2 naming the file.
    std::fs::write(dir.join("junk.bsp"), b"not a bsp at all, not even close to one").expect("write");
    let o = run(&["portals", &dir.join("junk.bsp").to_string_lossy()]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("junk.bsp"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn vis_with_portals_from_the_bsp_passes_ray_validation() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "from-bsp", "dm1");
    // A stale .prt beside the .bsp is ignored under --portals-from-bsp.
    std::fs::write(dir.join("dm1.prt"), "PRT1\n3\n0\n").expect("write");
    let bsp = dir.join("dm1.bsp");
    let o = run(&["vis", &bsp.to_string_lossy(), "--portals-from-bsp", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let report = stdout_json(&o);
    assert!(report["portals_rebuilt"]["portals"].as_u64().is_some_and(|n| n > 900), "{report}");
    let vised = read_bsp(&bsp);
    assert!(vised.pvs_stats().expect("rows").is_some_and(|s| s.avg_visible > 10.0 && s.avg_visible < 200.0));
    let o = run(&["validate", &bsp.to_string_lossy(), "--rays", "300000", "--json"]);
    assert_eq!(code(&o), 0, "validation found a miss: {}", String::from_utf8_lossy(&o.stdout));
    let v = stdout_json(&o);
    for oracle in v["oracles"].as_array().expect("oracles") {
        assert_eq!(oracle["misses"].as_array().map(Vec::len), Some(0), "{oracle}");
    }
    // --water without --portals-from-bsp, and --portals-from-bsp on a .prt, are errors.
    let o = run(&["vis", &bsp.to_string_lossy(), "--water", "opaque"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("--portals-from-bsp"), "{}", stderr(&o));
    let o = run(&["vis", &dir.join("dm1.prt").to_string_lossy(), "--portals-from-bsp"]);
    assert_eq!(code(&o), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn half_life_portals_from_the_bsp_match_sdhlt_and_pass_ray_validation() {
    let Some(src) = shared_map("hl/dm2.sdhlt.bsp") else { return };
    // From SDHLT's own portal file, then from the tree alone.
    let with_prt = temp_dir("hl-from-prt");
    std::fs::copy(&src, with_prt.join("dm2.bsp")).expect("copy .bsp");
    std::fs::copy(src.with_extension("prt"), with_prt.join("dm2.prt")).expect("copy .prt");
    let from_prt = with_prt.join("dm2.bsp");
    assert_eq!(code(&run(&["vis", s(&from_prt), "--threads", "2"])), 0);
    let dir = bsp_alone(&src, "hl-from-bsp", "dm2");
    let bsp = dir.join("dm2.bsp");
    let o = run(&["vis", s(&bsp), "--portals-from-bsp", "--threads", "2", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let j = stdout_json(&o);
    let prt_portals = std::fs::read_to_string(src.with_extension("prt")).expect("read .prt");
    let sdhlt: u64 =
        prt_portals.split_whitespace().nth(1).and_then(|t| t.parse().ok()).expect("portal count");
    assert_eq!(
        j["portals_rebuilt"]["portals"].as_u64(),
        Some(sdhlt),
        "the same portals as SDHLT's hlbsp: {j}"
    );
    let pairs = |p: &Path| read_bsp(p).pvs_stats().expect("rows").expect("vised").pairs;
    let (ours, theirs) = (pairs(&bsp) as f64, pairs(&from_prt) as f64);
    assert!((0.95..=1.05).contains(&(ours / theirs)), "pairs {ours} from the tree vs {theirs} from the .prt");
    let o = run(&["validate", s(&bsp), "--rays", "200000", "--json"]);
    assert_eq!(code(&o), 0, "validation found a miss: {}", String::from_utf8_lossy(&o.stdout));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&with_prt);
}

#[test]
fn external_vis_leaves_the_bsp_alone_and_holds_the_pvs_vis_would_write() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "external", "dm1");
    let bsp = dir.join("dm1.bsp");
    let before = std::fs::read(&bsp).expect("read");
    let o = run(&["vis", &bsp.to_string_lossy(), "--portals-from-bsp", "--external-vis"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(std::fs::read(&bsp).expect("read"), before, "the .bsp is untouched");
    let pack = sightline_formats::vispatch::read(&std::fs::read(dir.join("dm1.vis")).expect("dm1.vis"))
        .expect("reads");
    assert_eq!(pack.len(), 1);
    assert_eq!(pack[0].map_name, "dm1.bsp");
    // The same run into the .bsp: the record decodes to the rows written there.
    let o = run(&["vis", &bsp.to_string_lossy(), "--portals-from-bsp"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let vised = read_bsp(&bsp);
    let rows = pvs_rows(&vised);
    for (j, row) in rows.iter().enumerate() {
        assert_eq!(&pack[0].decode_row(j + 1, vised.visleafs()).expect("row"), row, "vis leaf {j}");
    }
    let leaves = vised.lumps[sightline_formats::bsp::lump::LEAVES];
    assert_eq!(pack[0].leaves, std::fs::read(&bsp).expect("read")[leaves.offset..leaves.end()]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_folder_makes_one_pack_and_lists_the_maps_it_skipped() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "pack", "dm1");
    std::fs::copy(&dm1, dir.join("DM1.BSP")).expect("copy");
    std::fs::write(dir.join("broken.bsp"), vec![7u8; 300]).expect("write");
    let pack = dir.join("pack.vis");
    let o = run(&[
        "vis",
        &dir.to_string_lossy(),
        "--external-vis",
        "--portals-from-bsp",
        "--fast",
        "-o",
        &pack.to_string_lossy(),
        "--json",
    ]);
    assert_eq!(code(&o), 1, "some maps skipped: exit 1; {}", stderr(&o));
    let report = stdout_json(&o);
    let skipped: Vec<String> = report["skipped"]
        .as_array()
        .expect("skipped")
        .iter()
        .map(|s| s["file"].as_str().unwrap_or("").to_string())
        .collect();
    assert_eq!(skipped.len(), 2, "{report}");
    assert!(
        skipped.iter().any(|f| f.ends_with("broken.bsp")) && skipped.iter().any(|f| f.ends_with("dm1.bsp")),
        "{skipped:?}"
    );
    let records =
        sightline_formats::vispatch::read(&std::fs::read(&pack).expect("pack written")).expect("reads");
    assert_eq!(records.iter().map(|r| r.map_name.as_str()).collect::<Vec<_>>(), ["DM1.BSP"]);
    // Nothing to pack: exit 2, nothing written; a folder needs -o.
    let bad = temp_dir("pack-bad");
    std::fs::write(bad.join("broken.bsp"), vec![7u8; 300]).expect("write");
    let none = bad.join("none.vis");
    let o = run(&["vis", &bad.to_string_lossy(), "--external-vis", "-o", &none.to_string_lossy()]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("broken.bsp") && !none.exists(), "{}", stderr(&o));
    let o = run(&["vis", &bad.to_string_lossy(), "--external-vis"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("-o"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&bad);
}

#[test]
fn mutated_trees_never_panic_portals_or_vis_from_the_bsp() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let bytes = std::fs::read(&dm1).expect("read");
    let nodes = read_bsp(&dm1).lumps[sightline_formats::bsp::lump::NODES];
    let dir = temp_dir("mutated-trees");
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for i in 0..6 {
        let mut m = bytes.clone();
        for _ in 0..8 {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let at = nodes.offset + (state >> 33) as usize % nodes.length;
            m[at] ^= 1 << ((state >> 20) % 8);
        }
        let path = dir.join(format!("m{i}.bsp"));
        std::fs::write(&path, &m).expect("write");
        for args in [vec!["portals"], vec!["vis", "--portals-from-bsp", "--fast"]] {
            let o = bin().args(&args).arg(&path).output().expect("runs");
            let c = code(&o);
            assert!(c == 0 || c == 2, "{args:?} on mutation {i}: exit {c}: {}", stderr(&o));
            assert!(!stderr(&o).contains("panicked"), "{args:?} on mutation {i}: {}", stderr(&o));
            if c == 2 {
                assert!(stderr(&o).contains(&format!("m{i}.bsp")), "{}", stderr(&o));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
