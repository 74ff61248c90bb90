//! How vis time grows with the number of portals, on sealed maps from `sightline_tests::mapgen` (rooms,
//! corridors, stairs, pillars, several storeys) compiled by `sightline_compiler::compile`.
//!
//! `cargo bench -p sightline-compiler --bench vis_growth` prints a Markdown table: rooms, storeys, vis
//! leaves, portals, full vis seconds (wall and CPU, 2 threads), chains, average visible leaves,
//! fast vis seconds. `-- --write DIR` instead writes the maps (`gen_RxRxS.map`) for measuring the
//! `sightline` binary itself or other compilers.

use std::time::Instant;

use sightline_compiler::vis::{self, VisOptions};
use sightline_compiler::{CompileOptions, NoProgress, Source, compile};
use sightline_tests::mapgen::{MapGenParams, generate};

mod common;
use common::cpu_seconds;

/// Rooms per side and storeys of the generated maps, smallest first.
const SIZES: [(u32, u32); 9] = [(2, 1), (2, 2), (4, 1), (4, 2), (6, 3), (8, 3), (12, 3), (16, 4), (20, 5)];

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(dir) = args.windows(2).find(|w| w[0] == "--write").map(|w| w[1].clone()) {
        std::fs::create_dir_all(&dir).expect("output folder");
        for (rooms, storeys) in SIZES {
            let params = MapGenParams { rooms_x: rooms, rooms_y: rooms, storeys, seed: 7 };
            let path = format!("{dir}/gen_{rooms}x{rooms}x{storeys}.map");
            std::fs::write(&path, generate(&params)).expect("write");
            println!("{path}");
        }
        return;
    }
    println!(
        "| rooms | storeys | vis leaves | portals | full wall s | full CPU s | chains | avg visible | fast wall s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (rooms, storeys) in SIZES {
        let params = MapGenParams { rooms_x: rooms, rooms_y: rooms, storeys, seed: 7 };
        let text = generate(&params);
        let file = format!("gen_{rooms}x{rooms}x{storeys}.map");
        let map = sightline_formats::map::parse(&text, &file).expect("generated maps parse");
        let compiled = compile(&Source::Map { map, file }, &CompileOptions::default(), &NoProgress)
            .expect("generated maps compile");
        let prt = &compiled.prt;
        let run = |fast: bool| {
            let cpu0 = cpu_seconds();
            let t = Instant::now();
            let r = vis::run(
                prt,
                &VisOptions { threads: 2, fast, ..VisOptions::default() },
                &sightline_job::progress::NoProgress,
            )
            .expect("vis");
            (t.elapsed().as_secs_f64(), cpu_seconds() - cpu0, r)
        };
        let (wall, cpu, full) = run(false);
        let (fast_wall, _, _) = run(true);
        println!(
            "| {r}×{r} | {storeys} | {leaves} | {portals} | {wall:.3} | {cpu:.2} | {chains} | {avg:.1} | {fast_wall:.3} |",
            r = rooms,
            leaves = prt.num_leaves,
            portals = prt.portals.len(),
            chains = full.stats.chains,
            avg = full.stats.avg_visible,
        );
    }
}
