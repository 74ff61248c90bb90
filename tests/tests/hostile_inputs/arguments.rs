//! Every numeric flag of every subcommand of the real binary, out of its range: refused with exit
//! 2 and an error naming the flag, without a panic, within [`TIMEOUT`] and (under `prlimit`)
//! [`MEMORY`] bytes of address space; and in range, parsed without a panic (a run on a missing
//! input, refused naming that input).
//!
//! The flags are taken from each subcommand's `--help`: every flag that takes a value must be in
//! the table below (numeric, with values in and out of range) or in the list of flags that take
//! no number, so a numeric flag added without a range check fails this test until it has one.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

use super::binary::{MEMORY, TIMEOUT, have_prlimit, run_logged};
use sightline_tests::sightline_binary as binary;

/// A numeric flag: its subcommand, a value in range, values out of it, and arguments its runs
/// need besides the command's base line (a render mode, `--compare` for `--move`).
#[derive(Clone, Copy)]
struct Flag {
    cmd: &'static str,
    flag: &'static str,
    good: &'static str,
    bad: &'static [&'static str],
    extra: &'static [&'static str],
}

const fn flag(
    cmd: &'static str,
    flag: &'static str,
    good: &'static str,
    bad: &'static [&'static str],
) -> Flag {
    Flag { cmd, flag, good, bad, extra: &[] }
}

/// Out-of-range values of the vis flags `compile` and `vis` share.
const VIS_FLAGS: [(&str, &str, &[&str]); 5] = [
    ("--level", "4", &["5", "-1", "x"]),
    ("--checkpoint-secs", "60", &["0", "31536001", "18446744073709551616"]),
    ("--max-memory", "512M", &["99999999999T", "-1", "x", "nan"]),
    ("--max-work", "2e11", &["1e30", "-1", "nan", "x"]),
    ("--max-time", "15m", &["0", "-1s", "nan", "9999h", "1m1h", "15x", "1e400"]),
];

/// Every numeric flag but the shared vis flags ([`VIS_FLAGS`]).
const FLAGS: &[Flag] = &[
    flag("compile", "--threads", "1", &["0", "1025", "100000", "18446744073709551616", "x"]),
    flag("vis", "--threads", "0", &["1025", "100000", "-1"]),
    flag("vis", "--farplane", "2048", &["-1", "nan", "inf"]),
    flag("vis", "--waves", "2", &["0", "1025", "-1", "x"]),
    flag("validate", "--rays", "1000", &["0", "-5", "1000000000001", "18446744073709551616"]),
    flag("validate", "--seed", "7", &["18446744073709551616", "-1", "x"]),
    flag("validate", "--threads", "0", &["1025", "100000"]),
    flag("validate", "--offset", "0.5", &["64", "-0.1", "nan", "inf"]),
    Flag {
        cmd: "render",
        flag: "--fov",
        good: "90",
        bad: &["0", "179", "-5", "nan", "1e309"],
        extra: &["--plan"],
    },
    Flag {
        cmd: "render",
        flag: "--size",
        good: "64x48",
        bad: &["0x10", "8193x10", "10x99999", "10", "axb"],
        extra: &["--plan"],
    },
    Flag {
        cmd: "render",
        flag: "--rays",
        good: "100",
        bad: &["0", "1000000000001"],
        extra: &["--pvs-matrix"],
    },
    flag("render", "--view", "0,0,64", &["0,0,nan", "1,2", "1,2,inf"]),
    Flag { cmd: "render", flag: "--look", good: "90,0", bad: &["nan,0", "90"], extra: &["--plan"] },
    Flag { cmd: "render", flag: "--from", good: "0,0,0", bad: &["0,0,inf", "x"], extra: &["--plan"] },
    Flag { cmd: "render", flag: "--z", good: "-64..64", bad: &["0..inf", "1"], extra: &["--plan"] },
    flag("bench", "--frames", "10", &["0", "-1", "100000001", "18446744073709551615", "1e8"]),
    flag("bench", "--seed", "3", &["18446744073709551616"]),
    flag("bench", "--ray-spacing", "8", &["0", "641", "-1"]),
    flag("bench", "--repeats", "3", &["0", "100001", "-1"]),
    flag("trace", "--poses", "1", &["0", "100001", "-1"]),
    flag("trace", "--seed", "3", &["18446744073709551616"]),
    flag("trace", "--fov", "90", &["0", "179", "nan"]),
    flag("trace", "--size", "32x24", &["0x10", "8193x10", "10", "axb"]),
    flag("trace", "--raycast-spacing", "8", &["0", "8193"]),
    flag("trace", "--view", "0,0,64", &["0,0,nan", "1,2", "1,2,inf"]),
    flag("trace", "--look", "90,0", &["nan,0", "90"]),
    flag("trace", "--walk", "2", &["0", "100001", "-1"]),
    flag("trace", "--path", "0,0,64;0,32,64", &["1,2", "0,0,nan", "", ";;"]),
    Flag { cmd: "trace", flag: "--step", good: "16", bad: &["0", "-1", "nan"], extra: &["--walk", "2"] },
    flag("trace", "--cell", "8", &["0", "-1", "nan"]),
    flag("trace", "--scene-seed", "3", &["18446744073709551616", "-1"]),
    flag("gvs", "--max-cells", "1", &["0", "1048577"]),
    flag("gvs", "--views", "1", &["10001", "-1", "18446744073709551616"]),
    flag("gvs", "--res", "16", &["8193"]),
    flag("gvs", "--fov", "60", &["0", "180", "nan"]),
    flag("gvs", "--error-cells", "1", &["1048577"]),
    flag("gvs", "--eps", "0.01", &["0", "1.5", "nan"]),
    flag("gvs", "--max-depth", "14", &["0", "65"]),
    flag("gvs", "--disc", "0.05", &["1", "-0.1", "nan"]),
    flag("gvs", "--adt", "0.001", &["0", "inf", "-1"]),
    flag("gvs", "--window", "1000", &["0", "1000000000001"]),
    flag("gvs", "--min-new", "1", &["4294967296", "x"]),
    flag("gvs", "--max-rays", "1000", &["0", "1000000000001"]),
    flag("gvs", "--max-random", "10", &["1000000000001"]),
    flag("gvs", "--first", "10", &["1000000000001"]),
    flag("gvs", "--targets", "3", &["65537"]),
    flag("gvs", "--target-rays", "16", &["65537"]),
    flag("gvs", "--probe-rays", "8", &["65537", "4294967295"]),
    flag("gvs", "--seed", "1", &["18446744073709551616"]),
    flag("gvs", "--scene-seed", "1", &["18446744073709551616"]),
    flag("gvs", "--threads", "1", &["0", "-2", "1025"]),
    flag("gvs", "--missed", "1", &["1000001"]),
    flag("gvs", "--cell", "-64,-64,0,64,64,128", &["0", "-1", "nan", "1,2", "-1,0,0,1,1,inf"]),
    Flag { cmd: "gvs", flag: "--move", good: "1,0,0", bad: &["1,nan,0", "1,2"], extra: &["--compare"] },
];

/// Flags that take a value that is not a number (a file, a name, a choice).
const NOT_NUMERIC: &[(&str, &str)] = &[
    ("compile", "--output"),
    ("compile", "--state"),
    ("vis", "--state"),
    ("vis", "--water"),
    ("vis", "--output"),
    ("portals", "--output"),
    ("portals", "--water"),
    ("validate", "--oracle"),
    ("render", "--output"),
    ("render", "--prt"),
    ("render", "--leak"),
    ("bench", "--backend"),
    ("bench", "--poses-file"),
    ("bench", "--save-poses"),
    ("trace", "--output"),
    ("trace", "--pose"),
    ("gvs", "--variant"),
    ("gvs", "--output"),
];

const COMMANDS: [&str; 9] =
    ["compile", "vis", "portals", "validate", "info", "render", "trace", "bench", "gvs"];

/// The command line of `cmd` on `input` before `flag`, the flag under test. A picture is small
/// (unless its size is under test), so that its memory never decides a run under `prlimit`.
fn base(cmd: &str, input: &str, flag: &str) -> Vec<String> {
    let mut line = vec![cmd.to_string()];
    line.push(match cmd {
        "compile" => format!("{input}.map"),
        "vis" => format!("{input}.prt"),
        // The mesh flags of `trace` on a mesh.
        "trace" if flag == "--cell" => format!("{input}.obj"),
        _ => format!("{input}.slvl"),
    });
    let rest: &[&str] = match cmd {
        "compile" => &["-o", "out.slvl"],
        "render" if flag == "--size" => &["-o", "out.png"],
        "render" => &["-o", "out.png", "--size", "64x48"],
        "gvs" => &["--cell", "leaves"],
        "trace" if flag == "--size" => &["--poses", "1"],
        "trace" if ["--poses", "--view", "--walk", "--path", "--step"].contains(&flag) => {
            &["--size", "32x24"]
        }
        "trace" => &["--poses", "1", "--size", "32x24"],
        _ => &[],
    };
    line.extend(rest.iter().map(|s| s.to_string()));
    line
}

/// The long names of the flags of `cmd` that take a value, from its `--help`.
fn flags_with_values(bin: &Path, cmd: &str) -> BTreeSet<String> {
    let out = Command::new(bin).args([cmd, "--help"]).output().expect("help");
    assert!(out.status.success(), "{cmd} --help: {out:?}");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let mut flags = BTreeSet::new();
    for line in text.lines().map(str::trim_start).filter(|l| l.starts_with('-')) {
        let mut words = line.split_whitespace().skip_while(|w| !w.starts_with("--"));
        if let (Some(name), Some(value)) = (words.next(), words.next())
            && (value.starts_with('<') || value.starts_with("[<"))
        {
            flags.insert(name.to_string());
        }
    }
    flags
}

/// Runs `args` in `dir`; returns the exit code (`None` for a hang or a signal) and stderr.
fn run(bin: &Path, prlimit: bool, args: &[String], dir: &Path, logs: &Path) -> (Option<i32>, String) {
    let status = run_logged(bin, prlimit, args, dir, logs);
    let stderr = std::fs::read(logs.join("stderr.txt")).unwrap_or_default();
    (status.and_then(|s| s.code()), String::from_utf8_lossy(&stderr).into_owned())
}

#[test]
fn every_numeric_flag_out_of_range_is_refused_naming_it() {
    let bin = binary();
    let prlimit = have_prlimit();
    let root = std::env::temp_dir().join(format!("sightline-hostile-args-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let (dir, logs) = (root.join("work"), root.join("logs"));
    std::fs::create_dir_all(&dir).expect("work dir");
    std::fs::create_dir_all(&logs).expect("logs dir");
    std::fs::copy(sightline_tests::bundled_maps().join("two_rooms.map"), dir.join("in.map")).expect("map");
    let made = Command::new(&bin)
        .args(["compile", "in.map", "-o", "in.slvl", "--no-vis", "--threads", "1"])
        .current_dir(&dir)
        .output()
        .expect("compile");
    assert!(made.status.success(), "{made:?}");

    // Every flag that takes a value is in the table or takes no number.
    let mut table: Vec<Flag> = FLAGS.to_vec();
    for cmd in ["compile", "vis"] {
        table.extend(VIS_FLAGS.iter().map(|&(name, good, bad)| flag(cmd, name, good, bad)));
    }
    for cmd in COMMANDS {
        let numeric: BTreeSet<String> =
            table.iter().filter(|t| t.cmd == cmd).map(|t| t.flag.to_string()).collect();
        let other: BTreeSet<String> =
            NOT_NUMERIC.iter().filter(|t| t.0 == cmd).map(|t| t.1.to_string()).collect();
        assert!(numeric.is_disjoint(&other), "{cmd}: {numeric:?} and {other:?}");
        let listed: BTreeSet<String> = numeric.union(&other).cloned().collect();
        assert_eq!(flags_with_values(&bin, cmd), listed, "{cmd}: the flags taking a value in --help");
    }

    let mut failures = Vec::new();
    let mut runs = 0;
    for &Flag { cmd, flag, good, bad, extra } in &table {
        let line = |input: &str, value: &str| {
            let mut args = base(cmd, input, flag);
            args.extend(extra.iter().map(|s| s.to_string()));
            args.extend([flag.to_string(), value.to_string()]);
            args
        };
        for value in bad {
            let args = line("in", value);
            let (code, stderr) = run(&bin, prlimit, &args, &dir, &logs);
            runs += 1;
            let problem = match code {
                None => Some(format!("no exit within {TIMEOUT:?} (or killed past {MEMORY} bytes)")),
                _ if stderr.contains("panicked") => Some("panicked".to_string()),
                Some(2) if stderr.contains(flag) => None,
                Some(2) => Some(format!("the error does not name {flag}")),
                Some(c) => Some(format!("exit {c}, not 2")),
            };
            if let Some(p) = problem {
                failures.push(format!("sightline {}: {p}\n  {}", args.join(" "), stderr.trim()));
            }
        }
        // In range, the value is parsed and taken (a flag whose parser and field disagree
        // panics here); the run stops at its missing input.
        let args = line("missing", good);
        let (code, stderr) = run(&bin, prlimit, &args, &dir, &logs);
        runs += 1;
        if code != Some(2) || stderr.contains("panicked") || !stderr.contains("missing") {
            failures.push(format!(
                "sightline {}: {code:?}, expected exit 2 naming the missing input\n  {}",
                args.join(" "),
                stderr.trim()
            ));
        }
    }
    eprintln!("{runs} runs over {} numeric flags", table.len());
    assert!(failures.is_empty(), "{} of {runs} runs failed:\n{}", failures.len(), failures.join("\n"));
    let _ = std::fs::remove_dir_all(&root);
}
