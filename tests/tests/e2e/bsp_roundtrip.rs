//! Quake BSP reading and visdata write-back on the ericw-tools outputs in `../shared/maps/ericw`.

use sightline_formats::bsp::{self, Bsp};
use sightline_formats::level::Contents;
use std::path::PathBuf;

/// `(map, average visible leaves, max visible leaves, visdata bytes)` of each full vis, as
/// ericw-tools' `vis` printed them (`../shared/reference/anchors.md`). One exception: anchors.md
/// lists 31,952 visdata bytes for dm2_nodetail, but the visibility lump of
/// `dm2_nodetail.vis.bsp` is 31,949 bytes (31,952 is that rounded up to Quake's 4-byte lump
/// alignment); the table holds the file's value.
const ANCHORS: [(&str, f64, usize, usize); 12] = [
    ("dm1", 84.1, 264, 11_403),
    ("dm2", 86.7, 236, 29_761),
    ("dm3", 89.2, 215, 22_296),
    ("start", 109.8, 290, 41_050),
    ("e1m1", 164.8, 401, 48_908),
    ("e1m2", 139.2, 274, 46_325),
    ("e1m3", 109.6, 272, 31_853),
    ("lqdm1", 701.2, 981, 22_408),
    ("lq_e0m1", 99.3, 200, 18_544),
    ("lq_e1m1", 582.6, 1330, 107_734),
    ("dm2_nodetail", 85.5, 238, 31_949),
    ("e1m1_nodetail", 154.7, 394, 57_406),
];

fn ericw() -> Option<PathBuf> {
    sightline_tests::shared_maps().map(|d| d.join("ericw"))
}

fn load(path: &std::path::Path) -> (Vec<u8>, Bsp) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let bsp = bsp::read(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (bytes, bsp)
}

fn rewrite_same(bytes: &[u8], bsp: &Bsp) -> Vec<u8> {
    let visofs: Vec<i32> = bsp.leaves.iter().map(|l| l.visofs).collect();
    let ambient: Vec<[u8; 4]> = bsp.leaves.iter().map(|l| l.ambient).collect();
    bsp::write_with_visdata(bytes, &bsp.visdata, &visofs, Some(&ambient)).expect("write back")
}

#[test]
fn every_ericw_bsp_reads_and_rewrites_identically() {
    let Some(dir) = ericw() else { return };
    let mut seen = 0;
    for (name, ..) in ANCHORS {
        for suffix in [".bsp", ".vis.bsp"] {
            let (bytes, bsp) = load(&dir.join(format!("{name}{suffix}")));
            assert_eq!(bsp.version, bsp::BspVersion::Bsp29, "{name}{suffix}");
            assert!(bsp.visleafs() > 0 && bsp.visleafs() < bsp.leaves.len(), "{name}{suffix}");
            assert_eq!(bsp.leaves[0].contents, Contents::Solid.code(), "{name}{suffix}: leaf 0 is solid");
            assert!(bsp.entities.contains("worldspawn"), "{name}{suffix}");
            assert!(rewrite_same(&bytes, &bsp) == bytes, "{name}{suffix}: write-back changed bytes");
            seen += 1;
        }
    }
    assert_eq!(seen, 24);
}

#[test]
fn vis_statistics_match_the_reference_compiler() {
    let Some(dir) = ericw() else { return };
    for (name, avg, max, bytes) in ANCHORS {
        let (_, bsp) = load(&dir.join(format!("{name}.vis.bsp")));
        let stats = bsp.pvs_stats().expect("rows decode").expect("has vis leaves");
        assert!((stats.avg_visible - avg).abs() <= 0.1, "{name}: average {} vs {avg}", stats.avg_visible);
        assert_eq!(stats.max_visible, max, "{name}: max visible");
        assert_eq!(stats.visdata_bytes, bytes, "{name}: visdata bytes");
    }
}

/// Writing the vis output's visdata into qbsp's output reproduces the vis output byte for byte:
/// the lumps after the visibility lump move, with Quake's alignment, and nothing else changes.
#[test]
fn writing_vis_output_into_qbsp_output_reproduces_it() {
    let Some(dir) = ericw() else { return };
    for name in ["dm1", "e1m1", "lqdm1"] {
        let (plain, plain_bsp) = load(&dir.join(format!("{name}.bsp")));
        let (vis, vis_bsp) = load(&dir.join(format!("{name}.vis.bsp")));
        assert!(plain_bsp.visdata.is_empty(), "{name}: qbsp output has no visdata");
        let visofs: Vec<i32> = vis_bsp.leaves.iter().map(|l| l.visofs).collect();
        let ambient: Vec<[u8; 4]> = vis_bsp.leaves.iter().map(|l| l.ambient).collect();
        let written =
            bsp::write_with_visdata(&plain, &vis_bsp.visdata, &visofs, Some(&ambient)).expect("write");
        assert!(written == vis, "{name}: differs from ericw's vis output");
        // And removing it again, with qbsp's leaf fields, gives back qbsp's file.
        let plain_visofs: Vec<i32> = plain_bsp.leaves.iter().map(|l| l.visofs).collect();
        let plain_ambient: Vec<[u8; 4]> = plain_bsp.leaves.iter().map(|l| l.ambient).collect();
        let back =
            bsp::write_with_visdata(&written, &[], &plain_visofs, Some(&plain_ambient)).expect("write");
        assert!(back == plain, "{name}: removing visdata does not restore qbsp's output");
    }
}

#[test]
fn decoded_rows_and_level_conversion_agree() {
    let Some(dir) = ericw() else { return };
    let (_, bsp) = load(&dir.join("dm1.vis.bsp"));
    let level = bsp::to_level(&bsp);
    assert_eq!(level.num_clusters as usize, bsp.visleafs());
    assert_eq!(level.pvs_offsets.len(), bsp.visleafs());
    assert_eq!(level.leaves.len(), bsp.leaves.len());
    assert_eq!(level.faces.len(), bsp.faces.len());
    for (i, leaf) in level.leaves.iter().enumerate() {
        let expected = if (1..=bsp.visleafs()).contains(&i) { i as i32 - 1 } else { -1 };
        assert_eq!(leaf.cluster, expected, "leaf {i}");
    }
    let mut row = vec![0; level.row_bytes()];
    for leaf in [1, 2, bsp.visleafs() / 2, bsp.visleafs()] {
        let from_bsp = bsp.decode_leaf_pvs(leaf).expect("row");
        let ofs = level.pvs_offsets[leaf - 1] as usize;
        sightline_formats::rle::decode_row(&level.pvs_data[ofs..], row.len(), &mut row).expect("level row");
        assert_eq!(from_bsp, row, "leaf {leaf}");
        // A leaf sees itself.
        assert_ne!(row[(leaf - 1) >> 3] & (1 << ((leaf - 1) & 7)), 0, "leaf {leaf} sees itself");
    }
    for face in &level.faces {
        assert!(face.num_vertices >= 3);
        // Corners lie on the face's plane, which the face is seen from.
        let plane = level.planes[face.plane as usize];
        for v in &level.vertices[face.first_vertex as usize..(face.first_vertex + face.num_vertices) as usize]
        {
            let d: f32 = (0..3).map(|k| plane.normal[k] * v[k]).sum::<f32>() - plane.dist;
            assert!(d.abs() < 0.1, "corner off its plane by {d}");
        }
    }
    // qbsp's output has no rows: the level has no PVS.
    let (_, plain) = load(&dir.join("dm1.bsp"));
    assert!(!bsp::to_level(&plain).has_vis());
}

/// Every ericw BSP becomes a level that passes `.slvl` validation and survives a `.slvl` round
/// trip, raw and compressed.
#[test]
fn levels_from_bsps_round_trip_through_slvl() {
    use sightline_formats::slvl::{self, WriteOptions};
    let Some(dir) = ericw() else { return };
    for (name, ..) in ANCHORS {
        for suffix in [".bsp", ".vis.bsp"] {
            let (bytes, bsp) = load(&dir.join(format!("{name}{suffix}")));
            let level = bsp::to_level(&bsp);
            assert_eq!(slvl::validate(&level), Ok(()), "{name}{suffix}");
            for compress in [false, true] {
                let file = slvl::write(&level, &WriteOptions { compress });
                assert!(slvl::read(&file).as_ref() == Ok(&level), "{name}{suffix}: compress {compress}");
                if compress {
                    // Compression must pay: the level holds the BSP's geometry minus lighting.
                    assert!(file.len() < bytes.len(), "{name}{suffix}: {} >= {}", file.len(), bytes.len());
                }
            }
        }
    }
}

#[test]
fn bsp2_and_rmq_read_like_bsp29() {
    let Some(dir) = ericw() else { return };
    let (bytes, bsp29) = load(&dir.join("dm1.vis.bsp"));
    for (rmq, version) in [(false, bsp::BspVersion::Bsp2), (true, bsp::BspVersion::Bsp2Rmq)] {
        let wide_bytes = sightline_tests::widen_bsp(&bytes, &bsp29, rmq);
        let wide = bsp::read(&wide_bytes).unwrap_or_else(|e| panic!("{version:?}: {e}"));
        assert_eq!(wide.version, version);
        assert_eq!(wide.nodes, bsp29.nodes, "{version:?}");
        assert_eq!(wide.leaves, bsp29.leaves, "{version:?}");
        assert_eq!(wide.faces, bsp29.faces, "{version:?}");
        assert_eq!(wide.edges, bsp29.edges, "{version:?}");
        assert_eq!(wide.marksurfaces, bsp29.marksurfaces, "{version:?}");
        assert_eq!(wide.pvs_stats(), bsp29.pvs_stats(), "{version:?}");
        assert_eq!(bsp::to_level(&wide), bsp::to_level(&bsp29), "{version:?}");
        // Visdata write-back works on the wide layouts too: drop the rows, then put them back.
        let visofs: Vec<i32> = wide.leaves.iter().map(|l| l.visofs).collect();
        let none: Vec<i32> = wide.leaves.iter().map(|_| -1).collect();
        let stripped = bsp::write_with_visdata(&wide_bytes, &[], &none, None).expect("strip");
        assert!(bsp::read(&stripped).expect("stripped reads").visdata.is_empty());
        let ambient: Vec<[u8; 4]> = wide.leaves.iter().map(|l| l.ambient).collect();
        let back =
            bsp::write_with_visdata(&stripped, &wide.visdata, &visofs, Some(&ambient)).expect("restore");
        assert!(back == wide_bytes, "{version:?}: strip then restore changed bytes");
    }
}
