//! Vis benchmark on the reference compiler's portal files, side by side with the numbers in
//! `../shared/reference/anchors.md` (ericw-tools `vis`, 2 threads, idle 2-core machine).
//!
//! `cargo bench -p sightline-compiler --bench vis [-- MAP...]` runs each map in a child process
//! (so peak memory, `VmHWM`, is per map) with 2 threads, full (level 4) and `--fast`, keeps the
//! fastest of three runs (as the reference numbers were taken), and prints a
//! Markdown table: wall and CPU seconds, the ratio to the reference time (wall against its 2-thread
//! time; CPU against its 1-thread time, which a loaded machine distorts less), average visible leaves
//! against the reference `.vis.bsp`, total visible pairs against the reference's, chains and
//! peak memory. CPU seconds matter on a shared machine, where wall time includes waiting.
//! `SIGHTLINE_MAPS` points at the shared maps (default `../shared/maps`).

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use sightline_compiler::vis::{self, VisOptions};
use sightline_formats::{bsp, prt};

/// (map, ericw full s with 2 threads, with 1 thread, ericw fast s, ericw avg visible full, ericw
/// peak MB) from anchors.md.
const ANCHORS: [(&str, f64, f64, f64, f64, f64); 12] = [
    ("dm1", 0.34, 0.66, 0.03, 84.1, 7.0),
    ("dm2", 0.58, 1.14, 0.08, 86.7, 9.0),
    ("dm3", 0.75, 1.42, 0.08, 89.2, 9.0),
    ("start", 2.59, 4.93, 0.18, 109.8, 12.0),
    ("e1m1", 3.72, 7.30, 0.22, 164.8, 12.0),
    ("e1m2", 4.01, 7.85, 0.23, 139.2, 13.0),
    ("e1m3", 1.80, 3.43, 0.15, 109.6, 11.0),
    ("lqdm1", 0.20, 0.40, 0.08, 701.2, 7.0),
    ("lq_e0m1", 0.21, 0.39, 0.05, 99.3, 8.0),
    ("lq_e1m1", 5.38, 10.69, 0.65, 582.6, 16.0),
    ("dm2_nodetail", 0.67, 1.22, 0.09, 85.5, 9.0),
    ("e1m1_nodetail", 5.49, 10.46, 0.31, 154.7, 13.0),
];

fn maps_dir() -> PathBuf {
    sightline_tests::shared_maps().unwrap_or_default().join("ericw")
}

/// User + system CPU seconds of this process, from `/proc/self/stat` (clock ticks of 1/100 s).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else { return f64::NAN };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (ticks(11) + ticks(12)) / 100.0
}

/// Peak resident memory in MB (`VmHWM`).
fn peak_mb() -> f64 {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else { return f64::NAN };
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Child: run one map, print `wall cpu avg pairs chains peak_mb portals`.
fn child(path: &str, fast: bool) {
    let text = std::fs::read_to_string(path).expect("read .prt");
    let file = prt::read(&text, path).expect("parse .prt");
    let cpu0 = cpu_seconds();
    let t = Instant::now();
    let r = vis::run(
        &file,
        &VisOptions { threads: 2, fast, ..VisOptions::default() },
        &sightline_job::progress::NoProgress,
    )
    .expect("vis");
    let wall = t.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - cpu0;
    let s = &r.stats;
    println!("{wall} {cpu} {} {} {} {} {}", s.avg_visible, s.visible_pairs, s.chains, peak_mb(), s.portals);
}

fn run_child(path: &std::path::Path, fast: bool) -> Option<Vec<f64>> {
    let exe = std::env::current_exe().ok()?;
    let mode = if fast { "fast" } else { "full" };
    let out = Command::new(exe).args(["--one", &path.display().to_string(), mode]).output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    let v: Vec<f64> = text.split_whitespace().filter_map(|s| s.parse().ok()).collect();
    (v.len() == 7).then_some(v)
}

/// The run with the least wall time of three, as the reference numbers were taken.
fn fastest_of_three(path: &std::path::Path, fast: bool) -> Option<Vec<f64>> {
    let runs: Vec<Vec<f64>> = (0..3).filter_map(|_| run_child(path, fast)).collect();
    runs.into_iter().min_by(|a, b| a[0].total_cmp(&b[0]))
}

/// Visible leaf pairs in a reference `.vis.bsp`.
fn reference_pairs(name: &str) -> Option<f64> {
    let bytes = std::fs::read(maps_dir().join(format!("{name}.vis.bsp"))).ok()?;
    let s = bsp::read(&bytes).ok()?.pvs_stats().ok()??;
    Some(s.avg_visible * s.visleafs as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, path, mode] = args.as_slice()
        && flag == "--one"
    {
        child(path, mode == "fast");
        return;
    }
    let wanted: Vec<&String> = args.iter().filter(|a| !a.starts_with('-')).collect();
    println!(
        "| map | portals | full wall s (2 thr) | full CPU s | ericw s (2 thr) | ericw / ours (wall) | ericw 1 thr s / ours CPU s | avg visible ours / ericw | pairs ours / ericw | chains | fast wall s | fast CPU s | ericw fast s | peak MB ours / ericw |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, e_full, e_one, e_fast, e_avg, e_mb) in ANCHORS {
        if !wanted.is_empty() && !wanted.iter().any(|w| *w == name) {
            continue;
        }
        let path = maps_dir().join(format!("{name}.prt"));
        if !path.is_file() {
            eprintln!("note: {} missing; skipped", path.display());
            continue;
        }
        let (Some(full), Some(fast)) = (fastest_of_three(&path, false), fastest_of_three(&path, true)) else {
            eprintln!("{name}: child run failed");
            continue;
        };
        let pairs = reference_pairs(name).map_or("?".to_string(), |p| format!("{:.3}", full[3] / p));
        println!(
            "| {name} | {portals} | {wall:.3} | {cpu:.2} | {e_full:.2} | {ratio:.2} | {work:.2} | {avg:.1} / {e_avg:.1} | {pairs} | {chains} | {fwall:.3} | {fcpu:.2} | {e_fast:.2} | {mb:.0} / {e_mb:.0} |",
            portals = full[6],
            wall = full[0],
            cpu = full[1],
            ratio = e_full / full[0],
            work = e_one / full[1],
            avg = full[2],
            chains = full[4],
            fwall = fast[0],
            fcpu = fast[1],
            mb = full[5].max(fast[5]),
        );
    }
}
