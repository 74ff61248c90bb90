//! The real binary's outputs and inputs at hostile places, for every command that writes a file
//! (compile of a `.map` and of an `.obj`, portals, render, vis in place, vis with an external
//! `.vis`, vis of a portal file, gvs) and every command that reads one:
//!
//! - an output that is one of the run's inputs, spelled as the same path, as `./name`, as a
//!   symlink to it or as a hard link to it, and two outputs of one run at the same file: refused
//!   with exit 2 before any work, the error naming both files, and the folder left as it was (every
//!   file's bytes, every link, no new file);
//! - an output through a symlink: the link is kept and the file it leads to gets the bytes a plain
//!   run writes; a character device (a null device): written directly, still a device after; a
//!   FIFO: refused with exit 2, never waited on; an in-place vis of a symlinked `.bsp` vises the
//!   file it leads to and keeps the link;
//! - a FIFO, a folder, `/dev/zero` and a symlink to `/dev/zero` as any input (the main file, a
//!   portal file, a pointfile, a vis checkpoint): refused with exit 2, naming it, never waited on
//!   or read without end; a FIFO where a file beside the input is looked for (a `.prt`, a
//!   `NAME.texinfo.json`): refused by name when the run needs it, passed over when it is optional.
//!
//! Every run is the binary under `prlimit` and a timeout ([`super::binary::run_logged`]). The
//! cases on a Quake `.bsp` need the shared maps and are skipped (saying so) without them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use super::binary::{TIMEOUT, have_prlimit, run_logged};
use sightline_formats::hash::{FNV_OFFSET, fnv1a};
use sightline_tests::sightline_binary as binary;

/// What a folder holds, entry by entry: a file's bytes, a link's target, or the kind of anything
/// else.
type Snapshot = BTreeMap<String, String>;

fn snapshot(dir: &Path) -> Snapshot {
    let mut all = Snapshot::new();
    for entry in std::fs::read_dir(dir).expect("list").map(|e| e.expect("entry")) {
        let path = entry.path();
        let meta = std::fs::symlink_metadata(&path).expect("metadata");
        let what = if meta.file_type().is_symlink() {
            format!("link to {}", std::fs::read_link(&path).expect("link").display())
        } else if meta.is_file() {
            let bytes = std::fs::read(&path).expect("read");
            format!("file of {} bytes, hash {:016x}", bytes.len(), fnv1a(&bytes, FNV_OFFSET))
        } else if meta.is_dir() {
            format!("folder with {:?}", snapshot(&path))
        } else {
            format!("special {:?}", meta.file_type())
        };
        all.insert(entry.file_name().to_string_lossy().into_owned(), what);
    }
    all
}

/// A folder for runs and another for their logs.
struct Bench {
    bin: PathBuf,
    prlimit: bool,
    root: PathBuf,
    logs: PathBuf,
}

impl Bench {
    fn new(tag: &str) -> Self {
        let root = std::env::temp_dir().join(format!("sightline-hostile-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let logs = root.join("logs");
        std::fs::create_dir_all(&logs).expect("logs dir");
        Self { bin: binary(), prlimit: have_prlimit(), root, logs }
    }

    /// A fresh folder `name` under the root.
    fn dir(&self, name: &str) -> PathBuf {
        let d = self.root.join(name);
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("case dir");
        d
    }

    /// Runs `args` in `dir`: the exit code (`None` for a hang or a signal) and stderr.
    fn run(&self, dir: &Path, args: &[&str]) -> (Option<i32>, String) {
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        let status = run_logged(&self.bin, self.prlimit, &args, dir, &self.logs);
        let stderr = std::fs::read(self.logs.join("stderr.txt")).unwrap_or_default();
        (status.and_then(|s| s.code()), String::from_utf8_lossy(&stderr).into_owned())
    }

    /// Runs `args` in `dir`, which must succeed (exit 0).
    fn ok(&self, dir: &Path, args: &[&str]) {
        let (code, stderr) = self.run(dir, args);
        assert_eq!(code, Some(0), "sightline {}: {stderr}", args.join(" "));
    }
}

impl Drop for Bench {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.root);
        }
    }
}

/// The inputs every case starts from, in `dir`: `k.map`, `k.obj`, `r.slvl` and its `r.prt`, a
/// portal file alone `p.prt`, and with the shared maps a Quake `e.bsp` with its `e.prt`. Returns
/// whether the `.bsp` is there.
fn inputs(b: &Bench, dir: &Path) -> bool {
    let maps = sightline_tests::bundled_maps();
    std::fs::copy(maps.join("two_rooms.map"), dir.join("k.map")).expect("map");
    std::fs::copy(maps.join("scene.obj"), dir.join("k.obj")).expect("obj");
    b.ok(dir, &["compile", "k.map", "-o", "r.slvl", "--no-vis", "--threads", "1"]);
    std::fs::copy(dir.join("r.prt"), dir.join("p.prt")).expect("prt");
    let Some(bsp) = sightline_tests::shared_map("ericw-testmaps/q1_vis_noambient_func_group.bsp") else {
        return false;
    };
    std::fs::copy(&bsp, dir.join("e.bsp")).expect("bsp");
    std::fs::copy(bsp.with_extension("prt"), dir.join("e.prt")).expect("its prt");
    true
}

/// GVS arguments for a short run. (Pictures are rendered small, `--size 64x48`, so that their
/// memory never decides a run under `prlimit`.)
const GVS: [&str; 8] = ["--views", "0", "--max-cells", "1", "--max-rays", "2000", "--threads", "1"];

/// `template` with `OUT` (or `IN`) replaced by `name`.
fn fill<'a>(template: &[&'a str], name: &'a str) -> Vec<&'a str> {
    template.iter().map(|&w| if w == "OUT" || w == "IN" { name } else { w }).collect()
}

#[test]
fn an_output_that_is_an_input_or_another_output_is_refused_leaving_the_folder_as_it_was() {
    let b = Bench::new("apart");
    let dir = b.dir("work");
    let bsp = inputs(&b, &dir);
    let mut cases: Vec<(&str, Vec<&str>)> = vec![
        ("k.map", vec!["compile", "k.map", "-o", "OUT"]),
        ("k.obj", vec!["compile", "k.obj", "-o", "OUT"]),
        ("k.map", vec!["compile", "k.map", "-o", "o.slvl", "--state", "OUT"]),
        ("r.slvl", vec!["render", "r.slvl", "-o", "OUT", "--plan", "--size", "64x48"]),
        ("p.prt", vec!["render", "r.slvl", "-o", "OUT", "--plan", "--size", "64x48", "--prt", "p.prt"]),
        ("p.prt", vec!["vis", "p.prt", "--state", "OUT"]),
        ("r.slvl", [&["gvs", "r.slvl", "--cell", "leaves", "-o", "OUT"][..], &GVS].concat()),
        ("k.obj", [&["gvs", "k.obj", "--cell", "64", "-o", "OUT"][..], &GVS].concat()),
    ];
    if bsp {
        cases.extend([
            ("e.bsp", vec!["portals", "e.bsp", "-o", "OUT"]),
            ("e.bsp", vec!["render", "e.bsp", "-o", "OUT", "--pvs-matrix", "--size", "64x48"]),
            ("e.bsp", vec!["vis", "e.bsp", "--state", "OUT"]),
            ("e.prt", vec!["vis", "e.bsp", "--state", "OUT"]),
            ("e.bsp", vec!["vis", "e.bsp", "--external-vis", "-o", "OUT"]),
            ("e.prt", vec!["vis", "e.bsp", "--external-vis", "-o", "OUT"]),
        ]);
    }
    // Every spelling of each input: the same path, `./name`, a symlink, a hard link.
    let names: Vec<&str> = cases.iter().map(|c| c.0).collect();
    for name in &names {
        let (link, hard) = (dir.join(format!("link-{name}")), dir.join(format!("hard-{name}")));
        if !link.exists() {
            std::os::unix::fs::symlink(name, &link).expect("symlink");
            std::fs::hard_link(dir.join(name), &hard).expect("hard link");
        }
    }
    // An existing output reached twice: through a symlink and a hard link to it.
    std::fs::write(dir.join("old.slvl"), b"an older level").expect("old output");
    std::os::unix::fs::symlink("old.slvl", dir.join("link-old.state")).expect("symlink");
    std::fs::hard_link(dir.join("old.slvl"), dir.join("hard-old.state")).expect("hard link");
    // Two outputs of one run at one place: (the command, the names its error must give).
    let mut twice: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (vec!["compile", "k.map", "-o", "k2.prt"], vec!["k2.prt"]),
        (vec!["compile", "k.obj", "-o", "o.slvl", "--state", "o.prt"], vec!["o.prt"]),
        (vec!["compile", "k.map", "-o", "o.slvl", "--state", "./o.pts"], vec!["./o.pts", "o.pts"]),
        (
            vec!["compile", "k.map", "-o", "old.slvl", "--state", "link-old.state"],
            vec!["link-old.state", "old.slvl"],
        ),
        (
            vec!["compile", "k.map", "-o", "old.slvl", "--state", "hard-old.state"],
            vec!["hard-old.state", "old.slvl"],
        ),
        (vec!["vis", "p.prt", "--state", "p.vis"], vec!["p.vis"]),
    ];
    if bsp {
        twice.push((
            vec!["vis", "e.bsp", "--external-vis", "-o", "x.vis", "--state", "./x.vis"],
            vec!["./x.vis", "x.vis"],
        ));
    }
    let before = snapshot(&dir);
    let mut failures = Vec::new();
    let mut check = |args: &[&str], named: &[&str]| {
        let (code, stderr) = b.run(&dir, args);
        let line = format!("sightline {}", args.join(" "));
        if code != Some(2) {
            failures.push(format!("{line}: exit {code:?}, not 2: {stderr}"));
        } else if let Some(missing) = named.iter().find(|n| !stderr.contains(*n)) {
            failures.push(format!("{line}: the error does not name {missing}: {stderr}"));
        } else if stderr.contains("panicked") {
            failures.push(format!("{line}: panicked"));
        }
        let after = snapshot(&dir);
        if after != before {
            let changed: Vec<&String> =
                before.keys().chain(after.keys()).filter(|k| before.get(*k) != after.get(*k)).collect();
            failures.push(format!("{line}: the folder changed at {changed:?}"));
        }
    };
    for (input, template) in &cases {
        let spellings =
            [input.to_string(), format!("./{input}"), format!("link-{input}"), format!("hard-{input}")];
        for out in &spellings {
            check(&fill(template, out), &[out.as_str(), input]);
        }
    }
    for (args, named) in &twice {
        check(args, named);
    }
    let runs = cases.len() * 4 + twice.len();
    assert!(failures.is_empty(), "{} of {runs} runs failed:\n{}", failures.len(), failures.join("\n"));
}

/// The writing commands, each with `OUT` for its output and the extension of that output.
fn writers(bsp: bool) -> Vec<(&'static str, Vec<&'static str>)> {
    let mut all = vec![
        ("slvl", vec!["compile", "k.map", "-o", "OUT", "--no-vis", "--threads", "1"]),
        ("png", vec!["render", "r.slvl", "-o", "OUT", "--pvs-matrix", "--size", "32x32"]),
        ("slvl", [&["gvs", "k.obj", "--cell", "64", "-o", "OUT"][..], &GVS].concat()),
    ];
    if bsp {
        all.push(("prt", vec!["portals", "e.bsp", "-o", "OUT"]));
        all.push(("vis", vec!["vis", "e.bsp", "--external-vis", "-o", "OUT", "--threads", "1"]));
    }
    all
}

#[test]
fn outputs_go_where_they_point_a_link_kept_a_device_written_a_fifo_refused() {
    let b = Bench::new("targets");
    let dir = b.dir("work");
    let bsp = inputs(&b, &dir);
    let real = dir.join("real");
    std::fs::create_dir_all(&real).expect("real dir");
    // A null device of our own when this user may make one (then nothing the test could do to
    // it reaches the system's), else the system's.
    let own = Command::new("mknod").arg(dir.join("null")).args(["c", "1", "3"]).status();
    let null = if own.is_ok_and(|s| s.success()) { dir.join("null") } else { PathBuf::from("/dev/null") };
    let null = null.to_str().expect("utf-8 path");
    for (i, (ext, template)) in writers(bsp).into_iter().enumerate() {
        let plain = format!("plain{i}.{ext}");
        b.ok(&dir, &fill(&template, &plain));
        let want = std::fs::read(dir.join(&plain)).expect("plain output");
        // Through a symlink: the link kept, its file holding what the plain run wrote.
        let target = real.join(format!("out{i}.{ext}"));
        std::fs::write(&target, b"older").expect("target");
        let link = format!("link{i}.{ext}");
        std::os::unix::fs::symlink(&target, dir.join(&link)).expect("symlink");
        b.ok(&dir, &fill(&template, &link));
        let meta = std::fs::symlink_metadata(dir.join(&link)).expect("link");
        assert!(meta.file_type().is_symlink(), "{template:?}: the link was replaced");
        assert_eq!(std::fs::read_link(dir.join(&link)).expect("link"), target);
        assert!(std::fs::read(&target).expect("target") == want, "{template:?}: the link's file");
        // A character device: written directly, still a device (not for compile, which writes
        // its portal file beside the level: beside a device is the device's folder).
        if template[0] != "compile" {
            b.ok(&dir, &fill(&template, null));
            let kind = std::fs::metadata(null).expect("null").file_type();
            assert!(std::os::unix::fs::FileTypeExt::is_char_device(&kind), "{template:?}: {null}");
        }
        // A FIFO: refused, not waited on.
        let fifo = format!("fifo{i}.{ext}");
        let made = Command::new("mkfifo").arg(dir.join(&fifo)).status().expect("mkfifo");
        assert!(made.success());
        let before = snapshot(&dir);
        let (code, stderr) = b.run(&dir, &fill(&template, &fifo));
        assert_eq!(code, Some(2), "{template:?} into a FIFO (None: it waited past {TIMEOUT:?}): {stderr}");
        assert!(stderr.contains(&fifo) && !stderr.contains("panicked"), "{template:?}: {stderr}");
        assert_eq!(snapshot(&dir), before, "{template:?} into a FIFO wrote something");
    }
}

#[test]
fn vis_in_place_of_a_symlinked_bsp_vises_its_file_and_keeps_the_link() {
    let b = Bench::new("inplace");
    let plain = b.dir("plain");
    if !inputs(&b, &plain) {
        return;
    }
    let dir = b.dir("linked");
    let real = dir.join("real");
    std::fs::create_dir_all(&real).expect("real dir");
    for f in ["e.bsp", "e.prt"] {
        std::fs::copy(plain.join(f), real.join(f)).expect("copy");
    }
    std::os::unix::fs::symlink("real/e.bsp", dir.join("l.bsp")).expect("symlink");
    std::os::unix::fs::symlink("real/e.prt", dir.join("l.prt")).expect("symlink");
    b.ok(&plain, &["vis", "e.bsp", "--threads", "1"]);
    b.ok(&dir, &["vis", "l.bsp", "--threads", "1"]);
    for (link, target) in [("l.bsp", "real/e.bsp"), ("l.prt", "real/e.prt")] {
        assert_eq!(std::fs::read_link(dir.join(link)).expect("still a link"), Path::new(target));
    }
    let vised = std::fs::read(real.join("e.bsp")).expect("vised");
    assert!(vised == std::fs::read(plain.join("e.bsp")).expect("plain"), "the link's file holds the vis");
    let names: Vec<String> = snapshot(&dir).into_keys().collect();
    assert_eq!(names, ["l.bsp", "l.prt", "real"], "nothing else written beside the link");
}

#[test]
fn a_fifo_a_folder_or_a_device_as_any_input_is_refused_naming_it() {
    let b = Bench::new("special-in");
    let dir = b.dir("work");
    let bsp = inputs(&b, &dir);
    // (the extension of the input, the command with `IN` for it)
    let mut cases: Vec<(&str, Vec<&str>)> = vec![
        ("map", vec!["compile", "IN", "-o", "o.slvl"]),
        ("obj", vec!["compile", "IN", "-o", "o.slvl"]),
        ("prt", vec!["vis", "IN", "--threads", "1"]),
        ("slvl", vec!["validate", "IN", "--rays", "100"]),
        ("slvl", vec!["info", "IN"]),
        ("map", vec!["info", "IN"]),
        ("slvl", vec!["render", "IN", "-o", "o.png", "--pvs-matrix", "--size", "64x48"]),
        ("map", vec!["render", "IN", "-o", "o.png", "--plan", "--size", "64x48"]),
        ("slvl", vec!["bench", "IN", "--frames", "10"]),
        ("slvl", [&["gvs", "IN", "--cell", "leaves"][..], &GVS].concat()),
        ("obj", [&["gvs", "IN", "--cell", "64"][..], &GVS].concat()),
        // The other files a run reads.
        ("state", vec!["vis", "p.prt", "--state", "IN", "--threads", "1"]),
        ("state", vec!["compile", "k.map", "-o", "o.slvl", "--state", "IN"]),
        ("prt", vec!["render", "r.slvl", "-o", "o.png", "--plan", "--size", "64x48", "--prt", "IN"]),
        ("pts", vec!["render", "r.slvl", "-o", "o.png", "--leak", "IN", "--size", "64x48"]),
    ];
    if bsp {
        cases.extend([
            ("bsp", vec!["vis", "IN", "--threads", "1"]),
            ("bsp", vec!["portals", "IN", "-o", "o.prt"]),
            ("bsp", vec!["validate", "IN", "--rays", "100"]),
            ("bsp", vec!["info", "IN"]),
            ("bsp", vec!["bench", "IN", "--frames", "10"]),
        ]);
    }
    let mut failures = Vec::new();
    let mut runs = 0;
    for (ext, template) in &cases {
        // Made fresh for each case: a FIFO, a folder, and a link to /dev/zero named as the input.
        let (fifo, folder, zero) = (format!("pipe.{ext}"), format!("folder.{ext}"), format!("zero.{ext}"));
        for f in [&fifo, &folder, &zero] {
            let p = dir.join(f);
            let _ = std::fs::remove_file(&p).or_else(|_| std::fs::remove_dir(&p));
        }
        assert!(Command::new("mkfifo").arg(dir.join(&fifo)).status().expect("mkfifo").success());
        std::fs::create_dir(dir.join(&folder)).expect("folder");
        std::os::unix::fs::symlink("/dev/zero", dir.join(&zero)).expect("symlink");
        for input in [fifo.as_str(), folder.as_str(), zero.as_str(), "/dev/zero"] {
            let args = fill(template, input);
            let before = snapshot(&dir);
            let (code, stderr) = b.run(&dir, &args);
            runs += 1;
            let line = format!("sightline {}", args.join(" "));
            if code != Some(2) {
                failures.push(format!(
                    "{line}: exit {code:?}, not 2 (None: no exit within {TIMEOUT:?}): {stderr}"
                ));
            } else if !stderr.contains(input) || stderr.contains("panicked") {
                failures.push(format!("{line}: the error does not name {input}: {stderr}"));
            }
            if snapshot(&dir) != before {
                failures.push(format!("{line}: the folder changed"));
            }
        }
    }
    assert!(failures.is_empty(), "{} of {runs} runs failed:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn a_fifo_beside_an_input_is_never_waited_on() {
    let b = Bench::new("special-beside");
    let dir = b.dir("work");
    let bsp = inputs(&b, &dir);
    let fifo = |name: &str| {
        let p = dir.join(name);
        let _ = std::fs::remove_file(&p);
        assert!(Command::new("mkfifo").arg(&p).status().expect("mkfifo").success());
    };
    // The level's own portal file, which info compares with the fingerprint the level records.
    fifo("r.prt");
    let (code, stderr) = b.run(&dir, &["info", "r.slvl"]);
    assert_eq!(code, Some(0), "info beside a FIFO (None: it waited past {TIMEOUT:?}): {stderr}");
    if bsp {
        // The portal file and the texinfo side file vis reads beside a `.bsp`: refused by name.
        let prt = std::fs::read(dir.join("e.prt")).expect("e.prt");
        for side in ["e.prt", "e.texinfo.json"] {
            fifo(side);
            let (code, stderr) = b.run(&dir, &["vis", "e.bsp", "--threads", "1"]);
            assert_eq!(code, Some(2), "vis beside a FIFO {side} (None: it waited): {stderr}");
            assert!(stderr.contains(side) && stderr.contains("FIFO"), "{stderr}");
            std::fs::remove_file(dir.join(side)).expect("remove");
            std::fs::write(dir.join("e.prt"), &prt).expect("the portal file back");
        }
        // The runtime's optional portal file beside a `.bsp`: passed over, not waited on.
        fifo("e.prt");
        let (code, stderr) = b.run(&dir, &["bench", "e.bsp", "--frames", "10"]);
        assert_eq!(code, Some(0), "bench beside a FIFO portal file (None: it waited): {stderr}");
    }
    // A FIFO given as bench's poses file: refused by name, never opened.
    fifo("poses.txt");
    let (code, stderr) = b.run(&dir, &["bench", "r.slvl", "--poses-file", "poses.txt"]);
    assert_eq!(code, Some(2), "bench --poses-file on a FIFO (None: it waited): {stderr}");
    assert!(stderr.contains("poses.txt") && stderr.contains("FIFO"), "{stderr}");
}
