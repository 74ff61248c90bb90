//! Choosing view cells: a grid of cubes over a scene's bounds, and an even selection from a list
//! (of cells, or of the cells whose error is measured). A level's open leaves as cells are
//! [`crate::scene::leaf_cells`].

use glam::Vec3;

use crate::geom::Cell;

/// Most cells a grid may have as a list ([`grid`]).
pub const MAX_GRID: u64 = 1 << 20;

/// Most cells a [`Grid`] may have (numbered, never listed: it holds no memory per cell).
pub const MAX_INDEXED: u64 = 1 << 32;

/// Why [`grid`] gives no cells.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GridError {
    /// The cube side is not positive (or NaN).
    #[error("cell size {0} must be positive")]
    Size(f32),
    /// The grid would have more cells than allowed ([`MAX_GRID`] as a list, [`MAX_INDEXED`] as a
    /// [`Grid`]).
    #[error("cell size {size} gives {count} cells (at most {max}); use a larger size")]
    TooMany {
        /// The cube side.
        size: f32,
        /// The cells it gives.
        count: u64,
        /// The most allowed.
        max: u64,
    },
}

/// A grid of cubes of side `size` covering `bounds` (at least one cube along every axis), x
/// fastest, then y, then z: [`Grid::cells`] of [`Grid::new`].
pub fn grid(bounds: &Cell, size: f32) -> Result<Vec<Cell>, GridError> {
    let g = Grid::new(bounds, size)?;
    let count = g.len() as u64;
    if count > MAX_GRID {
        return Err(GridError::TooMany { size, count, max: MAX_GRID });
    }
    Ok(g.cells())
}

/// A grid of cubes over a box: its corner, the cube side and the cubes along each axis. Cube
/// `(i, j, k)` is number `i + n.x (j + n.y k)` and spans `min + (i, j, k) size` to one side more.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// The corner the cubes start from (the bounds' minimum).
    pub min: Vec3,
    /// The cube side.
    pub size: f32,
    /// Cubes along x, y and z (each at least 1).
    pub n: [u32; 3],
}

impl Grid {
    /// The grid of cubes of side `size` covering `bounds` (at least one cube along every axis),
    /// of at most [`MAX_INDEXED`] cubes.
    pub fn new(bounds: &Cell, size: f32) -> Result<Grid, GridError> {
        if size.is_nan() || size <= 0.0 {
            return Err(GridError::Size(size));
        }
        let n = ((bounds.max - bounds.min) / size).ceil().max(Vec3::ONE);
        // Each factor saturates at `u64::MAX` for a huge (or NaN-free infinite) ratio.
        let count = (n.x as u64).saturating_mul(n.y as u64).saturating_mul(n.z as u64);
        if count > MAX_INDEXED {
            return Err(GridError::TooMany { size, count, max: MAX_INDEXED });
        }
        Ok(Grid { min: bounds.min, size, n: [n.x as u32, n.y as u32, n.z as u32] })
    }

    /// Number of cubes.
    pub fn len(&self) -> usize {
        self.n.iter().map(|&k| k as usize).product()
    }

    /// True when the grid has no cube (never, for a grid [`Grid::new`] made).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Cube number `c` (`None` past the last).
    pub fn cell(&self, c: usize) -> Option<Cell> {
        if c >= self.len() {
            return None;
        }
        let [nx, ny, _] = self.n.map(|k| k as usize);
        let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
        let lo = self.min + Vec3::new(i as f32, j as f32, k as f32) * self.size;
        Some(Cell::new(lo, lo + Vec3::splat(self.size)))
    }

    /// Every cube, x fastest, then y, then z.
    pub fn cells(&self) -> Vec<Cell> {
        (0..self.len()).filter_map(|c| self.cell(c)).collect()
    }

    /// The number of the cube containing `p` (a point on a shared side belongs to the cube above
    /// it; the grid's far sides belong to the last cubes); `None` outside the grid or not finite.
    pub fn cell_of(&self, p: Vec3) -> Option<usize> {
        let f = (p - self.min) / self.size;
        let mut idx = [0usize; 3];
        for (axis, slot) in idx.iter_mut().enumerate() {
            let (x, n) = (f[axis], self.n[axis]);
            if !(x >= 0.0 && x <= n as f32) {
                return None;
            }
            *slot = (x.floor() as u32).min(n - 1) as usize;
        }
        let [nx, ny, _] = self.n.map(|k| k as usize);
        Some(idx[0] + nx * (idx[1] + ny * idx[2]))
    }
}

/// `k` items spread evenly through `items` (all of them when `k` is at least their number).
pub fn evenly<T: Clone>(items: &[T], k: usize) -> Vec<T> {
    if k == 0 || items.is_empty() {
        return Vec::new();
    }
    let k = k.min(items.len());
    (0..k).filter_map(|i| items.get(i * items.len() / k).cloned()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_covers_the_bounds_x_first() {
        let bounds = Cell::new(Vec3::ZERO, Vec3::new(3.0, 1.5, 0.0));
        let cells = grid(&bounds, 1.0).expect("grid");
        // 3 along x, 2 along y, 1 along z (a flat box still gets one layer).
        assert_eq!(cells.len(), 6);
        assert_eq!(cells[1], Cell::new(Vec3::X, Vec3::new(2.0, 1.0, 1.0)));
        assert_eq!(cells[3], Cell::new(Vec3::Y, Vec3::new(1.0, 2.0, 1.0)));
    }

    #[test]
    fn every_cube_contains_its_own_centre_and_nothing_outside_is_in_one() {
        let bounds = Cell::new(Vec3::new(-1.0, 2.0, 0.0), Vec3::new(4.0, 5.5, 1.0));
        let g = Grid::new(&bounds, 1.5).expect("grid");
        assert_eq!(g.n, [4, 3, 1]);
        let cells = g.cells();
        assert_eq!(cells, grid(&bounds, 1.5).expect("grid"));
        for (c, cell) in cells.iter().enumerate() {
            assert_eq!(g.cell_of(cell.centre()), Some(c));
            assert_eq!(g.cell_of(cell.min), Some(c), "a cube owns its lower corner");
        }
        assert_eq!(g.cell_of(Vec3::new(-1.0, 2.0, 0.0) + Vec3::new(6.0, 4.5, 1.5)), Some(g.len() - 1));
        for p in [Vec3::new(-1.1, 3.0, 0.5), Vec3::new(0.0, 3.0, 1.6), Vec3::splat(f32::NAN)] {
            assert_eq!(g.cell_of(p), None, "{p}");
        }
        assert_eq!(g.cell(g.len()), None);
    }

    #[test]
    fn bad_grids_are_errors() {
        let bounds = Cell::new(Vec3::ZERO, Vec3::splat(1000.0));
        for size in [0.0, -1.0, f32::NAN] {
            assert!(matches!(grid(&bounds, size), Err(GridError::Size(_))), "{size}");
        }
        let err = grid(&bounds, 1.0).expect_err("10^9 cells");
        assert_eq!(err, GridError::TooMany { size: 1.0, count: 1_000_000_000, max: MAX_GRID });
        assert!(matches!(Grid::new(&bounds, 1e-3), Err(GridError::TooMany { max: MAX_INDEXED, .. })));
        assert_eq!(Grid::new(&bounds, 1.0).map(|g| g.len()), Ok(1_000_000_000));
        assert_eq!(
            err.to_string(),
            "cell size 1 gives 1000000000 cells (at most 1048576); use a larger size"
        );
    }

    #[test]
    fn evenly_spreads_its_picks() {
        let items: Vec<u32> = (0..10).collect();
        assert_eq!(evenly(&items, 3), [0, 3, 6]);
        assert_eq!(evenly(&items, 20), items);
        assert!(evenly(&items, 0).is_empty());
        assert!(evenly::<u32>(&[], 3).is_empty());
    }
}
