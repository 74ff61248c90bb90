//! Choosing view cells: a grid of cubes over a scene's bounds, and an even selection from a list
//! (of cells, or of the cells whose error is measured). A level's open leaves as cells are
//! [`crate::scene::leaf_cells`].

use glam::Vec3;

use crate::geom::Cell;

/// Most cells a grid may have.
pub const MAX_GRID: u64 = 1 << 20;

/// Why [`grid`] gives no cells.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GridError {
    /// The cube side is not positive (or NaN).
    #[error("cell size {0} must be positive")]
    Size(f32),
    /// The grid would have more than [`MAX_GRID`] cells.
    #[error("cell size {size} gives {count} cells (at most {MAX_GRID}); use a larger size")]
    TooMany {
        /// The cube side.
        size: f32,
        /// The cells it gives.
        count: u64,
    },
}

/// A grid of cubes of side `size` covering `bounds` (at least one cube along every axis), x
/// fastest, then y, then z.
pub fn grid(bounds: &Cell, size: f32) -> Result<Vec<Cell>, GridError> {
    if size.is_nan() || size <= 0.0 {
        return Err(GridError::Size(size));
    }
    let ext = bounds.max - bounds.min;
    let n = (ext / size).ceil().max(Vec3::ONE);
    let count = n.x as u64 * n.y as u64 * n.z as u64;
    if count > MAX_GRID {
        return Err(GridError::TooMany { size, count });
    }
    let mut cells = Vec::with_capacity(count as usize);
    for k in 0..n.z as u32 {
        for j in 0..n.y as u32 {
            for i in 0..n.x as u32 {
                let lo = bounds.min + Vec3::new(i as f32, j as f32, k as f32) * size;
                cells.push(Cell::new(lo, lo + Vec3::splat(size)));
            }
        }
    }
    Ok(cells)
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
    fn bad_grids_are_errors() {
        let bounds = Cell::new(Vec3::ZERO, Vec3::splat(1000.0));
        for size in [0.0, -1.0, f32::NAN] {
            assert!(matches!(grid(&bounds, size), Err(GridError::Size(_))), "{size}");
        }
        let err = grid(&bounds, 1.0).expect_err("10^9 cells");
        assert_eq!(err, GridError::TooMany { size: 1.0, count: 1_000_000_000 });
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
