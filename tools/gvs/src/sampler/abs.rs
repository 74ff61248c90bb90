//! Adaptive border sampling (ABS) around a seed, and silhouette re-seeding from the cell's
//! corners.

use glam::Vec3;

use crate::geom::enlarge;

use super::{Class, EdgeMode, Gvs, NONE, Sample, Seed};

impl Gvs<'_> {
    /// Adaptive border sampling around a seed.
    pub(super) fn abs(&mut self, seed: Seed) {
        self.stats.seeds += 1;
        let Some(tri) = self.tris.get(seed.tri as usize) else {
            return;
        };
        let o = seed.origin;
        let pts = enlarge(tri, o, self.p.eps);
        let samples = pts.map(|p| {
            let s = self.handle(o, p - o, Class::Point);
            self.check_discontinuity(o, p, s, seed.hit);
            s
        });
        if self.p.silhouette {
            self.reseed_silhouette(seed, tri, &pts, &samples);
        }
        for i in 0..9 {
            let j = (i + 1) % 9;
            match self.p.edge {
                EdgeMode::Bisect => self.bisect(o, pts[i], samples[i], pts[j], samples[j], 0, seed.hit),
                EdgeMode::EdgePoint => self.walk_edge(o, pts[i], samples[i], pts[j], samples[j], seed.hit),
            }
        }
        if self.p.probe {
            self.probe_neighbours(seed.tri, tri, o);
        }
    }

    /// Corner re-seeding (this project's extension, "sil"): an outline point whose ray escaped or
    /// hit much farther than aimed lies past a silhouette of the seed's surface, and one whose ray
    /// hit much nearer lies behind an occluder. What hides there is best seen from the cell corner
    /// furthest out past the silhouette (or away from the occluder). From that corner, cast at the
    /// triangle's centre (when it hits the triangle, queue it as a seed from there, so ABS runs
    /// again from the new origin) and at the outline point. Each (triangle, corner) pair is tried
    /// once.
    pub(super) fn reseed_silhouette(
        &mut self,
        seed: Seed,
        tri: &[Vec3; 3],
        pts: &[Vec3; 9],
        samples: &[Sample; 9],
    ) {
        let o = seed.origin;
        let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
        let view = centre - o;
        let mut corners = 0u8;
        let mut aim = [Vec3::ZERO; 8];
        for (p, s) in pts.iter().zip(samples) {
            let aimed = (*p - o).length();
            let dist = (s.pos - o).length();
            let out = if s.tri == NONE || dist > aimed * (1.0 + self.p.disc) {
                // Past a silhouette of the seed's surface: move out past it.
                (*p - centre).reject_from(view)
            } else if dist < aimed * (1.0 - self.p.disc)
                && let Some(near) = self.tris.get(s.tri as usize)
            {
                // Behind an occluder: move away from the occluder to look around it.
                (*p - (near[0] + near[1] + near[2]) / 3.0).reject_from(view)
            } else {
                continue;
            };
            let k = u8::from(out.x > 0.0) | u8::from(out.y > 0.0) << 1 | u8::from(out.z > 0.0) << 2;
            if corners & (1 << k) == 0 {
                aim[k as usize] = *p;
            }
            corners |= 1 << k;
        }
        let Some(tried) = self.tried.get_mut(seed.tri as usize) else {
            return;
        };
        let todo = corners & !*tried;
        *tried |= corners;
        for k in 0..8u8 {
            if todo & (1 << k) == 0 || self.out_of_rays() {
                continue;
            }
            let pick =
                |bit: u8, axis: usize| if k & bit != 0 { self.cell.max[axis] } else { self.cell.min[axis] };
            let corner = Vec3::new(pick(1, 0), pick(2, 1), pick(4, 2));
            if (corner - o).length_squared() == 0.0 {
                continue;
            }
            let s = self.cast(corner, centre - corner, Class::Silhouette);
            if s.tri == seed.tri {
                self.queue.push_back(Seed { origin: corner, tri: seed.tri, hit: s.pos });
            } else if s.tri != NONE && self.insert(s.tri, corner, s.pos) {
                self.queue.push_back(Seed { origin: corner, tri: s.tri, hit: s.pos });
            }
            // And at the outline point that was hidden or past the silhouette from `o`.
            let p = aim[k as usize];
            self.handle(corner, p - corner, Class::Silhouette);
        }
    }
}
