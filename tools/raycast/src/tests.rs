use glam::Vec3;
use proptest::prelude::*;

use crate::{Bvh, Hit, MAX_LEAF, STACK_SMALL, intersect_brute, intersect_brute_front};

fn quad_wall(x: f32) -> Vec<[Vec3; 3]> {
    let a = Vec3::new(x, -1.0, -1.0);
    let b = Vec3::new(x, 1.0, -1.0);
    let c = Vec3::new(x, 1.0, 1.0);
    let d = Vec3::new(x, -1.0, 1.0);
    vec![[a, b, c], [a, c, d]]
}

#[test]
fn nearest_wall_wins_and_occlusion_respects_t_max() {
    let mut tris = quad_wall(5.0);
    tris.extend(quad_wall(2.0));
    let bvh = Bvh::build(&tris);
    let hit = bvh.intersect(Vec3::ZERO, Vec3::X, f32::INFINITY).expect("hit");
    assert!((hit.t - 2.0).abs() < 1e-6);
    assert!(hit.triangle >= 2);
    assert!(bvh.occluded(Vec3::ZERO, Vec3::X, 2.5));
    assert!(!bvh.occluded(Vec3::ZERO, Vec3::X, 1.5));
    assert!(bvh.intersect(Vec3::ZERO, -Vec3::X, f32::INFINITY).is_none());
}

#[test]
fn non_finite_rays_hit_nothing() {
    let bvh = Bvh::build(&sphere_cloud(7));
    let bad =
        [Vec3::NAN, Vec3::new(1.0, f32::NAN, 0.0), Vec3::INFINITY, Vec3::new(0.0, f32::NEG_INFINITY, 1.0)];
    for v in bad {
        assert!(bvh.intersect(Vec3::ZERO, v, 1e30).is_none(), "direction {v}");
        assert!(bvh.intersect(v, Vec3::X, 1e30).is_none(), "origin {v}");
        assert!(!bvh.occluded(Vec3::ZERO, v, 1e30), "direction {v}");
    }
    assert!(bvh.intersect(Vec3::ZERO, Vec3::ZERO, 1e30).is_none());
}

#[test]
fn empty_and_degenerate_input() {
    let bvh = Bvh::build(&[]);
    assert!(bvh.is_empty());
    assert!(bvh.intersect(Vec3::ZERO, Vec3::X, 1.0).is_none());
    let nan = Vec3::splat(f32::NAN);
    let bvh = Bvh::build(&[[nan, Vec3::X, Vec3::Y], [Vec3::ZERO, Vec3::X, Vec3::X]]);
    assert_eq!(bvh.len(), 1);
    assert!(bvh.intersect(Vec3::new(0.5, -1.0, 0.0), Vec3::Y, 10.0).is_none());
}

proptest! {
    #[test]
    fn rays_through_a_shared_edge_never_leak(
        k in 0.0f32..1.0,
        (ox, oy, oz) in (-30.0f32..30.0, -30.0f32..30.0, 1.0f32..30.0),
    ) {
        // A flat fan of triangles sharing edges; aim at points on the seams.
        let c = Vec3::new(0.3, -0.2, 0.0);
        let ring: Vec<Vec3> = (0..7)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 7.0;
                Vec3::new(a.cos() * 3.0, a.sin() * 3.0, 0.0)
            })
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..7).map(|i| [c, ring[i], ring[(i + 1) % 7]]).collect();
        let bvh = Bvh::build(&tris);
        let o = Vec3::new(ox, oy, oz);
        for r in &ring {
            let target = c + (*r - c) * k;
            prop_assert!(bvh.intersect(o, target - o, 10.0).is_some(), "leak at {target}");
        }
    }
}

fn tri_strategy() -> impl Strategy<Value = [Vec3; 3]> {
    let p = || (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    (p(), p(), p()).prop_map(|(a, d1, d2)| [a, a + d1 * 0.3, a + d2 * 0.3])
}

proptest! {
    #[test]
    fn overlapping_lists_exactly_the_overlapping_boxes(
        tris in prop::collection::vec(tri_strategy(), 1..200),
        (cx, cy, cz, r) in (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0, 0.0f32..4.0),
    ) {
        let bvh = Bvh::build(&tris);
        let (lo, hi) = (Vec3::new(cx, cy, cz) - r, Vec3::new(cx, cy, cz) + r);
        let mut all = Vec::new();
        bvh.overlapping(lo, hi, |t| {
            all.push(t);
            true
        });
        // Stopping early gives a prefix of the same order.
        let mut first = Vec::new();
        bvh.overlapping(lo, hi, |t| {
            first.push(t);
            first.len() < 3
        });
        prop_assert_eq!(&first[..], &all[..all.len().min(3)]);
        let mut got = all;
        got.sort_unstable();
        let want: Vec<u32> = (0..tris.len() as u32)
            .filter(|&i| {
                let t = tris[i as usize];
                let (a, b) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                a.cmple(hi).all() && b.cmpge(lo).all()
            })
            .collect();
        prop_assert_eq!(got, want);
    }

    #[test]
    fn groups_partition_the_triangles(
        tris in prop::collection::vec(tri_strategy(), 1..300),
        max in 1usize..40,
    ) {
        let bvh = Bvh::build(&tris);
        let mut all = Vec::new();
        let mut sizes = Vec::new();
        bvh.groups(max, |g| {
            sizes.push(g.len());
            all.extend_from_slice(g);
        });
        prop_assert!(sizes.iter().all(|&n| n > 0 && n <= max.max(MAX_LEAF)), "{sizes:?}");
        all.sort_unstable();
        prop_assert_eq!(all, (0..tris.len() as u32).collect::<Vec<_>>());
    }

    #[test]
    fn agrees_with_brute_force(
        tris in prop::collection::vec(tri_strategy(), 1..300),
        rays in prop::collection::vec(
            ((-12.0f32..12.0, -12.0f32..12.0, -12.0f32..12.0), (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)),
            1..40,
        ),
    ) {
        let bvh = Bvh::build(&tris);
        for ((ox, oy, oz), (dx, dy, dz)) in rays {
            let o = Vec3::new(ox, oy, oz);
            let d = Vec3::new(dx, dy, dz);
            let a = bvh.intersect(o, d, 1e30);
            let b = intersect_brute(&tris, o, d, 1e30);
            prop_assert!(same_hit(&tris, o, d, a, b), "bvh {a:?} brute {b:?}");
            prop_assert_eq!(bvh.occluded(o, d, 1e30), b.is_some());
        }
    }
}

proptest! {
    #[test]
    fn packets_agree_with_one_ray_at_a_time(
        tris in prop::collection::vec(tri_strategy(), 1..300),
        (ox, oy, oz) in (-12.0f32..12.0, -12.0f32..12.0, -12.0f32..12.0),
        (bx, by, bz) in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
        spread in prop_oneof![Just(0.0f32), 0.0f32..0.05, 0.0f32..2.0],
        jitter in prop::collection::vec((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), 1..90),
        t_max in prop_oneof![Just(1e30f32), 0.1f32..20.0],
    ) {
        // A cone of rays from one origin (coherent at small spreads), every fifth ray from
        // elsewhere: packets of mixed axes and octants, partial and full packets, more than
        // one 64-ray chunk.
        let bvh = Bvh::build(&tris);
        let o = Vec3::new(ox, oy, oz);
        let base = Vec3::new(bx, by, bz);
        let rays: Vec<(Vec3, Vec3)> = jitter
            .iter()
            .enumerate()
            .map(|(i, &(x, y, z))| {
                let j = Vec3::new(x, y, z);
                if i % 5 == 4 { (o + j * 10.0, Vec3::new(j.y, j.z, j.x)) } else { (o, base + j * spread) }
            })
            .collect();
        let mut hits = vec![None; 3];
        bvh.intersect_many(&rays, t_max, &mut hits);
        prop_assert_eq!(hits.len(), rays.len());
        for (&(o, d), &a) in rays.iter().zip(&hits) {
            let b = bvh.intersect(o, d, t_max);
            prop_assert!(same_hit(&tris, o, d, a, b), "packet {a:?} one ray {b:?}");
        }
    }
}

#[test]
fn pixel_tiles_of_a_sphere_cloud_equal_brute_force() {
    let tris = sphere_cloud(7);
    let bvh = Bvh::build(&tris);
    let mut rng = unit_rng(11);
    let mut hits = Vec::new();
    for view in 0..8 {
        let eye = Vec3::new(rng(), rng(), rng()) * 50.0 - 25.0;
        let forward = (Vec3::new(rng(), rng(), rng()) * 2.0 - 1.0).normalize_or(Vec3::X);
        let right = forward.cross(Vec3::Z).normalize_or(Vec3::Y);
        let up = right.cross(forward);
        // 4×4 tiles of a 40×40 image at 60°, and some rays that are no rays at all.
        for tile in 0..100 {
            let (tx, ty) = (tile % 10 * 4, tile / 10 * 4);
            let mut rays: Vec<(Vec3, Vec3)> = (0..16)
                .map(|k| {
                    let u = ((tx + k % 4) as f32 / 20.0 - 1.0) * 0.577;
                    let v = ((ty + k / 4) as f32 / 20.0 - 1.0) * 0.577;
                    (eye, forward + right * u + up * v)
                })
                .collect();
            if tile == view {
                rays[3].1 = Vec3::ZERO;
                rays[7].1 = Vec3::NAN;
                rays[9].0 = Vec3::NAN;
            }
            bvh.intersect_many(&rays, 1e30, &mut hits);
            for (&(o, d), &a) in rays.iter().zip(&hits) {
                let b = intersect_brute(&tris, o, d, 1e30);
                assert!(same_hit(&tris, o, d, a, b), "view {view} tile {tile}: packet {a:?} brute {b:?}");
            }
        }
    }
}

#[test]
fn packets_on_trees_without_quads() {
    for tris in [Vec::new(), quad_wall(2.0)] {
        let bvh = Bvh::build(&tris);
        let rays = [(Vec3::ZERO, Vec3::X), (Vec3::ZERO, Vec3::new(1.0, 0.1, 0.1)), (Vec3::ZERO, -Vec3::X)];
        let mut hits = Vec::new();
        bvh.intersect_many(&rays, f32::INFINITY, &mut hits);
        let one: Vec<Option<Hit>> = rays.iter().map(|&(o, d)| bvh.intersect(o, d, f32::INFINITY)).collect();
        assert_eq!(hits, one);
        assert_eq!(hits[0].is_some(), !tris.is_empty());
    }
}

/// The tree's hit is the brute-force hit exactly (`t`, triangle, `u`, `v`), or a different
/// triangle hit at exactly the same `t` (a tie, which the traversal order decides).
fn same_hit(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, a: Option<Hit>, b: Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) if a.t.to_bits() == b.t.to_bits() => {
            a == b
                || intersect_brute(&tris[a.triangle as usize..=a.triangle as usize], o, d, 1e30)
                    .is_some_and(|h| h.t.to_bits() == a.t.to_bits() && h.u == a.u && h.v == a.v)
        }
        _ => false,
    }
}

/// Random closed spheres (shared edges) scattered in a box, rays from inside and outside in
/// every direction, some with a finite `t_max`.
/// 60 tessellated spheres (120 triangles each) in a 40-unit box.
fn sphere_cloud(seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = unit_rng(seed);
    let mut tris = Vec::new();
    for _ in 0..60 {
        let c = Vec3::new(rng(), rng(), rng()) * 40.0 - 20.0;
        let r = 0.5 + 2.0 * rng();
        let (nu, nv) = (10, 6);
        let p = |i: usize, j: usize| {
            let (a, b) =
                (i as f32 * std::f32::consts::TAU / nu as f32, j as f32 * std::f32::consts::PI / nv as f32);
            c + r * Vec3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos())
        };
        for i in 0..nu {
            for j in 0..nv {
                let (a, b, cc, dd) = (p(i, j), p((i + 1) % nu, j), p((i + 1) % nu, j + 1), p(i, j + 1));
                tris.push([a, b, cc]);
                tris.push([a, cc, dd]);
            }
        }
    }
    tris
}

#[test]
fn sphere_cloud_hits_equal_brute_force() {
    let tris = sphere_cloud(7);
    let mut rng = unit_rng(8);
    let bvh = Bvh::build(&tris);
    for k in 0..3000 {
        let o = Vec3::new(rng(), rng(), rng()) * 50.0 - 25.0;
        let d = Vec3::new(rng(), rng(), rng()) * 2.0 - 1.0;
        let t_max = if k % 3 == 0 { 20.0 * rng() } else { 1e30 };
        let (a, b) = (bvh.intersect(o, d, t_max), intersect_brute(&tris, o, d, t_max));
        assert!(same_hit(&tris, o, d, a, b), "ray {k}: bvh {a:?} brute {b:?}");
        assert_eq!(bvh.occluded(o, d, t_max), b.is_some(), "ray {k}");
        let (a, b) = (bvh.intersect_front(o, d, t_max), intersect_brute_front(&tris, o, d, t_max));
        assert!(same_hit(&tris, o, d, a, b), "ray {k}, front only: bvh {a:?} brute {b:?}");
    }
}

/// One-sided hits: a triangle counter-clockwise seen from +z is hit by rays coming from above in
/// any dominant axis, never from below, and a front-only hit is a hit of the two-sided test.
#[test]
fn front_hits_only_from_the_side_the_normal_points_to() {
    let tri = [Vec3::new(-4.0, -4.0, 0.0), Vec3::new(4.0, -4.0, 0.0), Vec3::new(0.0, 4.0, 0.0)];
    let bvh = Bvh::build(&[tri]);
    for d in [Vec3::new(0.1, 0.2, -1.0), Vec3::new(-2.0, 0.1, -1.0), Vec3::new(0.3, 3.0, -1.0)] {
        let from_above = Vec3::Z * 0.5;
        let hit = bvh.intersect_front(from_above, d, 1e30);
        assert_eq!(hit.map(|h| h.triangle), Some(0), "from above along {d}");
        assert_eq!(hit, bvh.intersect(from_above, d, 1e30));
        let up = Vec3::new(d.x, d.y, -d.z);
        assert!(bvh.intersect_front(-Vec3::Z * 0.5, up, 1e30).is_none(), "from below along {up}");
        assert!(bvh.intersect(-Vec3::Z * 0.5, up, 1e30).is_some(), "two-sided from below along {up}");
    }
}

/// Triangles nested in each other at shrinking sizes make a binary tree nearly as deep as the
/// triangles are many, so the 4-wide traversal needs the deep stack; it still finds every hit.
#[test]
fn deep_tree_uses_the_deep_stack_and_agrees_with_brute_force() {
    const NESTED: i32 = 300;
    const RATIO: f32 = 0.8;
    let tris: Vec<[Vec3; 3]> = (0..NESTED)
        .map(|k| {
            let s = RATIO.powi(k);
            [Vec3::new(s, 0.0, 0.0), Vec3::new(s, s, 0.0), Vec3::new(s, 0.0, s)]
        })
        .collect();
    let bvh = Bvh::build(&tris);
    assert!(bvh.deep, "expected a tree needing more than {STACK_SMALL} stack entries");
    let mut rng = unit_rng(3);
    for k in 0..2000 {
        let s = RATIO.powi(k % NESTED);
        let o = Vec3::new(-1.0, s * rng() * 0.5, s * rng() * 0.5);
        let d = Vec3::new(1.0, 0.01 * (rng() - 0.5), 0.01 * (rng() - 0.5));
        let (a, b) = (bvh.intersect(o, d, 1e30), intersect_brute(&tris, o, d, 1e30));
        assert!(same_hit(&tris, o, d, a, b), "ray {k}: bvh {a:?} brute {b:?}");
    }
}

/// Floats in `[0, 1)` from a seeded [`SplitMix64`](sightline_job::rng::SplitMix64).
fn unit_rng(seed: u64) -> impl FnMut() -> f32 {
    let mut r = sightline_job::rng::SplitMix64::new(seed);
    move || r.unit_f32()
}
