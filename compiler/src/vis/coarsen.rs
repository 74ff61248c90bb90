//! Coarsening: merge clusters into fewer, larger ones until a vis that would not fit memory, or
//! would take more than its work limit, does ([`VisOptions::coarsen`]; [`super::memory_estimate`]
//! and [`super::work_estimate`]). The result is a portal file over the same leaves whose
//! clusters are unions of the input's, with only the portals whose two sides land in different
//! new clusters; vis runs on it as on any PRT2 file, and a leaf's row is its new cluster's row.
//! `expand` then gives each input cluster its merged cluster's row (over input clusters), so
//! callers see the input's clusters (a compile stores rows per cluster, the far plane bounds them).
//!
//! # Why the PVS stays conservative
//! A real sight line crosses a sequence of portals, each leading from one cluster into the next.
//! After merging, the portals inside a merged cluster are gone, and the line crosses the
//! subsequence of the remaining ones, consecutive ones sharing a (merged) cluster: a chain of the
//! coarse file. Every constraint vis puts on that chain (clipping to each portal's front,
//! separating planes between its portals) is one it put on the longer fine chain, which held
//! the same portals and more; so constraints are only relaxed, and every cluster pair a line
//! joins stays visible. The merged rows (expanded to the input's clusters) hold nearly every pair
//! of the unmerged PVS as well, but not always all: a few pairs that no line joins get through
//! only the unmerged flow's tolerances, which round toward visible at every clip of the longer
//! chains (4–176 of 0.2–3 million pairs on E1M1 and the generated heavy maps, none found by
//! 40 M validator rays, 2026-11-29, `docs/benchmarks.md`).
//!
//! # Grouping
//! A cluster's centre is the centre of the bounds of its portal windings (a cluster without
//! portals stays alone). For a grid of cubic cells of side `cell`, anchored at the lowest corner
//! of all centres, two clusters merge when a portal joins them and both centres fall in the same
//! cell; the groups are the connected components of those portals. Groups are therefore
//! spatially compact and connected through portals. `cell` starts at the median cluster extent and
//! grows by the cube root of 2 a step (a cell's volume doubles) until the memory and work
//! estimates of the result fit their limits, the least merging of this scheme that does, or until
//! one cell holds every centre (then the groups are the connected components of the whole portal
//! graph, the coarsest this scheme makes); if that does not fit either, there is no coarsening.
//!
//! # Determinism
//! [`super::run`] sizes the merge for one thread (then checks the run fits with its own), so the
//! merge and the PVS are the same for any thread count. Components are found by union-find with the lower cluster as root; new clusters are numbered
//! in the order of their lowest input cluster, and portals keep their input order. Nothing
//! depends on threads or hashing.

use glam::DVec3;
use sightline_formats::bits;
use sightline_formats::prt::{PortalFile, PrtFormat, PrtPortal};

pub use super::stats::{CoarsenStats, MergedGroup};

use super::budget::Counts;
use super::options::VisOptions;
use super::stats::VisResult;

/// The limits a merge must fit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Limits {
    /// Bytes ([`super::memory_estimate`] plus the expanded rows).
    pub memory: u64,
    /// Portal tests, base-vis tests weighed as the limits weigh them (`budget::limit_work`).
    pub work: u64,
}

/// Growth of the cell's side per step: the cube root of 2, so each step doubles a cell's volume
/// (doubling the side, eight times the volume a step, overshot the limits by far: 10,000 tiny
/// brushes under a 4 GiB limit merged into 14 clusters using a fifth of it).
const GROWTH: f64 = 1.259_921_049_894_873;

/// How many steps the cell may grow (from the median cluster extent, this spans any coordinates
/// a portal file holds).
const MAX_STEPS: u32 = 192;

/// A coarsened input: the portal file vis runs on, and the merged cluster of each input cluster.
pub(crate) struct Coarse {
    /// The merged portal file.
    pub prt: PortalFile,
    /// Per input cluster, its merged cluster.
    pub new_id: Vec<u32>,
    /// What was done.
    pub stats: CoarsenStats,
}

/// Merge `prt`'s clusters until the vis estimates fit `limits` (see the module docs). `None` when
/// even the coarsest grouping does not fit.
pub(crate) fn fit(prt: &PortalFile, opts: &VisOptions, limits: Limits) -> Option<Coarse> {
    let nc = prt.num_clusters as usize;
    // The expanded rows, one per input cluster.
    let expanded = 8 * (nc as u64).saturating_mul(bits::words(nc) as u64);
    let centres = centres(prt);
    let placed: Vec<DVec3> = centres.iter().flatten().copied().collect();
    let lo = placed.iter().fold(DVec3::splat(f64::INFINITY), |a, &b| a.min(b));
    let hi = placed.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, &b| a.max(b));
    let span = (hi - lo).max_element();
    let mut cell = median_extent(prt).max(1.0);
    for _ in 0..=MAX_STEPS {
        let cell_of = |c: u32| centres[c as usize].map(|p| ((p - lo) / cell).floor().as_i64vec3());
        let mut parent: Vec<u32> = (0..prt.num_clusters).collect();
        for p in &prt.portals {
            let [a, b] = p.leaves;
            if a != b && cell_of(a).is_some() && cell_of(a) == cell_of(b) {
                union(&mut parent, a, b);
            }
        }
        // New numbers in the order of each group's lowest cluster (its root).
        let mut new_id = vec![u32::MAX; nc];
        let mut groups = 0u32;
        for c in 0..nc {
            let r = find(&mut parent, c as u32) as usize;
            if new_id[r] == u32::MAX {
                new_id[r] = groups;
                groups += 1;
            }
            new_id[c] = new_id[r];
        }
        let kept =
            prt.portals.iter().filter(|p| new_id[p.leaves[0] as usize] != new_id[p.leaves[1] as usize]);
        let counts = Counts {
            portals: kept.clone().count(),
            clusters: groups,
            leaves: prt.num_leaves,
            points: kept.map(|p| p.winding.points.len() as u128).sum(),
        };
        let estimate = super::budget::estimate(counts, opts).saturating_add(expanded);
        let work = super::budget::limit_work(counts, opts);
        if estimate <= limits.memory && work <= limits.work {
            let coarse = build(prt, &new_id, groups);
            let stats = CoarsenStats {
                clusters_before: prt.num_clusters,
                clusters_after: groups,
                portals_before: prt.portals.len(),
                portals_after: coarse.portals.len(),
                cell,
                estimate,
                work,
                fine_pairs_lower: fine_pairs_lower(prt),
                pairs_within_groups: 0,
                largest_groups: Vec::new(),
                retries: 0,
            };
            let stats = looseness(prt, &new_id, groups, stats);
            return Some(Coarse { prt: coarse, new_id, stats });
        }
        if cell > span {
            // One cell already held every centre: nothing coarser to try.
            return None;
        }
        cell *= GROWTH;
    }
    None
}

/// Merged groups [`CoarsenStats::largest_groups`] lists.
pub const LARGEST_GROUPS: usize = 5;

/// Leaves per cluster of `prt`.
fn cluster_leaves(prt: &PortalFile, clusters: usize, id: impl Fn(u32) -> usize) -> Vec<u64> {
    let mut leaves = vec![0u64; clusters];
    for &c in &prt.leaf_clusters {
        leaves[id(c)] += 1;
    }
    leaves
}

/// [`CoarsenStats::fine_pairs_lower`]: per cluster, its leaves times the leaves of itself and of
/// its distinct portal neighbours.
fn fine_pairs_lower(prt: &PortalFile) -> u64 {
    let nc = prt.num_clusters as usize;
    let leaves = cluster_leaves(prt, nc, |c| c as usize);
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); nc];
    for p in &prt.portals {
        let [a, b] = p.leaves;
        if a != b {
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
    }
    let mut total = 0u64;
    for (c, list) in neighbours.iter_mut().enumerate() {
        list.sort_unstable();
        list.dedup();
        let seen = leaves[c] + list.iter().map(|&k| leaves[k as usize]).sum::<u64>();
        total = total.saturating_add(leaves[c].saturating_mul(seen));
    }
    total
}

/// `stats` with [`CoarsenStats::pairs_within_groups`] and [`CoarsenStats::largest_groups`] of the
/// merge `new_id` (of `groups`) filled in.
fn looseness(prt: &PortalFile, new_id: &[u32], groups: u32, mut stats: CoarsenStats) -> CoarsenStats {
    let g = groups as usize;
    let leaves = cluster_leaves(prt, g, |c| new_id[c as usize] as usize);
    stats.pairs_within_groups = leaves.iter().fold(0u64, |a, &l| a.saturating_add(l.saturating_mul(l)));
    let mut members = vec![0u32; g];
    let mut bounds: Vec<Option<(DVec3, DVec3)>> = vec![None; g];
    for (c, b) in self::bounds(prt).into_iter().enumerate() {
        let k = new_id[c] as usize;
        members[k] += 1;
        if let Some((lo, hi)) = b {
            let e = bounds[k].get_or_insert((lo, hi));
            *e = (e.0.min(lo), e.1.max(hi));
        }
    }
    // Most leaves first, then the lower group number.
    let mut by_leaves: Vec<usize> = (0..g).filter(|&k| members[k] > 1).collect();
    by_leaves.sort_by_key(|&k| (std::cmp::Reverse(leaves[k]), k));
    stats.largest_groups = by_leaves
        .into_iter()
        .take(LARGEST_GROUPS)
        .map(|k| {
            let (lo, hi) = bounds[k].unwrap_or((DVec3::ZERO, DVec3::ZERO));
            MergedGroup {
                leaves: leaves[k] as u32,
                clusters: members[k],
                mins: lo.to_array(),
                maxs: hi.to_array(),
                centre: ((lo + hi) * 0.5).to_array(),
            }
        })
        .collect();
    stats
}

/// The centre of each cluster's portal windings' bounds (`None` for a cluster without portals).
fn centres(prt: &PortalFile) -> Vec<Option<DVec3>> {
    bounds(prt).into_iter().map(|b| b.map(|(lo, hi)| (lo + hi) * 0.5)).collect()
}

/// Per cluster, the bounds of its portal windings.
fn bounds(prt: &PortalFile) -> Vec<Option<(DVec3, DVec3)>> {
    let mut out: Vec<Option<(DVec3, DVec3)>> = vec![None; prt.num_clusters as usize];
    for p in &prt.portals {
        for &c in &p.leaves {
            for &q in &p.winding.points {
                let b = out[c as usize].get_or_insert((q, q));
                *b = (b.0.min(q), b.1.max(q));
            }
        }
    }
    out
}

/// The median over clusters with portals of the largest side of their bounds (0 without any).
fn median_extent(prt: &PortalFile) -> f64 {
    let mut extents: Vec<f64> =
        bounds(prt).into_iter().flatten().map(|(lo, hi)| (hi - lo).max_element()).collect();
    extents.sort_by(f64::total_cmp);
    extents.get(extents.len() / 2).copied().unwrap_or(0.0)
}

fn find(parent: &mut [u32], mut c: u32) -> u32 {
    while parent[c as usize] != c {
        let up = parent[parent[c as usize] as usize];
        parent[c as usize] = up;
        c = up;
    }
    c
}

/// Join the groups of `a` and `b`; the lower root stays root.
fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    parent[ra.max(rb) as usize] = ra.min(rb);
}

/// The portal file over merged clusters `new_id` (of `groups`).
pub(crate) fn build(prt: &PortalFile, new_id: &[u32], groups: u32) -> PortalFile {
    let portals = prt
        .portals
        .iter()
        .filter_map(|p| {
            let leaves = p.leaves.map(|c| new_id[c as usize]);
            (leaves[0] != leaves[1]).then(|| PrtPortal { leaves, winding: p.winding.clone() })
        })
        .collect();
    PortalFile {
        format: PrtFormat::Prt2,
        num_leaves: prt.num_leaves,
        num_clusters: groups,
        portals,
        leaf_clusters: prt.leaf_clusters.iter().map(|&c| new_id[c as usize]).collect(),
    }
}

/// The PVS over `prt`'s (the input's) clusters from the PVS `coarse` over merged clusters
/// `new_id`: an input cluster sees every input cluster in a merged cluster its own sees. The
/// leaf rows are unchanged, so are the statistics but `clusters` and `portals` (the input's).
/// Members of a merged cluster share a row, built once and copied: on the 10,000-brush room
/// merged into 73 clusters, setting each of the 43,651² bits one by one kept the run's time
/// outside base vis and the flow at 2.5 s, now 0.7 s.
pub(crate) fn expand(coarse: VisResult, prt: &PortalFile, new_id: &[u32]) -> VisResult {
    let nc = prt.num_clusters as usize;
    let words = bits::words(nc);
    let mut members = vec![Vec::new(); coarse.num_clusters()];
    for (c, &k) in new_id.iter().enumerate() {
        members[k as usize].push(c);
    }
    // Members of one merged cluster share its row: built once, at its first member, then copied.
    let mut rows = vec![0u64; nc * words];
    for group in members.iter().filter(|m| !m.is_empty()) {
        let first = group[0] * words;
        for k in bits::ones(coarse.cluster_row(new_id[group[0]] as usize)) {
            for &f in &members[k] {
                bits::set(&mut rows[first..first + words], f);
            }
        }
        for &c in &group[1..] {
            rows.copy_within(first..first + words, c * words);
        }
    }
    let mut cluster_leaves = vec![Vec::new(); nc];
    for (leaf, &c) in prt.leaf_clusters.iter().enumerate() {
        cluster_leaves[c as usize].push(leaf as u32);
    }
    let mut stats = coarse.stats;
    stats.clusters = prt.num_clusters;
    stats.portals = prt.portals.len();
    VisResult {
        num_leaves: coarse.num_leaves,
        leaf_clusters: prt.leaf_clusters.clone(),
        cluster_leaves,
        words,
        rows,
        stats,
    }
}
