//! The runtime on levels our compiler builds from the bundled maps, with vis and with `--no-vis`
//! (portals only): the portal backend needs nothing precomputed and stays inside the PVS.

use glam::Vec3;
use sightline_compiler::{CompileOptions, NoProgress, Source, compile, vis::VisOptions};
use sightline_formats::map::{self, MapFile};
use sightline_runtime::backend::{Backend, portal::Portal, pvs::Pvs};
use sightline_runtime::poses::random_cameras;
use sightline_runtime::{Camera, Scratch, Visible, World};

fn compiled(name: &str, vis: bool) -> (MapFile, World) {
    let path = sightline_tests::bundled_maps().join(name);
    let text = std::fs::read_to_string(&path).expect("bundled map");
    let parsed = map::parse(&text, name).expect("map parses");
    let opts =
        CompileOptions { vis: vis.then(VisOptions::default), threads: Some(1), ..CompileOptions::default() };
    let out = compile(&Source::Map { map: parsed.clone(), file: name.to_string() }, &opts, &NoProgress)
        .expect("compiles");
    let world = World::new(&out.level).expect("the runtime accepts the compiler's level");
    assert_eq!(world.has_vis(), vis);
    assert!(world.num_portals() > 0, "{name}: the level carries its portals");
    (parsed, world)
}

fn spot(map: &MapFile, target: &str) -> Vec3 {
    let e = map.entities.iter().find(|e| e.get("targetname") == Some(target)).expect("named spot");
    e.origin().expect("origin").as_vec3()
}

#[test]
fn portal_backend_sees_no_more_than_the_pvs_on_compiled_maps() {
    for name in ["lbend.map", "stairs_pillars.map", "angled.map", "two_rooms.map"] {
        let (_, world) = compiled(name, true);
        let mut scratch = Scratch::new(&world);
        let (mut pvs, mut portal) = (Visible::default(), Visible::default());
        let cams = random_cameras(&world, 3, 600);
        assert_eq!(cams.len(), 600, "{name}: camera poses in open leaves");
        for cam in cams {
            Pvs.cull(&world, &cam.view(), &mut scratch, &mut pvs);
            Portal.cull(&world, &cam.view(), &mut scratch, &mut portal);
            let extra: Vec<u32> = portal.leaves.iter().copied().filter(|l| !pvs.leaves.contains(l)).collect();
            assert!(extra.is_empty(), "{name}: portal leaves {extra:?} outside PVS ∩ frustum for {cam:?}");
        }
    }
}

#[test]
fn portal_backend_hides_the_l_bend_without_vis() {
    let (map, world) = compiled("lbend.map", false);
    let (a, c) = (spot(&map, "room_a"), spot(&map, "room_c"));
    let hidden = world.leaf_at(c);
    let mut scratch = Scratch::new(&world);
    let (mut pvs, mut portal) = (Visible::default(), Visible::default());
    let (mut pvs_saw, mut portal_saw) = (false, false);
    for yaw in (0..360).step_by(15) {
        let cam = Camera::quake(a, yaw as f32, 0.0);
        Pvs.cull(&world, &cam.view(), &mut scratch, &mut pvs);
        Portal.cull(&world, &cam.view(), &mut scratch, &mut portal);
        assert!(!portal.leaves.is_empty());
        pvs_saw |= pvs.leaves.contains(&hidden);
        portal_saw |= portal.leaves.contains(&hidden);
    }
    assert!(pvs_saw, "without vis the PVS backend draws everything in the frustum");
    assert!(!portal_saw, "the portal backend must not see room_c from room_a");
}

#[test]
fn compiled_faces_carry_their_sides_texture_projection() {
    // Standard and Valve 220 sides, rotated and angled ones included.
    for name in ["angled.map", "valve220.map", "stairs_pillars.map", "detail_water.map"] {
        let (map, world) = compiled(name, false);
        let draw = world.draw();
        assert!(draw.has_face_draw(), "{name}: texture projections");
        assert!(draw.num_faces() > 0, "{name}: faces");
        let sides: Vec<&map::BrushSide> =
            map.entities.iter().flat_map(|e| &e.brushes).flat_map(|b| &b.sides).collect();
        for f in 0..draw.num_faces() as u32 {
            let face = draw.face(f).expect("face");
            let d = face.draw.expect("projection");
            let texture = draw.texture_name(face.texture).expect("texture");
            // Some side with this texture lies in the face's plane (either orientation: liquids are
            // seen from inside too) and projects exactly so.
            let found = sides.iter().any(|s| {
                let n = s.plane.normal.as_vec3a();
                let same_plane = (n.dot(face.normal).abs() > 0.9999)
                    && face
                        .vertices
                        .iter()
                        .all(|v| (n.dot(glam::Vec3A::from_array(*v)) - s.plane.dist as f32).abs() < 0.05);
                let [sv, tv] = s.axes.vectors(s.plane.normal).map(|v| v.map(|c| c as f32));
                s.texture == texture && same_plane && [sv, tv] == [d.s, d.t]
            });
            assert!(found, "{name}: face {f} ({texture}) has no side with its plane and projection");
        }
    }
}
