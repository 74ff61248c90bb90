//! Triangle meshes (from `.obj`): a polygon BSP (thesis §4.2) so that meshes get leaves and
//! portals too.
//!
//! Each triangle's plane faces the side its front (counter-clockwise, OBJ's convention) looks at;
//! in front is empty space, behind is solid. A splitter is chosen among the planes of the polygons
//! in the node (at most `MAX_CANDIDATES` evenly spaced ones are scored by
//! `5·splits + |front − back|`, axial planes first on ties); polygons on the splitter's plane are
//! used up. A node without polygons is a leaf: empty when it is the front child of its parent (or
//! the root), solid when it is the back child. That is only a guess for a mesh that is not closed
//! and consistently oriented; `seal` checks it once the portals exist and opens every solid cell
//! the triangles do not enclose (warning with where), so a polygon soup never blocks sight its
//! triangles do not block.
//!
//! The level's world ends [`OUTSIDE_MARGIN`] units beyond the triangles: the tree starts with six
//! nodes on the faces of that box whose outer children are solid (as a map's filled outside), so no
//! leaf reaches past it and a line leaving the box never comes back. The tree's volume is twice the
//! margin beyond the triangles, so those outer cells have a volume too. Meshes have no entities: no
//! leak check, and every non-solid leaf is kept.
//!
//! A triangle is two-sided: its faces are handed to emit in both orientations, and emit keeps each
//! one that borders an open leaf (one of a closed mesh's, both of a triangle standing in the open).

use glam::DVec3;
use sightline_formats::geom::{ON_EPSILON, WORLD_LIMIT};
use sightline_formats::{Aabb, Contents, Plane, PlaneSet, Side, Winding};
use sightline_job::cancel::Cancel;
use sightline_job::progress::{Progress, phase};

use crate::brush::Brush;
use crate::bsp::{Tree, TreeNode};
use crate::csg::{CsgFace, Surface};
use crate::error::CompileError;
use crate::prepared::{OUTSIDE_MARGIN, Prepared};
use crate::report::Stats;

mod box_tree;
mod cover;
mod edges;
mod seal;

/// At most this many candidate planes are scored per node.
pub(crate) const MAX_CANDIDATES: usize = 32;

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

/// The prepared mesh and its tree. Once `cancel` is set, the polygon BSP stops splitting (its
/// unsplit nodes become leaves): the caller checks `cancel` and discards the result.
pub(crate) fn prepare(
    mesh: &Mesh,
    file: &str,
    progress: &dyn Progress,
    cancel: &Cancel,
) -> Result<(Prepared, MeshTree), CompileError> {
    let csg = phase(progress, "csg", mesh.triangles.len() as u64);
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
    csg.advance(mesh.triangles.len() as u64);
    let world = Aabb::from_points(polys.iter().flat_map(|p| p.winding.points.iter().copied()));
    if polys.is_empty() || world.is_empty() {
        return Err(CompileError::EmptyMesh { file: file.to_string(), triangles: mesh.triangles.len() });
    }
    let inner = world.expanded(OUTSIDE_MARGIN);
    let volume_box = world.expanded(2.0 * OUTSIDE_MARGIN);
    let volume = Brush::from_box(&mut planes, &volume_box, Contents::Empty);
    let mut sides = Vec::with_capacity(6);
    for axis in 0..3 {
        let n = DVec3::AXES[axis];
        sides.push(planes.insert(Plane { normal: n, dist: inner.maxs[axis] }) as u32);
        sides.push(planes.insert(Plane { normal: -n, dist: -inner.mins[axis] }) as u32);
    }
    let mut cover = seal::Cover::default();
    let mut faces = Vec::with_capacity(2 * polys.len());
    for (i, p) in polys.iter().enumerate() {
        cover.add(p.plane, p.winding.clone());
        let face = |plane: u32, winding: Winding| CsgFace { plane, winding, surface: 0, brush: i as u32 };
        faces.push(face(p.plane, p.winding.clone()));
        faces.push(face(p.plane ^ 1, p.winding.reversed()));
    }
    let mut tree = Tree::default();
    enclose(&planes, polys, volume, &sides, &mut tree.nodes, &mut cover.boundary, cancel);
    let mut stats = Stats { brushes: 0, csg_faces: faces.len(), ..Stats::default() };
    if mesh.skipped_faces > 0 {
        stats.warnings.push(format!(
            "{file}: {} faces with fewer than 3 vertices skipped (points and lines have no area)",
            mesh.skipped_faces
        ));
    }
    let open = edges::open_edges(mesh.triangles.iter());
    if let Some((a, b)) = open.first {
        stats.warnings.push(format!(
            "{file}: the mesh is not closed: {} edges belong to one triangle only, within {} to {} \
             (the first from {} to {}); space behind its triangles stays solid only where they enclose it",
            open.count,
            point(open.bounds.mins),
            point(open.bounds.maxs),
            point(a),
            point(b)
        ));
    }
    let prep = Prepared {
        planes,
        structural: Vec::new(),
        world_faces: faces,
        submodels: Vec::new(),
        seeds: Vec::new(),
        entities: "{\n\"classname\" \"worldspawn\"\n}\n".to_string(),
        textures: vec!["mesh".to_string()],
        surfaces: vec![Surface { texture: 0, vectors: [[0.0; 4]; 2] }],
        stats,
        visclusters: Vec::new(),
        fill: false,
    };
    Ok((prep, MeshTree { tree, volume: volume_box, world, cover }))
}

/// A mesh's tree before [`seal`] checks its solid cells.
#[derive(Debug)]
pub(crate) struct MeshTree {
    /// The tree: six box nodes, then the polygon BSP.
    pub tree: Tree,
    /// The tree's volume (twice [`OUTSIDE_MARGIN`] beyond the triangles).
    pub volume: Aabb,
    /// The triangles' bounds.
    pub world: Aabb,
    /// The triangles by plane and the box's solid cells.
    pub cover: seal::Cover,
}

/// `(x y z)` with at most two decimals, for messages.
pub(crate) fn point(p: DVec3) -> String {
    let r = |v: f64| (v * 100.0).round() / 100.0 + 0.0;
    format!("({} {} {})", r(p.x), r(p.y), r(p.z))
}

/// Nodes on `sides` (plane indices facing out of the mesh's box), each with a solid outer child
/// whose tree index goes to `boundary`, above the polygon BSP of `polys` (all inside the box).
fn enclose(
    planes: &PlaneSet,
    polys: Vec<Poly>,
    volume: Brush,
    sides: &[u32],
    out: &mut Vec<TreeNode>,
    boundary: &mut Vec<u32>,
    cancel: &Cancel,
) -> u32 {
    let Some((&side, rest)) = sides.split_first() else {
        return build_r(planes, polys, volume, Contents::Empty, out, cancel);
    };
    let plane = side & !1;
    let (Some(front), Some(back)) = volume.split(planes, plane) else {
        // The volume lies a margin beyond the box on every side, so this plane always cuts it.
        return enclose(planes, polys, volume, rest, out, boundary, cancel);
    };
    let index = out.len() as u32;
    out.push(TreeNode::Node { plane, children: [0, 0], bounds: volume.bounds, detail: false });
    fn solid(bounds: Aabb, out: &mut Vec<TreeNode>, boundary: &mut Vec<u32>) -> u32 {
        boundary.push(out.len() as u32);
        out.push(TreeNode::Leaf { contents: Contents::Solid, bounds });
        out.len() as u32 - 1
    }
    // Pre-order with the front child first.
    let children = if side == plane {
        let f = solid(front.bounds, out, boundary);
        [f, enclose(planes, polys, back, rest, out, boundary, cancel)]
    } else {
        let f = enclose(planes, polys, front, rest, out, boundary, cancel);
        [f, solid(back.bounds, out, boundary)]
    };
    if let Some(TreeNode::Node { children: c, .. }) = out.get_mut(index as usize) {
        *c = children;
    }
    index
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
    cancel: &Cancel,
) -> u32 {
    let index = out.len() as u32;
    let bounds = volume.bounds;
    if polys.is_empty() || cancel.is_cancelled() {
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
            let f = build_r(planes, front, vf, front_side, out, cancel);
            let k = build_r(planes, back, vb, back_side, out, cancel);
            if let Some(TreeNode::Node { children, .. }) = out.get_mut(index as usize) {
                *children = [f, k];
            }
            index
        }
        // The plane misses the volume: only one side exists here.
        (Some(v), None) => build_r(planes, front, v, front_side, out, cancel),
        (None, Some(v)) => build_r(planes, back, v, back_side, out, cancel),
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

    /// Cover tests and triangles of a compile of `obj` text.
    fn cover_tests(obj: &str) -> (u64, usize) {
        let tri = sightline_formats::obj::load_from_bytes(obj.as_bytes(), "shape.obj").expect("loads");
        let src = Source::Mesh { mesh: (&tri).into(), file: "shape.obj".into() };
        let opts = CompileOptions { vis: None, ..CompileOptions::default() };
        let out = compile(&src, &opts, &NoProgress).expect("compiles");
        (out.stats.cover_tests, tri.triangles.len())
    }

    #[test]
    fn the_seal_check_grows_near_linearly_with_coplanar_triangles() {
        use sightline_tests::coplanar::{Floor, grid_obj, polygon_obj, prism_obj, room_obj, scattered_obj};
        // Every portal on a plane was once tested against every triangle on it, and every leftover
        // piece cut by every later triangle: the work grew with the cube of the triangles. Now it
        // grows no faster than n log n from n to 4n, and stays within a few tests a triangle.
        type Shape = (&'static str, fn(u32) -> String);
        let shapes: [Shape; 8] = [
            ("polygon", polygon_obj),
            ("prism", prism_obj),
            ("scattered", |n| scattered_obj(n, 1)),
            ("grid", grid_obj),
            ("room grid", |n| room_obj(Floor::Grid, n)),
            ("room shuffled", |n| room_obj(Floor::Shuffled(1), n)),
            ("room crossed strips", |n| room_obj(Floor::CrossedStrips, n)),
            ("room fan", |n| room_obj(Floor::Fan, n)),
        ];
        let n = 150u32;
        let log_growth = 4.0 * f64::from(4 * n).log2() / f64::from(n).log2();
        for (name, make) in shapes {
            let (small, small_tris) = cover_tests(&make(n));
            let (large, large_tris) = cover_tests(&make(4 * n));
            assert!(
                large as f64 <= log_growth * small as f64 + 16.0,
                "{name}: {small} tests for {small_tris} triangles, {large} for {large_tris}"
            );
            assert!(large <= 8 * large_tris as u64, "{name}: {large} tests for {large_tris} triangles");
            if name.starts_with("room") || name == "prism" {
                // Closed: the covered portals' triangles are all looked at.
                assert!(large >= large_tris as u64 / 2, "{name}: {large} tests for {large_tris} triangles");
            }
        }
    }
}
