//! `sightline_tests::mapgen`: the generated text parses, every room is closed on all six sides,
//! and a flood fill from the player start never reaches the void but reaches every room.

use std::collections::{HashSet, VecDeque};

use glam::DVec3;
use sightline_formats::geom::Aabb;
use sightline_formats::map;
use sightline_tests::mapgen::{self, IBox, MapGenParams};

fn boxes_of(text: &str) -> (map::MapFile, Vec<Aabb>) {
    let parsed = map::parse(text, "generated.map").unwrap_or_else(|e| panic!("{e}"));
    let boxes: Vec<Aabb> = parsed.brushes().map(|b| b.bounds()).collect();
    (parsed, boxes)
}

/// True when some brush box is flush with face `axis`/`high` of `room` from outside and overlaps
/// that face's rectangle.
fn face_is_walled(room: &IBox, axis: usize, high: bool, boxes: &[Aabb]) -> bool {
    let plane = if high { room.hi[axis] } else { room.lo[axis] } as f64;
    boxes.iter().any(|b| {
        let flush =
            if high { (b.mins[axis] - plane).abs() < 1e-6 } else { (b.maxs[axis] - plane).abs() < 1e-6 };
        flush
            && (0..3)
                .filter(|&i| i != axis)
                .all(|i| b.mins[i] < room.hi[i] as f64 && b.maxs[i] > room.lo[i] as f64)
    })
}

#[test]
fn every_room_has_six_walls() {
    for params in [
        MapGenParams { rooms_x: 1, rooms_y: 1, storeys: 1, seed: 0 },
        MapGenParams { rooms_x: 4, rooms_y: 3, storeys: 2, seed: 42 },
        MapGenParams { rooms_x: 2, rooms_y: 5, storeys: 3, seed: 9 },
    ] {
        let text = mapgen::generate(&params);
        let layout = mapgen::layout(&params);
        let (parsed, boxes) = boxes_of(&text);
        assert_eq!(parsed.brushes().count(), layout.brushes.len());
        assert_eq!(
            parsed.entities.len(),
            2 + layout.rooms.len(),
            "worldspawn, player start, a light per room"
        );
        assert_eq!(layout.rooms.len() as u32, params.rooms_x * params.rooms_y * params.storeys);
        for room in &layout.rooms {
            for axis in 0..3 {
                for high in [false, true] {
                    assert!(
                        face_is_walled(room, axis, high, &boxes),
                        "{params:?}: room {room:?} axis {axis} high {high}"
                    );
                }
            }
        }
    }
}

#[test]
fn flood_from_the_player_stays_inside_and_reaches_every_room() {
    let params = MapGenParams { rooms_x: 3, rooms_y: 2, storeys: 2, seed: 5 };
    let text = mapgen::generate(&params);
    let layout = mapgen::layout(&params);
    let (parsed, boxes) = boxes_of(&text);
    let world = parsed.bounds();
    let start =
        parsed.entities.iter().find(|e| e.classname() == "info_player_start").and_then(|e| e.origin());
    let start = start.expect("a player start");
    // Cells of 16 units probed at their centres (16k + 8), never on a brush face.
    let cell = |p: DVec3| (p / 16.0).floor().as_ivec3();
    let centre = |c: glam::IVec3| c.as_dvec3() * 16.0 + DVec3::splat(8.0);
    let solid = |p: DVec3| boxes.iter().any(|b| b.contains_point(p, 0.0));
    assert!(!solid(start), "player start inside a brush");
    let mut seen = HashSet::from([cell(start)]);
    let mut queue = VecDeque::from([cell(start)]);
    while let Some(c) = queue.pop_front() {
        for d in [
            glam::IVec3::X,
            glam::IVec3::NEG_X,
            glam::IVec3::Y,
            glam::IVec3::NEG_Y,
            glam::IVec3::Z,
            glam::IVec3::NEG_Z,
        ] {
            let n = c + d;
            let p = centre(n);
            assert!(world.contains_point(p, 0.0), "flood escaped the map at {p}: not sealed");
            if !solid(p) && seen.insert(n) {
                queue.push_back(n);
            }
        }
    }
    for room in &layout.rooms {
        let c = DVec3::new(room.lo[0] as f64 + 24.0, room.lo[1] as f64 + 24.0, room.lo[2] as f64 + 24.0);
        assert!(seen.contains(&cell(c)), "room {room:?} not reached");
    }
}

#[test]
fn size_grows_with_the_parameters() {
    let brushes = |rx, ry, s| {
        let text = mapgen::generate(&MapGenParams { rooms_x: rx, rooms_y: ry, storeys: s, seed: 1 });
        map::parse(&text, "g.map").expect("parses").brushes().count()
    };
    let (small, medium, large) = (brushes(2, 2, 1), brushes(4, 4, 2), brushes(8, 8, 3));
    assert!(small < medium && medium < large, "{small} {medium} {large}");
}
