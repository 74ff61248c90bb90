//! First-person pictures ray-cast through the level's BSP tree.
//!
//! One ray per pixel walks the tree until sight stops (solid or sky). The pixel shows the last leaf
//! the ray crossed, in that leaf's colour ([`leaf_colour`]), shaded by the normal of the surface
//! the ray stopped at (Lambert with a fixed light plus ambient); sky is light blue, a ray that
//! never stops (a leaking level) black. With a PVS, a pixel whose leaf's cluster is missing from
//! the eye cluster's row is painted [`ALARM_RED`]: on a conservative PVS there is never any.
//!
//! Camera: Quake's angles in degrees. Yaw turns around +z from +x towards +y; pitch is positive
//! **up**. The field of view is horizontal.

use glam::DVec3;
use rayon::prelude::*;
use sightline_formats::Contents;

use super::RenderError;
use super::image::{ALARM_RED, Image, Rgb, leaf_colour, shade};
use crate::bsp::BspTree;
use crate::pvs::BitMatrix;

/// Colour of sky surfaces.
pub const SKY: Rgb = [120, 170, 230];
/// Direction light comes from (normalised when used).
const LIGHT: DVec3 = DVec3::new(0.35, 0.55, 0.76);

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: DVec3,
    /// Yaw in degrees.
    pub yaw: f64,
    /// Pitch in degrees, positive up.
    pub pitch: f64,
    /// Horizontal field of view in degrees.
    pub fov: f64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
}

impl Camera {
    /// Forward, right and up unit vectors.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let (y, p) = (self.yaw.to_radians(), self.pitch.to_radians());
        let forward = DVec3::new(p.cos() * y.cos(), p.cos() * y.sin(), p.sin());
        let right = DVec3::new(y.sin(), -y.cos(), 0.0);
        (forward, right, right.cross(forward))
    }

    /// The (unnormalised) direction through the centre of pixel `(x, y)`.
    pub fn ray(&self, x: u32, y: u32) -> DVec3 {
        let (f, r, u) = self.basis();
        let t = (self.fov.to_radians() * 0.5).tan();
        let sx = (2.0 * (f64::from(x) + 0.5) / f64::from(self.width) - 1.0) * t;
        let sy = (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(self.height)) * t * f64::from(self.height)
            / f64::from(self.width);
        f + r * sx + u * sy
    }
}

/// A rendered view and what it showed.
#[derive(Debug, Clone)]
pub struct View {
    /// The picture.
    pub image: Image,
    /// Leaf of the eye.
    pub eye_leaf: u32,
    /// Cluster of the eye leaf.
    pub eye_cluster: u32,
    /// Pixels painted [`ALARM_RED`].
    pub red_pixels: usize,
    /// Leaves shown by at least one pixel, ascending.
    pub leaves_shown: Vec<u32>,
    /// The leaf each pixel shows (row-major), `None` where the ray never stopped.
    pub pixel_leaves: Vec<Option<u32>>,
}

/// Render `camera` through `tree`; with `pvs`, paint pixels outside the eye cluster's row red.
pub fn render_view(
    tree: &BspTree<'_>,
    camera: &Camera,
    pvs: Option<&BitMatrix>,
) -> Result<View, RenderError> {
    if camera.width == 0 || camera.height == 0 || camera.width > 8192 || camera.height > 8192 {
        return Err(RenderError::ImageSize { width: camera.width, height: camera.height });
    }
    if !(camera.fov > 0.0 && camera.fov < 179.0) {
        return Err(RenderError::FieldOfView { fov: camera.fov });
    }
    let eye_leaf = tree.leaf_at(camera.eye);
    if !tree.is_open(eye_leaf) {
        return Err(RenderError::EyeInSolid { eye: camera.eye.to_array(), leaf: eye_leaf });
    }
    let eye_cluster = tree.cluster(eye_leaf).ok_or(RenderError::EyeOutsideClusters)?;
    let length = 2.0 * world_extent(tree) + 1.0;
    let level = tree.level();
    let rows: Vec<Vec<(Rgb, Option<u32>)>> = (0..camera.height)
        .into_par_iter()
        .map(|y| {
            let (mut out, mut stack) = (Vec::new(), Vec::new());
            (0..camera.width)
                .map(|x| {
                    let dir = camera.ray(x, y).normalize();
                    out.clear();
                    let hit = tree.trace(camera.eye, camera.eye + dir * length, &mut out, &mut stack);
                    let Some(hit) = hit else { return ([0, 0, 0], None) };
                    let Some(last) = out.last() else { return ([0, 0, 0], None) };
                    let k = 0.45 + 0.55 * hit.normal.dot(LIGHT.normalize()).max(0.0);
                    let sky =
                        level.leaves.get(hit.leaf as usize).is_some_and(|l| l.contents == Contents::Sky);
                    let base = if sky { SKY } else { leaf_colour(last.leaf) };
                    let outside = pvs.is_some_and(|m| {
                        tree.cluster(last.leaf as usize)
                            .is_some_and(|c| !m.get(eye_cluster as usize, c as usize))
                    });
                    (if outside { ALARM_RED } else { shade(base, k) }, Some(last.leaf))
                })
                .collect()
        })
        .collect();
    let mut image = Image::new(camera.width, camera.height, [0, 0, 0]);
    let mut shown = std::collections::BTreeSet::new();
    let mut pixel_leaves = Vec::with_capacity(image.pixels.len());
    for (y, row) in rows.iter().enumerate() {
        for (x, &(c, leaf)) in row.iter().enumerate() {
            image.put(x as i64, y as i64, c);
            shown.extend(leaf);
            pixel_leaves.push(leaf);
        }
    }
    let red_pixels = if pvs.is_some() { image.count(ALARM_RED) } else { 0 };
    Ok(View {
        image,
        eye_leaf: eye_leaf as u32,
        eye_cluster,
        red_pixels,
        leaves_shown: shown.into_iter().collect(),
        pixel_leaves,
    })
}

/// Largest extent of the open leaves' bounds.
fn world_extent(tree: &BspTree<'_>) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (i, l) in tree.level().leaves.iter().enumerate() {
        if tree.is_open(i) {
            lo = lo.min(DVec3::from(l.mins.map(f64::from)));
            hi = hi.max(DVec3::from(l.maxs.map(f64::from)));
        }
    }
    if lo.x > hi.x { 1.0 } else { (hi - lo).length() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsp::tests::corridor;

    #[test]
    fn camera_looks_where_it_says() {
        let cam = Camera { eye: DVec3::ZERO, yaw: 90.0, pitch: 0.0, fov: 90.0, width: 3, height: 3 };
        let d = cam.ray(1, 1).normalize();
        assert!((d - DVec3::Y).length() < 1e-9);
        let (_, r, u) = cam.basis();
        assert!((r - DVec3::X).length() < 1e-9 && (u - DVec3::Z).length() < 1e-9);
        let up = Camera { pitch: 30.0, ..cam }.ray(1, 1);
        assert!(up.z > 0.0);
    }

    #[test]
    fn corridor_view_shows_both_cells_and_red_only_when_missing() {
        let level = corridor();
        let tree = BspTree::new(&level).unwrap();
        let cam = Camera {
            eye: DVec3::new(4.0, 0.0, 32.0),
            yaw: 0.0,
            pitch: 0.0,
            fov: 90.0,
            width: 64,
            height: 48,
        };
        let mut pvs = BitMatrix::new(3);
        for (a, b) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)] {
            pvs.set(a, b);
        }
        let v = render_view(&tree, &cam, Some(&pvs)).unwrap();
        assert_eq!(v.eye_leaf, 1);
        assert_eq!(v.leaves_shown, vec![1, 2]);
        assert_eq!(v.red_pixels, 0);
        assert!(v.image.pixels.iter().any(|&p| p != [0, 0, 0]));
        pvs.clear(0, 1);
        let v = render_view(&tree, &cam, Some(&pvs)).unwrap();
        assert!(v.red_pixels > 0, "the far cell is outside the PVS and must show red");
        let inside_wall = Camera { eye: DVec3::new(130.0, 0.0, 32.0), ..cam };
        assert!(render_view(&tree, &inside_wall, None).is_err());
    }
}
