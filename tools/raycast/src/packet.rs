//! Packet traversal: up to [`LANES`] rays traced together through the 4-wide tree, one ray per
//! lane of plain `f32` arrays, so that one node decision serves every ray of the packet and the
//! per-ray arithmetic vectorises across rays. The kernel is compiled for AVX-512, AVX2 and the
//! baseline, and the widest the CPU has is chosen at run time (x86-64; other targets use the
//! baseline). Measured on primary rays of 4×4 pixel tiles (`sightline gvs` ID buffers, Zen 5):
//! 1.8–2.0× the one-ray rate with AVX-512, 1.5–1.6× with AVX2, 0.95–1.04× with SSE2 only.
//!
//! A packet's rays share the dominant axis of the watertight test and the direction octant, so
//! the near and far box planes and the axis permutation are the same in every lane. Each lane does
//! exactly the `f32` operations of the one-ray path ([`Bvh::intersect`]): the box test decides only
//! which nodes are visited (conservatively, as for one ray), and the triangle test gives bit-identical
//! `t`, `u` and `v`. Among hits at exactly equal `t` the first found wins; the packet visits nodes
//! in its own order, so such ties may name a different triangle than the one-ray path.

// Lane loops index several per-lane arrays at once; plain indices keep them readable and
// vectorisable.
#![allow(clippy::needless_range_loop)]

use glam::{Vec3, Vec3A};

use crate::node::Block;
use crate::traverse::box_hit;
use crate::triangle::{Ray, dominant_axis, tri_hit};
use crate::{Bvh, Hit, STACK_DEEP, STACK_SMALL, WIDEN};

/// Most rays in one packet.
const LANES: usize = 16;

/// One `f32` per lane.
type F = [f32; LANES];

/// `a > b ? a : b`, the SSE `max` (no NaN special case), as the one-ray box test computes it.
#[inline(always)]
fn mx(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `a < b ? a : b`, the SSE `min`.
#[inline(always)]
fn mn(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// The rays of one packet, lane by lane. Lanes past the packet's rays copy its first ray and have
/// `t_best = -∞`, so they never enter a box and never hit.
struct Packet {
    /// Origin, reciprocal direction and widened reciprocal (see `Bvh::walk`), per world axis.
    o: [F; 3],
    inv: [F; 3],
    wide: [F; 3],
    /// Origin in the permuted axes `kx, ky, kz` and the shear of the watertight test.
    ok: [F; 3],
    s: [F; 3],
    t_best: F,
    t_wide: F,
    /// Build position of the best hit (`u32::MAX`: none) and its barycentrics.
    k: [u32; LANES],
    u: F,
    v: F,
}

impl Bvh {
    /// Closest hits of `rays` (origin, direction) with `0 < t < t_max`, as [`Bvh::intersect`]
    /// gives them one by one (the same `t`, `u`, `v`; see the module notes on ties), into `out`
    /// (cleared first, one entry per ray in order). Rays are grouped by dominant axis and octant
    /// and traced 16 at a time; coherent rays (one origin, nearby directions) gain most.
    pub fn intersect_many(&self, rays: &[(Vec3, Vec3)], t_max: f32, out: &mut Vec<Option<Hit>>) {
        out.clear();
        out.resize(rays.len(), None);
        if self.quads.is_empty() || t_max.is_nan() || t_max <= 0.0 {
            for (o, &(origin, dir)) in out.iter_mut().zip(rays) {
                *o = self.intersect(origin, dir, t_max);
            }
            return;
        }
        for (base, chunk) in rays.chunks(64).enumerate().map(|(c, r)| (c * 64, r)) {
            // Group key: dominant axis and octant (24 values).
            let mut keys = [0u8; 64];
            let mut present = 0u32;
            for (key, &(_, d)) in keys.iter_mut().zip(chunk) {
                *key = (dominant_axis(d) * 8
                    + usize::from(d.x < 0.0)
                    + 2 * usize::from(d.y < 0.0)
                    + 4 * usize::from(d.z < 0.0)) as u8;
                present |= 1 << *key;
            }
            while present != 0 {
                let g = present.trailing_zeros();
                present &= present - 1;
                let mut lanes = [0usize; LANES];
                let mut n = 0;
                for (j, &key) in keys[..chunk.len()].iter().enumerate() {
                    if u32::from(key) != g {
                        continue;
                    }
                    lanes[n] = base + j;
                    n += 1;
                    if n == LANES {
                        self.dispatch(rays, &lanes[..n], t_max, out, g as usize / 8);
                        n = 0;
                    }
                }
                if n == 1 {
                    let (origin, dir) = rays[lanes[0]];
                    out[lanes[0]] = self.intersect(origin, dir, t_max);
                } else if n > 1 {
                    self.dispatch(rays, &lanes[..n], t_max, out, g as usize / 8);
                }
            }
        }
    }

    /// Trace the packet `lanes` (indices into `rays`, dominant axis `kz`) with the widest SIMD
    /// the CPU has. Every flavour does the same `f32` operations in the same order (no fused
    /// multiply-add), so hits, ties included, do not depend on the CPU.
    fn dispatch(
        &self,
        rays: &[(Vec3, Vec3)],
        lanes: &[usize],
        t_max: f32,
        out: &mut [Option<Hit>],
        kz: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F (checked just above), all this function needs.
                // `unsafe` allowed here: a `#[target_feature]` (SIMD) function is unsafe to call.
                #[allow(unsafe_code)]
                unsafe {
                    self.packet_avx512(rays, lanes, t_max, out, kz)
                };
                return;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just above), all this function needs.
                // `unsafe` allowed here: a `#[target_feature]` (SIMD) function is unsafe to call.
                #[allow(unsafe_code)]
                unsafe {
                    self.packet_avx2(rays, lanes, t_max, out, kz)
                };
                return;
            }
        }
        self.packet_any(rays, lanes, t_max, out, kz);
    }

    /// [`Bvh::packet_any`] compiled for AVX-512 (one ray per lane of a 512-bit register).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn packet_avx512(
        &self,
        rays: &[(Vec3, Vec3)],
        lanes: &[usize],
        t_max: f32,
        out: &mut [Option<Hit>],
        kz: usize,
    ) {
        self.packet_any(rays, lanes, t_max, out, kz);
    }

    /// [`Bvh::packet_any`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn packet_avx2(
        &self,
        rays: &[(Vec3, Vec3)],
        lanes: &[usize],
        t_max: f32,
        out: &mut [Option<Hit>],
        kz: usize,
    ) {
        self.packet_any(rays, lanes, t_max, out, kz);
    }

    /// The packet traversal for the tree's stack size and the packet's axis.
    #[inline(always)]
    fn packet_any(
        &self,
        rays: &[(Vec3, Vec3)],
        lanes: &[usize],
        t_max: f32,
        out: &mut [Option<Hit>],
        kz: usize,
    ) {
        match (kz, self.deep) {
            (0, false) => self.packet::<0, STACK_SMALL>(rays, lanes, t_max, out),
            (1, false) => self.packet::<1, STACK_SMALL>(rays, lanes, t_max, out),
            (_, false) => self.packet::<2, STACK_SMALL>(rays, lanes, t_max, out),
            (0, true) => self.packet::<0, STACK_DEEP>(rays, lanes, t_max, out),
            (1, true) => self.packet::<1, STACK_DEEP>(rays, lanes, t_max, out),
            (_, true) => self.packet::<2, STACK_DEEP>(rays, lanes, t_max, out),
        }
    }

    /// The packet traversal proper: `lanes` (at most [`LANES`], at least one) index rays of
    /// dominant axis `KZ` and one octant.
    #[inline(always)]
    fn packet<const KZ: usize, const N: usize>(
        &self,
        rays: &[(Vec3, Vec3)],
        lanes: &[usize],
        t_max: f32,
        out: &mut [Option<Hit>],
    ) {
        let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
        // Idle lanes copy the first ray (their `t_best` stays -∞).
        let mut o = [[0f32; LANES]; 3];
        let mut d = [[0f32; LANES]; 3];
        for l in 0..LANES {
            let (origin, dir) = rays[lanes[l.min(lanes.len() - 1)]];
            for a in 0..3 {
                o[a][l] = origin[a];
                d[a][l] = dir[a];
            }
        }
        let mut pk = Packet {
            o,
            inv: [[0.0; LANES]; 3],
            wide: [[0.0; LANES]; 3],
            ok: [o[kx], o[ky], o[KZ]],
            s: [[0.0; LANES]; 3],
            t_best: [f32::NEG_INFINITY; LANES],
            t_wide: [f32::NEG_INFINITY; LANES],
            k: [u32::MAX; LANES],
            u: [0.0; LANES],
            v: [0.0; LANES],
        };
        // As `Bvh::walk` and `Ray::new` compute them, lane by lane.
        for a in 0..3 {
            for l in 0..LANES {
                let x = d[a][l];
                let safe = if x.abs() < f32::MIN_POSITIVE { f32::MIN_POSITIVE.copysign(x) } else { x };
                pk.inv[a][l] = 1.0 / safe;
                pk.wide[a][l] = pk.inv[a][l] * WIDEN;
            }
        }
        for l in 0..LANES {
            pk.s[0][l] = d[kx][l] / d[KZ][l];
            pk.s[1][l] = d[ky][l] / d[KZ][l];
            pk.s[2][l] = 1.0 / d[KZ][l];
        }
        // Lanes whose ray is not finite or misses the root box stay idle, as the one-ray path returns
        // at once.
        let mut any = false;
        for (l, &i) in lanes.iter().enumerate() {
            let (origin, dir) = rays[i];
            let inv = Vec3A::new(pk.inv[0][l], pk.inv[1][l], pk.inv[2][l]);
            // As in `Bvh::traverse`: a non-finite ray hits nothing.
            if origin.is_finite()
                && dir.is_finite()
                && box_hit(&self.nodes[0], Vec3A::from(origin), inv, t_max).is_some()
            {
                pk.t_best[l] = t_max;
                pk.t_wide[l] = t_max * WIDEN;
                any = true;
            }
        }
        if !any {
            return;
        }
        // The octant is the packet's: near planes of the box test per axis.
        let side = |i: f32, axis: usize| 2 * axis + usize::from(i < 0.0);
        let near_plane = [side(pk.inv[0][0], 0), side(pk.inv[1][0], 1), side(pk.inv[2][0], 2)];
        // Stack of (first, count) and the lanes' entry distances (NaN: not entered).
        let mut stack = [(0u32, 0u32); N];
        let mut stack_near = [[0f32; LANES]; N];
        let mut sp = 0usize;
        let (mut first, mut count) = (0u32, 0u32);
        loop {
            if count > 0 {
                let f = first as usize;
                for b in &self.blocks[f..f + count.div_ceil(4) as usize] {
                    for j in 0..b.n as usize {
                        hit_lanes::<KZ>(b, j, &mut pk, rays, lanes);
                    }
                }
            } else {
                let q = &self.quads[first as usize];
                let mut near = [[0f32; LANES]; 4];
                let mut key = [f32::INFINITY; 4];
                for (c, (near, key)) in near.iter_mut().zip(&mut key).enumerate() {
                    let [nx, ny, nz] = near_plane;
                    let (pnx, pny, pnz) = (q.planes[nx][c], q.planes[ny][c], q.planes[nz][c]);
                    let (pfx, pfy, pfz) = (q.planes[nx ^ 1][c], q.planes[ny ^ 1][c], q.planes[nz ^ 1][c]);
                    let ([ox, oy, oz], [ix, iy, iz], [wx, wy, wz]) = (&pk.o, &pk.inv, &pk.wide);
                    for l in 0..LANES {
                        let tn = mx(mx((pnx - ox[l]) * ix[l], (pny - oy[l]) * iy[l]), (pnz - oz[l]) * iz[l]);
                        let tf = mn(mn((pfx - ox[l]) * wx[l], (pfy - oy[l]) * wy[l]), (pfz - oz[l]) * wz[l]);
                        let far = mn(tf, pk.t_wide[l]);
                        let n = mx(tn, 0.0);
                        near[l] = if n <= far { n } else { f32::NAN };
                    }
                    // Smallest entry distance over the lanes (∞: no lane enters).
                    let mut m = [f32::INFINITY; LANES];
                    for l in 0..LANES {
                        if near[l] <= f32::MAX {
                            m[l] = near[l];
                        }
                    }
                    let mut w = LANES / 2;
                    while w > 0 {
                        for l in 0..w {
                            m[l] = mn(m[l], m[l + w]);
                        }
                        w /= 2;
                    }
                    *key = m[0];
                }
                // Entered children nearest first (lane order among equal distances), as in
                // `Bvh::walk` (sharing one helper made the one-ray loop 0.66× as fast: measured).
                let mut order = [0usize; 4];
                let mut n = 0;
                for i in 0..4 {
                    if key[i] < f32::INFINITY {
                        let mut j = n;
                        while j > 0 && key[order[j - 1]] > key[i] {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = i;
                        n += 1;
                    }
                }
                if n > 0 {
                    for &i in order[1..n].iter().rev() {
                        // `N` is at least the tree's need (`collapse`).
                        if sp < N {
                            stack[sp] = (q.first[i], q.count[i]);
                            stack_near[sp] = near[i];
                            sp += 1;
                        }
                    }
                    (first, count) = (q.first[order[0]], q.count[order[0]]);
                    continue;
                }
            }
            // Pop, skipping children that every lane's best hit already rules out.
            loop {
                if sp == 0 {
                    for (l, &i) in lanes.iter().enumerate() {
                        out[i] = (pk.k[l] != u32::MAX).then(|| Hit {
                            t: pk.t_best[l],
                            triangle: self.ids[pk.k[l] as usize],
                            u: pk.u[l],
                            v: pk.v[l],
                        });
                    }
                    return;
                }
                sp -= 1;
                let e = &stack_near[sp];
                let mut live = false;
                for l in 0..LANES {
                    live |= e[l] <= pk.t_best[l];
                }
                if live {
                    (first, count) = stack[sp];
                    break;
                }
            }
        }
    }
}

/// The watertight test of triangle `j` of block `b` in every lane, exactly as `Block::hit` and
/// [`tri_hit`] compute it for one ray; lanes where an edge function is exactly zero take
/// [`tri_hit`] itself (its `f64` recomputation).
#[inline(always)]
fn hit_lanes<const KZ: usize>(b: &Block, j: usize, pk: &mut Packet, rays: &[(Vec3, Vec3)], lanes: &[usize]) {
    let (kx, ky) = ((KZ + 1) % 3, (KZ + 2) % 3);
    let p = &b.p;
    let vx = [p[0][kx][j], p[1][kx][j], p[2][kx][j]];
    let vy = [p[0][ky][j], p[1][ky][j], p[2][ky][j]];
    let vz = [p[0][KZ][j], p[1][KZ][j], p[2][KZ][j]];
    let [okx, oky, okz] = &pk.ok;
    let [sx, sy, sz] = &pk.s;
    let mut t = [0f32; LANES];
    let mut u = [0f32; LANES];
    let mut v = [0f32; LANES];
    let mut hit = [false; LANES];
    let mut zero = false;
    for l in 0..LANES {
        let (az, bz, cz) = (vz[0] - okz[l], vz[1] - okz[l], vz[2] - okz[l]);
        let ax = (vx[0] - okx[l]) - sx[l] * az;
        let ay = (vy[0] - oky[l]) - sy[l] * az;
        let bx = (vx[1] - okx[l]) - sx[l] * bz;
        let by = (vy[1] - oky[l]) - sy[l] * bz;
        let cx = (vx[2] - okx[l]) - sx[l] * cz;
        let cy = (vy[2] - oky[l]) - sy[l] * cz;
        let e0 = cx * by - cy * bx;
        let e1 = ax * cy - ay * cx;
        let e2 = bx * ay - by * ax;
        zero |= e0 == 0.0 || e1 == 0.0 || e2 == 0.0;
        let neg = e0 < 0.0 || e1 < 0.0 || e2 < 0.0;
        let pos = e0 > 0.0 || e1 > 0.0 || e2 > 0.0;
        let det = e0 + e1 + e2;
        let t_scaled = e0 * (sz[l] * az) + e1 * (sz[l] * bz) + e2 * (sz[l] * cz);
        let inv = 1.0 / det;
        t[l] = t_scaled * inv;
        u[l] = e1 * inv;
        v[l] = e2 * inv;
        hit[l] =
            !(neg && pos) && det != 0.0 && det.abs() < f32::INFINITY && t[l] > 0.0 && t[l] < pk.t_best[l];
    }
    if zero {
        // Rare: redo the lanes with a zero edge function one by one.
        let tri = b.tri(j);
        for (l, &i) in lanes.iter().enumerate() {
            if pk.t_best[l] == f32::NEG_INFINITY {
                continue;
            }
            let (origin, dir) = rays[i];
            match tri_hit::<KZ>(&tri, &Ray::new(origin, dir), pk.t_best[l]) {
                Some((tl, ul, vl)) => {
                    (t[l], u[l], v[l]) = (tl, ul, vl);
                    hit[l] = true;
                }
                None => hit[l] = false,
            }
        }
    }
    let k = b.first + j as u32;
    for l in 0..LANES {
        if hit[l] {
            pk.t_best[l] = t[l];
            pk.t_wide[l] = t[l] * WIDEN;
            pk.k[l] = k;
            pk.u[l] = u[l];
            pk.v[l] = v[l];
        }
    }
}
