//! Where the viewer puts its camera: at the level's `info_player_start`, looking along its
//! angle, or in front of a face of a given [`Surface`] (the stills of `--shots`).
//!
//! Poses are `Transform`s in the level root's space (Bevy axes, level units,
//! [`sightline_bevy::coords`]). Quake's `angle` is a yaw in degrees, counter-clockwise seen from
//! above, 0 along +X; a Bevy camera looks along its −Z, so the yaw about +Y is `angle − 90°`.

use bevy::math::{Quat, Vec3};
use bevy::transform::components::Transform;
use sightline_bevy::Surface;
use sightline_bevy::coords::to_bevy;
use sightline_formats::level::Contents;
use sightline_runtime::World;

/// Eye height above a player's origin, Quake units (Quake's `DEFAULT_VIEWHEIGHT`).
const EYE_HEIGHT: f32 = 22.0;

/// Distances in front of a face at which a camera may stand to look at it, nearest first.
const STANDOFFS: [f32; 5] = [256.0, 160.0, 96.0, 48.0, 24.0];

/// The eye of the first `info_player_start` with a well-formed origin, looking along its
/// `angle` (0 when absent), in an open leaf.
pub fn player_start(world: &World) -> Option<Transform> {
    let start = world.draw().entity_list().iter().find(|e| e.classname() == "info_player_start")?;
    let [x, y, z] = start.origin()?.ok()?;
    let eye = [x, y, z + EYE_HEIGHT];
    if !is_open(world, eye) {
        return None;
    }
    let angle: f32 =
        start.get("angle").and_then(|a| a.trim().parse().ok()).filter(|a: &f32| a.is_finite()).unwrap_or(0.0);
    let yaw = (angle - 90.0).to_radians();
    Some(Transform::from_translation(to_bevy(eye)).with_rotation(Quat::from_rotation_y(yaw)))
}

/// A camera looking at the centre of the first world face (in face order) of `surface` that an
/// open point in front of it sees unobstructed; `None` when the level has none.
pub fn facing(world: &World, surface: Surface) -> Option<Transform> {
    let draw = world.draw();
    let faces = draw.models().first().map_or(0..draw.num_faces() as u32, |m| m.faces.clone());
    faces.filter_map(|f| draw.face(f)).find_map(|face| {
        if Surface::of(draw.texture_name(face.texture).unwrap_or("")) != surface || face.vertices.is_empty() {
            return None;
        }
        let sum = face.vertices.iter().fold(Vec3::ZERO, |s, &p| s + Vec3::from_array(p));
        let centre = sum / face.vertices.len() as f32;
        let normal = Vec3::from_array(face.normal.to_array());
        STANDOFFS.iter().find_map(|&d| {
            // A little to the side as well, so the view is never straight along an axis.
            let eye = centre + normal * d + normal.any_orthonormal_vector() * (d * 0.25);
            let near_face = centre + normal * 1.0;
            (is_open(world, eye.to_array()) && world.trace(eye.to_array(), near_face.to_array()).is_none())
                .then(|| look(to_bevy(eye.to_array()), to_bevy(centre.to_array())))
        })
    })
}

/// Whether `p` (Quake axes) is in an open leaf that is not sky.
fn is_open(world: &World, p: [f32; 3]) -> bool {
    let leaf = world.leaf_at(p);
    world.leaf_cluster(leaf).is_some()
        && !matches!(world.leaf_contents(leaf), None | Some(Contents::Sky | Contents::Solid))
}

/// A camera at `eye` looking at `target` (Bevy axes), upright unless it looks straight up or down.
fn look(eye: Vec3, target: Vec3) -> Transform {
    let dir = (target - eye).normalize_or_zero();
    let up = if dir.y.abs() > 0.99 { Vec3::NEG_Z } else { Vec3::Y };
    Transform::from_translation(eye).looking_at(target, up)
}
