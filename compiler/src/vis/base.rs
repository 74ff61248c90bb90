//! Base vis (`mightsee`): per one-way portal, the portals that some straight line through it
//! could reach, ignoring occlusion.
//!
//! Portal `t` is a candidate for `p` when some point of `t` lies in front of `p`'s plane and some
//! point of `p` lies behind `t`'s plane, both by more than [`COPLANAR_EPSILON`]; candidates are
//! then flooded through clusters from the cluster `p` leads to. A leaf 0.01 units thick passes:
//! only portals within [`COPLANAR_EPSILON`] of the plane (numerically the same plane, where a
//! line through both would lie in the plane) are refused.

use rayon::prelude::*;

use super::bits;
use super::graph::{Graph, OneWay};

/// Points closer than this to a portal's plane count as lying in it for the front/back tests
/// (units; far below the 1/8-unit precision Quake BSP coordinates carry).
pub const COPLANAR_EPSILON: f64 = 1e-5;

/// True when some point of `t` lies in front of `p` by more than [`COPLANAR_EPSILON`].
#[inline]
fn any_in_front(g: &Graph, p: &OneWay, t: &OneWay) -> bool {
    let d = p.plane.distance(t.center);
    if d + t.radius <= COPLANAR_EPSILON {
        return false;
    }
    if d - t.radius > COPLANAR_EPSILON {
        return true;
    }
    g.winding(t).iter().any(|q| p.plane.distance(*q) > COPLANAR_EPSILON)
}

/// True when some point of `p` lies behind `t` by more than [`COPLANAR_EPSILON`].
#[inline]
fn any_behind(g: &Graph, p: &OneWay, t: &OneWay) -> bool {
    let d = t.plane.distance(p.center);
    if d - p.radius >= -COPLANAR_EPSILON {
        return false;
    }
    if d + p.radius < -COPLANAR_EPSILON {
        return true;
    }
    g.winding(p).iter().any(|q| t.plane.distance(*q) < -COPLANAR_EPSILON)
}

/// Portal spheres and planes as separate arrays, so the all-pairs scan streams through memory.
struct Soa {
    center: Vec<[f64; 4]>,
    plane: Vec<[f64; 4]>,
}

impl Soa {
    fn new(g: &Graph) -> Self {
        let center = g.portals.iter().map(|p| [p.center.x, p.center.y, p.center.z, p.radius]).collect();
        let plane = g
            .portals
            .iter()
            .map(|p| [p.plane.normal.x, p.plane.normal.y, p.plane.normal.z, p.plane.dist])
            .collect();
        Self { center, plane }
    }
}

/// The `mightsee` rows: `words` u64 per portal, portal after portal. `progress` is called once
/// per finished portal.
pub fn mightsee(g: &Graph, words: usize, progress: &(dyn Fn() + Sync)) -> Vec<u64> {
    let n = g.portals.len();
    let mut rows = vec![0u64; n * words];
    if words == 0 {
        return rows;
    }
    let soa = Soa::new(g);
    rows.par_chunks_mut(words).enumerate().for_each_init(
        || (vec![0u64; words], Vec::<u32>::new()),
        |(front, stack), (pi, row)| {
            front.fill(0);
            let p = &g.portals[pi];
            let [nx, ny, nz, nd] = soa.plane[pi];
            let [px, py, pz, pr] = soa.center[pi];
            for (ti, (c, t_plane)) in soa.center.iter().zip(&soa.plane).enumerate() {
                // Sphere tests first: most pairs are decided by them.
                let d = nx * c[0] + ny * c[1] + nz * c[2] - nd;
                if d + c[3] <= COPLANAR_EPSILON {
                    continue;
                }
                let e = t_plane[0] * px + t_plane[1] * py + t_plane[2] * pz - t_plane[3];
                if e - pr >= -COPLANAR_EPSILON || ti == pi {
                    continue;
                }
                let t = &g.portals[ti];
                let front_ok = d - c[3] > COPLANAR_EPSILON || any_in_front(g, p, t);
                if front_ok && (e + pr < -COPLANAR_EPSILON || any_behind(g, p, t)) {
                    bits::set(front, ti);
                }
            }
            // Flood through clusters using only candidate portals.
            stack.clear();
            stack.push(p.leaf);
            while let Some(c) = stack.pop() {
                for &ti in &g.cluster_portals[c as usize] {
                    let ti = ti as usize;
                    if bits::get(front, ti) && !bits::get(row, ti) {
                        bits::set(row, ti);
                        stack.push(g.portals[ti].leaf);
                    }
                }
            }
            progress();
        },
    );
    rows
}
