//! Compile time of id's E1M1 (and DM1, LibreQuake lq_e1m1) from parsed `.map` to level and portals,
//! without vis (vis has its own benchmarks). Parsing is outside the measured loop. Real maps come
//! from `$SIGHTLINE_MAPS` (default `../shared/maps`); without them nothing is measured.

use std::hint::black_box;

use criterion::{Criterion, criterion_main};
use sightline_compiler::{CompileOptions, NoProgress, Source, compile};

fn bench_compile(c: &mut Criterion) {
    let Some(dir) = sightline_tests::shared_maps() else {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); compile benchmarks skipped");
        return;
    };
    let mut g = c.benchmark_group("compile");
    g.sample_size(10);
    for name in ["id/e1m1.map", "id/dm1.map", "librequake/lq_e1m1.map"] {
        let Ok(text) = std::fs::read_to_string(dir.join(name)) else {
            eprintln!("note: {name} absent; skipped");
            continue;
        };
        let map = match sightline_formats::map::parse(&text, name) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("note: {e}; skipped");
                continue;
            }
        };
        let source = Source::Map { map, file: name.to_string() };
        for threads in [1, 2] {
            let opts = CompileOptions { threads: Some(threads), ..CompileOptions::default() };
            g.bench_function(format!("{name} no-vis threads={threads}"), |b| {
                b.iter(|| compile(black_box(&source), &opts, &NoProgress).map(|c| c.stats.portals))
            });
        }
    }
    g.finish();
}

// `criterion_group!` defines a public function; in a module of its own it needs no docs.
mod group {
    criterion::criterion_group!(benches, super::bench_compile);
}
criterion_main!(group::benches);
