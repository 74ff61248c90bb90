//! The runtime, `info` and `validate` on Quake 2 (`IBSP` 38) and Half-Life (BSP30) files from the
//! shared maps: worlds load with their clusters, answer ericw-tools' vis-test assertions, expose
//! the Quake 2 PHS; `info` reports the counts the READMEs of `q2/` and `hl/` publish; our Quake 2
//! vis output passes validation.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};
use sightline_formats::bsp::{self, q2};
use sightline_runtime::{Bitset, World, load};
use sightline_validate::pvs::level_pvs;
use sightline_validate::{NoProgress, Options, OracleChoice, validate};

fn shared(rel: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(rel)
}

/// Does the cluster of `from`'s leaf see the cluster of `to`'s leaf in `world`'s PVS?
fn sees(world: &World, from: [f32; 3], to: [f32; 3]) -> bool {
    let (a, b) = (world.leaf_at(from), world.leaf_at(to));
    let (Some(ca), Some(cb)) = (world.leaf_cluster(a), world.leaf_cluster(b)) else {
        panic!("points {from:?} / {to:?} are not in clusters")
    };
    let mut row = Bitset::new(0);
    world.decode_pvs(ca, &mut row);
    row.get(cb as usize)
}

/// Copies `bsp` and `prt` into a fresh folder as `name.bsp` / `name.prt` and vises the copy with
/// two threads; returns the folder and the vised `.bsp`.
fn vised_copy(bsp: &Path, prt: &Path, name: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("sightline-family-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let ours = dir.join(format!("{name}.bsp"));
    std::fs::copy(bsp, &ours).expect("copy .bsp");
    std::fs::copy(prt, dir.join(format!("{name}.prt"))).expect("copy .prt");
    let opts = sightline_compiler::dropin::DropInOptions {
        vis: sightline_compiler::vis::VisOptions { threads: 2, ..Default::default() },
        ..Default::default()
    };
    sightline_compiler::dropin::run(
        &ours,
        &opts,
        &sightline_job::progress::NoProgress,
        std::time::Instant::now(),
    )
    .expect("vis");
    (dir, ours)
}

#[test]
fn quake2_worlds_answer_the_reference_assertions_and_expose_the_phs() {
    let (Some(ericw), Some(raw), Some(prt)) = (
        shared("q2/q2_detail_leak_test.ericw.t1.bsp"),
        shared("q2/q2_detail_leak_test.bsp"),
        shared("q2/q2_detail_leak_test.prt"),
    ) else {
        return;
    };
    // Our own vis output too.
    let (dir, ours) = vised_copy(&raw, &prt, "q2_detail_leak_test");

    // ericw-tools' tests/test_vis.cc, vis.detailLeakTest (ericw-testmaps/assertions.json).
    let item_enviro = [48.0, 464.0, 32.0];
    let item_enviro_curve = [-64.0, 848.0, 56.0];
    let player_start_curve = [-64.0, -432.0, 56.0];
    let player_start = [64.0, -176.0, 40.0];
    for path in [&ericw, &ours] {
        let bytes = std::fs::read(path).expect("read");
        let world = load::load_bytes(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(world.num_clusters(), 15, "{}", path.display());
        assert!(sees(&world, item_enviro, item_enviro_curve));
        assert!(!sees(&world, item_enviro, player_start_curve));
        assert!(!sees(&world, item_enviro, player_start));
        assert!(sees(&world, player_start, player_start_curve));
        assert!(!sees(&world, player_start, item_enviro_curve));
        assert!(!sees(&world, player_start, item_enviro));
        // The PHS holds the PVS and is the file's own (ericw's is not the union here: its rows,
        // not a recomputed PHS, come back), and `load_path` gives the same world (no portal file
        // read: a Quake 2 `.prt` names clusters).
        let (mut pvs_row, mut phs_row) = (Bitset::new(0), Bitset::new(0));
        let mut phs_pairs = 0;
        for c in 0..world.num_clusters() {
            world.decode_pvs(c, &mut pvs_row);
            world.decode_phs(c, &mut phs_row);
            assert!(pvs_row.iter_ones().all(|j| phs_row.get(j)), "cluster {c}: PVS in PHS");
            phs_pairs += phs_row.iter_ones().count() as u64;
        }
        let stored = q2::read(&bytes).expect("q2").vis.expect("vis").pairs(q2::Q2Row::Phs).expect("rows");
        assert_eq!(phs_pairs, stored, "{}: the stored PHS", path.display());
        let by_path = load::load_path(path).expect("load_path");
        assert_eq!((by_path.num_leaves(), by_path.num_portals()), (world.num_leaves(), 0));
    }
    // Our PHS is the true union (ericw's misses bits here, q2/README.md): 149 pairs, not 103.
    let b = std::fs::read(&ours).expect("read");
    let vis = q2::read(&b).expect("q2").vis.expect("vis");
    assert_eq!(vis.pairs(q2::Q2Row::Phs).expect("rows"), 149);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn half_life_worlds_locate_points_and_decode_rows_as_the_file() {
    let Some(path) = shared("hl/lq_e0m1.sdhlt.vis.bsp") else { return };
    // `load_path` skips the VHLT portal file beside it (the portal backend takes PRT1 only).
    let world = load::load_path(&path).unwrap_or_else(|e| panic!("{e}"));
    let file = bsp::read(&std::fs::read(&path).expect("read")).expect("BSP30");
    assert_eq!((world.num_clusters(), world.num_portals()), (658, 0));
    let mut row = Bitset::new(0);
    for leaf in 1..=file.visleafs() {
        let bytes = file.decode_leaf_pvs(leaf).expect("row");
        let b = &file.leaves[leaf];
        let centre = [0, 1, 2].map(|k| (b.mins[k] + b.maxs[k]) / 2.0);
        let found = world.leaf_at(centre);
        // A leaf's box centre may lie in another leaf; the rows must then match that leaf's.
        let cluster = world.leaf_cluster(found);
        if found as usize == leaf {
            assert_eq!(cluster, Some(leaf as u32 - 1));
        }
        world.decode_pvs(leaf as u32 - 1, &mut row);
        for j in 0..file.visleafs() {
            assert_eq!(row.get(j), bytes[j / 8] & (1 << (j % 8)) != 0, "leaf {leaf}, bit {j}");
        }
    }
}

/// The `--json` report of `sightline info` (the real binary) on `path`.
fn bsp_info(path: &Path) -> Value {
    crate::info_cli::info(path)
}

/// The fields `keys` of `report`, in order.
fn fields(report: &Value, keys: &[&str]) -> Vec<Value> {
    keys.iter().map(|k| report[*k].clone()).collect()
}

#[test]
fn info_reports_the_published_counts_of_quake2_and_half_life_files() {
    // q2/README.md: dm2.ericw has 869 clusters, 77,959 PVS pairs, 250,130 PHS pairs.
    if let Some(p) = shared("q2/dm2.ericw.bsp") {
        let r = bsp_info(&p);
        assert_eq!(r["kind"], "bsp", "not a bsp: {r}");
        assert_eq!(
            fields(&r, &["game", "version", "clusters", "has_vis"]),
            [json!("quake2"), json!("IBSP38"), json!(869), json!(true)]
        );
        assert_eq!(fields(&r, &["pvs_pairs", "phs_pairs"]), [json!(77_959), json!(250_130)]);
        assert_eq!(fields(&r, &["leaves", "models"]), [json!(2527), json!(36)]);
    }
    if let Some(p) = shared("q2/dm2.bsp") {
        let r = bsp_info(&p);
        assert_eq!(r["kind"], "bsp", "not a bsp: {r}");
        assert_eq!(
            fields(&r, &["has_vis", "pvs_pairs", "clusters"]),
            [json!(false), Value::Null, json!(869)]
        );
    }
    // hl/README.md: lq_e0m1.sdhlt.vis has 658 visleafs, 8,871 visdata bytes, 58,979 pairs.
    if let Some(p) = shared("hl/lq_e0m1.sdhlt.vis.bsp") {
        let r = bsp_info(&p);
        assert_eq!(r["kind"], "bsp", "not a bsp: {r}");
        assert_eq!(
            fields(&r, &["game", "version", "visleafs", "visdata_bytes"]),
            [json!("half-life"), json!("BSP30"), json!(658), json!(8871)]
        );
        assert_eq!(fields(&r, &["pvs_pairs", "phs_pairs"]), [json!(58_979), Value::Null]);
    }
    if let Some(p) = shared("hl/lq_e0m1.sdhlt.prt") {
        let r = bsp_info(&p);
        assert_eq!(r["kind"], "prt", "not a prt: {r}");
        assert_eq!(
            fields(&r, &["format", "leaves", "clusters", "portals"]),
            [json!("vhlt"), json!(658), json!(371), json!(775)]
        );
    }
}

#[test]
fn our_quake2_vis_has_no_miss_by_ray_sampling() {
    let (Some(raw), Some(prt)) = (shared("q2/dm2.bsp"), shared("q2/dm2.prt")) else { return };
    let (dir, ours) = vised_copy(&raw, &prt, "dm2");
    let level = sightline_validate::load::load_level(&ours, &sightline_validate::NoProgress).expect("level");
    assert_eq!(level.num_clusters, 869);
    let pvs = level_pvs(&level).expect("pvs");
    let opts = Options { rays: 300_000, oracle: OracleChoice::Both, ..Options::default() };
    let v = validate(&level, &pvs, &opts, &NoProgress).expect("validate");
    assert_eq!(v.report.misses(), 0, "{}", v.report.text());
    let _ = std::fs::remove_dir_all(&dir);
}
