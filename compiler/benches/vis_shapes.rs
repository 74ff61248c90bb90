//! Vis time and memory on the shapes that cost it the most for their size
//! ([`sightline_tests::shapes`]): a straight corridor (a portal file written directly), a room
//! around one many-sided pillar and a room of many tiny brushes (both compiled by
//! `sightline_compiler::compile` without vis).
//!
//! `cargo bench -p sightline-compiler --bench vis_shapes` prints a Markdown table: shape, size, vis leaves,
//! portals, full vis seconds (wall and CPU, 2 threads), peak resident memory of the vis alone,
//! chains, average visible leaves. `-- --write DIR` instead writes the inputs (`corridor_N.prt`,
//! `pillar_N.map`, `tiny_N.map`) for measuring the `sightline` binary itself (or other compilers);
//! `-- --sizes small` runs only the smaller sizes, `-- --size N` (repeatable) only size `N` of
//! every shape.

use std::time::Instant;

use sightline_compiler::vis::{self, VisOptions};
use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_formats::prt::PortalFile;
use sightline_tests::shapes::{corridor_prt, pillar_room, tiny_brushes_room};

mod common;
use common::cpu_seconds;

/// A `/proc/self/status` field in KiB.
fn status_kib(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Reset the peak resident size to the current one (Linux: `5` into `/proc/self/clear_refs`), so
/// the next `VmHWM` is the peak of what runs after; `false` where that is not possible.
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The shapes: name, sizes (small, then large), and the portal file of a size.
struct Shape {
    name: &'static str,
    small: &'static [u32],
    large: &'static [u32],
    source: fn(u32) -> Input,
}

enum Input {
    Prt(PortalFile),
    Map(String),
}

const SHAPES: [Shape; 3] = [
    Shape {
        name: "corridor",
        small: &[100, 200],
        large: &[400, 800, 1600],
        source: |n| Input::Prt(corridor_prt(n)),
    },
    Shape { name: "pillar", small: &[100, 300], large: &[600, 1000], source: |n| Input::Map(pillar_room(n)) },
    Shape {
        name: "tiny",
        small: &[125, 250],
        large: &[500, 1000],
        source: |n| Input::Map(tiny_brushes_room(n, 7)),
    },
];

fn portal_file(name: &str, n: u32, input: Input) -> PortalFile {
    match input {
        Input::Prt(prt) => prt,
        Input::Map(text) => {
            let file = format!("{name}_{n}.map");
            let map = sightline_formats::map::parse(&text, &file).expect("generated maps parse");
            compile(&Source::Map { map, file }, &CompileOptions::default(), &NoProgress)
                .expect("generated maps compile")
                .prt
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let small_only = args.windows(2).any(|w| w[0] == "--sizes" && w[1] == "small");
    let only: Vec<u32> =
        args.windows(2).filter(|w| w[0] == "--size").map(|w| w[1].parse().expect("--size N")).collect();
    let sizes = |shape: &Shape| match (only.is_empty(), small_only) {
        (false, _) => only.clone(),
        (true, true) => shape.small.to_vec(),
        (true, false) => [shape.small, shape.large].concat(),
    };
    if let Some(dir) = args.windows(2).find(|w| w[0] == "--write").map(|w| w[1].clone()) {
        std::fs::create_dir_all(&dir).expect("output folder");
        for shape in &SHAPES {
            for n in sizes(shape) {
                let (file, text) = match (shape.source)(n) {
                    Input::Prt(prt) => {
                        (format!("{}_{n}.prt", shape.name), sightline_formats::prt::write(&prt))
                    }
                    Input::Map(text) => (format!("{}_{n}.map", shape.name), text),
                };
                std::fs::write(format!("{dir}/{file}"), text).expect("write");
                println!("{dir}/{file}");
            }
        }
        return;
    }
    println!(
        "| shape | size | vis leaves | portals | full wall s | full CPU s | peak vis MB | chains | avg visible |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for shape in &SHAPES {
        for n in sizes(shape) {
            let prt = portal_file(shape.name, n, (shape.source)(n));
            let before = status_kib("VmRSS:").unwrap_or(0);
            let peak_known = reset_peak();
            let cpu0 = cpu_seconds();
            let t = Instant::now();
            let r = vis::run(
                &prt,
                &VisOptions { threads: 2, ..VisOptions::default() },
                &sightline_job::progress::NoProgress,
            )
            .expect("vis");
            let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu0);
            let peak = match (peak_known, status_kib("VmHWM:")) {
                (true, Some(hwm)) => format!("{:.1}", hwm.saturating_sub(before) as f64 / 1024.0),
                _ => "?".to_string(),
            };
            println!(
                "| {} | {n} | {} | {} | {wall:.3} | {cpu:.2} | {peak} | {} | {:.1} |",
                shape.name,
                prt.num_leaves,
                prt.portals.len(),
                r.stats.chains,
                r.stats.avg_visible,
            );
        }
    }
}
