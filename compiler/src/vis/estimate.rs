//! How long the flow will take: predicted once base vis is done ([`flow_seconds`]), and refined
//! as portals finish: the flow's progress phase counts each portal's steps by its expected cost
//! ([`progress_steps`]), so the time left a progress bar or line shows is the refined estimate,
//! and [`Refine`] records it at a tenth. Estimates go to progress notes, the progress phase and
//! [`VisStats`](super::VisStats) only; nothing here changes the PVS.
//!
//! # The model
//! The flow's cost is its chains (recursive calls, one portal deeper each): a chain costs about
//! the same anywhere (1.3–3.4 µs of CPU on the shared and the heavy maps alike on an AMD EPYC
//! host, 2026-11-30), while the chains per portal vary by four orders of magnitude. A portal that might
//! see `m` of `n` one-way portals visits about [`CHAINS_SCALE`] × `m`^[`MIGHTSEE_EXPONENT`] /
//! `n`^[`PORTALS_EXPONENT`] chains ([`chains`]): on open maps the late portals find few branches
//! cut by seeds or narrowed rows, so chains grow faster than `m`, and longer rows narrow more. But
//! never more than about the clusters there are: a chain goes on only while something beyond it
//! is new. Without that cap, a map merged into a few dozen clusters (`--coarsen`) was predicted
//! millions of chains per portal, for 4 made. The cap is lower where a cluster has many portals
//! ([`CAP_TARGETS_EXPONENT`]). A chain is priced at [`CHAIN_PER_BASE_TEST`] base vis tests of this
//! very run, so on this machine and thread count, times [`scan_factor`] of the targets a frame
//! scans: on merged clusters a frame tests each of its cluster's hundreds or thousands of
//! portals, and a chain costs tens of times an unmerged one.
//! The refinement tracks progress by a flatter weight ([`progress_weight`]).
//! How far off the first estimate is, and why no richer model or early sample did better (a
//! flow's chains depend on how far earlier flows narrowed its row, down to the heaviest flows
//! just before it): `docs/benchmarks.md`, sessions 21, 22, 25, 27 and 29.

use std::time::Instant;

use super::graph::Graph;

/// Chains per portal per `m^MIGHTSEE_EXPONENT / n^PORTALS_EXPONENT` (see [`chains`]).
///
/// The three constants and [`CHAIN_PER_BASE_TEST`] were fitted together, on the real flow time,
/// over the 40 portal files whose flow took 0.05 s or more (id's and LibreQuake's maps from
/// ericw-tools, SDHLT, q2tools and q3map2; the heavy set from ericw-tools and from us; 2 threads,
/// AMD EPYC host, 2026-11-30): real / first estimate 0.50–1.71 on all of them (two runs each),
/// against 0.30–2.20 with the model before (`m`^2.2 / `n`^0.6, [`PROGRESS_CHAINS_SCALE`]).
/// Fitted without the map in question, 0.38–2.13: the 1,000-brush room, where every leaf sees
/// every other and the clusters' cap decides, is the one the others do not foretell
/// (`docs/benchmarks.md`, session 29).
pub const CHAINS_SCALE: f64 = 0.000175;

/// How a portal's chains grow with its `mightsee` count ([`chains`]).
pub const MIGHTSEE_EXPONENT: f64 = 2.7;

/// How a portal's chains shrink with the map's one-way portals at the same `mightsee`
/// ([`chains`]).
pub const PORTALS_EXPONENT: f64 = 0.55;

/// Wall time of a chain in wall time of a base vis test, fitted with [`CHAINS_SCALE`]: only
/// their product is measured. A map's own chain costs 54–195 base tests, more on longer rows,
/// and the model's count is 0.3–1.4 times the chains made (2026-11-30).
pub const CHAIN_PER_BASE_TEST: f64 = 205.0;

/// The targets a frame scans on an unmerged map, about (3.8–6.0 one-way portals per cluster on
/// the shared and the heavy maps): where [`chains`] caps a portal at the clusters exactly.
pub const CAP_TARGETS: f64 = 5.5;

/// How the cap of [`chains`] shrinks with the targets a frame scans `t`
/// ([`targets_per_frame`]): the clusters times `(t / CAP_TARGETS)^-CAP_TARGETS_EXPONENT`. A
/// cluster of many portals shows a chain many at once, so its rows fill in fewer chains: the
/// 1,000-brush room (11 targets) made 0.55 chains per one-way portal per cluster where the open
/// maps of 5–6 targets made 0.3–1.3, and rooms merged by `--coarsen` (170–1,200 targets)
/// 0.05–0.13. Fitted with [`SCAN_TARGETS_UNIT`] on ten such merges (session 29); unmerged
/// maps' caps move by 0.97–1.12 times, the 1,000-brush room's by 0.81.
pub const CAP_TARGETS_EXPONENT: f64 = 0.3;

/// The predicted chains of a portal that might see `mightsee` of `portals` one-way portals, in a
/// map of `clusters` clusters: the model's count rounded up, capped at about `clusters`
/// ([`CAP_TARGETS_EXPONENT`]), plus 1 so every portal counts. Monotone in `mightsee`.
pub fn chains(mightsee: u64, portals: usize, clusters: usize) -> u64 {
    let model = Model { scale: CHAINS_SCALE, mightsee: MIGHTSEE_EXPONENT, portals: PORTALS_EXPONENT };
    model.capped(mightsee, portals, clusters)
}

/// A count of a portal's chains: `scale` × `m`^`mightsee` / `n`^`portals` for a portal that
/// might see `m` of `n` one-way portals.
struct Model {
    scale: f64,
    mightsee: f64,
    portals: f64,
}

impl Model {
    /// The count for `mightsee` of `portals` one-way portals in a map of `clusters` clusters,
    /// rounded up and capped at about `clusters` ([`CAP_TARGETS_EXPONENT`]), plus 1 so every
    /// portal counts. Monotone in `mightsee`.
    fn capped(&self, mightsee: u64, portals: usize, clusters: usize) -> u64 {
        let n = portals.max(1) as f64;
        let predicted = self.scale * (mightsee as f64).powf(self.mightsee) / n.powf(self.portals);
        let targets = n / clusters.max(1) as f64;
        let cap = clusters as f64 * (targets / CAP_TARGETS).powf(-CAP_TARGETS_EXPONENT);
        // `as` saturates: a huge prediction or cap stays finite.
        (predicted.ceil().min(cap.floor()) as u64).saturating_add(1)
    }
}

/// Targets scanned per frame at which [`scan_factor`] doubles a chain's price.
///
/// A frame tests each portal out of its cluster, so a chain's CPU time grows with the targets:
/// on rooms of tiny brushes merged by `--coarsen` (AMD EPYC host, 2026-11-30) it was 10–35 µs at
/// 170–800 targets a frame and 60–90 µs at 1,000–1,200, against 1.1–3.4 µs on unmerged maps.
/// Fitted with [`CAP_TARGETS_EXPONENT`] on tiny_1000, tiny_3000, tiny_5000 and tiny_10000 merged
/// into 63–618 clusters (ten merges, 170–1,200 targets a frame): real / first flow time
/// 0.68–1.38 (`docs/benchmarks.md`, session 29). Not on every merge: tiny_10000 merged into 612
/// clusters made ten times the chains of the others, as unmerged open rooms do, and is 4.4
/// times short. Unmerged maps scan 3.8–11 targets a frame: a factor of 1.03–1.08, inside the fit
/// of [`CHAIN_PER_BASE_TEST`].
pub const SCAN_TARGETS_UNIT: f64 = 140.0;

/// The targets a frame scans in `g`, on average: the one-way portals per cluster (a frame
/// tests each portal out of its cluster). 0 without clusters. The plain mean, not one weighed by
/// how many portals lead into each cluster: ericw-tools' arenas have one open cluster of
/// hundreds of portals, which puts that weighed mean at 110–180 there, yet their chains cost
/// what other unmerged maps' do.
pub fn targets_per_frame(g: &Graph) -> f64 {
    match g.num_clusters() {
        0 => 0.0,
        nc => g.portals.len() as f64 / nc as f64,
    }
}

/// How many times an unmerged chain's price a chain costs whose frames scan `targets` targets
/// each ([`targets_per_frame`]): `1 + targets / SCAN_TARGETS_UNIT`. At least 1, monotone.
pub fn scan_factor(targets: f64) -> f64 {
    1.0 + targets.max(0.0) / SCAN_TARGETS_UNIT
}

/// Seconds predicted for `work` chains (a sum of [`chains`]) whose frames scan `targets` targets
/// each ([`targets_per_frame`]) by a run whose base vis made `base_tests` tests in
/// `base_seconds` (0 when base vis tested nothing: then there is nothing to flow). Never lower
/// for more work or more targets.
pub fn flow_seconds(work: u64, targets: f64, base_seconds: f64, base_tests: u64) -> f64 {
    if base_tests == 0 {
        return 0.0;
    }
    CHAIN_PER_BASE_TEST * scan_factor(targets) * base_seconds / base_tests as f64 * work as f64
}

/// A portal's share of the flow's progress ([`progress_steps`]): its chains by the shape model
/// ([`PROGRESS_CHAINS_SCALE`] × `m`^[`PROGRESS_MIGHTSEE_EXPONENT`] /
/// `n`^[`PROGRESS_PORTALS_EXPONENT`], capped as in [`chains`], for a map of `portals` one-way
/// portals and `clusters` clusters) to the power [`PROGRESS_EXPONENT`], in 1/[`PROGRESS_UNIT`]
/// steps. Monotone in `mightsee`; equal for portals whose chains reach the clusters' cap, as on
/// a map merged into a few clusters, whose early flows cost as much as its late ones.
pub fn progress_weight(mightsee: u64, portals: usize, clusters: usize) -> u64 {
    let shape = Model {
        scale: PROGRESS_CHAINS_SCALE,
        mightsee: PROGRESS_MIGHTSEE_EXPONENT,
        portals: PROGRESS_PORTALS_EXPONENT,
    };
    let chains = shape.capped(mightsee, portals, clusters) as f64;
    // `as` saturates: a huge weight stays finite.
    (chains.powf(PROGRESS_EXPONENT) * PROGRESS_UNIT).round() as u64
}

/// The progress weights' model of a portal's chains ([`progress_weight`]), the first estimate's
/// model before session 29: its count (fitted to the chains made, real / predicted 0.49–2.05 over 28
/// maps) keeps the relative cost of one map's portals, cheap ones included, which the replay of
/// [`PROGRESS_EXPONENT`] measured. [`chains`] is fitted to the flow's total time across maps
/// instead, and undercounts cheap portals: with its weights the estimate refined at a tenth fell
/// to an eighth of the real time on id's dm2 (session 29).
pub const PROGRESS_CHAINS_SCALE: f64 = 0.0163;

/// How the progress weights' chains grow with `mightsee` ([`PROGRESS_CHAINS_SCALE`]).
pub const PROGRESS_MIGHTSEE_EXPONENT: f64 = 2.2;

/// How the progress weights' chains shrink with the map's one-way portals
/// ([`PROGRESS_CHAINS_SCALE`]).
pub const PROGRESS_PORTALS_EXPONENT: f64 = 0.6;

/// How a portal's progress weight grows with its chains by the shape model
/// ([`progress_weight`]): within one map a flow's time grows more slowly than its chains. Per-flow
/// times of 36 maps (the shared ones and the heavy set, 2026-11-29) replayed through [`Refine`]
/// gave, as the worst ratio either way between the real flow time and the estimate refined at
/// 10 % of the elapsed time, 1.70 with this exponent (0.45: 1.81, 0.55: 2.07), 2.16 with
/// `(1 + m)^0.75`, 3.75 with `1 + m` and 4.50 with one step per portal; at 20 % of the elapsed
/// time 1.91, 1.97, 3.00 and 2.70; at the first tenth of the steps 2.22, 2.70 and 2.72.
pub const PROGRESS_EXPONENT: f64 = 0.5;

/// Steps per unit of [`progress_weight`], so portals of few chains keep their differences.
pub const PROGRESS_UNIT: f64 = 256.0;

/// First estimates at or above this many seconds are said (a progress note). The flow's
/// progress phase counts [`progress_steps`], so the time left it shows is the refined estimate.
pub const SAY_SECONDS: f64 = 10.0;

/// The steps of the flow's progress phase per position of the processing order, for portals
/// whose `mightsee` counts are `counts` (in that order) in a map of `clusters` clusters: their
/// [`progress_weight`]s scaled so that the steps add up to the portal count, each position
/// taking the steps its weight brings the running total to. A phase's time left (the elapsed
/// time scaled by the steps left over the steps done) is then the refined estimate: the cheap
/// portals processed first do not make the rest look short, as a step per portal did.
pub fn progress_steps(counts: &[u64], clusters: usize) -> Vec<u64> {
    let n = counts.len() as u128;
    let weights: Vec<u128> =
        counts.iter().map(|&m| u128::from(progress_weight(m, counts.len(), clusters))).collect();
    let total: u128 = weights.iter().sum::<u128>().max(1);
    let (mut weight, mut steps) = (0u128, 0u64);
    weights
        .iter()
        .map(|&w| {
            weight += w;
            // At most `n`, which is a `usize`.
            let upto = (n * weight / total) as u64;
            let step = upto - steps;
            steps = upto;
            step
        })
        .collect()
}

/// The estimate of a flow in progress made once a tenth of its [`progress_steps`] left at its
/// start is done: the elapsed time scaled by those steps over the steps done
/// (`vis.flow_refined_seconds`).
#[derive(Debug)]
pub struct Refine {
    /// Per position of the processing order, the steps of the positions before it (`n + 1`
    /// entries).
    done_before: Vec<u64>,
    /// Position the run started from (after a resume).
    start_pos: usize,
    start: Instant,
    /// The estimate (elapsed plus left) made at the first boundary past a tenth of the steps.
    pub at_tenth: Option<f64>,
}

impl Refine {
    /// For the processing order's `steps` ([`progress_steps`]), starting at `start_pos`.
    pub fn new(steps: &[u64], start_pos: usize) -> Self {
        let mut done_before = vec![0u64];
        for &s in steps {
            done_before.push(done_before.last().copied().unwrap_or(0).saturating_add(s));
        }
        Self { done_before, start_pos, start: Instant::now(), at_tenth: None }
    }

    /// The steps before position `p`.
    pub fn steps_before(&self, p: usize) -> u64 {
        self.done_before.get(p).copied().unwrap_or(0)
    }

    /// The positions before `done` are finished: the first time that is a tenth of the steps
    /// left at the start, [`Refine::at_tenth`] is set.
    pub fn boundary(&mut self, done: usize) {
        let total =
            self.steps_before(self.done_before.len() - 1).saturating_sub(self.steps_before(self.start_pos));
        let finished = self.steps_before(done).saturating_sub(self.steps_before(self.start_pos));
        if self.at_tenth.is_some()
            || finished == 0
            || finished >= total
            || finished.saturating_mul(10) < total
        {
            return;
        }
        self.at_tenth = Some(self.start.elapsed().as_secs_f64() * total as f64 / finished as f64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_job::rng::SplitMix64;

    fn flow_work(mightsee: impl IntoIterator<Item = u64>, portals: usize) -> u64 {
        mightsee.into_iter().map(|m| chains(m, portals, usize::MAX)).fold(0, u64::saturating_add)
    }

    /// The estimate is monotone in the work it predicts: raising a portal's `mightsee`, or
    /// weighing one more portal, never lowers it (random inputs).
    #[test]
    fn more_portals_or_mightsee_never_lower_the_estimate() {
        let mut rng = SplitMix64::new(46);
        for _ in 0..500 {
            let len = (rng.next_u64() % 50) as usize;
            let n = len + 1 + (rng.next_u64() % 100_000) as usize;
            let mut counts: Vec<u64> = (0..len).map(|_| rng.next_u64() % n as u64).collect();
            let before = flow_work(counts.iter().copied(), n);
            let seconds = flow_seconds(before, 5.0, 0.5, 1_000);
            if len > 0 {
                let i = (rng.next_u64() % len as u64) as usize;
                counts[i] += rng.next_u64() % 1_000;
                let raised = flow_work(counts.iter().copied(), n);
                assert!(raised >= before, "{raised} < {before}");
                assert!(flow_seconds(raised, 5.0, 0.5, 1_000) >= seconds);
            }
            counts.push(rng.next_u64() % n as u64);
            let added = flow_work(counts.iter().copied(), n);
            assert!(added > before, "a portal adds at least 1");
            assert!(flow_seconds(added, 5.0, 0.5, 1_000) > seconds);
        }
        assert_eq!(flow_work([u64::MAX, u64::MAX], 1), u64::MAX, "no overflow");
        assert_eq!(flow_seconds(5, 5.0, 1.0, 0), 0.0, "nothing to flow without base tests");
    }

    #[test]
    fn scanning_more_targets_never_lowers_the_estimate() {
        assert_eq!(scan_factor(0.0), 1.0);
        assert_eq!(scan_factor(-3.0), 1.0, "no discount");
        assert!((scan_factor(SCAN_TARGETS_UNIT) - 2.0).abs() < 1e-12);
        let mut last = 0.0;
        for t in (0..5_000).map(f64::from) {
            let seconds = flow_seconds(1_000, t, 0.5, 1_000);
            assert!(seconds >= last, "{t}: {seconds} < {last}");
            last = seconds;
        }
        // An unmerged map's few targets move the estimate by under a tenth.
        assert!(flow_seconds(1_000, 11.0, 0.5, 1_000) < 1.09 * flow_seconds(1_000, 0.0, 0.5, 1_000));
    }

    #[test]
    fn chains_grow_faster_than_mightsee_and_slower_on_longer_rows_up_to_the_clusters() {
        let many = usize::MAX;
        assert!(chains(2_000, 5_000, many) > 2 * chains(1_000, 5_000, many));
        assert!(chains(1_000, 10_000, many) < chains(1_000, 5_000, many));
        assert_eq!(chains(0, 0, 0), 1);
        // A merged map: every portal might see every other, but there are 73 clusters.
        assert!(chains(87_000, 87_000, many) > 1_000_000);
        // 1,192 targets a frame: the cap is a fifth of the clusters.
        assert_eq!(chains(87_000, 87_000, 73), 15);
        // About 5.5 targets a frame (an unmerged map): the cap is the clusters.
        assert_eq!(chains(5_500, 5_500, 1_000), 1_001);
        // Clusters of more portals cap lower: 11 targets a frame, as in the 1,000-brush room.
        let room = chains(48_766, 48_766, 4_395);
        assert!((3_500..4_395).contains(&room), "{room}");
        assert!((0..100_000).step_by(997).all(|m| chains(m, 87_000, 73) <= chains(m + 1, 87_000, 73)));
    }

    #[test]
    fn progress_weight_follows_the_chains_flattened_and_stops_at_their_cap() {
        let many = usize::MAX;
        assert_eq!(progress_weight(0, 5_000, many), PROGRESS_UNIT as u64, "one chain");
        let mut last = 0;
        for m in (0..200_000).step_by(7) {
            let w = progress_weight(m, 200_000, many);
            assert!(w >= last, "{m}: {w} < {last}");
            last = w;
        }
        let (big, small) = (progress_weight(9_999, 10_000, many), progress_weight(999, 10_000, many));
        let (cb, cs) = (chains(9_999, 10_000, many), chains(999, 10_000, many));
        assert!(big < small * (cb / cs), "flatter than the chains");
        assert!(big > 10 * small, "steeper than a step per portal");
        // Merged into 73 clusters, every portal that might see most of the map weighs alike.
        assert_eq!(progress_weight(40_000, 87_000, 73), progress_weight(87_000, 87_000, 73));
        assert!(progress_weight(u64::MAX, 1, many) > 0, "no overflow");
    }

    #[test]
    fn progress_steps_add_up_to_the_portals_and_follow_the_weights() {
        let mut rng = SplitMix64::new(25);
        for (len, clusters) in
            [(0usize, 1usize), (1, 1), (2, 5), (7, 3), (100, 40), (1_000, 50), (1_000, 900)]
        {
            let mut counts: Vec<u64> = (0..len).map(|_| rng.next_u64() % (len as u64 + 1)).collect();
            counts.sort_unstable();
            let steps = progress_steps(&counts, clusters);
            assert_eq!(steps.len(), len);
            assert_eq!(steps.iter().sum::<u64>(), len as u64, "{len} portals");
            // Each prefix is within a step of its share of the weight.
            let weight = |m: u64| progress_weight(m, len, clusters) as f64;
            let total: f64 = counts.iter().map(|&m| weight(m)).sum();
            let (mut w, mut s) = (0.0, 0u64);
            for (&m, &step) in counts.iter().zip(&steps) {
                w += weight(m);
                s += step;
                assert!((s as f64 - len as f64 * w / total).abs() <= 1.0 + 1e-9, "{s} at {w} of {total}");
            }
        }
        // Cheap portals first: the first half of the portals is less than half of the steps.
        let counts: Vec<u64> = (0..1_000).collect();
        let steps = progress_steps(&counts, 900);
        assert!(steps[..500].iter().sum::<u64>() < 400);
        assert_eq!(progress_steps(&[u64::MAX, u64::MAX], usize::MAX), [1, 1], "no overflow");
    }

    #[test]
    fn refinement_is_made_once_a_tenth_of_the_steps_left_is_done() {
        // Nine cheap portals, then one nine times dearer: half the steps are the last portal's.
        let steps = [1, 1, 1, 1, 1, 1, 1, 1, 1, 9];
        let mut r = Refine::new(&steps, 0);
        r.boundary(0);
        r.boundary(1);
        assert!(r.at_tenth.is_none(), "one step of 18 is not a tenth");
        r.boundary(2);
        let first = r.at_tenth.expect("two steps of 18 are");
        r.boundary(9);
        assert_eq!(r.at_tenth, Some(first), "made once");
        // Resumed after eight portals: the tenth is of the ten steps left.
        let mut resumed = Refine::new(&steps, 8);
        resumed.boundary(9);
        assert!(resumed.at_tenth.is_some(), "one step of ten left");
        let mut done = Refine::new(&steps, 0);
        done.boundary(10);
        assert!(done.at_tenth.is_none(), "done at the first boundary: nothing left to estimate");
        assert_eq!(done.steps_before(10), 18);
    }
}
