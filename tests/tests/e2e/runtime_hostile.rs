//! Damaged `.slvl` files through the runtime loader: truncations, bit flips and overwritten words
//! must fail with an error or load a world that answers every query without panicking.

use glam::{Vec3, Vec3A};
use sightline_formats::slvl;
use sightline_runtime::backend::{Backend, portal::Portal, pvs::Pvs};
use sightline_runtime::poses::{SplitMix64, point_in};
use sightline_runtime::{Camera, Scratch, Visible, load};
use sightline_tests::synth;

#[test]
fn damaged_slvl_files_fail_or_answer() {
    let mut level = synth::grid_level([5, 4, 3], 64.0, true, |x, y, z| (x + y + z) % 4 == 0);
    // GVS cells too, so damaged GVS lumps reach the loader and the GVS backend.
    let faces = level.faces.len() as u32;
    level.gvs_faces = (0..faces).step_by(2).collect();
    level.gvs_cells = vec![sightline_formats::level::GvsCell {
        mins: [0.0; 3],
        maxs: [320.0, 256.0, 192.0],
        first_face: 0,
        num_faces: level.gvs_faces.len() as u32,
    }];
    slvl::validate(&level).expect("valid level");
    let bases = [
        slvl::write(&level, &slvl::WriteOptions { compress: false }),
        slvl::write(&level, &slvl::WriteOptions { compress: true }),
    ];
    assert!(load::load_bytes(&bases[0]).is_ok() && load::load_bytes(&bases[1]).is_ok());
    let gvs = sightline_runtime::backend::by_name("gvs").expect("gvs backend");
    assert!(gvs.supports(&load::load_bytes(&bases[0]).expect("loads")));
    // Counts and offsets live in the header and the lump directory.
    let header = slvl::HEADER_BYTES + slvl::LumpKind::ALL.len() * slvl::DIR_ENTRY_BYTES;
    let mut rng = SplitMix64::new(2024);
    let (mut rejected, mut loaded) = (0, 0);
    for i in 0..6000 {
        let bytes = sightline_tests::mutate(&mut rng, &bases[i % 2], header);
        match load::load_bytes(&bytes) {
            Err(e) => {
                assert!(!e.to_string().is_empty());
                rejected += 1;
            }
            Ok(world) => {
                loaded += 1;
                let mut scratch = Scratch::new(&world);
                let mut out = Visible::default();
                let p = point_in(&mut rng, Vec3A::splat(-64.0), Vec3A::splat(400.0));
                let _ = world.leaf_at(p);
                let _ = world.trace(p, p + Vec3A::new(300.0, 50.0, -20.0));
                let cam = Camera::quake(Vec3::from(p), rng.range(0.0, 360.0), 0.0);
                Pvs.cull(&world, &cam.view(), &mut scratch, &mut out);
                Portal.cull(&world, &cam.view(), &mut scratch, &mut out);
                if gvs.supports(&world) {
                    gvs.cull(&world, &cam.view(), &mut scratch, &mut out);
                }
            }
        }
    }
    assert!(rejected > 3000, "only {rejected} of 6000 damaged files rejected ({loaded} loaded)");
}
