//! Interrupted runs: output into a closed pipe, Ctrl-C during `validate` and `vis` (the state
//! saved and resumed), damaged vis states.

use std::process::{Command, Output};

use crate::support::{bin, code, compile, copy_prt, maps, run, s, shared_map, stderr, temp_dir};

/// Run `args` with stdout a pipe whose reading end is closed before the command prints: its exit
/// code and stderr (the code it exits with when the reader goes away).
fn run_into_closed_pipe(args: &[&str]) -> (i32, String) {
    use std::process::Stdio;
    let mut child = bin()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the sightline binary runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    (code(&out), stderr(&out))
}

#[test]
fn printing_into_a_closed_pipe_is_not_a_panic() {
    // `sightline … | head -1`: the reader goes away; the command must not panic (exit 101), and
    // exits as it would have with the whole output read.
    let dir = temp_dir("pipe");
    let level = compile(&dir, "two_rooms.map");
    let prt = level.with_extension("prt");
    let map = maps().join("stairs_pillars.map");
    let out = dir.join("again.slvl");
    let commands: Vec<Vec<&str>> = vec![
        vec!["info", "--json", s(&map)],
        vec!["info", s(&level)],
        vec!["validate", s(&level), "--rays", "2000"],
        vec!["validate", s(&level), "--rays", "2000", "--json"],
        vec!["compile", s(&map), "-o", s(&out), "--threads", "2"],
        vec!["vis", s(&prt), "--threads", "2", "--json"],
        vec!["bench", s(&level), "--frames", "20"],
    ];
    for args in commands {
        let want = code(&run(&args));
        for _ in 0..3 {
            let (got, err) = run_into_closed_pipe(&args);
            assert!(!err.contains("panicked"), "{args:?}: {err}");
            assert_eq!(got, want, "{args:?}: the exit code of the full run: {err}");
        }
    }
}

/// A real Ctrl-C part way through a validation far too long to finish: it stops between leaves,
/// says so, and exits 2 with no report.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_validate_promptly() {
    use std::process::Stdio;
    let Some(bsp) = shared_map("ericw/e1m1.vis.bsp") else { return };
    // About an hour of one core: only a stop on request ends it within the bound below.
    let args = ["validate", s(&bsp), "--rays", "5000000000", "--threads", "1", "--json"];
    let child = bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().expect("kill runs").success());
    let start = std::time::Instant::now();
    let o = child.wait_with_output().expect("output");
    assert!(start.elapsed() < std::time::Duration::from_secs(60), "stopped between leaves");
    let err = stderr(&o);
    assert_eq!(code(&o), 2, "interrupted: {err}");
    assert!(err.contains("stopped before the sampling finished"), "{err}");
    assert!(o.stdout.is_empty(), "no report from a stopped run");
}

/// Wait for `cmd` at most two minutes (a hang fails the test instead of stalling it).
fn run_within_two_minutes(cmd: &mut Command) -> Output {
    use std::process::Stdio;
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    let start = std::time::Instant::now();
    while child.try_wait().expect("try_wait").is_none() {
        if start.elapsed() > std::time::Duration::from_secs(120) {
            let _ = child.kill();
            panic!("{cmd:?} hung");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

/// A real Ctrl-C (SIGINT from `kill`) part way through a one-thread vis of a shared map: the run
/// says it is stopping, saves its state and exits 2; the same command then resumes to the file an
/// uninterrupted run writes, byte for byte, and removes the state.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_vis_with_its_state_saved_and_the_rerun_resumes_to_the_same_file() {
    use std::process::Stdio;
    let Some((dir, prt)) = copy_prt("ericw/e1m1_nodetail.prt", "ctrl-c", "e1m1") else { return };
    let vis_file = dir.join("e1m1.vis");
    let state = dir.join("e1m1.state");
    let o = run(&["vis", s(&prt), "--no-progress", "--threads", "1"]);
    assert_eq!(code(&o), 0, "uninterrupted: {}", stderr(&o));
    let whole = std::fs::read(&vis_file).expect("the uninterrupted run's output");
    std::fs::remove_file(&vis_file).expect("remove");
    let args = ["vis", s(&prt), "--no-progress", "--threads", "1", "--state", s(&state)];
    let child = bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    // Well inside the flow, which takes over a second of one core here.
    std::thread::sleep(std::time::Duration::from_millis(250));
    let pid = child.id().to_string();
    let sent = Command::new("kill").args(["-INT", &pid]).status().expect("kill runs");
    assert!(sent.success(), "SIGINT sent");
    let start = std::time::Instant::now();
    let o = child.wait_with_output().expect("output");
    assert!(start.elapsed() < std::time::Duration::from_secs(60), "stopped at the next batch");
    let err = stderr(&o);
    assert_eq!(code(&o), 2, "interrupted: {err}");
    assert!(err.contains("interrupt: stopping at the next batch"), "{err}");
    assert!(err.contains("stopped after") && err.contains("--state to resume"), "{err}");
    assert!(state.is_file(), "the state is saved");
    assert!(!vis_file.exists(), "no output from a stopped run");
    let o = run(&args);
    assert_eq!(code(&o), 0, "resumed: {}", stderr(&o));
    assert_eq!(std::fs::read(&vis_file).expect("the resumed run's output"), whole);
    assert!(!state.exists(), "a finished run removes its state");
    let _ = std::fs::remove_dir_all(&dir);
}

/// FNV-1a 64, the checksum of a vis state's trailer.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

/// Tampered copies of a vis state (`SLVISST6`: bincode with fixed-width little-endian integers —
/// magic, input hash, portals, words, clusters, done, then length-prefixed rows (u64), chains
/// (u64), cull flags (one byte each), added (u32) and pairs (2 × u32) — and an FNV-1a trailer):
/// a flipped byte, and, with the checksum made right, a padding bit set in each finished row's
/// last word, a cull flag that is neither 0 nor 1, and a seed pair out of range.
fn tampered_states(bytes: &[u8]) -> Vec<(String, Vec<u8>)> {
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"));
    let resum = |mut b: Vec<u8>| {
        let n = b.len() - 8;
        let sum = fnv1a(&b[..n]);
        b[n..].copy_from_slice(&sum.to_le_bytes());
        b
    };
    assert_eq!(&bytes[..8], &0x534c_5649_5353_5436u64.to_le_bytes(), "a SLVISST6 state");
    let (portals, words, done) = (u64_at(bytes, 16), u64_at(bytes, 24) as usize, u64_at(bytes, 40) as usize);
    assert!(done > 0 && portals % 64 != 0, "{done} finished portals; {portals} leave padding bits");
    let mut out = Vec::new();
    let mut flipped = bytes.to_vec();
    flipped[bytes.len() / 2] ^= 0x20;
    out.push(("a flipped byte".to_string(), flipped));
    let rows_at = 56;
    for k in 0..done {
        let mut b = bytes.to_vec();
        let last = rows_at + (k * words + words - 1) * 8;
        b[last + 7] |= 0x80;
        out.push((format!("a padding bit in finished row {k}"), resum(b)));
    }
    let chains_len_at = rows_at + done * words * 8;
    let dropped_len_at = chains_len_at + 8 + done * 8;
    let added_len_at = dropped_len_at + 8 + done;
    let pairs_len_at = added_len_at + 8 + done * 4;
    assert_eq!(u64_at(bytes, dropped_len_at), done as u64, "one cull flag per finished portal");
    let mut b = bytes.to_vec();
    b[dropped_len_at + 8] = 2;
    out.push(("a cull flag of 2".to_string(), resum(b)));
    if u64_at(bytes, pairs_len_at) > 0 {
        let mut b = bytes.to_vec();
        b[pairs_len_at + 8..pairs_len_at + 12].copy_from_slice(&u32::MAX.to_le_bytes());
        out.push(("a seed pair out of range".to_string(), resum(b)));
    }
    out
}

#[test]
fn a_damaged_vis_state_is_an_error_naming_the_file_never_a_panic_or_a_hang() {
    let dir = temp_dir("state");
    let map = maps().join("stairs_pillars.map");
    let level = dir.join("sp.slvl");
    let o = run(&["compile", s(&map), "-o", s(&level), "--no-vis"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let prt = level.with_extension("prt");
    // `vis` and `compile` each interrupted after one batch, then resumed from tampered states.
    let state = dir.join("run.state");
    let vis_args = ["vis", s(&prt), "--threads", "2", "--state", s(&state)];
    let compile_args = ["compile", s(&map), "-o", s(&level), "--threads", "2", "--state", s(&state)];
    for args in [&vis_args[..], &compile_args[..]] {
        let _ = std::fs::remove_file(&state);
        let stop = run(&[args, &["--stop-after", "1"]].concat());
        assert_eq!(code(&stop), 2, "interrupted: {}", stderr(&stop));
        let saved = std::fs::read(&state).expect("state saved");
        for (what, bytes) in tampered_states(&saved) {
            std::fs::write(&state, &bytes).expect("write");
            let o = run_within_two_minutes(bin().args(args));
            let err = stderr(&o);
            assert_eq!(code(&o), 2, "{} with {what}: {err}", args[0]);
            assert!(err.contains("run.state") && !err.contains("panicked"), "{} with {what}: {err}", args[0]);
        }
        // The untouched state still resumes.
        std::fs::write(&state, &saved).expect("write");
        let o = run(args);
        assert_eq!(code(&o), 0, "{}: {}", args[0], stderr(&o));
        assert!(!state.exists(), "a finished run removes its state");
    }
}
