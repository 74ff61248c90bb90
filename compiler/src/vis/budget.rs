//! What a run will take, from the counts alone: its memory ([`memory_estimate`]) and work
//! ([`work_estimate`]), the limits it is refused over, its thread count and flow batch size.

use sightline_formats::bits;
use sightline_formats::prt::PortalFile;

use super::error::VisError;
use super::options::VisOptions;
use super::{base, flow, graph, seeds, state};

/// Portals per deterministic flow batch (a portal sees the results of earlier batches only) for
/// an input estimated at `100 ×` [`SERIAL_WORK`] or more: long runs on every core, whose batches
/// have to hold enough flows to keep the cores busy until a batch's longest flow ends.
pub const FLOW_BATCH: usize = 48;

/// Portals per flow batch below that, by the input's work with base tests counted once (not
/// [`work_estimate`]'s weight): the first `(below, batch)` whose
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

/// Below this work (in portal tests, base tests counted once as for [`FLOW_BATCHES`]), a run
/// given no thread count ([`VisOptions::threads`]
/// 0) takes one thread: such a run lasts milliseconds, and starting threads and waiting at batch
/// boundaries for a batch's longest flow cost more than a second thread shares. On a sealed room
/// with a 100-sided pillar (estimate 9 × 10⁶) two threads took 9.0 ms of CPU to one thread's 5.8,
/// for the same wall time; from about 7 × 10⁷ (the generated 4 × 4 × 2 rooms) two threads cut the
/// wall time by a fifth or more.
pub const SERIAL_WORK: u64 = 20_000_000;

/// Portals per flow batch for a run of `prt` (the input the flow reads, after any merging) with
/// `opts`: from [`FLOW_BATCHES`] by its work, else [`FLOW_BATCH`]. It depends on
/// the input alone, never on the thread count, so every thread count gives the same result.
pub fn flow_batch(prt: &PortalFile, opts: &VisOptions) -> usize {
    batch(Counts::of(prt), opts)
}

/// [`flow_batch`] from the counts.
pub(super) fn batch(counts: Counts, opts: &VisOptions) -> usize {
    let work = work(counts, opts);
    FLOW_BATCHES.iter().find(|&&(below, _)| work < below).map_or(FLOW_BATCH, |&(_, batch)| batch)
}

/// An upper estimate of the bytes [`run`](super::run) allocates for `prt` with `opts`, computed from the
/// counts alone: the portal × portal bit matrices (`mightsee`, the flow rows; with a state file
/// its log, `state::bytes_bound`, seed pairs included), the seeds (known and the batch's
/// pending ones, a row of clusters per portal and per cluster), the cluster × cluster matrices
/// (cluster rows, their snapshot and the `mightsee` rows for statistics), per-thread rows and flow frames (at most [`MAX_FLOW_DEPTH`](super::MAX_FLOW_DEPTH)
/// deep), and the portal graph.
pub fn memory_estimate(prt: &PortalFile, opts: &VisOptions) -> u64 {
    estimate(Counts::of(prt), &VisOptions { threads: thread_count(prt, opts), ..opts.clone() })
}

/// The threads a run of `prt` with `opts` uses: [`VisOptions::threads`] when given, else one below
/// [`SERIAL_WORK`] (the cores are then not even counted) and every core above it.
pub(super) fn thread_count(prt: &PortalFile, opts: &VisOptions) -> usize {
    match opts.threads {
        0 if work(Counts::of(prt), opts) < SERIAL_WORK => 1,
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        t => t,
    }
}

/// The counts [`memory_estimate`] and [`work_estimate`] depend on.
#[derive(Debug, Clone, Copy)]
pub(super) struct Counts {
    /// Portal lines.
    pub(super) portals: usize,
    pub(super) clusters: u32,
    pub(super) leaves: u32,
    /// Winding points over all portal lines.
    pub(super) points: u128,
}

impl Counts {
    pub(super) fn of(prt: &PortalFile) -> Self {
        Self {
            portals: prt.portals.len(),
            clusters: prt.num_clusters,
            leaves: prt.num_leaves,
            points: prt.portals.iter().map(|p| p.winding.points.len() as u128).sum(),
        }
    }
}

/// Cluster × cluster matrices a run holds: the result, its snapshot for symmetry, and the
/// `mightsee` rows' result.
const CLUSTER_MATRICES: u128 = 3;

/// Rows of cluster bits the seeds take for `one_way` portals and `nc` clusters: the known seeds
/// and the batch's pending ones, each a matrix of [`seeds::Seeds::rows`].
fn seed_rows(one_way: u128, nc: u128) -> u128 {
    // Both counts come from lengths in memory, so they fit a `usize`.
    2 * seeds::Seeds::rows(one_way as usize, nc as usize) as u128
}

/// [`memory_estimate`] from the counts, for `opts.threads` threads (resolved: at least one).
pub(super) fn estimate(counts: Counts, opts: &VisOptions) -> u64 {
    let threads = opts.threads.max(1) as u128;
    let (one_way, nc) = (2 * counts.portals as u128, u128::from(counts.clusters));
    let row = 8 * bits::words(one_way as usize) as u128;
    let cluster_row = 8 * bits::words(nc as usize) as u128;
    let points = counts.points;
    let graph = one_way * (std::mem::size_of::<graph::OneWay>() as u128 + 32 + 8 + 4)
        + 2 * (24 + 32) * points
        + nc * 2 * 24
        + base::OUT_BYTES_PER_PORTAL * one_way
        + 2 * 4 * (nc + 1);
    // `mightsee` and, with the flow, the rows it narrows.
    let mut matrices = one_way * row;
    if !opts.fast {
        matrices += one_way * row;
        // The seeds (known and pending), and the checkpoint log (a row per portal and up to
        // every seed pair, with its encoding while saved or loaded).
        matrices += seed_rows(one_way, nc) * cluster_row;
        if opts.state.is_some() {
            matrices += state::bytes_bound(one_way, row / 8, nc);
        }
    }
    // The cluster rows ([`CLUSTER_MATRICES`]), and 8 bytes a leaf and 24 a cluster besides.
    let clusters = CLUSTER_MATRICES * nc * cluster_row + u128::from(counts.leaves) * 8 + nc * 24;
    // Base vis's `entered` clusters and flood stack (each cluster once), the cluster rows' portal
    // row; with the flow, its state and the row it fills.
    let mut per_thread = row + cluster_row + 4 * nc;
    if !opts.fast {
        per_thread += row + flow::Flow::bytes(one_way as usize, nc as usize);
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
/// shared map (e1m1, 3,062 portals, 1,167 clusters) is estimated at 2.8 × 10⁹, a seventieth of
/// it; 10,000 tiny brushes in one room (260,304 portals, 43,651 clusters) at 1.2 × 10¹³.
pub const COARSEN_MAX_WORK: u64 = 200_000_000_000;

/// Portal tests per second of one core, the fixed rate a time budget (`sightline --max-time`)
/// becomes a [`VisOptions::max_work`] by: the same on every machine, so a given budget merges
/// alike everywhere and the PVS stays deterministic. On the shared maps (2 threads, 2026-11-29)
/// the run did 2–6 × 10⁸ of [`work_estimate`]'s tests per CPU second, so a run inside a budget
/// of `T` takes at most about `T` of one core there, usually a half to a fifth of it.
pub const WORK_PER_SECOND: u64 = 100_000_000;

/// An estimate of the work a vis of `prt` does, in portal tests, from the counts alone: base vis
/// tests every one-way portal against at most every other (`one_way²`), each test weighed ten
/// flow tests (`BASE_TEST_WEIGHT`); the flow, in a room where every cluster sees every other,
/// follows at least one chain per (one-way portal, cluster), each worth 300 tests (`CHAIN_WORK`)
/// plus 8 (`PORTAL_SCAN_WORK`) per portal of its cluster (`one_way / clusters` on average). On
/// real maps the flow visits a tenth to a half of that many chains. With `--fast` only base vis
/// counts. It grows with the square of the input, which is what makes a vis of a huge open area
/// not finish; [`VisOptions::max_work`] bounds it.
pub fn work_estimate(prt: &PortalFile, opts: &VisOptions) -> u64 {
    limit_work(Counts::of(prt), opts)
}

/// The work of a run from the counts with each base-vis test counted once: what sizes the flow's
/// batches ([`batch`]) and picks one thread for small inputs ([`thread_count`]). The limits use
/// [`limit_work`].
pub(super) fn work(counts: Counts, opts: &VisOptions) -> u64 {
    let one_way = 2 * counts.portals as u128;
    let base = one_way * one_way;
    let flow = if opts.fast {
        0
    } else {
        counted_chains(counts) * CHAIN_WORK + one_way * one_way * PORTAL_SCAN_WORK
    };
    u64::try_from(base + flow).unwrap_or(u64::MAX)
}

/// The chains [`work`] counts on: one per one-way portal and cluster.
fn counted_chains(counts: Counts) -> u128 {
    2 * counts.portals as u128 * u128::from(counts.clusters)
}

/// What one base-vis test costs against one flow test, in the work limits only ([`limit_work`]):
/// on inputs merged by `coarsen` into clusters of thousands of portals, a base test took 60–120
/// ns against the 10 ns of a flow test (10,000 tiny brushes merged into 128 clusters, 2026-11-29),
/// so counting it as one let the merge stop where base vis alone took over 15 minutes.
const BASE_TEST_WEIGHT: u128 = 10;

/// [`work_estimate`] from the counts, what the limits ([`VisOptions::max_work`], `--max-time`,
/// [`COARSEN_MAX_WORK`]) are checked against: [`work`] with each base-vis test weighed
/// [`BASE_TEST_WEIGHT`] times. Batch sizes and the thread count keep [`work`], so the PVS of an
/// input is as before the weight was introduced.
pub(super) fn limit_work(counts: Counts, opts: &VisOptions) -> u64 {
    let one_way = 2 * counts.portals as u128;
    let surcharge = (BASE_TEST_WEIGHT - 1) * one_way * one_way;
    u64::try_from(u128::from(work(counts, opts)) + surcharge).unwrap_or(u64::MAX)
}

/// How many times the chains `work_estimate` counts on (one per one-way portal and cluster) a
/// flow on merged clusters may make before `run` merges further. Flows that fit the estimate made
/// 0.03–0.93 of those chains (the heavy open maps unmerged 0.8–0.93; merged by
/// `--coarsen --max-work`, 0.03–0.92). Some partial merges made 5–140 times as many, and flows
/// 4–17 times as long as the unmerged map's (generated arena_32 and city_28, 2026-11-29,
/// `docs/benchmarks.md`): a merged cluster is not convex, and their chains followed every order
/// of the loops a line may make out of a merged cluster and back into it. Flows skip such loops
/// now (the `vis::flow` module docs), and no merge of the heavy set under 1/2 to 1/64 of its
/// estimate comes near the cap since; it stays as the bound of a flow the estimate does not
/// foresee.
pub const CHAIN_CAP_FACTOR: u64 = 2;

/// The chains a flow of `prt` (merged clusters) may make before `run` merges further:
/// [`CHAIN_CAP_FACTOR`] times those [`work`] counts on.
pub(super) fn chain_cap(prt: &PortalFile) -> u64 {
    let chains = counted_chains(Counts::of(prt)) * u128::from(CHAIN_CAP_FACTOR);
    u64::try_from(chains).unwrap_or(u64::MAX)
}

/// The work limit of `opts` and where it comes from.
pub(super) fn work_limit(opts: &VisOptions) -> Option<(u64, &'static str)> {
    match (opts.max_work, opts.coarsen) {
        (Some(limit), _) => Some((limit, "allowed by --max-work (or --max-time)")),
        (None, true) => Some((COARSEN_MAX_WORK, "coarsening merges down to (see --max-work)")),
        (None, false) => None,
    }
}

/// Refuse a run whose [`work_estimate`] exceeds the limit.
pub(super) fn check_work(prt: &PortalFile, opts: &VisOptions) -> Result<(), VisError> {
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
pub(super) fn check_memory(
    prt: &PortalFile,
    opts: &VisOptions,
    limit: Option<(u64, crate::memory::LimitSource)>,
) -> Result<(), VisError> {
    let need = memory_estimate(prt, opts);
    // Which matrices dominate, for the message: two portal × portal, or those of cluster rows
    // (three cluster × cluster, and the seeds' two of a row per portal and per cluster).
    let (one_way, nc) = (2 * prt.portals.len() as u128, u128::from(prt.num_clusters));
    let portal_matrices = 2 * one_way * bits::words(one_way as usize) as u128;
    let cluster_matrices =
        (CLUSTER_MATRICES * nc + seed_rows(one_way, nc)) * bits::words(nc as usize) as u128;
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
