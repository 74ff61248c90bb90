//! Face CSG: the drawn sides of brushes minus the parts buried in other brushes.
//!
//! A side of brush A loses the parts inside brush B when B hides it: B is solid or sky, or B has
//! A's own contents (water inside water). Subtraction splits the side by B's planes with
//! [`ON_EPSILON`]: pieces in front of any plane of B are outside B and survive.
//!
//! A liquid's surviving faces are also emitted facing into the liquid, so its surface shows from
//! both sides.
//!
//! Coplanar sides: where A's side lies on a side of B facing the **opposite** way, the two brushes
//! touch face to face and the side is hidden (both sides vanish). Where it lies on a side of B
//! facing the **same** way, the two faces overlap and exactly one survives: an opaque brush's face
//! wins over a liquid's, and between equals the brush listed first wins. So each spot of a plane
//! gets one face or none, whatever the thread count.

use rayon::prelude::*;
use sightline_formats::geom::ON_EPSILON;
use sightline_formats::{Contents, PlaneSet, Side, Winding};

use crate::brush::{Brush, NO_TEXTURE};

/// What a drawn side is drawn with (qbsp's texinfo): a texture and its projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
    /// Index into the level's textures.
    pub texture: u32,
    /// S and t texture vectors (see [`sightline_formats::map::TexAxes::vectors`]).
    pub vectors: [[f32; 4]; 2],
}

/// A brush as CSG sees it.
#[derive(Debug, Clone)]
pub struct CsgBrush {
    /// The brush with its side windings.
    pub brush: Brush,
    /// [`Surface`] index for each side of `brush.sides`, or [`NO_TEXTURE`] for sides never drawn.
    pub surfaces: Vec<u32>,
    /// Which model the brush belongs to: brushes only hide faces of their own model.
    pub model: u32,
    /// False for illusionary brushes: drawn, but they hide nothing.
    pub hides: bool,
}

/// A surviving piece of a drawn side.
#[derive(Debug, Clone)]
pub struct CsgFace {
    /// Plane index; the face is seen from the plane's front.
    pub plane: u32,
    /// Clockwise seen from the front.
    pub winding: Winding,
    /// Index of its [`Surface`].
    pub surface: u32,
    /// Index of the brush it came from.
    pub brush: u32,
}

fn opaque(c: Contents) -> bool {
    matches!(c, Contents::Solid | Contents::Sky)
}

fn hides(b: Contents, a: Contents) -> bool {
    opaque(b) || b == a
}

/// The faces of every brush in `brushes`, clipped by the others. Output order follows the input
/// (brush, then side, then piece), so it is the same for any thread count.
pub fn clip_faces(planes: &PlaneSet, brushes: &[CsgBrush]) -> Vec<CsgFace> {
    let per_brush: Vec<Vec<CsgFace>> = brushes
        .par_iter()
        .enumerate()
        .map(|(ai, a)| {
            let mut out = Vec::new();
            if a.brush.contents == Contents::Empty {
                return out;
            }
            let clippers: Vec<usize> = brushes
                .iter()
                .enumerate()
                .filter(|(bi, b)| {
                    *bi != ai
                        && b.model == a.model
                        && b.hides
                        && hides(b.brush.contents, a.brush.contents)
                        && b.brush.bounds.expanded(ON_EPSILON).intersects(&a.brush.bounds)
                })
                .map(|(bi, _)| bi)
                .collect();
            for (si, side) in a.brush.sides.iter().enumerate() {
                let surface = a.surfaces.get(si).copied().unwrap_or(NO_TEXTURE);
                if surface == NO_TEXTURE {
                    continue;
                }
                let mut pieces = vec![side.winding.clone()];
                for &bi in &clippers {
                    let b = &brushes[bi];
                    let bounds = side.winding.bounds().expanded(ON_EPSILON);
                    if !b.brush.bounds.intersects(&bounds) {
                        continue;
                    }
                    let b_wins = (opaque(b.brush.contents) && !opaque(a.brush.contents)) || bi < ai;
                    pieces = pieces
                        .into_iter()
                        .flat_map(|w| subtract(planes, w, side.plane, &b.brush, b_wins))
                        .collect();
                    if pieces.is_empty() {
                        break;
                    }
                }
                let liquid = matches!(a.brush.contents, Contents::Water | Contents::Slime | Contents::Lava);
                for winding in pieces {
                    // Liquid surfaces are seen from inside the liquid too, as in Quake.
                    let inside = liquid.then(|| CsgFace {
                        plane: side.plane ^ 1,
                        winding: winding.reversed(),
                        surface,
                        brush: ai as u32,
                    });
                    out.push(CsgFace { plane: side.plane, winding, surface, brush: ai as u32 });
                    out.extend(inside);
                }
            }
            out
        })
        .collect();
    per_brush.into_iter().flatten().collect()
}

/// The parts of `w` (on plane `plane`) outside brush `b`. A part lying on a side of `b` with the
/// same plane counts as outside unless `b_wins`.
fn subtract(planes: &PlaneSet, w: Winding, plane: u32, b: &Brush, b_wins: bool) -> Vec<Winding> {
    let mut outside = Vec::new();
    let mut rest = w;
    for s in &b.sides {
        let q = planes.get(s.plane as usize);
        if s.plane == plane {
            if b_wins {
                continue;
            }
            outside.push(rest);
            return outside;
        }
        if s.plane == plane ^ 1 {
            continue;
        }
        match rest.side(q, ON_EPSILON) {
            Side::Front | Side::On => {
                outside.push(rest);
                return outside;
            }
            Side::Back => {}
            Side::Cross => {
                let split = rest.split(q, ON_EPSILON);
                if let Some(f) = split.front {
                    outside.push(f);
                }
                match split.back {
                    Some(k) => rest = k,
                    None => return outside,
                }
            }
        }
    }
    outside
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use sightline_formats::Aabb;

    fn boxb(planes: &mut PlaneSet, lo: [f64; 3], hi: [f64; 3]) -> CsgBrush {
        let b = Brush::from_box(planes, &Aabb::new(DVec3::from(lo), DVec3::from(hi)), Contents::Solid);
        CsgBrush { surfaces: vec![0; b.sides.len()], brush: b, model: 0, hides: true }
    }

    fn area(faces: &[CsgFace]) -> f64 {
        faces.iter().map(|f| f.winding.area()).sum()
    }

    #[test]
    fn touching_boxes_hide_their_shared_faces() {
        let mut planes = PlaneSet::new();
        let a = boxb(&mut planes, [0.0; 3], [64.0; 3]);
        let b = boxb(&mut planes, [64.0, 0.0, 0.0], [128.0, 64.0, 64.0]);
        let faces = clip_faces(&planes, &[a, b]);
        // 2 boxes * 6 faces * 64² minus the two touching faces.
        assert!((area(&faces) - 10.0 * 4096.0).abs() < 1e-6, "{}", area(&faces));
    }

    #[test]
    fn overlapping_coplanar_faces_keep_exactly_one() {
        let mut planes = PlaneSet::new();
        let a = boxb(&mut planes, [0.0; 3], [64.0; 3]);
        let b = boxb(&mut planes, [32.0, 0.0, 0.0], [96.0, 64.0, 64.0]);
        let faces = clip_faces(&planes, &[a, b]);
        // The union is 96 x 64 x 64: its surface area, counted once.
        let expect = 2.0 * (96.0 * 64.0 * 2.0 + 64.0 * 64.0);
        assert!((area(&faces) - expect).abs() < 1e-6, "{} vs {expect}", area(&faces));
    }
}

#[cfg(test)]
mod proptests {
    use super::*;
    use glam::DVec3;
    use proptest::prelude::*;
    use sightline_formats::Aabb;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The faces left by CSG cover exactly the surface of the union of the boxes: their total
        /// area equals the union's surface area counted on a unit grid.
        #[test]
        fn faces_cover_the_union_surface_once(list in prop::collection::vec(
            (prop::array::uniform3(0i32..5), prop::array::uniform3(1i32..4)), 1..6)) {
            let mut planes = PlaneSet::new();
            let mut brushes = Vec::new();
            let mut grid = [[[false; 10]; 10]; 10];
            for (lo, size) in &list {
                let hi = [lo[0] + size[0], lo[1] + size[1], lo[2] + size[2]];
                let b = Brush::from_box(
                    &mut planes,
                    &Aabb::new(DVec3::from(lo.map(f64::from)), DVec3::from(hi.map(f64::from))),
                    Contents::Solid,
                );
                brushes.push(CsgBrush { surfaces: vec![0; b.sides.len()], brush: b, model: 0, hides: true });
                for x in lo[0]..hi[0] {
                    for y in lo[1]..hi[1] {
                        for z in lo[2]..hi[2] {
                            grid[x as usize][y as usize][z as usize] = true;
                        }
                    }
                }
            }
            let filled = |x: i32, y: i32, z: i32| {
                (0..10).contains(&x) && (0..10).contains(&y) && (0..10).contains(&z)
                    && grid[x as usize][y as usize][z as usize]
            };
            let mut surface = 0.0;
            for x in 0..10 {
                for y in 0..10 {
                    for z in 0..10 {
                        if !filled(x, y, z) {
                            continue;
                        }
                        for (dx, dy, dz) in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)] {
                            if !filled(x + dx, y + dy, z + dz) {
                                surface += 1.0;
                            }
                        }
                    }
                }
            }
            let faces = clip_faces(&planes, &brushes);
            let area: f64 = faces.iter().map(|f| f.winding.area()).sum();
            prop_assert!((area - surface).abs() < 1e-6, "faces {} vs surface {}", area, surface);
        }
    }
}
