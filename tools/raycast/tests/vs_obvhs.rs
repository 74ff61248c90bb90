//! Our BVH and obvhs' CWBVH (the library the `vs_obvhs` benchmark measures it against) give the
//! same closest hits on generated scenes: both miss, or both hit at the same `t` (within a relative
//! 1e-4) or the same triangle; any other ray must graze an edge (the nearer hit within 1e-4 of its
//! triangle's edge in barycentric terms), where only our watertight test is exact. Any-hit queries
//! agree on every ray whose closest hits agree.

// Shared with the benchmark, which also uses what this test does not (`heap_bytes`).
#[allow(dead_code)]
#[path = "../examples/vs_obvhs/library.rs"]
mod library;

use glam::Vec3;
use library::{Agreement, Theirs, compare};
use sightline_gvs::scenegen::{self, Rng};
use sightline_raycast::Bvh;

/// `n` rays from random points of the box `lo..hi` in random directions.
fn rays(rng: &mut Rng, lo: Vec3, hi: Vec3, n: usize) -> Vec<(Vec3, Vec3)> {
    (0..n)
        .map(|_| {
            let o = lo + (hi - lo) * Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
            let d = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            (o, d)
        })
        .collect()
}

#[test]
fn both_trees_give_the_same_closest_hits() {
    let scenes = [scenegen::city(8, 1), scenegen::spheres(1500, true, 2), scenegen::mesh(5000)];
    let mut rng = Rng::new(11);
    for (k, scene) in scenes.iter().enumerate() {
        let tris = &scene.triangles;
        let (ours, theirs) = (Bvh::build(tris), Theirs::build(tris));
        let (lo, hi) = tris
            .iter()
            .flatten()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        // Origins in the scene's box grown by a tenth of its size (the mesh is flat).
        let pad = Vec3::splat((hi - lo).max_element() * 0.1);
        let (mut hits, mut grazes) = (0, 0);
        for (o, d) in rays(&mut rng, lo - pad, hi + pad, 20_000) {
            match compare(tris, o, d, &ours, &theirs) {
                Agreement::Same => {
                    let hit = ours.intersect(o, d, f32::INFINITY);
                    hits += usize::from(hit.is_some());
                    // A segment ending halfway to the closest hit, and one reaching past it.
                    for t_max in hit.map_or(vec![1.0, 1e6], |h| vec![h.t * 0.5, h.t * 1.5 + 1e-3]) {
                        assert_eq!(
                            ours.occluded(o, d, t_max),
                            theirs.occluded(o, d, t_max),
                            "scene {k}: ray {o} {d} to t {t_max}"
                        );
                    }
                }
                Agreement::Graze => grazes += 1,
                Agreement::Differ(a, b) => panic!("scene {k}: ray {o} {d}: ours {a:?}, obvhs {b:?}"),
            }
        }
        // Many rays hit something (a fortieth even in the sparse sphere cloud), so agreement is not
        // two trees missing everything alike.
        assert!(hits > 500, "scene {k}: {hits} hits");
        assert!(grazes < 20, "scene {k}: {grazes} grazing rays");
    }
}
