//! What a run returns: the PVS ([`VisResult`]) and its measurements ([`VisStats`]).

use sightline_formats::bits;

/// Measurements of a run.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct VisStats {
    /// Vis leaves.
    pub leaves: u32,
    /// Clusters.
    pub clusters: u32,
    /// Portal lines in the input.
    pub portals: usize,
    /// Portal lines dropped (no area, or joining a cluster to itself).
    pub dropped_portals: usize,
    /// Separator level used.
    pub level: u8,
    /// True for base vis only.
    pub fast: bool,
    /// Worker threads.
    pub threads: usize,
    /// Average visible leaves per leaf (itself included).
    pub avg_visible: f64,
    /// Median visible leaves per leaf.
    pub median_visible: f64,
    /// Largest visible leaves of a leaf.
    pub max_visible: u32,
    /// `avg_visible` as a percentage of all leaves.
    pub percent_visible: f64,
    /// Sum over leaves of visible leaves.
    pub visible_pairs: u64,
    /// Average leaves visible after base vis alone.
    pub avg_mightsee: f64,
    /// Recursive flow calls (portal chains visited).
    pub chains: u64,
    /// Flow portals taken from a state file.
    pub resumed_portals: usize,
    /// [`work_estimate`](super::work_estimate) of the input (before any merging), in portal tests.
    pub work_estimate: u64,
    /// Seconds in base vis.
    pub base_seconds: f64,
    /// Portal pairs base vis tested: with `base_seconds`, this run's speed, which
    /// [`flow_estimate_seconds`](Self::flow_estimate_seconds) is scaled by.
    pub base_tests: u64,
    /// The flow's predicted chains (the sum of [`estimate::chains`](super::estimate::chains) over
    /// the portals left to flow, from their rows before the flow), 0 without a flow.
    pub flow_estimate_work: u64,
    /// The targets a frame scans on average, the one-way portals per cluster
    /// ([`estimate::targets_per_frame`](super::estimate::targets_per_frame)): a few on unmerged
    /// maps, hundreds or thousands on clusters merged by `--coarsen`, where a chain costs that
    /// much more ([`estimate::scan_factor`](super::estimate::scan_factor)); 0 without a flow.
    pub flow_estimate_targets: f64,
    /// The first estimate of `flow_seconds`, made before the flow from base vis's speed
    /// ([`estimate::flow_seconds`](super::estimate::flow_seconds)); its accuracy is measured in
    /// `docs/benchmarks.md`.
    pub flow_estimate_seconds: f64,
    /// The estimate of `flow_seconds` refined once a tenth of the flow's steps was done (elapsed
    /// time scaled by all the steps over those done, [`estimate::Refine`](super::estimate::Refine);
    /// steps weigh portals by expected cost), when the flow got that far.
    pub flow_refined_seconds: Option<f64>,
    /// Seconds in the flow.
    pub flow_seconds: f64,
    /// Seconds building cluster rows.
    pub rows_seconds: f64,
    /// When clusters were merged to fit memory ([`VisOptions::coarsen`](super::VisOptions::coarsen)): the rows are still
    /// over the input's clusters, but looser than they allow.
    pub coarsened: Option<CoarsenStats>,
    /// When the flow rows came from shard files ([`VisOptions::merge`](super::VisOptions::merge)):
    /// the plan, and what was missing.
    pub merged: Option<MergeStats>,
}

/// The PVS: one row per cluster (bits over clusters), expandable to leaves.
#[derive(Debug, Clone, PartialEq)]
pub struct VisResult {
    pub(super) num_leaves: usize,
    pub(super) leaf_clusters: Vec<u32>,
    pub(super) cluster_leaves: Vec<Vec<u32>>,
    pub(super) words: usize,
    pub(super) rows: Vec<u64>,
    /// Measurements.
    pub stats: VisStats,
}

impl VisResult {
    /// Number of vis leaves.
    pub fn num_leaves(&self) -> usize {
        self.num_leaves
    }

    /// Number of clusters.
    pub fn num_clusters(&self) -> usize {
        self.cluster_leaves.len()
    }

    /// Cluster of each leaf.
    pub fn leaf_clusters(&self) -> &[u32] {
        &self.leaf_clusters
    }

    /// Row of cluster `c` (a word row, [`bits`]): bit `k` set when cluster `k` is visible.
    pub fn cluster_row(&self, c: usize) -> &[u64] {
        &self.rows[c * self.words..(c + 1) * self.words]
    }

    /// True when cluster `a` sees cluster `b`.
    pub fn cluster_sees(&self, a: usize, b: usize) -> bool {
        a < self.num_clusters() && bits::get(self.cluster_row(a), b)
    }

    /// True when leaf `a` sees leaf `b` (false for leaves out of range).
    pub fn leaf_sees(&self, a: usize, b: usize) -> bool {
        match (self.leaf_clusters.get(a), self.leaf_clusters.get(b)) {
            (Some(&ca), Some(&cb)) => self.cluster_sees(ca as usize, cb as usize),
            _ => false,
        }
    }

    /// Leaf `leaf`'s row in Quake's byte layout ([`bits::bytes`]), uncompressed: bit `j` set when
    /// vis leaf `j` is visible (Quake: BSP leaf `j + 1`). `out` is cleared and sized
    /// `(num_leaves + 7) / 8`.
    pub fn leaf_row_bytes(&self, leaf: usize, out: &mut Vec<u8>) {
        out.clear();
        out.resize(bits::bytes::len(self.num_leaves), 0);
        let Some(&c) = self.leaf_clusters.get(leaf) else { return };
        for k in bits::ones(self.cluster_row(c as usize)) {
            for &j in &self.cluster_leaves[k] {
                bits::bytes::set(out, j as usize);
            }
        }
    }

    /// Number of leaves leaf `leaf` sees (itself included).
    pub fn visible_leaves(&self, leaf: usize) -> u32 {
        let Some(&c) = self.leaf_clusters.get(leaf) else { return 0 };
        bits::ones(self.cluster_row(c as usize)).map(|k| self.cluster_leaves[k].len() as u32).sum()
    }
}

impl VisResult {
    pub(super) fn average_visible(&self) -> f64 {
        let total: u64 = (0..self.num_leaves).map(|l| u64::from(self.visible_leaves(l))).sum();
        total as f64 / self.num_leaves.max(1) as f64
    }

    pub(super) fn fill_stats(&self, stats: &mut VisStats) {
        let mut counts: Vec<u32> = (0..self.num_leaves).map(|l| self.visible_leaves(l)).collect();
        counts.sort_unstable();
        let total: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        let n = counts.len();
        stats.visible_pairs = total;
        stats.avg_visible = total as f64 / n.max(1) as f64;
        stats.max_visible = counts.last().copied().unwrap_or(0);
        stats.median_visible = match n {
            0 => 0.0,
            _ if n % 2 == 1 => f64::from(counts[n / 2]),
            _ => (f64::from(counts[n / 2 - 1]) + f64::from(counts[n / 2])) / 2.0,
        };
        stats.percent_visible = 100.0 * stats.avg_visible / n.max(1) as f64;
    }
}

/// What coarsening did (reported so a mapper knows the PVS is looser than it could be).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct CoarsenStats {
    /// Clusters in the input.
    pub clusters_before: u32,
    /// Clusters vis ran on.
    pub clusters_after: u32,
    /// Portal lines in the input.
    pub portals_before: usize,
    /// Portal lines vis ran on (those joining different merged clusters).
    pub portals_after: usize,
    /// Side of the grid cells that grouped clusters, in map units.
    pub cell: f64,
    /// [`memory_estimate`](super::memory_estimate) of the run on the merged clusters plus the rows over the
    /// input's clusters `expand` builds, in bytes.
    pub estimate: u64,
    /// [`work_estimate`](super::work_estimate) of the run on the merged clusters, in portal tests.
    pub work: u64,
    /// Leaf pairs any PVS of the input holds (each leaf sees the leaves of its own cluster and of
    /// the clusters a portal joins it to): `visible_pairs` over this bounds how much looser the
    /// merged PVS is than an unmerged one could be (an upper bound of the ratio; the real one is
    /// lower).
    pub fine_pairs_lower: u64,
    /// Leaf pairs the merged groups alone make visible (every leaf of a group sees the group).
    pub pairs_within_groups: u64,
    /// The merged groups with the most leaves (at most [`LARGEST_GROUPS`](super::coarsen::LARGEST_GROUPS), most leaves first): where the PVS
    /// got looser.
    pub largest_groups: Vec<MergedGroup>,
    /// Merges given up before this one: their flows made more chains than
    /// [`CHAIN_CAP_FACTOR`](super::CHAIN_CAP_FACTOR) times the estimate allows, so
    /// clusters were merged further, each time under half the previous merge's work estimate.
    pub retries: u32,
}

/// A group of input clusters merged into one ([`CoarsenStats::largest_groups`]).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct MergedGroup {
    /// Vis leaves in it.
    pub leaves: u32,
    /// Input clusters in it.
    pub clusters: u32,
    /// Lowest corner of its clusters' portal bounds (map units).
    pub mins: [f64; 3],
    /// Highest corner.
    pub maxs: [f64; 3],
    /// Centre of those bounds.
    pub centre: [f64; 3],
}

/// What a merge found ([`VisStats::merged`]).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct MergeStats {
    /// Shards per wave.
    pub shards: u32,
    /// Waves.
    pub waves: u32,
    /// The shard files missing (a partial merge).
    pub missing: Vec<String>,
    /// One-way portals of the missing shards, left their base-vis rows.
    pub missing_portals: usize,
    /// Visible leaf pairs the missing portals' base-vis rows alone add (the PVS without them,
    /// their rows taken as empty, has this many fewer): how much looser a partial merge may be.
    pub pairs_from_missing: u64,
}
