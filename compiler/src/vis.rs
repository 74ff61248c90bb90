//! Vis: cluster-to-cluster visibility (the PVS) from a portal file, by portal flow with
//! antipenumbra (separating plane) clipping.
//!
//! Phases: `graph` turns each portal line into two one-way portals; `base` computes each
//! portal's `mightsee` (`--fast` stops there); `flow` clips windings through chains of portals,
//! one source portal at a time; then each cluster's row is the union of what its portals see plus
//! the clusters they lead to and itself. [`farplane::cull`] optionally hides far clusters from
//! each other afterwards (`-farplane`), the one step that may hide a visible cluster.
//!
//! # Guarantees
//! - **Never blocks a real sight line** (up to floating point): every clip keeps a
//!   [`poly::CLIP_EPSILON`] band beyond its plane, separating planes are accepted only when they
//!   separate within [`poly::SEPARATOR_EPSILON`], and only portals within
//!   [`base::COPLANAR_EPSILON`] of a plane are taken as lying in it, so a leaf 0.01 units thick or
//!   nearly coplanar portals pass sight. Lines that only graze an edge (a set of no width, such as
//!   a line through a row of exactly aligned wall corners) are not sight lines: a winding that at
//!   most touches a clipping plane, within [`poly::TOUCH_EPSILON`], is gone.
//! - **Symmetry prunes**: one-way portals `p` and `p ^ 1` are each other's reverse, and a line
//!   from `r` through `s` runs backwards from `s ^ 1` through `r ^ 1`; so `s` is cleared from row
//!   `r` whenever row `s ^ 1` lacks `r ^ 1` (`symmetry`), before the flow and after every batch.
//!   Rows stay supersets of the truth and later flows narrow by them.
//! - **Known sight lines prune**: a flow that reaches a new cluster checks the line between the
//!   middles of its clipped source and target (or, failing that, a line through the middle of a
//!   clipped pass portal) against the chain's windings (`certify`); when it passes, the
//!   clusters on it see each other for sure, and later flows from those clusters start with them
//!   marked seen (saved in checkpoints with the rows). On E1M2 this cuts the chains by a
//!   quarter. So do the clusters a finished flow saw, for later flows from its own cluster (whose
//!   row holds them anyway): on E1M1 a further quarter. A batch's new pairs are bits of a cluster
//!   matrix (`seeds`), never a list per chain (a corridor of 400 leaves once held 3 GB of such
//!   lists).
//! - **Bounded depth**: a chain is followed at most [`MAX_FLOW_DEPTH`] frames deep and then
//!   counts everything it might still see as seen, so a thread's working set is that many rows
//!   whatever the input.
//! - **Symmetric**: true visibility is symmetric and each computed row is a superset of it, so
//!   the final matrix is `M ∧ Mᵀ` (still a superset, and tighter than either).
//! - **Deterministic**: portals are processed in increasing `mightsee` order, in fixed batches
//!   ([`flow_batch`]: from 4 portals for the smallest inputs to [`FLOW_BATCH`] for the
//!   largest); a portal uses the final rows and seeds of portals from earlier batches only
//!   (in place of their `mightsee`), so the output is the same for any thread count and any
//!   timing. (Batches of one would let every portal use all earlier results, as the reference's
//!   single thread does: on dm1 9 % fewer chains than batches of 48, on small inputs a fifth.)
//! - **Resumable**: with [`VisOptions::state`], finished batches are checkpointed and a rerun
//!   continues after them, producing the same result as an uninterrupted run. The checkpoint is
//!   the log of the batch boundaries (`state`), replayed and checked on resume: a damaged or
//!   inconsistent file is a [`VisError::State`], never a different PVS.
//! - **Fits, or refuses**: before allocating, [`memory_estimate`] bounds what the run will take
//!   from the counts alone (portal and cluster bit matrices, per-thread rows, the graph); over the
//!   memory available or [`VisOptions::max_memory`] the run is a [`VisError::Memory`] at once,
//!   unless [`VisOptions::coarsen`] asks to merge clusters until it fits (`coarsen`): a looser
//!   PVS, still never hiding a visible leaf (merging only drops portals from chains, relaxing
//!   their constraints), reported in [`VisStats::coarsened`].
//! - **Fails, never hangs**: a panic in a flow worker (or anywhere in a run) stops every worker
//!   and returns [`VisError::Panicked`].

mod base;
mod budget;
mod certify;
pub mod coarsen;
mod error;
pub mod estimate;
mod explored;
pub mod farplane;
mod flow;
mod graph;
mod options;
mod parallel;
pub mod plan;
mod poly;
mod rows;
mod schedule;
mod seeds;
pub mod shard;
mod state;
mod stats;
mod symmetry;

use std::panic::AssertUnwindSafe;
use std::time::Instant;

use sightline_formats::bits;
use sightline_formats::prt::PortalFile;
use sightline_job::progress::{Progress, phase};

pub use base::COPLANAR_EPSILON;
pub use budget::{
    CHAIN_CAP_FACTOR, COARSEN_MAX_WORK, FLOW_BATCH, FLOW_BATCHES, SERIAL_WORK, WORK_PER_SECOND, flow_batch,
    memory_estimate, work_estimate,
};
pub use error::VisError;
pub use flow::MAX_FLOW_DEPTH;
pub use options::VisOptions;
pub use poly::{CLIP_EPSILON, SEPARATOR_EPSILON, TOUCH_EPSILON};
pub use rows::ROWS_SERIAL_WORDS;
pub use stats::{MergedGroup, VisResult, VisStats};

use budget::{chain_cap, check_memory, check_work, thread_count, work_limit};
use error::panic_error;
use rows::{cluster_rows, rows_threads, symmetric_average, symmetric_result};
use schedule::{flow_all, state_hash};

/// Compute the PVS of a portal file. `progress` gets the phases `vis base` (a step per portal)
/// and `vis flow` (as many steps as one-way portals, each finished flow bringing its share by
/// expected cost, so the phase's time left is the refined estimate: [`estimate::progress_steps`]),
/// from worker threads, a note when clusters are merged to fit the limits, the flow's estimated
/// time when it is long ([`estimate`]) and a warning, once done, that the merged PVS is looser
/// (and by how much);
/// [`VisOptions::cancel`] stops the run at its next batch boundary.
///
/// A flow on merged clusters that makes more chains than [`CHAIN_CAP_FACTOR`] times its work
/// estimate allows is given up at a batch boundary, and the clusters are merged further (each
/// time under half the previous merge's work estimate), with a note; a state file of the merge
/// given up is deleted, and a resumed run takes up the merge its state file belongs to.
pub fn run(prt: &PortalFile, opts: &VisOptions, progress: &dyn Progress) -> Result<VisResult, VisError> {
    // The thread count and the memory limit, each found once.
    let opts = &checked_input(prt, opts)?;
    let memory = crate::memory::limit(opts.max_memory, opts.threads);
    // Merges are sized for one thread, so every thread count merges alike (and gives the same
    // PVS); the run then has to fit with its own threads. Shards flow the input as it is.
    let single = VisOptions { threads: 1, ..opts.clone() };
    let mut merging = match check_memory(prt, &single, memory).and_then(|()| check_work(prt, opts)) {
        Err(e @ (VisError::Memory { .. } | VisError::Work { .. }))
            if opts.coarsen && opts.merge.is_none() =>
        {
            let limits = coarsen::Limits {
                memory: memory.map_or(u64::MAX, |(limit, _)| limit),
                work: work_limit(opts).map_or(u64::MAX, |(limit, _)| limit),
            };
            let coarse = coarsen::fit(prt, &single, limits).ok_or(e)?;
            progress.note(&format!(
                "vis does not fit its memory or work limit: merging {} clusters into {} (--coarsen)",
                coarse.stats.clusters_before, coarse.stats.clusters_after
            ));
            Some(resumed_merge(prt, &single, opts, Merging { coarse, limits, retries: 0, capped: true }))
        }
        Err(e) => return Err(e),
        Ok(()) => None,
    };
    let mut result = loop {
        let input = merging.as_ref().map_or(prt, |m| &m.coarse.prt);
        check_memory(input, opts, memory)?;
        check_work(input, opts)?;
        let cap = merging.as_ref().filter(|m| m.capped && m.retries < MAX_RETRIES).map(|m| m.cap(opts));
        let compute = || run_phases(input, opts, progress, cap);
        // Each parallel phase starts and ends its own threads (`parallel`).
        if let Some(result) = std::panic::catch_unwind(AssertUnwindSafe(compute)).map_err(panic_error)?? {
            break result;
        }
        // Over the cap (so merging): the state file, if any, belongs to the merge given up.
        if let Some(path) = &opts.state {
            let _ = std::fs::remove_file(path);
        }
        merging = merging.map(|m| m.further(prt, &single, progress));
    };
    if let Some(Merging { coarse: mut c, retries, .. }) = merging {
        c.stats.retries = retries;
        result = coarsen::expand(result, prt, &c.new_id);
        let largest = c.stats.largest_groups.first().map_or_else(String::new, |k| {
            let [x, y, z] = k.centre;
            format!("; the largest merged group holds {} leaves around ({x:.0} {y:.0} {z:.0})", k.leaves)
        });
        progress.warn(&format!(
            "vis did not fit its memory or work limit: merged {} clusters into {} ({} of {} portals left, estimates {} and {:.1e} portal tests); the PVS is looser: {} visible leaf pairs, at most {:.1} times the {} an unmerged PVS has at least{largest}",
            c.stats.clusters_before,
            c.stats.clusters_after,
            c.stats.portals_after,
            c.stats.portals_before,
            crate::memory::format_size(c.stats.estimate),
            c.stats.work as f64,
            result.stats.visible_pairs,
            result.stats.visible_pairs as f64 / c.stats.fine_pairs_lower.max(1) as f64,
            c.stats.fine_pairs_lower
        ));
        result.stats.coarsened = Some(c.stats);
    }
    result.stats.threads = opts.threads;
    result.stats.work_estimate = work_estimate(prt, opts);
    Ok(result)
}

/// Merges given up at most (then the last one flows to its end): each halves the work limit, so
/// sixteen reach a sixty-five-thousandth of the first merge's estimate.
const MAX_RETRIES: u32 = 16;

/// A run on merged clusters: the merge, the limits it was fitted to and the merges given up.
struct Merging {
    coarse: coarsen::Coarse,
    limits: coarsen::Limits,
    retries: u32,
    /// Its flow stops over [`Merging::cap`] (until no coarser merge fits).
    capped: bool,
}

impl Merging {
    /// The chains the flow on this merge may make ([`chain_cap`]).
    fn cap(&self, opts: &VisOptions) -> u64 {
        #[cfg(test)]
        if let Some(cap) = opts.chain_cap {
            return cap;
        }
        let _ = opts;
        chain_cap(&self.coarse.prt)
    }

    /// The next merge: the least merging under half this one's work estimate, if it has fewer
    /// clusters.
    fn next(&self, prt: &PortalFile, single: &VisOptions) -> Option<coarsen::Coarse> {
        let limits = coarsen::Limits { work: self.coarse.stats.work / 2, ..self.limits };
        coarsen::fit(prt, single, limits)
            .filter(|c| c.stats.clusters_after < self.coarse.stats.clusters_after)
    }

    /// Give this merge up for the next ([`Merging::next`]), saying so; without one, flow this
    /// merge again to its end (the cap lifted).
    fn further(self, prt: &PortalFile, single: &VisOptions, progress: &dyn Progress) -> Self {
        let Some(coarse) = self.next(prt, single) else {
            progress.note(&format!(
                "vis flow on {} merged clusters made more chains than its estimate allows, and no coarser merge fits: flowing it to its end",
                self.coarse.stats.clusters_after
            ));
            return Self { capped: false, ..self };
        };
        progress.note(&format!(
            "vis flow on {} merged clusters made more than {}× the chains its estimate allows: merging into {} (--coarsen)",
            self.coarse.stats.clusters_after, CHAIN_CAP_FACTOR, coarse.stats.clusters_after
        ));
        Self { coarse, limits: self.limits, retries: self.retries + 1, capped: true }
    }
}

/// With a state file, the merge it belongs to: the first merge, or one an earlier run reached by
/// giving merges up (the same steps, so the same merges). The last merge (none coarser fits)
/// resumes uncapped: its capped and uncapped flows are the same until the cap, so either run
/// goes on alike. A file of no merge is left for the flow to refuse, as for any other input.
fn resumed_merge(prt: &PortalFile, single: &VisOptions, opts: &VisOptions, first: Merging) -> Merging {
    let Some(saved) = opts.state.as_deref().and_then(state::input_hash_of) else {
        return first;
    };
    let mut next = first.next(prt, single);
    if state_hash(&first.coarse.prt, opts) == saved {
        return Merging { capped: next.is_some(), ..first };
    }
    for retries in 1..=MAX_RETRIES {
        let Some(coarse) = next else { break };
        let merging = Merging { coarse, limits: first.limits, retries, capped: true };
        next = merging.next(prt, single);
        if state_hash(&merging.coarse.prt, opts) == saved {
            return Merging { capped: next.is_some(), ..merging };
        }
    }
    first
}

/// `opts` for a run of `prt` that flows the input as it is (the shards of a plan): the level
/// and the input checked, the thread count chosen, the memory and work limits applied.
fn checked(prt: &PortalFile, opts: &VisOptions) -> Result<VisOptions, VisError> {
    let opts = checked_input(prt, opts)?;
    let memory = crate::memory::limit(opts.max_memory, opts.threads);
    check_memory(prt, &opts, memory)?;
    check_work(prt, &opts)?;
    Ok(opts)
}

/// `opts` with its thread count chosen for `prt`, once the level and the input are checked.
fn checked_input(prt: &PortalFile, opts: &VisOptions) -> Result<VisOptions, VisError> {
    if opts.level > 4 {
        return Err(VisError::Option(format!("level {} is out of range 0..=4", opts.level)));
    }
    check(prt)?;
    Ok(VisOptions { threads: thread_count(prt, opts), ..opts.clone() })
}

fn check(prt: &PortalFile) -> Result<(), VisError> {
    if prt.leaf_clusters.len() != prt.num_leaves as usize {
        return Err(VisError::Invalid(format!(
            "{} leaf clusters for {} leaves",
            prt.leaf_clusters.len(),
            prt.num_leaves
        )));
    }
    if let Some(c) = prt.leaf_clusters.iter().find(|&&c| c >= prt.num_clusters) {
        return Err(VisError::Invalid(format!("cluster {c} out of range ({} clusters)", prt.num_clusters)));
    }
    if let Some(p) = prt.portals.iter().find(|p| p.leaves.iter().any(|&c| c >= prt.num_clusters)) {
        return Err(VisError::Invalid(format!(
            "portal joins {:?}, out of range ({} clusters)",
            p.leaves, prt.num_clusters
        )));
    }
    Ok(())
}

/// The phases of a run, on the threads `opts.threads` says (see `parallel`); `None` when the
/// flow made more than `cap` chains ([`flow_all`]).
fn run_phases(
    prt: &PortalFile,
    opts: &VisOptions,
    progress: &dyn Progress,
    cap: Option<u64>,
) -> Result<Option<VisResult>, VisError> {
    let t0 = Instant::now();
    let g = graph::Graph::new(prt);
    let n = g.portals.len();
    let words = bits::words(n);
    let base_phase = phase(progress, "vis base", n as u64);
    let base::Mightsee { rows: might, clusters: might_clusters, tests: base_tests } =
        base::mightsee(&g, words, opts.threads, &|| base_phase.advance(1));
    drop(base_phase);
    let row_threads = rows_threads(prt, words, opts.threads);
    // The PVS base vis alone gives: the result of `--fast`, and the base vis average otherwise.
    let (base_result, avg_mightsee) = if opts.fast {
        let result = symmetric_result(prt, might_clusters, row_threads);
        let average = result.average_visible();
        (Some(result), average)
    } else {
        (None, symmetric_average(prt, &might_clusters, row_threads))
    };
    let base_seconds = t0.elapsed().as_secs_f64();
    let mut stats = VisStats {
        leaves: prt.num_leaves,
        clusters: prt.num_clusters,
        portals: prt.portals.len(),
        dropped_portals: g.dropped,
        level: opts.level,
        fast: opts.fast,
        base_seconds,
        base_tests,
        avg_mightsee,
        ..VisStats::default()
    };
    let mut result = if let Some(base_result) = base_result {
        base_result
    } else {
        let t1 = Instant::now();
        let portal_vis = match &opts.merge {
            Some(spec) => shard::merge_rows(prt, &g, might, words, opts, spec, &mut stats)?,
            None => match flow_all(prt, &g, might, words, opts, progress, &mut stats, cap)? {
                Some(rows) => rows,
                None => return Ok(None),
            },
        };
        stats.flow_seconds = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        let result = cluster_rows(prt, &g, &portal_vis, words, row_threads);
        stats.rows_seconds = t2.elapsed().as_secs_f64();
        result
    };
    result.fill_stats(&mut stats);
    result.stats = stats;
    Ok(Some(result))
}

#[cfg(test)]
mod tests;
