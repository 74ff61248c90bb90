//! The real `sightline` binary, run as a user or a build script would: exit codes (0 success,
//! 1 a finding, 2 an error), `--json` output that parses, errors that name the file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sightline"))
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("the sightline binary runs")
}

fn code(out: &Output) -> i32 {
    out.status.code().expect("exited with a code, not a signal")
}

fn stdout_json(out: &Output) -> Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("stdout is not one JSON value ({e}):\n{}", String::from_utf8_lossy(&out.stdout))
    })
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn maps() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// Compile `maps/NAME` into `dir`, returning the level's path (exit 0 and JSON checked).
fn compile(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(format!("{name}.slvl"));
    let o = run(&["compile", s(&maps().join(name)), "-o", s(&out), "--json", "--threads", "2"]);
    assert_eq!(code(&o), 0, "compile {name}: {}", stderr(&o));
    let j = stdout_json(&o);
    assert_eq!(j["leak"], Value::Null);
    assert!(j["stats"]["leaves"].as_u64().expect("stats.leaves") > 1);
    assert!(out.is_file(), "{} written", out.display());
    out
}

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

#[test]
fn missing_and_malformed_inputs_exit_2_and_name_the_file() {
    let dir = temp_dir("errors");
    let missing = dir.join("nowhere.map");
    for cmd in ["compile", "vis", "validate", "info", "bench"] {
        let o = run(&[cmd, s(&missing)]);
        assert_eq!(code(&o), 2, "{cmd} on a missing file: {}", stderr(&o));
        assert!(stderr(&o).contains("nowhere.map"), "{cmd} names the file: {}", stderr(&o));
        assert!(o.stdout.is_empty(), "{cmd} prints nothing on stdout when it fails");
    }
    let bad = dir.join("bad.map");
    std::fs::write(&bad, "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 0 0 ) oops\n}\n}\n")
        .expect("write");
    let o = run(&["compile", s(&bad), "-o", s(&dir.join("bad.slvl"))]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("bad.map:"), "a parse error carries file:line: {}", stderr(&o));
    assert!(!dir.join("bad.slvl").exists(), "nothing written on error");
    let garbage = dir.join("garbage.bsp");
    std::fs::write(&garbage, b"IBSP\x1d\0\0\0 not a real header").expect("write");
    for cmd in ["vis", "info", "validate", "bench"] {
        let o = run(&[cmd, s(&garbage)]);
        assert_eq!(code(&o), 2, "{cmd} on a damaged BSP: {}", stderr(&o));
        assert!(stderr(&o).contains("garbage.bsp"), "{cmd} names the file: {}", stderr(&o));
    }
}

#[test]
fn a_leak_is_a_finding_exit_1_with_json_and_a_pointfile() {
    let dir = temp_dir("leak");
    let out = dir.join("leak.slvl");
    let o = run(&["compile", s(&maps().join("leak.map")), "-o", s(&out), "--json"]);
    assert_eq!(code(&o), 1, "{}", stderr(&o));
    let j = stdout_json(&o);
    assert!(j["leak"].is_object(), "leak reported: {j}");
    let pts = j["leak"]["pointfile"].as_str().expect("leak.pointfile");
    assert!(Path::new(pts).is_file(), "pointfile {pts} written");
    assert!(!out.exists(), "no level written for a leaking map");
}

#[test]
fn compile_info_validate_bench_and_vis_succeed_with_json() {
    let dir = temp_dir("ok");
    let level = compile(&dir, "two_rooms.map");

    let info = run(&["info", "--json", s(&level)]);
    assert_eq!(code(&info), 0, "{}", stderr(&info));
    let j = stdout_json(&info);
    assert!(j.is_object() && !j.as_object().expect("object").is_empty());

    let val = run(&["validate", s(&level), "--rays", "20000", "--json"]);
    assert_eq!(code(&val), 0, "{}", stderr(&val));
    let j = stdout_json(&val);
    let text = j.to_string();
    assert!(text.contains("misses"), "the report lists misses: {text}");

    let bench = run(&["bench", s(&level), "--frames", "50", "--json"]);
    assert_eq!(code(&bench), 0, "{}", stderr(&bench));
    let plain = stdout_json(&bench);
    // Back faces culled in the walk: fewer faces on the same poses, the same leaves.
    let culled =
        run(&["bench", s(&level), "--frames", "50", "--json", "--cull-back-faces", "--backend", "pvs"]);
    assert_eq!(code(&culled), 0, "{}", stderr(&culled));
    let culled = stdout_json(&culled);
    assert_eq!(culled["cull_back_faces"], true);
    let pvs = |j: &Value, key: &str| j["backends"][0][key].as_f64().expect(key);
    assert!(pvs(&culled, "visible_faces_avg") < pvs(&plain, "visible_faces_avg"));
    assert_eq!(pvs(&culled, "visible_leaves_avg"), pvs(&plain, "visible_leaves_avg"));

    let prt = level.with_extension("prt");
    assert!(prt.is_file(), "compile wrote the portal file");
    let vis = run(&["vis", s(&prt), "--json", "--threads", "2"]);
    assert_eq!(code(&vis), 0, "{}", stderr(&vis));
    stdout_json(&vis);

    let png = dir.join("plan.png");
    let render = run(&["render", s(&level), "--plan", "--size", "64x48", "-o", s(&png)]);
    assert_eq!(code(&render), 0, "{}", stderr(&render));
    let bytes = std::fs::read(&png).expect("png written");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"));

    let gvs = run(&["gvs", "gen:city:2", "--max-cells", "2", "--views", "0", "--json"]);
    assert_eq!(code(&gvs), 0, "{}", stderr(&gvs));
    stdout_json(&gvs);
}

#[test]
fn a_pvs_that_hides_a_visible_leaf_is_a_finding_exit_1() {
    use sightline_formats::{rle, slvl};
    let dir = temp_dir("miss");
    let level_path = compile(&dir, "two_rooms.map");
    let mut level = slvl::read(&std::fs::read(&level_path).expect("read level")).expect("our own level");
    assert!(level.num_clusters > 1, "two rooms make more than one cluster");
    // Every cluster sees only itself: the two rooms see each other through the doorway, so
    // ray sampling must find pairs this PVS hides.
    let row_bytes = (level.num_clusters as usize).div_ceil(8);
    level.pvs_data.clear();
    level.pvs_offsets.clear();
    for c in 0..level.num_clusters as usize {
        let mut row = vec![0u8; row_bytes];
        row[c / 8] |= 1 << (c % 8);
        level.pvs_offsets.push(level.pvs_data.len() as u32);
        rle::encode_row(&row, &mut level.pvs_data);
    }
    let bad = dir.join("blind.slvl");
    std::fs::write(&bad, slvl::write(&level, &slvl::WriteOptions::default())).expect("write");
    let o = run(&["validate", s(&bad), "--rays", "20000", "--json"]);
    assert_eq!(code(&o), 1, "a miss is a finding: {}", stderr(&o));
    stdout_json(&o);
}

/// `NAME` in the shared maps folder (`$SIGHTLINE_MAPS`, else `../shared/maps`), or `None` with a
/// note when it is absent.
fn shared_map(name: &str) -> Option<PathBuf> {
    sightline_tests::shared_map(name)
}

/// Copies the shared `.bsp` at `bsp` and its `.prt` (and `.texinfo.json`, when present) into a
/// fresh temp dir `tag` as `NAME.*`; returns the dir.
fn copy_map(bsp: &Path, tag: &str, name: &str) -> PathBuf {
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
fn copy_prt(rel: &str, tag: &str, name: &str) -> Option<(PathBuf, PathBuf)> {
    let src = shared_map(rel)?;
    let dir = temp_dir(tag);
    let prt = dir.join(format!("{name}.prt"));
    std::fs::copy(&src, &prt).expect("copy the portal file");
    Some((dir, prt))
}

/// Runs `sightline ARGS` in `dir` (as TrenchBroom runs a compile profile's tasks in the map's
/// folder) and checks exit 0.
fn run_in(dir: &Path, args: &[&str]) -> Output {
    let o = bin().args(args).current_dir(dir).output().expect("the sightline binary runs");
    assert_eq!(code(&o), 0, "sightline {args:?} in {}: {}", dir.display(), stderr(&o));
    o
}

fn read_bsp(path: &Path) -> sightline_formats::bsp::Bsp {
    sightline_formats::bsp::read(&std::fs::read(path).expect("read .bsp")).expect("a valid .bsp")
}

/// Every vis leaf's decoded PVS row (vis leaf `j`'s row: bit `k` for vis leaf `k`).
fn pvs_rows(bsp: &sightline_formats::bsp::Bsp) -> Vec<Vec<u8>> {
    (1..=bsp.visleafs()).map(|l| bsp.decode_leaf_pvs(l).expect("row decodes")).collect()
}

fn bit(row: &[u8], k: usize) -> bool {
    row[k / 8] & (1 << (k % 8)) != 0
}

#[test]
fn vis_takes_an_ericw_command_line_base_name_and_single_dash_flags_anywhere() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let ours = copy_map(&dm1, "ericw-long", "dm1");
    let long = ours.join("dm1.bsp");
    run(&["vis", "--threads", "2", "--fast", s(&long)]);
    let expected = std::fs::read(&long).expect("vised .bsp");
    assert_ne!(expected, std::fs::read(&dm1).expect("original"), "vis wrote visdata");

    // A base name, options before it; then options after it, with harmless ones mixed in.
    let lines: [&[&str]; 3] = [
        &["vis", "-threads", "2", "-fast", "dm1"],
        &["vis", "dm1", "-fast", "-threads", "2", "-nopercent", "-v", "-nolog", "-noprogress", "-nostate"],
        &["vis", "-verbose", "-lowpriority", "0", "-Threads", "2", "dm1.bsp", "-FAST"],
    ];
    for (i, line) in lines.iter().enumerate() {
        let dir = copy_map(&dm1, &format!("ericw-short-{i}"), "dm1");
        let o = run_in(&dir, &[&line[..], &["--json"]].concat());
        let j = stdout_json(&o);
        assert!(j["input"].as_str().expect("input").ends_with("dm1.bsp"), "{line:?} resolved {j}");
        assert_eq!(
            (j["vis"]["fast"].as_bool(), j["vis"]["threads"].as_u64()),
            (Some(true), Some(2)),
            "{line:?}"
        );
        let got = std::fs::read(dir.join("dm1.bsp")).expect("vised .bsp");
        assert!(got == expected, "{line:?} writes the same bytes as --threads 2 --fast");
    }
}

#[test]
fn vis_rejects_unknown_single_dash_options_naming_them() {
    let dir = temp_dir("ericw-bad");
    let bsp = dir.join("x.bsp");
    for (args, named) in [
        (vec!["vis", "-bogus", s(&bsp)], "-bogus"),
        (vec!["vis", s(&bsp), "-threads", "2", "-noambientwind"], "-noambientwind"),
        (vec!["vis", s(&bsp), "-threads"], "-threads"),
        (vec!["vis", s(&bsp), "-farplane", "-5"], "-5"),
    ] {
        let o = run(&args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(named), "{args:?} names {named}: {}", stderr(&o));
        assert!(o.stdout.is_empty());
    }
    // Sightline's own flags are untouched: a `--` flag it does not know is clap's error.
    let o = run(&["vis", "--bogus", s(&bsp)]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("--bogus"));
}

#[test]
fn vis_noambient_zeroes_every_leaf_and_texinfo_json_silences_flagged_faces() {
    // LibreQuake's lqdm1 (dm1 as compiled here has no texture names, so no sounds).
    if let Some(lq) = shared_map("ericw/lqdm1.bsp") {
        let plain = copy_map(&lq, "ambient-plain", "lqdm1");
        run_in(&plain, &["vis", "-threads", "2", "-fast", "lqdm1"]);
        let levels = |dir: &Path| {
            read_bsp(&dir.join("lqdm1.bsp")).leaves.iter().map(|l| l.ambient).collect::<Vec<_>>()
        };
        assert!(levels(&plain).iter().any(|a| a.iter().any(|&v| v > 0)), "lqdm1 has ambient sounds");

        let none = copy_map(&lq, "ambient-none", "lqdm1");
        let o = run_in(&none, &["vis", "-threads", "2", "-fast", "-noambient", "lqdm1", "--json"]);
        assert_eq!(stdout_json(&o)["ambient_off"], serde_json::json!(["water", "sky", "slime", "lava"]));
        assert!(levels(&none).iter().all(|a| *a == [0; 4]), "every leaf's ambient levels are 0");

        let sky = copy_map(&lq, "ambient-sky", "lqdm1");
        run_in(&sky, &["vis", "-threads", "2", "-fast", "-noambientsky", "lqdm1"]);
        for (a, b) in levels(&plain).iter().zip(levels(&sky)) {
            assert_eq!((b[1], [b[0], b[2], b[3]]), (0, [a[0], a[2], a[3]]), "only the sky channel changes");
        }
    }

    // ericw-tools' test map: the sky of one room is a func_group with "_noambient" "1", which its
    // qbsp writes to NAME.texinfo.json. Read beside the .bsp, it silences that room.
    let Some(map) = shared_map("ericw-testmaps/q1_vis_noambient_func_group.standin.bsp") else { return };
    let dir = copy_map(&map, "ambient-json", "m");
    let o = run_in(&dir, &["vis", "-threads", "2", "m", "--json"]);
    let j = stdout_json(&o);
    assert_eq!(j["noambient_texinfos"], 1, "{j}");
    assert!(j["texinfo_json"].as_str().expect("texinfo_json").ends_with("m.texinfo.json"));
    let with_json: Vec<[u8; 4]> = read_bsp(&dir.join("m.bsp")).leaves.iter().map(|l| l.ambient).collect();
    let ericw = read_bsp(&map.with_extension("ericw.bsp"));
    assert_eq!(with_json, ericw.leaves.iter().map(|l| l.ambient).collect::<Vec<_>>(), "as ericw-tools' vis");

    std::fs::remove_file(dir.join("m.texinfo.json")).expect("remove");
    std::fs::copy(&map, dir.join("m.bsp")).expect("fresh copy");
    run_in(&dir, &["vis", "-threads", "2", "m"]);
    let without: Vec<[u8; 4]> = read_bsp(&dir.join("m.bsp")).leaves.iter().map(|l| l.ambient).collect();
    assert!(
        without.iter().zip(&with_json).any(|(a, b)| a[1] == 255 && b[1] == 0),
        "without the side file the func_group's sky sounds"
    );

    std::fs::write(dir.join("m.texinfo.json"), "{\"4\": {\"noambient\": 1}}").expect("write");
    let o = run(&["vis", s(&dir.join("m"))]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("m.texinfo.json"), "the bad side file is named: {}", stderr(&o));
}

#[test]
fn vis_farplane_hides_only_pairs_farther_than_it() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let full = copy_map(&dm1, "farplane-off", "dm1");
    run_in(&full, &["vis", "-threads", "2", "dm1"]);
    let far = copy_map(&dm1, "farplane-256", "dm1");
    let o = run_in(&far, &["vis", "-threads", "2", "-farplane", "256", "dm1", "--json"]);
    let j = stdout_json(&o);
    assert_eq!(j["farplane"], 256.0);
    let (a, b) = (read_bsp(&full.join("dm1.bsp")), read_bsp(&far.join("dm1.bsp")));
    let (rows_a, rows_b) = (pvs_rows(&a), pvs_rows(&b));
    let n = a.visleafs();
    // Distance between the stored bounds of vis leaves i and k (BSP leaves i + 1, k + 1).
    let gap = |i: usize, k: usize| {
        let (p, q) = (&b.leaves[i + 1], &b.leaves[k + 1]);
        (0..3)
            .map(|x| f64::from((p.mins[x] - q.maxs[x]).max(q.mins[x] - p.maxs[x]).max(0.0)).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (mut seen_a, mut seen_b, mut hidden) = (0, 0, 0);
    for i in 0..n {
        assert!(bit(&rows_b[i], i), "leaf {i} still sees itself");
        for k in 0..n {
            let (va, vb) = (bit(&rows_a[i], k), bit(&rows_b[i], k));
            assert!(!vb || va, "the far plane only hides: {i} -> {k}");
            assert_eq!(vb, bit(&rows_b[k], i), "symmetric: {i} <-> {k}");
            if va && !vb {
                hidden += 1;
                assert!(gap(i, k) > 256.0, "{i} -> {k} hidden at {} units", gap(i, k));
            }
            seen_a += usize::from(va);
            seen_b += usize::from(vb);
        }
    }
    assert!(seen_b <= seen_a && hidden > 0, "dm1 has leaves more than 256 units apart that see each other");
    assert_eq!(j["vis"]["visible_pairs"], seen_b as u64, "the report counts the culled matrix");
    eprintln!("far plane 256 on dm1: {seen_a} -> {seen_b} visible leaf pairs");

    // Without a .bsp there are no leaf bounds: an error, not a guess.
    let o = run(&["vis", s(&far.join("dm1.prt")), "--farplane", "256"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("dm1.prt"), "{}", stderr(&o));
}

#[test]
fn quake2_vis_farplane_hides_only_clusters_farther_apart_and_keeps_the_phs_a_union() {
    use sightline_formats::bsp::q2::{self, Q2Row};
    let Some(dm2) = shared_map("q2/dm2.bsp") else { return };
    let full = copy_map(&dm2, "q2-farplane-off", "dm2");
    run_in(&full, &["vis", "-threads", "2", "dm2"]);
    let far = copy_map(&dm2, "q2-farplane-512", "dm2");
    let j = stdout_json(&run_in(&far, &["vis", "-threads", "2", "-farplane", "512", "dm2", "--json"]));
    assert_eq!(j["farplane"], 512.0, "{j}");
    let read = |dir: &Path| std::fs::read(dir.join("dm2.bsp")).expect("read dm2.bsp");
    let (bytes_a, bytes_b) = (read(&full), read(&far));
    let (a, b) = (q2::read(&bytes_a).expect("q2"), q2::read(&bytes_b).expect("q2"));
    let (va, vb) = (a.vis.clone().expect("vised"), b.vis.clone().expect("vised"));
    let n = va.num_clusters;
    let rb = va.row_bytes();
    let (pa, pb) = (va.decode_all(Q2Row::Pvs).expect("rows"), vb.decode_all(Q2Row::Pvs).expect("rows"));
    let phs = vb.decode_all(Q2Row::Phs).expect("rows");
    let bit = |rows: &[u8], i: usize, k: usize| rows[i * rb + k / 8] & (1 << (k % 8)) != 0;
    // The nearest distance between the stored bounds of any leaf of cluster i and any of k.
    let level = q2::to_level(&b);
    let gap = |i: usize, k: usize| {
        let of = |c: usize| level.leaves.iter().filter(move |l| l.cluster == c as i32);
        of(i)
            .flat_map(|p| of(k).map(move |q| (p, q)))
            .map(|(p, q)| {
                (0..3)
                    .map(|x| f64::from((p.mins[x] - q.maxs[x]).max(q.mins[x] - p.maxs[x]).max(0.0)).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let mut hidden = 0;
    for i in 0..n {
        assert!(bit(&pb, i, i), "cluster {i} still sees itself");
        // The PHS is the union of the culled PVS rows of what cluster i sees.
        let mut heard = vec![0u8; rb];
        for m in (0..n).filter(|&m| bit(&pb, i, m)) {
            heard.iter_mut().zip(&pb[m * rb..(m + 1) * rb]).for_each(|(h, r)| *h |= r);
        }
        assert_eq!(heard, phs[i * rb..(i + 1) * rb], "PHS row of cluster {i}");
        for k in 0..n {
            let (seen_a, seen_b) = (bit(&pa, i, k), bit(&pb, i, k));
            assert!(!seen_b || seen_a, "the far plane only hides: {i} -> {k}");
            if seen_a && !seen_b {
                hidden += 1;
                assert!(gap(i, k) > 512.0, "{i} -> {k} hidden at {} units", gap(i, k));
            }
        }
    }
    assert!(hidden > 0, "dm2 has clusters more than 512 units apart that see each other");
    assert_eq!(j["farplane_hidden_pairs"].as_u64(), Some(hidden as u64 / 2), "{j}");
    // --phs-only keeps the PVS byte for byte: a far plane there is an error.
    let o = bin()
        .args(["vis", "--phs-only", "-farplane", "512", "dm2"])
        .current_dir(&far)
        .output()
        .expect("runs");
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("--phs-only"), "{}", stderr(&o));
}

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

// ---- Errors name their file and place, once; inputs Quake's tools accept are accepted ----

/// A minimal BSP29 and its PRT1 (LF line breaks): the plane x = 0 splits the world into two open
/// leaves (1: x > 0, 2: x < 0) that see each other through one portal; one PVS byte, no faces.
fn tiny_bsp() -> (Vec<u8>, String) {
    use sightline_formats::bsp::{HEADER_BYTES, NUM_LUMPS, lump};
    let mut lumps: Vec<Vec<u8>> = vec![Vec::new(); NUM_LUMPS];
    lumps[lump::ENTITIES] = b"{\n\"classname\" \"worldspawn\"\n}\n\0".to_vec();
    lumps[lump::PLANES] =
        [1f32, 0.0, 0.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).chain(0i32.to_le_bytes()).collect();
    lumps[lump::VISIBILITY] = vec![0b11];
    let mut node = 0i32.to_le_bytes().to_vec();
    for v in [-2i16, -3, -64, -64, 0, 64, 64, 64, 0, 0] {
        node.extend(v.to_le_bytes());
    }
    lumps[lump::NODES] = node;
    let leaf = |contents: i32, visofs: i32, bounds: [i16; 6]| {
        let mut l = contents.to_le_bytes().to_vec();
        l.extend(visofs.to_le_bytes());
        bounds.iter().for_each(|v| l.extend(v.to_le_bytes()));
        l.extend([0u8; 8]);
        l
    };
    lumps[lump::LEAVES] =
        [leaf(-2, -1, [0; 6]), leaf(-1, 0, [0, -64, 0, 64, 64, 64]), leaf(-1, 0, [-64, -64, 0, 0, 64, 64])]
            .concat();
    let mut model: Vec<u8> =
        [-64f32, -64.0, 0.0, 64.0, 64.0, 64.0, 0.0, 0.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    [0i32, -1, -1, -1, 2, 0, 0].iter().for_each(|v| model.extend(v.to_le_bytes()));
    lumps[lump::MODELS] = model;
    let mut out = vec![0u8; HEADER_BYTES];
    out[..4].copy_from_slice(&29i32.to_le_bytes());
    for (i, data) in lumps.iter().enumerate() {
        out.resize(out.len().next_multiple_of(4), 0);
        let entry = [out.len() as i32, data.len() as i32];
        out[4 + 8 * i..12 + 8 * i]
            .copy_from_slice(&[entry[0].to_le_bytes(), entry[1].to_le_bytes()].concat());
        out.extend_from_slice(data);
    }
    let prt = "PRT1\n2\n1\n4 0 1 (0 -64 0) (0 64 0) (0 64 64) (0 -64 64)\n".to_string();
    (out, prt)
}

/// The `error: ` line of a failed command, asserting that no part of it (anyhow's `{:#}` joins an
/// error and its causes with ": ") repeats: a cause repeated in its parent's message shows twice.
fn error_line(o: &Output) -> String {
    let err = stderr(o);
    let line =
        err.lines().find_map(|l| l.strip_prefix("error: ")).unwrap_or_else(|| panic!("no error: {err}"));
    let parts: Vec<&str> = line.split(": ").filter(|p| p.len() >= 4).collect();
    for (i, p) in parts.iter().enumerate() {
        assert!(!parts[i + 1..].contains(p), "`{p}` is printed twice: {line}");
    }
    line.to_string()
}

#[test]
fn a_level_without_models_is_an_error_naming_the_file_and_the_lump() {
    use sightline_formats::slvl;
    let dir = temp_dir("no-models");
    let level_path = compile(&dir, "room.map");
    let mut level = slvl::read(&std::fs::read(&level_path).expect("read level")).expect("our own level");
    level.models.clear();
    let bad = dir.join("modelless.slvl");
    std::fs::write(&bad, slvl::write(&level, &slvl::WriteOptions::default())).expect("write");
    let png = dir.join("x.png");
    for args in [
        &["info", s(&bad)][..],
        &["validate", s(&bad), "--rays", "1000"],
        &["render", s(&bad), "--plan", "--size", "8x8", "-o", s(&png)],
        &["bench", s(&bad), "--frames", "1"],
    ] {
        let o = run(args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        let line = error_line(&o);
        assert!(line.starts_with(&format!("{}: ", bad.display())), "{args:?} names the file first: {line}");
        assert!(
            line.contains("lump models") && line.contains("no world model"),
            "{args:?} names the lump: {line}"
        );
    }
}

/// A flag that cannot apply to the input is an error that names the input first. (A value out of
/// a flag's range is refused while the arguments are parsed, naming the flag and its range:
/// `tests/tests/hostile_inputs/arguments.rs`.)
#[test]
fn flags_that_cannot_apply_to_the_input_are_errors_naming_it() {
    let dir = temp_dir("flags");
    let level = compile(&dir, "room.map");
    let (bytes, prt_text) = tiny_bsp();
    let bsp = dir.join("tiny.bsp");
    std::fs::write(&bsp, &bytes).expect("write");
    std::fs::write(dir.join("tiny.prt"), prt_text).expect("write");
    let prt = dir.join("tiny.prt");
    let obj = maps().join("scene.obj");
    let png = dir.join("x.png");
    let cases: [(&Path, Vec<&str>); 8] = [
        (&bsp, vec!["vis", "--phs-only"]),
        (&prt, vec!["vis", "--farplane", "100"]),
        (&prt, vec!["vis", "--portals-from-bsp"]),
        (&bsp, vec!["vis", "--water", "opaque"]),
        (&bsp, vec!["vis", "-o", "x.vis"]),
        (&level, vec!["render", "--plan", "--pvs-matrix", "-o", s(&png)]),
        (&level, vec!["render", "--leak", "", "-o", s(&png)]),
        (&obj, vec!["gvs", "--cell", "leaves", "--views", "0"]),
    ];
    for (input, flags) in cases {
        let mut args = flags.clone();
        args.insert(1, s(input));
        let o = run(&args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        let line = error_line(&o);
        assert!(
            line.starts_with(&format!("{}: ", input.display())),
            "{args:?} names the input first: {line}"
        );
    }
}

/// `info` on an `.obj` says what it skipped, and an `.obj` without a usable triangle is an error
/// naming the file.
#[test]
fn info_on_an_obj_says_what_was_skipped() {
    let dir = temp_dir("obj-info");
    let points = dir.join("points.obj");
    std::fs::write(&points, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 3\n").expect("write");
    let o = run(&["info", s(&points)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let line = error_line(&o);
    assert!(line.starts_with(&format!("{}: no usable triangle", points.display())), "{line}");
    assert!(line.contains("2 faces skipped"), "{line}");
    let some = dir.join("some.obj");
    std::fs::write(&some, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n").expect("write");
    let o = run(&["info", s(&some)]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("triangles: 1\nskipped faces: 1 (fewer than three vertices"), "{text}");
    let j = stdout_json(&run(&["info", s(&some), "--json"]));
    assert_eq!((j["triangles"].as_u64(), j["skipped_faces"].as_u64()), (Some(1), Some(1)), "{j}");
}

#[test]
fn a_bsp_whose_visdata_overlaps_another_lump_is_refused_before_vis_runs() {
    use sightline_formats::bsp::{self, lump};
    let dir = temp_dir("overlap");
    let (mut bytes, prt) = tiny_bsp();
    let lumps = bsp::read(&bytes).expect("tiny BSP").lumps;
    let (vis, nodes) = (lumps[lump::VISIBILITY], lumps[lump::NODES]);
    // The visibility lump runs on over the nodes lump: readable, but vis would overwrite nodes.
    let at = 4 + 8 * lump::VISIBILITY + 4;
    bytes[at..at + 4].copy_from_slice(&((nodes.end() - vis.offset) as i32).to_le_bytes());
    bsp::read(&bytes).expect("still a readable BSP");
    let path = dir.join("overlap.bsp");
    std::fs::write(&path, &bytes).expect("write");
    std::fs::write(dir.join("overlap.prt"), prt).expect("write");
    let o = run(&["vis", s(&path), "--threads", "1"]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let line = error_line(&o);
    assert!(line.starts_with(&format!("{}: ", path.display())), "{line}");
    let ranges = format!(
        "lump visibility (bytes {}..{}) overlaps lump nodes (bytes {}..{})",
        vis.offset,
        nodes.end(),
        nodes.offset,
        nodes.end()
    );
    assert!(line.contains(&ranges), "names both lumps and their bytes: {line}");
    assert!(!stderr(&o).contains("portals"), "refused before any vis work: {}", stderr(&o));
    assert_eq!(std::fs::read(&path).expect("read"), bytes, "the file is untouched");
}

#[test]
fn compile_checks_its_output_folder_before_compiling() {
    let dir = temp_dir("out-dir");
    // leak.map would compile to a finding (exit 1): exit 2 shows nothing was compiled.
    let input = maps().join("leak.map");
    let missing = dir.join("no/such/folder/leak.slvl");
    let o = run(&["compile", s(&input), "-o", s(&missing)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let line = error_line(&o);
    assert!(line.contains(&dir.join("no/such/folder").display().to_string()), "names the folder: {line}");
    assert!(o.stdout.is_empty());
    let file = dir.join("a-file");
    std::fs::write(&file, "x").expect("write");
    let o = run(&["compile", s(&input), "-o", s(&file.join("leak.slvl"))]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(error_line(&o).contains("is not a folder"), "{}", stderr(&o));
    let o = run(&["compile", s(&input), "-o", s(&dir)]);
    assert_eq!(code(&o), 2, "an output that is a folder: {}", stderr(&o));
    let mut left: Vec<_> =
        std::fs::read_dir(&dir).expect("dir").map(|e| e.expect("entry").file_name()).collect();
    left.sort();
    assert_eq!(left, ["a-file"], "the checks leave nothing behind");
}

#[test]
fn a_map_with_high_bit_bytes_in_strings_compiles_and_keeps_them() {
    use sightline_formats::{map, slvl};
    let dir = temp_dir("latin1");
    let room = std::fs::read(maps().join("room.map")).expect("room.map");
    let text = String::from_utf8(room).expect("room.map is UTF-8");
    let (head, tail) = text.split_once("\"classname\" \"worldspawn\"\n").expect("worldspawn");
    let gold: Vec<u8> = (0x80..=0xFFu8).filter(|&b| b != b'"').collect();
    let mut bytes = format!("{head}\"classname\" \"worldspawn\"\n\"message\" \"").into_bytes();
    bytes.extend_from_slice(&gold);
    bytes.extend_from_slice(b"\"\n");
    bytes.extend_from_slice(tail.as_bytes());
    assert!(std::str::from_utf8(&bytes).is_err(), "the map is not UTF-8");
    let input = dir.join("gold.map");
    std::fs::write(&input, &bytes).expect("write");
    let out = dir.join("gold.slvl");
    let o = run(&["compile", s(&input), "-o", s(&out), "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    // The level's entity text holds each byte as the character of the same code (Latin-1).
    let level = slvl::read(&std::fs::read(&out).expect("level")).expect("valid level");
    let message =
        level.entities.split('\n').find_map(|l| l.strip_prefix("\"message\" \"")).expect("message kept");
    let message = message.strip_suffix('"').expect("quoted");
    assert_eq!(map::encode_latin1(message), Some(gold), "every byte comes back");
    let o = run(&["info", s(&input), "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(stdout_json(&o)["kind"], "map");
}

#[test]
fn zero_rays_is_an_argument_error() {
    let dir = temp_dir("rays");
    let level = compile(&dir, "room.map");
    for args in [
        &["validate", s(&level), "--rays", "0"][..],
        &["render", s(&level), "--pvs-matrix", "--rays", "0", "-o", s(&dir.join("m.png"))],
    ] {
        let o = run(args);
        assert_eq!(code(&o), 2, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("--rays"), "names the argument: {}", stderr(&o));
        assert!(
            o.stdout.is_empty(),
            "nothing validated, nothing reported: {}",
            String::from_utf8_lossy(&o.stdout)
        );
    }
    let o = run(&["validate", s(&level), "--rays", "1", "--json"]);
    assert_eq!(code(&o), 0, "one ray is a budget: {}", stderr(&o));
}

/// Backends `bench --json` ran (the ray-casting one runs on every level).
fn bench_backends(path: &Path) -> Vec<String> {
    let o = run(&["bench", s(path), "--frames", "20", "--json"]);
    assert_eq!(code(&o), 0, "bench {}: {}", path.display(), stderr(&o));
    let j = stdout_json(&o);
    let list = j["backends"].as_array().expect("backends");
    list.iter().map(|b| b["backend"].as_str().expect("name").to_string()).collect()
}

#[test]
fn bench_and_vis_read_a_crlf_portal_file_alike() {
    let dir = temp_dir("crlf");
    let (bsp, prt) = tiny_bsp();
    let path = dir.join("tiny.bsp");
    std::fs::write(&path, &bsp).expect("write");
    assert_eq!(
        bench_backends(&path),
        ["pvs", "raycast", "frustum", "none"],
        "no portal file: no portal backend"
    );
    std::fs::write(dir.join("tiny.prt"), prt.replace('\n', "\r\n")).expect("write");
    assert_eq!(
        bench_backends(&path),
        ["pvs", "portal", "raycast", "frustum", "none"],
        "the CRLF PRT1 gives the portal backend its portal"
    );
    let o = run(&["vis", s(&path), "--threads", "1", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(stdout_json(&o)["prt_format"], "PRT1");
}

#[test]
fn vis_and_bench_find_the_portal_file_of_a_vis_bsp_by_one_rule() {
    let dir = temp_dir("vis-bsp");
    let (bsp, prt) = tiny_bsp();
    let path = dir.join("tiny.vis.bsp");
    std::fs::write(&path, &bsp).expect("write");
    // Neither NAME.vis.prt nor NAME.prt: both are named.
    let o = run(&["vis", s(&path), "--threads", "1"]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let line = error_line(&o);
    for p in [dir.join("tiny.vis.prt"), dir.join("tiny.prt")] {
        assert!(line.contains(&p.display().to_string()), "names {}: {line}", p.display());
    }
    // NAME.prt beside NAME.vis.bsp (what a compiler leaves when a copy is vised).
    std::fs::write(dir.join("tiny.prt"), &prt).expect("write");
    let o = run(&["vis", s(&path), "--threads", "1", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(bench_backends(&path), ["pvs", "portal", "raycast", "frustum", "none"]);
    // NAME.vis.prt comes first: a PRT2 there is what both use (vis reads it, the portal backend
    // needs PRT1 and so does not run).
    let prt2 = "PRT2\n2\n2\n1\n4 0 1 (0 -64 0) (0 64 0) (0 64 64) (0 -64 64)\n0 -1\n1 -1\n";
    std::fs::write(dir.join("tiny.vis.prt"), prt2).expect("write");
    let o = run(&["vis", s(&path), "--threads", "1", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(stdout_json(&o)["prt_format"], "PRT2");
    assert_eq!(bench_backends(&path), ["pvs", "raycast", "frustum", "none"]);
}

#[test]
fn a_bad_polygon_is_reported_once() {
    let dir = temp_dir("polygon");
    let map = dir.join("flat.map");
    let text = "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 0 0 ) ( 2 0 0 ) T 0 0 0 1 1\n}\n}\n";
    std::fs::write(&map, text).expect("write");
    let obj = dir.join("empty-face.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n").expect("write");
    for (input, place, phrase) in
        [(&map, "flat.map:4:1", "degenerate plane"), (&obj, "empty-face.obj:4", "invalid polygon")]
    {
        for cmd in ["compile", "info"] {
            let o = run(&[cmd, s(input)]);
            assert_eq!(code(&o), 2, "{cmd}: {}", stderr(&o));
            let line = error_line(&o);
            assert_eq!(line.matches(phrase).count(), 1, "{cmd}: `{phrase}` once: {line}");
            assert!(line.contains(place), "{cmd} names the place: {line}");
        }
    }
}

/// A tiny portal file declaring the most leaves PRT1 allows: vis would need terabytes for its
/// cluster matrices and refuses at once, saying how much and why (exit 2), with or without
/// `--max-memory`; a normal map fits and a too small `--max-memory` refuses it too.
#[test]
fn vis_refuses_a_job_larger_than_memory_before_allocating() {
    let dir = temp_dir("memory");
    let prt = dir.join("huge.prt");
    std::fs::write(&prt, "PRT1\n4194304\n1\n4 0 1 (0 0 0) (0 64 0) (0 64 64) (0 0 64)\n").expect("write");
    let started = std::time::Instant::now();
    let o = run(&["vis", s(&prt), "--threads", "2", "--max-memory", "1G"]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("vis would need ") && err.contains(" TiB for the cluster matrices"), "{err}");
    assert!(err.contains("4194304 leaves") && err.contains("1 portals"), "{err}");
    assert!(err.contains("more than the 1.0 GiB allowed by --max-memory"), "{err}");
    let fast = run(&["vis", s(&prt), "--fast", "--threads", "2"]);
    let err = stderr(&fast);
    assert_eq!(code(&fast), 2, "{err}");
    assert!(err.contains("vis --fast would need") && err.contains("see --max-memory"), "{err}");
    assert!(started.elapsed().as_secs() < 20, "refused without allocating");
    assert!(!dir.join("huge.vis").exists());

    let level = compile(&dir, "two_rooms.map");
    let prt = level.with_extension("prt");
    let ok = run(&["vis", s(&prt), "--threads", "2", "--max-memory", "1G"]);
    assert_eq!(code(&ok), 0, "{}", stderr(&ok));
    let tight = run(&["vis", s(&prt), "--threads", "2", "--max-memory", "1K"]);
    assert_eq!(code(&tight), 2, "{}", stderr(&tight));
    assert!(stderr(&tight).contains("allowed by --max-memory"));
    let compiled = run(&["compile", s(&maps().join("two_rooms.map")), "-o", s(&level), "--max-memory", "1K"]);
    assert_eq!(code(&compiled), 2, "{}", stderr(&compiled));
    assert!(stderr(&compiled).contains("allowed by --max-memory"));
    // Refusals name the input first.
    assert!(stderr(&tight).contains(&format!("{}: vis would need", prt.display())), "{}", stderr(&tight));
    assert!(stderr(&compiled).contains("two_rooms.map: "), "{}", stderr(&compiled));
    let bad = run(&["vis", s(&prt), "--max-memory", "lots"]);
    assert_eq!(code(&bad), 2);
}

#[test]
fn vis_on_a_quake2_bsp_writes_pvs_and_phs_and_phs_only_repairs_ericw() {
    let Some(src) = shared_map("q2/q2_detail_leak_test.bsp") else { return };
    let dir = copy_map(&src, "q2-vis", "leak");
    // ericw's command line works the same way for Quake 2.
    let o = run_in(&dir, &["vis", "-threads", "2", "leak", "--json"]);
    let j = stdout_json(&o);
    assert_eq!((j["game"].as_str(), j["mode"].as_str()), (Some("quake2"), Some("vis")), "{j}");
    assert_eq!(
        (j["clusters"].as_u64(), j["pvs_pairs"].as_u64(), j["phs_pairs"].as_u64()),
        (Some(15), Some(103), Some(149))
    );
    assert!(j["visibility_bytes"].as_u64().expect("visibility_bytes") > 4 + 8 * 15);
    // `info` reads Quake 2 files: clusters and the pairs of the PVS and PHS just written.
    let o = run(&["info", s(&dir.join("leak.bsp")), "--json"]);
    let j = stdout_json(&o);
    assert_eq!((j["game"].as_str(), j["clusters"].as_u64()), (Some("quake2"), Some(15)), "{j}");
    assert_eq!((j["pvs_pairs"].as_u64(), j["phs_pairs"].as_u64()), (Some(103), Some(149)));

    let Some(ericw) = shared_map("q2/q2_detail_leak_test.ericw.bsp") else { return };
    let fix = temp_dir("q2-phs-only");
    std::fs::copy(&ericw, fix.join("e.bsp")).expect("copy .bsp");
    let o = run_in(&fix, &["vis", "--phs-only", "e.bsp", "--json"]);
    let j = stdout_json(&o);
    assert_eq!(j["mode"].as_str(), Some("phs-only"));
    assert_eq!(
        (j["phs_repair"]["rows_fixed"].as_u64(), j["phs_repair"]["bits_added"].as_u64()),
        (Some(15), Some(46))
    );
    let o = run_in(&fix, &["vis", "--phs-only", "e.bsp"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 of 15 rows changed"));

    // --phs-only on a Quake 1 file is an error naming it.
    let o = run(&["vis", "--phs-only", s(&maps().join("room.map"))]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("--phs-only"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&fix);
}

#[test]
fn quake3_vis_info_validate_and_bad_files() {
    let Some(src) = shared_map("q3/fan.bsp") else { return };
    let dir = copy_map(&src, "q3-vis", "fan");
    // ericw's command line works for Quake 3 too.
    let o = run_in(&dir, &["vis", "-threads", "2", "fan", "--json"]);
    let j = stdout_json(&o);
    assert_eq!((j["game"].as_str(), j["prt_format"].as_str()), (Some("quake3"), Some("q3map2")), "{j}");
    assert_eq!((j["clusters"].as_u64(), j["visibility_bytes"].as_u64()), (Some(172), Some(8 + 172 * 24)));
    let pairs = j["pvs_pairs"].as_u64().expect("pvs_pairs");
    let bsp = dir.join("fan.bsp");
    let o = run(&["info", s(&bsp), "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let info = stdout_json(&o);
    assert_eq!((info["kind"].as_str(), info["version"].as_i64()), (Some("q3_bsp"), Some(46)), "{info}");
    assert_eq!((info["clusters"].as_u64(), info["pvs_pairs"].as_u64()), (Some(172), Some(pairs)));
    assert_eq!((info["leaves"].as_u64(), info["has_vis"].as_bool()), (Some(413), Some(true)));
    let o = run(&["validate", s(&bsp), "--rays", "20000", "--json"]);
    assert_eq!(code(&o), 0, "no miss: {}", stderr(&o));
    assert!(stderr(&o).contains("sampling against the BSP tree only"), "{}", stderr(&o));

    // Broken files: exit 2, the message names the file and the place.
    let good = std::fs::read(&bsp).expect("read");
    let (_, lumps) = sightline_formats::bsp::q3::read_header(&good).expect("header");
    let vis_at = lumps[sightline_formats::bsp::q3::lump::VISIBILITY].offset;
    let mut bad = good.clone();
    bad[vis_at..vis_at + 4].copy_from_slice(&100_000i32.to_le_bytes());
    let broken = dir.join("broken.bsp");
    for (bytes, place) in [(&bad[..], format!("byte {}", vis_at + 4)), (&good[..1000], "byte 8".to_string())]
    {
        std::fs::write(&broken, bytes).expect("write");
        for cmd in ["info", "vis", "validate"] {
            let o = run(&[cmd, s(&broken)]);
            let err = stderr(&o);
            assert_eq!(code(&o), 2, "{cmd}: {err}");
            assert!(err.contains("broken.bsp") && err.contains(&place), "{cmd}: {err}");
            assert!(!err.contains("panicked"), "{cmd}: {err}");
        }
    }
    // A q3map2 portal file that does not parse: exit 2 naming it, line and column.
    let prt = std::fs::read_to_string(dir.join("fan.prt")).expect("read .prt");
    std::fs::write(dir.join("fan.prt"), prt.replacen("4 0 11 0 (", "4 0 11 x (", 1)).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("fan.prt:5:8: expected portal flags"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn half_life_vis_errors_exit_2_naming_the_file() {
    let Some(src) = shared_map("hl/lq_e0m1.sdhlt.bsp") else { return };
    let dir = temp_dir("hl-errors");
    let (bsp, prt) = (dir.join("m.bsp"), dir.join("m.prt"));
    let bytes = std::fs::read(&src).expect("read .bsp");
    let text = std::fs::read_to_string(src.with_extension("prt")).expect("read .prt");
    // A truncated BSP30: the error names the file and the lump.
    std::fs::write(&bsp, &bytes[..bytes.len() / 2]).expect("write");
    std::fs::write(&prt, &text).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("m.bsp") && stderr(&o).contains("lump"), "{}", stderr(&o));
    // A VHLT portal file with a negative leaf count: named with its line and column.
    std::fs::write(&bsp, &bytes).expect("write");
    std::fs::write(&prt, text.replacen("\n1\n", "\n-1\n", 1)).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("m.prt:3:1") && stderr(&o).contains("-1 leaves"), "{}", stderr(&o));
    // Counts that do not add up to the BSP's vis leaves.
    std::fs::write(&prt, text.replacen("\n1\n", "\n2\n", 1)).expect("write");
    let o = run(&["vis", s(&bsp)]);
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("658 vis leaves") && stderr(&o).contains("659"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&bsp).expect("read"), bytes, "nothing written on an error");
}

// Re-vis without source: `portals`, `vis --portals-from-bsp`, `--external-vis` (one map, a folder).

/// A fresh temp dir `tag` holding the shared `.bsp` at `bsp` alone (no `.prt`), as `NAME.bsp`.
fn bsp_alone(bsp: &Path, tag: &str, name: &str) -> PathBuf {
    let dir = temp_dir(tag);
    std::fs::copy(bsp, dir.join(format!("{name}.bsp"))).expect("copy .bsp");
    dir
}

#[test]
fn portals_rebuilds_a_prt1_over_the_bsps_vis_leaves() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "portals", "dm1");
    let o = run(&["portals", &dir.join("dm1.bsp").to_string_lossy(), "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let report = stdout_json(&o);
    let prt = std::fs::read_to_string(dir.join("dm1.prt")).expect("dm1.prt written beside the .bsp");
    let prt = sightline_formats::prt::read(&prt, "dm1.prt").expect("a valid portal file");
    assert_eq!(prt.format, sightline_formats::prt::PrtFormat::Prt1);
    assert_eq!(prt.num_leaves as usize, read_bsp(&dm1).visleafs());
    assert_eq!(report["portals"]["portals"].as_u64(), Some(prt.portals.len() as u64));
    // ericw-tools' qbsp wrote 983 cluster portals for the same tree.
    assert!((950..1050).contains(&prt.portals.len()), "{} portals", prt.portals.len());
    // Opaque water leaves out the liquid surfaces; -o names the file.
    let opaque = dir.join("opaque.prt");
    let o = run(&[
        "portals",
        &dir.join("dm1.bsp").to_string_lossy(),
        "--water",
        "opaque",
        "-o",
        &opaque.to_string_lossy(),
    ]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let fewer = sightline_formats::prt::read(&std::fs::read_to_string(&opaque).expect("opaque.prt"), "o")
        .expect("prt");
    assert!(fewer.portals.len() < prt.portals.len());
    // Not a BSP: exit 2 naming the file.
    std::fs::write(dir.join("junk.bsp"), b"not a bsp at all, not even close to one").expect("write");
    let o = run(&["portals", &dir.join("junk.bsp").to_string_lossy()]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("junk.bsp"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn vis_with_portals_from_the_bsp_passes_ray_validation() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "from-bsp", "dm1");
    // A stale .prt beside the .bsp is ignored under --portals-from-bsp.
    std::fs::write(dir.join("dm1.prt"), "PRT1\n3\n0\n").expect("write");
    let bsp = dir.join("dm1.bsp");
    let o = run(&["vis", &bsp.to_string_lossy(), "--portals-from-bsp", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let report = stdout_json(&o);
    assert!(report["portals_rebuilt"]["portals"].as_u64().is_some_and(|n| n > 900), "{report}");
    let vised = read_bsp(&bsp);
    assert!(vised.pvs_stats().expect("rows").is_some_and(|s| s.avg_visible > 10.0 && s.avg_visible < 200.0));
    let o = run(&["validate", &bsp.to_string_lossy(), "--rays", "300000", "--json"]);
    assert_eq!(code(&o), 0, "validation found a miss: {}", String::from_utf8_lossy(&o.stdout));
    let v = stdout_json(&o);
    for oracle in v["oracles"].as_array().expect("oracles") {
        assert_eq!(oracle["misses"].as_array().map(Vec::len), Some(0), "{oracle}");
    }
    // --water without --portals-from-bsp, and --portals-from-bsp on a .prt, are errors.
    let o = run(&["vis", &bsp.to_string_lossy(), "--water", "opaque"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("--portals-from-bsp"), "{}", stderr(&o));
    let o = run(&["vis", &dir.join("dm1.prt").to_string_lossy(), "--portals-from-bsp"]);
    assert_eq!(code(&o), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn half_life_portals_from_the_bsp_match_sdhlt_and_pass_ray_validation() {
    let Some(src) = shared_map("hl/dm2.sdhlt.bsp") else { return };
    // From SDHLT's own portal file, then from the tree alone.
    let with_prt = temp_dir("hl-from-prt");
    std::fs::copy(&src, with_prt.join("dm2.bsp")).expect("copy .bsp");
    std::fs::copy(src.with_extension("prt"), with_prt.join("dm2.prt")).expect("copy .prt");
    let from_prt = with_prt.join("dm2.bsp");
    assert_eq!(code(&run(&["vis", s(&from_prt), "--threads", "2"])), 0);
    let dir = bsp_alone(&src, "hl-from-bsp", "dm2");
    let bsp = dir.join("dm2.bsp");
    let o = run(&["vis", s(&bsp), "--portals-from-bsp", "--threads", "2", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let j = stdout_json(&o);
    let prt_portals = std::fs::read_to_string(src.with_extension("prt")).expect("read .prt");
    let sdhlt: u64 =
        prt_portals.split_whitespace().nth(1).and_then(|t| t.parse().ok()).expect("portal count");
    assert_eq!(
        j["portals_rebuilt"]["portals"].as_u64(),
        Some(sdhlt),
        "the same portals as SDHLT's hlbsp: {j}"
    );
    let pairs = |p: &Path| read_bsp(p).pvs_stats().expect("rows").expect("vised").pairs;
    let (ours, theirs) = (pairs(&bsp) as f64, pairs(&from_prt) as f64);
    assert!((0.95..=1.05).contains(&(ours / theirs)), "pairs {ours} from the tree vs {theirs} from the .prt");
    let o = run(&["validate", s(&bsp), "--rays", "200000", "--json"]);
    assert_eq!(code(&o), 0, "validation found a miss: {}", String::from_utf8_lossy(&o.stdout));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&with_prt);
}

#[test]
fn external_vis_leaves_the_bsp_alone_and_holds_the_pvs_vis_would_write() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "external", "dm1");
    let bsp = dir.join("dm1.bsp");
    let before = std::fs::read(&bsp).expect("read");
    let o = run(&["vis", &bsp.to_string_lossy(), "--portals-from-bsp", "--external-vis"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(std::fs::read(&bsp).expect("read"), before, "the .bsp is untouched");
    let pack = sightline_formats::vispatch::read(&std::fs::read(dir.join("dm1.vis")).expect("dm1.vis"))
        .expect("reads");
    assert_eq!(pack.len(), 1);
    assert_eq!(pack[0].map_name, "dm1.bsp");
    // The same run into the .bsp: the record decodes to the rows written there.
    let o = run(&["vis", &bsp.to_string_lossy(), "--portals-from-bsp"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let vised = read_bsp(&bsp);
    let rows = pvs_rows(&vised);
    for (j, row) in rows.iter().enumerate() {
        assert_eq!(&pack[0].decode_row(j + 1, vised.visleafs()).expect("row"), row, "vis leaf {j}");
    }
    let leaves = vised.lumps[sightline_formats::bsp::lump::LEAVES];
    assert_eq!(pack[0].leaves, std::fs::read(&bsp).expect("read")[leaves.offset..leaves.end()]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_folder_makes_one_pack_and_lists_the_maps_it_skipped() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let dir = bsp_alone(&dm1, "pack", "dm1");
    std::fs::copy(&dm1, dir.join("DM1.BSP")).expect("copy");
    std::fs::write(dir.join("broken.bsp"), vec![7u8; 300]).expect("write");
    let pack = dir.join("pack.vis");
    let o = run(&[
        "vis",
        &dir.to_string_lossy(),
        "--external-vis",
        "--portals-from-bsp",
        "--fast",
        "-o",
        &pack.to_string_lossy(),
        "--json",
    ]);
    assert_eq!(code(&o), 1, "some maps skipped: exit 1; {}", stderr(&o));
    let report = stdout_json(&o);
    let skipped: Vec<String> = report["skipped"]
        .as_array()
        .expect("skipped")
        .iter()
        .map(|s| s["file"].as_str().unwrap_or("").to_string())
        .collect();
    assert_eq!(skipped.len(), 2, "{report}");
    assert!(
        skipped.iter().any(|f| f.ends_with("broken.bsp")) && skipped.iter().any(|f| f.ends_with("dm1.bsp")),
        "{skipped:?}"
    );
    let records =
        sightline_formats::vispatch::read(&std::fs::read(&pack).expect("pack written")).expect("reads");
    assert_eq!(records.iter().map(|r| r.map_name.as_str()).collect::<Vec<_>>(), ["DM1.BSP"]);
    // Nothing to pack: exit 2, nothing written; a folder needs -o.
    let bad = temp_dir("pack-bad");
    std::fs::write(bad.join("broken.bsp"), vec![7u8; 300]).expect("write");
    let none = bad.join("none.vis");
    let o = run(&["vis", &bad.to_string_lossy(), "--external-vis", "-o", &none.to_string_lossy()]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("broken.bsp") && !none.exists(), "{}", stderr(&o));
    let o = run(&["vis", &bad.to_string_lossy(), "--external-vis"]);
    assert_eq!(code(&o), 2);
    assert!(stderr(&o).contains("-o"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&bad);
}

#[test]
fn mutated_trees_never_panic_portals_or_vis_from_the_bsp() {
    let Some(dm1) = shared_map("ericw/dm1.bsp") else { return };
    let bytes = std::fs::read(&dm1).expect("read");
    let nodes = read_bsp(&dm1).lumps[sightline_formats::bsp::lump::NODES];
    let dir = temp_dir("mutated-trees");
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for i in 0..6 {
        let mut m = bytes.clone();
        for _ in 0..8 {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let at = nodes.offset + (state >> 33) as usize % nodes.length;
            m[at] ^= 1 << ((state >> 20) % 8);
        }
        let path = dir.join(format!("m{i}.bsp"));
        std::fs::write(&path, &m).expect("write");
        for args in [vec!["portals"], vec!["vis", "--portals-from-bsp", "--fast"]] {
            let o = bin().args(&args).arg(&path).output().expect("runs");
            let c = code(&o);
            assert!(c == 0 || c == 2, "{args:?} on mutation {i}: exit {c}: {}", stderr(&o));
            assert!(!stderr(&o).contains("panicked"), "{args:?} on mutation {i}: {}", stderr(&o));
            if c == 2 {
                assert!(stderr(&o).contains(&format!("m{i}.bsp")), "{}", stderr(&o));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Over `--max-memory`, vis refuses and names `--coarsen` (exit 2); with it, vis merges clusters
/// until the run fits, warns, and reports the merge in JSON, for the same leaves. (Merges are
/// sized for one thread, so that any thread count gives the same PVS.)
#[test]
fn vis_coarsen_merges_clusters_until_it_fits() {
    let Some((dir, prt)) = copy_prt("ericw/dm1.prt", "coarsen", "dm1") else { return };
    let refused = run(&["vis", s(&prt), "--threads", "1", "--max-memory", "2000K"]);
    assert_eq!(code(&refused), 2, "{}", stderr(&refused));
    assert!(stderr(&refused).contains("rerun with --coarsen"), "{}", stderr(&refused));
    assert!(stderr(&refused).contains(&format!("{}: vis would need", prt.display())), "{}", stderr(&refused));
    assert!(!dir.join("dm1.vis").exists());
    let o = run(&["vis", s(&prt), "--threads", "1", "--max-memory", "2000K", "--coarsen", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: vis did not fit its memory or work limit: merged 410 clusters into "),
        "{}",
        stderr(&o)
    );
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let c = &report["vis"]["coarsened"];
    assert_eq!(c["clusters_before"], 410, "{report}");
    let after = c["clusters_after"].as_u64().expect("clusters_after");
    assert!(after > 0 && after < 410, "{report}");
    assert!(c["portals_after"].as_u64().expect("portals_after") < 983, "{report}");
    assert!(c["estimate"].as_u64().expect("estimate") <= 2000 * 1024, "{report}");
    assert_eq!(report["vis"]["leaves"], 415);
    assert!(dir.join("dm1.vis").exists());
}

/// Over `--max-work`, vis refuses up front naming the estimate and `--coarsen` (exit 2, nothing
/// written); with it, clusters merge until the estimate is under the limit, and `--json` reports
/// the input's estimate and the merged one.
#[test]
fn vis_max_work_refuses_or_coarsens_until_the_estimate_is_under() {
    let Some((dir, prt)) = copy_prt("ericw/dm1.prt", "max_work", "dm1") else { return };
    let full = run(&["vis", s(&prt), "--threads", "1", "--json"]);
    assert_eq!(code(&full), 0, "{}", stderr(&full));
    let report: serde_json::Value = serde_json::from_slice(&full.stdout).expect("json");
    let need = report["vis"]["work_estimate"].as_u64().expect("work_estimate");
    assert!(need > 0, "{report}");
    std::fs::remove_file(dir.join("dm1.vis")).expect("remove");
    let limit = (need / 3).to_string();
    let refused = run(&["vis", s(&prt), "--threads", "1", "--max-work", &limit]);
    assert_eq!(code(&refused), 2, "{}", stderr(&refused));
    let err = stderr(&refused);
    assert!(
        err.contains(&format!("estimated {need} portal tests")) && err.contains("rerun with --coarsen"),
        "{err}"
    );
    assert!(err.contains(&format!("{}: vis would take", prt.display())), "names the input: {err}");
    assert!(!dir.join("dm1.vis").exists());
    let o = run(&["vis", s(&prt), "--threads", "1", "--max-work", &limit, "--coarsen", "--json"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    // Said before the work starts, not only in the closing warning.
    let note = "note: vis does not fit its memory or work limit: merging 410 clusters into ";
    assert!(stderr(&o).contains(note), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let c = &report["vis"]["coarsened"];
    assert!(c["work"].as_u64().expect("work") <= need / 3, "{report}");
    assert_eq!(report["vis"]["work_estimate"].as_u64(), Some(need), "{report}");
    assert!(c["clusters_after"].as_u64().expect("clusters_after") < 410, "{report}");
    for bad in ["-1", "lots", "nan"] {
        let o = run(&["vis", s(&prt), "--max-work", bad]);
        assert_eq!(code(&o), 2, "{bad}: {}", stderr(&o));
    }
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

/// Every output that would replace an input, or another output of the same run, is refused
/// before any work with exit 2, whatever the spelling: the same name, `./name`, a symlink, a hard
/// link. Every input is left byte for byte as it was.
#[test]
fn an_output_that_is_an_input_is_refused_before_any_work() {
    let dir = temp_dir("apart");
    let map = dir.join("k.map");
    std::fs::copy(maps().join("two_rooms.map"), &map).expect("copy map");
    let level = dir.join("k.slvl");
    let o = run(&["compile", s(&map), "-o", s(&level), "--no-vis"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let prt = dir.join("k.prt");
    let bsp = dir.join("e.bsp");
    let Some(shared) = shared_map("id_bsp_orig/e1m1.bsp") else { return };
    std::fs::copy(shared, &bsp).expect("copy bsp");
    std::fs::copy(&prt, dir.join("e.prt")).expect("a portal file beside the bsp");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&map, dir.join("link.map")).expect("symlink");
        std::fs::hard_link(&map, dir.join("hard.map")).expect("hard link");
    }
    let dotted = format!("{}/./k.map", s(&dir));
    let link = dir.join("link.map");
    let hard = dir.join("hard.map");
    let e_prt = dir.join("e.prt");
    let png = dir.join("e.png");
    let mut cases: Vec<Vec<&str>> = vec![
        vec!["compile", s(&map), "-o", s(&map)],
        vec!["compile", s(&map), "-o", &dotted],
        vec!["compile", s(&map), "-o", s(&prt)],
        vec!["portals", s(&bsp), "-o", s(&bsp)],
        vec!["render", s(&bsp), "-o", s(&bsp), "--plan", "--from", "0,0,0"],
        vec!["render", s(&level), "-o", s(&e_prt), "--plan", "--from", "0,0,0", "--prt", s(&e_prt)],
        vec!["vis", s(&bsp), "--external-vis", "-o", s(&bsp)],
        vec!["vis", s(&bsp), "--external-vis", "-o", s(&e_prt)],
    ];
    if cfg!(unix) {
        cases.push(vec!["compile", s(&map), "-o", s(&link)]);
        cases.push(vec!["compile", s(&map), "-o", s(&hard)]);
    }
    let before: Vec<(PathBuf, Vec<u8>)> = [&map, &level, &prt, &bsp, &e_prt]
        .iter()
        .map(|p| (p.to_path_buf(), std::fs::read(p).expect("read input")))
        .collect();
    for args in &cases {
        let o = run(args);
        let err = stderr(&o);
        assert_eq!(code(&o), 2, "{args:?} must be refused: {err}");
        assert!(err.contains("would replace that file"), "{args:?}: {err}");
        for (p, bytes) in &before {
            assert_eq!(&std::fs::read(p).expect("still there"), bytes, "{args:?} changed {}", p.display());
        }
        assert!(!png.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A compiled map of another game is named as its own game (one place names games): `portals`
/// on a Quake 2 or Quake 3 file says which it is.
#[test]
fn a_bsp_of_another_game_is_named_by_its_game() {
    for (rel, named) in [("q2/start.bsp", "Quake 2 BSP (IBSP 38)"), ("q3/fan.bsp", "Quake 3 BSP (IBSP 46)")] {
        let Some(path) = shared_map(rel) else { return };
        let dir = temp_dir("other-game");
        let o = run(&["portals", s(&path), "-o", s(&dir.join("x.prt"))]);
        assert_eq!(code(&o), 2, "{}", stderr(&o));
        let line = error_line(&o);
        assert!(line.starts_with(&format!("{}: ", path.display())), "{line}");
        assert!(line.contains(named), "{rel}: {line}");
    }
}

/// A `.bsp` whose name is not UTF-8 finds the portal file beside it, as any other (it once
/// looked for a portal file named ";").
#[cfg(unix)]
#[test]
fn vis_finds_the_portal_file_beside_a_bsp_whose_name_is_not_utf8() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = temp_dir("not-utf8");
    let (bytes, prt) = tiny_bsp();
    let name = |ext: &str| dir.join(OsStr::from_bytes(&[b"m\xff.".as_slice(), ext.as_bytes()].concat()));
    std::fs::write(name("bsp"), &bytes).expect("write");
    std::fs::write(name("prt"), prt).expect("write");
    let o = bin().arg("vis").arg(name("bsp")).arg("--json").output().expect("runs");
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    assert_eq!(stdout_json(&o)["prt_format"], "PRT1", "vis read the portal file beside it");
    // An external `.vis` record would spell another name than the file's: refused, naming it.
    let o = bin().arg("vis").arg(name("bsp")).arg("--external-vis").output().expect("runs");
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(error_line(&o).contains("names its map in UTF-8"), "{}", stderr(&o));
    assert!(!dir.join(OsStr::from_bytes(b"m\xff.vis")).exists());
}

/// `--json` of `sightline compile` and `sightline vis` carries the flow's first time estimate
/// (made from base vis's speed before the flow) beside the real time; `--max-time` is a work
/// limit spelled in time (10^8 portal tests a second): under it with `--coarsen` clusters merge,
/// and the report says how much looser the PVS is and where; bad durations exit 2.
#[test]
fn json_carries_the_flow_estimate_and_max_time_coarsens_with_a_looseness_report() {
    let dir = temp_dir("estimate");
    let map = dir.join("rooms.map");
    let params = sightline_tests::mapgen::MapGenParams { rooms_x: 4, rooms_y: 4, storeys: 2, seed: 7 };
    std::fs::write(&map, sightline_tests::mapgen::generate(&params)).expect("write map");
    let o = run(&["compile", s(&map), "--json", "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let fine = stdout_json(&o);
    let v = &fine["vis"];
    assert!(v["base_tests"].as_u64().expect("base_tests") > 0, "{v}");
    assert!(v["flow_estimate_work"].as_u64().expect("flow_estimate_work") > 0, "{v}");
    assert!(v["flow_estimate_seconds"].as_f64().expect("flow_estimate_seconds") > 0.0, "{v}");
    assert!(v["flow_seconds"].as_f64().expect("flow_seconds") > 0.0, "{v}");
    let prt = dir.join("rooms.prt");
    let o = run(&["vis", s(&prt), "--json", "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let vis = stdout_json(&o);
    assert_eq!(vis["vis"]["flow_estimate_work"], v["flow_estimate_work"], "one estimate for one input");
    let need = v["work_estimate"].as_u64().expect("work_estimate");
    // A budget a tenth of the estimate's time at the fixed rate.
    let budget = format!("{}s", need as f64 / 1e8 / 10.0);
    let refused = run(&["compile", s(&map), "--json", "--max-time", &budget]);
    assert_eq!(code(&refused), 2, "{}", stderr(&refused));
    assert!(stderr(&refused).contains("rerun with --coarsen"), "{}", stderr(&refused));
    let o = run(&["compile", s(&map), "--json", "--max-time", &budget, "--coarsen", "--threads", "2"]);
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let coarse = stdout_json(&o);
    let c = &coarse["vis"]["coarsened"];
    assert!(c["work"].as_u64().expect("work") <= need / 10, "{c}");
    let pairs = coarse["vis"]["visible_pairs"].as_u64().expect("visible_pairs");
    let lower = c["fine_pairs_lower"].as_u64().expect("fine_pairs_lower");
    let fine_pairs = v["visible_pairs"].as_u64().expect("visible_pairs");
    assert!(0 < lower && lower <= fine_pairs && fine_pairs < pairs, "{lower} {fine_pairs} {pairs}");
    assert!(c["pairs_within_groups"].as_u64().expect("pairs_within_groups") <= pairs, "{c}");
    assert!(c["retries"].as_u64().is_some_and(|r| r <= 16), "{c}");
    let groups = c["largest_groups"].as_array().expect("largest_groups");
    assert!(!groups.is_empty() && groups.len() <= 5, "{c}");
    let leaves: Vec<u64> = groups.iter().map(|g| g["leaves"].as_u64().expect("leaves")).collect();
    assert!(leaves.windows(2).all(|w| w[0] >= w[1]), "most leaves first: {leaves:?}");
    for g in groups {
        assert!(g["clusters"].as_u64().expect("clusters") > 1, "{g}");
        for axis in 0..3 {
            let at = |k: &str| g[k][axis].as_f64().expect("coordinate");
            assert!(at("mins") <= at("centre") && at("centre") <= at("maxs"), "{g}");
        }
    }
    for bad in ["15x", "0", "-5m", "5m1h", "soon"] {
        let o = run(&["compile", s(&map), "--max-time", bad]);
        assert_eq!(code(&o), 2, "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("is not a duration"), "{bad}: {}", stderr(&o));
    }
    let both = run(&["vis", s(&prt), "--max-time", "15m", "--max-work", "2e11"]);
    assert_eq!(code(&both), 2, "{}", stderr(&both));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}
