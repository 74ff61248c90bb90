//! The level's GVS view cells, validated: the faces guided visibility sampling found visible from
//! each box cell (`Level::gvs_cells` / `gvs_faces`, written by `sightline gvs`), with a box per
//! face and a grid to find the eye's cell.
//!
//! A [`World`](crate::World) keeps the [`GvsCells`] of its level
//! ([`World::gvs_cells`](crate::World::gvs_cells)); the GVS backends
//! ([`crate::backend::gvs`]) answer from them. This module sits below the world and knows no
//! backend.
//!
//! # Conventions
//! - The eye's cell is the first cell whose box contains it (boxes are closed); outside every cell,
//!   the nearest cell by distance to its box (the first of equals). No cells: nothing visible.
//! - Face indices are those of the level, each listed once per cell.
//! - Like every GVS result, the face set is aggressive: it may miss faces seen only through tiny
//!   gaps (see the `tools` GVS documentation for the measured error).

use glam::Vec3A;
use sightline_formats::level::Level;

use crate::camera::{BoxSide, Frustum};
use crate::error::GvsError;

/// A view cell with its slice of [`GvsCells::faces`].
#[derive(Debug, Clone, Copy)]
struct Cell {
    mins: Vec3A,
    maxs: Vec3A,
    first: u32,
    count: u32,
}

/// The GVS cells of a level (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct GvsCells {
    cells: Vec<Cell>,
    faces: Vec<u32>,
    /// Finds the cells whose box may contain a point.
    grid: CellGrid,
    /// Box of every face of the level (indexed by face): centre, half-size.
    face_bounds: Vec<(Vec3A, Vec3A)>,
}

impl GvsCells {
    /// Build from a level's GVS lumps and faces, checking every index (a level without cells
    /// gives no cells).
    pub fn from_level(level: &Level) -> Result<GvsCells, GvsError> {
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
            face_bounds.push(((lo + hi) * 0.5, (hi - lo) * 0.5));
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
        let grid = CellGrid::build(&cells);
        Ok(GvsCells { cells, faces: level.gvs_faces.clone(), face_bounds, grid })
    }

    /// Number of view cells.
    pub fn num_cells(&self) -> usize {
        self.cells.len()
    }

    /// True without cells.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Number of faces of the level the cells were made from (face indices are below it).
    pub fn num_faces(&self) -> usize {
        self.face_bounds.len()
    }

    /// Index of the cell answering for `eye` (see the module docs), `None` without cells. The
    /// grid gives the few cells that can contain the eye, in index order; only an eye outside
    /// every cell scans all cells for the nearest.
    pub fn cell_at(&self, eye: Vec3A) -> Option<usize> {
        for &i in self.grid.candidates(eye) {
            if self.cells.get(i as usize).is_some_and(|c| distance_sq(c, eye) == 0.0) {
                return Some(i as usize);
            }
        }
        self.nearest_cell(eye)
    }

    /// The first cell at the least distance from `eye` (distance 0: containing it).
    fn nearest_cell(&self, eye: Vec3A) -> Option<usize> {
        let mut best: Option<(f32, usize)> = None;
        for (i, c) in self.cells.iter().enumerate() {
            let d = distance_sq(c, eye);
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
            let Some(&(center, extent)) = self.face_bounds.get(f as usize) else {
                continue;
            };
            if !matches!(frustum.test_box(center, extent, Frustum::ALL), BoxSide::Outside) {
                out.push(f);
            }
        }
        let dist = |f: u32| {
            self.face_bounds
                .get(f as usize)
                .map_or(0.0, |&(c, e)| ((eye - c).abs() - e).max(Vec3A::ZERO).length_squared())
        };
        out.sort_unstable_by(|&a, &b| dist(a).total_cmp(&dist(b)).then(a.cmp(&b)));
    }
}

/// Squared distance from `p` to a cell's box (0 inside).
#[inline]
fn distance_sq(c: &Cell, p: Vec3A) -> f32 {
    (c.mins - p).max(p - c.maxs).max(Vec3A::ZERO).length_squared()
}

/// A uniform grid over the cells' boxes (at most [`CellGrid::MAX_PER_AXIS`] per axis): each grid
/// cell lists, in ascending order, every view cell whose box, widened by [`CellGrid::MARGIN`],
/// overlaps it. A view cell at distance 0 from a point (see [`distance_sq`]) is then in the list
/// of the point's grid cell, so the first such cell of that list is the first of all cells.
#[derive(Debug, Clone, Default)]
struct CellGrid {
    lo: Vec3A,
    hi: Vec3A,
    scale: Vec3A,
    dims: [usize; 3],
    /// CSR: view cells of grid cell `g` are `list[start[g]..start[g + 1]]`.
    start: Vec<u32>,
    list: Vec<u32>,
}

impl CellGrid {
    const MAX_PER_AXIS: usize = 64;
    /// Widening of the boxes (relative to the grid's size, plus one unit): far more than the
    /// distance at which a squared distance rounds to zero.
    const MARGIN: f32 = 1e-3;
    /// Most list entries; a grid that would be larger is not built (every query scans).
    const MAX_ENTRIES: usize = 1 << 22;

    fn build(cells: &[Cell]) -> Self {
        let Some(first) = cells.first() else { return Self::default() };
        let (mut lo, mut hi) = (first.mins, first.maxs);
        for c in cells {
            lo = lo.min(c.mins);
            hi = hi.max(c.maxs);
        }
        let margin = Vec3A::splat(
            Self::MARGIN * (1.0 + (hi - lo).max_element() + lo.abs().max(hi.abs()).max_element()),
        );
        let (lo, hi) = (lo - margin, hi + margin);
        let per_axis = (cells.len() as f64).cbrt().ceil().clamp(1.0, Self::MAX_PER_AXIS as f64) as usize;
        let dims = [per_axis; 3];
        let scale = Vec3A::splat(per_axis as f32) / (hi - lo).max(Vec3A::splat(f32::MIN_POSITIVE));
        let mut grid = CellGrid { lo, hi, scale, dims, start: Vec::new(), list: Vec::new() };
        let ranges: Vec<([usize; 3], [usize; 3])> =
            cells.iter().map(|c| (grid.index(c.mins - margin), grid.index(c.maxs + margin))).collect();
        let total: usize =
            ranges.iter().map(|(a, b)| (0..3).map(|k| b[k] + 1 - a[k]).product::<usize>()).sum();
        if total > Self::MAX_ENTRIES {
            return Self::default();
        }
        let count = per_axis * per_axis * per_axis;
        let mut counts = vec![0u32; count + 1];
        let flat = |x: usize, y: usize, z: usize| (z * per_axis + y) * per_axis + x;
        for (a, b) in &ranges {
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        counts[flat(x, y, z) + 1] += 1;
                    }
                }
            }
        }
        for g in 0..count {
            counts[g + 1] += counts[g];
        }
        grid.start = counts.clone();
        grid.list = vec![0; total];
        for (i, (a, b)) in ranges.iter().enumerate() {
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        let slot = &mut counts[flat(x, y, z)];
                        grid.list[*slot as usize] = i as u32;
                        *slot += 1;
                    }
                }
            }
        }
        grid
    }

    /// Grid coordinates of `p`, clamped into the grid.
    fn index(&self, p: Vec3A) -> [usize; 3] {
        let g = ((p - self.lo) * self.scale).to_array();
        std::array::from_fn(|k| (g[k].max(0.0) as usize).min(self.dims[k].saturating_sub(1)))
    }

    /// The view cells that may be at distance 0 from `p`, ascending (none outside the grid).
    fn candidates(&self, p: Vec3A) -> &[u32] {
        if self.dims[0] == 0 || !(p.cmpge(self.lo).all() && p.cmple(self.hi).all()) {
            return &[];
        }
        let [x, y, z] = self.index(p);
        let g = (z * self.dims[1] + y) * self.dims[0] + x;
        match (self.start.get(g), self.start.get(g + 1)) {
            (Some(&a), Some(&b)) => self.list.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
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
        let gvs = GvsCells::from_level(&level()).expect("valid");
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
    fn grid_finds_the_same_cell_as_a_scan() {
        use crate::poses::{SplitMix64, point_in};
        let mut rng = SplitMix64::new(3);
        let mut l = level();
        l.gvs_cells.clear();
        for _ in 0..300 {
            let lo = point_in(&mut rng, Vec3A::splat(-500.0), Vec3A::splat(500.0));
            let hi = lo + point_in(&mut rng, Vec3A::ZERO, Vec3A::splat(120.0));
            l.gvs_cells.push(GvsCell {
                mins: lo.to_array(),
                maxs: hi.to_array(),
                first_face: 0,
                num_faces: 1,
            });
        }
        let gvs = GvsCells::from_level(&l).expect("valid");
        assert!(!gvs.grid.list.is_empty());
        let mut inside = 0;
        for i in 0..20_000 {
            let c = &gvs.cells[rng.below(gvs.cells.len())];
            let mut p = match i % 3 {
                0 => point_in(&mut rng, Vec3A::splat(-700.0), Vec3A::splat(700.0)),
                _ => point_in(&mut rng, c.mins, c.maxs),
            };
            if i % 4 == 0 {
                // Exactly on a box face.
                p.x = c.maxs.x;
            }
            let want = gvs.nearest_cell(p);
            assert_eq!(gvs.cell_at(p), want, "point {p:?}");
            inside += usize::from(want.is_some_and(|c| distance_sq(&gvs.cells[c], p) == 0.0));
        }
        assert!(inside > 10_000, "{inside} points inside a cell");
    }

    #[test]
    fn rejects_bad_indices() {
        let mut l = level();
        l.gvs_faces[2] = 9;
        assert!(matches!(GvsCells::from_level(&l), Err(GvsError::Face { entry: 2, .. })));
        let mut l = level();
        l.gvs_cells[1].num_faces = 5;
        assert!(matches!(GvsCells::from_level(&l), Err(GvsError::CellRange { cell: 1, .. })));
        assert_eq!(GvsCells::from_level(&Level::default()).map(|g| g.num_cells()), Ok(0));
    }
}
