//! Hostile input: thousands of mutated files (truncations, bit flips, random bytes, huge counts
//! spliced into headers, shuffled chunks) for every reader, asserting that none panics and that
//! none allocates beyond a bound linear in the input. The real binary gets the same mutated files
//! (`binary`), special files as inputs and outputs that would replace its inputs (`outputs`), and
//! every numeric flag out of its range (`arguments`).
//!
//! A counting global allocator tracks, per thread, the bytes currently allocated and the peak
//! since the last reset, so tests running on other threads do not disturb a measurement.

use sightline_formats::{FileKind, map, obj, prt, slvl};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static CURRENT: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn note(delta: isize) {
    // `try_with` because allocation can happen while thread-locals are being torn down.
    let _ = CURRENT.try_with(|c| {
        let now = c.get() + delta;
        c.set(now);
        let _ = PEAK.try_with(|p| p.set(p.get().max(now)));
    });
}

// SAFETY: every method forwards to `System` with the same arguments; the bookkeeping only touches
// const-initialised thread-locals, which never allocate.
#[allow(unsafe_code)] // A global allocator is an `unsafe` trait; it forwards to `System`.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note(-(layout.size() as isize));
        // SAFETY: forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size as isize - layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[path = "hostile_inputs/arguments.rs"]
mod arguments;
#[path = "hostile_inputs/binary.rs"]
mod binary;
#[path = "hostile_inputs/memory.rs"]
mod memory;
#[path = "hostile_inputs/outputs.rs"]
mod outputs;
#[path = "hostile_inputs/paired.rs"]
mod paired;
#[path = "hostile_inputs/readers.rs"]
mod readers;
#[path = "hostile_inputs/signals.rs"]
mod signals;

/// A fresh, empty folder for the runs of one test (`tag` tells tests apart, the process id runs).
fn scratch_dir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sightline-hostile-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// The names in `dir`, sorted.
fn file_names(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs `f` and returns the peak number of bytes it held allocated at once on this thread.
fn peak_during(f: impl FnOnce()) -> usize {
    let base = CURRENT.with(Cell::get);
    PEAK.with(|p| p.set(base));
    f();
    (PEAK.with(Cell::get) - base).max(0) as usize
}

use sightline_job::rng::SplitMix64 as Rng;
use sightline_tests::mutate;

/// Values that break naive readers when they land in a count, offset or length field.
/// Text mutation: byte mutations as above, plus numbers made huge or non-finite and braces and
/// parentheses inserted or deleted.
fn mutate_text(rng: &mut Rng, input: &[u8]) -> String {
    let bytes = if rng.below(3) == 0 {
        let mut out = input.to_vec();
        let at = rng.below(out.len() + 1);
        let token: &[u8] = [
            &b"99999999999999999999"[..],
            b"1e300",
            b"nan",
            b"-inf",
            b"{",
            b"}",
            b"(",
            b")",
            b"\"",
            b"4294967295",
            b"-1",
            b"\n",
        ][rng.below(12)];
        if rng.below(2) == 0 || at == out.len() {
            out.splice(at..at, token.iter().copied());
        } else {
            out.remove(at);
        }
        out
    } else {
        mutate(rng, input, 64)
    };
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Memory a reader may take for an input of `len` bytes.
fn linear_bound(len: usize) -> usize {
    64 * len + (16 << 20)
}

/// Runs `read` on `count` mutations of each input, checking the memory bound; returns how many
/// mutations were rejected (so a caller can check the readers really do reject).
fn hammer(
    name: &str,
    inputs: &[Vec<u8>],
    count: usize,
    seed: u64,
    mut mutation: impl FnMut(&mut Rng, &[u8]) -> Vec<u8>,
    bound: impl Fn(usize) -> usize,
    mut read: impl FnMut(&[u8]) -> bool,
) -> usize {
    let mut rng = Rng::new(seed);
    let mut rejected = 0;
    let mut worst = 0usize;
    for input in inputs {
        for i in 0..count {
            let data = mutation(&mut rng, input);
            let mut ok = true;
            let peak = peak_during(|| ok = read(&data));
            rejected += usize::from(!ok);
            worst = worst.max(peak);
            assert!(
                peak <= bound(data.len()),
                "{name}: mutation {i} of a {}-byte input ({} bytes) took {peak} bytes at peak",
                input.len(),
                data.len()
            );
        }
    }
    let largest = inputs.iter().map(Vec::len).max().unwrap_or(0);
    eprintln!(
        "{name}: {rejected} of {} mutations rejected; peak allocation {worst} bytes (largest input {largest} bytes)",
        inputs.len() * count
    );
    rejected
}

fn shared(path: &str) -> Option<Vec<u8>> {
    let dir = sightline_tests::shared_maps()?;
    Some(std::fs::read(dir.join(path)).unwrap_or_else(|e| panic!("{path}: {e}")))
}

fn bundled(name: &str) -> Vec<u8> {
    let path = sightline_tests::bundled_maps().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn bundled_with_ext(ext: &str) -> Vec<Vec<u8>> {
    let dir = sightline_tests::bundled_maps();
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    paths.sort();
    paths.iter().map(|p| std::fs::read(p).expect("read bundled map")).collect()
}

#[test]
fn file_kind_detection_survives_hostile_bytes() {
    let mut inputs = bundled_with_ext("map");
    inputs.extend(bundled_with_ext("obj"));
    let mut rng = Rng::new(14);
    let mut kinds = 0;
    for input in &inputs {
        for _ in 0..200 {
            let data = mutate(&mut rng, input, 16);
            let peak = peak_during(|| kinds += usize::from(FileKind::from_bytes(&data).is_some()));
            assert!(peak <= linear_bound(data.len()), "detection took {peak} bytes");
        }
    }
    assert!(kinds > 0, "no mutated map or mesh was recognised");
}

#[test]
fn map_parser_survives_hostile_text() {
    let mut inputs = bundled_with_ext("map");
    let real = shared("id/dm1.map");
    let rejected = hammer(
        "map",
        &inputs,
        150,
        6,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| map::parse(std::str::from_utf8(data).unwrap_or_default(), "hostile.map").is_ok(),
    );
    assert!(rejected > inputs.len() * 50, "only {rejected} mutated maps rejected");
    if let Some(real) = real {
        inputs = vec![real];
        hammer(
            "map (dm1)",
            &inputs,
            60,
            7,
            |r, d| mutate_text(r, d).into_bytes(),
            linear_bound,
            |data| map::parse(std::str::from_utf8(data).unwrap_or_default(), "dm1.map").is_ok(),
        );
    }
}

#[test]
fn prt_reader_survives_hostile_text() {
    let Some(dm1) = shared("ericw/dm1.prt") else { return };
    let lqdm1 = shared("ericw/lqdm1.prt").expect("lqdm1.prt");
    let rejected = hammer(
        "prt",
        &[dm1, lqdm1],
        400,
        8,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| prt::read(std::str::from_utf8(data).unwrap_or_default(), "hostile.prt").is_ok(),
    );
    assert!(rejected > 400, "only {rejected} of 800 mutated portal files rejected");
}

#[test]
fn obj_loader_survives_hostile_text() {
    let inputs = bundled_with_ext("obj");
    assert!(!inputs.is_empty(), "maps/ has an .obj");
    let scene = bundled("scene.obj");
    assert!(inputs.contains(&scene));
    let rejected = hammer(
        "obj",
        &inputs,
        1000,
        9,
        |r, d| mutate_text(r, d).into_bytes(),
        linear_bound,
        |data| obj::load_from_bytes(data, "hostile.obj").is_ok(),
    );
    // Many mutations of an .obj stay valid (tobj skips unknown lines): only require some rejections.
    assert!(rejected > 50, "only {rejected} mutated .obj files rejected");
}

// ---- Inputs that other tools accept, or that failed late or silently ----

/// `.map` bytes, not text: mutations that leave bytes which are not UTF-8 (Quake's high-bit
/// characters) reach the parser as Latin-1 text instead of failing to decode.
#[test]
fn map_parser_survives_hostile_bytes() {
    let inputs = bundled_with_ext("map");
    let mut high_bit_accepted = 0;
    hammer(
        "map bytes",
        &inputs,
        150,
        21,
        |r, d| {
            let mut out = mutate(r, d, 0);
            // Half of the mutations also put high-bit bytes inside the first quoted string.
            if r.below(2) == 0
                && let Some(q) = out.iter().position(|&b| b == b'"')
            {
                let junk: Vec<u8> = (0..1 + r.below(8)).map(|_| 0x80 | r.next_u64() as u8).collect();
                out.splice(q + 1..q + 1, junk);
            }
            out
        },
        linear_bound,
        |data| {
            let ok = map::parse_bytes(data, "hostile.map").is_ok();
            high_bit_accepted += usize::from(ok && std::str::from_utf8(data).is_err());
            ok
        },
    );
    assert!(high_bit_accepted > 0, "no map with high-bit bytes was accepted");
}

/// A small PRT1 file: 3 leaves in a row, two portals.
const PRT1_ROW: &str = "PRT1\n3\n2\n4 0 1 (64 0 0) (64 0 64) (64 64 64) (64 64 0)\n\
                        4 1 2 (128 0 0) (128 0 64) (128 64 64) (128 64 0)\n";

#[test]
fn prt_reader_reads_crlf_like_lf_and_survives_hostile_bytes() {
    let lf = prt::read(PRT1_ROW, "row.prt").expect("valid");
    let crlf = PRT1_ROW.replace('\n', "\r\n");
    assert_eq!(prt::read_bytes(crlf.as_bytes(), "row.prt"), Ok(lf.clone()));
    assert_eq!(prt::PrtFormat::of_text(&crlf), Some(prt::PrtFormat::Prt1));
    let inputs = [PRT1_ROW.as_bytes().to_vec(), crlf.into_bytes()];
    let rejected = hammer(
        "prt bytes",
        &inputs,
        500,
        22,
        |r, d| mutate(r, d, 0),
        linear_bound,
        |data| {
            match prt::read_bytes(data, "hostile.prt") {
                // Whatever reads is a consistent file: its header sniffs as its format.
                Ok(f) => {
                    assert_eq!(prt::PrtFormat::of_text(&String::from_utf8_lossy(data)), Some(f.format));
                    true
                }
                Err(e) => {
                    assert!(e.line >= 1 && e.col >= 1, "{e}");
                    false
                }
            }
        },
    );
    assert!(rejected > 100, "only {rejected} of 1000 mutated portal files rejected");
}

/// Faces of one or two vertices are skipped and counted, never turned into triangles of no area;
/// a face of no vertex is an error at its line.
#[test]
fn obj_faces_of_one_or_two_vertices_are_skipped_and_counted() {
    let mut rng = Rng::new(23);
    for _ in 0..300 {
        let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n");
        let (mut skipped, mut triangles) = (0, 0);
        for _ in 0..1 + rng.below(12) {
            let n = 1 + rng.below(5);
            let face: Vec<String> = (0..n).map(|k| (1 + (k + rng.below(4)) % 4).to_string()).collect();
            text.push_str(&format!("f {}\n", face.join(" ")));
            if n < 3 {
                skipped += 1;
            } else {
                triangles += n - 2;
            }
        }
        let mut mesh = None;
        let peak = peak_during(|| mesh = Some(obj::load_from_bytes(text.as_bytes(), "faces.obj")));
        assert!(peak <= linear_bound(text.len()), "{peak} bytes");
        let mesh = mesh.expect("ran").unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!((mesh.skipped_faces, mesh.triangles.len()), (skipped, triangles), "{text}");
    }
    let e = obj::load_from_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf\n", "none.obj").unwrap_err();
    assert!(e.to_string().starts_with("none.obj:5"), "{e}");
}

/// A brush of more sides than a compile takes is an error naming it, found before any work on
/// it; a brush of many narrow sides within the limit keeps them all.
#[test]
fn a_brush_of_too_many_sides_is_an_error_naming_it() {
    use sightline_compiler::MAX_BRUSH_SIDES;
    use sightline_compiler::{CompileError, CompileOptions, NoProgress, Source, compile};
    // A room (room.map) with a prism over an n-gon of radius 100 in worldspawn: its sides are
    // narrow (0.6 units at n = 1022) and turn by small angles.
    let room = String::from_utf8(bundled("room.map")).expect("UTF-8");
    let prism = |n: usize| {
        let mut b = String::from("{\n");
        let corner = |i: usize| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            (128.0 + 100.0 * a.cos(), 128.0 + 100.0 * a.sin())
        };
        for i in 0..n {
            let ((x0, y0), (x1, y1)) = (corner(i), corner(i + 1));
            b.push_str(&format!("( {x0} {y0} 16 ) ( {x0} {y0} 64 ) ( {x1} {y1} 16 ) wall 0 0 0 1 1\n"));
        }
        b.push_str("( 0 0 16 ) ( 1 0 16 ) ( 0 1 16 ) wall 0 0 0 1 1\n( 0 0 64 ) ( 0 1 64 ) ( 1 0 64 ) wall 0 0 0 1 1\n}\n");
        let at = room.find("}\n{\n\"classname\" \"info_player_start\"").expect("worldspawn ends");
        let mut text = room.clone();
        text.insert_str(at, &b);
        text = text.replace("\"origin\" \"128 128 24\"", "\"origin\" \"16 16 100\"");
        (text, room[..at].lines().count() + 1)
    };
    // n sides around and two caps.
    let (text, line) = prism(MAX_BRUSH_SIDES - 1);
    let map = map::parse(&text, "many.map").expect("parses");
    let brush = map.entities[0].brushes.len() - 1;
    let mut result = None;
    let peak = peak_during(|| {
        result = Some(compile(
            &Source::Map { map, file: "many.map".into() },
            &CompileOptions::default(),
            &NoProgress,
        ));
    });
    assert!(peak <= linear_bound(text.len()), "{peak} bytes");
    match result.expect("ran") {
        Err(e @ CompileError::BadBrush { .. }) => {
            let msg = e.to_string();
            let place = format!(
                "many.map:{line}: entity 0 (`worldspawn`) brush {brush}: {} sides",
                MAX_BRUSH_SIDES + 1
            );
            assert!(msg.starts_with(&place), "{msg}");
        }
        other => panic!("{other:?}"),
    }
    // Within the limit the brush keeps every narrow side (it used to keep 2 of them and be
    // skipped with a warning). A few of these faces, 0.6 units wide at 0.006 radians from their
    // neighbours, still fall into slivers of the tree thinner than ON_EPSILON that the outside
    // fill closes: at least 99 % of the sides are drawn.
    let (text, _) = prism(MAX_BRUSH_SIDES - 2);
    let map = map::parse(&text, "ok.map").expect("parses");
    let out = compile(&Source::Map { map, file: "ok.map".into() }, &CompileOptions::default(), &NoProgress)
        .expect("compiles");
    assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    assert_eq!(out.stats.world_brushes, 7, "the room's six walls and the prism");
    let faces = out.level.faces.len();
    assert!(
        faces >= (MAX_BRUSH_SIDES - 2) * 99 / 100 + 6,
        "{faces} faces for 1,022 sides, two caps and the room"
    );
}

/// A level whose tree has no world model to root it is refused by every reader, naming the lump:
/// `.slvl` reading and the runtime by the rule every reader shares, the validator by its own
/// guard (it takes levels from code too).
#[test]
fn a_level_without_models_is_refused_naming_the_lump() {
    let room = String::from_utf8(bundled("room.map")).expect("UTF-8");
    let map = map::parse(&room, "room.map").expect("parses");
    let out = sightline_compiler::compile(
        &sightline_compiler::Source::Map { map, file: "room.map".into() },
        &sightline_compiler::CompileOptions::default(),
        &sightline_compiler::NoProgress,
    )
    .expect("compiles");
    let mut level = out.level;
    level.models.clear();
    let bytes = slvl::write(&level, &slvl::WriteOptions::default());
    let read = slvl::read(&bytes).expect_err("no world model");
    assert!(matches!(read, slvl::SlvlError::Invalid { lump: "models", .. }), "{read}");
    let runtime = sightline_runtime::World::new(&level).expect_err("no world model");
    let source = std::error::Error::source(&runtime).map(|s| s.to_string()).unwrap_or_default();
    assert!(source.contains("lump models") && source.contains("no world model"), "{runtime}: {source}");
    let tree = sightline_validate::bsp::BspTree::new(&level).expect_err("no tree");
    assert!(tree.to_string().contains("models lump is empty"), "{tree}");
}
