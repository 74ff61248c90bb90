//! `sightline compile` end to end: the leaking map, bad input, JSON, determinism across threads.
//! The command line runs as the real binary ([`sightline_tests::sightline_binary`]): its exit code
//! (0 clean, 1 a finding, 2 an error with the message on stderr) and the files it writes; what
//! the compile itself does is checked through `sightline_compiler::compile`.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::DVec3;
use sightline_compiler::{CompileError, CompileOptions, NoProgress, Source, compile};

/// How a run of the binary ended without an error: exit 0 or exit 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// Exit 0.
    Clean,
    /// Exit 1: a finding (a leak).
    Finding,
}

/// The command line of one `sightline compile`.
#[derive(Debug, Clone)]
struct Args {
    input: PathBuf,
    output: PathBuf,
    threads: Option<usize>,
    no_vis: bool,
    state: Option<PathBuf>,
    stop_after: Option<usize>,
    allow_leak: bool,
}

/// Runs `sightline compile ... --json`: the outcome on exit 0 or 1, else (exit 2) what it printed
/// on stderr. Any other exit (a panic, a signal) fails the test.
fn run(a: &Args) -> Result<Outcome, String> {
    let mut cmd = Command::new(sightline_tests::sightline_binary());
    cmd.arg("compile").arg(&a.input).arg("-o").arg(&a.output).arg("--json");
    if let Some(threads) = a.threads {
        cmd.arg("--threads").arg(threads.to_string());
    }
    if a.no_vis {
        cmd.arg("--no-vis");
    }
    if let Some(state) = &a.state {
        cmd.arg("--state").arg(state);
    }
    if let Some(n) = a.stop_after {
        cmd.arg("--stop-after").arg(n.to_string());
    }
    if a.allow_leak {
        cmd.arg("--allow-leak");
    }
    let out = cmd.output().expect("run sightline");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    match out.status.code() {
        Some(0) => Ok(Outcome::Clean),
        Some(1) => Ok(Outcome::Finding),
        Some(2) => Err(stderr),
        _ => panic!("{cmd:?}: {}\n{stderr}", out.status),
    }
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-compile-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn args(input: &Path, output: &Path) -> Args {
    Args {
        input: input.to_path_buf(),
        output: output.to_path_buf(),
        threads: None,
        no_vis: true,
        state: None,
        stop_after: None,
        allow_leak: false,
    }
}

fn write_map(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write map");
    path
}

/// One axial box brush side list in Standard syntax.
fn box_brush(lo: [i64; 3], hi: [i64; 3]) -> String {
    let [x0, y0, z0] = lo;
    let [x1, y1, z1] = hi;
    format!(
        "{{\n( {x0} {y0} {z0} ) ( {x0} {y1} {z0} ) ( {x0} {y0} {z1} ) wall 0 0 0 1 1\n\
         ( {x1} {y0} {z0} ) ( {x1} {y0} {z1} ) ( {x1} {y1} {z0} ) wall 0 0 0 1 1\n\
         ( {x0} {y0} {z0} ) ( {x0} {y0} {z1} ) ( {x1} {y0} {z0} ) wall 0 0 0 1 1\n\
         ( {x0} {y1} {z0} ) ( {x1} {y1} {z0} ) ( {x0} {y1} {z1} ) wall 0 0 0 1 1\n\
         ( {x0} {y0} {z0} ) ( {x1} {y0} {z0} ) ( {x0} {y1} {z0} ) wall 0 0 0 1 1\n\
         ( {x0} {y0} {z1} ) ( {x0} {y1} {z1} ) ( {x1} {y0} {z1} ) wall 0 0 0 1 1\n}}\n"
    )
}

#[test]
fn leaking_map_reports_the_entity_writes_a_pointfile_to_the_void_and_exits_1() {
    let dir = temp_dir("leak");
    let input = sightline_tests::bundled_maps().join("leak.map");
    let out = dir.join("leak.slvl");
    let outcome = run(&args(&input, &out)).expect("a leak is a finding, not an error");
    assert_eq!(outcome, Outcome::Finding);
    assert!(!out.exists(), "no level is written for a leaking map");
    let pts = std::fs::read_to_string(dir.join("leak.pts")).expect("pointfile written");
    let points: Vec<DVec3> = pts
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().expect("number")).collect();
            assert_eq!(v.len(), 3, "pointfile line `{l}`");
            DVec3::new(v[0], v[1], v[2])
        })
        .collect();
    assert!(points.len() >= 2);
    assert!(points.windows(2).all(|w| w[0].distance(w[1]) <= 8.0 + 1e-6), "points every 8 units");

    let text = std::fs::read_to_string(&input).expect("map");
    let map = sightline_formats::map::parse(&text, "leak.map").expect("parses");
    let start = map.entities.iter().find(|e| e.classname() == "info_player_start").expect("start").clone();
    assert_eq!(points[0], start.origin().expect("origin"), "the path starts at the entity");
    let world = sightline_formats::Aabb::from_points(
        map.entities.iter().flat_map(|e| &e.brushes).flat_map(|b| &b.sides).flat_map(|s| s.points),
    );
    let last = *points.last().expect("points");
    assert!(!world.contains_point(last, 0.0), "the path ends outside the world: {last}");

    // The library names the entity and its line.
    let err = compile(&Source::Map { map, file: "leak.map".into() }, &CompileOptions::default(), &NoProgress)
        .expect_err("leaks");
    let CompileError::Leak(report) = &err else { panic!("expected a leak, got {err}") };
    assert_eq!(report.classname, "info_player_start");
    assert_eq!(report.line, start.line);
    assert!(err.to_string().contains("leak.map:"), "{err}");
}

#[test]
fn allow_leak_writes_the_level_without_portal_file_and_still_exits_1() {
    let dir = temp_dir("allow");
    let out = dir.join("leak.slvl");
    let mut a = args(&sightline_tests::bundled_maps().join("leak.map"), &out);
    a.allow_leak = true;
    assert_eq!(run(&a).expect("runs"), Outcome::Finding);
    assert!(out.exists());
    assert!(dir.join("leak.pts").exists());
    assert!(!dir.join("leak.prt").exists());
}

#[test]
fn bad_inputs_are_clear_errors() {
    let dir = temp_dir("bad");
    let run_err = |name: &str, text: &str| {
        let input = write_map(&dir, name, text);
        run(&args(&input, &dir.join("out.slvl"))).expect_err("must fail (exit 2)")
    };
    let broken =
        run_err("broken.map", "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 0 0 ) wall\n}\n}\n");
    assert!(broken.contains("broken.map:"), "{broken}");
    let none = run_err("empty.map", "// nothing here\n");
    assert!(none.contains("empty.map"), "{none}");
    let huge = run_err(
        "huge.map",
        &format!("{{\n\"classname\" \"worldspawn\"\n{}}}\n", box_brush([0, 0, 0], [5_000_000, 64, 64])),
    );
    assert!(huge.contains("huge.map:"), "{huge}");
    // Six planes whose half-spaces do not meet: x < 0 and x > 64.
    let degenerate = "{\n\"classname\" \"worldspawn\"\n{\n\
        ( 0 0 0 ) ( 0 0 1 ) ( 0 1 0 ) wall 0 0 0 1 1\n\
        ( 64 0 0 ) ( 64 1 0 ) ( 64 0 1 ) wall 0 0 0 1 1\n\
        ( 0 0 0 ) ( 0 0 1 ) ( 1 0 0 ) wall 0 0 0 1 1\n\
        ( 0 64 0 ) ( 1 64 0 ) ( 0 64 1 ) wall 0 0 0 1 1\n\
        ( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) wall 0 0 0 1 1\n\
        ( 0 0 64 ) ( 0 1 64 ) ( 1 0 64 ) wall 0 0 0 1 1\n}\n}\n";
    let msg = run_err("degenerate.map", degenerate);
    assert!(msg.contains("degenerate.map:3:") && msg.contains("brush 0"), "{msg}");
    assert!(msg.contains("degenerate"), "{msg}");
}

#[test]
fn library_rejects_maps_without_entities_and_huge_origins() {
    let empty = sightline_formats::map::MapFile {
        entities: Vec::new(),
        format: sightline_formats::map::MapFormat::Standard,
    };
    let err =
        compile(&Source::Map { map: empty, file: "x.map".into() }, &CompileOptions::default(), &NoProgress)
            .expect_err("no entities");
    assert!(matches!(err, CompileError::NoEntities { .. }), "{err}");

    let text = format!(
        "{{\n\"classname\" \"worldspawn\"\n{}}}\n{{\n\"classname\" \"light\"\n\"origin\" \"9000000 0 0\"\n}}\n",
        box_brush([0, 0, 0], [64, 64, 64])
    );
    let map = sightline_formats::map::parse(&text, "o.map").expect("parses");
    let err = compile(&Source::Map { map, file: "o.map".into() }, &CompileOptions::default(), &NoProgress)
        .expect_err("huge origin");
    assert!(matches!(err, CompileError::HugeCoordinate { line: 12, .. }), "{err}");
}

#[test]
fn output_is_identical_for_any_thread_count_and_prt_reads_back() {
    let dir = temp_dir("threads");
    for name in ["two_rooms.map", "angled.map", "detail_water.map", "scene.obj"] {
        let input = sightline_tests::bundled_maps().join(name);
        let mut bytes = Vec::new();
        for threads in [1, 2] {
            let out = dir.join(format!("{name}-{threads}.slvl"));
            let mut a = args(&input, &out);
            a.threads = Some(threads);
            a.no_vis = false;
            assert_eq!(run(&a).expect("compiles"), Outcome::Clean, "{name}");
            let prt_text = std::fs::read_to_string(out.with_extension("prt")).expect("prt");
            let prt = sightline_formats::prt::read(&prt_text, name).expect("our .prt reads back");
            for p in &prt.portals {
                assert!(p.leaves.iter().all(|&l| l < prt.num_clusters));
                assert!(p.winding.is_valid(0.05), "{name}: portal winding not convex and planar");
            }
            let level_bytes = std::fs::read(&out).expect("level");
            let level = sightline_formats::slvl::read(&level_bytes).expect("level reads back");
            assert!(level.has_vis() || level.num_clusters == 0, "{name}: vis ran");
            bytes.push((level_bytes, prt_text));
        }
        assert!(bytes[0] == bytes[1], "{name}: output differs between 1 and 2 threads");
    }
}

#[test]
fn detail_brushes_group_leaves_into_clusters() {
    let input = sightline_tests::bundled_maps().join("detail_water.map");
    let text = std::fs::read_to_string(&input).expect("map");
    let map = sightline_formats::map::parse(&text, "detail_water.map").expect("parses");
    let out = compile(
        &Source::Map { map, file: "detail_water.map".into() },
        &CompileOptions::default(),
        &NoProgress,
    )
    .expect("compiles");
    let level = &out.level;
    let open = level.leaves.iter().filter(|l| l.cluster >= 0).count() as u32;
    assert!(
        level.num_clusters < open,
        "detail leaves share clusters: {} clusters, {open} leaves",
        level.num_clusters
    );
    assert_eq!(out.prt.format, sightline_formats::prt::PrtFormat::Prt2);
    let water =
        level.leaves.iter().find(|l| l.contents == sightline_formats::Contents::Water).expect("water leaf");
    // The water surface is drawn from inside the water too.
    let faces = &level.leaf_faces[water.first_face as usize..(water.first_face + water.num_faces) as usize];
    assert!(
        faces.iter().any(|&f| level.textures[level.faces[f as usize].texture as usize].starts_with('*')),
        "the water leaf lists a water face"
    );
}

/// A sealed 256-unit room made of six 16-unit walls, as map text (no closing brace of worldspawn).
fn room_world() -> String {
    let mut s = String::from("{\n\"classname\" \"worldspawn\"\n");
    s += &box_brush([-16, -16, -16], [272, 272, 0]);
    s += &box_brush([-16, -16, 256], [272, 272, 272]);
    s += &box_brush([-16, -16, 0], [0, 272, 256]);
    s += &box_brush([256, -16, 0], [272, 272, 256]);
    s += &box_brush([0, -16, 0], [256, 0, 256]);
    s += &box_brush([0, 256, 0], [256, 272, 256]);
    s
}

#[test]
fn brush_entities_become_submodels_and_hints_split_first() {
    let mut text = room_world();
    // A hint brush across the room: its `hint` side at x = 144 must be the first split.
    let hint = box_brush([128, 0, 0], [144, 256, 256]).replace("wall", "skip").replacen(
        "( 144 0 0 ) ( 144 0 256 ) ( 144 256 0 ) skip",
        "( 144 0 0 ) ( 144 0 256 ) ( 144 256 0 ) hint",
        1,
    );
    assert!(hint.contains("hint"));
    text += &hint;
    text += "}\n";
    text += &format!("{{\n\"classname\" \"func_door\"\n{}}}\n", box_brush([32, 32, 0], [64, 64, 64]));
    text += "{\n\"classname\" \"info_player_start\"\n\"origin\" \"200 200 24\"\n}\n";
    let map = sightline_formats::map::parse(&text, "sub.map").expect("parses");
    let out = compile(&Source::Map { map, file: "sub.map".into() }, &CompileOptions::default(), &NoProgress)
        .expect("compiles");
    let level = &out.level;
    assert_eq!(level.models.len(), 2);
    assert!(level.models[1].num_faces == 6, "the door keeps its six faces");
    assert!(level.entities.contains("\"model\" \"*1\""), "{}", level.entities);
    let root = &level.nodes[level.models[0].head_node as usize];
    let plane = &level.planes[root.plane as usize];
    assert_eq!((plane.normal, plane.dist), ([1.0, 0.0, 0.0], 144.0), "the hint plane splits first");
    // The door is not part of the world: the world has one open region split only by the hint.
    assert_eq!(out.stats.vis_leaves, 2);
}

#[test]
fn interrupted_compile_resumes_from_its_vis_state_to_the_same_level() {
    let dir = temp_dir("resume");
    let input = sightline_tests::bundled_maps().join("stairs_pillars.map");
    let whole = dir.join("whole.slvl");
    let mut a = args(&input, &whole);
    a.no_vis = false;
    a.threads = Some(2);
    assert_eq!(run(&a).expect("compiles"), Outcome::Clean);

    let resumed = dir.join("resumed.slvl");
    let state = dir.join("vis.state");
    let mut b = args(&input, &resumed);
    b.no_vis = false;
    b.threads = Some(2);
    b.state = Some(state.clone());
    b.stop_after = Some(1);
    let err = run(&b).expect_err("stops after the first batch of flow portals");
    assert!(err.contains("run again with the same --state to resume"), "{err}");
    assert!(state.is_file(), "the state is saved");
    assert!(!resumed.exists(), "nothing is written for an interrupted compile");

    // The library reports the portals it took from the state.
    let text = std::fs::read_to_string(&input).expect("map");
    let map = sightline_formats::map::parse(&text, "stairs_pillars.map").expect("parses");
    let opts = CompileOptions {
        threads: Some(2),
        allow_leak: false,
        vis: Some(sightline_compiler::vis::VisOptions { state: Some(state.clone()), ..Default::default() }),
        ..CompileOptions::default()
    };
    let out = compile(&Source::Map { map, file: "stairs_pillars.map".into() }, &opts, &NoProgress)
        .expect("resumes");
    let vis = out.vis.expect("vis ran");
    assert!(vis.resumed_portals > 0 && vis.resumed_portals < 2 * vis.portals, "{vis:?}");
    assert!(!state.exists(), "a finished run removes its state");

    b.stop_after = None;
    b.state = Some(dir.join("fresh.state"));
    assert_eq!(run(&b).expect("compiles"), Outcome::Clean);
    assert_eq!(std::fs::read(&resumed).expect("level"), std::fs::read(&whole).expect("level"));
    assert_eq!(
        sightline_formats::slvl::read(&std::fs::read(&whole).expect("level")).expect("reads").pvs_data,
        out.level.pvs_data,
        "the resumed PVS equals the uninterrupted one"
    );
    std::fs::remove_dir_all(&dir).expect("clean up");
}
