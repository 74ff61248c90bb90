//! How a vis run spreads its work: over `threads` threads of its own, the calling thread and
//! `threads - 1` helpers started for the phase (scoped: every helper has ended when the phase
//! returns), or, for a run of one thread, in order on the calling thread.
//!
//! No pool outlives a phase and no thread waits for work between phases: a two-thread run on a
//! small map pays two thread starts per parallel phase, not a pool's start, its hand-over of the
//! run to a pool thread, and its idle workers' spinning between phases and after the run
//! (`docs/benchmarks.md`). A helper that cannot be started leaves its share to the threads that
//! were. A panic on a helper is carried back and resumed on the calling thread, with its message.
//!
//! Every phase gives the same result either way: rows are computed independently of each other,
//! and the flow's batches fix what each portal reads whatever the thread count.

use std::any::Any;
use std::panic::AssertUnwindSafe;
use std::sync::{Mutex, PoisonError};

/// Rows a thread takes from the shared queue at a time in [`each_row`].
const ROWS_PER_TAKE: usize = 8;

/// `f(state, index, row)` for each `size`-word row of `rows` (the last may be shorter), with a
/// `state` from `init` per thread: on `threads` threads when `threads > 1` (rows handed out a
/// few at a time, so that rows of uneven cost spread evenly), else in order on this thread.
pub fn each_row<S, I, F>(threads: usize, rows: &mut [u64], size: usize, init: I, f: F)
where
    I: Fn() -> S + Sync,
    F: Fn(&mut S, usize, &mut [u64]) + Sync,
{
    if threads <= 1 {
        let mut s = init();
        for (i, row) in rows.chunks_mut(size).enumerate() {
            f(&mut s, i, row);
        }
        return;
    }
    let queue = Mutex::new(rows.chunks_mut(size).enumerate());
    on_every_thread(threads, || {
        let mut s = init();
        let mut taken = Vec::with_capacity(ROWS_PER_TAKE);
        loop {
            taken.extend(queue.lock().unwrap_or_else(PoisonError::into_inner).by_ref().take(ROWS_PER_TAKE));
            if taken.is_empty() {
                return;
            }
            for (i, row) in taken.drain(..) {
                f(&mut s, i, row);
            }
        }
    });
}

/// `f()` once on each of `threads` threads (this one and `threads - 1` helpers) when
/// `threads > 1`, else once on this thread; returns when every call has.
pub fn on_every_thread(threads: usize, f: impl Fn() + Sync) {
    let panicked: Mutex<Option<Box<dyn Any + Send>>> = Mutex::new(None);
    let guarded = || {
        if let Err(payload) = std::panic::catch_unwind(AssertUnwindSafe(&f)) {
            panicked.lock().unwrap_or_else(PoisonError::into_inner).get_or_insert(payload);
        }
    };
    std::thread::scope(|scope| {
        for _ in 1..threads {
            // A helper that cannot start leaves its share to the others.
            let _ = std::thread::Builder::new().spawn_scoped(scope, guarded);
        }
        guarded();
    });
    if let Some(payload) = panicked.into_inner().unwrap_or_else(PoisonError::into_inner) {
        std::panic::resume_unwind(payload);
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;

    #[test]
    fn every_row_is_done_once_whatever_the_thread_count() {
        let want: Vec<u64> = (0..1003u64).map(|i| i * 3 + 1).collect();
        for threads in [1, 2, 3, 8] {
            let mut rows = vec![0u64; 1003];
            let inits = AtomicUsize::new(0);
            let init = || inits.fetch_add(1, Ordering::Relaxed);
            each_row(threads, &mut rows, 2, init, |_, i, row| {
                for (k, x) in row.iter_mut().enumerate() {
                    *x += (2 * i + k) as u64 * 3 + 1;
                }
            });
            assert_eq!(rows, want, "{threads} threads");
            assert!((1..=threads).contains(&inits.load(Ordering::Relaxed)), "a state per thread");
        }
    }

    #[test]
    fn a_panic_on_a_helper_reaches_the_caller_with_its_message() {
        let calls = AtomicUsize::new(0);
        let r = std::panic::catch_unwind(AssertUnwindSafe(|| {
            on_every_thread(3, || {
                if calls.fetch_add(1, Ordering::SeqCst) == 1 {
                    panic!("helper failed");
                }
            })
        }));
        assert_eq!(calls.load(Ordering::SeqCst), 3, "every thread ran, the others to the end");
        let payload = r.expect_err("the panic is resumed");
        assert_eq!(payload.downcast_ref::<&str>(), Some(&"helper failed"));
    }
}
