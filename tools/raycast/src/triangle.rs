//! The watertight ray/triangle test, one triangle at a time and four at once.

use glam::{Vec3, Vec4};

use crate::node::{Block, Prepared};

/// A ray prepared for the watertight test: the axis permutation and shear that map `dir` to +z.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ray {
    pub(crate) origin: Vec3,
    /// The dominant axis; the other two are `(kz + 1) % 3` and `(kz + 2) % 3`. (Woop et al. swap
    /// those two when `dir[kz] < 0` to keep the winding; that only negates u, v, w, det and the
    /// scaled t exactly, so the test is the same without it.)
    pub(crate) kz: usize,
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    pub(crate) sz: f32,
}

impl Ray {
    /// The ray's shear constants (watertight test), for `dir`'s dominant axis.
    #[inline]
    pub(crate) fn new(origin: Vec3, dir: Vec3) -> Ray {
        let kz = dominant_axis(dir);
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        Ray { origin, kz, sx: dir[kx] / dir[kz], sy: dir[ky] / dir[kz], sz: 1.0 / dir[kz] }
    }
}

/// The axis of `dir`'s largest component (the first of equals; 2 when any is NaN).
#[inline(always)]
pub(crate) fn dominant_axis(dir: Vec3) -> usize {
    let a = dir.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// A ray's origin and shear (see [`Ray`]) in the permuted axes `kx, ky, kz`, in all SIMD lanes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WideRay {
    pub(crate) o: [Vec4; 3],
    pub(crate) s: [Vec4; 3],
}

impl WideRay {
    #[inline(always)]
    pub(crate) fn new<const KZ: usize>(ray: &Ray) -> WideRay {
        let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
        let o = ray.origin;
        WideRay {
            o: [Vec4::splat(o[kx]), Vec4::splat(o[ky]), Vec4::splat(o[KZ])],
            s: [Vec4::splat(ray.sx), Vec4::splat(ray.sy), Vec4::splat(ray.sz)],
        }
    }
}

impl Block {
    /// [`tri_hit`] on the (up to four) triangles of the block at once: the nearest hit with
    /// `0 < t < t_max` as `(build position, t, u, v)`, the first of equals in lane order, exactly
    /// as testing them one after the other would give. Blocks where an edge function comes out
    /// exactly zero go through [`tri_hit`] (its `f64` recomputation).
    /// With `FRONT`, only triangles the ray meets from their front (see [`tri_hit_sided`]).
    #[inline(always)]
    pub(crate) fn hit<const KZ: usize, const FRONT: bool>(
        &self,
        r: &WideRay,
        ray: &Ray,
        t_max: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        let b = self;
        let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
        let [ox, oy, oz] = r.o;
        let [sx, sy, sz] = r.s;
        let p = &b.p;
        let (az, bz, cz) = (p[0][kz] - oz, p[1][kz] - oz, p[2][kz] - oz);
        let ax = (p[0][kx] - ox) - sx * az;
        let ay = (p[0][ky] - oy) - sy * az;
        let bx = (p[1][kx] - ox) - sx * bz;
        let by = (p[1][ky] - oy) - sy * bz;
        let cx = (p[2][kx] - ox) - sx * cz;
        let cy = (p[2][ky] - oy) - sy * cz;
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        if (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).any() {
            return b.hit_scalar::<KZ, FRONT>(ray, t_max);
        }
        let neg = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let pos = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let det = u + v + w;
        let t_scaled = u * (sz * az) + v * (sz * bz) + w * (sz * cz);
        let inv = Vec4::ONE / det;
        let t = t_scaled * inv;
        let facing = if FRONT { (det * sz).cmpgt(zero) } else { det.cmpne(zero) };
        let hit = !(neg & pos)
            & facing
            & det.cmpne(zero)
            & det.abs().cmplt(Vec4::INFINITY)
            & t.cmpgt(zero)
            & t.cmplt(Vec4::splat(t_max));
        let mask = hit.bitmask();
        if mask == 0 {
            return None;
        }
        let ts: [f32; 4] = t.into();
        let mut lane = mask.trailing_zeros() as usize;
        for i in lane + 1..4 {
            if mask & (1 << i) != 0 && ts[i] < ts[lane] {
                lane = i;
            }
        }
        Some((b.first as usize + lane, ts[lane], v[lane] * inv[lane], w[lane] * inv[lane]))
    }

    /// [`tri_hit`] on the block's triangles one after the other.
    fn hit_scalar<const KZ: usize, const FRONT: bool>(
        &self,
        ray: &Ray,
        t_max: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        let mut best = None;
        let mut t_best = t_max;
        for lane in 0..self.n as usize {
            if let Some((t, u, v)) = tri_hit_sided::<KZ, FRONT>(&self.tri(lane), ray, t_best) {
                t_best = t;
                best = Some((self.first as usize + lane, t, u, v));
            }
        }
        best
    }
}

/// Watertight ray/triangle test (Woop, Benthin and Wald 2013): `(t, u, v)` when the ray hits the
/// triangle with `0 < t < t_max`. Rays through a shared edge or corner hit at least one of the
/// triangles sharing it, so nothing leaks through the seams of a closed mesh; edge functions that
/// come out exactly zero are recomputed in `f64`.
#[inline(always)]
pub(crate) fn tri_hit<const KZ: usize>(tri: &Prepared, ray: &Ray, t_max: f32) -> Option<(f32, f32, f32)> {
    tri_hit_sided::<KZ, false>(tri, ray, t_max)
}

/// [`tri_hit`]; with `FRONT`, only when the ray meets the triangle from its front, the side
/// `(v1 - v0) × (v2 - v0)` points to (`dir · normal < 0`: the corners run counter-clockwise as
/// the ray sees them). The side comes from the sign of the test's own determinant, so a ray
/// meets each triangle of a closed mesh's seam from the same side as its neighbours.
#[inline(always)]
pub(crate) fn tri_hit_sided<const KZ: usize, const FRONT: bool>(
    tri: &Prepared,
    ray: &Ray,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let a = tri.v0 - ray.origin;
    let b = tri.v1 - ray.origin;
    let c = tri.v2 - ray.origin;
    let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
    let ax = a[kx] - ray.sx * a[kz];
    let ay = a[ky] - ray.sy * a[kz];
    let bx = b[kx] - ray.sx * b[kz];
    let by = b[ky] - ray.sy * b[kz];
    let cx = c[kx] - ray.sx * c[kz];
    let cy = c[ky] - ray.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let d = |p: f32, q: f32, r: f32, s: f32| {
            (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32
        };
        u = d(cx, by, cy, bx);
        v = d(ax, cy, ay, cx);
        w = d(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() || (FRONT && det * ray.sz <= 0.0) {
        return None;
    }
    let az = ray.sz * a[kz];
    let bz = ray.sz * b[kz];
    let cz = ray.sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    (t > 0.0 && t < t_max).then_some((t, v * inv, w * inv))
}
