//! Work and memory limits: `--max-memory`, `--max-work`, `--max-time`, `--coarsen`, and the
//! flow estimate in `--json`.

use crate::support::{code, compile, copy_prt, maps, run, s, stderr, stdout_json, temp_dir};

/// A tiny portal file declaring the most leaves PRT1 allows: vis would need terabytes for its
/// cluster matrices and refuses at once, saying how much and why (exit 2), with or without
/// `--max-memory`; a normal map fits and a too small `--max-memory` refuses it too.
#[test]
fn vis_refuses_a_job_larger_than_memory_before_allocating() {
    let dir = temp_dir("memory");
    let prt = dir.join("huge.prt");
    std::fs::write(&prt, "PRT1\n4194304\n1\n4 0 1 (0 0 0) (0 64 0) (0 64 64) (0 0 64)\n").expect("write");
    let started = std::time::Instant::now();
    let o = run(&["vis", s(&prt), "--threads", "2", "--max-memory", "1G"]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("vis would need ") && err.contains(" TiB for the cluster matrices"), "{err}");
    assert!(err.contains("4194304 leaves") && err.contains("1 portals"), "{err}");
    assert!(err.contains("more than the 1.0 GiB allowed by --max-memory"), "{err}");
    let fast = run(&["vis", s(&prt), "--fast", "--threads", "2"]);
    let err = stderr(&fast);
    assert_eq!(code(&fast), 2, "{err}");
    assert!(err.contains("vis --fast would need") && err.contains("see --max-memory"), "{err}");
    assert!(started.elapsed().as_secs() < 20, "refused without allocating");
    assert!(!dir.join("huge.vis").exists());

    let level = compile(&dir, "two_rooms.map");
    let prt = level.with_extension("prt");
    let ok = run(&["vis", s(&prt), "--threads", "2", "--max-memory", "1G"]);
    assert_eq!(code(&ok), 0, "{}", stderr(&ok));
    let tight = run(&["vis", s(&prt), "--threads", "2", "--max-memory", "1K"]);
    assert_eq!(code(&tight), 2, "{}", stderr(&tight));
    assert!(stderr(&tight).contains("allowed by --max-memory"));
    let compiled = run(&["compile", s(&maps().join("two_rooms.map")), "-o", s(&level), "--max-memory", "1K"]);
    assert_eq!(code(&compiled), 2, "{}", stderr(&compiled));
    assert!(stderr(&compiled).contains("allowed by --max-memory"));
    // Refusals name the input first.
    assert!(stderr(&tight).contains(&format!("{}: vis would need", prt.display())), "{}", stderr(&tight));
    assert!(stderr(&compiled).contains("two_rooms.map: "), "{}", stderr(&compiled));
    let bad = run(&["vis", s(&prt), "--max-memory", "lots"]);
    assert_eq!(code(&bad), 2);
}

/// Over `--max-memory`, vis refuses and names `--coarsen` (exit 2); with it, vis merges clusters
/// until the run fits, warns, and reports the merge in JSON, for the same leaves. (Merges are
/// sized for one thread, so that any thread count gives the same PVS.)
#[test]
fn vis_coarsen_merges_clusters_until_it_fits() {
    let Some((dir, prt)) = copy_prt("ericw/dm1.prt", "coarsen", "dm1") else { return };
    let refused = run(&["vis", s(&prt), "--threads", "1", "--max-memory", "2000K"]);
    assert_eq!(code(&refused), 2, "{}", stderr(&refused));
    assert!(stderr(&refused).contains("rerun with --coarsen"), "{}", stderr(&refused));
    assert!(stderr(&refused).contains(&format!("{}: vis would need", prt.display())), "{}", stderr(&refused));
    assert!(!dir.join("dm1.vis").exists());
    let o = run(&["vis", s(&prt), "--threads", "1", "--max-memory", "2000K", "--coarsen", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: vis did not fit its memory or work limit: merged 410 clusters into "),
        "{}",
        stderr(&o)
    );
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let c = &report["vis"]["coarsened"];
    assert_eq!(c["clusters_before"], 410, "{report}");
    let after = c["clusters_after"].as_u64().expect("clusters_after");
    assert!(after > 0 && after < 410, "{report}");
    assert!(c["portals_after"].as_u64().expect("portals_after") < 983, "{report}");
    assert!(c["estimate"].as_u64().expect("estimate") <= 2000 * 1024, "{report}");
    assert_eq!(report["vis"]["leaves"], 415);
    assert!(dir.join("dm1.vis").exists());
}

/// Over `--max-work`, vis refuses up front naming the estimate and `--coarsen` (exit 2, nothing
/// written); with it, clusters merge until the estimate is under the limit, and `--json` reports
/// the input's estimate and the merged one.
#[test]
fn vis_max_work_refuses_or_coarsens_until_the_estimate_is_under() {
    let Some((dir, prt)) = copy_prt("ericw/dm1.prt", "max_work", "dm1") else { return };
    let full = run(&["vis", s(&prt), "--threads", "1", "--json"]);
    assert_eq!(code(&full), 0, "{}", stderr(&full));
    let report: serde_json::Value = serde_json::from_slice(&full.stdout).expect("json");
    let need = report["vis"]["work_estimate"].as_u64().expect("work_estimate");
    assert!(need > 0, "{report}");
    std::fs::remove_file(dir.join("dm1.vis")).expect("remove");
    let limit = (need / 3).to_string();
    let refused = run(&["vis", s(&prt), "--threads", "1", "--max-work", &limit]);
    assert_eq!(code(&refused), 2, "{}", stderr(&refused));
    let err = stderr(&refused);
    assert!(
        err.contains(&format!("estimated {need} portal tests")) && err.contains("rerun with --coarsen"),
        "{err}"
    );
    assert!(err.contains(&format!("{}: vis would take", prt.display())), "names the input: {err}");
    assert!(!dir.join("dm1.vis").exists());
    let o = run(&["vis", s(&prt), "--threads", "1", "--max-work", &limit, "--coarsen", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    // Said before the work starts, not only in the closing warning.
    let note = "note: vis does not fit its memory or work limit: merging 410 clusters into ";
    assert!(stderr(&o).contains(note), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let c = &report["vis"]["coarsened"];
    assert!(c["work"].as_u64().expect("work") <= need / 3, "{report}");
    assert_eq!(report["vis"]["work_estimate"].as_u64(), Some(need), "{report}");
    assert!(c["clusters_after"].as_u64().expect("clusters_after") < 410, "{report}");
    for bad in ["-1", "lots", "nan"] {
        let o = run(&["vis", s(&prt), "--max-work", bad]);
        assert_eq!(code(&o), 2, "{bad}: {}", stderr(&o));
    }
}

/// `--json` of `sightline compile` and `sightline vis` carries the flow's first time estimate
/// (made from base vis's speed before the flow) beside the real time; `--max-time` is a work
/// limit spelled in time (10^8 portal tests a second): under it with `--coarsen` clusters merge,
/// and the report says how much looser the PVS is and where; bad durations exit 2.
#[test]
fn json_carries_the_flow_estimate_and_max_time_coarsens_with_a_looseness_report() {
    let dir = temp_dir("estimate");
    let map = dir.join("rooms.map");
    let params = sightline_tests::mapgen::MapGenParams { rooms_x: 4, rooms_y: 4, storeys: 2, seed: 7 };
    std::fs::write(&map, sightline_tests::mapgen::generate(&params)).expect("write map");
    let o = run(&["compile", s(&map), "--json", "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let fine = stdout_json(&o);
    let v = &fine["vis"];
    assert!(v["base_tests"].as_u64().expect("base_tests") > 0, "{v}");
    assert!(v["flow_estimate_work"].as_u64().expect("flow_estimate_work") > 0, "{v}");
    // One-way portals per cluster: the generated rooms have several a cluster.
    assert!(v["flow_estimate_targets"].as_f64().expect("flow_estimate_targets") >= 1.0, "{v}");
    assert!(v["flow_estimate_seconds"].as_f64().expect("flow_estimate_seconds") > 0.0, "{v}");
    assert!(v["flow_seconds"].as_f64().expect("flow_seconds") > 0.0, "{v}");
    let prt = dir.join("rooms.prt");
    let o = run(&["vis", s(&prt), "--json", "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let vis = stdout_json(&o);
    assert_eq!(vis["vis"]["flow_estimate_work"], v["flow_estimate_work"], "one estimate for one input");
    assert_eq!(vis["vis"]["flow_estimate_targets"], v["flow_estimate_targets"]);
    let need = v["work_estimate"].as_u64().expect("work_estimate");
    // A budget a tenth of the estimate's time at the fixed rate.
    let budget = format!("{}s", need as f64 / 1e8 / 10.0);
    let refused = run(&["compile", s(&map), "--json", "--max-time", &budget]);
    assert_eq!(code(&refused), 2, "{}", stderr(&refused));
    assert!(stderr(&refused).contains("rerun with --coarsen"), "{}", stderr(&refused));
    let o = run(&["compile", s(&map), "--json", "--max-time", &budget, "--coarsen", "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let coarse = stdout_json(&o);
    let c = &coarse["vis"]["coarsened"];
    assert!(c["work"].as_u64().expect("work") <= need / 10, "{c}");
    let pairs = coarse["vis"]["visible_pairs"].as_u64().expect("visible_pairs");
    let lower = c["fine_pairs_lower"].as_u64().expect("fine_pairs_lower");
    let fine_pairs = v["visible_pairs"].as_u64().expect("visible_pairs");
    assert!(0 < lower && lower <= fine_pairs && fine_pairs < pairs, "{lower} {fine_pairs} {pairs}");
    assert!(c["pairs_within_groups"].as_u64().expect("pairs_within_groups") <= pairs, "{c}");
    assert!(c["retries"].as_u64().is_some_and(|r| r <= 16), "{c}");
    let groups = c["largest_groups"].as_array().expect("largest_groups");
    assert!(!groups.is_empty() && groups.len() <= 5, "{c}");
    let leaves: Vec<u64> = groups.iter().map(|g| g["leaves"].as_u64().expect("leaves")).collect();
    assert!(leaves.windows(2).all(|w| w[0] >= w[1]), "most leaves first: {leaves:?}");
    for g in groups {
        assert!(g["clusters"].as_u64().expect("clusters") > 1, "{g}");
        for axis in 0..3 {
            let at = |k: &str| g[k][axis].as_f64().expect("coordinate");
            assert!(at("mins") <= at("centre") && at("centre") <= at("maxs"), "{g}");
        }
    }
    for bad in ["15x", "0", "-5m", "5m1h", "soon"] {
        let o = run(&["compile", s(&map), "--max-time", bad]);
        assert_eq!(code(&o), 2, "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("is not a duration"), "{bad}: {}", stderr(&o));
    }
    let both = run(&["vis", s(&prt), "--max-time", "15m", "--max-work", "2e11"]);
    assert_eq!(code(&both), 2, "{}", stderr(&both));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}
