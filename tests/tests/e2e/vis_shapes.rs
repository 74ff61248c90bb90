//! Vis on `sightline_tests::shapes` and the open maps of `sightline_tests::heavy`, the inputs that
//! cost vis the most for their size, at sizes small enough for a test: the results are exact where
//! the answer is known (a straight corridor sees all of itself, also past the flow's depth limit)
//! and free of ray-sampled misses where it is not (a room around a many-sided pillar, a room of
//! tiny brushes, hilly terrain, a city, an arena: where flows enter portals again along other
//! routes and skip the frames those cover).

use sightline_compiler::vis::{self, VisOptions};
use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_tests::heavy::{arena, city, terrain};
use sightline_tests::shapes::{corridor_prt, pillar_room, tiny_brushes_room};
use sightline_validate::pvs::level_pvs;
use sightline_validate::{Options, OracleChoice, validate};

fn none() -> sightline_job::progress::NoProgress {
    sightline_job::progress::NoProgress
}

#[test]
fn a_straight_corridor_sees_all_of_itself_for_any_thread_count() {
    // Longer than the flow follows a chain, so the depth limit is crossed.
    let n = 300u32;
    let prt = corridor_prt(n);
    let one = vis::run(&prt, &VisOptions { threads: 1, ..VisOptions::default() }, &none()).expect("vis");
    assert_eq!(one.stats.visible_pairs, u64::from(n) * u64::from(n), "every leaf sees every other");
    let two = vis::run(&prt, &VisOptions { threads: 2, ..VisOptions::default() }, &none()).expect("vis");
    assert!((0..n as usize).all(|c| one.cluster_row(c) == two.cluster_row(c)));
}

fn compiled_level(text: &str, name: &str) -> sightline_formats::Level {
    let map = sightline_formats::map::parse(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
    let opts = CompileOptions {
        vis: Some(VisOptions { threads: 2, ..VisOptions::default() }),
        ..Default::default()
    };
    compile(&Source::Map { map, file: name.to_string() }, &opts, &NoProgress)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .level
}

/// Compile each map with vis and sample 300,000 rays with both oracles: no miss, and some pairs
/// sampled by each.
fn assert_no_sampled_misses(maps: &[(&str, String)]) {
    for (name, text) in maps {
        let level = compiled_level(text, name);
        assert!(level.has_vis(), "{name} has a PVS");
        let pvs = level_pvs(&level).unwrap_or_else(|e| panic!("{name}: {e}"));
        let opts = Options { rays: 300_000, oracle: OracleChoice::Both, ..Options::default() };
        let v = validate(&level, &pvs, &opts, &sightline_validate::NoProgress)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(v.report.misses(), 0, "{name}: {}", v.report.text());
        assert!(v.report.oracles.iter().all(|o| o.sampled_pairs > 0), "{name}: {}", v.report.text());
    }
}

#[test]
fn pillar_and_tiny_brush_rooms_have_no_sampled_misses() {
    assert_no_sampled_misses(&[
        ("pillar_40.map", pillar_room(40)),
        ("tiny_12.map", tiny_brushes_room(12, 5)),
    ]);
}

#[test]
fn open_maps_have_no_sampled_misses() {
    assert_no_sampled_misses(&[
        ("terrain_8.map", terrain(8, 3)),
        ("city_5.map", city(5, 3)),
        ("arena_5.map", arena(5)),
    ]);
}

#[test]
fn the_pillar_hides_the_far_side_of_its_ring() {
    // Around a pillar, a leaf's view is cut off behind the pillar: some leaves see fewer than
    // all, and no PVS row is looser than the base vis bound.
    let text = pillar_room(40);
    let map = sightline_formats::map::parse(&text, "pillar.map").unwrap();
    let out =
        compile(&Source::Map { map, file: "pillar.map".into() }, &CompileOptions::default(), &NoProgress)
            .expect("compiles");
    let prt = &out.prt;
    let full = vis::run(prt, &VisOptions { threads: 2, ..VisOptions::default() }, &none()).expect("vis");
    let fast =
        vis::run(prt, &VisOptions { threads: 2, fast: true, ..VisOptions::default() }, &none()).expect("vis");
    let n = prt.num_leaves as usize;
    assert!(n >= 40, "a leaf per side at least ({n})");
    for a in 0..n {
        for b in 0..n {
            assert!(!full.leaf_sees(a, b) || fast.leaf_sees(a, b), "{a} sees {b} beyond base vis");
            assert_eq!(full.leaf_sees(a, b), full.leaf_sees(b, a), "symmetric");
        }
    }
    assert!(full.stats.visible_pairs < (n * n) as u64, "the pillar hides something");
}
