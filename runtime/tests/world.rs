//! Unit tests over synthetic grid levels: queries against brute force, walk order, backends,
//! and validation of damaged levels.

use glam::{Vec3, Vec3A};
use sightline_formats::level::Level;

use sightline_runtime::backend::{Backend, portal::Portal, pvs::Pvs};
use sightline_runtime::camera::{BoxSide, Camera, Frustum};
use sightline_runtime::poses::{SplitMix64, point_in, random_cameras};
use sightline_runtime::scratch::{Scratch, Visible};
use sightline_runtime::world::World;
use sightline_tests::runtime_check::{LeafRegions, order_violations, sampled_leaves};
use sightline_tests::synth::grid_level;

/// 8×6×3 cells of 64 units with random pillars (about a quarter solid).
fn pillars(seed: u64) -> Level {
    let mut rng = SplitMix64::new(seed);
    let solid: Vec<bool> = (0..8 * 6 * 3).map(|_| rng.below(4) == 0).collect();
    grid_level([8, 6, 3], 64.0, true, |x, y, z| solid[(z * 6 + y) * 8 + x])
}

/// An L: a corridor along +X (y = 0), turning into +Y at x = 7; everything else solid.
fn l_bend() -> Level {
    grid_level([8, 8, 1], 64.0, true, |x, y, _| !(y == 0 || x == 7))
}

#[test]
fn grid_level_loads() {
    let world = World::new(&pillars(1)).expect("valid");
    assert_eq!(world.num_leaves(), 8 * 6 * 3);
    assert!(world.depth() >= 7 && world.depth() <= 9, "depth {}", world.depth());
    assert!(world.has_vis());
}

#[test]
fn leaf_at_agrees_with_brute_force() {
    for seed in 0..4 {
        let world = World::new(&pillars(seed)).expect("valid");
        let regions = LeafRegions::new(&world);
        let mut rng = SplitMix64::new(seed + 100);
        for _ in 0..2000 {
            // Include points outside the grid, and points exactly on cell planes.
            let mut p = point_in(&mut rng, Vec3A::splat(-100.0), Vec3A::new(612.0, 484.0, 292.0));
            if rng.below(4) == 0 {
                p.x = (p.x / 64.0).round() * 64.0;
            }
            assert_eq!(regions.leaves_at(p), vec![world.leaf_at(p)], "point {p:?}");
        }
    }
}

#[test]
fn trace_agrees_with_sampling() {
    let world = World::new(&pillars(7)).expect("valid");
    let mut rng = SplitMix64::new(3);
    let mut hits = 0;
    for _ in 0..1000 {
        let a = sightline_runtime::poses::random_open_point(&world, &mut rng).expect("open point");
        let b = point_in(&mut rng, Vec3A::splat(-50.0), Vec3A::new(562.0, 434.0, 242.0));
        let samples = 4000;
        let first_solid = sampled_leaves(&world, a, b, samples)
            .into_iter()
            .find(|&(_, l)| world.leaf_contents(l).is_some_and(|c| !c.is_open()));
        let len = (b - a).length();
        let step = 1.0 / samples as f32 + 0.05 / len;
        match (world.trace(a, b), first_solid) {
            (None, None) => {}
            (Some(hit), Some((t, leaf))) => {
                hits += 1;
                assert!(!hit.start_solid);
                assert!(
                    (hit.fraction - t).abs() <= step + 0.04 / len,
                    "trace {hit:?} vs sampled {t} (len {len})"
                );
                assert_eq!(hit.leaf, leaf);
                assert!((hit.normal.length() - 1.0).abs() < 1e-4);
                assert!(hit.normal.dot(b - a) < 0.0, "normal faces the segment's start");
                assert!(world.leaf_contents(world.leaf_at(hit.point)).is_some_and(|c| c.is_open()));
            }
            (hit, sampled) => panic!("trace {hit:?} vs sampled {sampled:?} from {a:?} to {b:?}"),
        }
    }
    assert!(hits > 100, "only {hits} segments hit solid");
}

#[test]
fn trace_from_solid_starts_solid() {
    let world = World::new(&l_bend()).expect("valid");
    let hit = world.trace(Vec3A::new(32.0, 200.0, 32.0), Vec3A::new(32.0, 32.0, 32.0)).expect("hit");
    assert!(hit.start_solid);
    assert_eq!(hit.fraction, 0.0);
}

/// The open, marked leaves whose box is not outside the frustum: what the walk must output.
fn expected_set(world: &World, cam: &Camera) -> Vec<u32> {
    let fr: Frustum = cam.view().frustum;
    let mut v: Vec<u32> = world
        .open_leaves()
        .iter()
        .copied()
        .filter(|&l| {
            let b = world.leaf_bounds(l).expect("leaf");
            fr.test_box(b.center, b.extent, Frustum::ALL) != BoxSide::Outside
        })
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn pvs_walk_outputs_frustum_leaves_front_to_back() {
    let world = World::new(&pillars(11)).expect("valid");
    let mut scratch = Scratch::new(&world);
    let mut out = Visible::for_world(&world);
    for cam in random_cameras(&world, 5, 300) {
        Pvs.cull(&world, &cam.view(), &mut scratch, &mut out);
        let mut got = out.leaves.clone();
        got.sort_unstable();
        assert_eq!(got, expected_set(&world, &cam), "all-visible PVS: output is the frustum set");
        let bad = order_violations(&world, cam.view().eye, &out.leaves, 512);
        assert!(bad.is_empty(), "order violations {bad:?} for {cam:?}");
        // Faces: each once, and exactly those of the output leaves.
        let mut faces = out.faces.clone();
        faces.sort_unstable();
        faces.dedup();
        assert_eq!(faces.len(), out.faces.len());
        let want: usize = out.leaves.iter().map(|&l| world.leaf_faces(l).len()).sum();
        assert_eq!(faces.len(), want);
    }
}

#[test]
fn pvs_marks_are_reused_while_the_eye_stays_in_its_cluster() {
    let world = World::new(&pillars(3)).expect("valid");
    let mut scratch = Scratch::new(&world);
    let mut out = Visible::for_world(&world);
    let cam = random_cameras(&world, 1, 1)[0];
    Pvs.cull(&world, &cam.view(), &mut scratch, &mut out);
    assert!(!scratch.stats.marks_reused);
    let turned = Camera { yaw: cam.yaw + 90.0, ..cam };
    Pvs.cull(&world, &turned.view(), &mut scratch, &mut out);
    assert!(scratch.stats.marks_reused);
}

#[test]
fn portal_backend_hides_the_room_around_the_corner() {
    let world = World::new(&l_bend()).expect("valid");
    let mut scratch = Scratch::new(&world);
    let (mut pvs, mut portal) = (Visible::default(), Visible::default());
    // At the corridor's start looking along +X: the far arm (x = 7, y >= 2) is around the corner.
    let cam = Camera::quake(Vec3::new(32.0, 32.0, 32.0), 0.0, 0.0);
    Pvs.cull(&world, &cam.view(), &mut scratch, &mut pvs);
    Portal.cull(&world, &cam.view(), &mut scratch, &mut portal);
    let far_arm = |l: &u32| (*l as usize / 8) >= 3;
    assert!(pvs.leaves.iter().any(far_arm), "the all-visible PVS includes the far arm");
    assert!(
        !portal.leaves.iter().any(far_arm),
        "portal search reached around the corner: {:?}",
        portal.leaves
    );
    assert!(portal.leaves.len() >= 8, "the straight corridor is visible: {:?}", portal.leaves);
    assert!(order_violations(&world, cam.view().eye, &portal.leaves, 512).is_empty());
}

#[test]
fn portal_backend_finds_what_rays_see() {
    let world = World::new(&pillars(5)).expect("valid");
    let mut scratch = Scratch::new(&world);
    let mut out = Visible::default();
    let mut rng = SplitMix64::new(77);
    let mut checked = 0;
    for cam in random_cameras(&world, 21, 200) {
        let view = cam.view();
        Portal.cull(&world, &view, &mut scratch, &mut out);
        assert!(!scratch.stats.truncated);
        let (f, r, u) = cam.basis();
        for _ in 0..50 {
            // A ray inside the frustum, traced to its first solid.
            let h = (cam.fov_y.to_radians() * 0.5).tan();
            let dir = f + r * rng.range(-0.95, 0.95) * h * cam.aspect + u * rng.range(-0.95, 0.95) * h;
            let end = view.eye + dir * 2000.0;
            let stop = world.trace(view.eye, end).map_or(1.0, |hit| hit.fraction);
            for (t, leaf) in sampled_leaves(&world, view.eye, end, 4000) {
                let inside = (view.eye + dir * 2000.0 * t).cmpge(Vec3A::ZERO).all()
                    && (view.eye + dir * 2000.0 * t).cmple(Vec3A::new(512.0, 384.0, 192.0)).all();
                if t >= stop - 0.002 || !inside {
                    // Past the first solid, or out of the (unsealed) grid.
                    break;
                }
                if (view.eye + dir * 2000.0 * t - view.eye).length() < cam.near + 1.0 {
                    continue;
                }
                checked += 1;
                assert!(
                    out.leaves.contains(&leaf),
                    "ray-visible leaf {leaf} missing for {cam:?}: dir {dir:?} path {:?} out {:?} marked {}",
                    sampled_leaves(&world, view.eye, end, 4000),
                    out.leaves,
                    scratch.stats.marked_leaves
                );
            }
        }
    }
    assert!(checked > 1000);
}

#[test]
fn damaged_levels_fail_or_answer_without_panicking() {
    let base = pillars(4);
    let mut rng = SplitMix64::new(99);
    let (mut rejected, mut accepted) = (0, 0);
    for _ in 0..3000 {
        let mut level = base.clone();
        for _ in 0..1 + rng.below(3) {
            mutate(&mut level, &mut rng);
        }
        match World::new(&level) {
            Err(_) => rejected += 1,
            Ok(world) => {
                accepted += 1;
                let mut scratch = Scratch::new(&world);
                let mut out = Visible::default();
                for i in 0..4 {
                    let p = point_in(&mut rng, Vec3A::splat(-100.0), Vec3A::splat(600.0));
                    let cam = Camera::quake(Vec3::from(p), rng.range(0.0, 360.0), 0.0);
                    let _ = world.leaf_at(p);
                    let _ = world.trace(p, p + Vec3A::splat(300.0));
                    Pvs.cull(&world, &cam.view(), &mut scratch, &mut out);
                    if i % 2 == 0 {
                        Portal.cull(&world, &cam.view(), &mut scratch, &mut out);
                    }
                }
            }
        }
    }
    assert!(rejected > 1000 && accepted > 100, "rejected {rejected}, accepted {accepted}");
}

fn mutate(level: &mut Level, rng: &mut SplitMix64) {
    let wild = |rng: &mut SplitMix64| -> i64 {
        match rng.below(4) {
            0 => rng.below(8) as i64 - 4,
            1 => i64::from(i32::MAX) - rng.below(3) as i64,
            2 => rng.below(1000) as i64,
            _ => -(rng.below(1000) as i64),
        }
    };
    let v = wild(rng);
    match rng.below(12) {
        0 if !level.nodes.is_empty() => {
            let i = rng.below(level.nodes.len());
            level.nodes[i].children[rng.below(2)] = v as i32;
        }
        1 if !level.nodes.is_empty() => {
            let i = rng.below(level.nodes.len());
            level.nodes[i].plane = v as u32;
        }
        2 if !level.leaves.is_empty() => {
            let i = rng.below(level.leaves.len());
            level.leaves[i].cluster = v as i32;
        }
        3 if !level.leaves.is_empty() => {
            let i = rng.below(level.leaves.len());
            level.leaves[i].first_face = v as u32;
        }
        4 if !level.leaves.is_empty() => {
            let i = rng.below(level.leaves.len());
            level.leaves[i].mins[rng.below(3)] = [f32::NAN, 1e30, -5.0, 700.0][rng.below(4)];
        }
        5 if !level.planes.is_empty() => {
            let i = rng.below(level.planes.len());
            level.planes[i].normal[rng.below(3)] = [f32::NAN, 0.0, 2.0, f32::INFINITY][rng.below(4)];
        }
        6 if !level.pvs_offsets.is_empty() => {
            let i = rng.below(level.pvs_offsets.len());
            level.pvs_offsets[i] = v as u32;
        }
        7 if !level.pvs_data.is_empty() => {
            let n = rng.below(level.pvs_data.len());
            level.pvs_data.truncate(n);
        }
        8 if !level.portals.is_empty() => {
            let i = rng.below(level.portals.len());
            level.portals[i].leaves[rng.below(2)] = v as u32;
        }
        9 if !level.portals.is_empty() => {
            let i = rng.below(level.portals.len());
            level.portals[i].num_vertices = v as u32;
        }
        10 => level.num_clusters = v as u32,
        11 if !level.models.is_empty() => level.models[0].head_node = v as i32,
        _ => level.models.clear(),
    }
}

#[test]
fn world_is_shareable_and_scratch_follows_the_world() {
    fn shareable<T: Send + Sync>() {}
    shareable::<World>();
    let small = World::new(&l_bend()).expect("valid");
    let big = World::new(&pillars(6)).expect("valid");
    let mut scratch = Scratch::new(&small);
    let mut out = Visible::default();
    let cam = random_cameras(&big, 4, 1)[0];
    // A scratch made for another world resizes itself and gives the same answer as a fresh one.
    Pvs.cull(&big, &cam.view(), &mut scratch, &mut out);
    let mut fresh = Visible::default();
    Pvs.cull(&big, &cam.view(), &mut Scratch::new(&big), &mut fresh);
    assert_eq!(out, fresh);
    assert!(!out.leaves.is_empty());
}

#[test]
fn fast_walks_equal_the_reference_walk() {
    use sightline_tests::runtime_check::{pvs_leaves, reference_walk};
    for seed in [12, 13] {
        let level = pillars(seed);
        let trees = World::new(&level).expect("valid");
        assert!(trees.pvs_trees_in_memory());
        let mut decoding = World::new(&level).expect("valid");
        decoding.drop_pvs_trees();
        let (mut s1, mut s2) = (Scratch::new(&trees), Scratch::new(&decoding));
        let (mut a, mut b) = (Visible::for_world(&trees), Visible::for_world(&decoding));
        let mut dropped = 0;
        for cam in random_cameras(&trees, seed, 400) {
            let view = cam.view();
            let marked = pvs_leaves(&trees, view.eye);
            let want = reference_walk(&trees, &view, &|l| marked[l as usize]);
            Pvs.cull(&trees, &view, &mut s1, &mut a);
            Pvs.cull(&decoding, &view, &mut s2, &mut b);
            assert_eq!(a, want, "PVS trees vs reference for {cam:?}");
            assert_eq!(b, want, "decoded marks vs reference for {cam:?}");
            assert_eq!(s1.stats.marked_leaves, s2.stats.marked_leaves);
            // A portal frame in between overwrites the scratch marks: the same view again must
            // decode again, not reuse them.
            Portal.cull(&decoding, &view, &mut s2, &mut b);
            Pvs.cull(&decoding, &view, &mut s2, &mut b);
            assert_eq!(b, want, "decoded marks after a portal frame for {cam:?}");
            // Back-face culling in the walk: the reference with the same culling, and the
            // unculled output with the back faces dropped afterwards.
            let culled_view = view.with_back_face_culling(true);
            let culled = reference_walk(&trees, &culled_view, &|l| marked[l as usize]);
            let mut after = want.clone();
            trees.cull_back_faces(view.eye, &mut after.faces);
            assert_eq!(culled, after, "culled reference vs a pass after the walk for {cam:?}");
            Pvs.cull(&trees, &culled_view, &mut s1, &mut a);
            Pvs.cull(&decoding, &culled_view, &mut s2, &mut b);
            assert_eq!(a, culled, "culled PVS trees vs reference for {cam:?}");
            assert_eq!(b, culled, "culled decoded marks vs reference for {cam:?}");
            dropped += want.faces.len() - culled.faces.len();
        }
        assert!(dropped > 0, "seed {seed}: some back faces were culled");
    }
}

#[test]
fn simd_box_test_equals_the_scalar_test() {
    let mut rng = SplitMix64::new(5);
    for _ in 0..20_000 {
        let cam = Camera::quake(
            Vec3::new(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), rng.range(-50.0, 50.0)),
            rng.range(0.0, 360.0),
            rng.range(-80.0, 80.0),
        );
        let fr = cam.view().frustum;
        let c = point_in(&mut rng, Vec3A::splat(-300.0), Vec3A::splat(300.0));
        let e = point_in(&mut rng, Vec3A::ZERO, Vec3A::splat(80.0));
        let mask = rng.below(64) as u8;
        let want = sightline_tests::runtime_check::scalar_box_test(&fr, c, e, mask)
            .map_or(BoxSide::Outside, BoxSide::Inside);
        assert_eq!(fr.test_box(c, e, mask), want, "box {c:?} ± {e:?}, mask {mask:#x}");
    }
}

#[test]
fn a_world_with_gvs_cells_offers_the_gvs_backend() {
    use sightline_formats::level::GvsCell;
    use sightline_runtime::{GvsCells, backend};
    let mut level = pillars(8);
    let plain = World::new(&level).expect("valid");
    let gvs = backend::by_name("gvs").expect("gvs is in backend::all()");
    assert!(!gvs.supports(&plain), "no cells, no GVS backend");
    assert!(plain.gvs_cells().is_none());
    // Two cells: each sees every third face.
    let faces = level.faces.len() as u32;
    level.gvs_faces = (0..faces).step_by(3).chain((1..faces).step_by(3)).collect();
    let half = faces.div_ceil(3);
    level.gvs_cells = vec![
        GvsCell { mins: [0.0; 3], maxs: [256.0, 384.0, 192.0], first_face: 0, num_faces: half },
        GvsCell {
            mins: [256.0, 0.0, 0.0],
            maxs: [512.0, 384.0, 192.0],
            first_face: half,
            num_faces: level.gvs_faces.len() as u32 - half,
        },
    ];
    let world = World::new(&level).expect("valid with cells");
    assert!(gvs.supports(&world));
    // The backend answers what the level's cells answer directly.
    let cells = GvsCells::from_level(&level).expect("cells");
    let mut scratch = Scratch::new(&world);
    let (mut a, mut b) = (Visible::default(), Vec::new());
    let mut seen = 0;
    for cam in random_cameras(&world, 3, 200) {
        let view = cam.view();
        gvs.cull(&world, &view, &mut scratch, &mut a);
        cells.query(view.eye, &view.frustum, &mut b);
        if view.cull_back_faces {
            world.cull_back_faces(view.eye, &mut b);
        }
        assert_eq!(a.faces, b);
        assert!(a.leaves.is_empty());
        seen += a.faces.len();
    }
    assert!(seen > 0, "the cells' faces are seen");
    // A damaged GVS lump fails the load.
    level.gvs_faces[0] = faces + 5;
    assert!(matches!(World::new(&level), Err(sightline_runtime::LoadError::Invalid(_))));
}

#[test]
fn world_new_runs_the_shared_level_rules_then_its_own() {
    use sightline_formats::slvl;
    use sightline_runtime::LoadError;
    // A rule every reader shares, stated once in `slvl::validate` (the runtime never reads
    // textures, yet rejects what `.slvl` reading rejects).
    let mut level = pillars(9);
    level.faces[0].texture = 99;
    assert!(slvl::validate(&level).is_err());
    assert!(matches!(World::new(&level), Err(LoadError::Invalid(_))));
    // The runtime's own rules: unit normals, a strict world tree of bounded depth.
    let mut level = pillars(9);
    level.planes[0].normal = [2.0, 0.0, 0.0];
    assert_eq!(slvl::validate(&level), Ok(()));
    assert!(matches!(World::new(&level), Err(LoadError::BadPlane { index: 0 })));
    let mut level = pillars(9);
    let shared = level.nodes[0].children[0];
    level.nodes[0].children[1] = shared;
    assert_eq!(slvl::validate(&level), Ok(()), "a shared subtree is acyclic");
    assert!(matches!(World::new(&level), Err(LoadError::NotATree { .. } | LoadError::SharedLeaf { .. })));
}

/// An error and its causes, joined as the CLI prints them (anyhow's `{:#}`).
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}

#[test]
fn errors_print_each_cause_once_and_name_the_lump() {
    use sightline_runtime::LoadError;
    let mut level = pillars(9);
    level.faces[0].texture = 99;
    let e = World::new(&level).expect_err("bad texture index");
    let cause = std::error::Error::source(&e).expect("the slvl rule is the source").to_string();
    assert_eq!(error_chain(&e), format!("invalid level: {cause}"));
    assert_eq!(error_chain(&e).matches(&cause).count(), 1);
    let mut level = pillars(9);
    level.models.clear();
    let e = World::new(&level).expect_err("no models");
    assert!(matches!(e, LoadError::Invalid(_)), "the rule every reader shares: {e:?}");
    let no_world =
        "lump models, record 0 (byte 0 of the uncompressed lump): no world model (model 0) to root the tree";
    assert!(error_chain(&e).starts_with(&format!("invalid level: {no_world}")), "{}", error_chain(&e));
    // `load_path` names the file once, whatever failed.
    let dir = std::env::temp_dir().join(format!("sightline-runtime-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("modelless.slvl");
    let bytes = sightline_formats::slvl::write(&level, &sightline_formats::slvl::WriteOptions::default());
    std::fs::write(&path, bytes).expect("write");
    let e = sightline_runtime::load::load_path(&path).expect_err("no models");
    let name = path.display().to_string();
    assert!(error_chain(&e).starts_with(&format!("{name}: {no_world}")), "{}", error_chain(&e));
    let missing = dir.join("missing.bsp");
    let e = sightline_runtime::load::load_path(&missing).expect_err("missing");
    assert_eq!(error_chain(&e).matches(&missing.display().to_string()).count(), 1, "{}", error_chain(&e));
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn brush_models_take_the_origin_of_their_entity() {
    use sightline_formats::entities::EntityError;
    use sightline_runtime::error::LoadError;
    let mut level = pillars(3);
    let world_model = level.models[0];
    level.models.push(sightline_formats::level::Model { num_faces: 0, ..world_model });
    level.models.push(sightline_formats::level::Model { num_faces: 0, ..world_model });
    level.entities = "{ \"classname\" \"worldspawn\" }\n\
                      { \"classname\" \"func_rotating\" \"model\" \"*1\" \"origin\" \"1 2 -82\" }\n\
                      { \"classname\" \"func_door\" \"model\" \"*2\" }\n\
                      { \"classname\" \"func_door\" \"model\" \"*9\" \"origin\" \"5 5 5\" }\n"
        .to_string();
    let world = World::new(&level).expect("valid");
    let models = world.draw().models();
    let origins: Vec<[f32; 3]> = models.iter().map(|m| m.origin.to_array()).collect();
    assert_eq!(origins, [[0.0; 3], [1.0, 2.0, -82.0], [0.0; 3]], "a model no entity names keeps zero");
    assert_eq!(world.draw().entity_list().len(), 4);
    assert_eq!(world.draw().entity_list()[1].classname(), "func_rotating");
    // A brush entity's origin that is not three finite numbers, and text that does not parse,
    // refuse the level with the byte offset.
    let rotating = level.entities.find("{ \"classname\" \"func_rotating\"").expect("entity");
    level.entities = level.entities.replace("1 2 -82", "1 nan -82");
    match World::new(&level) {
        Err(LoadError::Entities(EntityError::BadOrigin { offset, .. })) => assert_eq!(offset, rotating),
        other => panic!("bad origin accepted: {other:?}"),
    }
    level.entities = "{ \"classname\" \"worldspawn\"".to_string();
    assert!(matches!(World::new(&level), Err(LoadError::Entities(EntityError::Unclosed { offset: 0 }))));
}
