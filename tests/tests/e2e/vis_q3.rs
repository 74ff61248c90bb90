//! Quake 3 (`IBSP` 46) vis on the shared maps in `q3/`: only the visibility lump changes, the
//! PVS has no more pairs than q3map2's, ray sampling finds no miss, one and two threads write
//! the same bytes, and q3map2's portal orientation is the one vis assumes.

use std::path::{Path, PathBuf};
use std::time::Instant;

use sightline_compiler::dropin::{self, DropInOptions};
use sightline_compiler::vis::VisOptions;
use sightline_formats::bsp::q3;
use sightline_formats::prt;
use sightline_validate::{NoProgress, Options, OracleChoice, pvs::level_pvs, validate};

const MAPS: [&str; 2] = ["fan", "dm17ish"];

fn q3_map(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(&format!("q3/{name}"))
}

/// Copies `map.bsp` and `map.prt` into a fresh folder named by `tag`; returns the `.bsp`.
fn copy_in(map: &str, tag: &str) -> Option<PathBuf> {
    let (bsp, prt) = (q3_map(&format!("{map}.bsp"))?, q3_map(&format!("{map}.prt"))?);
    let dir = std::env::temp_dir().join(format!("sightline-vis-q3-{map}-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::copy(prt, dir.join(format!("{map}.prt"))).expect("copy .prt");
    let out = dir.join(format!("{map}.bsp"));
    std::fs::copy(bsp, &out).expect("copy .bsp");
    Some(out)
}

fn vis(bsp: &Path, threads: usize) -> Vec<u8> {
    let opts =
        DropInOptions { vis: VisOptions { threads, ..VisOptions::default() }, ..DropInOptions::default() };
    dropin::run(bsp, &opts, &NoProgress, Instant::now()).expect("vis");
    std::fs::read(bsp).expect("read back")
}

/// Every lump but visibility, by content.
fn other_lumps(bytes: &[u8]) -> Vec<Vec<u8>> {
    let (_, lumps) = q3::read_header(bytes).expect("header");
    (0..q3::NUM_LUMPS)
        .filter(|&i| i != q3::lump::VISIBILITY)
        .map(|i| bytes[lumps[i].offset..lumps[i].end()].to_vec())
        .collect()
}

#[test]
fn q3_vis_keeps_other_lumps_is_no_looser_than_q3map2_and_deterministic() {
    for map in MAPS {
        let (Some(one), Some(two)) = (copy_in(map, "t1"), copy_in(map, "t2")) else { return };
        let original = std::fs::read(&one).unwrap();
        let written = vis(&one, 1);
        assert_eq!(vis(&two, 2), written, "{map}: 1 and 2 threads write the same file");
        assert_eq!(other_lumps(&original), other_lumps(&written), "{map}: only lump 16 changes");
        let (old, new) = (q3::read(&original).unwrap(), q3::read(&written).unwrap());
        assert!(old.vis.is_none(), "{map}: the shared .bsp is unvised");
        let v = new.vis.as_ref().expect("visibility lump");
        assert_eq!(
            (v.num_clusters, v.cluster_bytes),
            (old.leaf_cluster_count(), q3::row_bytes_for(v.num_clusters))
        );
        for c in 0..v.num_clusters {
            assert!(v.sees(c, c), "{map}: cluster {c} sees itself");
            assert!(v.row(c)[v.num_clusters / 8..].iter().enumerate().all(|(k, &b)| {
                let first = (v.num_clusters / 8 + k) * 8;
                (0..8).all(|bit| first + bit < v.num_clusters || b & (1 << bit) == 0)
            }));
        }
        let reference =
            q3::read(&std::fs::read(q3_map(&format!("{map}.q3map2.bsp")).unwrap()).unwrap()).unwrap();
        let (ours, theirs) = (v.pairs(), reference.vis.as_ref().unwrap().pairs());
        eprintln!("{map}: PVS pairs {ours}, q3map2 {theirs} ({:.4})", ours as f64 / theirs as f64);
        assert!(ours <= theirs, "{map}: {ours} PVS pairs, more than q3map2's {theirs}");

        // Ray sampling against the tree (opaque leaves block) finds every sampled pair in the PVS.
        let level = q3::to_level(&new);
        let pvs = level_pvs(&level).unwrap();
        let opts = Options { rays: 100_000, oracle: OracleChoice::Tree, ..Options::default() };
        let report = validate(&level, &pvs, &opts, &NoProgress).unwrap().report;
        assert_eq!(report.misses(), 0, "{map}: {}", report.text());
        for dir in [&one, &two] {
            let _ = std::fs::remove_dir_all(dir.parent().unwrap());
        }
    }
}

#[test]
fn q3map2_portals_face_into_their_first_cluster() {
    // The convention vis relies on (as for PRT1): a point just in front of a portal's winding lies
    // in the first cluster it names, one just behind in the second.
    for map in MAPS {
        let (Some(bsp), Some(prt_path)) = (q3_map(&format!("{map}.bsp")), q3_map(&format!("{map}.prt")))
        else {
            return;
        };
        let file = q3::read(&std::fs::read(bsp).unwrap()).unwrap();
        let world = sightline_runtime::World::new(&q3::to_level(&file)).unwrap();
        let portals = prt::read_bytes(&std::fs::read(&prt_path).unwrap(), "q3.prt").unwrap();
        assert_eq!(portals.format, prt::PrtFormat::Q3map2);
        let mut checked = 0;
        for (i, p) in portals.portals.iter().enumerate() {
            let plane = p.winding.plane().expect("plane");
            let centre = p.winding.center();
            let cluster = |d: f64| {
                let q = (centre + plane.normal * d).as_vec3();
                world.leaf_cluster(world.leaf_at(q))
            };
            assert_eq!(cluster(0.5), Some(p.leaves[0]), "{map}: portal {i} front");
            assert_eq!(cluster(-0.5), Some(p.leaves[1]), "{map}: portal {i} back");
            checked += 1;
        }
        assert_eq!(checked, portals.portals.len());
    }
}

#[test]
fn the_runtime_loads_a_q3map2_bsp_with_its_cluster_pvs() {
    let Some(path) = q3_map("fan.q3map2.bsp") else { return };
    let file = q3::read(&std::fs::read(&path).unwrap()).unwrap();
    let vis = file.vis.as_ref().unwrap();
    let world = sightline_runtime::load::load_path(&path).unwrap();
    assert_eq!((world.num_clusters() as usize, world.has_vis()), (vis.num_clusters, true));
    let mut row = sightline_runtime::Bitset::new(0);
    let mut checked = 0;
    for (i, leaf) in file.leaves.iter().enumerate().filter(|(_, l)| l.cluster >= 0 && l.mins[0] <= l.maxs[0])
    {
        // The middle of a leaf's box lies in that leaf when the leaf is a box; check the others
        // through whatever leaf the point falls in.
        let mid = sightline_formats::geom::Aabb::new(
            glam::DVec3::from_array(leaf.mins.map(f64::from)),
            glam::DVec3::from_array(leaf.maxs.map(f64::from)),
        )
        .center()
        .as_vec3();
        let Some(c) = world.leaf_cluster(world.leaf_at(mid)) else { continue };
        world.decode_pvs(c, &mut row);
        for j in 0..vis.num_clusters {
            assert_eq!(row.get(j), vis.sees(c as usize, j), "leaf {i}: cluster {c} sees {j}");
        }
        checked += 1;
    }
    assert!(checked > 100, "only {checked} leaves checked");
}
