//! Maps that reach the coordinate limit ([`WORLD_LIMIT`]) compile like any other: the outside
//! volume, a margin beyond the world, may lie beyond the limit.

use glam::DVec3;
use sightline_formats::geom::WORLD_LIMIT;

use crate::{CompileError, CompileOptions, NoProgress, Source, compile};

/// A box brush from `lo` to `hi`.
fn cuboid(lo: [i64; 3], hi: [i64; 3]) -> String {
    let ([x0, y0, z0], [x1, y1, z1]) = (lo, hi);
    format!(
        "{{\n( {x0} {y0} {z0} ) ( {x0} {y1} {z0} ) ( {x0} {y0} {z1} ) wall 0 0 0 1 1\n\
         ( {x1} {y0} {z0} ) ( {x1} {y0} {z1} ) ( {x1} {y1} {z0} ) wall 0 0 0 1 1\n\
         ( {x0} {y0} {z0} ) ( {x0} {y0} {z1} ) ( {x1} {y0} {z0} ) wall 0 0 0 1 1\n\
         ( {x0} {y1} {z0} ) ( {x1} {y1} {z0} ) ( {x0} {y1} {z1} ) wall 0 0 0 1 1\n\
         ( {x0} {y0} {z0} ) ( {x1} {y0} {z0} ) ( {x0} {y1} {z0} ) wall 0 0 0 1 1\n\
         ( {x0} {y0} {z1} ) ( {x0} {y1} {z1} ) ( {x1} {y0} {z1} ) wall 0 0 0 1 1\n}}\n"
    )
}

/// The six 16-unit walls around the open box `lo..hi` (the walls lie outside it), but `missing`.
fn room(lo: [i64; 3], hi: [i64; 3], missing: Option<usize>) -> String {
    let mut s = String::new();
    for axis in 0..3 {
        for side in 0..2 {
            if missing == Some(axis * 2 + side) {
                continue;
            }
            let (mut a, mut b) = ([lo[0] - 16, lo[1] - 16, lo[2] - 16], [hi[0] + 16, hi[1] + 16, hi[2] + 16]);
            if side == 0 {
                b[axis] = lo[axis];
            } else {
                a[axis] = hi[axis];
            }
            s += &cuboid(a, b);
        }
    }
    s
}

fn compile_text(brushes: &str, origin: DVec3) -> Result<(), CompileError> {
    let text = format!(
        "{{\n\"classname\" \"worldspawn\"\n{brushes}}}\n{{\n\"classname\" \"info_player_start\"\n\"origin\" \"{} {} {}\"\n}}\n",
        origin.x, origin.y, origin.z
    );
    let map = sightline_formats::map::parse(&text, "limit.map").expect("parses");
    compile(&Source::Map { map, file: "limit.map".into() }, &CompileOptions::default(), &NoProgress)
        .map(|_| ())
}

/// A sealed room near the origin plus one 16-unit cube whose farthest face lies at `extreme`
/// along each axis and sign.
#[test]
fn cube_near_the_limit_leaks_nowhere() {
    let limit = WORLD_LIMIT as i64;
    let inside = DVec3::new(128.0, 128.0, 24.0);
    for extreme in [999_000, 999_984, 999_985, 999_999, limit] {
        for axis in 0..3 {
            for sign in [1, -1] {
                let (mut lo, mut hi) = ([0, 0, 0], [16, 16, 16]);
                lo[axis] = if sign > 0 { extreme - 16 } else { -extreme };
                hi[axis] = if sign > 0 { extreme } else { -extreme + 16 };
                let brushes = room([0, 0, 0], [256, 256, 128], None) + &cuboid(lo, hi);
                let r = compile_text(&brushes, inside);
                assert!(r.is_ok(), "cube at {sign} * {extreme} on axis {axis}: {}", r.unwrap_err());
            }
        }
    }
}

/// Rooms whose walls touch the limit, in each corner of the world; with a wall missing the leak
/// is still found.
#[test]
fn rooms_touching_the_limit() {
    let limit = WORLD_LIMIT as i64;
    for corner in 0..8 {
        let sign = |axis: usize| if corner >> axis & 1 == 1 { 1 } else { -1 };
        let (mut lo, mut hi) = ([0; 3], [0; 3]);
        for axis in 0..3 {
            // The wall's outer face lies exactly at the limit.
            let (a, b) = if sign(axis) > 0 {
                (limit - 16 - 200, limit - 16)
            } else {
                (-limit + 16, -limit + 16 + 200)
            };
            lo[axis] = a;
            hi[axis] = b;
        }
        let centre = DVec3::new(
            (lo[0] + hi[0]) as f64 / 2.0,
            (lo[1] + hi[1]) as f64 / 2.0,
            (lo[2] + hi[2]) as f64 / 2.0,
        );
        let r = compile_text(&room(lo, hi, None), centre);
        assert!(r.is_ok(), "corner {corner}: {}", r.unwrap_err());
        for missing in 0..6 {
            let err = compile_text(&room(lo, hi, Some(missing)), centre).expect_err("a wall is missing");
            assert!(matches!(err, CompileError::Leak(_)), "corner {corner}, wall {missing}: {err}");
        }
    }
}

/// The reported case, and its real leak when the room's wall is gone.
#[test]
fn reported_cube_and_a_real_leak() {
    let inside = DVec3::new(128.0, 128.0, 24.0);
    let cube = cuboid([999_969, 0, 0], [999_985, 16, 16]);
    compile_text(&(room([0, 0, 0], [256, 256, 128], None) + &cube), inside).expect("sealed");
    let err = compile_text(&(room([0, 0, 0], [256, 256, 128], Some(1)) + &cube), inside).expect_err("leaks");
    assert!(matches!(err, CompileError::Leak(_)), "{err}");
}
