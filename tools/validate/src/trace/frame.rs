//! Primary rays of a camera, cast against a BVH: the nearest hit per pixel, and the picture.

use std::time::{Duration, Instant};

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sightline_raycast::Bvh;

use super::{Camera, Surfaces, TraceError};
use crate::render::RenderError;
use crate::render::image::{Image, leaf_colour, shade};
use crate::render::view::SKY;

/// Direction light comes from (normalised when used), as in `render::view`.
const LIGHT: DVec3 = DVec3::new(0.35, 0.55, 0.76);

/// The nearest hit of one pixel's ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelHit {
    /// Ray parameter (units of the pixel's unnormalised direction).
    pub t: f32,
    /// Scene triangle.
    pub triangle: u32,
    /// Face of the triangle.
    pub face: u32,
}

/// A camera's primary rays: one origin, one direction per pixel (row-major).
#[derive(Debug, Clone)]
pub struct Rays {
    /// The camera.
    pub camera: Camera,
    /// Eye in `f32`, every ray's origin.
    pub origin: Vec3,
    /// Direction through each pixel's centre, row-major.
    pub dirs: Vec<Vec3>,
}

impl Rays {
    /// The rays of `camera` (size 1..=8192 each side, field of view in (0, 179)).
    pub fn new(camera: &Camera) -> Result<Rays, TraceError> {
        let (w, h) = (camera.width, camera.height);
        if w == 0 || h == 0 || w > 8192 || h > 8192 {
            return Err(RenderError::ImageSize { width: w, height: h }.into());
        }
        if !(camera.fov > 0.0 && camera.fov < 179.0) {
            return Err(RenderError::FieldOfView { fov: camera.fov }.into());
        }
        let dirs = (0..h).flat_map(|y| (0..w).map(move |x| camera.ray(x, y).as_vec3())).collect();
        Ok(Rays { camera: *camera, origin: camera.eye.as_vec3(), dirs })
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True when there is no ray.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }
}

/// Every pixel's nearest hit against one BVH, and the time the casting took.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Per pixel (row-major), `None` where the ray hits nothing.
    pub hits: Vec<Option<PixelHit>>,
    /// Wall-clock time of casting the rays (all threads).
    pub time: Duration,
}

impl Frame {
    /// Million rays per second of the casting.
    pub fn mrays_per_s(&self) -> f64 {
        self.hits.len() as f64 / self.time.as_secs_f64().max(1e-9) / 1e6
    }
}

/// Cast `rays` against `bvh` (one-sided when the scene's faces are, [`Surfaces::one_sided`]: a
/// ray meets a face only from its front, as a Quake engine culls back faces), whose build triangle
/// `i` is scene triangle `map(i)` (the identity for the whole scene).
pub fn cast<S: Surfaces + ?Sized>(scene: &S, bvh: &Bvh, map: Option<&[u32]>, rays: &Rays) -> Frame {
    let width = rays.camera.width as usize;
    let one_sided = scene.one_sided();
    let start = Instant::now();
    let local: Vec<Option<(f32, u32)>> = rays
        .dirs
        .par_chunks(width.max(1))
        .flat_map_iter(|row| {
            row.iter().map(|&d| {
                let hit = if one_sided {
                    bvh.intersect_front(rays.origin, d, f32::INFINITY)
                } else {
                    bvh.intersect(rays.origin, d, f32::INFINITY)
                };
                hit.map(|h| (h.t, h.triangle))
            })
        })
        .collect();
    let time = start.elapsed();
    let hits = local
        .into_iter()
        .map(|h| {
            let (t, i) = h?;
            let triangle = match map {
                Some(m) => *m.get(i as usize)?,
                None => i,
            };
            Some(PixelHit { t, triangle, face: scene.face_of(triangle)? })
        })
        .collect();
    Frame { hits, time }
}

/// The picture of a frame: each face in its own colour ([`leaf_colour`] of the face index; sky
/// faces light blue), shaded by the angle of its triangle to a fixed light (two-sided); black where
/// nothing is hit.
pub fn picture<S: Surfaces + ?Sized>(scene: &S, rays: &Rays, frame: &Frame) -> Image {
    let mut image = Image::new(rays.camera.width, rays.camera.height, [0, 0, 0]);
    let light = LIGHT.normalize();
    for (p, h) in image.pixels.iter_mut().zip(&frame.hits) {
        let Some(h) = h else { continue };
        let k = 0.45 + 0.55 * scene.normal(h.triangle).dot(light).abs();
        *p = shade(if scene.is_sky(h.face) { SKY } else { leaf_colour(h.face) }, k);
    }
    image
}
