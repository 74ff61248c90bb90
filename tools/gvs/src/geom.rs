//! Geometry for GVS: box view cells and their ray sampler, Halton numbers, the enlarged triangle
//! outline of adaptive border sampling, the `edgepoint` boundary crossing ([`Fan`]), and Liang–Barsky clipping.
//!
//! Angles are radians; `eps` offsets are angular (world offset = `eps × distance from the origin`).

use glam::{Vec3, Vec3A, Vec4};

/// A box view cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

/// Radical inverse of `i` in base `b`: the `i`-th Halton number, in `[0, 1)` (the reference the
/// tests check [`Halton5`] against).
#[cfg(test)]
pub(crate) fn halton(i: u64, b: u32) -> f32 {
    // The bases in use get constant divisors (multiplications instead of divisions).
    match b {
        2 => radical_inverse::<2>(i),
        3 => radical_inverse::<3>(i),
        5 => radical_inverse::<5>(i),
        7 => radical_inverse::<7>(i),
        11 => radical_inverse::<11>(i),
        _ => radical_inverse_in(i, u64::from(b)),
    }
}

#[inline(always)]
fn radical_inverse<const B: u64>(i: u64) -> f32 {
    radical_inverse_in(i, B)
}

/// The digits of `i` in base `b`, reversed behind the radix point. While `b · i < 2^53` the
/// reversed digits are gathered as an integer over `b^digits` (both exact in `f64`) with one
/// division at the end; larger `i` take a division per digit.
#[inline(always)]
fn radical_inverse_in(mut i: u64, b: u64) -> f32 {
    if b < 2 {
        return 0.0;
    }
    if i < (1u64 << 53) / b {
        let (mut digits, mut scale) = (0u64, 1u64);
        while i > 0 {
            digits = digits * b + i % b;
            scale *= b;
            i /= b;
        }
        return (digits as f64 / scale as f64) as f32;
    }
    let (mut f, mut r) = (1.0f64, 0.0f64);
    while i > 0 {
        f /= b as f64;
        r += f * (i % b) as f64;
        i /= b;
    }
    r as f32
}

/// Consecutive points of the five-dimensional Halton sequence (bases 2, 3, 5, 7, 11) of
/// [`Cell::sample_ray`], from a given index on: each point equals `halton(i, b)` in every base,
/// bit for bit, at an amortised constant cost (the digits of `i` are counted up, not recomputed).
#[derive(Debug, Clone)]
pub struct Halton5 {
    i: u64,
    dims: [Digits; 5],
}

/// The digits of an index in one base, for [`Halton5`].
#[derive(Debug, Clone)]
struct Digits {
    b: u64,
    /// Digits, least significant first, of an index below [`Digits::limit`].
    d: [u8; 53],
    /// `pow[k] = b^(len - 1 - k)`, with `b^len` (`scale`) the largest power of `b` exact in `f64`.
    pow: [u64; 53],
    scale: f64,
    /// The digits reversed behind the radix point, times `scale`: `Σ d[k] pow[k]`.
    num: u64,
    /// Indices from here on take `radical_inverse_in`'s exact path (see there): `2^53 / b`, kept
    /// because an integer division per use cost a fifth of the city's random rays' time.
    limit: u64,
}

impl Digits {
    fn new(b: u64, i: u64) -> Digits {
        let mut len = 0;
        let mut scale = 1u64;
        while scale <= (1u64 << 53) / b {
            scale *= b;
            len += 1;
        }
        let mut pow = [0u64; 53];
        let mut p = 1;
        for k in (0..len).rev() {
            pow[k] = p;
            p *= b;
        }
        let mut d = Digits { b, d: [0; 53], pow, scale: scale as f64, num: 0, limit: (1u64 << 53) / b };
        d.reset(i);
        d
    }

    fn reset(&mut self, mut i: u64) {
        self.d = [0; 53];
        self.num = 0;
        if i >= self.limit {
            return;
        }
        let mut k = 0;
        while i > 0 {
            self.d[k] = (i % self.b) as u8;
            self.num += u64::from(self.d[k]) * self.pow[k];
            i /= self.b;
            k += 1;
        }
    }

    /// From index `i - 1` (below the limit) to `i`.
    fn increment(&mut self) {
        let mut k = 0;
        loop {
            self.d[k] += 1;
            self.num += self.pow[k];
            if u64::from(self.d[k]) < self.b {
                return;
            }
            self.d[k] = 0;
            self.num -= self.b * self.pow[k];
            k += 1;
        }
    }

    fn value(&self, i: u64) -> f32 {
        if i < self.limit {
            // The same real number as `radical_inverse_in`'s quotient, both exact in `f64`.
            (self.num as f64 / self.scale) as f32
        } else {
            radical_inverse_in(i, self.b)
        }
    }
}

impl Halton5 {
    /// The sequence from index `i` on.
    pub fn new(i: u64) -> Halton5 {
        Halton5 { i, dims: [2, 3, 5, 7, 11].map(|b| Digits::new(b, i)) }
    }

    /// The point at the current index; then move to the next index (wrapping).
    pub fn next_point(&mut self) -> [f32; 5] {
        let i = self.i;
        let x = self.dims.each_ref().map(|d| d.value(i));
        let next = i.wrapping_add(1);
        for d in &mut self.dims {
            if next < d.limit && next > 0 {
                d.increment();
            } else {
                d.reset(next);
            }
        }
        self.i = next;
        x
    }
}

impl Cell {
    /// The cell from two corners in any order.
    pub fn new(a: Vec3, b: Vec3) -> Cell {
        Cell { min: a.min(b), max: a.max(b) }
    }

    /// Centre.
    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The eight corners; bit 0 of the index picks `max.x`, bit 1 `max.y`, bit 2 `max.z`.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|k| {
            Vec3::new(
                if k & 1 != 0 { self.max.x } else { self.min.x },
                if k & 2 != 0 { self.max.y } else { self.min.y },
                if k & 4 != 0 { self.max.z } else { self.min.z },
            )
        })
    }

    /// The point at fractions `f` (each in `0..=1`) of the way from `min` to `max`.
    pub fn at(&self, f: Vec3) -> Vec3 {
        self.min + (self.max - self.min) * f
    }

    /// A Halton point `x` as a segment's two ends: a point of the cell volume (`x[0..3]`) and a
    /// point of `tri` (`x[3..5]`, the unit square folded onto the triangle).
    pub fn segment_to(&self, tri: &[Vec3; 3], x: [f32; 5]) -> (Vec3, Vec3) {
        let [a, b, c, mut u, mut v] = x;
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        (self.at(Vec3::new(a, b, c)), tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v)
    }

    /// The cell moved by `v`.
    pub fn translated(&self, v: Vec3) -> Cell {
        Cell { min: self.min + v, max: self.max + v }
    }

    /// True when `p` is inside or on the cell (with `slack` world units of tolerance).
    pub fn contains(&self, p: Vec3, slack: f32) -> bool {
        p.cmpge(self.min - slack).all() && p.cmple(self.max + slack).all()
    }

    /// The nearest point of the cell to `p`.
    pub fn clamp(&self, p: Vec3) -> Vec3 {
        p.clamp(self.min, self.max)
    }

    /// The `i`-th quasi-random ray leaving the cell (thesis §4.1): a face chosen with probability
    /// proportional to its area, a uniform origin on it, and a direction uniform over the solid
    /// angle of the outward hemisphere. Five Halton dimensions (bases 2, 3, 5, 7, 11).
    /// A flat or degenerate cell samples its largest faces; a point cell samples the full sphere.
    pub fn sample_ray(&self, i: u64) -> (Vec3, Vec3) {
        // One call per base, so each divides by a constant (a multiplication).
        self.ray_at([
            radical_inverse::<2>(i),
            radical_inverse::<3>(i),
            radical_inverse::<5>(i),
            radical_inverse::<7>(i),
            radical_inverse::<11>(i),
        ])
    }

    /// The ray of [`Cell::sample_ray`] at the Halton point `x` (see `Halton5`).
    pub fn ray_at(&self, x: [f32; 5]) -> (Vec3, Vec3) {
        let d = self.max - self.min;
        let areas = [d.y * d.z, d.y * d.z, d.x * d.z, d.x * d.z, d.x * d.y, d.x * d.y];
        let total: f32 = areas.iter().sum();
        let r1 = std::f32::consts::TAU * x[3];
        let r2 = x[4];
        let s = (1.0 - r2 * r2).max(0.0).sqrt();
        if total.is_nan() || total <= 0.0 {
            // A point: uniform direction over the whole sphere.
            let z = 2.0 * r2 - 1.0;
            let s = (1.0 - z * z).max(0.0).sqrt();
            return (self.min, Vec3::new(r1.cos() * s, r1.sin() * s, z));
        }
        let mut pick = x[0] * total;
        let mut face = 5;
        for (k, &a) in areas.iter().enumerate() {
            if pick < a {
                face = k;
                break;
            }
            pick -= a;
        }
        let axis = face / 2;
        let positive = face % 2 == 1;
        let (ua, va) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut o = self.min;
        o[axis] = if positive { self.max[axis] } else { self.min[axis] };
        o[ua] = self.min[ua] + d[ua] * x[1];
        o[va] = self.min[va] + d[va] * x[2];
        let mut dir = Vec3::ZERO;
        dir[ua] = r1.cos() * s;
        dir[va] = r1.sin() * s;
        dir[axis] = if positive { r2 } else { -r2 };
        (o, dir)
    }

    /// Liang–Barsky: the parameter range `[l0, l1]` (within `[lo, hi]`) where `p + l d` is inside
    /// the cell, or `None`.
    pub fn clip(&self, p: Vec3, d: Vec3, lo: f32, hi: f32) -> Option<(f32, f32)> {
        let (mut l0, mut l1) = (lo, hi);
        for k in 0..3 {
            if d[k] == 0.0 {
                if p[k] < self.min[k] || p[k] > self.max[k] {
                    return None;
                }
                continue;
            }
            let a = (self.min[k] - p[k]) / d[k];
            let b = (self.max[k] - p[k]) / d[k];
            l0 = l0.max(a.min(b));
            l1 = l1.min(a.max(b));
        }
        (l0 <= l1).then_some((l0, l1))
    }
}

/// The enlarged outline `t'` of triangle `tri` seen from `o` (thesis eq. 12): nine points, three
/// per corner (offset across the incoming edge, the corner, offset across the outgoing edge), each
/// `eps × |p - o|` outside the triangle and perpendicular to the viewing ray, in order around the
/// triangle. Works for either winding and for back faces.
pub fn enlarge(tri: &[Vec3; 3], o: Vec3, eps: f32) -> [Vec3; 9] {
    let (tri, o) = (tri.map(Vec3A::from), Vec3A::from(o));
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let flip = if n.dot(o - tri[0]) < 0.0 { -1.0 } else { 1.0 };
    let mut out = [Vec3::ZERO; 9];
    for i in 0..3 {
        let p = tri[i];
        let next = tri[(i + 1) % 3];
        let prev = tri[(i + 2) % 3];
        let view = p - o;
        let out_next = view.cross(next - p).normalize_or_zero() * flip;
        let out_prev = view.cross(p - prev).normalize_or_zero() * flip;
        let corner = if out_next.dot(out_prev) > 0.0 {
            (out_next + out_prev).normalize_or_zero()
        } else {
            // Quadratic in the viewing side (view and the flipped normals both change sign), so
            // it takes the back-face flip once more.
            (view.cross(out_next) + out_prev.cross(view)).normalize_or_zero() * flip
        };
        let r = eps * view.length();
        out[3 * i] = Vec3::from(p + out_prev * r);
        out[3 * i + 1] = Vec3::from(p + corner * r);
        out[3 * i + 2] = Vec3::from(p + out_next * r);
    }
    out
}

/// The fan of rays from `o` through the points `a + s (b - a)` of a line, set up once for
/// [`Fan::span`] against any number of triangles.
#[derive(Debug, Clone, Copy)]
pub struct Fan {
    o: Vec3A,
    /// `a - o` and `b - a`.
    ao: Vec3A,
    ab: Vec3A,
    /// Normal of the fan's plane, `(a - o) × (b - o)`.
    n: Vec3A,
    /// `n × (a - o)` and `n × (b - a)`: the line parameter of the ray through a point `x` of the
    /// plane is `-(x - o)·na / (x - o)·nab`.
    na: Vec3A,
    nab: Vec3A,
}

impl Fan {
    /// The rays from `o` through the line from `a` (`s = 0`) to `b` (`s = 1`).
    pub fn new(o: Vec3, a: Vec3, b: Vec3) -> Fan {
        let (o, a, b) = (Vec3A::from(o), Vec3A::from(a), Vec3A::from(b));
        let (ao, ab) = (a - o, b - a);
        let n = ao.cross(b - o);
        Fan { o, ao, ab, n, na: n.cross(ao), nab: n.cross(ab) }
    }

    /// Where the fan's rays cross the boundary of triangle `tri` (thesis `edgepoint`,
    /// §4.3.4–4.3.5, computed as plane/edge intersections), crossings behind `o` left out: the
    /// smallest and the largest line parameter `s`, each with its boundary point (the same
    /// crossing twice when there is one), or `None` when there is none. Among equal `s` the
    /// smallest is the first edge's, the largest the last's.
    pub fn span(&self, tri: &[Vec3; 3]) -> Option<[(f32, Vec3); 2]> {
        // The three edges at once, edge `i` (from corner `i` to the next) in SIMD lane `i`, every
        // lane computed and the results selected (branches on which edges the plane cuts are
        // unpredictable). Coordinates are relative to `o`.
        let (o, n) = (self.o, self.n);
        let axis = |k: usize, from: usize| {
            let c = |i: usize| tri[(from + i) % 3][k] - o[k];
            Vec4::new(c(0), c(1), c(2), 0.0)
        };
        let (px, py, pz) = (axis(0, 0), axis(1, 0), axis(2, 0));
        let (qx, qy, qz) = (axis(0, 1), axis(1, 1), axis(2, 1));
        let dot = |v: Vec3A, x: Vec4, y: Vec4, z: Vec4| x * v.x + y * v.y + z * v.z;
        let (di, dj) = (dot(n, px, py, pz), dot(n, qx, qy, qz));
        let zero = Vec4::ZERO;
        let cut = (di.cmpgt(zero) ^ dj.cmpgt(zero)) & di.cmpne(dj);
        // Where the plane cuts each edge (`w = x - o`).
        let ratio = di / (di - dj);
        let (wx, wy, wz) = (px + (qx - px) * ratio, py + (qy - py) * ratio, pz + (qz - pz) * ratio);
        // `((b - a) × w)·n` and `((a - o) × w)·n` as one dot product each.
        let den = dot(self.nab, wx, wy, wz);
        let s = -dot(self.na, wx, wy, wz) / den;
        // The crossing must be in front of `o` along the ray through a + s (b - a).
        let (ao, ab) = (self.ao, self.ab);
        let ahead = (ao.x + ab.x * s) * wx + (ao.y + ab.y * s) * wy + (ao.z + ab.z * s) * wz;
        let ok = cut & den.cmpne(zero) & s.is_finite_mask() & ahead.cmpgt(zero);
        let lo: [f32; 4] = Vec4::select(ok, s, Vec4::INFINITY).into();
        let hi: [f32; 4] = Vec4::select(ok, s, Vec4::NEG_INFINITY).into();
        let (mut first, mut last) = (0, 0);
        for i in 1..3 {
            first = if lo[i] < lo[first] { i } else { first };
            last = if hi[i] >= hi[last] { i } else { last };
        }
        if lo[first] > hi[last] {
            return None;
        }
        let (wx, wy, wz): ([f32; 4], [f32; 4], [f32; 4]) = (wx.into(), wy.into(), wz.into());
        let point = |i: usize| Vec3::from(o + Vec3A::new(wx[i], wy[i], wz[i]));
        Some([(lo[first], point(first)), (hi[last], point(last))])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halton_matches_the_digit_by_digit_definition() {
        let reference = |mut i: u64, b: u64| {
            let (mut f, mut r) = (1.0f64, 0.0f64);
            while i > 0 {
                f /= b as f64;
                r += f * (i % b) as f64;
                i /= b;
            }
            r
        };
        let mut i = 1u64;
        while i < u64::MAX / 3 {
            for b in [2u32, 3, 5, 7, 11, 13] {
                for k in [i, i + 1, i * 2 + 1] {
                    let h = halton(k, b);
                    assert!((0.0..=1.0).contains(&h), "{k} base {b}: {h}");
                    assert!((f64::from(h) - reference(k, u64::from(b))).abs() < 1e-6, "{k} base {b}");
                }
            }
            i = i * 3 + 1;
        }
        assert!(halton(u64::MAX, 11) <= 1.0);
    }

    #[test]
    fn halton_sequence_equals_the_indexed_numbers() {
        let bases = [2, 3, 5, 7, 11];
        for start in [0u64, 1, 9, 242, 1_000_000, (1 << 53) / 11 - 300, u64::MAX - 40] {
            let mut seq = Halton5::new(start);
            for k in 0..600u64 {
                let i = start.wrapping_add(k);
                let want = bases.map(|b| halton(i, b).to_bits());
                assert_eq!(seq.next_point().map(f32::to_bits), want, "index {i}");
            }
        }
    }

    #[test]
    fn halton_base_two_and_three() {
        assert_eq!(halton(0, 13), 0.0);
        assert!((halton(1, 13) - 1.0 / 13.0).abs() < 1e-7);
        assert_eq!(halton(5, 1), 0.0);
        assert_eq!(halton(1, 2), 0.5);
        assert_eq!(halton(3, 2), 0.75);
        assert!((halton(2, 3) - 2.0 / 3.0).abs() < 1e-6);
    }

    #[test]
    fn sampled_rays_leave_the_cell_from_its_surface() {
        let c = Cell::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 2.5));
        for i in 1..500 {
            let (o, d) = c.sample_ray(i);
            assert!(c.contains(o, 1e-5));
            assert!((d.length() - 1.0).abs() < 1e-4);
            // Leaving: a step along d goes outside.
            assert!(!c.contains(o + d * 1e-2, 0.0) || d.length() == 0.0, "{o} {d}");
        }
    }

    #[test]
    fn enlarge_surrounds_the_triangle() {
        // The digest's worked example: viewer above a counter-clockwise triangle.
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        for o in [Vec3::new(0.0, 0.0, 10.0), Vec3::new(0.2, 0.3, -7.0)] {
            let pts = enlarge(&tri, o, 0.01);
            let corner0 = pts[1];
            assert!(corner0.x < 0.0 && corner0.y < 0.0, "{corner0}");
            // No enlarged point projects inside the triangle.
            for p in pts {
                let d = p - o;
                let t = -o.z / d.z;
                let q = o + d * t;
                let inside = q.x > 0.0 && q.y > 0.0 && q.x + q.y < 1.0;
                assert!(!inside, "{p} projects inside");
            }
        }
    }

    #[test]
    fn edgepoint_matches_the_digest_example() {
        let tri = [Vec3::new(0.0, -1.0, 3.0), Vec3::new(0.6, 1.0, 3.0), Vec3::new(-0.4, 1.0, 3.0)];
        let fan = Fan::new(Vec3::ZERO, Vec3::new(-1.0, 0.0, 5.0), Vec3::new(1.0, 0.0, 5.0));
        let [(s0, _), (s1, _)] = fan.span(&tri).expect("two crossings");
        assert!((s0 - 1.0 / 3.0).abs() < 1e-5 && (s1 - 0.75).abs() < 1e-5, "{s0} {s1}");
    }

    #[test]
    fn liang_barsky_clip() {
        let c = Cell::new(Vec3::ZERO, Vec3::ONE);
        let (a, b) = c.clip(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, 10.0).expect("crosses");
        assert!((a - 1.0).abs() < 1e-6 && (b - 2.0).abs() < 1e-6);
        assert!(c.clip(Vec3::new(-1.0, 2.0, 0.5), Vec3::X, 0.0, 10.0).is_none());
    }
}
