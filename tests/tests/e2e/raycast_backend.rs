//! The ray-casting backend on real levels: what its rays reach is a subset of the PVS walk's
//! leaves and faces (it is aggressive: never more, often less), and it falls back to the PVS walk
//! exactly when told.

use sightline_runtime::backend::raycast::RayCast;
use sightline_runtime::backend::{Backend, pvs::Pvs};
use sightline_runtime::poses::random_cameras;
use sightline_runtime::{Scratch, Visible, load};

/// Vised levels of three families.
const LEVELS: [&str; 4] =
    ["ericw/e1m1.vis.bsp", "ericw/dm2.vis.bsp", "hl/start.sdhlt.vis.bsp", "q2/e1m1.ericw.t1.bsp"];

#[test]
fn raycast_leaves_are_a_subset_of_the_pvs_walk_leaves_on_real_maps() {
    let always = RayCast { adaptive: false, ..RayCast::DEFAULT };
    for rel in LEVELS {
        let Some(path) = sightline_tests::shared_map(rel) else { continue };
        let world = load::load_path(&path).unwrap_or_else(|e| panic!("{rel}: {e}"));
        let mut scratch = Scratch::new(&world);
        let (mut pvs, mut ray) = (Visible::for_world(&world), Visible::for_world(&world));
        let (mut sum_pvs, mut sum_ray, mut cast) = (0usize, 0usize, 0usize);
        for cam in random_cameras(&world, 5, 200) {
            let view = cam.view();
            Pvs.cull(&world, &view, &mut scratch, &mut pvs);
            always.cull(&world, &view, &mut scratch, &mut ray);
            let extra: Vec<u32> = ray.leaves.iter().copied().filter(|l| !pvs.leaves.contains(l)).collect();
            assert!(extra.is_empty(), "{rel}: ray-cast leaves {extra:?} outside the PVS walk for {cam:?}");
            assert!(ray.faces.iter().all(|f| pvs.faces.contains(f)), "{rel}: faces outside the PVS walk");
            if scratch.stats.rays > 0 {
                let (cols, rows) = always.grid();
                assert_eq!(scratch.stats.rays, cols * rows);
                assert!(!ray.leaves.is_empty(), "{rel}: rays reach at least the eye's leaf");
                cast += 1;
            }
            sum_pvs += pvs.leaves.len();
            sum_ray += ray.leaves.len();
        }
        assert!(cast >= 160, "{rel}: {cast} of 200 frames cast rays");
        assert!(sum_ray < sum_pvs, "{rel}: rays {sum_ray} vs PVS {sum_pvs}: rays hide occluded leaves");
    }
}

#[test]
fn adaptive_raycast_frames_are_the_rays_or_the_pvs_walks() {
    let Some(path) = sightline_tests::shared_map("ericw/e1m1.vis.bsp") else { return };
    let world = load::load_path(&path).unwrap();
    let always = RayCast { adaptive: false, ..RayCast::DEFAULT };
    assert!(!RayCast::DEFAULT.conservative() && Pvs.conservative());
    assert!(!sightline_runtime::backend::gvs::Gvs.conservative(), "GVS sets are sampled");
    let (mut s1, mut s2) = (Scratch::new(&world), Scratch::new(&world));
    let (mut rays, mut pvs, mut adaptive) =
        (Visible::for_world(&world), Visible::for_world(&world), Visible::for_world(&world));
    for cam in random_cameras(&world, 11, 200) {
        let view = cam.view();
        always.cull(&world, &view, &mut s1, &mut rays);
        Pvs.cull(&world, &view, &mut s1, &mut pvs);
        RayCast::DEFAULT.cull(&world, &view, &mut s2, &mut adaptive);
        if s2.stats.rays == 0 {
            assert_eq!(adaptive, pvs, "a fallback frame is the PVS walk's");
        } else {
            assert_eq!(adaptive, rays, "a ray frame is the rays'");
        }
    }
}
