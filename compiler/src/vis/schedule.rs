//! The flow's batch scheduler: every portal flowed in deterministic batches, on the run's
//! threads, with checkpoints at batch boundaries.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, PoisonError, RwLock};
use std::time::{Duration, Instant};

use sightline_formats::hash::{FNV_OFFSET, fnv1a};
use sightline_formats::prt::PortalFile;
use sightline_job::progress::{Phase, Progress, phase};

use std::panic::AssertUnwindSafe;

use super::budget::flow_batch;
use super::error::{VisError, panic_error};
use super::options::VisOptions;
use super::stats::VisStats;
use super::{estimate, flow, graph, parallel, plan, seeds, state, symmetry};

/// Hash of the input and of what changes flow rows: the options and the run's `batch` size
/// (with [`VisOptions::waves`], the wave count and the whole batch size too: waves of more than
/// 255 portals would otherwise hash alike).
pub(super) fn input_hash(prt: &PortalFile, opts: &VisOptions, batch: usize) -> u64 {
    let text = sightline_formats::prt::write(prt);
    let h = fnv1a(text.as_bytes(), FNV_OFFSET);
    let short = u8::try_from(batch).unwrap_or(u8::MAX);
    let h = fnv1a(&[opts.level, short, u8::from(opts.seeds)], h);
    match opts.waves {
        Some(w) => fnv1a(&[u64::from(w).to_le_bytes(), (batch as u64).to_le_bytes()].concat(), h),
        None => h,
    }
}

/// Portals per batch of a run of `prt` with `opts` over `one_way` one-way portals (its graph's):
/// [`flow_batch`], or with [`VisOptions::waves`] a wave ([`plan::wave_size`]).
fn batch_size(prt: &PortalFile, opts: &VisOptions, one_way: impl FnOnce() -> usize) -> usize {
    opts.waves.map_or_else(|| flow_batch(prt, opts), |w| plan::wave_size(one_way(), w))
}

/// The hash a state file of a run of `prt` with `opts` carries ([`input_hash`] with the run's
/// batch size).
pub(super) fn state_hash(prt: &PortalFile, opts: &VisOptions) -> u64 {
    input_hash(prt, opts, batch_size(prt, opts, || graph::Graph::new(prt).portals.len()))
}

/// Flow every portal in deterministic batches; returns the final portal rows, or `None` when
/// the flow made more than `cap` chains by a batch boundary before its end (the chains folded at
/// each boundary are the same for any thread count, so so is where it stops).
#[allow(clippy::too_many_arguments)]
pub(super) fn flow_all(
    prt: &PortalFile,
    g: &graph::Graph,
    might: Vec<u64>,
    words: usize,
    opts: &VisOptions,
    progress: &dyn Progress,
    stats: &mut VisStats,
    cap: Option<u64>,
) -> Result<Option<Vec<u64>>, VisError> {
    let n = g.portals.len();
    let order = plan::processing_order(&might, words, n);
    // The flow narrows the `mightsee` rows in place.
    let mut test = might;
    symmetry::tighten_all(&mut test, words, n);
    // Each position's row count before the flow narrows it further: the estimate's input.
    let counts: Vec<u64> =
        order.iter().map(|&p| sightline_formats::bits::count(&test[p * words..(p + 1) * words])).collect();
    let nc = g.num_clusters();
    let mut seeds = seeds::Seeds::new(n, nc);
    // A shard plan's waves are batches too ([`plan::wave_size`]).
    let batch = batch_size(prt, opts, || n);
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
    // A resumed run already over the cap was flowing uncapped (a run stops at the first boundary
    // over it, before any checkpoint there): it goes on so.
    let cap = cap.filter(|&cap| stats.chains <= cap);
    // The estimate, for the portals left.
    stats.flow_estimate_work =
        counts[done..].iter().map(|&m| estimate::chains(m, n, nc)).fold(0, |a, w| a.saturating_add(w));
    stats.flow_estimate_targets = estimate::targets_per_frame(g);
    stats.flow_estimate_seconds = estimate::flow_seconds(
        stats.flow_estimate_work,
        stats.flow_estimate_targets,
        stats.base_seconds,
        stats.base_tests,
    );
    if stats.flow_estimate_seconds >= estimate::SAY_SECONDS {
        progress.note(&format!(
            "vis flow: estimated {} for {} portals (from base vis's speed on this run)",
            sightline_job::progress::format_seconds(stats.flow_estimate_seconds),
            n - done
        ));
    }
    // The phase counts steps by each portal's expected cost, so the time left it shows is the
    // refined estimate.
    let steps = estimate::progress_steps(&counts, nc);
    let refine = estimate::Refine::new(&steps, done);
    let flow_phase = phase(progress, "vis flow", n as u64);
    if done > 0 {
        flow_phase.advance(refine.steps_before(done));
    }
    let run = Run { g, order: &order, steps: &steps, words, n, batch, opts, cap, progress: &flow_phase };
    let Some(test) = run.batches(Rows { test, seeds, quiet }, done, log, refine, stats)? else {
        return Ok(None);
    };
    if let Some(path) = &opts.state {
        // The run is complete: the checkpoint has served its purpose.
        let _ = std::fs::remove_file(path);
    }
    Ok(Some(test))
}

/// What flows read and batch boundaries write.
struct Rows {
    /// Per portal its final row once its batch is folded, else its `mightsee`.
    test: Vec<u64>,
    /// Per cluster, the clusters known visible from it by a certified line ([`certify`](super::certify)).
    seeds: seeds::Seeds,
    /// Flows folded in a row whose beam culls dropped nothing ([`flow::quiet_after`]).
    quiet: usize,
}

/// What the flow workers share for one run of [`flow_all`].
struct Run<'a> {
    g: &'a graph::Graph,
    order: &'a [usize],
    /// Per position of `order`, its steps of the progress phase ([`estimate::progress_steps`]).
    steps: &'a [u64],
    words: usize,
    n: usize,
    /// Portals per batch ([`flow_batch`]).
    batch: usize,
    opts: &'a VisOptions,
    /// Stop once more chains than this are folded ([`flow_all`]).
    cap: Option<u64>,
    progress: &'a Phase<'a>,
}

/// The batch in flight and what its last finisher needs.
struct Cursor {
    /// Next position in `order` to hand out.
    next: AtomicUsize,
    /// Portals of the open batch finished.
    finished: AtomicUsize,
    /// Positions before this one may start (the end of the open batch).
    ready: Lone<AtomicUsize>,
    /// Chains each flow of the open batch may make before it unwinds ([`flow::Flow::chain_limit`]):
    /// the run's cap less the chains folded before the batch. A flow past it takes the batch
    /// over the cap, so the boundary gives the run up.
    budget: AtomicU64,
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
    /// The run stopped over its chain cap.
    capped: bool,
    /// The flow's estimate, refined at each boundary.
    refine: estimate::Refine,
}

impl Run<'_> {
    /// Positions `done..n` of `order` in batches of `self.batch` (counted from `done`): a
    /// portal starts once every earlier batch is folded into `test`, and reads `test` only then.
    /// A worker runs on each of the run's threads, takes portals from a shared cursor and waits
    /// for the next batch by spinning briefly, then sleeping ([`Cursor::wait_for`]). A worker
    /// that panics records the error and halts the cursor, so the others stop waiting for a
    /// batch that cannot close. Returns the final rows, `None` over the chain cap, or why the run
    /// stopped.
    fn batches(
        &self,
        rows: Rows,
        done: usize,
        log: Option<state::State>,
        refine: estimate::Refine,
        stats: &mut VisStats,
    ) -> Result<Option<Vec<u64>>, VisError> {
        let test = RwLock::new(rows);
        let slots: Vec<Lone<Mutex<Slot>>> =
            (0..self.batch).map(|_| Lone(Mutex::new(Slot::default()))).collect();
        let cursor = Cursor {
            next: AtomicUsize::new(done),
            finished: AtomicUsize::new(0),
            ready: Lone(AtomicUsize::new((done + self.batch).min(self.n))),
            budget: AtomicU64::new(self.budget(stats.chains)),
            halt: Lone(AtomicBool::new(false)),
            gate: Mutex::new(()),
            wake: Condvar::new(),
            sleepers: AtomicUsize::new(0),
        };
        let boundary = Mutex::new(Boundary {
            stats,
            log,
            last_save: Instant::now(),
            outcome: None,
            capped: false,
            refine,
        });
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
            None if boundary.capped => Ok(None),
            None => Ok(Some(test.into_inner().unwrap_or_else(PoisonError::into_inner).test)),
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
        let mut f =
            flow::Flow::new(self.g.portals.len(), self.g.num_clusters(), self.opts.level, self.opts.seeds);
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
            f.chain_limit = cursor.budget.load(Ordering::Acquire);
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
            self.progress.advance(self.steps[pos]);
            if finished == batch_end - batch_start {
                rows = None;
                self.close_batch(batch_start, batch_end, test, slots, cursor, boundary);
            }
        }
    }

    /// What a flow may make ([`Cursor::budget`]) once `chains` are folded.
    fn budget(&self, chains: u64) -> u64 {
        self.cap.map_or(u64::MAX, |cap| cap.saturating_sub(chains))
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
        b.refine.boundary(done);
        b.stats.flow_refined_seconds = b.refine.at_tenth;
        if done < n && self.cap.is_some_and(|cap| b.stats.chains > cap) {
            b.capped = true;
            cursor.stop();
            return;
        }
        let cancelled = self.opts.cancel.is_cancelled();
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
        cursor.budget.store(self.budget(b.stats.chains), Ordering::Release);
        cursor.open((done + self.batch).min(n));
    }
}
