//! What a validation run reports, as text and as JSON.
//!
//! Tightness is `|PVS| / |sampled|`: how many pairs the PVS holds for each pair the rays proved
//! visible (1.0 is a PVS as tight as the sampling can tell; the true visible set lies between the
//! two). Per cluster it is `|row| / |sampled row|` over clusters with at least one sampled pair.

use std::fmt::Write as _;

use sightline_formats::Level;

use super::pvs::BitMatrix;
use super::sample::Miss;
use super::{Options, OracleChoice};

/// Pairs found after part of the budget.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Coverage {
    /// Part of the budget (`"1/8"` ... `"1/1"`).
    pub fraction: String,
    /// Rays cast so far.
    pub rays: u64,
    /// Sampled pairs so far.
    pub pairs: u64,
}

/// Tightness over clusters.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Spread {
    /// Tightest cluster.
    pub min: f64,
    /// Median cluster.
    pub median: f64,
    /// Loosest cluster.
    pub worst: f64,
}

/// One oracle's results.
#[derive(Debug, Clone, serde::Serialize)]
pub struct OracleReport {
    /// `"tree"` or `"mesh"`.
    pub oracle: String,
    /// Rays cast.
    pub rays: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Rays per second.
    pub rays_per_second: f64,
    /// Cluster pairs proved visible (ordered pairs, each cluster with itself included).
    pub sampled_pairs: u64,
    /// `pvs_pairs / sampled_pairs`.
    pub tightness: f64,
    /// Per-cluster tightness.
    pub per_cluster: Option<Spread>,
    /// Clusters with no sampled pair at all.
    pub unsampled_clusters: u64,
    /// Pairs found as the budget grows.
    pub coverage: Vec<Coverage>,
    /// Sampled pairs missing from the PVS, ordered by (from, to).
    pub misses: Vec<Miss>,
}

/// Pairs one oracle sampled and the other did not.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Disagreement {
    /// Sampled through the tree only.
    pub pairs_only_tree: u64,
    /// Sampled against the faces only.
    pub pairs_only_mesh: u64,
}

/// The whole report.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    /// Input file, as given.
    pub input: String,
    /// Leaves in the level.
    pub leaves: usize,
    /// Leaves sight passes through (not solid, not sky).
    pub open_leaves: usize,
    /// Open leaves with a sampling point (the others are too thin to hold one).
    pub sampled_leaves: usize,
    /// Clusters.
    pub clusters: u32,
    /// Bundles per sampled leaf.
    pub bundles_per_leaf: u32,
    /// Rays per bundle (two per line: forward and backward).
    pub rays_per_bundle: u32,
    /// Bundle offset in world units.
    pub bundle_offset: f64,
    /// Seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Oracles run.
    pub oracle_choice: OracleChoice,
    /// Pairs in the PVS (ordered, each cluster with itself included).
    pub pvs_pairs: u64,
    /// Per-oracle results.
    pub oracles: Vec<OracleReport>,
    /// Disagreement between the oracles when both ran.
    pub disagreement: Option<Disagreement>,
}

impl Report {
    /// The header of a report; oracles are added as they finish.
    pub fn new(
        level: &Level,
        open_leaves: usize,
        sampled_leaves: usize,
        bundles: u32,
        opts: &Options,
        pvs: &BitMatrix,
    ) -> Self {
        Self {
            input: String::new(),
            leaves: level.leaves.len(),
            open_leaves,
            sampled_leaves,
            clusters: level.num_clusters,
            bundles_per_leaf: bundles,
            rays_per_bundle: super::sample::rays_per_bundle(opts.offset),
            bundle_offset: opts.offset,
            seed: opts.seed,
            threads: rayon::current_num_threads(),
            oracle_choice: opts.oracle,
            pvs_pairs: pvs.count(),
            oracles: Vec::new(),
            disagreement: None,
        }
    }

    /// Total misses over the oracles.
    pub fn misses(&self) -> usize {
        self.oracles.iter().map(|o| o.misses.len()).sum()
    }

    /// The human-readable report.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: {} leaves ({} open, {} sampled), {} clusters, PVS {} pairs",
            if self.input.is_empty() { "level" } else { &self.input },
            self.leaves,
            self.open_leaves,
            self.sampled_leaves,
            self.clusters,
            self.pvs_pairs
        );
        let _ = writeln!(
            s,
            "sampling: {} bundles per leaf, {} rays per bundle (offset {} units), seed {}, {} threads",
            self.bundles_per_leaf, self.rays_per_bundle, self.bundle_offset, self.seed, self.threads
        );
        for o in &self.oracles {
            let _ = writeln!(
                s,
                "[{}] {} rays in {:.2} s ({:.2} M rays/s); sampled {} pairs; tightness {:.3}",
                o.oracle,
                o.rays,
                o.seconds,
                o.rays_per_second / 1e6,
                o.sampled_pairs,
                o.tightness
            );
            if let Some(p) = o.per_cluster {
                let _ = writeln!(
                    s,
                    "[{}] per cluster: min {:.3}, median {:.3}, worst {:.3}; {} clusters unsampled",
                    o.oracle, p.min, p.median, p.worst, o.unsampled_clusters
                );
            }
            let cov: Vec<String> = o.coverage.iter().map(|c| format!("{} {}", c.fraction, c.pairs)).collect();
            let _ = writeln!(s, "[{}] coverage: {}", o.oracle, cov.join(", "));
            let _ = writeln!(s, "[{}] misses: {}", o.oracle, o.misses.len());
            for m in &o.misses {
                let _ = writeln!(
                    s,
                    "  miss: cluster {} does not list cluster {}: leaf {} ({:.2} {:.2} {:.2}) sees leaf {} ({:.2} {:.2} {:.2})",
                    m.from_cluster,
                    m.to_cluster,
                    m.from_leaf,
                    m.from[0],
                    m.from[1],
                    m.from[2],
                    m.to_leaf,
                    m.to[0],
                    m.to[1],
                    m.to[2]
                );
            }
        }
        if let Some(d) = self.disagreement {
            let _ = writeln!(
                s,
                "oracles disagree on {} pairs (tree only) and {} pairs (mesh only): the BSP-tree oracle and the \
                 triangle-mesh oracle trace the same rays through different geometry, so near edges one finds a \
                 pair the other does not; a disagreement is not a miss (only a pair the PVS hides is)",
                d.pairs_only_tree, d.pairs_only_mesh
            );
        }
        let rays: u64 = self.oracles.iter().map(|o| o.rays).sum();
        let misses = self.misses();
        if misses == 0 {
            let _ = writeln!(s, "PASS: no sightline reached a leaf the PVS hides ({rays} rays)");
        } else {
            let _ =
                writeln!(s, "FAIL: {misses} misses: sightlines reached leaves the PVS hides ({rays} rays)");
        }
        s
    }
}

impl OracleReport {
    /// Summarise one oracle's run.
    pub fn new(
        name: &str,
        rays: u64,
        seconds: f64,
        coverage: Vec<Coverage>,
        sampled: &BitMatrix,
        pvs: &BitMatrix,
        misses: Vec<Miss>,
    ) -> Self {
        let sampled_pairs = sampled.count();
        let mut ratios: Vec<f64> = (0..sampled.len())
            .filter(|&c| sampled.row_count(c) > 0)
            .map(|c| pvs.row_count(c) as f64 / sampled.row_count(c) as f64)
            .collect();
        ratios.sort_by(f64::total_cmp);
        let per_cluster = (!ratios.is_empty()).then(|| Spread {
            min: ratios[0],
            median: ratios[ratios.len() / 2],
            worst: ratios[ratios.len() - 1],
        });
        Self {
            oracle: name.to_string(),
            rays,
            seconds,
            rays_per_second: if seconds > 0.0 { rays as f64 / seconds } else { 0.0 },
            sampled_pairs,
            tightness: if sampled_pairs > 0 { pvs.count() as f64 / sampled_pairs as f64 } else { 0.0 },
            per_cluster,
            unsampled_clusters: (sampled.len() - ratios.len()) as u64,
            coverage,
            misses,
        }
    }
}
