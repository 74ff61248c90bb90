//! Outputs that belong together (`compile`'s level and portal file, or its level and pointfile)
//! through the real binary: a failure to write any of them replaces none, the level records which
//! portal file is its own (so a pair left inconsistent is told apart by `info`), a pointfile from an
//! earlier leak is removed when the map is sealed, and temporary files a killed writer left are
//! swept by the next run.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use super::{file_names, scratch_dir};
use sightline_tests::{bundled_maps, sightline_binary};

fn sightline(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(sightline_binary()).args(args).output().expect("run sightline")
}

fn compile(input: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<&std::ffi::OsStr> =
        vec!["compile".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()];
    args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
    sightline(&args)
}

fn portal_file_status(level: &Path) -> String {
    let out = sightline(&["info".as_ref(), level.as_os_str(), "--json".as_ref()]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("info JSON");
    v["portal_file"].as_str().unwrap_or_else(|| panic!("no portal_file in {v}")).to_string()
}

/// A folder where any one of the outputs goes: the run fails naming it, and no output (nor any
/// temporary file) appears or changes.
#[test]
fn a_pair_is_written_all_or_none() {
    let maps = bundled_maps();
    for (input, blocked) in
        [("room.map", "prt"), ("room.map", "slvl"), ("leak.map", "pts"), ("leak.map", "slvl")]
    {
        let d = scratch_dir(&format!("paired-none-{blocked}-{input}"));
        let out = d.join("k.slvl");
        // Earlier outputs that must survive the failed run unchanged.
        for ext in ["slvl", "prt", "pts"] {
            if ext != blocked {
                fs::write(out.with_extension(ext), format!("old {ext}")).expect("seed");
            }
        }
        fs::create_dir(out.with_extension(blocked)).expect("blocking folder");
        let before = file_names(&d);
        let run = compile(&maps.join(input), &out, &["--allow-leak", "--no-vis"]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{input} with k.{blocked} a folder: {stderr}");
        assert!(stderr.contains(&format!("k.{blocked}")), "the error names the blocked output: {stderr}");
        assert_eq!(file_names(&d), before, "{input}: no file appeared or vanished");
        for ext in ["slvl", "prt", "pts"] {
            if ext != blocked {
                assert_eq!(fs::read_to_string(out.with_extension(ext)).expect("kept"), format!("old {ext}"));
            }
        }
        fs::remove_dir_all(&d).expect("clean");
    }
}

/// The level names its portal file: after a compile they match; a portal file from another
/// compile beside it (what a kill between the two renames would leave) is reported as not its own;
/// a leaking level records none.
#[test]
fn the_level_records_which_portal_file_is_its_own() {
    let maps = bundled_maps();
    let d = scratch_dir("paired-record");
    let (room, pillars) = (d.join("room.slvl"), d.join("pillars.slvl"));
    assert_eq!(compile(&maps.join("room.map"), &room, &["--no-vis"]).status.code(), Some(0));
    assert_eq!(compile(&maps.join("stairs_pillars.map"), &pillars, &["--no-vis"]).status.code(), Some(0));
    assert_eq!(portal_file_status(&room), "matches");
    fs::copy(pillars.with_extension("prt"), room.with_extension("prt")).expect("swap");
    assert_eq!(portal_file_status(&room), "differs");
    fs::remove_file(room.with_extension("prt")).expect("remove");
    assert_eq!(portal_file_status(&room), "missing");
    let leak = d.join("leak.slvl");
    assert_eq!(compile(&maps.join("leak.map"), &leak, &["--allow-leak"]).status.code(), Some(1));
    assert_eq!(portal_file_status(&leak), "not_recorded");
    fs::remove_dir_all(&d).expect("clean");
}

/// A sealed compile removes the pointfile an earlier leak left under its name (it would show a
/// leak the level no longer has), but never a folder or a link of that name.
#[test]
fn a_sealed_compile_removes_a_stale_pointfile() {
    let maps = bundled_maps();
    let d = scratch_dir("paired-stale-pts");
    let out = d.join("k.slvl");
    assert_eq!(compile(&maps.join("leak.map"), &out, &[]).status.code(), Some(1));
    assert!(out.with_extension("pts").is_file(), "the leak wrote its pointfile");
    let run = compile(&maps.join("room.map"), &out, &["--no-vis"]);
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(!out.with_extension("pts").exists(), "the stale pointfile is gone");
    assert!(String::from_utf8_lossy(&run.stderr).contains("k.pts"), "and the run says so");
    #[cfg(unix)]
    {
        let target = d.join("elsewhere.pts");
        fs::write(&target, "user's").expect("write");
        std::os::unix::fs::symlink(&target, out.with_extension("pts")).expect("link");
        assert_eq!(compile(&maps.join("room.map"), &out, &["--no-vis"]).status.code(), Some(0));
        assert!(fs::symlink_metadata(out.with_extension("pts")).is_ok(), "a link is left alone");
        assert_eq!(fs::read_to_string(&target).expect("kept"), "user's");
    }
    fs::remove_dir_all(&d).expect("clean");
}

/// Temporary files a killed writer left beside the outputs (full-size, hidden) are removed by the
/// next run that writes those names; another live process's are not.
#[cfg(target_os = "linux")]
#[test]
fn temporaries_a_killed_compile_left_are_swept() {
    let maps = bundled_maps();
    let d = scratch_dir("paired-sweep");
    let out = d.join("k.slvl");
    // Process ids on Linux stop at 2^22: 999999999 never runs.
    let dead = [".k.slvl.999999999.0.tmp", ".k.prt.999999999.1.tmp"];
    let live = format!(".k.slvl.{}.0.tmp", std::process::id());
    for name in dead.iter().copied().chain([live.as_str()]) {
        fs::write(d.join(name), vec![7u8; 4096]).expect("seed");
    }
    assert_eq!(compile(&maps.join("room.map"), &out, &["--no-vis"]).status.code(), Some(0));
    let left = file_names(&d);
    assert!(dead.iter().all(|n| !left.contains(&n.to_string())), "{left:?}");
    assert!(left.contains(&live), "a running process's temporary is kept: {left:?}");
    fs::remove_dir_all(&d).expect("clean");
}
