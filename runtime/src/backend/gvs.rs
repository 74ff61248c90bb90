//! The GVS backend: the faces guided visibility sampling found visible from the eye's view cell
//! (`Level::gvs_cells` / `gvs_faces`, written by `sightline gvs`), frustum-culled per face box and
//! sorted front to back by the distance from the eye to the face box.
//!
//! The cells and face boxes are not part of [`World`], so this backend is a value built from the
//! [`Level`] ([`Gvs::from_level`]) rather than a unit struct in [`super::all`].
//!
//! # Conventions
//! - The eye's cell is the first cell whose box contains it (boxes are closed); outside every cell,
//!   the nearest cell by distance to its box (the first of equals). No cells: nothing visible.
//! - `Visible::leaves` stays empty: GVS cells are not leaves. `Visible::faces` holds face indices of
//!   the level, each once.
//! - Like every GVS result, the face set is aggressive: it may miss faces seen only through tiny
//!   gaps (see the `tools` GVS documentation for the measured error).

use glam::Vec3A;
use sightline_formats::level::Level;
use thiserror::Error;

use crate::backend::Backend;
use crate::camera::{BoxSide, Frustum, View};
use crate::scratch::{Scratch, Visible};
use crate::world::{Bounds, World};

/// Why a level's GVS data cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum GvsError {
    /// A cell's face range lies outside `gvs_faces`.
    #[error("gvs cell {cell}: faces {first}..+{count} outside the {len} gvs_faces")]
    CellRange {
        /// Cell index.
        cell: usize,
        /// First face entry.
        first: u32,
        /// Entry count.
        count: u32,
        /// Length of `gvs_faces`.
        len: usize,
    },
    /// A face index or its corners are out of range, or a bound is not finite.
    #[error("gvs face entry {entry}: {detail}")]
    Face {
        /// Entry in `gvs_faces`.
        entry: usize,
        /// What is wrong.
        detail: String,
    },
}

/// A view cell with its slice of [`Gvs::faces`].
#[derive(Debug, Clone, Copy)]
struct Cell {
    mins: Vec3A,
    maxs: Vec3A,
    first: u32,
    count: u32,
}

/// The GVS backend (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct Gvs {
    cells: Vec<Cell>,
    faces: Vec<u32>,
    /// Box of every face of the level (indexed by face).
    face_bounds: Vec<Bounds>,
}

impl Gvs {
    /// Build from a level's GVS lumps, checking every index.
    pub fn from_level(level: &Level) -> Result<Gvs, GvsError> {
        let mut face_bounds = Vec::with_capacity(level.faces.len());
        for (i, f) in level.faces.iter().enumerate() {
            let first = f.first_vertex as usize;
            let vs = level.vertices.get(first..first.saturating_add(f.num_vertices as usize));
            let Some(vs) = vs.filter(|v| !v.is_empty()) else {
                return Err(GvsError::Face { entry: i, detail: format!("face {i} corners out of range") });
            };
            let mut lo = Vec3A::INFINITY;
            let mut hi = Vec3A::NEG_INFINITY;
            for v in vs {
                let p = Vec3A::from_array(*v);
                lo = lo.min(p);
                hi = hi.max(p);
            }
            if !(lo.is_finite() && hi.is_finite()) {
                return Err(GvsError::Face { entry: i, detail: format!("face {i} has non-finite corners") });
            }
            face_bounds.push(Bounds::from_min_max(lo, hi));
        }
        let mut cells = Vec::with_capacity(level.gvs_cells.len());
        for (i, c) in level.gvs_cells.iter().enumerate() {
            let end = c.first_face as usize + c.num_faces as usize;
            if end > level.gvs_faces.len() {
                return Err(GvsError::CellRange {
                    cell: i,
                    first: c.first_face,
                    count: c.num_faces,
                    len: level.gvs_faces.len(),
                });
            }
            let (mins, maxs) = (Vec3A::from_array(c.mins), Vec3A::from_array(c.maxs));
            if !(mins.is_finite() && maxs.is_finite()) {
                return Err(GvsError::Face {
                    entry: c.first_face as usize,
                    detail: format!("cell {i} bounds"),
                });
            }
            cells.push(Cell {
                mins: mins.min(maxs),
                maxs: mins.max(maxs),
                first: c.first_face,
                count: c.num_faces,
            });
        }
        for (e, &f) in level.gvs_faces.iter().enumerate() {
            if f as usize >= level.faces.len() {
                return Err(GvsError::Face {
                    entry: e,
                    detail: format!("face {f} of {}", level.faces.len()),
                });
            }
        }
        Ok(Gvs { cells, faces: level.gvs_faces.clone(), face_bounds })
    }

    /// Number of view cells.
    pub fn num_cells(&self) -> usize {
        self.cells.len()
    }

    /// Index of the cell answering for `eye` (see the module docs), `None` without cells.
    pub fn cell_at(&self, eye: Vec3A) -> Option<usize> {
        let mut best: Option<(f32, usize)> = None;
        for (i, c) in self.cells.iter().enumerate() {
            let d = (c.mins - eye).max(eye - c.maxs).max(Vec3A::ZERO).length_squared();
            if d == 0.0 {
                return Some(i);
            }
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, i));
            }
        }
        best.map(|(_, i)| i)
    }

    /// The faces of cell `cell` (empty for a bad index).
    pub fn cell_faces(&self, cell: usize) -> &[u32] {
        self.cells
            .get(cell)
            .and_then(|c| self.faces.get(c.first as usize..c.first as usize + c.count as usize))
            .unwrap_or(&[])
    }

    /// Append to `out` the faces of the eye's cell inside `frustum`, front to back.
    pub fn query(&self, eye: Vec3A, frustum: &Frustum, out: &mut Vec<u32>) {
        out.clear();
        let Some(cell) = self.cell_at(eye) else {
            return;
        };
        for &f in self.cell_faces(cell) {
            let Some(b) = self.face_bounds.get(f as usize) else {
                continue;
            };
            if !matches!(frustum.test_box(b.center, b.extent, Frustum::ALL), BoxSide::Outside) {
                out.push(f);
            }
        }
        let dist = |f: u32| {
            self.face_bounds
                .get(f as usize)
                .map_or(0.0, |b| ((eye - b.center).abs() - b.extent).max(Vec3A::ZERO).length_squared())
        };
        out.sort_unstable_by(|&a, &b| dist(a).total_cmp(&dist(b)).then(a.cmp(&b)));
    }
}

impl Backend for Gvs {
    fn name(&self) -> &'static str {
        "gvs"
    }

    fn supports(&self, world: &World) -> bool {
        !self.cells.is_empty() && world.num_faces() == self.face_bounds.len()
    }

    fn cull(&self, _world: &World, view: &View, scratch: &mut Scratch, out: &mut Visible) {
        out.leaves.clear();
        self.query(view.eye, &view.frustum, &mut out.faces);
        scratch.stats.marked_leaves = 0;
        scratch.stats.portals_crossed = 0;
        scratch.stats.truncated = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use glam::Vec3;
    use sightline_formats::level::{Face, GvsCell};

    /// Two unit squares in front of (+X) and behind (-X) the origin, one cell around the origin
    /// seeing both, and one far cell seeing only the first.
    fn level() -> Level {
        let sq = |x: f32| [[x, -1.0, -1.0], [x, 1.0, -1.0], [x, 1.0, 1.0], [x, -1.0, 1.0]];
        let mut vertices = sq(5.0).to_vec();
        vertices.extend(sq(-5.0));
        Level {
            vertices,
            faces: vec![
                Face { plane: 0, first_vertex: 0, num_vertices: 4, texture: 0 },
                Face { plane: 0, first_vertex: 4, num_vertices: 4, texture: 0 },
            ],
            gvs_cells: vec![
                GvsCell { mins: [-1.0; 3], maxs: [1.0; 3], first_face: 0, num_faces: 2 },
                GvsCell { mins: [100.0; 3], maxs: [101.0; 3], first_face: 2, num_faces: 1 },
            ],
            gvs_faces: vec![0, 1, 0],
            ..Level::default()
        }
    }

    #[test]
    fn answers_with_the_frustum_culled_faces_of_the_eye_cell() {
        let gvs = Gvs::from_level(&level()).expect("valid");
        let mut out = Vec::new();
        let cam = Camera::quake(Vec3::ZERO, 0.0, 0.0);
        gvs.query(Vec3A::ZERO, &cam.view().frustum, &mut out);
        assert_eq!(out, vec![0]);
        let back = Camera::quake(Vec3::ZERO, 180.0, 0.0);
        gvs.query(Vec3A::ZERO, &back.view().frustum, &mut out);
        assert_eq!(out, vec![1]);
        // Far away: the nearest cell (the second) answers.
        assert_eq!(gvs.cell_at(Vec3A::splat(500.0)), Some(1));
        assert_eq!(gvs.cell_faces(1), &[0]);
    }

    #[test]
    fn rejects_bad_indices() {
        let mut l = level();
        l.gvs_faces[2] = 9;
        assert!(matches!(Gvs::from_level(&l), Err(GvsError::Face { entry: 2, .. })));
        let mut l = level();
        l.gvs_cells[1].num_faces = 5;
        assert!(matches!(Gvs::from_level(&l), Err(GvsError::CellRange { cell: 1, .. })));
        assert_eq!(Gvs::from_level(&Level::default()).map(|g| g.num_cells()), Ok(0));
    }
}
