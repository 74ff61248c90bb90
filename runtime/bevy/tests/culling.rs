//! The plugin in a headless Bevy app (no window, no GPU), on a level built here whose PVS is
//! exact: a row of six 64-unit cells along Quake's `+X` with cell 3 solid, so cells 0–2 (clusters
//! 0–2) and cells 4–5 (clusters 3–4) are two rooms that cannot see each other through the wall.
//! Then the scripted walk on a real map (`ericw/e1m1.vis.bsp`, when the shared maps are present).

use std::any::TypeId;
use std::path::Path;

use bevy::app::App;
use bevy::asset::Assets;
use bevy::camera::visibility::VisibleEntities;
use bevy::ecs::prelude::*;
use bevy::math::primitives::Cuboid;
use bevy::math::{Quat, Vec3};
use bevy::mesh::{Mesh, Mesh3d};
use bevy::transform::components::Transform;
use sightline_bevy::coords::to_bevy;
use sightline_bevy::{ClusterMesh, LevelAsset, LevelRoot, PvsCamera, PvsCameraState, PvsCulled};
use sightline_formats::rle;
use sightline_runtime::World;
use sightline_tests::synth;

// The scripted walk of the `walk` example (test scaffolding, not part of the library).
#[allow(dead_code)]
#[path = "../examples/walk/headless.rs"]
mod headless;
#[allow(dead_code)]
#[path = "../examples/walk/tour.rs"]
mod tour;

use headless::camera_bundle;

const CELL: f32 = 64.0;

/// The two-room level; see the module docs.
fn two_rooms() -> World {
    let mut level = synth::grid_level([6, 1, 1], CELL, false, |x, _, _| x == 3);
    let rooms: [&[usize]; 2] = [&[0, 1, 2], &[3, 4]];
    for cluster in 0..5 {
        let room = rooms.iter().find(|r| r.contains(&cluster)).copied().unwrap_or(&[]);
        let mut row = vec![0u8; level.row_bytes()];
        for &c in room {
            row[c / 8] |= 1 << (c % 8);
        }
        level.pvs_offsets.push(level.pvs_data.len() as u32);
        rle::encode_row(&row, &mut level.pvs_data);
    }
    World::new(&level).expect("valid level")
}

/// The centre of cell `x`, in Bevy's axes.
fn cell_center(x: usize) -> Vec3 {
    to_bevy([(x as f32 + 0.5) * CELL, CELL / 2.0, CELL / 2.0])
}

/// A camera at cell `x`'s centre looking along Quake's `+X` (`-X` when `back`).
fn pose(x: usize, back: bool) -> Transform {
    let dir = if back { -Vec3::X } else { Vec3::X };
    Transform::from_translation(cell_center(x)).looking_to(dir, Vec3::Y)
}

struct Scene {
    app: App,
    /// The cluster mesh entity of each cluster.
    cluster_mesh: Vec<Entity>,
}

fn scene() -> Scene {
    let mut app = headless::app(Path::new("."));
    let world = two_rooms();
    let level = LevelAsset::from_world(world, &mut app.world_mut().resource_mut::<Assets<Mesh>>());
    // Each cell's faces are listed by its own cluster only: one group per cluster, in order.
    assert_eq!(
        level.groups().iter().map(|g| g.clusters.clone()).collect::<Vec<_>>(),
        (0..5).map(|c| vec![c]).collect::<Vec<_>>()
    );
    let handle = app.world_mut().resource_mut::<Assets<LevelAsset>>().add(level);
    app.world_mut().spawn(LevelRoot(handle));
    app.update();
    let mut meshes: Vec<(u32, Entity)> = {
        let world = app.world_mut();
        world.query::<(Entity, &ClusterMesh)>().iter(world).map(|(e, m)| (m.group, e)).collect()
    };
    meshes.sort();
    Scene { app, cluster_mesh: meshes.into_iter().map(|(_, e)| e).collect() }
}

fn visible(app: &App, camera: Entity) -> Vec<Entity> {
    app.world().get::<VisibleEntities>(camera).expect("camera").get(TypeId::of::<Mesh3d>()).to_vec()
}

#[test]
fn a_mesh_behind_the_wall_is_hidden_and_one_in_view_is_shown() {
    let mut s = scene();
    let camera = s.app.world_mut().spawn((camera_bundle(), pose(0, false))).id();
    // A camera without PvsCamera at the same place: Bevy's own frustum culling only.
    let plain = s.app.world_mut().spawn((camera_bundle(), pose(0, false))).remove::<PvsCamera>().id();
    s.app.update();
    let seen = visible(&s.app, camera);
    for c in 0..3 {
        assert!(seen.contains(&s.cluster_mesh[c]), "cluster {c} is in view");
    }
    for c in 3..5 {
        assert!(!seen.contains(&s.cluster_mesh[c]), "cluster {c} is behind the wall");
    }
    // The other view is untouched: Bevy's frustum keeps the meshes beyond the wall there.
    let other = visible(&s.app, plain);
    for c in 0..5 {
        assert!(other.contains(&s.cluster_mesh[c]), "cluster {c} in the plain camera's list");
    }
    let stats = s.app.world().get::<PvsCameraState>(camera).expect("state").stats();
    assert!(stats.culled);
    assert_eq!((stats.drawn, stats.hidden), (3, 2));
}

#[test]
fn a_marked_entity_is_hidden_when_it_crosses_into_the_other_room() {
    let mut s = scene();
    let camera = s.app.world_mut().spawn((camera_bundle(), pose(0, false))).id();
    let cube = s.app.world_mut().resource_mut::<Assets<Mesh>>().add(Cuboid::new(8.0, 8.0, 8.0));
    let thing = s
        .app
        .world_mut()
        .spawn((Mesh3d(cube.clone()), PvsCulled, Transform::from_translation(cell_center(1))))
        .id();
    // Not marked: the plugin never touches it, wherever it is.
    let bystander = s.app.world_mut().spawn((Mesh3d(cube), Transform::from_translation(cell_center(5)))).id();
    s.app.update();
    assert!(visible(&s.app, camera).contains(&thing), "in the eye's room");
    assert!(visible(&s.app, camera).contains(&bystander), "unmarked entities are not culled");
    // Into the other room and back.
    for (x, seen) in [(2, true), (4, false), (5, false), (1, true)] {
        s.app.world_mut().get_mut::<Transform>(thing).expect("thing").translation = cell_center(x);
        s.app.update();
        assert_eq!(visible(&s.app, camera).contains(&thing), seen, "entity in cell {x}");
    }
    // Straddling the wall into the eye's room: visible (conservative).
    let wall_face = to_bevy([3.0 * CELL, CELL / 2.0, CELL / 2.0]);
    s.app.world_mut().get_mut::<Transform>(thing).expect("thing").translation = wall_face - Vec3::X * 2.0;
    s.app.update();
    assert!(visible(&s.app, camera).contains(&thing), "touching cell 2");
}

#[test]
fn a_frozen_eye_keeps_its_set_while_the_camera_flies_away() {
    let mut s = scene();
    let camera = s.app.world_mut().spawn((camera_bundle(), pose(0, false))).id();
    s.app.update();
    let before = visible(&s.app, camera);
    s.app.world_mut().get_mut::<PvsCamera>(camera).expect("camera").freeze = true;
    s.app.update();
    // Fly into the other room and look back: the set is still the one of cell 0.
    *s.app.world_mut().get_mut::<Transform>(camera).expect("camera") = pose(5, true);
    s.app.update();
    let frozen = visible(&s.app, camera);
    assert!(frozen.contains(&s.cluster_mesh[0]) && !frozen.contains(&s.cluster_mesh[4]));
    let mut a = before.clone();
    let mut b = frozen.clone();
    a.sort();
    b.sort();
    assert_eq!(a, b, "the frozen set");
    assert!(s.app.world().get::<PvsCameraState>(camera).expect("state").frozen_eye().is_some());
    // Unfreeze: culled from cell 5 now.
    s.app.world_mut().get_mut::<PvsCamera>(camera).expect("camera").freeze = false;
    s.app.update();
    let live = visible(&s.app, camera);
    assert!(!live.contains(&s.cluster_mesh[0]) && live.contains(&s.cluster_mesh[4]));
}

#[test]
fn an_eye_in_solid_hides_nothing() {
    // (The grid's border cells own the space beyond it: no point of this level is outside, and
    // outside is the same case for the plugin, an eye leaf without a cluster.)
    let mut s = scene();
    let camera = s.app.world_mut().spawn((camera_bundle(), pose(3, false))).id();
    s.app.update();
    let stats = s.app.world().get::<PvsCameraState>(camera).expect("state").stats();
    assert!(!stats.culled);
    assert_eq!(stats.hidden, 0);
    // Cells 4 and 5 are in view and kept.
    let seen = visible(&s.app, camera);
    assert!(seen.contains(&s.cluster_mesh[3]) && seen.contains(&s.cluster_mesh[4]));
    assert_eq!(stats.drawn as usize, seen.len());
}

#[test]
fn a_scaled_and_turned_level_is_culled_in_its_own_space() {
    let mut s = scene();
    let root =
        s.app.world_mut().query_filtered::<Entity, With<LevelRoot>>().single(s.app.world()).expect("root");
    let place = Transform::from_xyz(1000.0, -20.0, 5.0)
        .with_rotation(Quat::from_rotation_y(1.0))
        .with_scale(Vec3::splat(0.03125));
    *s.app.world_mut().get_mut::<Transform>(root).expect("root") = place;
    let at = place * pose(0, false);
    let camera = s.app.world_mut().spawn((camera_bundle(), at)).id();
    s.app.update();
    let seen = visible(&s.app, camera);
    assert!(seen.contains(&s.cluster_mesh[1]));
    assert!(!seen.contains(&s.cluster_mesh[4]));
}

#[test]
fn the_scripted_walk_on_e1m1_hides_and_draws() {
    let Some(dir) = sightline_tests::shared_maps() else {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); the E1M1 walk is not run");
        return;
    };
    let path = dir.join("ericw/e1m1.vis.bsp");
    if !path.is_file() {
        eprintln!("note: {} missing; the E1M1 walk is not run", path.display());
        return;
    }
    let report = headless::walk_file(&path, 60).expect("walk");
    assert_eq!(report.frames, 60);
    assert!(report.stops > 100, "{report:?}");
    assert_eq!(report.culled_frames, 60, "every stop is an open leaf with a cluster: {report:?}");
    assert!(report.drawn_avg > 1.0 && report.hidden_avg > 1.0, "{report:?}");
    assert!(report.drawn_avg + report.hidden_avg <= f64::from(report.meshes), "{report:?}");
    let json = report.to_json();
    for key in ["\"frames\":60", "\"drawn_avg\":", "\"hidden_avg\":", "\"system_us_avg\":"] {
        assert!(json.contains(key), "{json}");
    }
}

#[test]
fn a_damaged_level_fails_to_load_with_its_name_and_place() {
    let Some(dir) = sightline_tests::shared_maps() else {
        eprintln!("note: real maps not found (set SIGHTLINE_MAPS); the damaged-file check is not run");
        return;
    };
    let Ok(bytes) = std::fs::read(dir.join("ericw/e1m1.vis.bsp")) else {
        eprintln!("note: ericw/e1m1.vis.bsp missing; the damaged-file check is not run");
        return;
    };
    let tmp = std::env::temp_dir().join(format!("sightline-bevy-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let path = tmp.join("cut.bsp");
    std::fs::write(&path, &bytes[..1000]).expect("write");
    let err = headless::walk_file(&path, 1).expect_err("a cut file");
    let _ = std::fs::remove_dir_all(&tmp);
    let msg = err.to_string();
    assert!(msg.contains("cut.bsp") && msg.contains("lump"), "{msg}");
    assert!(!msg.contains('\n'), "one line: {msg}");
}
