//! Helpers shared by the modules: running the binary, reading its output, temp dirs and the
//! bundled and shared maps.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

pub(crate) fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sightline"))
}

pub(crate) fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("the sightline binary runs")
}

pub(crate) fn code(out: &Output) -> i32 {
    out.status.code().expect("exited with a code, not a signal")
}

pub(crate) fn stdout_json(out: &Output) -> Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("stdout is not one JSON value ({e}):\n{}", String::from_utf8_lossy(&out.stdout))
    })
}

pub(crate) fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

pub(crate) fn maps() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps")
}

pub(crate) fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

pub(crate) fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// Compile `maps/NAME` into `dir`, returning the level's path (exit 0 and JSON checked).
pub(crate) fn compile(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(format!("{name}.slvl"));
    let o = run(&["compile", s(&maps().join(name)), "-o", s(&out), "--json", "--threads", "2"]);
    assert_eq!(code(&o), 0, "compile {name}: {}", stderr(&o));
    let j = stdout_json(&o);
    assert_eq!(j["leak"], Value::Null);
    assert!(j["stats"]["leaves"].as_u64().expect("stats.leaves") > 1);
    assert!(out.is_file(), "{} written", out.display());
    out
}

/// `NAME` in the shared maps folder (`$SIGHTLINE_MAPS`, else `../shared/maps`), or `None` with a
/// note when it is absent.
pub(crate) fn shared_map(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(name)
}

/// Copies the shared `.bsp` at `bsp` and its `.prt` (and `.texinfo.json`, when present) into a
/// fresh temp dir `tag` as `NAME.*`; returns the dir.
pub(crate) fn copy_map(bsp: &Path, tag: &str, name: &str) -> PathBuf {
    let dir = temp_dir(tag);
    std::fs::copy(bsp, dir.join(format!("{name}.bsp"))).expect("copy .bsp");
    std::fs::copy(bsp.with_extension("prt"), dir.join(format!("{name}.prt"))).expect("copy .prt");
    let side = bsp.with_extension("texinfo.json");
    if side.is_file() {
        std::fs::copy(side, dir.join(format!("{name}.texinfo.json"))).expect("copy .texinfo.json");
    }
    dir
}

/// Copies the shared `.prt` `rel` into a fresh temp dir `tag` as `NAME.prt`; returns the dir and
/// the copy, or `None` (with a note) when the shared maps are absent.
pub(crate) fn copy_prt(rel: &str, tag: &str, name: &str) -> Option<(PathBuf, PathBuf)> {
    let src = shared_map(rel)?;
    let dir = temp_dir(tag);
    let prt = dir.join(format!("{name}.prt"));
    std::fs::copy(&src, &prt).expect("copy the portal file");
    Some((dir, prt))
}

/// Runs `sightline ARGS` in `dir` (as TrenchBroom runs a compile profile's tasks in the map's
/// folder) and checks exit 0.
pub(crate) fn run_in(dir: &Path, args: &[&str]) -> Output {
    let o = bin().args(args).current_dir(dir).output().expect("the sightline binary runs");
    assert_eq!(code(&o), 0, "sightline {args:?} in {}: {}", dir.display(), stderr(&o));
    o
}

pub(crate) fn read_bsp(path: &Path) -> sightline_formats::bsp::Bsp {
    sightline_formats::bsp::read(&std::fs::read(path).expect("read .bsp")).expect("a valid .bsp")
}

/// Every vis leaf's decoded PVS row (vis leaf `j`'s row: bit `k` for vis leaf `k`).
pub(crate) fn pvs_rows(bsp: &sightline_formats::bsp::Bsp) -> Vec<Vec<u8>> {
    (1..=bsp.visleafs()).map(|l| bsp.decode_leaf_pvs(l).expect("row decodes")).collect()
}
