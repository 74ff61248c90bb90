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

use glam::DVec3;

use super::graph::{Graph, OneWay};
use sightline_formats::bits;

/// Points closer than this to a portal's plane count as lying in it for the front/back tests
/// (units; far below the 1/8-unit precision Quake BSP coordinates carry).
pub const COPLANAR_EPSILON: f64 = 1e-5;

/// True when some point of `t` lies in front of `p` by more than [`COPLANAR_EPSILON`], for a
/// pair whose bounding spheres and boxes leave it open.
#[inline]
fn any_in_front(g: &Graph, p: &OneWay, t: &OneWay) -> bool {
    g.winding(t).iter().any(|q| p.plane.distance(*q) > COPLANAR_EPSILON)
}

/// True when some point of `p` lies behind `t` by more than [`COPLANAR_EPSILON`], for a pair
/// whose bounding spheres and boxes leave it open.
#[inline]
fn any_behind(g: &Graph, p: &OneWay, t: &OneWay) -> bool {
    g.winding(p).iter().any(|q| t.plane.distance(*q) < -COPLANAR_EPSILON)
}

/// A winding's box ([`Span`]): its points' least and greatest coordinates, and whether every
/// corner of it is one of the points (a rectangle lying along the axes, as most portals of
/// axis-aligned brushes are).
#[derive(Clone, Copy)]
struct WindingBox {
    lo: [f64; 3],
    hi: [f64; 3],
    corners: bool,
}

impl WindingBox {
    fn of(points: &[DVec3]) -> Self {
        let lo = points.iter().fold(DVec3::splat(f64::MAX), |a, &q| a.min(q)).to_array();
        let hi = points.iter().fold(DVec3::splat(f64::MIN), |a, &q| a.max(q)).to_array();
        // Four distinct points, each on a corner, and the box flat along an axis: then they are
        // its four corners.
        let on_corners = points.iter().all(|q| (0..3).all(|i| q[i] == lo[i] || q[i] == hi[i]));
        let distinct = points.iter().enumerate().all(|(i, q)| !points[..i].contains(q));
        let flat = (0..3).any(|i| lo[i] == hi[i]);
        Self { lo, hi, corners: points.len() == 4 && on_corners && distinct && flat }
    }

    /// Whether some point lies above `level` in front of the plane `(n, d)` (`n · x - d >
    /// level`), when the box decides it: the least and the greatest of `n · x - d` over the box
    /// bound the points', and when every corner is a point the greatest is a point's. A box
    /// decides only when it clears the level by [`BOX_SLACK`] times the magnitudes involved, far
    /// above the rounding of either sum, so it decides as the points' own tests would.
    #[inline]
    fn any_above(&self, n: DVec3, d: f64, level: f64) -> Option<bool> {
        let (mut least, mut most, mut size) = (-d, -d, d.abs());
        for i in 0..3 {
            let (a, b) = (n[i] * self.lo[i], n[i] * self.hi[i]);
            least += a.min(b);
            most += a.max(b);
            size += a.abs().max(b.abs());
        }
        let margin = BOX_SLACK * size;
        if most <= level - margin {
            Some(false)
        } else if least > level + margin || (self.corners && most > level + margin) {
            Some(true)
        } else {
            None
        }
    }
}

/// The share of the magnitudes of `n · x` and `d` a box must clear a level by
/// ([`WindingBox::any_above`]).
const BOX_SLACK: f64 = 1e-9;

/// Per cluster, the one-way portals leading out of it, side by side: what the flood reads for
/// each portal it meets, in one run of memory per cluster (entries `start[c]..start[c + 1]`).
/// A cluster with more than [`GROUP_ABOVE`] portals (one merged by `coarsen` or
/// `func_viscluster`) lists them by the direction of their normals, then by their planes' place
/// along it ([`run_order`]), in runs of [`GROUP`] bounded together ([`Group`]): a run that the
/// bounds show to lie wholly behind the source's plane, or to face wholly away from the source,
/// is refused whole.
struct Out {
    /// Per cluster, then one past the last.
    start: Vec<u32>,
    portal: Vec<u32>,
    /// The cluster the portal leads to.
    leaf: Vec<u32>,
    /// Its plane, `[normal, dist]`, and its bounding sphere, `[centre, radius]`.
    plane_sphere: Vec<[f64; 8]>,
    /// The box of its winding.
    boxes: Vec<WindingBox>,
    /// Per cluster, then one past the last: its runs in `groups` (none for small clusters).
    group_start: Vec<u32>,
    groups: Vec<Group>,
}

/// Clusters with more portals than this list them in runs ([`Out`]); fewer are tested one by one.
pub const GROUP_ABOVE: usize = 64;

/// Portals in a run of a large cluster's list ([`Out`]).
pub const GROUP: usize = 16;

/// A run of entries of [`Out`], `first..end`, and bounds of their planes and spheres, each grown
/// by [`GROUP_MARGIN`].
struct Group {
    /// A box holding their bounding spheres, `[min, max]`.
    bounds: [[f64; 3]; 2],
    /// A sphere holding their bounding spheres, `[centre, radius]`.
    sphere: [f64; 4],
    /// Their mean unit normal, `[normal, spread]`: every normal lies within `spread` of it.
    normal: [f64; 4],
    /// The greatest `mean normal · centre` of their spheres' centres.
    height: f64,
    /// The least `normal · centre - dist` of their planes (their spheres' centres lie in their
    /// planes up to the rounding of the points).
    offset: f64,
    /// The largest magnitude of a coordinate of the box, for the margin of [`Group::refused`].
    scale: f64,
    first: u32,
    end: u32,
}

/// Units a run's bounds are grown by, and a run refused only when its bounds clear the tests by
/// this much plus [`GROUP_SLACK`] times the magnitude of the coordinates involved: far above the
/// rounding of the member tests the run stands for (about 10⁻¹⁵ of those magnitudes), so a run
/// refused whole holds no portal its own test would take.
const GROUP_MARGIN: f64 = 1e-6;

/// The share of the coordinates' magnitude added to [`GROUP_MARGIN`].
const GROUP_SLACK: f64 = 1e-9;

/// Bytes [`Out`] takes per one-way portal (for [`super::memory_estimate`]): its entry, in a
/// large cluster its share of a run, and its place in the sort while built; `4 (clusters + 1)`
/// more for each of `start` and `group_start`.
pub const OUT_BYTES_PER_PORTAL: u128 = 4
    + 4
    + 64
    + std::mem::size_of::<WindingBox>() as u128
    + (std::mem::size_of::<Group>() / GROUP + 1) as u128
    + 4;

impl Out {
    fn new(g: &Graph) -> Self {
        let n = g.portals.len();
        let mut out = Out {
            start: Vec::with_capacity(g.num_clusters() + 1),
            portal: Vec::with_capacity(n),
            leaf: Vec::with_capacity(n),
            plane_sphere: Vec::with_capacity(n),
            boxes: Vec::with_capacity(n),
            group_start: Vec::with_capacity(g.num_clusters() + 1),
            groups: Vec::new(),
        };
        let mut order = Vec::new();
        for list in &g.cluster_portals {
            let first = out.portal.len();
            out.start.push(first as u32);
            out.group_start.push(out.groups.len() as u32);
            let large = list.len() > GROUP_ABOVE;
            let listed: &[u32] = if large {
                order.clear();
                order.extend_from_slice(list);
                run_order(g, &mut order);
                &order
            } else {
                list
            };
            for &t in listed {
                let p = &g.portals[t as usize];
                let (nrm, c) = (p.plane.normal, p.center);
                out.portal.push(t);
                out.leaf.push(p.leaf);
                out.plane_sphere.push([nrm.x, nrm.y, nrm.z, p.plane.dist, c.x, c.y, c.z, p.radius]);
                out.boxes.push(WindingBox::of(g.winding(p)));
            }
            if large {
                for run in (first..out.portal.len()).step_by(GROUP) {
                    let end = (run + GROUP).min(out.portal.len());
                    out.groups.push(Group::of(&out.plane_sphere[run..end], run, end));
                }
            }
        }
        out.start.push(out.portal.len() as u32);
        out.group_start.push(out.groups.len() as u32);
        out
    }
}

impl Group {
    /// The run of entries `first..end`, whose planes and spheres are `entries`.
    fn of(entries: &[[f64; 8]], first: usize, end: usize) -> Self {
        let grow = |x: f64| x * (1.0 + GROUP_SLACK) + GROUP_MARGIN;
        let k = entries.len().max(1) as f64;
        let centre_of = |e: &[f64; 8]| DVec3::new(e[4], e[5], e[6]);
        let normal_of = |e: &[f64; 8]| DVec3::new(e[0], e[1], e[2]);
        let lo = entries.iter().fold(DVec3::splat(f64::MAX), |a, e| a.min(centre_of(e) - e[7]));
        let hi = entries.iter().fold(DVec3::splat(f64::MIN), |a, e| a.max(centre_of(e) + e[7]));
        let centre = entries.iter().fold(DVec3::ZERO, |a, e| a + centre_of(e)) / k;
        let radius = entries.iter().map(|e| centre.distance(centre_of(e)) + e[7]).fold(0.0, f64::max);
        let normal = entries.iter().fold(DVec3::ZERO, |a, e| a + normal_of(e)).normalize_or_zero();
        let spread = entries.iter().map(|e| normal.distance(normal_of(e))).fold(0.0, f64::max);
        let height = entries.iter().map(|e| normal.dot(centre_of(e))).fold(f64::MIN, f64::max);
        let offset = entries.iter().map(|e| normal_of(e).dot(centre_of(e)) - e[3]).fold(f64::MAX, f64::min);
        let pad = |v: DVec3, sign: f64| v + sign * (v.abs() * GROUP_SLACK + GROUP_MARGIN);
        let (lo, hi) = (pad(lo, -1.0), pad(hi, 1.0));
        Group {
            bounds: [lo.to_array(), hi.to_array()],
            sphere: [centre.x, centre.y, centre.z, grow(radius)],
            normal: [normal.x, normal.y, normal.z, grow(spread)],
            height: height + height.abs() * GROUP_SLACK + GROUP_MARGIN,
            offset: offset - offset.abs() * GROUP_SLACK - GROUP_MARGIN,
            scale: lo.abs().max(hi.abs()).max_element(),
            first: first as u32,
            end: end as u32,
        }
    }

    /// Every portal of the run is refused as a candidate of a portal of plane `(pn, pd)` and
    /// bounding sphere `(pc, pr)`: by its sphere lying wholly behind that plane, or by that sphere
    /// lying wholly in front of its own plane (the two sphere tests of [`candidates`]).
    #[inline]
    fn refused(&self, pn: DVec3, pd: f64, pc: DVec3, pr: f64) -> bool {
        let margin = GROUP_MARGIN + GROUP_SLACK * (self.scale + pc.abs().max_element() + pr + pd.abs());
        // The box's corner farthest in front of `p`.
        let [lo, hi] = self.bounds;
        let front: f64 = (0..3).map(|i| (pn[i] * lo[i]).max(pn[i] * hi[i])).sum();
        if front - pd <= COPLANAR_EPSILON - margin {
            return true;
        }
        // A member's `n · pc - dist` is `n · (pc - c) + offset` for its centre `c`: at least
        // `mean · pc - height - spread |pc - c| + least offset`, and `|pc - c|` is at most
        // `|pc - centre| + radius`.
        let [nx, ny, nz, spread] = self.normal;
        let [x, y, z, radius] = self.sphere;
        let turn = if spread > 0.0 { spread * (pc.distance(DVec3::new(x, y, z)) + radius) } else { 0.0 };
        let least = DVec3::new(nx, ny, nz).dot(pc) - self.height - turn + self.offset;
        least - pr >= -COPLANAR_EPSILON + margin
    }
}

/// Sorts `list` (one-way portals) by the direction of their normals (the axis nearest, its sign,
/// and a 3 × 3 grid of the other two components), then by their centres' place along that axis
/// (so a run's planes lie close together, and most runs lie wholly on one side of a source), then
/// along a Z-order curve of their centres, then by index.
fn run_order(g: &Graph, list: &mut [u32]) {
    let centre = |t: u32| g.portals[t as usize].center;
    let (lo, hi) = list.iter().fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(lo, hi), &t| {
        (lo.min(centre(t)), hi.max(centre(t)))
    });
    let scale = 1023.0 / (hi - lo).max_element().max(f64::MIN_POSITIVE);
    let key = |t: u32| {
        let q = ((centre(t) - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(1023.0));
        // Bits of a 10-bit coordinate spread three apart, for the Z-order key.
        let interleave = |v: f64| {
            let mut x = v as u64;
            let mut out = 0u64;
            for b in 0..10 {
                out |= (x & 1) << (3 * b);
                x >>= 1;
            }
            out
        };
        let n = g.portals[t as usize].plane.normal;
        let a = n.abs().max_position();
        let (u, v) = (n[(a + 1) % 3], n[(a + 2) % 3]);
        let bin = |c: f64| ((c + 1.0) * 1.5).clamp(0.0, 2.0) as u64;
        let direction = (2 * a as u64 + u64::from(n[a] < 0.0)) * 9 + bin(u) * 3 + bin(v);
        let along = if n[a] < 0.0 { 1023.0 - q[a] } else { q[a] };
        (direction, (along * 1024.0) as u64, interleave(q.x) | interleave(q.y) << 1 | interleave(q.z) << 2)
    };
    list.sort_by_cached_key(|&t| (key(t), t));
}

/// The `mightsee` rows (`words` u64 per portal, portal after portal) and the cluster rows they
/// give. `progress` is called once per finished portal.
///
/// The flood from the cluster a portal leads to enters a portal when it is a candidate; each
/// cluster is entered once, so each portal out of it is met (and tested) once, and the work grows
/// with what a portal might see, not with the number of portals in the map. (Entering a cluster
/// once per portal into it cost, per source, the portals into a cluster times the portals out of
/// it: nothing on leaves with a few portals each, but quadratic on clusters merged by `coarsen`,
/// whose base vis of 10,000 tiny brushes did not finish in 15 minutes.) In a cluster of more than
/// [`GROUP_ABOVE`] portals a run refused whole by its bounds ([`Group`]) costs one test: on the
/// 10,000 tiny brushes merged into 73 clusters, where a flood meets about all 87,010 portals,
/// base vis took 17–20 s instead of 39–58 s, with the same rows. A pair the bounding spheres
/// leave open is decided by the boxes of the two windings where they can ([`WindingBox`]: always,
/// but within rounding margins, for rectangles along the axes), and only then by the points,
/// which lie apart from the entries the flood reads: on the same merged room (whose portals are
/// all such rectangles) base vis took 12.5–14.2 s instead of 17.9–24.7 s, and the whole vis 18 %
/// less CPU, with the same rows.
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
            let (pn, pd) = (p.plane.normal, p.plane.dist);
            let p_box = WindingBox::of(g.winding(p));
            let mut met = 0u64;
            while let Some(c) = stack.pop() {
                let c = c as usize;
                let runs = &out.groups[out.group_start[c] as usize..out.group_start[c + 1] as usize];
                if runs.is_empty() {
                    let range = out.start[c] as usize..out.start[c + 1] as usize;
                    met += range.len() as u64;
                    candidates(g, &out, (pi, &p_box), range, row, entered, stack);
                    continue;
                }
                for run in runs {
                    met += 1;
                    if run.refused(pn, pd, p.center, p.radius) {
                        continue;
                    }
                    let range = run.first as usize..run.end as usize;
                    met += range.len() as u64;
                    candidates(g, &out, (pi, &p_box), range, row, entered, stack);
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

/// Tests the entries `range` of [`Out`] as candidates of portal `pi` (whose winding's box is
/// `p_box`): each one taken is set in `row`, and the cluster it leads to, if not yet `entered`,
/// is entered and pushed on `stack`.
#[inline]
fn candidates(
    g: &Graph,
    out: &Out,
    (pi, p_box): (usize, &WindingBox),
    range: std::ops::Range<usize>,
    row: &mut [u64],
    entered: &mut [u64],
    stack: &mut Vec<u32>,
) {
    let p = &g.portals[pi];
    let (pn, pd, pc, pr) = (p.plane.normal, p.plane.dist, p.center, p.radius);
    let entries = out.plane_sphere[range.clone()].iter().zip(&out.portal[range.clone()]);
    let entries = entries.zip(&out.boxes[range.clone()]);
    for (((&[nx, ny, nz, nd, x, y, z, radius], &ti), t_box), &next) in entries.zip(&out.leaf[range]) {
        // `t` is a candidate for `p` when some point of `t` lies in front of `p` and some point of
        // `p` behind `t`, each by more than `COPLANAR_EPSILON`; the bounding spheres decide most
        // pairs (`Plane::distance` spelled out: the same operations in the same order), and
        // first by `p` lying all in front of `t`, which refuses most of those refused.
        let e = (nx * pc.x + ny * pc.y + nz * pc.z) - nd;
        if e - pr >= -COPLANAR_EPSILON {
            continue;
        }
        let d = (pn.x * x + pn.y * y + pn.z * z) - pd;
        if d + radius <= COPLANAR_EPSILON {
            continue;
        }
        let ti = ti as usize;
        // `p` itself is met when the flood enters its own cluster; it is no candidate of itself.
        if ti == pi {
            continue;
        }
        // Then the boxes of the windings, and their points only where the boxes leave it open.
        // Some point of `p` lies behind `t` by more than the epsilon when one lies above it in
        // front of the reversed plane.
        let in_front = d - radius > COPLANAR_EPSILON
            || t_box
                .any_above(pn, pd, COPLANAR_EPSILON)
                .unwrap_or_else(|| any_in_front(g, p, &g.portals[ti]));
        let behind = || {
            e + pr < -COPLANAR_EPSILON
                || p_box
                    .any_above(-DVec3::new(nx, ny, nz), -nd, COPLANAR_EPSILON)
                    .unwrap_or_else(|| any_behind(g, p, &g.portals[ti]))
        };
        if in_front && behind() {
            bits::set(row, ti);
            if !bits::get(entered, next as usize) {
                bits::set(entered, next as usize);
                stack.push(next);
            }
        }
    }
}

/// What base vis finds.
pub struct Mightsee {
    /// Per one-way portal, `words` words: the portals it might see.
    pub rows: Vec<u64>,
    /// Per cluster, `bits::words(clusters)` words: itself and every cluster the floods from its
    /// portals entered, which are the clusters its portals lead to and those they might see (so
    /// the cluster rows the `mightsee` rows give, before `M ∧ Mᵀ`).
    pub clusters: Vec<u64>,
    /// Portal pairs tested (each portal out of each cluster a flood entered, but a run of a large
    /// cluster refused whole counts once): the work base vis did, which [`super::estimate`]
    /// turns into this run's speed.
    pub tests: u64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_formats::geom::Winding;
    use sightline_formats::prt::{PortalFile, PrtPortal};
    use sightline_job::rng::SplitMix64;

    /// `portals` random quads between `clusters` clusters in a 16-unit box: half facing along an
    /// axis, centred on a 1/256-unit grid with sides of 3 × 4, 6 × 8 or 5 × 12 eighths (so
    /// spheres touch planes, or miss them by 1/256, often), half facing any way.
    fn random_portals(portals: usize, clusters: u32, seed: u64, shift: DVec3) -> PortalFile {
        let mut rng = SplitMix64::new(seed);
        let mut list = Vec::new();
        while list.len() < portals {
            let grid = |rng: &mut SplitMix64| rng.below(16 * 256) as f64 / 256.0;
            let (centre, normal, (a, b)) = if rng.below(2) == 0 {
                let mut n = DVec3::ZERO;
                n[rng.below(3)] = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                let half = [(3.0, 4.0), (6.0, 8.0), (5.0, 12.0)][rng.below(3)];
                let c = DVec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng));
                (c, n, (half.0 / 16.0, half.1 / 16.0))
            } else {
                let c =
                    DVec3::new(rng.range_f64(0.0, 16.0), rng.range_f64(0.0, 16.0), rng.range_f64(0.0, 16.0));
                let n =
                    DVec3::new(rng.range_f64(-1.0, 1.0), rng.range_f64(-1.0, 1.0), rng.range_f64(-1.0, 1.0));
                (c, n.normalize_or_zero(), (rng.range_f64(0.1, 3.0), rng.range_f64(0.1, 3.0)))
            };
            if normal == DVec3::ZERO {
                continue;
            }
            let u = normal.any_orthonormal_vector();
            let v = normal.cross(u);
            let pts = [(-a, -b), (a, -b), (a, b), (-a, b)].map(|(s, t)| shift + centre + s * u + t * v);
            let from = rng.below(clusters as usize) as u32;
            let to = (from + 1 + rng.below(clusters as usize - 1) as u32) % clusters;
            list.push(PrtPortal { leaves: [from, to], winding: Winding::new(pts.to_vec()) });
        }
        PortalFile::prt1(clusters, list)
    }

    /// Refusing runs of a large cluster's portals whole (by their bounds) takes exactly the
    /// candidates that testing each portal takes, on clusters of hundreds of portals facing every
    /// way, near the origin and ten million units from it, and the bounds do refuse runs.
    #[test]
    fn runs_refused_whole_hold_no_candidate() {
        for seed in 0..8 {
            let shift = if seed < 4 { DVec3::ZERO } else { DVec3::new(1e7, -3e6, 5e5) };
            let prt = random_portals(600, 3 + seed as u32 % 3, seed, shift);
            let g = Graph::new(&prt);
            let (n, words) = (g.portals.len(), bits::words(g.portals.len()));
            let out = Out::new(&g);
            assert!(!out.groups.is_empty(), "seed {seed}: no cluster over {GROUP_ABOVE} portals");
            let got = mightsee(&g, words, 2, &|| {});
            let mut refused = 0;
            for pi in 0..n {
                // The same flood, every portal tested on its own.
                let mut want = vec![0u64; words];
                let mut entered = vec![0u64; bits::words(g.num_clusters())];
                let mut stack = vec![g.portals[pi].leaf];
                bits::set(&mut entered, g.portals[pi].leaf as usize);
                while let Some(c) = stack.pop() {
                    let range = out.start[c as usize] as usize..out.start[c as usize + 1] as usize;
                    candidates(
                        &g,
                        &out,
                        (pi, &WindingBox::of(g.winding(&g.portals[pi]))),
                        range,
                        &mut want,
                        &mut entered,
                        &mut stack,
                    );
                }
                assert_eq!(&got.rows[pi * words..(pi + 1) * words], &want[..], "seed {seed}, portal {pi}");
                let p = &g.portals[pi];
                refused += out
                    .groups
                    .iter()
                    .filter(|r| r.refused(p.plane.normal, p.plane.dist, p.center, p.radius))
                    .count();
            }
            assert!(refused > 0, "seed {seed}: no run refused");
        }
    }

    /// A winding's box decides whether some point lies in front of a plane exactly as the points
    /// do, whenever it decides, on quads along the axes whose spheres and boxes touch planes or
    /// miss them by 1/256 (near the origin and ten million units from it) and on quads facing any
    /// way; and where the winding is a rectangle along the axes, it decides nine in ten of the
    /// pairs the spheres leave open (all of them near the origin).
    #[test]
    fn boxes_decide_as_the_points_do() {
        for seed in 0..4 {
            let shift = if seed < 2 { DVec3::ZERO } else { DVec3::new(1e7, -3e6, 5e5) };
            let g = Graph::new(&random_portals(300, 4, seed, shift));
            let boxes: Vec<WindingBox> = g.portals.iter().map(|p| WindingBox::of(g.winding(p))).collect();
            assert!(boxes.iter().any(|b| b.corners) && boxes.iter().any(|b| !b.corners), "seed {seed}");
            let (mut open, mut decided) = (0, 0);
            for (pi, p) in g.portals.iter().enumerate() {
                for (ti, t) in g.portals.iter().enumerate().filter(|&(ti, _)| ti != pi) {
                    let front = boxes[ti].any_above(p.plane.normal, p.plane.dist, COPLANAR_EPSILON);
                    let behind = boxes[pi].any_above(-t.plane.normal, -t.plane.dist, COPLANAR_EPSILON);
                    // The spheres' margins: where they leave the answer open.
                    let (d, e) = (p.plane.distance(t.center), t.plane.distance(p.center));
                    let sphere_open = [
                        d - t.radius <= COPLANAR_EPSILON && d + t.radius > COPLANAR_EPSILON,
                        e + p.radius >= -COPLANAR_EPSILON && e - p.radius < -COPLANAR_EPSILON,
                    ];
                    let checks = [(front, any_in_front(&g, p, t)), (behind, any_behind(&g, p, t))];
                    let rectangle = [boxes[ti].corners, boxes[pi].corners];
                    for (((said, truth), sphere_open), rectangle) in
                        checks.into_iter().zip(sphere_open).zip(rectangle)
                    {
                        if let Some(said) = said {
                            assert_eq!(said, truth, "seed {seed}, portals {pi} and {ti}");
                        }
                        let counted = sphere_open && rectangle;
                        open += usize::from(counted);
                        decided += usize::from(counted && said.is_some());
                    }
                }
            }
            assert!(
                decided * 10 > open * 9,
                "seed {seed}: boxes decided {decided} of the {open} the spheres leave open"
            );
        }
    }

    /// Base vis's rows are those the definition gives: the flood from each portal's cluster
    /// through every portal some point of which lies in front of it while some point of it lies
    /// behind that portal, tested point by point.
    #[test]
    fn rows_are_the_definitions() {
        for seed in 0..4 {
            let shift = if seed < 2 { DVec3::ZERO } else { DVec3::new(1e7, -3e6, 5e5) };
            let g = Graph::new(&random_portals(400, 40, seed, shift));
            let (n, words) = (g.portals.len(), bits::words(g.portals.len()));
            let got = mightsee(&g, words, 2, &|| {});
            for (pi, p) in g.portals.iter().enumerate() {
                let mut want = vec![0u64; words];
                let mut entered = vec![false; g.num_clusters()];
                let mut stack = vec![p.leaf];
                entered[p.leaf as usize] = true;
                while let Some(c) = stack.pop() {
                    for &ti in &g.cluster_portals[c as usize] {
                        let t = &g.portals[ti as usize];
                        if ti as usize != pi && any_in_front(&g, p, t) && any_behind(&g, p, t) {
                            bits::set(&mut want, ti as usize);
                            if !std::mem::replace(&mut entered[t.leaf as usize], true) {
                                stack.push(t.leaf);
                            }
                        }
                    }
                }
                assert_eq!(
                    &got.rows[pi * words..(pi + 1) * words],
                    &want[..],
                    "seed {seed}, portal {pi} of {n}"
                );
            }
        }
    }
}
