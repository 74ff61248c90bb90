//! How long the flow will take: predicted once base vis is done ([`flow_seconds`]), and refined
//! at batch boundaries as portals finish ([`Refine`]). Estimates go to progress notes and
//! [`VisStats`](super::VisStats) only; nothing here changes the PVS.
//!
//! # The model
//! The flow's cost is its chains (recursive calls, one portal deeper each): a chain costs about
//! the same anywhere (1.1–2.0 µs of CPU per flow on the shared and the heavy maps alike on an AMD
//! EPYC host, 2026-11-29), while the chains per portal vary by four orders of magnitude. A portal that might
//! see `m` of `n` one-way portals visits about [`CHAINS_SCALE`] × `m`^2.2 / `n`^0.6 chains
//! ([`chains`]): on open maps the late portals find few branches cut by seeds or narrowed rows,
//! so chains grow faster than `m`, and longer rows narrow more. But never more than the clusters
//! there are: a chain goes on only while something beyond it is new, and the open maps' flows
//! made 0.5–0.8 chains per portal per cluster. Without that cap, a map merged into a few dozen
//! clusters (`--coarsen`) was predicted millions of chains per portal, for 4 made. A chain is
//! priced at [`CHAIN_PER_BASE_TEST`] base vis tests of this very run, so on this machine and
//! thread count. Merged clusters break the model both ways: on the 10,000-brush room merged to
//! 73 clusters a chain costs about 136 µs (a frame walks its cluster's thousands of portals) and
//! the cap still counts 18 times the chains made, so the first estimate is about 3× short there.
//! The refinement tracks progress by a flatter weight ([`progress_weight`]).
//! How far off the first estimate is, and why no richer model or early sample did better (a
//! flow's chains depend on how far earlier flows narrowed its row): `docs/benchmarks.md`,
//! 2026-11-29, sessions 21 and 22.

use std::time::Instant;

use sightline_job::progress::format_seconds;

/// Chains per portal per `m^2.2 / n^0.6` (see [`chains`]): fitted over the shared maps and the
/// heavy set whose flows visited 50,000 chains or more (28 maps, 2 threads, 2026-11-29), on which
/// real / predicted chains was 0.49–2.05.
pub const CHAINS_SCALE: f64 = 0.0163;

/// Wall time of a chain in wall time of a base vis test: the geometric mean over the same maps
/// (their own ratios 0.3–2.0 times it).
pub const CHAIN_PER_BASE_TEST: f64 = 160.0;

/// The predicted chains of a portal that might see `mightsee` of `portals` one-way portals, in a
/// map of `clusters` clusters: the model's count capped at `clusters`, plus 1 so every portal
/// counts. Monotone in `mightsee`.
pub fn chains(mightsee: u64, portals: usize, clusters: usize) -> u64 {
    let m = mightsee as f64;
    let predicted = CHAINS_SCALE * m.powf(2.2) / (portals.max(1) as f64).powf(0.6);
    // `as` saturates: a huge prediction stays finite.
    (predicted.ceil() as u64).min(clusters as u64).saturating_add(1)
}

/// Seconds predicted for `work` chains (a sum of [`chains`]) by a run whose base vis made
/// `base_tests` tests in `base_seconds` (0 when base vis tested nothing: then there is nothing to
/// flow). Never lower for more work.
pub fn flow_seconds(work: u64, base_seconds: f64, base_tests: u64) -> f64 {
    if base_tests == 0 {
        return 0.0;
    }
    CHAIN_PER_BASE_TEST * base_seconds / base_tests as f64 * work as f64
}

/// A portal's share of the flow's progress, for [`Refine`]: `1 + mightsee`. Within one map chains
/// grow with about `m` (fitted slopes 0.4–1.2 on the same maps), more slowly than across maps:
/// weighed by their predicted [`chains`], the cheap first tenth made the estimate refined there
/// 1.4–5× pessimistic; by `m`, 0.4–2.4 of the truth.
pub fn progress_weight(mightsee: u64) -> u64 {
    mightsee.saturating_add(1)
}

/// First estimates at or above this many seconds are said (a progress note), with a refined one
/// at every further tenth of the flow's progress ([`progress_weight`]).
pub const SAY_SECONDS: f64 = 10.0;

/// The refined estimate of a flow in progress: elapsed time scaled by the progress left over the
/// progress done ([`progress_weight`]), so the cheap portals processed first do not make the rest
/// look short.
#[derive(Debug)]
pub struct Refine {
    /// Per position of the processing order, the progress weight of the positions before it
    /// (`n + 1` entries).
    done_before: Vec<u64>,
    /// Position the run started from (after a resume).
    start_pos: usize,
    start: Instant,
    /// Tenths of the progress already said.
    said: u64,
    /// Say anything at all (the first estimate was long).
    say: bool,
    /// The estimate (elapsed plus left) made at the first boundary past a tenth of the progress.
    pub at_tenth: Option<f64>,
}

impl Refine {
    /// For the processing order's `weights` (one per position), starting at `start_pos`; `say`
    /// when the first estimate is worth saying.
    pub fn new(weights: impl IntoIterator<Item = u64>, start_pos: usize, say: bool) -> Self {
        let mut done_before = vec![0u64];
        for w in weights {
            done_before.push(done_before.last().copied().unwrap_or(0).saturating_add(w));
        }
        Self { done_before, start_pos, start: Instant::now(), said: 0, say, at_tenth: None }
    }

    /// The positions before `done` are finished: the line to say, if a new tenth of the
    /// progress was reached.
    pub fn boundary(&mut self, done: usize) -> Option<String> {
        let at = |p: usize| self.done_before.get(p).copied().unwrap_or(0);
        let total = at(self.done_before.len() - 1).saturating_sub(at(self.start_pos));
        let finished = at(done).saturating_sub(at(self.start_pos));
        if total == 0 || finished == 0 || finished >= total {
            return None;
        }
        let tenth = finished.saturating_mul(10) / total;
        if tenth <= self.said {
            return None;
        }
        self.said = tenth;
        let elapsed = self.start.elapsed().as_secs_f64();
        let left = elapsed * (total - finished) as f64 / finished as f64;
        self.at_tenth.get_or_insert(elapsed + left);
        self.say.then(|| {
            format!(
                "vis flow: {}% of the flow done in {}, about {} left",
                tenth * 10,
                format_seconds(elapsed),
                format_seconds(left)
            )
        })
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
            let seconds = flow_seconds(before, 0.5, 1_000);
            if len > 0 {
                let i = (rng.next_u64() % len as u64) as usize;
                counts[i] += rng.next_u64() % 1_000;
                let raised = flow_work(counts.iter().copied(), n);
                assert!(raised >= before, "{raised} < {before}");
                assert!(flow_seconds(raised, 0.5, 1_000) >= seconds);
            }
            counts.push(rng.next_u64() % n as u64);
            let added = flow_work(counts.iter().copied(), n);
            assert!(added > before, "a portal adds at least 1");
            assert!(flow_seconds(added, 0.5, 1_000) > seconds);
        }
        assert_eq!(flow_work([u64::MAX, u64::MAX], 1), u64::MAX, "no overflow");
        assert_eq!(flow_seconds(5, 1.0, 0), 0.0, "nothing to flow without base tests");
    }

    #[test]
    fn chains_grow_faster_than_mightsee_and_slower_on_longer_rows_up_to_the_clusters() {
        let many = usize::MAX;
        assert!(chains(2_000, 5_000, many) > 2 * chains(1_000, 5_000, many));
        assert!(chains(1_000, 10_000, many) < chains(1_000, 5_000, many));
        assert_eq!(chains(0, 0, 0), 1);
        // A merged map: every portal might see every other, but there are 73 clusters.
        assert!(chains(87_000, 87_000, many) > 1_000_000);
        assert_eq!(chains(87_000, 87_000, 73), 74);
        assert!((0..100_000).step_by(997).all(|m| chains(m, 87_000, 73) <= chains(m + 1, 87_000, 73)));
    }

    #[test]
    fn refinement_says_each_tenth_once_by_progress_weight() {
        // Nine cheap portals, then one nine times dearer: half the work is the last portal.
        let mut r = Refine::new([1, 1, 1, 1, 1, 1, 1, 1, 1, 9], 0, true);
        assert!(r.boundary(0).is_none());
        assert!(r.boundary(1).is_none(), "a portal of 18 units is not a tenth");
        assert!(r.at_tenth.is_none());
        assert!(r.boundary(2).is_some_and(|l| l.starts_with("vis flow: 10% of the flow done")));
        assert!(r.boundary(2).is_none(), "said once");
        assert!(r.at_tenth.is_some());
        assert!(
            r.boundary(9).is_some_and(|l| l.starts_with("vis flow: 50%")),
            "nine of ten portals are half"
        );
        assert!(r.boundary(10).is_none(), "done: nothing left to estimate");
        let mut quiet = Refine::new([1, 1], 1, false);
        assert!(quiet.boundary(2).is_none());
        assert!(Refine::new([5, 5], 0, false).boundary(1).is_none(), "quiet, but measured");
    }
}
