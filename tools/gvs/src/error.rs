//! The thesis' error metric: ID buffers rendered by ray casting against the whole scene from random
//! viewpoints inside a cell; a pixel is wrong when the triangle it shows is missing from the cell's
//! PVS (which is exactly where a PVS-only render would differ).
//!
//! Views: position uniform in the cell volume, heading uniform, pitch uniform in ±45° (the
//! thesis does not say where its cameras were), square image, `fov` degrees in both directions,
//! `+Z` up. Everything is deterministic for a given seed; ID buffers are cast row-parallel.

use glam::Vec3;
use rayon::prelude::*;
use sightline_formats::bits;
use sightline_raycast::{Bvh, intersect_brute};

use super::geom::Cell;
use super::twins::Twins;
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
            let eye = cell.at(f);
            let yaw = rng.range(0.0, std::f32::consts::TAU);
            let pitch = rng.range(-45f32.to_radians(), 45f32.to_radians());
            let forward = Vec3::new(pitch.cos() * yaw.cos(), pitch.cos() * yaw.sin(), pitch.sin());
            View { eye, forward }
        })
        .collect()
}

/// Side of the square pixel tiles traced as one packet ([`Bvh::intersect_many`]).
const TILE: usize = 4;

/// A twin hit this much farther than a pixel's triangle (relative to its distance) is at the same
/// depth: the rounding of two triangles in one plane.
const TIE: f32 = 1e-5;

/// Most ties kept per pixel (the first twins in index order): a two-sided surface gives one, and
/// a buffer stays within `8 × MAX_TIES` bytes per pixel on a soup of many coplanar copies.
const MAX_TIES: usize = 2;

/// One view's ID buffer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IdBuffer {
    /// Triangle index seen at every pixel of a `res × res` image (`u32::MAX` for nothing), rows
    /// top to bottom.
    pub ids: Vec<u32>,
    /// `(pixel, triangle)`, ascending: a twin ([`Twins`]) of the pixel's triangle that the pixel's
    /// ray meets at the same depth (within `TIE`). Which of the two a ray reports is rounding, so
    /// the pixel is shown when either is in the PVS.
    pub ties: Vec<(u32, u32)>,
}

/// The ID buffer of `view` over the triangles `tris` (indexed by `bvh`, with their `twins`): `res
/// × res` pixels at `fov_deg` degrees. Bands of `TILE` rows are cast in parallel, each in packets
/// of `TILE × TILE` pixels (the same hits as one ray per pixel, but for which of two triangles at
/// exactly the same distance a pixel shows).
pub fn id_buffer(
    bvh: &Bvh,
    tris: &[[Vec3; 3]],
    twins: &Twins,
    view: &View,
    res: usize,
    fov_deg: f32,
) -> IdBuffer {
    let right = view.forward.cross(Vec3::Z).normalize_or(Vec3::X);
    let up = right.cross(view.forward);
    let half = (fov_deg.to_radians() * 0.5).tan();
    let mut ids = vec![u32::MAX; res * res];
    let band = res.max(1) * TILE;
    let mut ties: Vec<(u32, u32)> = ids
        .par_chunks_mut(band)
        .enumerate()
        .flat_map_iter(|(b, rows)| {
            let mut rays = Vec::with_capacity(TILE * TILE);
            let mut pixels = Vec::with_capacity(TILE * TILE);
            let mut hits = Vec::new();
            let mut ties = Vec::new();
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
                for ((&p, h), &(o, d)) in pixels.iter().zip(&hits).zip(&rays) {
                    let (Some(px), Some(h)) = (rows.get_mut(p), h) else {
                        continue;
                    };
                    *px = h.triangle;
                    let first = ties.len();
                    for &u in twins.of(h.triangle) {
                        if ties.len() - first == MAX_TIES {
                            break;
                        }
                        let Some(tri) = tris.get(u as usize) else {
                            continue;
                        };
                        if intersect_brute(std::slice::from_ref(tri), o, d, h.t * (1.0 + TIE)).is_some() {
                            ties.push(((b * band + p) as u32, u));
                        }
                    }
                }
            }
            ties
        })
        .collect();
    ties.sort_unstable();
    IdBuffer { ids, ties }
}

/// True when triangle `t` is in the PVS bitset `pvs` (`u32::MAX`, nothing, never is).
fn has(pvs: &[u64], t: u32) -> bool {
    t != u32::MAX && bits::get(pvs, t as usize)
}

/// The pixels of `buf` whose triangle is not in `pvs` but a tied twin is, ascending.
fn shown_by_twin(buf: &IdBuffer, pvs: &[u64]) -> Vec<u32> {
    let mut px: Vec<u32> = buf
        .ties
        .iter()
        .filter(|&&(p, u)| has(pvs, u) && !buf.ids.get(p as usize).is_some_and(|&t| has(pvs, t)))
        .map(|&(p, _)| p)
        .collect();
    px.dedup();
    px
}

/// The wrong pixels of `buf` (a triangle not in the PVS bitset `pvs`, nor a tied twin of it), by
/// their triangle.
fn wrong(buf: &IdBuffer, pvs: &[u64]) -> impl Iterator<Item = u32> {
    let shown = shown_by_twin(buf, pvs);
    let mut next = shown.into_iter().peekable();
    buf.ids.iter().enumerate().filter_map(move |(p, &t)| {
        if t == u32::MAX || has(pvs, t) {
            return None;
        }
        if next.next_if_eq(&(p as u32)).is_some() {
            return None;
        }
        Some(t)
    })
}

/// Pixels of `buf` whose triangle (and every tied twin) is not in the PVS bitset `pvs`.
pub fn error_pixels(buf: &IdBuffer, pvs: &[u64]) -> u64 {
    wrong(buf, pvs).count() as u64
}

/// The triangles of the wrong pixels of `buf` (see [`error_pixels`]) with their pixel counts,
/// most pixels first (ties by triangle index).
pub fn missed(buf: &IdBuffer, pvs: &[u64]) -> Vec<(u32, u64)> {
    let mut m: Vec<(u32, u64)> = Vec::new();
    let mut tris: Vec<u32> = wrong(buf, pvs).collect();
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

/// Wrong pixels per view, added up one view at a time (the ID buffers need not be kept): the
/// mean and the largest.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErrorStats {
    total: u64,
    views: u64,
    max: u64,
}

impl ErrorStats {
    /// Count one view with `wrong` wrong pixels ([`error_pixels`]).
    pub fn add(&mut self, wrong: u64) {
        self.total += wrong;
        self.views += 1;
        self.max = self.max.max(wrong);
    }

    /// (mean, max) wrong pixels per view; `None` before any view.
    pub fn get(&self) -> Option<(f64, u64)> {
        (self.views > 0).then(|| (self.total as f64 / self.views as f64, self.max))
    }
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
        let buf = IdBuffer { ids: vec![1, 2, u32::MAX, 70, 2, 64, 2], ties: Vec::new() };
        assert_eq!(missed(&buf, &pvs), vec![(2, 3), (70, 1)]);
        assert_eq!(error_pixels(&buf, &pvs), 4);
        let one = IdBuffer { ids: vec![1], ties: Vec::new() };
        let mut stats = ErrorStats::default();
        assert_eq!(stats.get(), None);
        for b in [&buf, &one] {
            stats.add(error_pixels(b, &pvs));
        }
        assert_eq!(stats.get(), Some((2.0, 4)));
        // Pixel 1's triangle 2 ties with 64 (in the PVS), pixel 4's with 3 (not), and pixel 5's
        // triangle 64 is in the PVS anyway.
        let tied = IdBuffer { ties: vec![(1, 64), (4, 3), (5, 2)], ..buf };
        assert_eq!(missed(&tied, &pvs), vec![(2, 2), (70, 1)]);
        assert_eq!(error_pixels(&tied, &pvs), 3);
    }

    #[test]
    fn a_pixel_on_a_two_sided_surface_is_shown_by_either_side() {
        // A square at z = 0 wound up (0, 1) and down along the other diagonal (2, 3), seen from
        // above: every ray that reports one side meets the other at the same depth.
        let p = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let tris = vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]], [p[0], p[3], p[1]], [p[1], p[3], p[2]]];
        let bvh = Bvh::build(&tris);
        let twins = Twins::build(&tris, &bvh);
        let view = View { eye: Vec3::new(0.0, -0.1, 3.0), forward: Vec3::new(0.0, 0.05, -1.0).normalize() };
        let buf = id_buffer(&bvh, &tris, &twins, &view, 32, 40.0);
        let on: Vec<usize> = (0..buf.ids.len()).filter(|&i| buf.ids[i] != u32::MAX).collect();
        assert!(on.len() > 500, "{} pixels on the square", on.len());
        // Every pixel on the square ties with the other side, and only those pixels do.
        let mut tied: Vec<usize> = buf.ties.iter().map(|&(px, _)| px as usize).collect();
        tied.dedup();
        assert_eq!(tied, on);
        assert!(buf.ties.windows(2).all(|w| w[0] < w[1]));
        for &(px, u) in &buf.ties {
            assert_ne!(buf.ids[px as usize] < 2, u < 2, "pixel {px} ties {} with {u}", buf.ids[px as usize]);
        }
        // Either side alone shows the whole square; without ties one side would leave pixels.
        for side in [[0u32, 1], [2, 3]] {
            let pvs = [side.iter().fold(0u64, |w, &t| w | 1 << t)];
            assert_eq!(error_pixels(&buf, &pvs), 0);
            let bare = IdBuffer { ties: Vec::new(), ..buf.clone() };
            assert_eq!(
                error_pixels(&bare, &pvs) as usize,
                on.iter().filter(|&&i| !side.contains(&buf.ids[i])).count()
            );
        }
        assert_eq!(error_pixels(&buf, &[0]) as usize, on.len());
    }
}
