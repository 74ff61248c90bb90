//! How a mesh's outside phase (the check that its triangles enclose its solid cells) grows with
//! the number of coplanar triangles, on the shapes of `sightline_tests::coplanar`.
//!
//! `cargo bench -p sightline-compiler --bench outside_growth` prints a Markdown table: shape,
//! size, triangles, cover tests, outside seconds, whole compile seconds (no vis). `-- --write DIR`
//! instead writes the meshes (`polygon_N.obj`, `prism_N.obj`, `scattered_N.obj`, `grid_N.obj`,
//! `room_*_N.obj`) for timing the `sightline` binary itself.

use std::time::Instant;

use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_tests::coplanar::{Floor, grid_obj, polygon_obj, prism_obj, room_obj, scattered_obj};

/// Sizes (polygon corners or triangles), smallest first.
const SIZES: [u32; 5] = [200, 400, 800, 2000, 4000];

type Shape = (&'static str, fn(u32) -> String);

const SHAPES: [Shape; 8] = [
    ("polygon", polygon_obj),
    ("prism", prism_obj),
    ("scattered", |n| scattered_obj(n, 1)),
    ("grid", grid_obj),
    ("room_grid", |n| room_obj(Floor::Grid, n)),
    ("room_shuffled", |n| room_obj(Floor::Shuffled(1), n)),
    ("room_crossed", |n| room_obj(Floor::CrossedStrips, n)),
    ("room_fan", |n| room_obj(Floor::Fan, n)),
];

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(dir) = args.windows(2).find(|w| w[0] == "--write").map(|w| w[1].clone()) {
        std::fs::create_dir_all(&dir).expect("output folder");
        for (name, make) in SHAPES {
            for n in SIZES {
                let path = format!("{dir}/{name}_{n}.obj");
                std::fs::write(&path, make(n)).expect("write");
                println!("{path}");
            }
        }
        return;
    }
    println!("| shape | size | triangles | cover tests | outside s | compile s |");
    println!("|---|---|---|---|---|---|");
    for (name, make) in SHAPES {
        for n in SIZES {
            let file = format!("{name}_{n}.obj");
            let obj = sightline_formats::obj::load_from_bytes(make(n).as_bytes(), &file)
                .expect("generated meshes load");
            let source = Source::Mesh { mesh: (&obj).into(), file };
            let t = Instant::now();
            let out =
                compile(&source, &CompileOptions { vis: None, ..CompileOptions::default() }, &NoProgress)
                    .expect("generated meshes compile");
            let total = t.elapsed().as_secs_f64();
            let outside =
                out.stats.phases.iter().find(|p| p.name == "outside").map_or(f64::NAN, |p| p.seconds);
            println!(
                "| {name} | {n} | {} | {} | {outside:.4} | {total:.3} |",
                obj.triangles.len(),
                out.stats.cover_tests
            );
        }
    }
}
