//! Edge sampling of the enlarged outline: recursive bisection (stock GVS) and the thesis'
//! edge-point walk.

use glam::Vec3;

use crate::geom::Fan;

use super::{Class, Gvs, Sample};

/// Most steps of one edge-point walk before it gives up.
const WALK_STEPS: u32 = 64;

impl Gvs<'_> {
    /// Cast an edge ray at `p`, handle it and check it for a discontinuity.
    fn edge_ray(&mut self, o: Vec3, p: Vec3, e2: Vec3) -> Sample {
        let s = self.handle(o, p - o, Class::Edge);
        self.check_discontinuity(o, p, s, e2);
        s
    }

    /// Stock recursive subdivision of the outline edge `a`–`b`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn bisect(&mut self, o: Vec3, a: Vec3, sa: Sample, b: Vec3, sb: Sample, depth: u32, e2: Vec3) {
        if sa.tri == sb.tri || depth >= self.p.max_depth || self.out_of_rays() {
            return;
        }
        let m = (a + b) * 0.5;
        if let Some(adt) = self.p.adt
            && (a - b).length() < adt * (m - o).length()
        {
            return;
        }
        let sm = self.edge_ray(o, m, e2);
        self.bisect(o, a, sa, m, sm, depth + 1, e2);
        self.bisect(o, m, sm, b, sb, depth + 1, e2);
    }

    /// The edge-point walk over the outline edge `a`–`b` (thesis `process_edge`).
    pub(crate) fn walk_edge(&mut self, o: Vec3, a: Vec3, sa: Sample, b: Vec3, sb: Sample, e2: Vec3) {
        if sa.tri == sb.tri {
            return;
        }
        if self.p.midpoint {
            let m = (a + b) * 0.5;
            let sm = self.edge_ray(o, m, e2);
            let mut steps = 0;
            self.walk(o, a, sa, m, sm, e2, &mut steps, 0);
            let mut steps = 0;
            self.walk(o, m, sm, b, sb, e2, &mut steps, 0);
        } else {
            let mut steps = 0;
            self.walk(o, a, sa, b, sb, e2, &mut steps, 0);
        }
    }

    /// One segment of the walk: step from `a` past the far boundary of its object, or from `b` past
    /// the near boundary of its object, or (both ends escaped, or no boundary found) bisect.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn walk(
        &mut self,
        o: Vec3,
        a: Vec3,
        sa: Sample,
        b: Vec3,
        sb: Sample,
        e2: Vec3,
        steps: &mut u32,
        depth: u32,
    ) {
        if sa.tri == sb.tri || *steps >= WALK_STEPS || depth >= self.p.max_depth || self.out_of_rays() {
            return;
        }
        *steps += 1;
        let len = (b - a).length();
        // Nothing narrower than the enlargement offset is resolved.
        let eps = self.p.eps;
        if len.is_nan() || len <= eps * ((a + b) * 0.5 - o).length() {
            return;
        }
        // Step past a boundary by a twentieth of the enlargement offset (at most a quarter of the
        // segment), in units of the segment.
        let push = |x: Vec3| (0.05 * eps * (x - o).length()).min(0.25 * len) / len;
        let fan = Fan::new(o, a, b);
        if let Some(tri) = self.tris.get(sa.tri as usize)
            && let Some([_, (s, x)]) = fan.span(tri)
        {
            let s = s + push(x);
            if s > 0.0 && s < 1.0 {
                let m = a + (b - a) * s;
                let sm = self.edge_ray(o, m, e2);
                if sm.tri != sa.tri {
                    self.walk(o, m, sm, b, sb, e2, steps, depth);
                    return;
                }
            }
        }
        if let Some(tri) = self.tris.get(sb.tri as usize)
            && let Some([(s, x), _]) = fan.span(tri)
        {
            let s = s - push(x);
            if s > 0.0 && s < 1.0 {
                let m = a + (b - a) * s;
                let sm = self.edge_ray(o, m, e2);
                if sm.tri != sb.tri {
                    self.walk(o, a, sa, m, sm, e2, steps, depth);
                    return;
                }
            }
        }
        let m = (a + b) * 0.5;
        let sm = self.edge_ray(o, m, e2);
        self.walk(o, a, sa, m, sm, e2, steps, depth + 1);
        self.walk(o, m, sm, b, sb, e2, steps, depth + 1);
    }
}
