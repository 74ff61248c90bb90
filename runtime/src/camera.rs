//! Cameras and view frusta.
//!
//! # Conventions
//! - World axes are Quake's: `+Z` up. A [`Camera`] with yaw 0 and pitch 0 looks along `+X`; yaw turns
//!   counter-clockwise seen from above (towards `+Y`), positive pitch looks **up**, positive roll
//!   turns the image clockwise. Angles are in degrees.
//! - A [`Frustum`] plane keeps what is in **front** of it (`normal · p - dist >= 0`), like every
//!   plane in Sightline: the normals point into the frustum.

use glam::{Mat4, Vec3, Vec3A, Vec4};

/// A perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Heading in degrees (0 = `+X`, 90 = `+Y`).
    pub yaw: f32,
    /// Degrees above the horizon.
    pub pitch: f32,
    /// Degrees of roll about the view direction.
    pub roll: f32,
    /// Vertical field of view in degrees (0 < fov_y < 180).
    pub fov_y: f32,
    /// Width / height.
    pub aspect: f32,
    /// Near plane distance (> 0).
    pub near: f32,
    /// Far plane distance (> near).
    pub far: f32,
}

impl Camera {
    /// A camera at `position` looking along yaw/pitch with Quake's 90° horizontal field of view
    /// at 4:3, near 1 and far 65536.
    pub fn quake(position: Vec3, yaw: f32, pitch: f32) -> Self {
        let aspect = 4.0 / 3.0;
        let fov_y = 2.0 * (45f32.to_radians().tan() / aspect).atan().to_degrees();
        Self { position, yaw, pitch, roll: 0.0, fov_y, aspect, near: 1.0, far: 65536.0 }
    }

    /// Unit forward, right and up vectors.
    pub fn basis(&self) -> (Vec3A, Vec3A, Vec3A) {
        let (sy, cy) = self.yaw.to_radians().sin_cos();
        let (sp, cp) = self.pitch.to_radians().sin_cos();
        let (sr, cr) = self.roll.to_radians().sin_cos();
        let forward = Vec3A::new(cp * cy, cp * sy, sp);
        let right0 = Vec3A::new(sy, -cy, 0.0);
        let up0 = right0.cross(forward);
        let right = right0 * cr - up0 * sr;
        let up = up0 * cr + right0 * sr;
        (forward, right, up)
    }

    /// The view for culling.
    pub fn view(&self) -> View {
        View { eye: self.position.into(), frustum: Frustum::from_camera(self), cull_back_faces: false }
    }
}

/// Which clip-space depth range a projection matrix maps to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClipDepth {
    /// `0..1` (Direct3D, Vulkan, Metal, wgpu; glam's `perspective_rh`).
    ZeroToOne,
    /// `-1..1` (OpenGL; glam's `perspective_rh_gl`).
    NegOneToOne,
}

/// Six planes bounding what a camera sees: left, right, bottom, top, near, far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frustum {
    /// Inward unit normals.
    normals: [Vec3A; 6],
    /// Plane distances (`normal · p = dist` on the plane).
    dists: [f32; 6],
    /// The planes transposed for the box test, four per group (lanes 6 and 7 are padding that
    /// every box is inside, and no mask selects them).
    lanes: [PlaneLanes; 2],
}

/// Four planes, one per SIMD lane: normal components, their absolute values, distances.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PlaneLanes {
    nx: Vec4,
    ny: Vec4,
    nz: Vec4,
    ax: Vec4,
    ay: Vec4,
    az: Vec4,
    d: Vec4,
}

/// Result of a box against a frustum plane set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxSide {
    /// Entirely outside one plane.
    Outside,
    /// Inside or crossing: the planes it still crosses, as a mask.
    Inside(u8),
}

impl Frustum {
    /// Every plane bit set.
    pub const ALL: u8 = 0x3f;

    fn from_planes(planes: [(Vec3A, f32); 6]) -> Self {
        // Padding planes: zero normal, distance -1, so every box is inside them.
        let lanes = [0, 4].map(|g| {
            let p: [(Vec3A, f32); 4] =
                std::array::from_fn(|i| planes.get(g + i).copied().unwrap_or((Vec3A::ZERO, -1.0)));
            let lane = |f: fn(&(Vec3A, f32)) -> f32| Vec4::from_array(p.map(|q| f(&q)));
            PlaneLanes {
                nx: lane(|q| q.0.x),
                ny: lane(|q| q.0.y),
                nz: lane(|q| q.0.z),
                ax: lane(|q| q.0.x.abs()),
                ay: lane(|q| q.0.y.abs()),
                az: lane(|q| q.0.z.abs()),
                d: lane(|q| q.1),
            }
        });
        Self { normals: planes.map(|p| p.0), dists: planes.map(|p| p.1), lanes }
    }

    /// The frustum of a camera.
    pub fn from_camera(cam: &Camera) -> Self {
        let eye = Vec3A::from(cam.position);
        let (f, r, u) = cam.basis();
        let v = (cam.fov_y.to_radians() * 0.5).tan();
        let h = v * cam.aspect;
        let side = |n: Vec3A| {
            let n = n.normalize_or_zero();
            (n, n.dot(eye))
        };
        Self::from_planes([
            side(r + f * h),
            side(-r + f * h),
            side(u + f * v),
            side(-u + f * v),
            (f, f.dot(eye) + cam.near),
            (-f, -(f.dot(eye) + cam.far)),
        ])
    }

    /// The frustum of a view-projection matrix (column vectors: `clip = m * world`), by the
    /// Gribb–Hartmann rows.
    pub fn from_view_projection(m: Mat4, depth: ClipDepth) -> Self {
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        let plane = |p: Vec4| {
            let n = Vec3A::new(p.x, p.y, p.z);
            let len = n.length();
            if len > 0.0 && len.is_finite() { (n / len, -p.w / len) } else { (Vec3A::ZERO, 0.0) }
        };
        let near = match depth {
            ClipDepth::ZeroToOne => r2,
            ClipDepth::NegOneToOne => r3 + r2,
        };
        Self::from_planes([
            plane(r3 + r0),
            plane(r3 - r0),
            plane(r3 + r1),
            plane(r3 - r1),
            plane(near),
            plane(r3 - r2),
        ])
    }

    /// Test a box (centre, half-size) against the planes in `mask`; planes the box is fully inside
    /// are cleared from the returned mask. The centre/extent form of the p/n-vertex test, all
    /// eight plane lanes at once without branches: per plane `d = n · c - dist` and
    /// `r = |n| · e`; outside when `d + r < 0`, fully inside when `d - r >= 0` (each dot product
    /// summed as `(x + y) + z`, so results equal a plane-by-plane scalar test bit for bit).
    #[inline]
    pub fn test_box(&self, center: Vec3A, extent: Vec3A, mask: u8) -> BoxSide {
        match self.classify(center.to_array(), extent.to_array(), mask) {
            (true, m) => BoxSide::Inside(m),
            (false, _) => BoxSide::Outside,
        }
    }

    /// [`Frustum::test_box`] as `(not outside, remaining mask)`, without branches.
    #[inline(always)]
    pub(crate) fn classify(&self, c: [f32; 3], e: [f32; 3], mask: u8) -> (bool, u8) {
        let (cx, cy, cz) = (Vec4::splat(c[0]), Vec4::splat(c[1]), Vec4::splat(c[2]));
        let (ex, ey, ez) = (Vec4::splat(e[0]), Vec4::splat(e[1]), Vec4::splat(e[2]));
        let mut outside = 0;
        let mut inside = 0;
        for (g, l) in self.lanes.iter().enumerate() {
            let dist = l.nx * cx + l.ny * cy + l.nz * cz - l.d;
            let radius = l.ax * ex + l.ay * ey + l.az * ez;
            outside |= (dist + radius).cmplt(Vec4::ZERO).bitmask() << (4 * g);
            inside |= (dist - radius).cmpge(Vec4::ZERO).bitmask() << (4 * g);
        }
        let mask = mask & Self::ALL;
        (outside as u8 & mask == 0, mask & !(inside as u8))
    }

    /// The six planes as (inward unit normal, distance): left, right, bottom, top, near, far.
    pub fn planes(&self) -> [(Vec3A, f32); 6] {
        std::array::from_fn(|i| (self.normals[i], self.dists[i]))
    }

    /// True when `p` is inside every plane.
    pub fn contains_point(&self, p: Vec3A) -> bool {
        self.normals.iter().zip(&self.dists).all(|(n, d)| n.dot(p) - d >= 0.0)
    }
}

/// What a backend needs for one frame: the eye, the frustum and whether to drop back faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Eye position (the apex of the frustum).
    pub eye: Vec3A,
    /// The view frustum.
    pub frustum: Frustum,
    /// Leave out faces whose plane the eye is more than [`crate::query::BACKFACE_EPSILON`]
    /// behind (the rule of [`crate::World::cull_back_faces`]), decided as the walk outputs each
    /// face. Off in the constructors; turn it on with [`View::with_back_face_culling`].
    pub cull_back_faces: bool,
}

impl View {
    /// A view from an eye position and a view-projection matrix.
    pub fn from_view_projection(eye: Vec3, m: Mat4, depth: ClipDepth) -> Self {
        Self { eye: eye.into(), frustum: Frustum::from_view_projection(m, depth), cull_back_faces: false }
    }

    /// This view with back-face culling on or off ([`View::cull_back_faces`]).
    pub fn with_back_face_culling(self, on: bool) -> Self {
        Self { cull_back_faces: on, ..self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_frustum_matches_matrix_frustum() {
        let cam = Camera {
            position: Vec3::new(10.0, -20.0, 30.0),
            yaw: 30.0,
            pitch: 10.0,
            ..Camera::quake(Vec3::ZERO, 0.0, 0.0)
        };
        let (f, r, u) = cam.basis();
        let eye = Vec3A::from(cam.position);
        // Right-handed view (looking down -Z) and a 0..1-depth perspective, written out.
        let view = Mat4::from_cols(
            Vec4::new(r.x, u.x, -f.x, 0.0),
            Vec4::new(r.y, u.y, -f.y, 0.0),
            Vec4::new(r.z, u.z, -f.z, 0.0),
            Vec4::new(-r.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
        );
        let h = 1.0 / (cam.fov_y.to_radians() * 0.5).tan();
        let depth = cam.far / (cam.near - cam.far);
        let proj = Mat4::from_cols(
            Vec4::new(h / cam.aspect, 0.0, 0.0, 0.0),
            Vec4::new(0.0, h, 0.0, 0.0),
            Vec4::new(0.0, 0.0, depth, -1.0),
            Vec4::new(0.0, 0.0, depth * cam.near, 0.0),
        );
        let a = Frustum::from_camera(&cam);
        let b = Frustum::from_view_projection(proj * view, ClipDepth::ZeroToOne);
        for i in 0..6 {
            assert!(
                a.normals[i].dot(b.normals[i]) > 0.9999,
                "plane {i}: {:?} vs {:?}",
                a.normals[i],
                b.normals[i]
            );
            assert!((a.dists[i] - b.dists[i]).abs() < 0.05 * a.dists[i].abs().max(1.0), "plane {i}");
        }
        let ahead = Vec3A::from(cam.position) + f * 100.0;
        assert!(a.contains_point(ahead));
        assert!(!a.contains_point(Vec3A::from(cam.position) - f * 100.0));
    }

    #[test]
    fn box_test_masks_planes_fully_inside() {
        let cam = Camera::quake(Vec3::ZERO, 0.0, 0.0);
        let fr = cam.view().frustum;
        // A small box straight ahead is inside every plane.
        assert_eq!(
            fr.test_box(Vec3A::new(100.0, 0.0, 0.0), Vec3A::splat(1.0), Frustum::ALL),
            BoxSide::Inside(0)
        );
        // Behind the eye: outside.
        assert_eq!(
            fr.test_box(Vec3A::new(-100.0, 0.0, 0.0), Vec3A::splat(1.0), Frustum::ALL),
            BoxSide::Outside
        );
        // Around the eye: crosses the side planes and the near plane.
        match fr.test_box(Vec3A::ZERO, Vec3A::splat(10.0), Frustum::ALL) {
            BoxSide::Inside(mask) => assert_eq!(mask & 0x1f, 0x1f),
            BoxSide::Outside => panic!("box around the eye rejected"),
        }
    }
}
