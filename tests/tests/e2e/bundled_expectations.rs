//! The expectations `maps/README.md` states for the bundled maps, checked on the compiled levels:
//! marked spots (`info_null` entities with a `targetname`) see, or do not see, each other.

use sightline_compiler::{CompileOptions, NoProgress, Source, compile, vis::VisOptions};
use sightline_runtime::{Bitset, World};

/// Compile a bundled map with full vis and return the runtime world and the marked spots.
fn compile_bundled(name: &str) -> (World, Vec<(String, glam::Vec3)>) {
    let path = sightline_tests::bundled_maps().join(name);
    let text = std::fs::read_to_string(&path).expect("bundled map readable");
    let file = path.display().to_string();
    let map = sightline_formats::map::parse(&text, &file).expect("bundled map parses");
    let marks = map
        .entities
        .iter()
        .filter(|e| e.classname() == "info_null")
        .filter_map(|e| Some((e.get("targetname")?.to_string(), e.origin()?.as_vec3())))
        .collect();
    let opts = CompileOptions { vis: Some(VisOptions::default()), ..CompileOptions::default() };
    let compiled = compile(&Source::Map { map, file }, &opts, &NoProgress).expect("bundled map compiles");
    let world = World::new(&compiled.level).expect("compiled level loads");
    (world, marks)
}

/// Does the cluster at mark `from` have the cluster at mark `to` in its PVS?
fn sees(world: &World, marks: &[(String, glam::Vec3)], from: &str, to: &str) -> bool {
    let at = |name: &str| {
        let p = marks.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("mark {name} missing")).1;
        let leaf = world.leaf_at(p);
        world.leaf_cluster(leaf).unwrap_or_else(|| panic!("mark {name} is not in an open world leaf"))
    };
    let (a, b) = (at(from), at(to));
    let mut row = Bitset::new(0);
    world.decode_pvs(a, &mut row);
    row.get(b as usize)
}

#[test]
fn two_rooms_all_see_each_other() {
    let (w, m) = compile_bundled("two_rooms.map");
    assert!(w.has_vis());
    for (a, b) in [("room_a", "corridor"), ("room_a", "room_b"), ("room_b", "corridor")] {
        assert!(sees(&w, &m, a, b), "{a} must see {b}");
        assert!(sees(&w, &m, b, a), "{b} must see {a}");
    }
}

#[test]
fn lbend_hides_the_far_room() {
    let (w, m) = compile_bundled("lbend.map");
    assert!(sees(&w, &m, "room_a", "corridor_east"));
    assert!(sees(&w, &m, "corridor_east", "corridor_north"));
    assert!(!sees(&w, &m, "room_a", "room_c"), "room_a must not see room_c round the bend");
    assert!(!sees(&w, &m, "room_c", "room_a"), "room_c must not see room_a round the bend");
}

#[test]
fn thin_gap_and_nearly_coplanar_portals_do_not_block_sight() {
    for map in ["thin_leaf.map", "coplanar.map"] {
        let (w, m) = compile_bundled(map);
        assert!(sees(&w, &m, "room_a", "room_b"), "{map}: room_a must see room_b");
        assert!(sees(&w, &m, "room_b", "room_a"), "{map}: room_b must see room_a");
    }
}

#[test]
fn pillars_do_not_hide_the_hall() {
    let (w, m) = compile_bundled("stairs_pillars.map");
    assert!(sees(&w, &m, "stairs_top", "behind_pillars"));
    assert!(sees(&w, &m, "behind_pillars", "stairs_top"));
}
