//! Depth discontinuities and reverse sampling into the gap behind an occluder.

use glam::Vec3;

use crate::geom::Fan;

use super::{Class, Gvs, NONE, Sample};

impl Gvs<'_> {
    /// `check_discontinuity`: the ray `o + t (p - o)` hit `s`; when that is much nearer than `p`
    /// (`t < 1 - disc`: the hit is nearer by more than `disc` of the aimed distance), count it and
    /// (when enabled) reverse-sample into the gap behind the occluder. `e2` is a point known
    /// visible on the far surface (the seed's hit point).
    pub(crate) fn check_discontinuity(&mut self, o: Vec3, p: Vec3, s: Sample, e2: Vec3) {
        if s.tri == NONE || 1.0 - s.t <= self.p.disc {
            return;
        }
        self.stats.discontinuities += 1;
        if self.p.reverse && !self.out_of_rays() {
            self.reverse(o, p, e2, s.tri);
        }
    }

    /// Reverse sampling: the occluder `near` hides the aimed point `e1` from `o`; find the point of
    /// its boundary in the plane (o, e1, e2) on the side of `e2`, push it just outside, and shoot
    /// from where the line e1 → that point leaves through the cell back at `e1`.
    pub(super) fn reverse(&mut self, o: Vec3, e1: Vec3, e2: Vec3, near: u32) {
        let Some(tri) = self.tris.get(near as usize) else {
            return;
        };
        let Some([_, (s, x)]) = Fan::new(o, e1, e2).span(tri) else {
            return;
        };
        if s <= 0.0 {
            return;
        }
        let view = x - o;
        let side = (e2 - e1).reject_from(view).normalize_or_zero();
        let x = x + side * (self.p.eps * view.length());
        let d = x - e1;
        let Some((l0, _)) = self.cell.clip(e1, d, 1.0, f32::INFINITY) else {
            return;
        };
        let origin = e1 + d * l0;
        if (origin - e1).length_squared() > 0.0 {
            self.handle(origin, e1 - origin, Class::Reverse);
        }
    }
}
