//! Every binary reader, and the portal rebuild from a BSP tree, under thousands of mutations:
//! RLE rows, Quake 1, Quake 2, Quake 3 and Half-Life BSPs, external `.vis` packs, q3map2 and VHLT
//! portal files, `.slvl` levels and `.vis` files. None panics, and none allocates beyond its bound.

use sightline_formats::{bsp, prt, rle, slvl, visfile};
use sightline_job::rng::SplitMix64 as Rng;
use sightline_tests::mutate;

use super::{hammer, linear_bound, mutate_text, shared};

#[test]
fn rle_rows_survive_hostile_bytes() {
    let mut rng = Rng::new(1);
    let mut inputs = Vec::new();
    for _ in 0..20 {
        let row: Vec<u8> = (0..1 + rng.below(400))
            .map(|_| if rng.below(4) == 0 { rng.next_u64() as u8 } else { 0 })
            .collect();
        let mut packed = Vec::new();
        rle::encode_row(&row, &mut packed);
        inputs.push(packed);
    }
    let rejected = hammer(
        "rle",
        &inputs,
        300,
        2,
        |r, d| mutate(r, d, 8),
        linear_bound,
        |data| {
            // A row far longer than the input could fill is refused before anything is allocated.
            assert!(rle::decode_row_vec(data, usize::MAX / 2).is_err());
            rle::decode_row_vec(data, data.len() * 3).is_ok()
        },
    );
    assert!(rejected > 1000, "only {rejected} of 6000 mutated rows rejected");
}

#[test]
fn bsp_reader_survives_hostile_files() {
    let Some(vis) = shared("ericw/dm1.vis.bsp") else { return };
    let plain = shared("ericw/dm1.bsp").expect("dm1.bsp beside dm1.vis.bsp");
    let rejected = hammer(
        "bsp",
        &[vis, plain],
        1500,
        3,
        |r, d| mutate(r, d, bsp::HEADER_BYTES),
        linear_bound,
        |data| match bsp::read(data) {
            Ok(b) => {
                // A file that reads must answer every query without panicking.
                let _ = b.pvs_stats();
                // ...and convert to a level that passes `.slvl` validation.
                assert_eq!(slvl::validate(&bsp::to_level(&b)), Ok(()));
                let visofs: Vec<i32> = b.leaves.iter().map(|l| l.visofs).collect();
                let written = bsp::write_with_visdata(data, &b.visdata, &visofs, None);
                // The layout check vis runs before any work refuses what the writer cannot do.
                if bsp::check_vis_layout(&b.lumps).is_err() {
                    assert!(matches!(written, Err(bsp::BspError::Overlap { .. })), "{written:?}");
                }
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 1000, "only {rejected} of 3000 mutated BSPs rejected");
}

#[test]
fn bsp_portal_rebuild_survives_hostile_trees() {
    use sightline_compiler::bsp_portals::{self, BspPortalOptions};
    use sightline_compiler::vis::{self, VisOptions};
    let Some(plain) = shared("ericw/dm1.bsp") else { return };
    let lumps = bsp::read(&plain).expect("dm1 reads").lumps;
    // Mutations aimed at what the rebuild reads: nodes, planes, leaves and models.
    let targets =
        [bsp::lump::NODES, bsp::lump::PLANES, bsp::lump::LEAVES, bsp::lump::MODELS].map(|l| lumps[l]);
    let nasty: [u32; 8] =
        [0, u32::MAX, 0x8000_0000, 0x7f7f_ffff, 0x0080_0000, 0x4e6e_6b28, 0xcf00_0000, 0x7fff];
    let mut vised = 0;
    let mut built_ok = 0;
    let mut round = 0;
    let rejected = hammer(
        "bsp portals",
        &[plain],
        300,
        11,
        |r, d| {
            let mut out = d.to_vec();
            for _ in 0..1 + r.below(4) {
                let t = targets[r.below(targets.len())];
                let at = t.offset + r.below(t.length.max(1));
                match r.below(3) {
                    0 => out[at] ^= 1 << r.below(8),
                    1 => out[at] = r.next_u64() as u8,
                    _ => {
                        let at = (at & !3).min(out.len() - 4);
                        out[at..at + 4].copy_from_slice(&nasty[r.below(nasty.len())].to_le_bytes());
                    }
                }
            }
            out
        },
        linear_bound,
        |data| {
            let Ok(b) = bsp::read(data) else { return false };
            // Clusters from the stored rows on even rounds, every leaf its own on odd ones.
            round += 1;
            let opts = BspPortalOptions { no_clusters: round % 2 == 1, ..BspPortalOptions::default() };
            let Ok(built) = bsp_portals::build(&b, opts) else { return false };
            built_ok += 1;
            let n = built.prt.num_leaves;
            assert!(
                built.prt.portals.iter().all(|p| p.leaves.iter().all(|&l| l < n) && p.winding.len() >= 3)
            );
            // Vis on the first few rebuilt graphs: an answer or an error, never a panic.
            if vised < 4 {
                vised += 1;
                let _ = vis::run(
                    &built.prt,
                    &VisOptions { threads: 1, ..VisOptions::default() },
                    &sightline_job::progress::NoProgress,
                );
            }
            true
        },
    );
    assert!(rejected > 30, "only {rejected} of 300 mutated trees rejected");
    assert!(built_ok > 30, "only {built_ok} of 300 mutated trees rebuilt");
}

#[test]
fn external_vis_reader_survives_hostile_files() {
    use sightline_formats::vispatch;
    let leaves: Vec<u8> = (0..40u32)
        .flat_map(|i| {
            let mut leaf = [0u8; vispatch::LEAF_BYTES];
            leaf[4..8].copy_from_slice(&(if i == 0 { -1 } else { (i % 3) as i32 }).to_le_bytes());
            leaf
        })
        .collect();
    let record = |name: &str| vispatch::VisPatchRecord {
        map_name: name.into(),
        visdata: vec![0xff, 0x0f, 0, 3, 1],
        leaves: leaves.clone(),
    };
    let file = vispatch::write(&[record("e1m1.bsp"), record("e1m2.bsp")]).expect("write");
    let rejected = hammer(
        "external vis",
        &[file],
        2000,
        12,
        |r, d| mutate(r, d, vispatch::HEADER_BYTES + 8),
        linear_bound,
        |data| match vispatch::read(data) {
            Ok(records) => {
                for r in &records {
                    for leaf in 0..=r.num_leaves() {
                        let _ = r.decode_row(leaf, 39);
                    }
                }
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 1000, "only {rejected} of 2000 mutated external .vis files rejected");
}

#[test]
fn q2_bsp_reader_survives_hostile_files() {
    let (Some(small), Some(big)) = (shared("q2/q2_detail_leak_test.ericw.bsp"), shared("q2/dm2.ericw.bsp"))
    else {
        return;
    };
    let plain = shared("q2/q2_detail_leak_test.bsp").expect("q2_detail_leak_test.bsp");
    let reads = |name: &str, inputs: &[Vec<u8>], count: usize| {
        hammer(
            name,
            inputs,
            count,
            11,
            |r, d| {
                // Half of the mutations land in the visibility lump (counts, offsets, rows).
                if r.below(2) == 0
                    && let Ok(lumps) = bsp::q2::read_header(d)
                {
                    let v = lumps[bsp::q2::lump::VISIBILITY];
                    let mut out = d.to_vec();
                    let body = mutate(r, &d[v.offset..v.end()], 64);
                    out.splice(v.offset..v.end(), body);
                    return out;
                }
                mutate(r, d, bsp::q2::HEADER_BYTES)
            },
            linear_bound,
            |data| {
                // The Quake 1 reader names the format instead of misreading it.
                if bsp::q2::is_q2(data) {
                    assert!(matches!(bsp::read(data), Err(bsp::BspError::OtherGame { .. })));
                }
                match bsp::q2::read(data) {
                    Ok(b) => {
                        // A file the reader takes gives a level that passes `.slvl` validation.
                        assert_eq!(slvl::validate(&bsp::q2::to_level(&b)), Ok(()));
                        if let Some(vis) = &b.vis {
                            // Decompressing every row is bounded by the clusters, not the input;
                            // mutations keep the cluster count of a real file.
                            if vis.num_clusters * vis.row_bytes() <= 8 * data.len() {
                                let _ = vis.decode_all(bsp::q2::Q2Row::Pvs);
                                if bsp::q2::check_vis_layout(&b.lumps).is_ok() {
                                    let _ = sightline_compiler::phs::repair_phs(data);
                                }
                            }
                            let _ = bsp::q2::write_with_visibility(data, &vis.data);
                        }
                        true
                    }
                    Err(_) => false,
                }
            },
        )
    };
    let rejected = reads("q2 bsp", &[small, plain], 1000) + reads("q2 bsp (dm2)", &[big], 150);
    assert!(rejected > 600, "only {rejected} of 2150 mutated Quake 2 BSPs rejected");
}

#[test]
fn q3_bsp_reader_survives_hostile_files() {
    let (Some(vised), Some(plain)) = (shared("q3/fan.q3map2.bsp"), shared("q3/fan.bsp")) else { return };
    let rejected = hammer(
        "q3 bsp",
        &[vised, plain],
        600,
        12,
        |r, d| {
            // Half of the mutations land in the visibility lump (counts, rows).
            if r.below(2) == 0
                && let Ok((_, lumps)) = bsp::q3::read_header(d)
                && lumps[bsp::q3::lump::VISIBILITY].length > 0
            {
                let v = lumps[bsp::q3::lump::VISIBILITY];
                let mut out = d.to_vec();
                let body = mutate(r, &d[v.offset..v.end()], 8);
                out.splice(v.offset..v.end(), body);
                return out;
            }
            mutate(r, d, bsp::q3::HEADER_BYTES)
        },
        linear_bound,
        |data| match bsp::q3::read(data) {
            Ok(b) => {
                // What reads converts to a level that passes the level rules, and writes back.
                let level = bsp::q3::to_level(&b);
                if b.vis.as_ref().is_none_or(|v| v.num_clusters * v.num_clusters <= 64 * data.len()) {
                    let _ = slvl::validate(&level);
                }
                let lump = bsp::q3::vis_lump(0, &[]).expect("empty lump");
                let _ = bsp::q3::write_with_visibility(data, &lump);
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 300, "only {rejected} of 1200 mutated Quake 3 BSPs rejected");
}

#[test]
fn q3map2_prt_reader_survives_hostile_text() {
    let Some(fan) = shared("q3/fan.prt") else { return };
    let rejected = hammer(
        "q3map2 prt",
        &[fan],
        600,
        13,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| prt::read_bytes(data, "hostile.prt").is_ok(),
    );
    assert!(rejected > 300, "only {rejected} of 600 mutated q3map2 portal files rejected");
}

#[test]
fn half_life_bsp_and_vhlt_portal_files_survive_hostile_files() {
    let Some(plain) = shared("hl/lq_e0m1.sdhlt.bsp") else { return };
    let vised = shared("hl/lq_e0m1.sdhlt.vis.bsp").expect("lq_e0m1.sdhlt.vis.bsp");
    let rejected = hammer(
        "bsp30",
        &[plain, vised],
        800,
        31,
        |r, d| mutate(r, d, bsp::HEADER_BYTES),
        linear_bound,
        |data| match bsp::read(data) {
            Ok(b) => {
                let _ = b.pvs_stats();
                assert_eq!(slvl::validate(&bsp::to_level(&b)), Ok(()));
                true
            }
            Err(e) => {
                // Errors name the byte offset (or the header).
                assert!(e.to_string().starts_with("byte ") || e.to_string().contains("header"), "{e}");
                false
            }
        },
    );
    assert!(rejected > 250, "only {rejected} of 1600 mutated BSP30 files rejected");

    let counts = shared("hl/lq_e0m1.sdhlt.prt").expect("lq_e0m1.sdhlt.prt");
    let fixed = shared("hl/lq_e0m1.sdhlt.fixed.prt").expect("lq_e0m1.sdhlt.fixed.prt");
    let rejected = hammer(
        "vhlt prt",
        &[counts, fixed],
        300,
        32,
        |r, d| if r.below(2) == 0 { mutate_text(r, d).into_bytes() } else { mutate(r, d, 64) },
        linear_bound,
        |data| match prt::read_bytes(data, "hostile.prt") {
            Ok(f) => {
                // Whatever reads is consistent: it sniffs as its dialect, and a VHLT portal leaf
                // holds consecutive leaves.
                assert_eq!(prt::PrtFormat::of_text(&String::from_utf8_lossy(data)), Some(f.format));
                assert_eq!(f.leaf_clusters.len(), f.num_leaves as usize);
                assert!(f.leaf_clusters.windows(2).all(|w| w[0] <= w[1]));
                true
            }
            Err(e) => {
                assert!(e.to_string().starts_with("hostile.prt:"), "{e}");
                false
            }
        },
    );
    assert!(rejected > 200, "only {rejected} of 600 mutated VHLT portal files rejected");
}

/// `.slvl` files expand lz4 lumps: the reader allows all lumps together
/// `slvl::MAX_TOTAL_EXPANSION` times the file size plus 16 MiB, and parsed records take at most
/// a few times their bytes, so the bound is wider than for the other readers.
fn slvl_bound(len: usize) -> usize {
    8 * (slvl::MAX_TOTAL_EXPANSION as usize * len + (16 << 20))
}

#[test]
fn slvl_reader_survives_hostile_files() {
    let Some(vis) = shared("ericw/dm1.vis.bsp") else { return };
    let level = bsp::to_level(&bsp::read(&vis).expect("dm1 reads"));
    let inputs = [
        slvl::write(&level, &slvl::WriteOptions { compress: false }),
        slvl::write(&level, &slvl::WriteOptions { compress: true }),
    ];
    let header = slvl::HEADER_BYTES + slvl::LumpKind::ALL.len() * slvl::DIR_ENTRY_BYTES;
    let rejected = hammer(
        "slvl",
        &inputs,
        1500,
        4,
        |r, d| mutate(r, d, header),
        slvl_bound,
        |data| match slvl::read(data) {
            Ok(level) => {
                // A level that reads must answer PVS queries without panicking.
                let _ = level.pvs_stats();
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 2000, "only {rejected} of 3000 mutated .slvl files rejected");
}

/// A `.slvl` whose checksums were recomputed after the mutation reaches the record validation,
/// which checksums otherwise stop first.
#[test]
fn slvl_validation_survives_mutated_records() {
    let Some(vis) = shared("ericw/dm1.vis.bsp") else { return };
    let level = bsp::to_level(&bsp::read(&vis).expect("dm1 reads"));
    let raw = slvl::write(&level, &slvl::WriteOptions { compress: false });
    let entries = slvl::directory(&raw).expect("directory");
    let header = slvl::HEADER_BYTES + entries.len() * slvl::DIR_ENTRY_BYTES;
    let fix_checksums = |data: &mut Vec<u8>| {
        for (i, e) in entries.iter().enumerate() {
            let (start, end) = (e.offset as usize, (e.offset + e.length) as usize);
            let at = slvl::HEADER_BYTES + i * slvl::DIR_ENTRY_BYTES + 32;
            if end <= data.len() && at + 4 <= header {
                let sum = slvl::crc32(&data[start..end]).to_le_bytes();
                data[at..at + 4].copy_from_slice(&sum);
            }
        }
    };
    let rejected = hammer(
        "slvl records",
        std::slice::from_ref(&raw),
        1500,
        5,
        |r, d| {
            // Keep the header and directory intact so the mutation hits records.
            let mut body = mutate(r, &d[header..], 0);
            body.resize(d.len() - header, 0);
            let mut out = d[..header].to_vec();
            out.extend_from_slice(&body);
            fix_checksums(&mut out);
            out
        },
        slvl_bound,
        |data| slvl::read(data).is_ok(),
    );
    assert!(rejected > 500, "only {rejected} of 1500 mutated records rejected");
}

#[test]
fn vis_file_reader_survives_hostile_files() {
    let mut rng = Rng::new(12);
    let mut inputs = Vec::new();
    for _ in 0..10 {
        let leaves = 1 + rng.below(300);
        let row_bytes = leaves.div_ceil(8);
        let (mut data, mut offsets) = (Vec::new(), Vec::new());
        for _ in 0..leaves {
            offsets.push(data.len() as u32);
            let row: Vec<u8> =
                (0..row_bytes).map(|_| if rng.below(3) == 0 { rng.next_u64() as u8 } else { 0 }).collect();
            rle::encode_row(&row, &mut data);
        }
        inputs.push(visfile::write(row_bytes, &offsets, &data).expect("small file"));
    }
    let rejected = hammer(
        "vis file",
        &inputs,
        300,
        13,
        |r, d| mutate(r, d, visfile::HEADER_BYTES),
        linear_bound,
        |data| match visfile::read(data) {
            Ok(f) => {
                // Every row of a file that reads decodes or fails cleanly.
                for &o in &f.leaf_offsets {
                    let _ = rle::decode_row_vec(&f.data[o as usize..], f.row_bytes as usize);
                }
                true
            }
            Err(_) => false,
        },
    );
    assert!(rejected > 1500, "only {rejected} of 3000 mutated .vis files rejected");
}
