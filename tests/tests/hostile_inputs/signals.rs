//! Ctrl-C (SIGINT) and SIGTERM through the real binary at moments spread over a whole compile
//! (parsing, CSG, tree, portals, outside fill, emit, vis): the run ends promptly, either finished
//! (exit 0, every output written) or stopped (exit 2, saying so, with no output under its final
//! name and no temporary file left); and a `vis --state` run stopped by SIGTERM saves its state,
//! which the next run resumes to the same file an uninterrupted run writes.

use std::fs;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::{file_names, scratch_dir};
use sightline_tests::{shapes, sightline_binary};

/// Longer than any stop takes from the signal to the exit: a run past it is a hang.
const PROMPT: Duration = Duration::from_secs(15);

fn signal(child: &Child, name: &str) {
    let pid = child.id().to_string();
    let ok = Command::new("kill").args([&format!("-{name}"), &pid]).status().expect("run kill").success();
    assert!(ok, "kill -{name} {pid}");
}

/// Waits for `child` at most [`PROMPT`]; its exit code and stderr. A hang is killed and fails.
fn finish(mut child: Child, what: &str) -> (Option<i32>, String) {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            let mut stderr = String::new();
            if let Some(mut e) = child.stderr.take() {
                use std::io::Read;
                let _ = e.read_to_string(&mut stderr);
            }
            return (status.code(), stderr);
        }
        if start.elapsed() > PROMPT {
            let _ = child.kill();
            panic!("{what}: still running {PROMPT:?} after the signal");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn compile(map: &Path, out: &Path, vis: bool) -> Child {
    Command::new(sightline_binary())
        .arg("compile")
        .arg(map)
        .arg("-o")
        .arg(out)
        .args(["--threads", "2"])
        .args(if vis { &[][..] } else { &["--no-vis"][..] })
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run sightline")
}

/// Signals at 12 moments of a compile of `map` (alternately SIGINT and SIGTERM); returns how many
/// runs stopped.
fn stop_at_moments(d: &Path, map: &Path, vis: bool) -> usize {
    // One uninterrupted run sets the time scale.
    let out = d.join("whole.slvl");
    let start = Instant::now();
    let (code, stderr) = finish(compile(map, &out, vis), "uninterrupted compile");
    let whole = start.elapsed();
    assert_eq!(code, Some(0), "{stderr}");
    fs::remove_file(&out).expect("rm");
    fs::remove_file(out.with_extension("prt")).expect("rm");
    let before = file_names(d);
    let mut stopped = 0;
    for i in 0..12u32 {
        // Moments spread over the whole run, denser at the start (parsing and CSG are quick), from
        // 20 ms on: before that the process may not have started its own code (a signal then
        // ends it by the system's default, before it could have written anything).
        let at = Duration::from_millis(20) + whole.mul_f64(f64::from(i * i) / 121.0 * 0.9);
        let sig = if i % 2 == 0 { "INT" } else { "TERM" };
        let out = d.join(format!("run{i}.slvl"));
        let child = compile(map, &out, vis);
        std::thread::sleep(at);
        signal(&child, sig);
        let what = format!("{}: SIG{sig} after {at:?} of {whole:?}", map.display());
        let (code, stderr) = finish(child, &what);
        match code {
            Some(0) => {
                assert!(
                    out.is_file() && out.with_extension("prt").is_file(),
                    "{what}: finished without outputs"
                );
                fs::remove_file(&out).expect("rm");
                fs::remove_file(out.with_extension("prt")).expect("rm");
            }
            Some(2) => {
                stopped += 1;
                assert!(stderr.contains("stopped"), "{what}: {stderr}");
            }
            other => panic!("{what}: exit {other:?}: {stderr}"),
        }
        assert_eq!(file_names(d), before, "{what}: no output and no temporary file");
    }
    stopped
}

#[test]
fn a_compile_stopped_at_any_moment_exits_promptly_and_writes_nothing() {
    let d = scratch_dir("signals-compile");
    // Thousands of brushes without vis: seconds of CSG, tree, portals and outside fill.
    let big = d.join("big.map");
    fs::write(&big, shapes::tiny_brushes_room(4000, 7)).expect("map");
    let stopped = stop_at_moments(&d, &big, false);
    assert!(stopped >= 8, "most signals land during the phases before vis ({stopped} of 12 stopped)");
    // A hundred brushes with vis: seconds of vis.
    let small = d.join("small.map");
    fs::write(&small, shapes::tiny_brushes_room(100, 7)).expect("map");
    let stopped = stop_at_moments(&d, &small, true);
    assert!(stopped >= 8, "most signals land during vis ({stopped} of 12 stopped)");
    fs::remove_dir_all(&d).expect("clean");
}

fn vis(prt: &Path, state: &Path) -> Child {
    Command::new(sightline_binary())
        .arg("vis")
        .arg(prt)
        .arg("--state")
        .arg(state)
        .args(["--threads", "2"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run sightline")
}

#[test]
fn sigterm_during_vis_saves_the_state_and_the_resumed_run_writes_the_same_file() {
    let d = scratch_dir("signals-vis");
    let map = d.join("small.map");
    fs::write(&map, shapes::tiny_brushes_room(100, 7)).expect("map");
    let (code, stderr) = finish(compile(&map, &d.join("small.slvl"), false), "compile");
    assert_eq!(code, Some(0), "{stderr}");
    let (prt, state, out) = (d.join("small.prt"), d.join("small.state"), d.join("small.vis"));
    let start = Instant::now();
    let (code, stderr) = finish(vis(&prt, &state), "uninterrupted vis");
    let whole = start.elapsed();
    assert_eq!(code, Some(0), "{stderr}");
    let expected = fs::read(&out).expect("vis output");
    fs::remove_file(&out).expect("rm");
    let mut resumed = 0;
    for fraction in [0.5, 0.7, 0.85] {
        let child = vis(&prt, &state);
        std::thread::sleep(whole.mul_f64(fraction));
        signal(&child, "TERM");
        let (code, stderr) = finish(child, "vis under SIGTERM");
        if code == Some(0) {
            // Finished before the signal landed: nothing to resume.
            assert_eq!(fs::read(&out).expect("output"), expected);
            fs::remove_file(&out).expect("rm");
            continue;
        }
        assert_eq!(code, Some(2), "{stderr}");
        assert!(stderr.contains("--state"), "says how to resume: {stderr}");
        assert!(!out.exists(), "a stopped vis writes no output");
        if state.exists() {
            resumed += 1;
            let (code, stderr) = finish(vis(&prt, &state), "resumed vis");
            assert_eq!(code, Some(0), "{stderr}");
            assert_eq!(fs::read(&out).expect("output"), expected, "the resumed run writes the same file");
            fs::remove_file(&out).expect("rm");
        }
    }
    assert!(resumed > 0, "at least one SIGTERM saved a state to resume");
    fs::remove_dir_all(&d).expect("clean");
}
