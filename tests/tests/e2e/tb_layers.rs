//! TrenchBroom layers omitted from export (`_tb_layer_omit_from_export`) are not compiled: on
//! generated maps with a layer that would split a room and leak (twice: a `light` of the layer and
//! one in a group nested in a group of the layer), the compile succeeds, says what it left out, and
//! writes the very files the map without that layer gives. A layer not omitted is compiled.

use std::path::PathBuf;
use std::process::Command;
use std::sync::Mutex;

use sightline_compiler::vis::VisOptions;
use sightline_compiler::{CompileError, CompileOptions, Source, compile};
use sightline_job::progress::Progress;
use sightline_tests::mapgen::{MapGenParams, generate_with_layer};

const PARAMS: [MapGenParams; 2] = [
    MapGenParams { rooms_x: 1, rooms_y: 1, storeys: 1, seed: 3 },
    MapGenParams { rooms_x: 2, rooms_y: 2, storeys: 2, seed: 11 },
];

/// A [`Progress`] that keeps the notes.
#[derive(Default)]
struct Notes(Mutex<Vec<String>>);

impl Progress for Notes {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
    fn note(&self, message: &str) {
        self.0.lock().expect("notes").push(message.to_string());
    }
}

fn source(text: &str, file: &str) -> Source {
    let map = sightline_formats::map::parse(text, file).expect("generated maps parse");
    Source::Map { map, file: file.to_string() }
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sightline-layers-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// `sightline compile IN -o OUT.slvl` (with vis): exit code, stderr, and the `.slvl` and `.prt`.
fn run_binary(dir: &std::path::Path, name: &str, text: &str) -> (Option<i32>, String, Vec<u8>, Vec<u8>) {
    let input = dir.join(format!("{name}.map"));
    std::fs::write(&input, text).expect("write map");
    let output = dir.join(format!("{name}.slvl"));
    let out = Command::new(sightline_tests::sightline_binary())
        .arg("compile")
        .arg(&input)
        .arg("-o")
        .arg(&output)
        .output()
        .expect("run sightline");
    let read = |p: PathBuf| std::fs::read(p).unwrap_or_default();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        read(output.clone()),
        read(output.with_extension("prt")),
    )
}

#[test]
fn an_omitted_layer_is_left_out_as_if_removed_by_hand() {
    for params in PARAMS {
        let map = generate_with_layer(&params, true);
        let notes = Notes::default();
        let opts = CompileOptions { vis: Some(VisOptions::default()), ..CompileOptions::default() };
        let with = compile(&source(&map.text, "layered.map"), &opts, &notes)
            .unwrap_or_else(|e| panic!("{params:?}: {e}"));
        assert!(with.leak.is_none());
        let without = compile(&source(&map.without_layer, "plain.map"), &opts, &Notes::default())
            .expect("the map without the layer compiles");
        assert_eq!(with.level, without.level, "{params:?}");
        assert_eq!(with.prt, without.prt, "{params:?}");
        assert_eq!(with.stats.brushes, without.stats.brushes, "only the compiled brushes count");
        let expected = format!(
            "layered.map: left out {} brushes and {} entities of 1 layer omitted from export \
             (_tb_layer_omit_from_export): \"scaffold\"",
            map.layer_brushes, map.layer_entities
        );
        assert_eq!(*notes.0.lock().expect("notes"), [expected], "{params:?}");
    }

    // The binary writes byte-identical files and prints the note.
    let dir = temp_dir("omitted");
    let map = generate_with_layer(&PARAMS[1], true);
    let (code, stderr, slvl, prt) = run_binary(&dir, "layered", &map.text);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.contains("note: ") && stderr.contains("left out 4 brushes and 3 entities"), "{stderr}");
    let (plain_code, plain_err, plain_slvl, plain_prt) = run_binary(&dir, "plain", &map.without_layer);
    assert_eq!(plain_code, Some(0), "{plain_err}");
    assert!(!plain_err.contains("left out"), "{plain_err}");
    assert!(!slvl.is_empty() && !prt.is_empty());
    assert!(slvl == plain_slvl, "the .slvl files differ");
    assert!(prt == plain_prt, "the .prt files differ");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_layer_not_omitted_is_compiled() {
    for params in PARAMS {
        let map = generate_with_layer(&params, false);
        let notes = Notes::default();
        // Its lights stand in the void: the first of them leaks.
        let err = compile(&source(&map.text, "layered.map"), &CompileOptions::default(), &notes)
            .expect_err("the layer's lights leak");
        let CompileError::Leak(report) = &err else { panic!("{params:?}: expected a leak, got {err}") };
        assert_eq!((report.classname.as_str(), report.line), ("light", map.outside_line), "{params:?}");
        assert!(notes.0.lock().expect("notes").is_empty());
        // Its brushes are in the level: the wall splits the first room.
        let opts = CompileOptions { allow_leak: true, vis: None, ..CompileOptions::default() };
        let with = compile(&source(&map.text, "layered.map"), &opts, &notes).expect("compiles with the leak");
        let without = compile(&source(&map.without_layer, "plain.map"), &opts, &notes).expect("compiles");
        assert!(with.level.leaves.len() > without.level.leaves.len(), "{params:?}");
        assert_eq!(with.stats.brushes, without.stats.brushes + map.layer_brushes);
        assert_eq!(with.stats.submodels, without.stats.submodels + 1, "the layer's func_wall");
    }
}
