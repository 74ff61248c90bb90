//! Per-frame culling cost of each backend on 256 fixed random poses: E1M1 (ericw-tools' build,
//! with its `.prt` for the portal backend) when the shared maps are present, else a synthetic
//! grid level. Every pose is a new eye position, so the PVS backend decodes and marks each frame.
//! The PVS backend is also measured with back faces culled in the walk and in a pass after it.

use criterion::{Criterion, Throughput, criterion_main};
use sightline_runtime::backend::{self, Backend};
use sightline_runtime::{Scratch, Visible, World, load, poses};
use sightline_tests::synth;

fn world() -> (String, World) {
    let dir = sightline_tests::shared_maps().unwrap_or_default();
    let path = dir.join("ericw/e1m1_nodetail.vis.bsp");
    match load::load_path(&path) {
        Ok(world) => ("e1m1".to_string(), world),
        Err(e) => {
            eprintln!("note: {} not usable ({e}); benchmarking a synthetic grid", path.display());
            let level = synth::grid_level([16, 16, 4], 64.0, true, |x, y, z| (x * 7 + y * 3 + z) % 5 == 0);
            ("grid".to_string(), World::new(&level).unwrap_or_else(|e| panic!("grid level: {e}")))
        }
    }
}

fn bench(c: &mut Criterion) {
    let (name, world) = world();
    let views: Vec<_> = poses::random_cameras(&world, 1, 256).iter().map(|c| c.view()).collect();
    let mut group = c.benchmark_group(format!("cull/{name}"));
    group.throughput(Throughput::Elements(views.len() as u64));
    for b in backend::all().iter().filter(|b| b.supports(&world)) {
        let mut scratch = Scratch::new(&world);
        let mut out = Visible::for_world(&world);
        group.bench_function(b.name(), |bench| {
            bench.iter(|| {
                let mut total = 0;
                for view in &views {
                    b.cull(&world, view, &mut scratch, &mut out);
                    total += out.leaves.len();
                }
                total
            })
        });
    }
    // Back-face culling: in the walk (`View::cull_back_faces`), and as a pass after it.
    let culled: Vec<_> = views.iter().map(|v| v.with_back_face_culling(true)).collect();
    let mut scratch = Scratch::new(&world);
    let mut out = Visible::for_world(&world);
    group.bench_function("pvs+backfaces-in-walk", |bench| {
        bench.iter(|| {
            let mut total = 0;
            for view in &culled {
                backend::pvs::Pvs.cull(&world, view, &mut scratch, &mut out);
                total += out.faces.len();
            }
            total
        })
    });
    group.bench_function("pvs+backfaces-after", |bench| {
        bench.iter(|| {
            let mut total = 0;
            for view in &views {
                backend::pvs::Pvs.cull(&world, view, &mut scratch, &mut out);
                world.cull_back_faces(view.eye, &mut out.faces);
                total += out.faces.len();
            }
            total
        })
    });
    group.finish();
}

// `criterion_group!` defines a public function; in a module of its own it needs no docs.
mod group {
    criterion::criterion_group!(benches, super::bench);
}
criterion_main!(group::benches);
