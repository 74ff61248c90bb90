//! Memory limits through the real binary: under any address-space limit (`prlimit --as`, as
//! `ulimit -v` sets it) and any `--max-memory`, `compile` either finishes or refuses with a
//! message naming the file, the phase and the limit (exit 2); it never dies of a failed
//! allocation. Each phase's estimate comes before the phase allocates, so the refusals name the
//! phase whose estimate first exceeded the limit.

use std::fs;
use std::path::Path;
use std::process::Command;

use super::scratch_dir;
use sightline_tests::{bundled_maps, shapes, sightline_binary};

/// Runs `sightline compile input` with `extra` arguments, under an address-space limit of `as_mib`
/// when given; the exit code and stderr. Death by a signal (an abort on a failed allocation)
/// fails the test.
fn compile(input: &Path, out: &Path, as_mib: Option<u64>, extra: &[&str]) -> (i32, String) {
    let mut cmd = match as_mib {
        Some(mib) => {
            let mut c = Command::new("prlimit");
            c.arg(format!("--as={}", mib << 20)).arg(sightline_binary());
            c
        }
        None => Command::new(sightline_binary()),
    };
    cmd.arg("compile").arg(input).arg("-o").arg(out).args(extra);
    let run = cmd.output().expect("run sightline under prlimit");
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    let code = run.status.code().unwrap_or_else(|| panic!("{cmd:?} died: {}\n{stderr}", run.status));
    assert!(matches!(code, 0..=2), "{cmd:?}: exit {code}: {stderr}");
    assert!(!stderr.contains("panicked") && !stderr.contains("memory allocation"), "{cmd:?}: {stderr}");
    (code, stderr)
}

/// The phase a refusal names (`csg`, `bsp`, `portals`, `outside`, `emit`, `vis`), from
/// "FILE: PHASE would need ...".
fn refused_phase(stderr: &str, file: &Path) -> Option<String> {
    let name = file.display().to_string();
    let line = stderr.lines().find(|l| l.contains("would need"))?;
    assert!(line.contains(&name), "a refusal names the file: {line}");
    let after = &line[line.find(&name)? + name.len()..];
    after.trim_start_matches(':').split_whitespace().next().map(str::to_string)
}

#[test]
fn under_any_address_space_limit_compile_finishes_or_refuses_cleanly() {
    if Command::new("prlimit").arg("--version").output().is_err() {
        panic!("prlimit (util-linux) is needed for this test");
    }
    let d = scratch_dir("memory-as");
    let big = d.join("tiny1500.map");
    fs::write(&big, shapes::tiny_brushes_room(1500, 3)).expect("map");
    // Thousands of brushes without vis (its matrices would need gigabytes), small inputs with.
    let inputs = [
        (big, &["--no-vis"][..]),
        (bundled_maps().join("stairs_pillars.map"), &[][..]),
        (bundled_maps().join("scene.obj"), &[][..]),
    ];
    let mut phases = std::collections::BTreeSet::new();
    for (input, vis) in &inputs {
        let mut finished = false;
        for threads in [&["--threads", "2"][..], &[][..]] {
            for mib in (100..=900).step_by(100) {
                let args = [threads, vis].concat();
                let (code, stderr) = compile(input, &d.join("out.slvl"), Some(mib), &args);
                if code == 2 {
                    let phase = refused_phase(&stderr, input);
                    let threads_refused = stderr.contains("worker threads");
                    assert!(
                        phase.is_some() || threads_refused,
                        "{}: AS {mib} MiB: {stderr}",
                        input.display()
                    );
                    phases.extend(phase);
                } else {
                    finished = true;
                }
            }
        }
        assert!(finished, "{}: finishes under a limit of 900 MiB", input.display());
    }
    assert!(!phases.is_empty(), "tight limits are refused by a phase's estimate: {phases:?}");
    fs::remove_dir_all(&d).expect("clean");
}

/// `--max-memory` from far too little to enough: every step exits cleanly, and the refusals walk
/// through the phases in order (a larger allowance never fails an earlier phase).
#[test]
fn max_memory_refuses_each_phase_before_it_allocates() {
    let d = scratch_dir("memory-max");
    let map = d.join("tiny1500.map");
    fs::write(&map, shapes::tiny_brushes_room(1500, 3)).expect("map");
    let order = ["csg", "bsp", "portals", "outside", "emit", "vis"];
    let mut last = 0;
    let mut seen = Vec::new();
    for mib in (4..=200).step_by(4) {
        let (code, stderr) = compile(&map, &d.join("out.slvl"), None, &["--max-memory", &format!("{mib}M")]);
        let Some(phase) = (code == 2).then(|| refused_phase(&stderr, &map)).flatten() else {
            assert_eq!(code, 0, "{mib} MiB: {stderr}");
            continue;
        };
        let at =
            order.iter().position(|p| *p == phase).unwrap_or_else(|| panic!("unknown phase in {stderr}"));
        assert!(at >= last, "{mib} MiB refused {phase} after a smaller allowance passed it");
        assert!(stderr.contains("--max-memory"), "{stderr}");
        last = at;
        if !seen.contains(&phase) {
            seen.push(phase);
        }
    }
    assert!(seen.len() >= 3, "refusals in several phases: {seen:?}");
    fs::remove_dir_all(&d).expect("clean");
}
