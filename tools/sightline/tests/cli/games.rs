//! Quake 2, Quake 3 and Half-Life files: `vis` (PVS and PHS, `--phs-only`, `-farplane`),
//! `info`, `validate`, and their broken files.

use std::path::Path;

use crate::support::{bin, code, copy_map, maps, run, run_in, s, shared_map, stderr, stdout_json, temp_dir};

#[test]
fn quake2_vis_farplane_hides_only_clusters_farther_apart_and_keeps_the_phs_a_union() {
    use sightline_formats::bsp::q2::{self, Q2Row};
    let Some(dm2) = shared_map("q2/dm2.bsp") else { return };
    let full = copy_map(&dm2, "q2-farplane-off", "dm2");
    run_in(&full, &["vis", "-threads", "2", "dm2"]);
    let far = copy_map(&dm2, "q2-farplane-512", "dm2");
    let j = stdout_json(&run_in(&far, &["vis", "-threads", "2", "-farplane", "512", "dm2", "--json"]));
    assert_eq!(j["farplane"], 512.0, "{j}");
    let read = |dir: &Path| std::fs::read(dir.join("dm2.bsp")).expect("read dm2.bsp");
    let (bytes_a, bytes_b) = (read(&full), read(&far));
    let (a, b) = (q2::read(&bytes_a).expect("q2"), q2::read(&bytes_b).expect("q2"));
    let (va, vb) = (a.vis.clone().expect("vised"), b.vis.clone().expect("vised"));
    let n = va.num_clusters;
    let rb = va.row_bytes();
    let (pa, pb) = (va.decode_all(Q2Row::Pvs).expect("rows"), vb.decode_all(Q2Row::Pvs).expect("rows"));
    let phs = vb.decode_all(Q2Row::Phs).expect("rows");
    let bit = |rows: &[u8], i: usize, k: usize| rows[i * rb + k / 8] & (1 << (k % 8)) != 0;
    // The nearest distance between the stored bounds of any leaf of cluster i and any of k.
    let level = q2::to_level(&b);
    let gap = |i: usize, k: usize| {
        let of = |c: usize| level.leaves.iter().filter(move |l| l.cluster == c as i32);
        of(i)
            .flat_map(|p| of(k).map(move |q| (p, q)))
            .map(|(p, q)| {
                (0..3)
                    .map(|x| f64::from((p.mins[x] - q.maxs[x]).max(q.mins[x] - p.maxs[x]).max(0.0)).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let mut hidden = 0;
    for i in 0..n {
        assert!(bit(&pb, i, i), "cluster {i} still sees itself");
        // The PHS is the union of the culled PVS rows of what cluster i sees.
        let mut heard = vec![0u8; rb];
        for m in (0..n).filter(|&m| bit(&pb, i, m)) {
            heard.iter_mut().zip(&pb[m * rb..(m + 1) * rb]).for_each(|(h, r)| *h |= r);
        }
        assert_eq!(heard, phs[i * rb..(i + 1) * rb], "PHS row of cluster {i}");
        for k in 0..n {
            let (seen_a, seen_b) = (bit(&pa, i, k), bit(&pb, i, k));
            assert!(!seen_b || seen_a, "the far plane only hides: {i} -> {k}");
            if seen_a && !seen_b {
                hidden += 1;
                assert!(gap(i, k) > 512.0, "{i} -> {k} hidden at {} units", gap(i, k));
            }
        }
    }
    assert!(hidden > 0, "dm2 has clusters more than 512 units apart that see each other");
    assert_eq!(j["farplane_hidden_pairs"].as_u64(), Some(hidden as u64 / 2), "{j}");
    // --phs-only keeps the PVS byte for byte: a far plane there is an error.
    let o = bin()
        .args(["vis", "--phs-only", "-farplane", "512", "dm2"])
        .current_dir(&far)
        .output()
        .expect("runs");
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("--phs-only"), "{}", stderr(&o));
}

#[test]
fn vis_on_a_quake2_bsp_writes_pvs_and_phs_and_phs_only_repairs_ericw() {
    let Some(src) = shared_map("q2/q2_detail_leak_test.bsp") else { return };
    let dir = copy_map(&src, "q2-vis", "leak");
    // ericw's command line works the same way for Quake 2.
    let o = run_in(&dir, &["vis", "-threads", "2", "leak", "--json"]);
    let j = stdout_json(&o);
    assert_eq!((j["game"].as_str(), j["mode"].as_str()), (Some("quake2"), Some("vis")), "{j}");
    assert_eq!(
        (j["clusters"].as_u64(), j["pvs_pairs"].as_u64(), j["phs_pairs"].as_u64()),
        (Some(15), Some(103), Some(149))
    );
    assert!(j["visibility_bytes"].as_u64().expect("visibility_bytes") > 4 + 8 * 15);
    // `info` reads Quake 2 files: clusters and the pairs of the PVS and PHS just written.
    let o = run(&["info", s(&dir.join("leak.bsp")), "--json"]);
    let j = stdout_json(&o);
    assert_eq!((j["game"].as_str(), j["clusters"].as_u64()), (Some("quake2"), Some(15)), "{j}");
    assert_eq!((j["pvs_pairs"].as_u64(), j["phs_pairs"].as_u64()), (Some(103), Some(149)));

    let Some(ericw) = shared_map("q2/q2_detail_leak_test.ericw.bsp") else { return };
    let fix = temp_dir("q2-phs-only");
    std::fs::copy(&ericw, fix.join("e.bsp")).expect("copy .bsp");
    let o = run_in(&fix, &["vis", "--phs-only", "e.bsp", "--json"]);
    let j = stdout_json(&o);
    assert_eq!(j["mode"].as_str(), Some("phs-only"));
    assert_eq!(
        (j["phs_repair"]["rows_fixed"].as_u64(), j["phs_repair"]["bits_added"].as_u64()),
        (Some(15), Some(46))
    );
    let o = run_in(&fix, &["vis", "--phs-only", "e.bsp"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 of 15 rows changed"));

    // --phs-only on a Quake 1 file is an error naming it.
    let o = run(&["vis", "--phs-only", s(&maps().join("room.map"))]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("--phs-only"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&fix);
}

#[test]
fn quake3_vis_info_validate_and_bad_files() {
    let Some(src) = shared_map("q3/fan.bsp") else { return };
    let dir = copy_map(&src, "q3-vis", "fan");
    // ericw's command line works for Quake 3 too.
    let o = run_in(&dir, &["vis", "-threads", "2", "fan", "--json"]);
    let j = stdout_json(&o);
    assert_eq!((j["game"].as_str(), j["prt_format"].as_str()), (Some("quake3"), Some("q3map2")), "{j}");
    assert_eq!((j["clusters"].as_u64(), j["visibility_bytes"].as_u64()), (Some(172), Some(8 + 172 * 24)));
    let pairs = j["pvs_pairs"].as_u64().expect("pvs_pairs");
    let bsp = dir.join("fan.bsp");
    let o = run(&["info", s(&bsp), "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let info = stdout_json(&o);
    assert_eq!((info["kind"].as_str(), info["version"].as_i64()), (Some("q3_bsp"), Some(46)), "{info}");
    assert_eq!((info["clusters"].as_u64(), info["pvs_pairs"].as_u64()), (Some(172), Some(pairs)));
    assert_eq!((info["leaves"].as_u64(), info["has_vis"].as_bool()), (Some(413), Some(true)));
    let o = run(&["validate", s(&bsp), "--rays", "20000", "--json"]);
    assert_eq!(code(&o), 0, "no miss: {}", stderr(&o));
    assert!(stderr(&o).contains("sampling against the BSP tree only"), "{}", stderr(&o));

    // Broken files: exit 2, the message names the file and the place.
    let good = std::fs::read(&bsp).expect("read");
    let (_, lumps) = sightline_formats::bsp::q3::read_header(&good).expect("header");
    let vis_at = lumps[sightline_formats::bsp::q3::lump::VISIBILITY].offset;
    let mut bad = good.clone();
    bad[vis_at..vis_at + 4].copy_from_slice(&100_000i32.to_le_bytes());
    let broken = dir.join("broken.bsp");
    for (bytes, place) in [(&bad[..], format!("byte {}", vis_at + 4)), (&good[..1000], "byte 8".to_string())]
    {
        std::fs::write(&broken, bytes).expect("write");
        for cmd in ["info", "vis", "validate"] {
            let o = run(&[cmd, s(&broken)]);
            let err = stderr(&o);
            assert_eq!(code(&o), 2, "{cmd}: {err}");
            assert!(err.contains("broken.bsp") && err.contains(&place), "{cmd}: {err}");
            assert!(!err.contains("panicked"), "{cmd}: {err}");
        }
    }
    // A q3map2 portal file that does not parse: exit 2 naming it, line and column.
    let prt = std::fs::read_to_string(dir.join("fan.prt")).expect("read .prt");
    std::fs::write(dir.join("fan.prt"), prt.replacen("4 0 11 0 (", "4 0 11 x (", 1)).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("fan.prt:5:8: expected portal flags"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn half_life_vis_errors_exit_2_naming_the_file() {
    let Some(src) = shared_map("hl/lq_e0m1.sdhlt.bsp") else { return };
    let dir = temp_dir("hl-errors");
    let (bsp, prt) = (dir.join("m.bsp"), dir.join("m.prt"));
    let bytes = std::fs::read(&src).expect("read .bsp");
    let text = std::fs::read_to_string(src.with_extension("prt")).expect("read .prt");
    // A truncated BSP30: the error names the file and the lump.
    std::fs::write(&bsp, &bytes[..bytes.len() / 2]).expect("write");
    std::fs::write(&prt, &text).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("m.bsp") && stderr(&o).contains("lump"), "{}", stderr(&o));
    // A VHLT portal file with a negative leaf count: named with its line and column.
    std::fs::write(&bsp, &bytes).expect("write");
    std::fs::write(&prt, text.replacen("\n1\n", "\n-1\n", 1)).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("m.prt:3:1") && stderr(&o).contains("-1 leaves"), "{}", stderr(&o));
    // Counts that do not add up to the BSP's vis leaves.
    std::fs::write(&prt, text.replacen("\n1\n", "\n2\n", 1)).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("658 vis leaves") && stderr(&o).contains("659"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&bsp).expect("read"), bytes, "nothing written on an error");
}
