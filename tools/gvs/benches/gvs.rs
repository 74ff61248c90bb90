//! Ray casting and GVS benchmarks on the generated city (about 0.8 M triangles at size 100) and
//! sphere clouds (1 000 spheres, and the thesis' 10 116).
//!
//! `cargo bench -p sightline-gvs --bench gvs`. Throughput is reported in rays per second on one
//! thread (criterion runs the closures on the calling thread), i.e. rays/s per core.

use criterion::{Criterion, Throughput, criterion_main};
use glam::Vec3;
use sightline_gvs::scenegen::{self, Rng};
use sightline_gvs::{Cell, Neighbours, Params, SceneIndex, Variant, sampler};
use sightline_raycast::Bvh;
use std::hint::black_box;

const RAYS: usize = 100_000;
/// Spheres of the sparse sphere scene (most rays escape the cloud).
const SPHERES: usize = 1000;
/// Spheres in the thesis' sphere scene (Table 5: 10 116 in a 40³ box).
const THESIS_SPHERES: usize = 10_116;

fn bench(c: &mut Criterion) {
    let scene = scenegen::city(100, 1);
    let (lo, hi) = scene.cells[0];
    let cell = Cell::new(lo, hi);
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.throughput(Throughput::Elements(scene.triangles.len() as u64));
    g.bench_function(format!("build city:100 ({} triangles)", scene.triangles.len()), |b| {
        b.iter(|| black_box(Bvh::build(&scene.triangles)))
    });
    let city_index = SceneIndex::build(&scene.triangles);
    let bvh = &city_index.bvh;
    g.bench_function(format!("neighbour table city:100 ({} triangles)", scene.triangles.len()), |b| {
        b.iter(|| black_box(Neighbours::build(&scene.triangles, bvh).bytes()))
    });
    // Eye-level rays from the street cell (as the error metric casts them) and GVS-style rays
    // leaving the cell surface in every direction.
    let mut rng = Rng::new(3);
    let eye: Vec<(Vec3, Vec3)> = (0..RAYS)
        .map(|_| {
            let o = lo + (hi - lo) * Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
            let yaw = rng.range(0.0, std::f32::consts::TAU);
            let pitch = rng.range(-0.8, 0.8);
            (o, Vec3::new(pitch.cos() * yaw.cos(), pitch.cos() * yaw.sin(), pitch.sin()))
        })
        .collect();
    let surface: Vec<(Vec3, Vec3)> = (1..=RAYS as u64).map(|i| cell.sample_ray(i)).collect();
    g.throughput(Throughput::Elements(RAYS as u64));
    for (name, rays) in [("intersect eye-level rays", &eye), ("intersect cell-surface rays", &surface)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut hits = 0u32;
                for &(o, d) in rays.iter() {
                    hits += u32::from(bvh.intersect(o, d, f32::INFINITY).is_some());
                }
                black_box(hits)
            })
        });
    }
    g.bench_function("occluded eye-level rays (t_max 20)", |b| {
        b.iter(|| black_box(eye.iter().filter(|&&(o, d)| bvh.occluded(o, d, 20.0)).count()))
    });
    g.finish();

    // Among the spheres most GVS rays escape through the whole cloud: the cost is traversal of many
    // sparse boxes, unlike the city's streets. At the thesis' density (10 116 spheres in the same
    // box, 0.8 M triangles) nearly every ray hits within a few units, but the tree no longer fits
    // in the caches.
    let spheres = scenegen::spheres(SPHERES, false, 1);
    let sphere_cell = Cell::new(spheres.cells[0].0, spheres.cells[0].1);
    let sphere_index = SceneIndex::build(&spheres.triangles);
    let sphere_bvh = &sphere_index.bvh;
    let dense = scenegen::spheres(THESIS_SPHERES, false, 1);
    let dense_bvh = Bvh::build(&dense.triangles);
    let mut g = c.benchmark_group("bvh spheres");
    g.sample_size(10);
    g.throughput(Throughput::Elements(RAYS as u64));
    for (n, cell, bvh) in [
        (SPHERES, sphere_cell, sphere_bvh),
        (THESIS_SPHERES, Cell::new(dense.cells[0].0, dense.cells[0].1), &dense_bvh),
    ] {
        let rays: Vec<(Vec3, Vec3)> = (1..=RAYS as u64).map(|i| cell.sample_ray(i)).collect();
        g.bench_function(format!("intersect cell-surface rays, spheres:{n}"), |b| {
            b.iter(|| {
                black_box(rays.iter().filter(|&&(o, d)| bvh.intersect(o, d, f32::INFINITY).is_some()).count())
            })
        });
    }
    g.finish();

    // Throughput is the variant's rays (the same every run), so criterion prints GVS rays per
    // second on one core, bookkeeping included.
    let mut g = c.benchmark_group("gvs");
    g.sample_size(10);
    // The scene indexes (BVH and neighbour table) are built once per scene, outside the timing.
    let scenes =
        [("city:100 street cell", &city_index, cell), ("spheres:1000 cell", &sphere_index, sphere_cell)];
    for (name, index, cell) in scenes {
        for v in [Variant::Stock, Variant::EdgePoint, Variant::Silhouette, Variant::ProbeFirstTarget] {
            let run = || sampler::run(index, cell, v.params(Params::default()));
            g.throughput(Throughput::Elements(run().stats.rays));
            g.bench_function(format!("{} {name}", v.name()), |b| b.iter(|| black_box(run().entries.len())));
        }
    }
    g.finish();

    // The default variant's rays of the same cells cast alone, in the order GVS cast them: the ray
    // casting's share of the whole run above (the rest is the sampler's bookkeeping).
    let mut g = c.benchmark_group("gvs rays alone");
    g.sample_size(10);
    for (name, index, cell) in scenes {
        let (_, rays) =
            sampler::run_recorded(index, cell, Variant::ProbeFirstTarget.params(Params::default()));
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(format!("{} {name}", Variant::ProbeFirstTarget.name()), |b| {
            b.iter(|| {
                black_box(
                    rays.iter().filter(|&&(o, d)| index.bvh.intersect(o, d, f32::INFINITY).is_some()).count(),
                )
            })
        });
    }
    g.finish();
}

// `criterion_group!` defines a public function; in a module of its own it needs no docs.
mod group {
    criterion::criterion_group!(benches, super::bench);
}
criterion_main!(group::benches);
