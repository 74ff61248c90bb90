//! Throughput of the binary formats: PVS row decoding, BSP reading and `.slvl` reading/writing.
//! Real levels come from `$SIGHTLINE_MAPS` (default `../shared/maps`); without them only the row
//! codec is measured.

use criterion::{Criterion, Throughput, criterion_main};
use sightline_formats::{bsp, rle, slvl};
use std::hint::black_box;

fn rows(c: &mut Criterion) {
    // A sparse 1,344-leaf row (E1M1's size), about 12 % of leaves visible.
    let row: Vec<u8> = (0..168u32).map(|i| if i % 8 == 0 { 0xff } else { (i * 37 % 5 == 0) as u8 }).collect();
    let mut packed = Vec::new();
    rle::encode_row(&row, &mut packed);
    let mut out = vec![0; row.len()];
    let mut g = c.benchmark_group("rle");
    g.throughput(Throughput::Bytes(row.len() as u64));
    g.bench_function("decode_row_168", |b| {
        b.iter(|| rle::decode_row(black_box(&packed), row.len(), &mut out))
    });
    g.bench_function("encode_row_168", |b| {
        b.iter(|| {
            let mut v = Vec::with_capacity(row.len());
            rle::encode_row(black_box(&row), &mut v);
            v
        })
    });
    g.finish();
}

fn files(c: &mut Criterion) {
    let Some(dir) = sightline_tests::shared_maps() else {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); BSP and .slvl benchmarks skipped");
        return;
    };
    let Ok(bytes) = std::fs::read(dir.join("ericw/e1m1.vis.bsp")) else { return };
    let Ok(parsed) = bsp::read(&bytes) else { return };
    let level = bsp::to_level(&parsed);
    let raw = slvl::write(&level, &slvl::WriteOptions { compress: false });
    let lz4 = slvl::write(&level, &slvl::WriteOptions { compress: true });
    let mut g = c.benchmark_group("e1m1");
    g.sample_size(20);
    g.bench_function("bsp_read", |b| b.iter(|| bsp::read(black_box(&bytes))));
    g.bench_function("bsp_pvs_stats", |b| b.iter(|| parsed.pvs_stats()));
    g.bench_function("bsp_to_level", |b| b.iter(|| bsp::to_level(black_box(&parsed))));
    g.bench_function("slvl_write_raw", |b| {
        b.iter(|| slvl::write(black_box(&level), &slvl::WriteOptions { compress: false }))
    });
    g.bench_function("slvl_write_lz4", |b| {
        b.iter(|| slvl::write(black_box(&level), &slvl::WriteOptions { compress: true }))
    });
    g.bench_function("slvl_read_raw", |b| b.iter(|| slvl::read(black_box(&raw))));
    g.bench_function("slvl_read_lz4", |b| b.iter(|| slvl::read(black_box(&lz4))));
    g.finish();
}

// `criterion_group!` defines a public function; in a module of its own it needs no docs.
mod group {
    criterion::criterion_group!(benches, super::rows, super::files);
}
criterion_main!(group::benches);
