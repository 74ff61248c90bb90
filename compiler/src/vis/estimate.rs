//! How long the flow will take: predicted once base vis is done ([`flow_seconds`]), and refined
//! at batch boundaries as portals finish ([`Refine`]). Estimates go to progress notes and
//! [`VisStats`](super::VisStats) only; nothing here changes the PVS.
//!
//! # The model
//! A portal's flow visits about `√m` chains (its [`weight`]), `m` its `mightsee` count: later
//! portals (in increasing `mightsee` order) find their rows narrowed and their clusters seeded by
//! earlier flows, so chains per portal grow with about the square root of `m`, not with `m` or
//! faster (fitted slopes of log chains on log `m` per portal: 0.2–0.6 on E1M1, DM2, the generated
//! rooms and pillar rooms, below 0 on tiny brushes). A chain's row operations grow with the
//! rows' length, so a chain costs about `√n` more on `n` one-way portals (2 µs of CPU on DM1,
//! 16 on 10,000 tiny brushes), while a base vis test costs the same on any input. The flow's
//! seconds are [`FLOW_PER_BASE_TEST`] × √n × (base vis seconds per base test, measured on this
//! very run, so on this machine and thread count) × the weights' sum. Measured in
//! `docs/benchmarks.md` (2026-11-29).

use std::time::Instant;

use sightline_job::progress::format_seconds;

/// Flow seconds per unit of [`weight`] and per `√n` (`n` one-way portals), in base vis seconds
/// per base test: the geometric mean (6.1) over the shared and generated maps whose flow took
/// half a second or more, whose own ratios were 0.68–1.64 times it (2 threads, 2026-11-29).
pub const FLOW_PER_BASE_TEST: f64 = 6.0;

/// The predicted flow cost of a portal that might see `mightsee` portals: `1 + ⌊√mightsee⌋`
/// (at least one, so every portal counts). Monotone in `mightsee`.
pub fn weight(mightsee: u64) -> u64 {
    1 + mightsee.isqrt()
}

/// The predicted flow work of portals with these `mightsee` counts: the sum of their
/// [`weight`]s. Never lower for more portals or larger counts.
pub fn flow_work(mightsee: impl IntoIterator<Item = u64>) -> u64 {
    mightsee.into_iter().map(weight).fold(0, u64::saturating_add)
}

/// Seconds predicted for `work` (a [`flow_work`]) on `portals` one-way portals, for a run whose
/// base vis made `base_tests` tests in `base_seconds` (0 when base vis tested nothing: then there
/// is nothing to flow). Never lower for more work or more portals.
pub fn flow_seconds(work: u64, portals: usize, base_seconds: f64, base_tests: u64) -> f64 {
    if base_tests == 0 {
        return 0.0;
    }
    FLOW_PER_BASE_TEST * (portals as f64).sqrt() * base_seconds / base_tests as f64 * work as f64
}

/// First estimates at or above this many seconds are said (a progress note), with a refined one
/// at every further tenth of the predicted work.
pub const SAY_SECONDS: f64 = 10.0;

/// The refined estimate of a flow in progress: elapsed time scaled by the predicted work left
/// over the predicted work done (so the cheap portals processed first do not make the rest look
/// short).
#[derive(Debug)]
pub struct Refine {
    /// Per position of the processing order, the predicted work of the positions before it
    /// (`n + 1` entries).
    done_before: Vec<u64>,
    /// Position the run started from (after a resume).
    start_pos: usize,
    start: Instant,
    /// Tenths of the predicted work already said.
    said: u64,
    /// Say anything at all (the first estimate was long).
    say: bool,
    /// The estimate (elapsed plus left) made at the first boundary past a tenth of the work.
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

    /// The positions before `done` are finished: the line to say, if a new tenth of the predicted
    /// work was reached.
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
                "vis flow: {}% of the predicted work done in {}, about {} left",
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

    /// The estimate is monotone in the work it predicts: adding a portal, or raising a
    /// portal's `mightsee`, never lowers it (random inputs).
    #[test]
    fn more_portals_or_mightsee_never_lower_the_estimate() {
        let mut rng = SplitMix64::new(46);
        for _ in 0..500 {
            let len = (rng.next_u64() % 50) as usize;
            let mut counts: Vec<u64> = (0..len).map(|_| rng.next_u64() % 100_000).collect();
            let before = flow_work(counts.iter().copied());
            let seconds = flow_seconds(before, len, 0.5, 1_000);
            if len > 0 {
                let i = (rng.next_u64() % len as u64) as usize;
                counts[i] += rng.next_u64() % 1_000;
                let raised = flow_work(counts.iter().copied());
                assert!(raised >= before, "{raised} < {before}");
                assert!(flow_seconds(raised, len, 0.5, 1_000) >= seconds);
            }
            counts.push(rng.next_u64() % 100_000);
            let added = flow_work(counts.iter().copied());
            assert!(added > before, "a portal adds at least 1");
            assert!(flow_seconds(added, len + 1, 0.5, 1_000) > seconds);
        }
        assert_eq!(flow_work([u64::MAX, u64::MAX]), (1 + u64::MAX.isqrt()) * 2, "no overflow");
    }

    #[test]
    fn refinement_says_each_tenth_once_by_predicted_work() {
        // Nine cheap portals, then one nine times dearer: half the work is the last portal.
        let mut r = Refine::new([1, 1, 1, 1, 1, 1, 1, 1, 1, 9], 0, true);
        assert!(r.boundary(0).is_none());
        assert!(r.boundary(1).is_none(), "a portal of 18 units is not a tenth");
        assert!(r.at_tenth.is_none());
        assert!(r.boundary(2).is_some_and(|l| l.starts_with("vis flow: 10% of the predicted work")));
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
