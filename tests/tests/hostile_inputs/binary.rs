//! The real `sightline` binary on hostile files: for every format it reads (`.map` in both
//! dialects, `.obj`, `.prt` as PRT1, PRT2 and PRT1-AM, BSP29, BSP2, `.slvl`, vis state files),
//! deterministic mutations of a valid seed (truncations at evenly spaced offsets, the byte
//! mutations of [`sightline_tests::mutate`], and for text huge, non-finite and negative numbers,
//! deep nesting, CRLF line ends and bytes that are not UTF-8) are run through every command that
//! reads the format.
//!
//! Each run is a child process under [`TIMEOUT`] (killed past it) and, through util-linux
//! `prlimit`, an address-space limit of [`MEMORY`] bytes (an allocation past it aborts the child,
//! which fails the test). A run passes when it exits 0, 1 or 2, prints no panic, and on exit 2 its
//! error names the mutated file and a place in it (a number or a place word). Every reader of a
//! compiled map applies the same checks: a mutated `.bsp` that `info` refuses, `vis` and
//! `validate` refuse too. Runs go over two worker threads; the suite's runs take well under a
//! minute on 2 cores.
//!
//! The binary is the one cargo built beside this test (`target/<profile>/sightline`), which
//! `cargo test --workspace` builds; the test says so when it is missing.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use sightline_formats::prt::{self, PrtFormat};
use sightline_formats::{bsp, slvl};
use sightline_job::rng::SplitMix64 as Rng;
use sightline_tests::{mutate, sightline_binary as binary};

/// A run taking longer than this is a hang.
pub(crate) const TIMEOUT: Duration = Duration::from_secs(20);
/// Address space a run may reserve (`RLIMIT_AS`), threads' stacks included.
pub(crate) const MEMORY: u64 = 512 << 20;
/// Mutations per format.
const MUTATIONS: usize = 96;
/// Words that name a place in a file, besides numbers ("whole file" for what only the file as a
/// whole can lack, such as any triangle at all).
const PLACE_WORDS: [&str; 14] = [
    "line",
    "offset",
    "lump",
    "byte",
    "header",
    "field",
    "portal",
    "leaf",
    "entity",
    "brush",
    "face",
    "vertex",
    "magic",
    "whole file",
];

/// One format: the mutated file's name, its seed, files that sit beside it, and the commands
/// (`IN` stands for the mutated file).
struct Format {
    name: &'static str,
    file: &'static str,
    seed: Vec<u8>,
    text: bool,
    header: usize,
    beside: Vec<(&'static str, Vec<u8>)>,
    commands: Vec<Vec<&'static str>>,
}

/// A text mutation: the byte mutations, or a token that breaks naive parsers, or the whole file
/// with CRLF line ends, or deep nesting, or bytes that are not UTF-8.
fn mutate_text(rng: &mut Rng, input: &[u8]) -> Vec<u8> {
    let mut out = input.to_vec();
    let at = rng.below(out.len() + 1);
    match rng.below(6) {
        0 => {
            const TOKENS: [&str; 12] = [
                "99999999999999999999",
                "1e300",
                "nan",
                "-inf",
                "inf",
                "-1",
                "-2147483648",
                "4294967295",
                "{",
                "}",
                "(",
                "\"",
            ];
            let token = TOKENS[rng.below(TOKENS.len())];
            // Replace the number (or word) starting at a random place, or insert the token.
            let end = out[at..].iter().position(|b| b.is_ascii_whitespace()).map_or(out.len(), |n| at + n);
            out.splice(at..end, token.bytes());
        }
        1 => out = String::from_utf8_lossy(input).replace('\n', "\r\n").into_bytes(),
        2 => {
            let open: &[u8] = [&b"{"[..], b"(", b"{\n\"a\" \"b\"\n"][rng.below(3)];
            let nest: Vec<u8> =
                open.iter().copied().cycle().take(open.len() * (1000 + rng.below(20_000))).collect();
            out.splice(at..at, nest);
        }
        3 => {
            out.splice(at..at, [0xff, 0xfe, 0x80, 0xc3]);
        }
        4 => out.truncate(at),
        _ => out = mutate(rng, input, 64),
    }
    out
}

fn seeds_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-hostile-bin-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Whether util-linux `prlimit` runs here (without it, runs are not memory-bounded).
pub(crate) fn have_prlimit() -> bool {
    let ok = Command::new("prlimit").arg("--version").output().is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("note: util-linux prlimit not found: runs are not memory-bounded");
    }
    ok
}

/// Runs the binary in `dir` and waits (killing it past [`TIMEOUT`]); `None` on a timeout.
/// Its output goes to `stdout.txt` and `stderr.txt` in `dir`.
fn run(bin: &Path, prlimit: bool, args: &[String], dir: &Path) -> Option<ExitStatus> {
    run_logged(bin, prlimit, args, dir, dir)
}

/// [`run`] with the output in `logs` (so that the folder the run works in gets no file of the
/// test's): `stdout.txt` and `stderr.txt`. Under `prlimit` the address space is [`MEMORY`].
pub(crate) fn run_logged(
    bin: &Path,
    prlimit: bool,
    args: &[String],
    dir: &Path,
    logs: &Path,
) -> Option<ExitStatus> {
    let out = File::create(logs.join("stdout.txt")).expect("stdout file");
    let err = File::create(logs.join("stderr.txt")).expect("stderr file");
    let mut cmd = if prlimit {
        let mut c = Command::new("prlimit");
        c.arg(format!("--as={MEMORY}")).arg("--").arg(bin);
        c
    } else {
        Command::new(bin)
    };
    let mut child =
        cmd.args(args).current_dir(dir).stdin(Stdio::null()).stdout(out).stderr(err).spawn().expect("spawn");
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            return Some(status);
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Runs `args` in a fresh folder (seed files written first) and returns what went wrong, if
/// anything, and whether the run refused its input (exit 2).
fn check(
    bin: &Path,
    prlimit: bool,
    dir: &Path,
    files: &[(&str, &[u8])],
    args: &[String],
    file: &str,
) -> (Option<String>, bool) {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).expect("case dir");
    for (name, data) in files {
        std::fs::write(dir.join(name), data).expect("write case file");
    }
    let status = run(bin, prlimit, args, dir);
    let stderr = std::fs::read(dir.join("stderr.txt")).map(|b| String::from_utf8_lossy(&b).into_owned());
    let stderr = stderr.unwrap_or_default();
    let problem = match status.map(|s| s.code()) {
        None => Some(format!("no exit within {TIMEOUT:?}")),
        Some(None) => {
            Some(format!("killed by a signal (abort past {MEMORY} bytes of address space?): {status:?}"))
        }
        Some(Some(c)) if !(0..=2).contains(&c) => Some(format!("exit code {c}")),
        _ if stderr.contains("panicked") => Some("panicked".to_string()),
        Some(Some(2)) if !stderr.contains(file) => Some(format!("exit 2 without naming {file}")),
        Some(Some(2)) => {
            let rest = stderr.replace(&dir.display().to_string(), "").replace(file, "");
            let lower = rest.to_lowercase();
            let place =
                rest.bytes().any(|b| b.is_ascii_digit()) || PLACE_WORDS.iter().any(|w| lower.contains(w));
            (!place).then(|| "exit 2 without a place in the file".to_string())
        }
        _ => None,
    };
    let refused = matches!(status.map(|s| s.code()), Some(Some(2)));
    let lines = stderr.trim().lines().take(3).collect::<Vec<_>>().join("\n  ");
    (problem.map(|p| format!("{p}\n  stderr: {lines}")), refused)
}

/// Seeds made by the binary from the bundled maps, and the small ericw test BSP when the shared
/// maps are present.
fn formats(bin: &Path, dir: &Path) -> Vec<Format> {
    let maps = sightline_tests::bundled_maps();
    let read = |p: &Path| std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let made = |args: &[&str]| {
        let status = Command::new(bin).args(args).current_dir(dir).output().expect("seed run");
        assert!(status.status.code().is_some_and(|c| c <= 2), "{args:?}: {status:?}");
    };
    let map = |name: &str| maps.join(name).display().to_string();
    made(&["compile", &map("two_rooms.map"), "-o", "rooms.slvl", "--threads", "1"]);
    made(&["compile", &map("detail_water.map"), "-o", "water.slvl", "--no-vis"]);
    made(&["compile", &map("stairs_pillars.map"), "-o", "stairs.slvl", "--no-vis"]);
    made(&["vis", "stairs.prt", "--threads", "1", "--state", "stairs.state", "--stop-after", "1"]);
    let prt1 = read(&dir.join("rooms.prt"));
    let prt2 = read(&dir.join("water.prt"));
    let mut am = prt::read_bytes(&prt2, "water.prt").expect("PRT2 seed reads");
    assert_eq!(am.format, PrtFormat::Prt2);
    am.format = PrtFormat::Prt1Am;
    let prt1am = prt::write(&am).into_bytes();
    let state = read(&dir.join("stairs.state"));
    let stairs_prt = read(&dir.join("stairs.prt"));

    let map_cmds = vec![
        vec!["compile", "IN", "-o", "out.slvl", "--threads", "1"],
        vec!["info", "IN"],
        vec!["render", "IN", "-o", "out.png", "--size", "32x24", "--view", "0,0,64"],
    ];
    let text = |name, file, seed: Vec<u8>, commands: Vec<Vec<&'static str>>| Format {
        name,
        file,
        seed,
        text: true,
        header: 64,
        beside: Vec::new(),
        commands,
    };
    let prt_cmds = || vec![vec!["vis", "IN", "--threads", "1"], vec!["info", "IN"]];
    let mut all = vec![
        text("map", "hostile.map", read(&maps.join("two_rooms.map")), map_cmds.clone()),
        text("map220", "hostile.map", read(&maps.join("valve220.map")), map_cmds),
        text(
            "obj",
            "hostile.obj",
            read(&maps.join("scene.obj")),
            vec![
                vec!["compile", "IN", "-o", "out.slvl", "--threads", "1"],
                vec!["info", "IN"],
                vec![
                    "gvs",
                    "IN",
                    "--cell",
                    "128",
                    "--views",
                    "0",
                    "--max-cells",
                    "1",
                    "--max-rays",
                    "2000",
                    "--threads",
                    "1",
                ],
            ],
        ),
        text("prt1", "hostile.prt", prt1, prt_cmds()),
        text("prt2", "hostile.prt", prt2, prt_cmds()),
        text("prt1-am", "hostile.prt", prt1am, prt_cmds()),
        Format {
            name: "slvl",
            file: "hostile.slvl",
            seed: read(&dir.join("rooms.slvl")),
            text: false,
            header: slvl::HEADER_BYTES,
            beside: Vec::new(),
            commands: vec![
                vec!["validate", "IN", "--rays", "2000", "--threads", "1"],
                vec!["info", "IN"],
                vec!["render", "IN", "-o", "out.png", "--size", "32x24", "--view", "0,0,64"],
                vec!["bench", "IN", "--frames", "20"],
                vec![
                    "gvs",
                    "IN",
                    "--cell",
                    "leaves",
                    "--views",
                    "0",
                    "--max-cells",
                    "1",
                    "--max-rays",
                    "2000",
                    "--threads",
                    "1",
                ],
            ],
        },
        Format {
            name: "state",
            file: "hostile.state",
            seed: state,
            text: false,
            header: 64,
            beside: vec![("stairs.prt", stairs_prt)],
            commands: vec![vec!["vis", "stairs.prt", "--threads", "1", "--state", "IN"]],
        },
    ];
    let shared = sightline_tests::shared_map("ericw-testmaps/q1_vis_noambient_func_group.bsp");
    if let Some(path) = shared {
        let bsp29 = read(&path);
        let parsed = bsp::read(&bsp29).expect("seed BSP reads");
        let bsp2 = sightline_tests::widen_bsp(&bsp29, &parsed, false);
        let prt = read(&path.with_extension("prt"));
        for (name, seed) in [("bsp29", bsp29), ("bsp2", bsp2)] {
            all.push(Format {
                name,
                file: "hostile.bsp",
                seed,
                text: false,
                header: bsp::HEADER_BYTES,
                beside: vec![("hostile.prt", prt.clone())],
                commands: vec![
                    vec!["vis", "IN", "--threads", "1"],
                    vec!["info", "IN"],
                    vec!["validate", "IN", "--rays", "2000", "--threads", "1"],
                    vec!["render", "IN", "-o", "out.png", "--size", "32x24", "--pvs-matrix"],
                    vec!["bench", "IN", "--frames", "20"],
                ],
            });
        }
    }
    // The other families: Half-Life (BSP30 with SDHLT's portal dialect), Quake 2 and Quake 3,
    // each as a mutated BSP beside its good portal file and as a mutated portal file beside its
    // good BSP.
    let family = [
        ("bsp30", "vhlt-prt", "hl/lq_e0m1.sdhlt.bsp", bsp::HEADER_BYTES, true),
        ("ibsp38", "q2-prt1", "ericw-testmaps/q2_detail_leak_test.bsp", bsp::q2::HEADER_BYTES, false),
        ("ibsp46", "q3map2-prt", "q3/fan.bsp", bsp::q3::HEADER_BYTES, false),
    ];
    for (name, prt_name, rel, header, portals) in family {
        let Some(path) = sightline_tests::shared_map(rel) else { continue };
        let (bsp_bytes, prt_bytes) = (read(&path), read(&path.with_extension("prt")));
        let mut bsp_cmds = vec![
            vec!["vis", "IN", "--threads", "1"],
            vec!["info", "IN"],
            vec!["validate", "IN", "--rays", "2000", "--threads", "1"],
        ];
        if portals {
            bsp_cmds.push(vec!["portals", "IN", "-o", "out.prt"]);
        }
        all.push(Format {
            name,
            file: "hostile.bsp",
            seed: bsp_bytes.clone(),
            text: false,
            header,
            beside: vec![("hostile.prt", prt_bytes.clone())],
            commands: bsp_cmds,
        });
        all.push(Format {
            name: prt_name,
            file: "hostile.prt",
            seed: prt_bytes,
            text: true,
            header: 64,
            beside: vec![("hostile.bsp", bsp_bytes)],
            commands: vec![vec!["vis", "hostile.bsp", "--threads", "1"], vec!["info", "IN"]],
        });
    }
    // A vised Quake 2 file, for the PHS alone (`--phs-only` reads the file as vis does).
    if let Some(path) = sightline_tests::shared_map("ericw-testmaps/q2_detail_leak_test.ericw.bsp") {
        all.push(Format {
            name: "ibsp38-vised",
            file: "hostile.bsp",
            seed: read(&path),
            text: false,
            header: bsp::q2::HEADER_BYTES,
            beside: Vec::new(),
            commands: vec![
                vec!["vis", "IN", "--phs-only"],
                vec!["info", "IN"],
                vec!["validate", "IN", "--rays", "2000", "--threads", "1"],
            ],
        });
    }
    all
}

#[test]
fn every_command_on_every_format_exits_0_1_or_2_naming_file_and_place() {
    let bin = binary();
    let dir = seeds_dir();
    let prlimit = have_prlimit();
    let formats = formats(&bin, &dir);
    // Every job: (format, mutation index, mutated bytes, command), drawn in order from one stream
    // per format so the set does not depend on thread timing.
    let mut jobs = Vec::new();
    for (f, format) in formats.iter().enumerate() {
        let mut rng = Rng::keyed(0x4057_11e5, f as u64, 0);
        for i in 0..MUTATIONS {
            let data = if i < MUTATIONS / 4 {
                // Truncations at evenly spaced offsets.
                format.seed[..format.seed.len() * i / (MUTATIONS / 4)].to_vec()
            } else if format.text {
                mutate_text(&mut rng, &format.seed)
            } else {
                mutate(&mut rng, &format.seed, format.header)
            };
            for c in 0..format.commands.len() {
                jobs.push((f, i, c, data.clone()));
            }
        }
    }
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let refused: Vec<AtomicUsize> = formats.iter().map(|_| AtomicUsize::new(0)).collect();
    // Which (format, mutation, command) runs refused their input.
    let refusals = Mutex::new(std::collections::BTreeSet::new());
    std::thread::scope(|s| {
        for worker in 0..2 {
            let (jobs, formats, next, failures, refused) = (&jobs, &formats, &next, &failures, &refused);
            let refusals = &refusals;
            let (bin, dir) = (&bin, &dir);
            s.spawn(move || {
                let case = dir.join(format!("worker{worker}"));
                while let Some((f, i, c, data)) = jobs.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let format = &formats[*f];
                    let mut files: Vec<(&str, &[u8])> =
                        format.beside.iter().map(|(n, d)| (*n, d.as_slice())).collect();
                    files.push((format.file, data));
                    let args: Vec<String> = format.commands[*c]
                        .iter()
                        .map(|a| if *a == "IN" { format.file.to_string() } else { (*a).to_string() })
                        .collect();
                    let (problem, was_refused) = check(bin, prlimit, &case, &files, &args, format.file);
                    if was_refused {
                        refused[*f].fetch_add(1, Ordering::Relaxed);
                        refusals.lock().expect("refusals").insert((*f, *i, *c));
                    }
                    if let Some(problem) = problem {
                        let kept = dir.join(format!("fail-{}-{i}-{c}-{}", format.name, format.file));
                        let _ = std::fs::write(&kept, data);
                        let line =
                            format!("{} mutation {i}: sightline {}: {problem}", format.name, args.join(" "));
                        failures.lock().expect("failures").push((*f, *i, *c, line));
                    }
                }
            });
        }
    });
    let mut failures = failures.into_inner().expect("failures");
    // One set of checks for every reader: a compiled map `info` refuses, `vis` and `validate`
    // refuse too (vis once rewrote Quake 2 files whose planes, edges or faces the others refuse).
    let refusals = refusals.into_inner().expect("refusals");
    for (f, format) in formats.iter().enumerate().filter(|(_, format)| format.file.ends_with(".bsp")) {
        let command = |name: &str| format.commands.iter().position(|c| c[0] == name && c[1] == "IN");
        let Some(info) = command("info") else { continue };
        for other in ["vis", "validate"].into_iter().filter_map(command) {
            for i in (0..MUTATIONS).filter(|&i| refusals.contains(&(f, i, info))) {
                if !refusals.contains(&(f, i, other)) {
                    let line = format!(
                        "{} mutation {i}: `info` refuses it but `{}` takes it",
                        format.name,
                        format.commands[other].join(" ")
                    );
                    failures.push((f, i, other, line));
                }
            }
        }
    }
    failures.sort_by_key(|(f, i, c, _)| (*f, *i, *c));
    let count = failures.len();
    let list: Vec<String> = failures.into_iter().take(25).map(|(.., l)| l).collect();
    for (format, n) in formats.iter().zip(&refused) {
        let n = n.load(Ordering::Relaxed);
        let runs = MUTATIONS * format.commands.len();
        eprintln!("{}: {n} of {runs} runs refused their input (exit 2)", format.name);
        assert!(n > 0, "{}: no mutation was refused, so the suite checked no error message", format.name);
    }
    eprintln!("{} runs over {} formats; {count} failed", jobs.len(), formats.len());
    assert!(
        count == 0,
        "{count} of {} runs failed; failing inputs kept in {}:\n{}",
        jobs.len(),
        dir.display(),
        list.join("\n")
    );
    let _ = std::fs::remove_dir_all(&dir);
}
