//! Vis across machines with the real binary (`sightline vis plan|shard|merge|status`): on shared
//! maps of Quake 1, Quake 2 (with its PHS) and Half-Life, the merge of N shards writes the same
//! bytes as the one-process run of the same plan (`sightline vis --waves W`) for N = 1, 2, 7, 16;
//! a shard of another input or of other options is refused naming its file; `status` lists
//! exactly the missing shards; and a partial merge keeps every pair of the full one.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use sightline_compiler::vis::plan::Plan;
use sightline_compiler::vis::shard::{MergeSpec, ShardFiles};
use sightline_compiler::vis::{self, VisOptions};
use sightline_job::progress::NoProgress;

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-vis-shards-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// `sightline ARGS`, its output.
fn sightline(args: &[&str]) -> Output {
    Command::new(sightline_tests::sightline_binary()).args(args).output().expect("run sightline")
}

/// `sightline ARGS`, which must succeed.
fn ok(args: &[&str]) -> Output {
    let out = sightline(args);
    assert!(out.status.success(), "sightline {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

/// Copies the shared map `rel` (without `.bsp`) and its `.prt` into `dir` as `name.bsp` and
/// `name.prt`; `None` when the shared map is absent.
fn copy_map(rel: &str, dir: &Path, name: &str) -> Option<PathBuf> {
    let bsp = sightline_tests::shared_map(&format!("{rel}.bsp"))?;
    let prt = sightline_tests::shared_map(&format!("{rel}.prt"))?;
    let out = dir.join(format!("{name}.bsp"));
    std::fs::copy(bsp, &out).expect("copy .bsp");
    std::fs::copy(prt, dir.join(format!("{name}.prt"))).expect("copy .prt");
    Some(out)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// Every shard of `shards` × `waves` of the map at `bsp`, wave after wave, on one thread each.
fn run_shards(bsp: &Path, shards: u32, waves: u32) {
    for w in 1..=waves {
        for k in 1..=shards {
            ok(&[
                "vis",
                "shard",
                &format!("{k}/{shards}"),
                s(bsp),
                "--wave",
                &w.to_string(),
                "--waves",
                &waves.to_string(),
                "--threads",
                "1",
                "--no-progress",
            ]);
        }
    }
}

#[test]
fn merged_shards_write_the_bytes_of_the_one_process_run_on_every_family() {
    let dir = temp_dir("identical");
    // Quake 1 (ericw-tools' compile), Quake 2 (the PHS is written from the merged PVS), Half-Life.
    for rel in ["ericw/dm1", "q2/dm2", "hl/start"] {
        let tag = rel.replace('/', "_");
        let Some(one) = copy_map(rel, &dir, &format!("{tag}_one")) else { continue };
        ok(&["vis", "--waves", "1", "--threads", "2", "--no-progress", s(&one)]);
        let want = std::fs::read(&one).expect("read");
        for n in [1u32, 2, 7, 16] {
            let Some(bsp) = copy_map(rel, &dir, &format!("{tag}_{n}")) else { continue };
            run_shards(&bsp, n, 1);
            let shards = n.to_string();
            let st = sightline(&["vis", "status", "--shards", &shards, s(&bsp)]);
            assert_eq!(st.status.code(), Some(0), "{rel}: status with every shard done");
            ok(&["vis", "merge", "--shards", &shards, "--no-progress", s(&bsp)]);
            assert!(std::fs::read(&bsp).expect("read") == want, "{rel}: the merge of {n} shards differs");
        }
    }
    // Two waves: the second wave's shards read the first's; the same bytes as `--waves 2`.
    if let Some(one) = copy_map("ericw/dm1", &dir, "waves_one") {
        ok(&["vis", "--waves", "2", "--threads", "2", "--no-progress", s(&one)]);
        for n in [1u32, 3] {
            let Some(bsp) = copy_map("ericw/dm1", &dir, &format!("waves_{n}")) else { return };
            run_shards(&bsp, n, 2);
            ok(&["vis", "merge", "--shards", &n.to_string(), "--waves", "2", "--no-progress", s(&bsp)]);
            assert!(
                std::fs::read(&bsp).expect("read") == std::fs::read(&one).expect("read"),
                "2 waves of {n}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_shard_of_another_input_or_options_is_refused_and_status_lists_the_missing() {
    let dir = temp_dir("refuse");
    let (Some(bsp), Some(other)) = (copy_map("ericw/dm1", &dir, "dm1"), copy_map("ericw/e1m1", &dir, "e1m1"))
    else {
        return;
    };
    let shards = dir.join("shards");
    let at = |k: u32| shards.join(format!("dm1.{k}-of-4.shard"));
    let shard = |k: u32, input: &Path, extra: &[&str]| {
        let spec = format!("{k}/4");
        let mut args = vec!["vis", "shard", spec.as_str(), s(input)];
        args.extend(["--dir", s(&shards), "--threads", "1", "--no-progress"]);
        args.extend(extra);
        ok(&args);
    };
    for k in [1, 2, 4] {
        shard(k, &bsp, &[]);
    }
    // Status lists exactly shard 3 as missing (exit 1), and the JSON says so too.
    let st = sightline(&["vis", "status", "--shards", "4", "--dir", s(&shards), s(&bsp)]);
    assert_eq!(st.status.code(), Some(1));
    let text = String::from_utf8_lossy(&st.stdout);
    assert_eq!(text.matches("missing:").count(), 1, "{text}");
    assert!(text.contains(&format!("missing: {}", at(3).display())), "{text}");
    let st = sightline(&["vis", "status", "--shards", "4", "--dir", s(&shards), "--json", s(&bsp)]);
    let list: serde_json::Value = serde_json::from_slice(&st.stdout).expect("status JSON");
    let states: Vec<&str> =
        list.as_array().expect("a list").iter().map(|e| e["state"].as_str().unwrap_or("")).collect();
    assert_eq!(states, ["done", "done", "missing", "done"]);
    // A merge without it fails (exit 2) naming it, and writes nothing.
    let before = std::fs::read(&bsp).expect("read");
    let m = sightline(&["vis", "merge", "--shards", "4", "--dir", s(&shards), "--no-progress", s(&bsp)]);
    assert_eq!(m.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&m.stderr).contains("dm1.3-of-4.shard"));
    assert!(std::fs::read(&bsp).expect("read") == before, "a failed merge wrote the map");
    // Shard 3 of another map (named dm1 in another folder), or of other options, is refused.
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).expect("dir");
    let imposter = elsewhere.join("dm1.bsp");
    std::fs::rename(&other, &imposter).expect("move");
    std::fs::rename(dir.join("e1m1.prt"), elsewhere.join("dm1.prt")).expect("move");
    for (input, extra, why) in
        [(&imposter, &[][..], "another input"), (&bsp, &["--level", "3"][..], "other options")]
    {
        shard(3, input, extra);
        let m = sightline(&["vis", "merge", "--shards", "4", "--dir", s(&shards), "--no-progress", s(&bsp)]);
        let err = String::from_utf8_lossy(&m.stderr);
        assert_eq!(m.status.code(), Some(2), "{why}: {err}");
        assert!(err.contains("dm1.3-of-4.shard") && err.contains("another input"), "{why}: {err}");
        let st = sightline(&["vis", "status", "--shards", "4", "--dir", s(&shards), s(&bsp)]);
        assert!(String::from_utf8_lossy(&st.stdout).contains("stale:"), "{why}");
    }
    // Rerun right, the shard completes the merge.
    shard(3, &bsp, &[]);
    ok(&["vis", "merge", "--shards", "4", "--dir", s(&shards), "--no-progress", s(&bsp)]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_partial_merge_keeps_every_pair_of_the_full_merge() {
    let dir = temp_dir("partial");
    for rel in ["ericw/dm1", "hl/start"] {
        let Some(bsp) = copy_map(rel, &dir, &rel.replace('/', "_")) else { continue };
        let prt_path = bsp.with_extension("prt");
        let text = std::fs::read_to_string(&prt_path).expect("read .prt");
        let prt = sightline_formats::prt::read(&text, s(&prt_path)).expect("parse .prt");
        // Shards made from the .bsp (the binary) are the .prt's: the same portal file.
        run_shards(&bsp, 7, 1);
        let files = ShardFiles::for_input(&bsp, None, Plan::new(7, 1).expect("plan"));
        let merge = |allow_partial| {
            let opts = VisOptions {
                threads: 2,
                merge: Some(MergeSpec { files: files.clone(), allow_partial }),
                ..VisOptions::default()
            };
            vis::run(&prt, &opts, &NoProgress)
        };
        let full = merge(false).expect("full merge");
        for gone in [2u32, 5] {
            std::fs::remove_file(files.path(1, gone)).expect("remove a shard");
        }
        let partial = merge(true).expect("partial merge");
        let stats = partial.stats.merged.clone().expect("merge stats");
        assert_eq!(stats.missing.len(), 2, "{rel}");
        assert!(stats.missing_portals > 0, "{rel}");
        for a in 0..full.num_leaves() {
            for b in 0..full.num_leaves() {
                assert!(
                    !full.leaf_sees(a, b) || partial.leaf_sees(a, b),
                    "{rel}: partial hides {b} from {a}"
                );
            }
        }
        assert!(partial.stats.visible_pairs >= full.stats.visible_pairs, "{rel}");
        // The binary says what was missing and writes the looser PVS.
        let out = ok(&["vis", "merge", "--shards", "7", "--allow-partial", "--no-progress", s(&bsp)]);
        assert!(String::from_utf8_lossy(&out.stdout).contains("PARTIAL: 2 shard files missing"), "{rel}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
