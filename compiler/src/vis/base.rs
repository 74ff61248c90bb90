//! Base vis (`mightsee`): per one-way portal, the portals that some straight line through it
//! could reach, ignoring occlusion.
//!
//! Portal `t` is a candidate for `p` when some point of `t` lies in front of `p`'s plane and some
//! point of `p` lies behind `t`'s plane, both by more than [`COPLANAR_EPSILON`]; candidates are
//! then flooded through clusters from the cluster `p` leads to. A leaf 0.01 units thick passes:
//! only portals within [`COPLANAR_EPSILON`] of the plane (numerically the same plane, where a
//! line through both would lie in the plane) are refused. (The reference `vis` uses 0.1 here,
//! which lets a leaf 0.01 units thick block sight.)

use std::sync::atomic::{AtomicU64, Ordering};

use super::graph::{Graph, OneWay};
use sightline_formats::bits;

/// Points closer than this to a portal's plane count as lying in it for the front/back tests
/// (units; far below the 1/8-unit precision Quake BSP coordinates carry).
pub const COPLANAR_EPSILON: f64 = 1e-5;

/// True when some point of `t` lies in front of `p` by more than [`COPLANAR_EPSILON`], for a
/// pair whose bounding spheres leave it open.
#[inline]
fn any_in_front(g: &Graph, p: &OneWay, t: &OneWay) -> bool {
    g.winding(t).iter().any(|q| p.plane.distance(*q) > COPLANAR_EPSILON)
}

/// True when some point of `p` lies behind `t` by more than [`COPLANAR_EPSILON`], for a pair
/// whose bounding spheres leave it open.
#[inline]
fn any_behind(g: &Graph, p: &OneWay, t: &OneWay) -> bool {
    g.winding(p).iter().any(|q| t.plane.distance(*q) < -COPLANAR_EPSILON)
}

/// Per cluster, the one-way portals leading out of it, side by side: what the flood reads for
/// each portal it meets, in one run of memory per cluster (entries `start[c]..start[c + 1]`, in
/// the order of [`Graph::cluster_portals`]).
struct Out {
    /// Per cluster, then one past the last.
    start: Vec<u32>,
    portal: Vec<u32>,
    /// The cluster the portal leads to.
    leaf: Vec<u32>,
    /// Its plane, `[normal, dist]`, and its bounding sphere, `[centre, radius]`.
    plane_sphere: Vec<[f64; 8]>,
}

/// Bytes [`Out`] takes per one-way portal (for [`super::memory_estimate`]); `4 (clusters + 1)`
/// more for `start`.
pub const OUT_BYTES_PER_PORTAL: u128 = 4 + 4 + 64;

impl Out {
    fn new(g: &Graph) -> Self {
        let n = g.portals.len();
        let mut out = Out {
            start: Vec::with_capacity(g.num_clusters() + 1),
            portal: Vec::with_capacity(n),
            leaf: Vec::with_capacity(n),
            plane_sphere: Vec::with_capacity(n),
        };
        for list in &g.cluster_portals {
            out.start.push(out.portal.len() as u32);
            for &t in list {
                let p = &g.portals[t as usize];
                let (nrm, c) = (p.plane.normal, p.center);
                out.portal.push(t);
                out.leaf.push(p.leaf);
                out.plane_sphere.push([nrm.x, nrm.y, nrm.z, p.plane.dist, c.x, c.y, c.z, p.radius]);
            }
        }
        out.start.push(out.portal.len() as u32);
        out
    }
}

/// The `mightsee` rows (`words` u64 per portal, portal after portal) and the cluster rows they
/// give. `progress` is called once per finished portal.
///
/// The flood from the cluster a portal leads to enters a portal when it is a candidate; each
/// cluster is entered once, so each portal out of it is met (and tested) once, and the work grows
/// with what a portal might see, not with the number of portals in the map. (Entering a cluster
/// once per portal into it cost, per source, the portals into a cluster times the portals out of
/// it: nothing on leaves with a few portals each, but quadratic on clusters merged by `coarsen`,
/// whose base vis of 10,000 tiny brushes did not finish in 15 minutes.)
pub fn mightsee(g: &Graph, words: usize, threads: usize, progress: &(dyn Fn() + Sync)) -> Mightsee {
    let n = g.portals.len();
    let nc = g.num_clusters();
    let cluster_words = bits::words(nc);
    let mut rows = vec![0u64; n * words];
    let out = Out::new(g);
    let reach: Vec<AtomicU64> = (0..nc * cluster_words).map(|_| AtomicU64::new(0)).collect();
    let tests = AtomicU64::new(0);
    // Chunks of `words` words, one per portal (none without portals).
    super::parallel::each_row(
        threads,
        &mut rows,
        words.max(1),
        || (vec![0u64; cluster_words], Vec::<u32>::new()),
        |(entered, stack), pi, row| {
            entered.fill(0);
            let p = &g.portals[pi];
            stack.clear();
            stack.push(p.leaf);
            bits::set(entered, p.leaf as usize);
            let (pn, pd, pc, pr) = (p.plane.normal, p.plane.dist, p.center, p.radius);
            let mut met = 0u64;
            while let Some(c) = stack.pop() {
                let c = c as usize;
                let range = out.start[c] as usize..out.start[c + 1] as usize;
                met += range.len() as u64;
                let entries = out.plane_sphere[range.clone()].iter().zip(&out.portal[range.clone()]);
                for ((&[nx, ny, nz, nd, x, y, z, radius], &ti), &next) in entries.zip(&out.leaf[range]) {
                    // `t` is a candidate for `p` when some point of `t` lies in front of `p` and
                    // some point of `p` behind `t`, each by more than `COPLANAR_EPSILON`; the
                    // bounding spheres decide most pairs (`Plane::distance` spelled out: the same
                    // operations in the same order), and first by `p` lying all in front of `t`,
                    // which refuses most of those refused.
                    let e = (nx * pc.x + ny * pc.y + nz * pc.z) - nd;
                    if e - pr >= -COPLANAR_EPSILON {
                        continue;
                    }
                    let d = (pn.x * x + pn.y * y + pn.z * z) - pd;
                    if d + radius <= COPLANAR_EPSILON {
                        continue;
                    }
                    let ti = ti as usize;
                    // `p` itself is met when the flood enters its own cluster; it is no candidate
                    // of itself.
                    if ti == pi {
                        continue;
                    }
                    // The winding points only where the spheres leave it open.
                    if (d - radius > COPLANAR_EPSILON || any_in_front(g, p, &g.portals[ti]))
                        && (e + pr < -COPLANAR_EPSILON || any_behind(g, p, &g.portals[ti]))
                    {
                        bits::set(row, ti);
                        if !bits::get(entered, next as usize) {
                            bits::set(entered, next as usize);
                            stack.push(next);
                        }
                    }
                }
            }
            let owner = p.owner as usize * cluster_words;
            for (w, &e) in entered.iter().enumerate().filter(|&(_, &e)| e != 0) {
                reach[owner + w].fetch_or(e, Ordering::Relaxed);
            }
            tests.fetch_add(met, Ordering::Relaxed);
            progress();
        },
    );
    let mut clusters: Vec<u64> = reach.into_iter().map(AtomicU64::into_inner).collect();
    for c in 0..nc {
        bits::set(&mut clusters[c * cluster_words..(c + 1) * cluster_words], c);
    }
    Mightsee { rows, clusters, tests: tests.into_inner() }
}

/// What base vis finds.
pub struct Mightsee {
    /// Per one-way portal, `words` words: the portals it might see.
    pub rows: Vec<u64>,
    /// Per cluster, `bits::words(clusters)` words: itself and every cluster the floods from its
    /// portals entered, which are the clusters its portals lead to and those they might see (so
    /// the cluster rows the `mightsee` rows give, before `M ∧ Mᵀ`).
    pub clusters: Vec<u64>,
    /// Portal pairs tested (each portal out of each cluster a flood entered): the work base vis
    /// did, which [`super::estimate`] turns into this run's speed.
    pub tests: u64,
}
