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
mod certify;
pub mod coarsen;
pub mod farplane;
mod flow;
mod graph;
mod parallel;
mod poly;
mod seeds;
mod state;
mod symmetry;

use std::any::Any;
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError, RwLock};
use std::time::{Duration, Instant};

use sightline_formats::bits;
use sightline_formats::prt::PortalFile;

pub use base::COPLANAR_EPSILON;
pub use poly::{CLIP_EPSILON, SEPARATOR_EPSILON, TOUCH_EPSILON};

/// Portals per deterministic flow batch (a portal sees the results of earlier batches only) for
/// an input estimated at `100 ×` [`SERIAL_WORK`] or more: long runs on every core, whose batches
/// have to hold enough flows to keep the cores busy until a batch's longest flow ends.
pub const FLOW_BATCH: usize = 48;

/// Portals per flow batch below that, by [`work_estimate`]: the first `(below, batch)` whose
/// bound is above the estimate. The sooner a flow's rows and seeds reach later flows, the fewer
/// chains they visit, but every batch boundary waits for the batch's longest flow, so smaller
/// inputs (shorter, more even flows) take smaller batches:
/// - below [`SERIAL_WORK`] (one thread unless told otherwise), 4: against batches of 48 on
///   ericw-tools' compiles of the generated maps (one thread, instructions), 2 × 2 × 1 rooms
///   −21 %, 4 × 4 × 1 rooms −18 %, the 100-sided pillar about −25 %, the same PVS (batches of
///   one save 1–2 % more, but leave a second thread nothing to do but wait at every portal);
/// - up to ten times that, 8, and up to a hundred times, 16: on two threads against 48, the
///   4 × 4 × 2 rooms −6 % CPU and −8 % wall time, dm1 −8 % and −5 %, the 6 × 6 × 3 rooms −3 %,
///   LibreQuake's lqdm1 −2 % (E1M1, above, takes 6–9 % more CPU with batches of 8 to 32).
pub const FLOW_BATCHES: [(u64, usize); 3] =
    [(SERIAL_WORK, 4), (10 * SERIAL_WORK, 8), (100 * SERIAL_WORK, 16)];

/// Below this [`work_estimate`] (in portal tests), a run given no thread count ([`VisOptions::threads`]
/// 0) takes one thread: such a run lasts milliseconds, and starting threads and waiting at batch
/// boundaries for a batch's longest flow cost more than a second thread shares. On a sealed room
/// with a 100-sided pillar (estimate 9 × 10⁶) two threads took 9.0 ms of CPU to one thread's 5.8,
/// for the same wall time; from about 7 × 10⁷ (the generated 4 × 4 × 2 rooms) two threads cut the
/// wall time by a fifth or more.
pub const SERIAL_WORK: u64 = 20_000_000;

/// Portals per flow batch for a run of `prt` (the input the flow reads, after any merging) with
/// `opts`: from [`FLOW_BATCHES`] by its [`work_estimate`], else [`FLOW_BATCH`]. It depends on
/// the input alone, never on the thread count, so every thread count gives the same result.
pub fn flow_batch(prt: &PortalFile, opts: &VisOptions) -> usize {
    batch(Counts::of(prt), opts)
}

/// [`flow_batch`] from the counts.
fn batch(counts: Counts, opts: &VisOptions) -> usize {
    let work = work(counts, opts);
    FLOW_BATCHES.iter().find(|&&(below, _)| work < below).map_or(FLOW_BATCH, |&(_, batch)| batch)
}

/// Deepest frame a flow enters (its source portal's frame is 0). There the chain stops and every
/// portal it might still see counts as seen, which can only keep more: a thread holds at most this
/// many frames (rows of portal bits) whatever the input. No result on the shared real maps comes
/// near it (they are the same with a limit of 64 and without one).
pub const MAX_FLOW_DEPTH: usize = 64;

/// Options of [`run`].
#[derive(Debug, Clone)]
pub struct VisOptions {
    /// Stop after base vis (`mightsee`), like the reference `-fast`.
    pub fast: bool,
    /// Separator tests, 0..=4 as the reference `vis -level` defines them (4 is the tightest).
    pub level: u8,
    /// Seed flows with clusters known visible by certified sight lines (`certify`) and with
    /// those earlier flows from the same cluster saw (on by default). Off, every flow finds
    /// everything itself: more work, and about the PVS the seeds would leave (the beam cull
    /// depends on the order clusters are found in, and a seeded flow's row also holds portals
    /// into clusters only its cluster's other portals see).
    pub seeds: bool,
    /// Worker threads; 0 uses every core, or one for a run estimated below [`SERIAL_WORK`].
    /// The result is the same for any count.
    pub threads: usize,
    /// Checkpoint file: loaded when present (resume), written every `checkpoint_interval`.
    pub state: Option<PathBuf>,
    /// Time between checkpoints.
    pub checkpoint_interval: Duration,
    /// Stop (with [`VisError::Interrupted`], after a checkpoint) once at least this many flow
    /// portals are finished: for tests of resuming.
    pub stop_after: Option<usize>,
    /// Stop the same way at the next batch boundary once this flag is set (for example by a
    /// Ctrl-C handler): with [`VisOptions::state`] the finished portals are saved first.
    pub cancel: Option<Arc<AtomicBool>>,
    /// Refuse (with [`VisError::Memory`]) a run whose [`memory_estimate`] is above this many
    /// bytes; the memory the machine has available ([`crate::memory::available`]) is always a
    /// limit too.
    pub max_memory: Option<u64>,
    /// Refuse (with [`VisError::Work`]) a run whose [`work_estimate`] is above this many portal
    /// tests. With [`VisOptions::coarsen`] and no limit given, [`COARSEN_MAX_WORK`] applies.
    pub max_work: Option<u64>,
    /// Over either limit, merge clusters until both estimates fit ([`coarsen`]) instead of
    /// refusing.
    pub coarsen: bool,
    /// Tests only: panic in the flow at this position of the processing order.
    #[cfg(test)]
    pub(crate) panic_at: Option<usize>,
}

impl Default for VisOptions {
    fn default() -> Self {
        Self {
            fast: false,
            level: 4,
            seeds: true,
            threads: 0,
            state: None,
            checkpoint_interval: Duration::from_secs(180),
            stop_after: None,
            cancel: None,
            max_memory: None,
            max_work: None,
            coarsen: false,
            #[cfg(test)]
            panic_at: None,
        }
    }
}

/// Which phase a progress report is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum VisPhase {
    /// Clusters were merged ([`VisOptions::coarsen`]): reported once, before base vis, with
    /// `done` the merged clusters and `total` the input's.
    Coarsen,
    /// Base vis (`mightsee`).
    Base,
    /// Full flow.
    Flow,
}

/// A progress report: `done` of `total` portals finished in `phase` (clusters for
/// [`VisPhase::Coarsen`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VisProgress {
    /// The phase.
    pub phase: VisPhase,
    /// Portals finished (counting resumed ones).
    pub done: usize,
    /// Portals in the phase.
    pub total: usize,
}

/// What went wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum VisError {
    /// The portal file is inconsistent.
    #[error("invalid portal file: {0}")]
    Invalid(String),
    /// An option is out of range.
    #[error("invalid option: {0}")]
    Option(String),
    /// A checkpoint could not be read or written, or belongs to another input.
    #[error("vis state: {0}")]
    State(String),
    /// Stopped on request after `done` flow portals; the state file holds them.
    #[error("stopped after {done} of {total} portals (state saved)")]
    Interrupted {
        /// Flow portals finished.
        done: usize,
        /// Flow portals in all.
        total: usize,
    },
    /// The run would need more memory than is available or allowed; nothing was allocated.
    #[error("{what} would need {need_text} for {reason}: more than the {limit_text} {source_of_limit}; {hint}", need_text = crate::memory::format_size(*need), limit_text = crate::memory::format_size(*limit))]
    Memory {
        /// Estimated bytes ([`memory_estimate`]).
        need: u64,
        /// The limit in bytes.
        limit: u64,
        /// What needs it (`vis`, `vis --fast`).
        what: String,
        /// What the memory is for (the matrices and the counts that size them).
        reason: String,
        /// Where the limit comes from.
        source_of_limit: crate::memory::LimitSource,
        /// What to do about it (rerun with `--coarsen`, or that coarsening did not help).
        hint: String,
    },
    /// The run's [`work_estimate`] is over [`VisOptions::max_work`]; nothing was computed.
    #[error(
        "vis would take an estimated {need} portal tests ({reason}): more than the {limit} {source_of_limit}; {hint}"
    )]
    Work {
        /// Estimated portal tests ([`work_estimate`]).
        need: u64,
        /// The limit.
        limit: u64,
        /// The counts the estimate comes from.
        reason: String,
        /// Where the limit comes from (`--max-work`, or coarsening's default).
        source_of_limit: String,
        /// What to do about it.
        hint: String,
    },
    /// A bug: vis panicked (in a flow worker or elsewhere); every worker was stopped.
    #[error("vis panicked (a bug; every worker was stopped): {0}")]
    Panicked(String),
}

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
    /// [`work_estimate`] of the input (before any merging), in portal tests.
    pub work_estimate: u64,
    /// Seconds in base vis.
    pub base_seconds: f64,
    /// Seconds in the flow.
    pub flow_seconds: f64,
    /// Seconds building cluster rows.
    pub rows_seconds: f64,
    /// When clusters were merged to fit memory ([`VisOptions::coarsen`]): the rows are still
    /// over the input's clusters, but looser than they allow.
    pub coarsened: Option<coarsen::CoarsenStats>,
}

/// The PVS: one row per cluster (bits over clusters), expandable to leaves.
#[derive(Debug, Clone, PartialEq)]
pub struct VisResult {
    num_leaves: usize,
    leaf_clusters: Vec<u32>,
    cluster_leaves: Vec<Vec<u32>>,
    words: usize,
    rows: Vec<u64>,
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

/// Compute the PVS of a portal file. `progress` is called (from worker threads) as portals finish.
pub fn run(
    prt: &PortalFile,
    opts: &VisOptions,
    progress: &(dyn Fn(VisProgress) + Sync),
) -> Result<VisResult, VisError> {
    if opts.level > 4 {
        return Err(VisError::Option(format!("level {} is out of range 0..=4", opts.level)));
    }
    check(prt)?;
    // The thread count and the memory limit, each found once.
    let opts = &VisOptions { threads: thread_count(prt, opts), ..opts.clone() };
    let memory = crate::memory::limit(opts.max_memory);
    // Merges are sized for one thread, so every thread count merges alike (and gives the same
    // PVS); the run then has to fit with its own threads.
    let single = VisOptions { threads: 1, ..opts.clone() };
    let coarse = match check_memory(prt, &single, memory).and_then(|()| check_work(prt, opts)) {
        Err(e @ (VisError::Memory { .. } | VisError::Work { .. })) if opts.coarsen => {
            let limits = coarsen::Limits {
                memory: memory.map_or(u64::MAX, |(limit, _)| limit),
                work: work_limit(opts).map_or(u64::MAX, |(limit, _)| limit),
            };
            let coarse = coarsen::fit(prt, &single, limits).ok_or(e)?;
            let (done, total) = (coarse.stats.clusters_after as usize, coarse.stats.clusters_before as usize);
            progress(VisProgress { phase: VisPhase::Coarsen, done, total });
            Some(coarse)
        }
        Err(e) => return Err(e),
        Ok(()) => None,
    };
    let input = coarse.as_ref().map_or(prt, |c| &c.prt);
    check_memory(input, opts, memory)?;
    check_work(input, opts)?;
    let compute = || run_phases(input, opts, progress);
    // Each parallel phase starts and ends its own threads (`parallel`).
    let mut result = std::panic::catch_unwind(AssertUnwindSafe(compute)).map_err(panic_error)??;
    if let Some(c) = coarse {
        result = coarsen::expand(result, prt, &c.new_id);
        result.stats.coarsened = Some(c.stats);
    }
    result.stats.threads = opts.threads;
    result.stats.work_estimate = work_estimate(prt, opts);
    Ok(result)
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

/// An upper estimate of the bytes [`run`] allocates for `prt` with `opts`, computed from the
/// counts alone: the portal × portal bit matrices (`mightsee`, the flow rows; with a state file
/// its log, `state::bytes_bound`, seed pairs included), the cluster × cluster matrices
/// (certified seeds and the batch's pending ones, cluster rows, their snapshot and the
/// `mightsee` rows for statistics), per-thread rows and flow frames (at most [`MAX_FLOW_DEPTH`]
/// deep), and the portal graph.
pub fn memory_estimate(prt: &PortalFile, opts: &VisOptions) -> u64 {
    estimate(Counts::of(prt), &VisOptions { threads: thread_count(prt, opts), ..opts.clone() })
}

/// The threads a run of `prt` with `opts` uses: [`VisOptions::threads`] when given, else one below
/// [`SERIAL_WORK`] (the cores are then not even counted) and every core above it.
fn thread_count(prt: &PortalFile, opts: &VisOptions) -> usize {
    match opts.threads {
        0 if work_estimate(prt, opts) < SERIAL_WORK => 1,
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        t => t,
    }
}

/// The counts [`memory_estimate`] and [`work_estimate`] depend on.
#[derive(Debug, Clone, Copy)]
struct Counts {
    /// Portal lines.
    portals: usize,
    clusters: u32,
    leaves: u32,
    /// Winding points over all portal lines.
    points: u128,
}

impl Counts {
    fn of(prt: &PortalFile) -> Self {
        Self {
            portals: prt.portals.len(),
            clusters: prt.num_clusters,
            leaves: prt.num_leaves,
            points: prt.portals.iter().map(|p| p.winding.points.len() as u128).sum(),
        }
    }
}

/// [`memory_estimate`] from the counts, for `opts.threads` threads (resolved: at least one).
fn estimate(counts: Counts, opts: &VisOptions) -> u64 {
    let threads = opts.threads.max(1) as u128;
    let (one_way, nc) = (2 * counts.portals as u128, u128::from(counts.clusters));
    let row = 8 * bits::words(one_way as usize) as u128;
    let cluster_row = 8 * bits::words(nc as usize) as u128;
    let points = counts.points;
    let graph = one_way * (std::mem::size_of::<graph::OneWay>() as u128 + 32 + 8)
        + 2 * (24 + 32) * points
        + nc * 2 * 24
        + base::OUT_BYTES_PER_PORTAL * one_way
        + 4 * (nc + 1);
    // `mightsee` and, with the flow, the rows it narrows.
    let mut matrices = one_way * row;
    if !opts.fast {
        matrices += one_way * row;
        // The certified seeds (known and pending), and the checkpoint log (a row per portal and
        // up to every seed pair, with its encoding while saved or loaded).
        matrices += 2 * nc * cluster_row;
        if opts.state.is_some() {
            matrices += state::bytes_bound(one_way, row / 8, nc);
        }
    }
    // Cluster rows: the result, its snapshot for symmetry, and the `mightsee` rows' result.
    let clusters = 3 * nc * cluster_row + u128::from(counts.leaves) * 8 + nc * 24;
    // Base vis's `entered` clusters and flood stack (each cluster once), the cluster rows' portal
    // row; with the flow, its state and the row it fills.
    let mut per_thread = row + cluster_row + 4 * nc;
    if !opts.fast {
        per_thread += row + flow::Flow::bytes(bits::words(one_way as usize), nc as usize);
    }
    let slots = batch(counts, opts) as u128 * row;
    let total = graph + matrices + clusters + threads * per_thread + slots;
    u64::try_from(total).unwrap_or(u64::MAX)
}

/// Work of one flow chain in portal tests, the unit of [`work_estimate`]: on the shared maps and
/// the generated rooms a chain costs 2–5 µs and base vis 5–20 ns per portal test.
const CHAIN_WORK: u128 = 300;

/// Work, in portal tests, of one of the portals a chain scans in its cluster (and the row words
/// each narrows): nothing on leaves of a few portals each, but a cluster merged by `coarsen`
/// holds thousands, and then a chain costs 0.45 ms (10,000 tiny brushes merged into 14 clusters
/// of 3,656 one-way portals on average, 2026-11-26).
const PORTAL_SCAN_WORK: u128 = 8;

/// The work limit [`VisOptions::coarsen`] merges clusters down to when no
/// [`VisOptions::max_work`] is given, in portal tests: under an hour of one core. The largest
/// shared map (e1m1, 3,062 portals, 1,167 clusters) is estimated at 2.5 × 10⁹, an eightieth of
/// it; 10,000 tiny brushes in one room (260,304 portals, 43,651 clusters) at 9.3 × 10¹².
pub const COARSEN_MAX_WORK: u64 = 200_000_000_000;

/// An estimate of the work a vis of `prt` does, in portal tests, from the counts alone: base vis
/// tests every one-way portal against at most every other (`one_way²`); the flow, in a room where
/// every cluster sees every other, follows at least one chain per (one-way portal, cluster), each
/// worth 300 tests (`CHAIN_WORK`) plus 8 (`PORTAL_SCAN_WORK`) per portal of its cluster
/// (`one_way / clusters` on average). On real maps the flow visits a tenth to a half of that many
/// chains. With `--fast` only base vis counts. It grows with the square of the input, which is
/// what makes a vis of a huge open area not finish; [`VisOptions::max_work`] bounds it.
pub fn work_estimate(prt: &PortalFile, opts: &VisOptions) -> u64 {
    work(Counts::of(prt), opts)
}

/// [`work_estimate`] from the counts.
fn work(counts: Counts, opts: &VisOptions) -> u64 {
    let one_way = 2 * counts.portals as u128;
    let base = one_way * one_way;
    let flow = if opts.fast {
        0
    } else {
        one_way * u128::from(counts.clusters) * CHAIN_WORK + one_way * one_way * PORTAL_SCAN_WORK
    };
    u64::try_from(base + flow).unwrap_or(u64::MAX)
}

/// The work limit of `opts` and where it comes from.
fn work_limit(opts: &VisOptions) -> Option<(u64, &'static str)> {
    match (opts.max_work, opts.coarsen) {
        (Some(limit), _) => Some((limit, "allowed by --max-work")),
        (None, true) => Some((COARSEN_MAX_WORK, "coarsening merges down to (see --max-work)")),
        (None, false) => None,
    }
}

/// Refuse a run whose [`work_estimate`] exceeds the limit.
fn check_work(prt: &PortalFile, opts: &VisOptions) -> Result<(), VisError> {
    let need = work_estimate(prt, opts);
    match work_limit(opts) {
        Some((limit, source_of_limit)) if need > limit => Err(VisError::Work {
            need,
            limit,
            reason: format!(
                "{} portals, {} clusters: it grows with their square",
                prt.portals.len(),
                prt.num_clusters
            ),
            source_of_limit: source_of_limit.to_string(),
            hint: if opts.coarsen {
                "merging clusters (--coarsen) does not bring it under either"
            } else {
                "rerun with --coarsen to merge clusters until it is under (a looser PVS)"
            }
            .to_string(),
        }),
        _ => Ok(()),
    }
}

/// Refuse a run whose [`memory_estimate`] exceeds `limit` ([`crate::memory::limit`]: the memory
/// available, or [`VisOptions::max_memory`] when lower).
fn check_memory(
    prt: &PortalFile,
    opts: &VisOptions,
    limit: Option<(u64, crate::memory::LimitSource)>,
) -> Result<(), VisError> {
    let need = memory_estimate(prt, opts);
    // Which matrices dominate, for the message: two portal × portal, four cluster × cluster.
    let (one_way, nc) = (2 * prt.portals.len() as u128, u128::from(prt.num_clusters));
    let portal_matrices = 2 * one_way * bits::words(one_way as usize) as u128;
    let cluster_matrices = 4 * nc * bits::words(nc as usize) as u128;
    match limit {
        Some((limit, source_of_limit)) if need > limit => Err(VisError::Memory {
            need,
            limit,
            what: if opts.fast { "vis --fast" } else { "vis" }.to_string(),
            reason: format!(
                "the {} matrices ({} leaves, {} clusters, {} portals)",
                if portal_matrices >= cluster_matrices { "portal" } else { "cluster" },
                prt.num_leaves,
                prt.num_clusters,
                prt.portals.len()
            ),
            source_of_limit,
            hint: if opts.coarsen {
                "merging clusters (--coarsen) does not make it fit either (merges are sized for one thread: fewer threads may fit)"
            } else {
                "rerun with --coarsen to merge clusters until it fits (a looser PVS)"
            }
            .to_string(),
        }),
        _ => Ok(()),
    }
}

/// The error for a caught panic, with its message when it has one.
fn panic_error(payload: Box<dyn Any + Send>) -> VisError {
    let message = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".to_string());
    VisError::Panicked(message)
}

/// Hash of the input and of what changes flow rows: the options and the run's `batch` size.
fn input_hash(prt: &PortalFile, opts: &VisOptions, batch: usize) -> u64 {
    let text = sightline_formats::prt::write(prt);
    let h = state::fnv1a(text.as_bytes(), state::FNV_OFFSET);
    let batch = u8::try_from(batch).unwrap_or(u8::MAX);
    state::fnv1a(&[opts.level, batch, u8::from(opts.seeds)], h)
}

/// The phases of a run, on the threads `opts.threads` says (see `parallel`).
fn run_phases(
    prt: &PortalFile,
    opts: &VisOptions,
    progress: &(dyn Fn(VisProgress) + Sync),
) -> Result<VisResult, VisError> {
    let t0 = Instant::now();
    let g = graph::Graph::new(prt);
    let n = g.portals.len();
    let words = bits::words(n);
    let counter = AtomicUsize::new(0);
    let base::Mightsee { rows: might, clusters: might_clusters } =
        base::mightsee(&g, words, opts.threads, &|| {
            let done = counter.fetch_add(1, Ordering::Relaxed) + 1;
            progress(VisProgress { phase: VisPhase::Base, done, total: n });
        });
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
        avg_mightsee,
        ..VisStats::default()
    };
    let mut result = if let Some(base_result) = base_result {
        base_result
    } else {
        let t1 = Instant::now();
        let portal_vis = flow_all(prt, &g, might, words, opts, progress, &mut stats)?;
        stats.flow_seconds = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        let result = cluster_rows(prt, &g, &portal_vis, words, row_threads);
        stats.rows_seconds = t2.elapsed().as_secs_f64();
        result
    };
    result.fill_stats(&mut stats);
    result.stats = stats;
    Ok(result)
}

/// Below this many words of rows (the one-way portals' rows of `words` words and the cluster
/// rows), the phases that turn rows into cluster rows run on one thread: there they take tens of
/// microseconds, less than starting a helper thread for them (on the generated 4 × 4 × 2 rooms,
/// two threads spent 0.18 ms on them against 0.10 ms on one).
pub const ROWS_SERIAL_WORDS: usize = 1 << 18;

/// The threads for the cluster-row phases of a run of `prt` with `words`-word portal rows on
/// `threads` threads (see [`ROWS_SERIAL_WORDS`]); the result is the same on any.
fn rows_threads(prt: &PortalFile, words: usize, threads: usize) -> usize {
    let nc = prt.num_clusters as usize;
    let size =
        (2 * prt.portals.len()).saturating_mul(words).saturating_add(nc.saturating_mul(bits::words(nc)));
    if size < ROWS_SERIAL_WORDS { 1 } else { threads }
}

/// Flow every portal in deterministic batches; returns the final portal rows.
fn flow_all(
    prt: &PortalFile,
    g: &graph::Graph,
    might: Vec<u64>,
    words: usize,
    opts: &VisOptions,
    progress: &(dyn Fn(VisProgress) + Sync),
    stats: &mut VisStats,
) -> Result<Vec<u64>, VisError> {
    let n = g.portals.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_cached_key(|&p| (bits::count(&might[p * words..(p + 1) * words]), p));
    // The flow narrows the `mightsee` rows in place.
    let mut test = might;
    symmetry::tighten_all(&mut test, words, n);
    let nc = g.num_clusters();
    let mut seeds = seeds::Seeds::new(nc);
    let batch = flow_batch(prt, opts);
    let mut done = 0usize;
    let mut quiet = 0usize;
    // With a state file, the log of every batch boundary: loaded and replayed when the file
    // exists (the rows and seeds the uninterrupted run had after those batches), then extended.
    let mut log = None;
    if let Some(path) = &opts.state {
        // Hashing prints the whole portal file: only checkpoints need the input's identity.
        let want = state::Expect {
            input_hash: input_hash(prt, opts, batch),
            portals: n,
            words,
            clusters: nc,
            batch,
        };
        log = Some(match state::load(path, &want)? {
            Some(st) => {
                quiet = st
                    .replay(&order, &mut test, seeds.known_mut())
                    .map_err(|e| state::inconsistent(path, &e))?;
                done = st.done as usize;
                stats.chains = st.total_chains();
                stats.resumed_portals = done;
                st
            }
            None => state::State::new(want.input_hash, n, words, nc),
        });
    }
    let run = Run { g, order: &order, words, n, batch, opts, progress };
    let test = run.batches(Rows { test, seeds, quiet }, done, log, stats)?;
    if let Some(path) = &opts.state {
        // The run is complete: the checkpoint has served its purpose.
        let _ = std::fs::remove_file(path);
    }
    Ok(test)
}

/// What flows read and batch boundaries write.
struct Rows {
    /// Per portal its final row once its batch is folded, else its `mightsee`.
    test: Vec<u64>,
    /// Per cluster, the clusters known visible from it by a certified line ([`certify`]).
    seeds: seeds::Seeds,
    /// Flows folded in a row whose beam culls dropped nothing ([`flow::quiet_after`]).
    quiet: usize,
}

/// What the flow workers share for one run of [`flow_all`].
struct Run<'a> {
    g: &'a graph::Graph,
    order: &'a [usize],
    words: usize,
    n: usize,
    /// Portals per batch ([`flow_batch`]).
    batch: usize,
    opts: &'a VisOptions,
    progress: &'a (dyn Fn(VisProgress) + Sync),
}

/// The batch in flight and what its last finisher needs.
struct Cursor {
    /// Next position in `order` to hand out.
    next: AtomicUsize,
    /// Portals of the open batch finished.
    finished: AtomicUsize,
    /// Positions before this one may start (the end of the open batch).
    ready: Lone<AtomicUsize>,
    /// Set when the run stops early (interrupted or failed).
    halt: Lone<AtomicBool>,
    /// Where a worker that waited past [`SPIN_WAITS`] checks sleeps until the batch opens or the
    /// run halts.
    gate: Mutex<()>,
    wake: Condvar,
    /// Workers asleep on `wake` (only then does opening a batch need a wake-up call).
    sleepers: AtomicUsize,
}

/// Checks a worker makes for the next batch, with a spin-loop hint between them (about 10 µs in
/// all), before it sleeps: batches of small maps close within microseconds, sooner than a
/// sleeping thread wakes, while a worker that kept checking through a long batch would hold a
/// core for nothing. Yielding the core between checks (192 `sched_yield` calls after 64 spins)
/// cost 2–7 % more CPU on two threads for the same wall time: with no other thread to run, each
/// yield is a system call that returns at once (`docs/benchmarks.md`).
const SPIN_WAITS: u32 = 256;

impl Cursor {
    /// Waits until position `i` may start; `false` when the run halts first.
    fn wait_for(&self, i: usize) -> bool {
        let mut spins = 0u32;
        while i >= self.ready.load(Ordering::Acquire) {
            if self.halt.load(Ordering::Acquire) {
                return false;
            }
            spins = spins.saturating_add(1);
            if spins < SPIN_WAITS {
                std::hint::spin_loop();
            } else {
                let guard = self.gate.lock().unwrap_or_else(PoisonError::into_inner);
                self.sleepers.fetch_add(1, Ordering::SeqCst);
                if i >= self.ready.load(Ordering::SeqCst) && !self.halt.load(Ordering::SeqCst) {
                    // The timeout only bounds a wake-up that went astray; `open` and `stop`
                    // notify under the gate, after their store.
                    let _ = self.wake.wait_timeout(guard, Duration::from_millis(10));
                }
                self.sleepers.fetch_sub(1, Ordering::SeqCst);
            }
        }
        !self.halt.load(Ordering::Acquire)
    }

    /// Lets positions before `end` start, waking sleeping workers.
    fn open(&self, end: usize) {
        self.ready.store(end, Ordering::SeqCst);
        self.notify();
    }

    /// Halts the run, waking sleeping workers so they return.
    fn stop(&self) {
        self.halt.store(true, Ordering::SeqCst);
        self.notify();
    }

    fn notify(&self) {
        // A worker counts itself asleep before it checks `ready` and `halt`, and the store
        // came before this load (all sequentially consistent): either it sees the store, or
        // this sees it counted, and then taking the gate orders the store before its check.
        // With nobody asleep (one thread, or a batch that closed within the spins) there is
        // no wake-up call to make.
        if self.sleepers.load(Ordering::SeqCst) > 0 {
            drop(self.gate.lock().unwrap_or_else(PoisonError::into_inner));
            self.wake.notify_all();
        }
    }
}

/// A value alone on its cache lines (128 bytes: two lines, as Intel's adjacent-line prefetch
/// moves them in pairs). The flag and bound a waiting worker polls, and each finished flow's slot,
/// sit apart from the counters every flow updates and from each other, so a worker finishing a
/// flow does not take the line another one is reading or writing: on two threads this saved
/// about 2 % of the CPU of the 4 × 4 × 2 generated rooms (`docs/benchmarks.md`).
#[repr(align(128))]
struct Lone<T>(T);

impl<T> std::ops::Deref for Lone<T> {
    type Target = T;

    fn deref(&self) -> &T {
        &self.0
    }
}

/// A finished flow waiting for its batch to close.
#[derive(Default)]
struct Slot {
    row: Vec<u64>,
    chains: u64,
    /// A beam cull of the flow dropped a portal.
    dropped: bool,
}

/// Bookkeeping done at batch boundaries by the worker that finishes a batch.
struct Boundary<'s> {
    stats: &'s mut VisStats,
    /// With a state file, what it will hold: the log of every boundary so far.
    log: Option<state::State>,
    last_save: Instant,
    outcome: Option<VisError>,
}

impl Run<'_> {
    /// Positions `done..n` of `order` in batches of `self.batch` (counted from `done`): a
    /// portal starts once every earlier batch is folded into `test`, and reads `test` only then.
    /// A worker runs on each of the run's threads, takes portals from a shared cursor and waits
    /// for the next batch by spinning briefly, then sleeping ([`Cursor::wait_for`]). A worker
    /// that panics records the error and halts the cursor, so the others stop waiting for a
    /// batch that cannot close. Returns the final rows, or why the run stopped.
    fn batches(
        &self,
        rows: Rows,
        done: usize,
        log: Option<state::State>,
        stats: &mut VisStats,
    ) -> Result<Vec<u64>, VisError> {
        let test = RwLock::new(rows);
        let slots: Vec<Lone<Mutex<Slot>>> =
            (0..self.batch).map(|_| Lone(Mutex::new(Slot::default()))).collect();
        let cursor = Cursor {
            next: AtomicUsize::new(done),
            finished: AtomicUsize::new(0),
            ready: Lone(AtomicUsize::new((done + self.batch).min(self.n))),
            halt: Lone(AtomicBool::new(false)),
            gate: Mutex::new(()),
            wake: Condvar::new(),
            sleepers: AtomicUsize::new(0),
        };
        let boundary = Mutex::new(Boundary { stats, log, last_save: Instant::now(), outcome: None });
        // One worker on each of the run's threads (this one and its helpers), or on this one.
        parallel::on_every_thread(self.opts.threads, || {
            let work = || self.worker(done, &test, &slots, &cursor, &boundary);
            if let Err(payload) = std::panic::catch_unwind(AssertUnwindSafe(work)) {
                let mut b = boundary.lock().unwrap_or_else(PoisonError::into_inner);
                if !matches!(b.outcome, Some(VisError::Panicked(_))) {
                    b.outcome = Some(panic_error(payload));
                }
                cursor.stop();
            }
        });
        let boundary = boundary.into_inner().unwrap_or_else(PoisonError::into_inner);
        match boundary.outcome {
            Some(e) => Err(e),
            None => Ok(test.into_inner().unwrap_or_else(PoisonError::into_inner).test),
        }
    }

    fn worker(
        &self,
        start: usize,
        test: &RwLock<Rows>,
        slots: &[Lone<Mutex<Slot>>],
        cursor: &Cursor,
        boundary: &Mutex<Boundary<'_>>,
    ) {
        let mut f = flow::Flow::new(self.words, self.g.num_clusters(), self.opts.level, self.opts.seeds);
        // The rows, read-locked from a worker's first flow of a batch to its last: a batch is
        // folded (write-locked) only once all its flows are done, and a worker lets go before it
        // waits for the next batch.
        let mut rows = None;
        // A row for the next result: the one this worker's last flow replaced in its slot.
        let mut spare = Vec::new();
        loop {
            let i = cursor.next.fetch_add(1, Ordering::AcqRel);
            if i >= self.n {
                return;
            }
            if i >= cursor.ready.load(Ordering::Acquire) {
                rows = None;
            }
            if !cursor.wait_for(i) {
                return;
            }
            let mut out = std::mem::take(&mut spare);
            out.resize(self.words, 0);
            f.chains = 0;
            #[cfg(test)]
            if self.opts.panic_at == Some(i) {
                panic!("injected panic at flow position {i}");
            }
            let batch_start = start + (i - start) / self.batch * self.batch;
            let batch_end = (batch_start + self.batch).min(self.n);
            // A batch's portals are handed out from its end: `order` puts the largest `mightsee`
            // (the longest flows) there, so the batch's last flows to start are its shortest.
            let pos = batch_end - 1 - (i - batch_start);
            let r = rows.get_or_insert_with(|| test.read().unwrap_or_else(PoisonError::into_inner));
            f.run(self.g, &r.test, &r.seeds, self.order[pos], flow::trial_after(r.quiet), &mut out);
            {
                let mut slot = slots[pos - batch_start].lock().unwrap_or_else(PoisonError::into_inner);
                spare = std::mem::replace(&mut slot.row, out);
                (slot.chains, slot.dropped) = (f.chains, f.dropped());
            }
            let finished = cursor.finished.fetch_add(1, Ordering::AcqRel) + 1;
            (self.progress)(VisProgress {
                phase: VisPhase::Flow,
                done: batch_start + finished,
                total: self.n,
            });
            if finished == batch_end - batch_start {
                rows = None;
                self.close_batch(batch_start, batch_end, test, slots, cursor, boundary);
            }
        }
    }

    /// Fold a finished batch into `test`, checkpoint and check for a stop, then open the next.
    fn close_batch(
        &self,
        batch_start: usize,
        batch_end: usize,
        test: &RwLock<Rows>,
        slots: &[Lone<Mutex<Slot>>],
        cursor: &Cursor,
        boundary: &Mutex<Boundary<'_>>,
    ) {
        let (n, words) = (self.n, self.words);
        let mut guard = boundary.lock().unwrap_or_else(PoisonError::into_inner);
        let b = &mut *guard;
        let mut rows = test.write().unwrap_or_else(PoisonError::into_inner);
        let Rows { test: rows, seeds, quiet } = &mut *rows;
        // The batch's seed pairs, new at this boundary; the log gives them to its last portal.
        let mut added = Vec::new();
        match b.log {
            Some(_) => seeds.fold(|from, to| added.push((from, to))),
            None => seeds.fold(|_, _| {}),
        }
        for (pos, &p) in self.order[batch_start..batch_end].iter().enumerate() {
            let slot = slots[pos].lock().unwrap_or_else(PoisonError::into_inner);
            symmetry::replace_row(rows, words, p, &slot.row);
            *quiet = flow::quiet_after(*quiet, slot.dropped);
            b.stats.chains += slot.chains;
            // The log replays exactly this: the row as folded, and the pairs that were new.
            if let Some(log) = &mut b.log {
                let pairs =
                    if pos + 1 == batch_end - batch_start { std::mem::take(&mut added) } else { Vec::new() };
                log.push(&rows[p * words..(p + 1) * words], slot.chains, slot.dropped, pairs);
            }
        }
        let done = batch_end;
        let cancelled = self.opts.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed));
        let stop = (self.opts.stop_after.is_some_and(|s| done >= s) || cancelled) && done < n;
        if let (Some(path), Some(log)) = (&self.opts.state, &b.log)
            && (stop || (done < n && b.last_save.elapsed() >= self.opts.checkpoint_interval))
        {
            let saved = state::save(path, log);
            b.last_save = Instant::now();
            if let Err(e) = saved {
                b.outcome = Some(e);
                cursor.stop();
                return;
            }
        }
        if stop {
            b.outcome = Some(VisError::Interrupted { done, total: n });
            cursor.stop();
            return;
        }
        cursor.finished.store(0, Ordering::Release);
        cursor.open((done + self.batch).min(n));
    }
}

/// Cluster rows from portal rows: a cluster sees itself, every cluster its portals lead to, and
/// every cluster a portal it owns sees; then `M ∧ Mᵀ`.
fn cluster_rows(
    prt: &PortalFile,
    g: &graph::Graph,
    portal_vis: &[u64],
    words: usize,
    threads: usize,
) -> VisResult {
    let nc = prt.num_clusters as usize;
    let cw = bits::words(nc);
    let mut rows = vec![0u64; nc * cw];
    if cw > 0 {
        parallel::each_row(
            threads,
            &mut rows,
            cw,
            || vec![0u64; words],
            |pv, c, row| {
                pv.fill(0);
                for &q in &g.cluster_portals[c] {
                    let q = q as usize;
                    for (a, b) in pv.iter_mut().zip(&portal_vis[q * words..(q + 1) * words]) {
                        *a |= b;
                    }
                    bits::set(pv, q);
                }
                for q in bits::ones(pv) {
                    bits::set(row, g.portals[q].leaf as usize);
                }
                bits::set(row, c);
            },
        );
    }
    symmetric_result(prt, rows, threads)
}

/// The result of cluster rows (`bits::words(clusters)` words per cluster) made symmetric: `M ∧ Mᵀ`.
fn symmetric_result(prt: &PortalFile, mut rows: Vec<u64>, threads: usize) -> VisResult {
    let nc = prt.num_clusters as usize;
    let cw = bits::words(nc);
    let snapshot = rows.clone();
    if cw > 0 {
        parallel::each_row(threads, &mut rows, cw, Vec::new, |ones, a, row| {
            ones.clear();
            ones.extend(bits::ones(row));
            for &b in ones.iter() {
                if !bits::get(&snapshot[b * cw..(b + 1) * cw], a) {
                    bits::clear(row, b);
                }
            }
        });
    }
    let mut cluster_leaves = vec![Vec::new(); nc];
    for (leaf, &c) in prt.leaf_clusters.iter().enumerate() {
        cluster_leaves[c as usize].push(leaf as u32);
    }
    VisResult {
        num_leaves: prt.num_leaves as usize,
        leaf_clusters: prt.leaf_clusters.clone(),
        cluster_leaves,
        words: cw,
        rows,
        stats: VisStats::default(),
    }
}

/// The leaves visible per leaf, on average, in the result cluster rows `rows` give once made
/// symmetric ([`symmetric_result`]), counted without building it: the same number as that
/// result's [`VisResult::average_visible`].
fn symmetric_average(prt: &PortalFile, rows: &[u64], threads: usize) -> f64 {
    let nc = prt.num_clusters as usize;
    let cw = bits::words(nc);
    let mut size = vec![0u64; nc];
    for &c in &prt.leaf_clusters {
        size[c as usize] += 1;
    }
    // Per cluster `a`, its leaves times the leaves of every cluster `b` it sees that sees it.
    let mut seen = vec![0u64; nc];
    if cw > 0 {
        parallel::each_row(
            threads,
            &mut seen,
            1,
            || (),
            |(), a, out| {
                let both = bits::ones(&rows[a * cw..(a + 1) * cw])
                    .filter(|&b| bits::get(&rows[b * cw..(b + 1) * cw], a));
                out[0] = size[a] * both.map(|b| size[b]).sum::<u64>();
            },
        );
    }
    seen.iter().sum::<u64>() as f64 / prt.num_leaves.max(1) as f64
}

impl VisResult {
    fn average_visible(&self) -> f64 {
        let total: u64 = (0..self.num_leaves).map(|l| u64::from(self.visible_leaves(l))).sum();
        total as f64 / self.num_leaves.max(1) as f64
    }

    fn fill_stats(&self, stats: &mut VisStats) {
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

#[cfg(test)]
mod tests;
