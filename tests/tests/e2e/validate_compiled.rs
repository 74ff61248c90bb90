//! `sightline validate` on levels our compiler builds from the bundled maps: no misses, and the
//! expected visibility facts hold in the sampled set.

use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_validate::pvs::level_pvs;
use sightline_validate::{Options, OracleChoice, validate};

fn compiled(name: &str) -> sightline_formats::Level {
    let path = sightline_tests::bundled_maps().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let map = sightline_formats::map::parse(&text, name).unwrap_or_else(|e| panic!("{e}"));
    let opts = CompileOptions { vis: Some(Default::default()), ..Default::default() };
    compile(&Source::Map { map, file: name.to_string() }, &opts, &NoProgress)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .level
}

#[test]
fn bundled_maps_compile_to_a_pvs_without_misses() {
    for name in [
        "two_rooms.map",
        "lbend.map",
        "stairs_pillars.map",
        "thin_leaf.map",
        "coplanar.map",
        "angled.map",
        "detail_water.map",
    ] {
        let level = compiled(name);
        assert!(level.has_vis(), "{name} has a PVS");
        let pvs = level_pvs(&level).unwrap();
        let opts = Options { rays: 400_000, oracle: OracleChoice::Both, ..Options::default() };
        let v = validate(&level, &pvs, &opts, &sightline_validate::NoProgress).unwrap();
        eprint!("{name}: {}", v.report.text());
        assert_eq!(v.report.misses(), 0, "{name}: {}", v.report.text());
        assert!(v.report.oracles.iter().all(|o| o.sampled_pairs > 0));
    }
}

/// `text` compiled with vis, as `name`.
fn compiled_text(text: &str, name: &str) -> sightline_formats::Level {
    let map = sightline_formats::map::parse(text, name).unwrap_or_else(|e| panic!("{e}"));
    let opts = CompileOptions { vis: Some(Default::default()), ..Default::default() };
    compile(&Source::Map { map, file: name.to_string() }, &opts, &NoProgress)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .level
}

/// Whether, in `level`'s PVS, the cluster at `from` sees the cluster at `to`.
fn sees(level: &sightline_formats::Level, from: [i64; 3], to: [i64; 3]) -> bool {
    let tree = sightline_validate::bsp::BspTree::new(level).expect("a world tree");
    let cluster = |p: [i64; 3]| {
        let p = glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        tree.cluster(tree.leaf_at(p)).expect("an open leaf") as usize
    };
    level_pvs(level).expect("a PVS").get(cluster(from), cluster(to))
}

/// Solid without drawn faces is solid to both oracles: a slab textured `skip` on every side across
/// a doorway hides each room from the other (as a `wall` slab does, unlike a `clip` one), and
/// validation reports no miss from either oracle and no pair only one of them finds (the mesh
/// oracle once saw through such a slab thinner than 8 units: 26 misses here). A pair both oracles
/// proved, cleared from the PVS, is still a miss of both.
#[test]
fn a_brush_without_faces_is_solid_to_both_oracles() {
    use sightline_tests::mapgen::{
        BLOCKED_ROOMS_HIDDEN as HIDDEN, BLOCKED_ROOMS_SEER as SEER, blocked_rooms,
    };
    for (blocker, blocks) in [("skip", true), ("wall", true), ("clip", false)] {
        let level = compiled_text(&blocked_rooms(blocker), &format!("{blocker}.map"));
        assert_eq!(sees(&level, SEER, HIDDEN), !blocks, "{blocker}: does the slab hide the rooms?");
        let pvs = level_pvs(&level).unwrap();
        let opts = Options { rays: 400_000, oracle: OracleChoice::Both, ..Options::default() };
        let v = validate(&level, &pvs, &opts, &sightline_validate::NoProgress).unwrap();
        let text = v.report.text();
        assert_eq!(v.report.misses(), 0, "{blocker}: {text}");
        let d = v.report.disagreement.expect("both oracles ran");
        assert_eq!((d.pairs_only_tree, d.pairs_only_mesh), (0, 0), "{blocker}: {text}");
        if blocker != "skip" {
            continue;
        }
        // A pair both oracles proved, off the diagonal, removed from the PVS: a miss of both.
        let (tree, mesh) = (v.sampled[0].last().unwrap(), v.sampled[1].last().unwrap());
        let n = pvs.len();
        let (a, b) = (0..n)
            .flat_map(|a| (0..n).map(move |b| (a, b)))
            .find(|&(a, b)| a != b && tree.get(a, b) && mesh.get(a, b))
            .expect("a proved pair");
        let mut cut = pvs.clone();
        cut.clear(a, b);
        let v = validate(&level, &cut, &opts, &sightline_validate::NoProgress).unwrap();
        for o in &v.report.oracles {
            let found: Vec<(u32, u32)> = o.misses.iter().map(|m| (m.from_cluster, m.to_cluster)).collect();
            assert_eq!(found, [(a as u32, b as u32)], "[{}] finds the cleared pair", o.oracle);
        }
    }
}
