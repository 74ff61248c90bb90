//! The correctness gate: the whole-scene frame against the PVS-set frame, pixel by pixel.

use glam::DVec3;

use super::frame::{Frame, PixelHit, Rays};
use super::scene::LevelScene;

/// Most mismatches described in full in a [`GateReport`] (all are counted).
pub const MAX_LISTED: usize = 16;
/// A hit this close to the outline of its face (world units, or this fraction of its distance from
/// the eye when that is more) is a **graze**: the ray slips through the zero-width crack where the
/// face meets an occluder's edge, which vis rightly treats as closed.
pub const GRAZE: f64 = 0.01;
/// [`GRAZE`] as a fraction of the hit's distance from the eye (`f32` rounding of far hits).
pub const GRAZE_RELATIVE: f64 = 1e-5;

/// A pixel where the PVS set hides what the whole scene shows: a visibility bug.
#[derive(Debug, Clone, PartialEq)]
pub struct Mismatch {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// The whole scene's hit (the surface the eye sees there).
    pub full: PixelHit,
    /// The PVS set's hit (`None`: its ray hits nothing).
    pub pvs: Option<PixelHit>,
    /// The hit point of the whole scene's hit.
    pub point: [f64; 3],
    /// Leaf of the hit point, a hair back along the ray (the leaf the eye sees it from).
    pub point_leaf: usize,
    /// Cluster of that leaf (`None`: not in any cluster).
    pub point_cluster: Option<u32>,
    /// Clusters of the leaves listing the seen face.
    pub face_clusters: Vec<u32>,
    /// Distance from the hit point to the face's outline (world units).
    pub edge_distance: f64,
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = self.point;
        write!(
            f,
            "pixel ({}, {}): face {} (triangle {}) at ({:.1}, {:.1}, {:.1}), {:.3} units inside its outline, leaf {} cluster {}, listed by clusters {:?}; the PVS set shows {}",
            self.x,
            self.y,
            self.full.face,
            self.full.triangle,
            p[0],
            p[1],
            p[2],
            self.edge_distance,
            self.point_leaf,
            self.point_cluster.map_or("none".into(), |c| c.to_string()),
            self.face_clusters,
            match self.pvs {
                Some(h) => format!("face {} (triangle {}) farther away", h.face, h.triangle),
                None => "nothing".into(),
            }
        )
    }
}

/// The gate's verdict on one camera; `M` describes a mismatch ([`Mismatch`] on levels,
/// [`MeshMismatch`] on meshes).
#[derive(Debug, Clone, PartialEq)]
pub struct GateReport<M = Mismatch> {
    /// Pixels compared.
    pub pixels: usize,
    /// Pixels where both hit the same face (or nothing).
    pub same: usize,
    /// Pixels where different faces are hit at bit-equal distance (a shared edge; not a bug).
    pub ties: usize,
    /// Pixels where the seen face is missing from the PVS set but hit on its outline ([`GRAZE`]):
    /// not a bug (levels only).
    pub grazes: usize,
    /// Pixels where the PVS set hides the seen surface: the visibility bugs.
    pub mismatches: usize,
    /// The first [`MAX_LISTED`] mismatches, row-major.
    pub listed: Vec<M>,
}

impl<M> Default for GateReport<M> {
    fn default() -> Self {
        GateReport { pixels: 0, same: 0, ties: 0, grazes: 0, mismatches: 0, listed: Vec::new() }
    }
}

impl<M> GateReport<M> {
    /// True when no pixel differs other than by a tie.
    pub fn passed(&self) -> bool {
        self.mismatches == 0
    }
}

/// What the caller makes of a pixel whose seen face the reduced frame lacks.
enum Verdict<M> {
    /// Not a bug ([`GRAZE`]).
    Graze,
    /// A visibility bug, described when the listing still has room.
    Miss(Option<M>),
}

/// Count the pixels of `full` against `pvs`; `judge(pixel, full hit, pvs hit, describe)` rules on a
/// pixel whose faces differ at different distances (`describe`: the listing has room).
fn tally<M>(
    full: &Frame,
    pvs: &Frame,
    mut judge: impl FnMut(usize, &PixelHit, Option<PixelHit>, bool) -> Verdict<M>,
) -> GateReport<M> {
    let mut r = GateReport { pixels: full.hits.len(), ..GateReport::default() };
    for (i, (a, b)) in full.hits.iter().zip(&pvs.hits).enumerate() {
        match (a, b) {
            (None, None) => r.same += 1,
            (Some(a), Some(b)) if a.face == b.face => r.same += 1,
            (Some(a), Some(b)) if a.t == b.t => r.ties += 1,
            (None, Some(_)) => r.mismatches += 1, // impossible for a subset; counted, never listed
            (Some(a), b) => match judge(i, a, *b, r.listed.len() < MAX_LISTED) {
                Verdict::Graze => r.grazes += 1,
                Verdict::Miss(m) => {
                    r.mismatches += 1;
                    r.listed.extend(m);
                }
            },
        }
    }
    r
}

/// Compare the whole scene's frame with the PVS set's on the same rays; the eye cluster is the
/// caller's (reported beside this).
pub fn compare(scene: &LevelScene<'_>, rays: &Rays, full: &Frame, pvs: &Frame) -> GateReport {
    let width = rays.camera.width.max(1) as usize;
    tally(full, pvs, |i, a, b, describe| {
        let dir = rays.dirs[i].as_dvec3();
        let point = rays.camera.eye + dir * f64::from(a.t);
        let edge_distance = outline_distance(scene, a.face, point);
        if edge_distance <= GRAZE.max(GRAZE_RELATIVE * (point - rays.camera.eye).length()) {
            return Verdict::Graze;
        }
        Verdict::Miss(describe.then(|| {
            let tree = scene.tree();
            let back = point - dir.normalize_or_zero() * 0.05;
            let point_leaf = tree.leaf_at(back);
            Mismatch {
                x: (i % width) as u32,
                y: (i / width) as u32,
                full: *a,
                pvs: b,
                point: point.to_array(),
                point_leaf,
                point_cluster: tree.cluster(point_leaf),
                face_clusters: scene.face_clusters(a.face),
                edge_distance,
            }
        }))
    })
}

/// A pixel of a mesh whose whole-scene triangle is missing from the eye cell's set.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshMismatch {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// The whole scene's hit.
    pub full: PixelHit,
    /// The cell set's hit (`None`: its ray hits nothing).
    pub set: Option<PixelHit>,
    /// The hit point of the whole scene's hit.
    pub point: [f64; 3],
}

impl std::fmt::Display for MeshMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = self.point;
        write!(
            f,
            "pixel ({}, {}): triangle {} at ({:.2}, {:.2}, {:.2}) is missing from the cell set, which shows {}",
            self.x,
            self.y,
            self.full.triangle,
            p[0],
            p[1],
            p[2],
            match self.set {
                Some(h) => format!("triangle {} farther away", h.triangle),
                None => "nothing".into(),
            }
        )
    }
}

/// Compare a mesh's whole-scene frame with its cell set's on the same rays: every pixel whose
/// triangles differ at different distances is a mismatch (no graze: a mesh has no portals).
pub fn compare_mesh(rays: &Rays, full: &Frame, set: &Frame) -> GateReport<MeshMismatch> {
    let width = rays.camera.width.max(1) as usize;
    tally(full, set, |i, a, b, describe| {
        Verdict::Miss(describe.then(|| MeshMismatch {
            x: (i % width) as u32,
            y: (i / width) as u32,
            full: *a,
            set: b,
            point: (rays.camera.eye + rays.dirs[i].as_dvec3() * f64::from(a.t)).to_array(),
        }))
    })
}

/// Distance from `p` (on the face's plane) to the outline of face `face` (infinite for a face the
/// level lacks).
fn outline_distance(scene: &LevelScene<'_>, face: u32, p: DVec3) -> f64 {
    let level = scene.tree().level();
    let Some(f) = level.faces.get(face as usize) else { return f64::INFINITY };
    let first = f.first_vertex as usize;
    let Some(corners) = level.vertices.get(first..first + f.num_vertices as usize) else {
        return f64::INFINITY;
    };
    let c = |k: usize| DVec3::from(corners[k % corners.len()].map(f64::from));
    (0..corners.len())
        .map(|k| {
            let (a, b) = (c(k), c(k + 1));
            let e = b - a;
            let s = if e.length_squared() > 0.0 {
                ((p - a).dot(e) / e.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (a + e * s - p).length()
        })
        .fold(f64::INFINITY, f64::min)
}
