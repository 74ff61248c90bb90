//! Throughput of the `.map` parser on the biggest shared map (LibreQuake lq_e1m1, 2.5 MB) and on
//! id's E1M1, and of brush bounds (one winding per side). Real maps come from `$SIGHTLINE_MAPS`
//! (default `../shared/maps`); without them nothing is measured.

use criterion::{Criterion, Throughput, criterion_main};
use sightline_formats::map;
use std::hint::black_box;

fn parse(c: &mut Criterion) {
    let Some(dir) = sightline_tests::shared_maps() else {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); .map benchmarks skipped");
        return;
    };
    let mut g = c.benchmark_group("map");
    g.sample_size(20);
    for name in ["librequake/lq_e1m1.map", "id/e1m1.map"] {
        let Ok(text) = std::fs::read_to_string(dir.join(name)) else { continue };
        let Ok(parsed) = map::parse(&text, name) else { continue };
        g.throughput(Throughput::Bytes(text.len() as u64));
        g.bench_function(format!("parse {name}"), |b| b.iter(|| map::parse(black_box(&text), name)));
        g.bench_function(format!("bounds {name}"), |b| b.iter(|| black_box(&parsed).bounds()));
    }
    g.finish();
}

// `criterion_group!` defines a public function; in a module of its own it needs no docs.
mod group {
    criterion::criterion_group!(benches, super::parse);
}
criterion_main!(group::benches);
