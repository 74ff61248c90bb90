//! Re-vising compiled maps without their source: portals rebuilt from a real BSP's tree are the
//! compiler's own (as many as its PRT1) and give a PVS as tight as its `.prt` (within 5 % more
//! pairs), the same for any thread count;
//! see-through water sees strictly more than opaque water; and an external `.vis` record made for
//! a map decodes to the PVS computed. (The real binary, with ray validation, is exercised in
//! `tools/sightline/tests/cli/revis.rs`.)

use sightline_compiler::bsp_portals::{self, BspPortalOptions};
use sightline_compiler::contents::LiquidSight;
use sightline_compiler::vis::{self, VisOptions, VisResult};
use sightline_compiler::visdata::{self, AmbientOptions, Rows, VisInput};
use sightline_formats::bsp;
use sightline_formats::prt;
use sightline_formats::vispatch::{self, VisPatchRecord};

fn run(prt: &prt::PortalFile, threads: usize) -> VisResult {
    vis::run(prt, &VisOptions { threads, ..VisOptions::default() }, &sightline_job::progress::NoProgress)
        .expect("vis runs")
}

/// Visible (leaf, leaf) pairs of a result, and every leaf's row back to back.
fn rows_and_pairs(r: &VisResult) -> (Vec<u8>, u64) {
    let mut all = Vec::new();
    let mut row = Vec::new();
    for leaf in 0..r.num_leaves() {
        r.leaf_row_bytes(leaf, &mut row);
        all.extend_from_slice(&row);
    }
    let pairs = all.iter().map(|b| u64::from(b.count_ones())).sum();
    (all, pairs)
}

#[test]
fn rebuilt_portals_are_as_tight_as_the_compilers_and_deterministic() {
    for name in ["dm1", "dm2_nodetail"] {
        let (Some(bsp_path), Some(prt_path)) = (
            sightline_tests::shared_map(&format!("ericw/{name}.bsp")),
            sightline_tests::shared_map(&format!("ericw/{name}.prt")),
        ) else {
            return;
        };
        let (input, stats) =
            VisInput::from_bsp_tree(&bsp_path, BspPortalOptions::default()).expect("rebuild");
        let reference = prt::read_bytes(&std::fs::read(&prt_path).expect("read .prt"), name).expect(".prt");
        assert_eq!(input.prt.num_leaves, reference.num_leaves, "{name}: the BSP's own vis leaves");
        assert_eq!(stats.portals, input.prt.portals.len());
        // Without detail, qbsp's PRT1 holds the portals of the very tree the BSP stores: the
        // rebuild finds each of them. (With detail its PRT2 joins clusters, not leaves.)
        if reference.format == prt::PrtFormat::Prt1 {
            assert_eq!(input.prt.portals.len(), reference.portals.len(), "{name}: portals");
        }
        let (rows1, pairs) = rows_and_pairs(&run(&input.prt, 1));
        let (rows2, _) = rows_and_pairs(&run(&input.prt, 2));
        assert_eq!(rows1, rows2, "{name}: rows differ between 1 and 2 threads");
        let (_, reference_pairs) = rows_and_pairs(&run(&reference, 2));
        eprintln!("{name}: {pairs} pairs from the tree, {reference_pairs} from the compiler's .prt");
        assert!(
            pairs as f64 <= reference_pairs as f64 * 1.05,
            "{name}: {pairs} pairs from the tree, more than 1.05 x {reference_pairs}"
        );
    }
}

#[test]
fn see_through_water_sees_strictly_more_than_opaque_water() {
    let Some(path) = sightline_tests::shared_map("ericw/dm1.bsp") else { return };
    let pairs = |water| {
        let (input, stats) = VisInput::from_bsp_tree(
            &path,
            BspPortalOptions { liquids: water, ..BspPortalOptions::default() },
        )
        .expect("rebuild");
        (rows_and_pairs(&run(&input.prt, 2)).1, stats)
    };
    let (clear, clear_stats) = pairs(LiquidSight::Transparent);
    let (opaque, opaque_stats) = pairs(LiquidSight::Opaque);
    eprintln!("dm1: {clear} pairs with see-through liquids, {opaque} with opaque ones");
    assert_eq!(clear_stats.liquid_portals_dropped, 0);
    assert!(opaque_stats.liquid_portals_dropped > 0, "dm1 has water and lava surfaces");
    assert_eq!(clear_stats.portals, opaque_stats.portals + opaque_stats.liquid_portals_dropped);
    assert!(clear > opaque, "transparent liquids: {clear} pairs, opaque: {opaque}");
}

#[test]
fn an_external_vis_record_decodes_to_the_pvs_computed() {
    let Some(path) = sightline_tests::shared_map("ericw/dm1.bsp") else { return };
    let (input, _) = VisInput::from_bsp_tree(&path, BspPortalOptions::default()).expect("rebuild");
    let b = input.bsp.as_ref().expect("a .bsp input");
    let result = run(&input.prt, 2);
    let rows = Rows::new(&result);
    let record =
        visdata::vispatch_record("dm1.bsp", &b.bytes, &b.bsp, &result, &rows, &AmbientOptions::default())
            .expect("record");
    let two = VisPatchRecord { map_name: "other.bsp".into(), ..record.clone() };
    let back = vispatch::read(&vispatch::write(&[two, record.clone()]).expect("write")).expect("read");
    let found = vispatch::find(&back, "DM1.BSP").expect("found without regard to case");
    assert_eq!(*found, record);
    assert_eq!(found.num_leaves(), b.bsp.leaves.len(), "every leaf of the file, brush models' included");
    let visleafs = b.bsp.visleafs();
    let mut expected = Vec::new();
    for leaf in 1..=visleafs {
        result.leaf_row_bytes(leaf - 1, &mut expected);
        assert_eq!(found.decode_row(leaf, visleafs).expect("row"), expected, "leaf {leaf}");
    }
    // The record is what vis would write into the BSP: the same rows, offsets and ambient levels.
    let vised = visdata::write_into_bsp(&b.bytes, &b.bsp, &result, &rows).expect("write into bsp");
    let vised = bsp::read(&vised).expect("reads");
    assert_eq!(found.visdata, vised.visdata);
    // BSP2 maps get no record: engines load external .vis files for BSP29 only.
    let mut bsp2 = b.bsp.clone();
    bsp2.version = bsp::BspVersion::Bsp2;
    assert!(
        visdata::vispatch_record("dm1.bsp", &b.bytes, &bsp2, &result, &rows, &AmbientOptions::default())
            .is_err()
    );
}

#[test]
fn every_rebuilt_portal_joins_open_vis_leaves_of_its_map() {
    for dir in ["ericw", "id_bsp_orig"] {
        let Some(path) = sightline_tests::shared_map(&format!("{dir}/e1m1.bsp")) else { return };
        let file = bsp::read(&std::fs::read(&path).expect("read")).expect("bsp");
        let built = bsp_portals::build(&file, BspPortalOptions::default()).expect("rebuild");
        assert_eq!(built.prt.num_leaves as usize, file.visleafs());
        for p in &built.prt.portals {
            let contents = p.leaves.map(|l| file.leaves[l as usize + 1].contents);
            assert!(!contents.contains(&-2), "{dir}/e1m1: a portal into solid: {:?}", p.leaves);
            assert_eq!(
                contents[0] == -6,
                contents[1] == -6,
                "{dir}/e1m1: sky joins only sky: {:?}",
                p.leaves
            );
            assert!(p.winding.plane().is_some(), "{dir}/e1m1: a portal without a plane");
        }
        assert_eq!(
            built.stats.open_leaves,
            file.leaves[1..=file.visleafs()].iter().filter(|l| l.contents != -2).count()
        );
    }
}

#[test]
fn a_vised_bsp_keeps_its_detail_clusters() {
    // lqdm1 was compiled with detail: ericw-tools' PRT2 has 253 clusters, and its vis gave every
    // leaf of a cluster one row. Rebuilt from the vised file, the clusters come back, so vis runs
    // on as many cells as from the `.prt`, and the PVS stays within 5 % of ericw-tools' pairs.
    let (Some(vised), Some(prt_path)) =
        (sightline_tests::shared_map("ericw/lqdm1.vis.bsp"), sightline_tests::shared_map("ericw/lqdm1.prt"))
    else {
        return;
    };
    let (input, stats) = VisInput::from_bsp_tree(&vised, BspPortalOptions::default()).expect("rebuild");
    let reference =
        prt::read_bytes(&std::fs::read(&prt_path).expect("read .prt"), "lqdm1.prt").expect(".prt");
    assert_eq!(input.prt.format, prt::PrtFormat::Prt2);
    assert_eq!(stats.clusters, reference.num_clusters as usize);
    let (_, pairs) = rows_and_pairs(&run(&input.prt, 2));
    let (_, reference_pairs) = rows_and_pairs(&run(&reference, 2));
    eprintln!("lqdm1: {pairs} pairs from the vised tree's clusters, {reference_pairs} from the .prt");
    assert!(pairs as f64 <= reference_pairs as f64 * 1.05, "{pairs} against {reference_pairs}");
    // Every leaf on its own: more cells, fewer pairs.
    let (leaves, leaf_stats) = VisInput::from_bsp_tree(
        &vised,
        BspPortalOptions { no_clusters: true, ..BspPortalOptions::default() },
    )
    .expect("rebuild");
    assert_eq!(leaf_stats.clusters, leaf_stats.vis_leaves);
    assert_eq!(leaves.prt.format, prt::PrtFormat::Prt1);
}
