//! How a vis run spreads its work: over the rayon pool [`super::run`] installs it in, or, for a
//! run of one thread, in order on the calling thread with no pool at all (a pool of one still
//! starts a thread, which on a map of a few dozen portals costs more than the vis).
//!
//! Every phase gives the same result either way: rows are computed independently of each other,
//! and the flow's batches fix what each portal reads whatever the thread count.

use rayon::prelude::*;

/// `f(state, index, row)` for each `size`-word row of `rows` (the last may be shorter), with a
/// `state` from `init` per worker: on every thread of the current pool when `threads > 1`, else
/// in order on this thread.
pub fn each_row<S, I, F>(threads: usize, rows: &mut [u64], size: usize, init: I, f: F)
where
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut [u64]) + Sync + Send,
{
    if threads > 1 {
        rows.par_chunks_mut(size).enumerate().for_each_init(init, |s, (i, row)| f(s, i, row));
    } else {
        let mut s = init();
        for (i, row) in rows.chunks_mut(size).enumerate() {
            f(&mut s, i, row);
        }
    }
}

/// `f()` once on every thread of the current pool when `threads > 1`, else once on this thread.
pub fn on_every_thread(threads: usize, f: impl Fn() + Sync) {
    if threads > 1 {
        rayon::broadcast(|_| f());
    } else {
        f();
    }
}
