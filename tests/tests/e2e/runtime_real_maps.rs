//! The runtime on real Quake maps (ericw-tools' E1M1 and DM2 without detail, so their `.prt` files
//! are PRT1 leaf portals): point location and traces against brute force, the portal backend
//! inside PVS ∩ frustum, and front-to-back order.

use glam::Vec3A;
use sightline_runtime::backend::{Backend, portal::Portal, pvs::Pvs};
use sightline_runtime::poses::{SplitMix64, point_in, random_cameras, random_open_point};
use sightline_runtime::{Scratch, Visible, World, load};
use sightline_tests::runtime_check::{
    LeafRegions, order_violations, pvs_leaves, reference_walk, sampled_leaves,
};

const MAPS: [&str; 2] = ["e1m1_nodetail", "dm2_nodetail"];

fn worlds() -> Vec<(&'static str, World)> {
    let Some(dir) = sightline_tests::shared_maps() else { return Vec::new() };
    MAPS.iter()
        .map(|name| {
            let path = dir.join(format!("ericw/{name}.vis.bsp"));
            let world = load::load_path(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(world.num_portals() > 1000, "{name}: portals from {name}.prt");
            assert!(world.has_vis(), "{name}: visdata");
            (*name, world)
        })
        .collect()
}

/// A box a little larger than every open leaf.
pub(crate) fn world_box(world: &World) -> (Vec3A, Vec3A) {
    let mut lo = Vec3A::splat(f32::INFINITY);
    let mut hi = Vec3A::splat(f32::NEG_INFINITY);
    for &l in world.open_leaves() {
        let b = world.leaf_bounds(l).expect("leaf");
        lo = lo.min(b.mins());
        hi = hi.max(b.maxs());
    }
    (lo - 64.0, hi + 64.0)
}

#[test]
fn leaf_at_agrees_with_brute_force_on_real_maps() {
    for (name, world) in worlds() {
        let regions = LeafRegions::new(&world);
        let (lo, hi) = world_box(&world);
        let mut rng = SplitMix64::new(17);
        for i in 0..1500 {
            let p = if i % 2 == 0 {
                point_in(&mut rng, lo, hi)
            } else {
                random_open_point(&world, &mut rng).expect("open")
            };
            assert_eq!(regions.leaves_at(p), vec![world.leaf_at(p)], "{name}: point {p:?}");
        }
    }
}

#[test]
fn trace_agrees_with_sampling_on_real_maps() {
    for (name, world) in worlds() {
        let (lo, hi) = world_box(&world);
        let mut rng = SplitMix64::new(5);
        let (mut agree, mut thin) = (0, 0);
        for _ in 0..400 {
            let a = random_open_point(&world, &mut rng).expect("open");
            let b = point_in(&mut rng, lo, hi);
            let len = (b - a).length();
            let samples = (len * 2.0) as usize + 1; // every half unit
            let solid = |l: u32| world.leaf_contents(l).is_some_and(|c| !c.is_open());
            let first = sampled_leaves(&world, a, b, samples).into_iter().find(|&(_, l)| solid(l));
            let hit = world.trace(a, b);
            match (hit, first) {
                (None, None) => agree += 1,
                (Some(h), Some((t, _))) => {
                    // The trace may find a solid sliver the half-unit sampler stepped over, never
                    // a later one.
                    assert!(h.fraction <= t + 1.0 / len, "{name}: trace {h:?} after sampled solid at {t}");
                    if (h.fraction - t).abs() <= 1.0 / len {
                        agree += 1;
                    } else {
                        thin += 1;
                    }
                    assert!(!solid(world.leaf_at(h.point)), "{name}: hit point {:?} is in solid", h.point);
                }
                (Some(h), None) => {
                    // Solid thinner than the sampling step.
                    assert!(solid(h.leaf));
                    thin += 1;
                }
                (None, Some((t, leaf))) => {
                    panic!("{name}: trace missed solid leaf {leaf} sampled at {t} on {a:?} -> {b:?}")
                }
            }
        }
        assert!(thin * 20 <= agree, "{name}: {thin} thin hits vs {agree} agreeing");
    }
}

#[test]
fn portal_backend_stays_inside_pvs_and_frustum() {
    for (name, world) in worlds() {
        let mut scratch = Scratch::new(&world);
        let (mut pvs, mut portal) = (Visible::for_world(&world), Visible::for_world(&world));
        let (mut sum_pvs, mut sum_portal, mut views) = (0usize, 0usize, 0usize);
        for cam in random_cameras(&world, 42, 2500) {
            let view = cam.view();
            Pvs.cull(&world, &view, &mut scratch, &mut pvs);
            Portal.cull(&world, &view, &mut scratch, &mut portal);
            let extra: Vec<u32> = portal.leaves.iter().copied().filter(|l| !pvs.leaves.contains(l)).collect();
            assert!(extra.is_empty(), "{name}: portal leaves {extra:?} outside PVS ∩ frustum for {cam:?}");
            let eye_leaf = world.leaf_at(view.eye);
            assert_eq!(portal.leaves.first(), pvs.leaves.first(), "{name}: both start at the eye's leaf");
            if let Some(&first) = pvs.leaves.first() {
                assert_eq!(first, eye_leaf, "{name}: the eye's leaf comes first");
            }
            sum_pvs += pvs.leaves.len();
            sum_portal += portal.leaves.len();
            views += 1;
        }
        assert!(views >= 2400);
        assert!(
            sum_portal * 10 < sum_pvs * 9,
            "{name}: portal {sum_portal} vs PVS {sum_pvs}: portals should cull more"
        );
    }
}

#[test]
fn walk_is_front_to_back_on_real_maps() {
    for (name, world) in worlds() {
        let mut scratch = Scratch::new(&world);
        let mut out = Visible::for_world(&world);
        for (i, cam) in random_cameras(&world, 8, 120).into_iter().enumerate() {
            let view = cam.view();
            let backend: &dyn Backend = if i % 2 == 0 { &Pvs } else { &Portal };
            backend.cull(&world, &view, &mut scratch, &mut out);
            let bad = order_violations(&world, view.eye, &out.leaves, 256);
            assert!(
                bad.is_empty(),
                "{name} ({}): leaves drawn before leaves in front of them: {bad:?}",
                backend.name()
            );
        }
    }
}

#[test]
fn pvs_walk_equals_the_reference_walk_on_real_maps() {
    for (name, mut world) in worlds() {
        assert!(world.pvs_trees_in_memory(), "{name}: PVS trees fit the budget");
        let mut scratch = Scratch::new(&world);
        let mut fast = Visible::for_world(&world);
        let cams = random_cameras(&world, 31, 1500);
        let mut wants = Vec::new();
        let mut dropped = 0;
        for cam in &cams {
            let view = cam.view();
            let marked = pvs_leaves(&world, view.eye);
            let want = reference_walk(&world, &view, &|l| marked[l as usize]);
            Pvs.cull(&world, &view, &mut scratch, &mut fast);
            assert_eq!(fast, want, "{name}: PVS trees vs reference for {cam:?}");
            // Back faces culled in the walk: the reference with the same culling, which is the
            // unculled output with `cull_back_faces` run after it.
            let culled_view = view.with_back_face_culling(true);
            let culled = reference_walk(&world, &culled_view, &|l| marked[l as usize]);
            let mut after = want.clone();
            world.cull_back_faces(view.eye, &mut after.faces);
            assert_eq!(culled, after, "{name}: culled reference vs a pass after it for {cam:?}");
            Pvs.cull(&world, &culled_view, &mut scratch, &mut fast);
            assert_eq!(fast, culled, "{name}: culled PVS trees vs reference for {cam:?}");
            dropped += want.faces.len() - culled.faces.len();
            wants.push((want, culled));
        }
        assert!(dropped > cams.len(), "{name}: back faces culled ({dropped})");
        // The same with rows decoded and marked per cluster change.
        world.drop_pvs_trees();
        let mut scratch = Scratch::new(&world);
        for (cam, (want, culled)) in cams.iter().zip(&wants) {
            Pvs.cull(&world, &cam.view(), &mut scratch, &mut fast);
            assert_eq!(&fast, want, "{name}: decoded marks vs reference for {cam:?}");
            Pvs.cull(&world, &cam.view().with_back_face_culling(true), &mut scratch, &mut fast);
            assert_eq!(&fast, culled, "{name}: culled decoded marks vs reference for {cam:?}");
        }
        assert!(wants.iter().map(|w| w.0.faces.len()).sum::<usize>() > 1000 * cams.len() / 100);
    }
}

/// The runtime finds a real map's portal file as vis does (`NAME.prt` beside `NAME.vis.bsp`) and
/// reads it the same with Windows line breaks.
#[test]
fn a_crlf_portal_file_beside_a_real_map_gives_the_same_portals() {
    let Some(bsp) = sightline_tests::shared_map("ericw/e1m1_nodetail.vis.bsp") else { return };
    let prt = std::fs::read_to_string(bsp.with_file_name("e1m1_nodetail.prt")).expect("e1m1_nodetail.prt");
    let dir = std::env::temp_dir().join(format!("sightline-crlf-prt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let copy = dir.join("e1m1_nodetail.vis.bsp");
    std::fs::copy(&bsp, &copy).expect("copy");
    std::fs::write(dir.join("e1m1_nodetail.prt"), prt.replace('\n', "\r\n")).expect("write");
    assert_eq!(sightline_formats::prt::find_beside_bsp(&copy), Some(dir.join("e1m1_nodetail.prt")));
    let crlf = load::load_path(&copy).expect("loads");
    let lf = load::load_path(&bsp).expect("loads");
    assert!(lf.num_portals() > 1000);
    assert_eq!(crlf.num_portals(), lf.num_portals());
    std::fs::remove_dir_all(&dir).expect("clean up");
}
