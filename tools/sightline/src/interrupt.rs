//! Ctrl-C (SIGINT) and SIGTERM (what `kill`, a batch scheduler or a container runtime sends): the
//! first asks the running work to stop at its next safe point (vis saves its state there, compile
//! writes nothing), a second ends the process at once (exit 130 for SIGINT, 143 for SIGTERM).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// What to tell the user when vis stopped on request after `done` of `total` flow portals, with or
/// without a state file to resume from. A stop by Ctrl-C is announced first ([`announce_stop`]),
/// if no progress report did: the signal may land after a batch's last report and before vis
/// checks the flag at its end.
pub(crate) fn interrupted(done: usize, total: usize, saved: bool) -> String {
    announce_stop();
    if saved {
        format!("stopped after {done} of {total} portals; run again with the same --state to resume")
    } else {
        format!(
            "stopped after {done} of {total} portals; nothing was saved (give --state FILE to make a run resumable)"
        )
    }
}

/// The flag Ctrl-C sets, once a vis options builder asked for it ([`ctrl_c_flag`]).
static CTRL_C: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// The stop request every long command hands its library: Ctrl-C cancels it ([`ctrl_c_flag`]).
pub(crate) fn cancel() -> sightline_job::cancel::Cancel {
    sightline_job::cancel::Cancel::from_flag(ctrl_c_flag())
}

/// A flag set by Ctrl-C or SIGTERM, so the work stops at its next safe point (vis at the next
/// batch boundary, saving its state). A second signal, once the flag is set, ends the process at
/// once (exit 128 + the signal's number: 130, 143). The handler only sets the flag (no thread
/// waits for the signal); progress reports say that the stop is under way ([`announce_stop`]). If
/// a handler cannot be installed, that signal keeps its default effect.
pub(crate) fn ctrl_c_flag() -> Arc<AtomicBool> {
    CTRL_C
        .get_or_init(|| {
            let flag = Arc::new(AtomicBool::new(false));
            use signal_hook::consts::{SIGINT, SIGTERM};
            for signal in [SIGINT, SIGTERM] {
                // Handlers run in the order registered: the exit looks at the flag before it is set.
                if signal_hook::flag::register_conditional_shutdown(signal, 128 + signal, flag.clone())
                    .is_ok()
                {
                    let _ = signal_hook::flag::register(signal, flag.clone());
                }
            }
            flag
        })
        .clone()
}

/// Says once on stderr, after Ctrl-C has set the flag, that the run is stopping. Every progress
/// report calls it (a signal handler cannot print).
pub(crate) fn announce_stop() {
    static SAID: AtomicBool = AtomicBool::new(false);
    if CTRL_C.get().is_some_and(|f| f.load(Ordering::Relaxed)) && !SAID.swap(true, Ordering::Relaxed) {
        eprintln!("\ninterrupt: stopping at the next batch of work (Ctrl-C or SIGTERM again to quit now)");
    }
}
