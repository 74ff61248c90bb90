//! The mesh oracle: rays against the level's world faces in a BVH, independent of the tree's
//! solid leaves.
//!
//! A ray's free part ends at the first world-face triangle it hits. Liquid surfaces let sight
//! through, as Quake's vis does: faces whose two sides, probed 0.05 units off the face's middle,
//! are both leaves sight passes, and faces whose texture name starts with `*` unless one of
//! those sides is solid (SDHLT builds some `*` brushes as solid: Half-Life's start has a `*lava`
//! face over solid, which no vis sees through). Every other face, sky included, blocks
//! (conservative: fewer pairs, never a false miss). The open
//! leaves on the free part are found by walking the tree *through* solid leaves, so a solid sliver
//! the tree has but the geometry does not (no face on it) cannot stop the ray.
//!
//! What is solid is the tree's, as for the tree oracle: a run of solid leaves on the free part
//! stops the ray unless it is a **sliver**, a slab the ray enters and leaves through parallel
//! planes less than [`SLIVER`] units apart. So solid without drawn faces blocks here as in the
//! tree oracle: a brush textured `skip` on every side (solid, no faces), the corner of a solid
//! the ray only clips, the unfaced outside of a sky brush. The two oracles then disagree only
//! where the tree has a sliver the faces do not close.

use glam::{DVec3, Vec3};
use sightline_formats::texture::TextureKind;
use sightline_formats::{Contents, Face, Level};
use sightline_raycast::Bvh;

use super::bsp::{BspTree, Crossing};
use super::sample::RayOracle;

/// Why the world faces could not be turned into a mesh.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The level has no models.
    #[error("the models lump is empty: the level has no world model (model 0)")]
    NoWorldModel,
    /// The world model's face range lies outside the level's faces.
    #[error("world model's faces are out of range")]
    FacesOutOfRange,
    /// A face's corners lie outside the level's vertices.
    #[error("face {face} has corners out of range")]
    CornersOutOfRange {
        /// Face index.
        face: usize,
    },
    /// The world model has no face with three corners.
    #[error("the world has no faces to cast rays against")]
    NoFaces,
}

/// Thickest slab of solid leaves, between parallel planes, that the mesh oracle takes for a tree
/// artifact and sees through (world units, measured across the slab).
pub const SLIVER: f64 = 0.5;
/// Cosine below which the planes a ray enters and leaves a solid run through are not parallel.
const PARALLEL: f64 = 0.999;
/// Distance from a face at which its two sides are probed.
const FACE_PROBE: f64 = 0.05;
/// Step past a see-through face before casting again.
const PASS_STEP: f64 = 0.01;
/// Most see-through faces one ray passes.
const MAX_PASSES: usize = 64;

/// World faces as triangles in a BVH.
#[derive(Debug)]
pub struct MeshOracle<'a> {
    tree: &'a BspTree<'a>,
    bvh: Bvh,
    /// Per triangle: true when sight passes through it.
    see_through: Vec<bool>,
    length: f64,
}

/// Per-thread scratch of the mesh oracle.
#[derive(Debug, Default)]
pub struct MeshScratch {
    stack: Vec<(i32, f64, f64, DVec3)>,
    all: Vec<Crossing>,
}

impl<'a> MeshOracle<'a> {
    /// Triangulate the world model's faces (fans) and build the BVH.
    pub fn new(tree: &'a BspTree<'a>, length: f64) -> Result<Self, MeshError> {
        let level = tree.level();
        let mut triangles = Vec::new();
        let mut see_through = Vec::new();
        for (_, f, corners) in world_faces(level)? {
            let liquid_name =
                level.textures.get(f.texture as usize).is_some_and(|t| TextureKind::of(t).is_liquid());
            let [front, back] = face_sides(tree, f.plane, corners);
            let solid = |leaf: Option<usize>| {
                leaf.and_then(|l| level.leaves.get(l)).is_some_and(|l| l.contents == Contents::Solid)
            };
            let open = |leaf: Option<usize>| leaf.is_some_and(|l| tree.is_open(l));
            let through = (open(front) && open(back)) || (liquid_name && !solid(front) && !solid(back));
            for t in fan(corners) {
                triangles.push(t);
                see_through.push(through);
            }
        }
        if triangles.is_empty() {
            return Err(MeshError::NoFaces);
        }
        Ok(Self { tree, bvh: Bvh::build(&triangles), see_through, length })
    }

    /// Distance along the ray to the first blocking face (or the ray length).
    pub fn free_length(&self, origin: DVec3, dir: DVec3) -> f64 {
        let d = dir.as_vec3();
        let mut t = 0.0;
        for _ in 0..MAX_PASSES {
            let o = (origin + dir * t).as_vec3();
            match self.bvh.intersect(o, d, (self.length - t) as f32) {
                None => return self.length,
                Some(hit) => {
                    let at = t + f64::from(hit.t);
                    if !self.see_through.get(hit.triangle as usize).copied().unwrap_or(false) {
                        return at;
                    }
                    t = at + PASS_STEP;
                }
            }
        }
        t
    }
}

/// A world face: its index in the level's faces, the face, its corners.
pub(crate) type WorldFace<'a> = (usize, &'a Face, &'a [[f32; 3]]);

/// The world model's faces (model 0), in face order.
pub(crate) fn world_faces(level: &Level) -> Result<Vec<WorldFace<'_>>, MeshError> {
    let Some(world) = level.models.first() else { return Err(MeshError::NoWorldModel) };
    let first = world.first_face as usize;
    let faces = level.faces.get(first..first.saturating_add(world.num_faces as usize));
    let Some(faces) = faces else { return Err(MeshError::FacesOutOfRange) };
    faces
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let v0 = f.first_vertex as usize;
            match level.vertices.get(v0..v0.saturating_add(f.num_vertices as usize)) {
                Some(corners) => Ok((first + i, f, corners)),
                None => Err(MeshError::CornersOutOfRange { face: first + i }),
            }
        })
        .collect()
}

/// A face's triangles as a fan around its first corner (none for fewer than three corners).
pub(crate) fn fan(corners: &[[f32; 3]]) -> impl Iterator<Item = [Vec3; 3]> + '_ {
    (2..corners.len()).map(|k| [Vec3::from(corners[0]), Vec3::from(corners[k - 1]), Vec3::from(corners[k])])
}

/// The leaves just in front of and just behind the middle of a face ([`FACE_PROBE`] off it);
/// `None` for a face whose plane the level lacks.
fn face_sides(tree: &BspTree<'_>, plane: u32, corners: &[[f32; 3]]) -> [Option<usize>; 2] {
    let Some(p) = tree.level().planes.get(plane as usize) else { return [None; 2] };
    let n = DVec3::from(p.normal.map(f64::from));
    let centre =
        corners.iter().map(|c| DVec3::from(c.map(f64::from))).sum::<DVec3>() / corners.len().max(1) as f64;
    [Some(tree.leaf_at(centre + n * FACE_PROBE)), Some(tree.leaf_at(centre - n * FACE_PROBE))]
}

impl RayOracle for MeshOracle<'_> {
    type Scratch = MeshScratch;

    fn cast(&self, origin: DVec3, dir: DVec3, s: &mut MeshScratch, out: &mut Vec<Crossing>) {
        let free = self.free_length(origin, dir) - PASS_STEP;
        if free <= 0.0 {
            return;
        }
        s.all.clear();
        self.tree.trace_through(origin, origin + dir * free, &mut s.all, &mut s.stack);
        let unit = dir.normalize_or_zero();
        // The first crossing of the current run of solid leaves, if the ray is in one.
        let mut run: Option<Crossing> = None;
        for c in &s.all {
            let c = Crossing { t0: c.t0 * free, t1: c.t1 * free, ..*c };
            if !self.tree.is_open(c.leaf as usize) {
                run.get_or_insert(c);
                continue;
            }
            if let Some(entry) = run.take() {
                // Left the run through `c.normal`: a sliver only between parallel planes close
                // together; anything else is solid, as the tree oracle has it.
                let parallel = entry.normal.dot(c.normal) >= PARALLEL;
                let across = (c.t0 - entry.t0) * unit.dot(entry.normal).abs();
                if !(parallel && across < SLIVER) {
                    return;
                }
            }
            out.push(c);
        }
    }
}
