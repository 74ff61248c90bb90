//! The thesis' error metric: ID buffers rendered by ray casting against the whole scene from random
//! viewpoints inside a cell; a pixel is wrong when the triangle it shows is missing from the cell's
//! PVS (which is exactly where a PVS-only render would differ).
//!
//! Views: position uniform in the cell volume, heading uniform, pitch uniform in ±45° (the
//! thesis does not say where its cameras were), square image, `fov` degrees in both directions,
//! `+Z` up. Everything is deterministic for a given seed; ID buffers are cast row-parallel.

use glam::Vec3;
use rayon::prelude::*;
use sightline_runtime::bvh::Bvh;

use super::geom::Cell;
use crate::scenegen::Rng;

/// A viewpoint and looking direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Eye.
    pub eye: Vec3,
    /// Unit forward.
    pub forward: Vec3,
}

/// `n` random views inside `cell`.
pub fn views(cell: &Cell, n: usize, seed: u64) -> Vec<View> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let f = Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
            let eye = cell.min + (cell.max - cell.min) * f;
            let yaw = rng.range(0.0, std::f32::consts::TAU);
            let pitch = rng.range(-45f32.to_radians(), 45f32.to_radians());
            let forward = Vec3::new(pitch.cos() * yaw.cos(), pitch.cos() * yaw.sin(), pitch.sin());
            View { eye, forward }
        })
        .collect()
}

/// Side of the square pixel tiles traced as one packet ([`Bvh::intersect_many`]).
const TILE: usize = 4;

/// Triangle index seen at every pixel of a `res × res` image (`u32::MAX` for nothing), rows top
/// to bottom. Bands of [`TILE`] rows are cast in parallel, each in packets of `TILE × TILE`
/// pixels (the same hits as one ray per pixel, but for which of two triangles at exactly the same
/// distance a pixel shows).
pub fn id_buffer(bvh: &Bvh, view: &View, res: usize, fov_deg: f32) -> Vec<u32> {
    let right = view.forward.cross(Vec3::Z).normalize_or(Vec3::X);
    let up = right.cross(view.forward);
    let half = (fov_deg.to_radians() * 0.5).tan();
    let mut out = vec![u32::MAX; res * res];
    let band = res.max(1) * TILE;
    out.par_chunks_mut(band).enumerate().for_each(|(b, rows)| {
        let mut rays = Vec::with_capacity(TILE * TILE);
        let mut pixels = Vec::with_capacity(TILE * TILE);
        let mut hits = Vec::new();
        for x0 in (0..res).step_by(TILE) {
            rays.clear();
            pixels.clear();
            for (dy, row) in rows.chunks(res.max(1)).enumerate() {
                let v = (1.0 - 2.0 * ((b * TILE + dy) as f32 + 0.5) / res as f32) * half;
                for x in x0..(x0 + TILE).min(row.len()) {
                    let u = (2.0 * (x as f32 + 0.5) / res as f32 - 1.0) * half;
                    rays.push((view.eye, view.forward + right * u + up * v));
                    pixels.push(dy * res + x);
                }
            }
            bvh.intersect_many(&rays, f32::INFINITY, &mut hits);
            for (&p, h) in pixels.iter().zip(&hits) {
                if let (Some(px), Some(h)) = (rows.get_mut(p), h) {
                    *px = h.triangle;
                }
            }
        }
    });
    out
}

/// Pixels of `ids` whose triangle is not in the PVS bitset `pvs`.
pub fn error_pixels(ids: &[u32], pvs: &[u64]) -> u64 {
    ids.iter()
        .filter(|&&t| t != u32::MAX && pvs.get(t as usize / 64).is_none_or(|w| w & (1 << (t % 64)) == 0))
        .count() as u64
}

/// The triangles of `ids` missing from the PVS bitset `pvs` with their pixel counts, most pixels
/// first (ties by triangle index).
pub fn missed(ids: &[u32], pvs: &[u64]) -> Vec<(u32, u64)> {
    let mut m: Vec<(u32, u64)> = Vec::new();
    let mut tris: Vec<u32> = ids
        .iter()
        .copied()
        .filter(|&t| t != u32::MAX && pvs.get(t as usize / 64).is_none_or(|w| w & (1 << (t % 64)) == 0))
        .collect();
    tris.sort_unstable();
    for t in tris {
        match m.last_mut() {
            Some((last, n)) if *last == t => *n += 1,
            _ => m.push((t, 1)),
        }
    }
    m.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    m
}

/// Error of one PVS against precomputed ID buffers: (mean, max) wrong pixels per view.
///
/// (See [`missed`] for which triangles they are.)
pub fn measure(buffers: &[Vec<u32>], pvs: &[u64]) -> (f64, u64) {
    let errs: Vec<u64> = buffers.iter().map(|b| error_pixels(b, pvs)).collect();
    let max = errs.iter().copied().max().unwrap_or(0);
    let mean = if errs.is_empty() { 0.0 } else { errs.iter().sum::<u64>() as f64 / errs.len() as f64 };
    (mean, max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missed_counts_pixels_of_triangles_outside_the_pvs() {
        // Triangles 1 and 64 are in the PVS; 2 (three pixels) and 70 (one) are not.
        let mut pvs = vec![0u64; 2];
        pvs[0] |= 1 << 1;
        pvs[1] |= 1;
        let ids = [1, 2, u32::MAX, 70, 2, 64, 2];
        assert_eq!(missed(&ids, &pvs), vec![(2, 3), (70, 1)]);
        assert_eq!(error_pixels(&ids, &pvs), 4);
        assert_eq!(measure(&[ids.to_vec(), vec![1]], &pvs), (2.0, 4));
    }
}
