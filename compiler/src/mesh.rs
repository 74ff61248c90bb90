//! Triangle meshes (from `.obj`): a polygon BSP (thesis §4.2) so that meshes get leaves and
//! portals too.
//!
//! Each triangle's plane faces the side its front (counter-clockwise, OBJ's convention) looks at;
//! in front is empty space, behind is solid. A splitter is chosen among the planes of the polygons
//! in the node (at most [`MAX_CANDIDATES`] evenly spaced ones are scored by
//! `5·splits + |front − back|`, axial planes first on ties); polygons on the splitter's plane are
//! used up. A node without polygons is a leaf: empty when it is the front child of its parent (or
//! the root), solid when it is the back child. Meshes have no entities: no leak check, and every
//! non-solid leaf is kept.

use glam::DVec3;
use sightline_formats::geom::{ON_EPSILON, WORLD_LIMIT};
use sightline_formats::{Aabb, Contents, PlaneSet, Side, Winding};

use crate::brush::Brush;
use crate::bsp::{Tree, TreeNode};
use crate::csg::{CsgFace, Surface};
use crate::{CompileError, OUTSIDE_MARGIN, Prepared, Progress, Stats};

/// At most this many candidate planes are scored per node.
pub const MAX_CANDIDATES: usize = 32;

/// A triangle soup.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Triangles, counter-clockwise seen from their front (outside).
    pub triangles: Vec<[DVec3; 3]>,
    /// Faces of the source with one or two vertices, left out when it was read
    /// ([`sightline_formats::obj::TriMesh::skipped_faces`]); a compile reports them as a warning.
    pub skipped_faces: usize,
}

impl From<&sightline_formats::obj::TriMesh> for Mesh {
    /// The triangles of an `.obj` mesh, in file order (a triangle with an index out of range is
    /// left out), and its count of skipped faces.
    fn from(obj: &sightline_formats::obj::TriMesh) -> Self {
        Self {
            triangles: (0..obj.triangles.len()).filter_map(|i| obj.triangle(i)).collect(),
            skipped_faces: obj.skipped_faces,
        }
    }
}

#[derive(Debug, Clone)]
struct Poly {
    plane: u32,
    winding: Winding,
}

pub(crate) fn prepare(mesh: &Mesh, file: &str, progress: &dyn Progress) -> Result<Prepared, CompileError> {
    progress.begin("csg", mesh.triangles.len() as u64);
    let mut planes = PlaneSet::new();
    let mut polys = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        if t.iter().any(|p| !p.is_finite() || p.abs().max_element() > WORLD_LIMIT) {
            return Err(CompileError::HugeCoordinate {
                file: file.to_string(),
                line: 0,
                what: "a mesh vertex".to_string(),
            });
        }
        // Reverse to our clockwise-from-front order.
        let winding = Winding::new(vec![t[2], t[1], t[0]]);
        let Some(plane) = winding.plane() else { continue };
        if winding.area() < ON_EPSILON * ON_EPSILON {
            continue;
        }
        polys.push(Poly { plane: planes.insert(plane) as u32, winding });
    }
    progress.advance(mesh.triangles.len() as u64);
    let world = Aabb::from_points(polys.iter().flat_map(|p| p.winding.points.iter().copied()));
    if polys.is_empty() || world.is_empty() {
        return Err(CompileError::EmptyMesh { file: file.to_string() });
    }
    let bounds = world.expanded(OUTSIDE_MARGIN);
    let volume = Brush::from_box(&mut planes, &bounds, Contents::Empty);
    let faces: Vec<CsgFace> = polys
        .iter()
        .enumerate()
        .map(|(i, p)| CsgFace {
            plane: p.plane,
            winding: p.winding.clone(),
            surface: 0,
            brush: i as u32,
            contents: Contents::Solid,
        })
        .collect();
    let mut tree = Tree::default();
    build_r(&planes, polys, volume, Contents::Empty, &mut tree.nodes);
    let mut stats = Stats { brushes: 0, csg_faces: faces.len(), ..Stats::default() };
    if mesh.skipped_faces > 0 {
        stats.warnings.push(format!(
            "{file}: {} faces with fewer than 3 vertices skipped (points and lines have no area)",
            mesh.skipped_faces
        ));
    }
    Ok(Prepared {
        planes,
        structural: Vec::new(),
        world_faces: faces,
        submodels: Vec::new(),
        seeds: Vec::new(),
        entities: "{\n\"classname\" \"worldspawn\"\n}\n".to_string(),
        textures: vec!["mesh".to_string()],
        surfaces: vec![Surface { texture: 0, vectors: [[0.0; 4]; 2] }],
        stats,
        tree: Some((tree, bounds)),
        fill: false,
    })
}

/// The plane (oriented as the first polygon on it faces) to split by.
fn choose(planes: &PlaneSet, polys: &[Poly]) -> u32 {
    let mut candidates: Vec<u32> = Vec::new();
    for p in polys {
        if !candidates.iter().any(|&c| c & !1 == p.plane & !1) {
            candidates.push(p.plane);
            if candidates.len() >= MAX_CANDIDATES * 4 {
                break;
            }
        }
    }
    let step = candidates.len().div_ceil(MAX_CANDIDATES).max(1);
    let mut best = (i64::MAX, 1u8, candidates.first().copied().unwrap_or(polys[0].plane));
    for &c in candidates.iter().step_by(step) {
        let plane = planes.get(c as usize);
        let (mut front, mut back, mut splits) = (0i64, 0i64, 0i64);
        for p in polys {
            if p.plane & !1 == c & !1 {
                continue;
            }
            match p.winding.side(plane, ON_EPSILON) {
                Side::Front | Side::On => front += 1,
                Side::Back => back += 1,
                Side::Cross => {
                    splits += 1;
                    front += 1;
                    back += 1;
                }
            }
        }
        let score = 5 * splits + (front - back).abs();
        let axial = u8::from(!plane.kind().is_axial());
        if (score, axial) < (best.0, best.1) {
            best = (score, axial, c);
        }
    }
    best.2
}

fn build_r(
    planes: &PlaneSet,
    polys: Vec<Poly>,
    volume: Brush,
    empty_side: Contents,
    out: &mut Vec<TreeNode>,
) -> u32 {
    let index = out.len() as u32;
    let bounds = volume.bounds;
    if polys.is_empty() {
        out.push(TreeNode::Leaf { contents: empty_side, bounds });
        return index;
    }
    let chosen = choose(planes, &polys);
    // Split by the even plane of the pair; the chosen polygon's front (empty) side is the even
    // plane's front only when the chosen plane is even.
    let plane = chosen & !1;
    let (front_side, back_side) =
        if chosen == plane { (Contents::Empty, Contents::Solid) } else { (Contents::Solid, Contents::Empty) };
    let (vf, vb) = volume.split(planes, plane);
    let split_plane = planes.get(plane as usize);
    let mut front = Vec::new();
    let mut back = Vec::new();
    for p in polys {
        if p.plane & !1 == plane {
            continue;
        }
        let s = p.winding.split(split_plane, ON_EPSILON);
        if let Some(w) = s.front {
            front.push(Poly { plane: p.plane, winding: w });
        }
        if let Some(w) = s.back {
            back.push(Poly { plane: p.plane, winding: w });
        }
    }
    match (vf, vb) {
        (Some(vf), Some(vb)) => {
            out.push(TreeNode::Node { plane, children: [0, 0], bounds, detail: false });
            let f = build_r(planes, front, vf, front_side, out);
            let k = build_r(planes, back, vb, back_side, out);
            if let Some(TreeNode::Node { children, .. }) = out.get_mut(index as usize) {
                *children = [f, k];
            }
            index
        }
        // The plane misses the volume: only one side exists here.
        (Some(v), None) => build_r(planes, front, v, front_side, out),
        (None, Some(v)) => build_r(planes, back, v, back_side, out),
        (None, None) => {
            out.push(TreeNode::Leaf { contents: empty_side, bounds });
            index
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CompileOptions, NoProgress, Source, compile};

    /// A closed cube with inward-facing triangles: a room seen from inside.
    fn room() -> Mesh {
        let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) * 64.0;
        let quads = [
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)], // floor, up
            [c(0., 0., 1.), c(0., 1., 1.), c(1., 1., 1.), c(1., 0., 1.)], // ceiling, down
            [c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)], // x=0, +x
            [c(1., 0., 0.), c(1., 0., 1.), c(1., 1., 1.), c(1., 1., 0.)], // x=1, -x
            [c(0., 0., 0.), c(0., 0., 1.), c(1., 0., 1.), c(1., 0., 0.)], // y=0, +y
            [c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)], // y=1, -y
        ];
        let mut triangles = Vec::new();
        for q in quads {
            triangles.push([q[0], q[1], q[2]]);
            triangles.push([q[0], q[2], q[3]]);
        }
        Mesh { triangles, skipped_faces: 0 }
    }

    #[test]
    fn closed_room_mesh_makes_an_empty_cell_inside_solid() {
        let src = Source::Mesh { mesh: room(), file: "room.obj".into() };
        let out = compile(&src, &CompileOptions::default(), &NoProgress).expect("compiles");
        let level = &out.level;
        // The inside of the room is one empty leaf; the rest is solid.
        let open: Vec<_> = level.leaves.iter().filter(|l| l.contents != Contents::Solid).collect();
        assert_eq!(open.len(), 1, "{:?}", level.leaves);
        assert!(open[0].mins.iter().all(|&v| v.abs() < 1e-3));
        assert_eq!(level.faces.len(), 12);
        assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    }

    #[test]
    fn skipped_obj_faces_are_a_warning_and_change_nothing_else() {
        let plain = compile(
            &Source::Mesh { mesh: room(), file: "room.obj".into() },
            &CompileOptions::default(),
            &NoProgress,
        )
        .expect("compiles");
        let mesh = Mesh { skipped_faces: 3, ..room() };
        let out =
            compile(&Source::Mesh { mesh, file: "room.obj".into() }, &CompileOptions::default(), &NoProgress)
                .expect("compiles");
        assert_eq!(
            out.stats.warnings,
            ["room.obj: 3 faces with fewer than 3 vertices skipped (points and lines have no area)"]
        );
        assert_eq!(out.level, plain.level);
    }
}
