//! The one conversion between Quake's coordinates and Bevy's, used by every module of this crate.
//!
//! # Convention
//! - Quake (and every level the runtime loads) is right-handed and **Z-up**; Bevy is
//!   right-handed and **Y-up**, looking down `-Z`.
//! - A Quake point `(x, y, z)` is the Bevy point `(x, z, -y)`: a rotation of -90° about `+X`
//!   (determinant +1, so handedness and lengths are kept). Quake's `+Y` (left, for a viewer
//!   facing `+X`) becomes Bevy's `-Z`; up stays up.
//! - **Units are kept**: one Quake unit is one Bevy unit. Scale the level's root entity
//!   ([`crate::LevelRoot`]) to change that; culling maps cameras and entities into the level's
//!   own space through the root's `GlobalTransform`, so any rigid placement or uniform scale of
//!   the root is honoured.
//! - Winding: Quake faces are clockwise seen from their front; Bevy's front faces are
//!   counter-clockwise, so [`crate::mesh`] reverses each face's corners.

use bevy::math::{Affine3A, Mat3, Vec3};

/// A Quake point or direction in Bevy's axes.
#[inline]
pub fn to_bevy(q: [f32; 3]) -> Vec3 {
    Vec3::new(q[0], q[2], -q[1])
}

/// A Bevy point or direction in Quake's axes (the inverse of [`to_bevy`]).
#[inline]
pub fn to_quake(b: Vec3) -> [f32; 3] {
    [b.x, -b.z, b.y]
}

/// The affine map from Quake's axes to Bevy's (the rotation of [`to_bevy`]).
pub fn bevy_from_quake() -> Affine3A {
    Affine3A::from_mat3(Mat3::from_cols(Vec3::X, Vec3::NEG_Z, Vec3::Y))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_conversion_is_a_rotation_and_its_inverse_undoes_it() {
        let q = [1.0, 2.0, 3.0];
        assert_eq!(to_bevy(q), Vec3::new(1.0, 3.0, -2.0));
        assert_eq!(to_quake(to_bevy(q)), q);
        // Quake up is Bevy up; the matrix agrees with the function.
        assert_eq!(to_bevy([0.0, 0.0, 1.0]), Vec3::Y);
        assert_eq!(bevy_from_quake().transform_point3(Vec3::from_array(q)), to_bevy(q));
        assert!((bevy_from_quake().matrix3.determinant() - 1.0).abs() < 1e-6);
    }
}
