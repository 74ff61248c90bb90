//! Every real `.map` parses, and its entity, brush and side counts equal those of an independent
//! brace-depth scan of the text.

use std::path::{Path, PathBuf};
use std::time::Instant;

use sightline_formats::map::{self, MapFormat};

use crate::brace_scan;
use brace_scan::{BraceCounts, brace_scan};

fn maps_in(dir: &Path) -> Vec<PathBuf> {
    let mut maps: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "map"))
        .collect();
    maps.sort();
    maps
}

fn check(path: &Path) -> map::MapFile {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let start = Instant::now();
    let parsed = map::parse(&text, &path.display().to_string()).unwrap_or_else(|e| panic!("{e}"));
    let elapsed = start.elapsed();
    let got = BraceCounts {
        entities: parsed.entities.len(),
        brushes: parsed.entities.iter().map(|e| e.brushes.len()).sum(),
        sides: parsed.entities.iter().flat_map(|e| &e.brushes).map(|b| b.sides.len()).sum(),
    };
    assert_eq!(got, brace_scan(&text), "{}", path.display());
    assert!(got.entities > 1 && got.brushes > 0, "{}: suspiciously empty", path.display());
    eprintln!(
        "{}: {} entities, {} brushes, {} sides, {:?}, {} bytes parsed in {:.2?}",
        path.display(),
        got.entities,
        got.brushes,
        got.sides,
        parsed.format,
        text.len(),
        elapsed
    );
    parsed
}

#[test]
fn every_shared_map_parses_with_independent_counts() {
    let Some(root) = sightline_tests::shared_maps() else { return };
    for (dir, format) in [("id", MapFormat::Standard), ("librequake", MapFormat::Valve220)] {
        let maps = maps_in(&root.join(dir));
        assert!(!maps.is_empty(), "no maps in {dir}");
        for path in maps {
            assert_eq!(check(&path).format, format, "{}", path.display());
        }
    }
}

#[test]
fn known_counts_of_e1m1() {
    let Some(root) = sightline_tests::shared_maps() else { return };
    let parsed = check(&root.join("id/e1m1.map"));
    let world = &parsed.entities[0];
    assert_eq!(world.classname(), "worldspawn");
    assert_eq!(world.get("message"), Some("the Slipgate Complex"));
    assert!(parsed.entities.iter().any(|e| e.classname() == "info_player_start"));
}

#[test]
fn every_bundled_map_parses_with_independent_counts() {
    let maps = maps_in(&sightline_tests::bundled_maps());
    assert!(maps.len() >= 10, "expected the bundled maps, found {}", maps.len());
    for path in maps {
        check(&path);
    }
}
