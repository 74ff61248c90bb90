//! The neighbour table of neighbour probing: per triangle, the triangles whose bounding boxes touch
//! its own (its mesh neighbours, and whatever else crosses its box), found once per scene through
//! the BVH instead of once per cell and triangle.
//!
//! A triangle's box is widened by a relative margin that absorbs the rounding of shared vertices
//! ([`touching_box`]). Lists are in the order of [`Bvh::overlapping`] (deterministic, whatever the
//! thread count). Memory is bounded: a triangle with more than [`MAX_STORED`] neighbours (large
//! triangles crossing many others) stores none and is marked crowded; probing queries the BVH for
//! it instead, which gives the same list.
//!
//! The table also holds the scene's [`Sheets`]: from which side probing expects a neighbour to be
//! seen depends on how its winding relates to the triangle seen.

use glam::Vec3;
use rayon::prelude::*;
use sightline_raycast::Bvh;

use super::sheets::Sheets;

/// Most neighbours stored for one triangle (the table holds at most `4 × MAX_STORED + 14` bytes per
/// triangle). Measured on the sphere scene: 15.4 on average.
pub const MAX_STORED: usize = 64;

/// Triangles per parallel work item of the build.
const CHUNK: usize = 4096;

/// The box whose overlapping triangles are `tri`'s neighbours: its bounds widened by `1e-4` of
/// their largest extent plus 4 ulps of the largest coordinate.
pub fn touching_box(tri: &[Vec3; 3]) -> (Vec3, Vec3) {
    let lo = tri[0].min(tri[1]).min(tri[2]);
    let hi = tri[0].max(tri[1]).max(tri[2]);
    let margin = 1e-4 * (hi - lo).max_element() + 4.0 * f32::EPSILON * lo.abs().max(hi.abs()).max_element();
    (lo - margin, hi + margin)
}

/// Per triangle, its neighbours (compressed rows).
#[derive(Debug, Clone, Default)]
pub struct Neighbours {
    /// Triangle `t`'s neighbours are `list[start[t]..start[t + 1]]`.
    start: Vec<usize>,
    list: Vec<u32>,
    /// Per triangle: true when it has more than [`MAX_STORED`] neighbours (none stored).
    crowded: Vec<bool>,
    /// The triangles' sheets.
    sheets: Sheets,
}

impl Neighbours {
    /// The table of `tris` (indexed by `bvh`) and their sheets, built in parallel.
    pub fn build(tris: &[[Vec3; 3]], bvh: &Bvh) -> Neighbours {
        let parts: Vec<(Vec<u32>, Vec<u32>, Vec<bool>)> = tris
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut counts = Vec::with_capacity(chunk.len());
                let mut list = Vec::new();
                let mut crowded = Vec::with_capacity(chunk.len());
                for tri in chunk {
                    let (lo, hi) = touching_box(tri);
                    let before = list.len();
                    let mut n = 0usize;
                    // Stops at the first neighbour past the limit: a crowded triangle costs
                    // `MAX_STORED + 1` callbacks, not one per triangle crossing it.
                    bvh.overlapping(lo, hi, |u| {
                        n += 1;
                        if n <= MAX_STORED {
                            list.push(u);
                        }
                        n <= MAX_STORED
                    });
                    if n > MAX_STORED {
                        list.truncate(before);
                    }
                    counts.push((list.len() - before) as u32);
                    crowded.push(n > MAX_STORED);
                }
                (counts, list, crowded)
            })
            .collect();
        let mut nb = Neighbours {
            start: Vec::with_capacity(tris.len() + 1),
            list: Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum()),
            crowded: Vec::with_capacity(tris.len()),
            sheets: Sheets::build(tris),
        };
        nb.start.push(0);
        for (counts, list, crowded) in parts {
            for c in counts {
                let last = nb.start.last().copied().unwrap_or(0);
                nb.start.push(last + c as usize);
            }
            nb.list.extend(list);
            nb.crowded.extend(crowded);
        }
        nb
    }

    /// The neighbours of triangle `t`, or `None` when it is crowded (or out of range).
    pub fn of(&self, t: u32) -> Option<&[u32]> {
        let t = t as usize;
        if self.crowded.get(t).is_none_or(|&c| c) {
            return None;
        }
        self.list.get(*self.start.get(t)?..*self.start.get(t + 1)?)
    }

    /// The scene's sheets (empty in an empty table).
    pub fn sheets(&self) -> &Sheets {
        &self.sheets
    }

    /// Bytes the table holds.
    pub fn bytes(&self) -> usize {
        self.start.len() * size_of::<usize>()
            + self.list.len() * size_of::<u32>()
            + self.crowded.len()
            + self.sheets.bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two fans of triangles around shared centres, far apart: each triangle's neighbours are its
    /// own fan's triangles (themselves included), as the BVH query gives them.
    #[test]
    fn rows_equal_the_bvh_query() {
        let mut tris = Vec::new();
        for centre in [Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0)] {
            for k in 0..6 {
                let a = k as f32 * std::f32::consts::TAU / 6.0;
                let b = (k + 1) as f32 * std::f32::consts::TAU / 6.0;
                tris.push([
                    centre,
                    centre + Vec3::new(a.cos(), a.sin(), 0.0),
                    centre + Vec3::new(b.cos(), b.sin(), 0.0),
                ]);
            }
        }
        let bvh = Bvh::build(&tris);
        let nb = Neighbours::build(&tris, &bvh);
        for t in 0..tris.len() as u32 {
            let (lo, hi) = touching_box(&tris[t as usize]);
            let mut want = Vec::new();
            bvh.overlapping(lo, hi, |u| {
                want.push(u);
                true
            });
            assert_eq!(nb.of(t), Some(&want[..]), "triangle {t}");
            assert!(want.iter().all(|&u| u / 6 == t / 6), "triangle {t}: {want:?}");
        }
        assert_eq!(nb.of(tris.len() as u32), None);
    }

    /// Many large triangles crossing each other: every one is crowded, nothing is stored.
    #[test]
    fn crowded_triangles_store_nothing() {
        let tris: Vec<[Vec3; 3]> = (0..MAX_STORED + 10)
            .map(|k| {
                let z = k as f32 * 0.01;
                [Vec3::new(-10.0 + z, -10.0, -1.0), Vec3::new(10.0, -10.0 + z, 1.0), Vec3::new(0.0, 10.0, z)]
            })
            .collect();
        let bvh = Bvh::build(&tris);
        let nb = Neighbours::build(&tris, &bvh);
        assert!((0..tris.len() as u32).all(|t| nb.of(t).is_none()));
        assert!(nb.list.is_empty());
    }
}
