//! `--help` and `--version` on the top level and on every subcommand; usage errors exit 2.

use crate::support::{code, run, stderr};

#[test]
fn help_and_version_exit_0_usage_errors_exit_2() {
    assert_eq!(code(&run(&["--version"])), 0);
    assert_eq!(code(&run(&["--help"])), 0);
    let none = run(&[]);
    assert_eq!(code(&none), 2, "no subcommand is a usage error");
    let unknown = run(&["frobnicate"]);
    assert_eq!(code(&unknown), 2);
    assert!(stderr(&unknown).contains("frobnicate"), "the unknown word is named: {}", stderr(&unknown));
    let bad_flag = run(&["info", "--no-such-flag", "x"]);
    assert_eq!(code(&bad_flag), 2);
    assert!(stderr(&bad_flag).contains("--no-such-flag"));
}

/// Every subcommand's help builds and prints: `sightline --help` lists the subcommands (at least
/// the known ones), and `sightline <sub> --help` exits 0 with a usage line naming it. (clap's own
/// definition checks, `debug_assert`, are the binary's unit test.)
#[test]
fn every_subcommand_prints_its_help() {
    let top = run(&["--help"]);
    assert_eq!(code(&top), 0, "{}", stderr(&top));
    let text = String::from_utf8_lossy(&top.stdout).into_owned();
    let subcommands: Vec<String> = text
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|name| name != "help")
        .collect();
    for known in ["compile", "vis", "portals", "validate", "info", "render", "bench", "gvs"] {
        assert!(subcommands.iter().any(|s| s == known), "`{known}` missing from --help:\n{text}");
    }
    // The first line, the summary, names every subcommand the list shows.
    let first = text.lines().next().unwrap_or_default();
    for sub in &subcommands {
        assert!(first.contains(sub.as_str()), "`{sub}` missing from the first line of --help:\n{text}");
    }
    for sub in &subcommands {
        let o = run(&[sub, "--help"]);
        assert_eq!(code(&o), 0, "{sub} --help: {}", stderr(&o));
        let help = String::from_utf8_lossy(&o.stdout);
        assert!(help.contains("Usage:") && help.contains(sub.as_str()), "{sub} --help:\n{help}");
    }
}
