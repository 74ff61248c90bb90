//! Errors name their file and place, once; inputs Quake's tools accept are accepted.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::support::{bin, code, compile, maps, run, s, shared_map, stderr, stdout_json, temp_dir};

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
