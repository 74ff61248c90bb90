//! Shadow rays to a level's point lights, with per-cluster light lists (as Quake 2 RTX picks the
//! lights of a cluster by its PVS).
//!
//! Each hit pixel is lit by the point lights that reach it: a light at distance `d` below its
//! `light` value `r`, in front of the hit face, with nothing between (a shadow ray, any hit, both
//! sides of a face block it) adds `(r - d) cos θ`, Quake's linear falloff.
//!
//! Which lights a pixel tries: in the **full** mode every light; in the **PVS** mode only the light
//! list of the hit point's cluster (the cluster of the leaf a hair in front of the hit, NOT the eye
//! cluster): the lights whose leaf's cluster that cluster's PVS row names. Shadow rays are traced
//! against the whole scene's BVH in both modes (only the light list is culled). A light that
//! reaches a point sees it, so its cluster is in the point's PVS: both modes light every pixel
//! alike unless the PVS hides a visible cluster.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;
use sightline_formats::entities::EntityError;

use super::Surfaces;
use super::frame::{Frame, Rays};
use super::scene::LevelScene;
use crate::pvs::BitMatrix;
use crate::render::image::{Image, leaf_colour, shade};
use crate::render::view::SKY;

/// A light's value when its entity gives none (Quake's default).
pub const DEFAULT_LIGHT: f64 = 300.0;

/// How far a shadow ray starts off the hit face, along its normal (world units).
const OFFSET: f64 = 0.05;

/// A point light of the level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Its origin.
    pub origin: DVec3,
    /// Its `light` value: the reach in units and the brightness at the light.
    pub value: f64,
    /// The cluster of its leaf (`None`: in solid or outside every cluster; never in a list).
    pub cluster: Option<u32>,
}

/// The point lights of `entities`: every entity whose classname starts with `light` and that has
/// an origin; its value is the first number of `light` (Quake, Quake 2), else the last of
/// `_light` (Half-Life's `r g b brightness`), else [`DEFAULT_LIGHT`]; lights whose value is not a
/// positive finite number are left out.
pub fn lights(scene: &LevelScene<'_>, entities: &str) -> Result<Vec<Light>, EntityError> {
    let tree = scene.tree();
    let mut out = Vec::new();
    for e in sightline_formats::entities::parse(entities)? {
        if !e.classname().starts_with("light") {
            continue;
        }
        let Some(Ok(o)) = e.origin() else { continue };
        let first = |k: &str| e.get(k).and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok());
        let last = |k: &str| e.get(k).and_then(|v| v.split_whitespace().last()?.parse::<f64>().ok());
        let value = first("light").or_else(|| last("_light")).unwrap_or(DEFAULT_LIGHT);
        if !(value.is_finite() && value > 0.0) {
            continue;
        }
        let origin = DVec3::from(o.map(f64::from));
        out.push(Light { origin, value, cluster: tree.cluster(tree.leaf_at(origin)) });
    }
    Ok(out)
}

/// Light lists of the clusters asked for so far: the lights whose cluster the cluster's PVS row
/// names (ascending light numbers).
#[derive(Debug, Default)]
pub struct LightLists {
    lists: HashMap<u32, Arc<Vec<u32>>>,
}

impl LightLists {
    /// The light list of `cluster`.
    pub fn get(&mut self, lights: &[Light], pvs: &BitMatrix, cluster: u32) -> Arc<Vec<u32>> {
        self.lists
            .entry(cluster)
            .or_insert_with(|| {
                let seen = |c: u32| pvs.get(cluster as usize, c as usize);
                Arc::new(
                    (0..lights.len() as u32)
                        .filter(|&l| lights[l as usize].cluster.is_some_and(seen))
                        .collect(),
                )
            })
            .clone()
    }

    /// Lists built.
    pub fn len(&self) -> usize {
        self.lists.len()
    }

    /// True when no list was built.
    pub fn is_empty(&self) -> bool {
        self.lists.is_empty()
    }
}

/// A frame's lighting.
#[derive(Debug, Clone)]
pub struct Lit {
    /// Light per pixel (row-major; 0 where nothing is hit or nothing reaches).
    pub light: Vec<f64>,
    /// Lights tried (within reach, in front of the face), so shadow rays cast.
    pub shadow_rays: u64,
    /// Wall-clock time of the lighting (light lists and shadow rays, all threads).
    pub time: Duration,
}

/// Light every hit pixel of `frame` by `lights`: every light (`lists` `None`, the full mode) or the
/// light list of each hit point's cluster (`Some`, the PVS mode); shadow rays against the whole
/// scene's BVH.
pub fn light(
    scene: &LevelScene<'_>,
    rays: &Rays,
    frame: &Frame,
    lights: &[Light],
    lists: Option<(&BitMatrix, &mut LightLists)>,
) -> Lit {
    let start = Instant::now();
    let tree = scene.tree();
    let all: Arc<Vec<u32>> = Arc::new((0..lights.len() as u32).collect());
    let none: Arc<Vec<u32>> = Arc::new(Vec::new());
    // Hit points, their normals and which lights they try.
    let points: Vec<Option<(DVec3, DVec3, u32)>> = frame
        .hits
        .par_iter()
        .zip(&rays.dirs)
        .map(|(h, d)| {
            let h = h.as_ref()?;
            let d = d.as_dvec3();
            let p = rays.camera.eye + d * f64::from(h.t);
            let n = scene.normal(h.triangle);
            let back = p - d.normalize_or_zero() * OFFSET;
            let cluster = tree.cluster(tree.leaf_at(back)).unwrap_or(u32::MAX);
            Some((p + n * OFFSET, n, cluster))
        })
        .collect();
    let lists: HashMap<u32, Arc<Vec<u32>>> = match lists {
        None => HashMap::new(),
        Some((pvs, cache)) => {
            let mut m = HashMap::new();
            for &(_, _, c) in points.iter().flatten() {
                m.entry(c)
                    .or_insert_with(|| if c == u32::MAX { none.clone() } else { cache.get(lights, pvs, c) });
            }
            m
        }
    };
    let full = lists.is_empty();
    let bvh = scene.bvh();
    let per_pixel: Vec<(f64, u64)> = points
        .par_iter()
        .map(|pt| {
            let Some((p, n, c)) = *pt else { return (0.0, 0) };
            let list = if full { &all } else { lists.get(&c).unwrap_or(&none) };
            let (mut sum, mut cast) = (0.0, 0u64);
            for &l in list.iter() {
                let light = &lights[l as usize];
                let v = light.origin - p;
                let dist = v.length();
                let cos = n.dot(v) / dist.max(f64::MIN_POSITIVE);
                if dist >= light.value || cos <= 0.0 {
                    continue;
                }
                cast += 1;
                if !bvh.occluded(p.as_vec3(), v.as_vec3(), 1.0) {
                    sum += (light.value - dist) * cos;
                }
            }
            (sum, cast)
        })
        .collect();
    let time = start.elapsed();
    Lit {
        light: per_pixel.iter().map(|x| x.0).collect(),
        shadow_rays: per_pixel.iter().map(|x| x.1).sum(),
        time,
    }
}

/// The picture of a lit frame: each face in its own colour (sky light blue, unlit), scaled by
/// `0.15 + 0.85 min(1, light / 200)`; black where nothing is hit.
pub fn lit_picture(scene: &LevelScene<'_>, rays: &Rays, frame: &Frame, lit: &Lit) -> Image {
    let mut image = Image::new(rays.camera.width, rays.camera.height, [0, 0, 0]);
    for ((p, h), l) in image.pixels.iter_mut().zip(&frame.hits).zip(&lit.light) {
        let Some(h) = h else { continue };
        *p = if scene.is_sky(h.face) {
            SKY
        } else {
            shade(leaf_colour(h.face), 0.15 + 0.85 * (l / 200.0).min(1.0))
        };
    }
    image
}
