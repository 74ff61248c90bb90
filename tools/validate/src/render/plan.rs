//! Top-down plans of a level: which leaves are solid, which one holds the eye, which are in its
//! PVS, which of those a view frustum takes in, the portals, and a leak path.
//!
//! Each pixel looks at [`PLAN_Z_SAMPLES`] heights evenly spread over the slab `z0..z1` and shows
//! the most telling leaf found there, in this order: eye leaf (yellow), frustum-visible PVS leaf
//! (cyan), PVS leaf (green), other open leaf (grey), sky (dark blue), solid (near black). Leaves
//! carry a faint tint (1/8) of their own colour so neighbours can be told apart. North (+y) is up.
//! Below the plan, a band holds a legend of the categories drawn (and portals, leak path) and a
//! scale bar: the largest power of two of map units (8 to 65536) that fits a third of the width.

use glam::DVec3;
use rayon::prelude::*;
use sightline_formats::Contents;

use super::RenderError;
use super::font::{GLYPH_H, draw_text, text_width};
use super::image::{Image, Rgb, leaf_colour};
use super::view::Camera;
use crate::bsp::BspTree;
use crate::pvs::BitMatrix;

/// Heights sampled per pixel.
pub const PLAN_Z_SAMPLES: usize = 8;
/// Solid.
pub const SOLID: Rgb = [24, 24, 30];
/// Sky leaves.
pub const SKY: Rgb = [30, 40, 80];
/// Open leaves outside the PVS.
pub const OPEN: Rgb = [96, 96, 96];
/// Leaves in the eye's PVS.
pub const PVS: Rgb = [50, 150, 60];
/// PVS leaves inside the view frustum.
pub const FRUSTUM: Rgb = [60, 200, 235];
/// The eye's leaf.
pub const EYE: Rgb = [250, 215, 0];
/// Portals.
pub const PORTAL: Rgb = [235, 235, 235];
/// The leak path.
pub const LEAK: Rgb = [255, 140, 0];
/// Where the leak starts (the entity).
pub const LEAK_START: Rgb = [0, 255, 120];
/// Where the leak ends (the void).
pub const LEAK_END: Rgb = [255, 0, 255];
/// The legend band's background.
pub const BAND: Rgb = [8, 8, 12];
/// The legend's text and scale bar.
pub const LABEL: Rgb = [250, 250, 250];
/// The outline of the legend's swatches.
pub const OUTLINE: Rgb = [140, 140, 140];

/// What to draw.
#[derive(Debug, Clone, Default)]
pub struct PlanOptions {
    /// The eye (defines the eye leaf and, with a PVS, the PVS leaves).
    pub from: Option<DVec3>,
    /// The slab `z0..z1`.
    pub z: (f64, f64),
    /// A camera at `from` whose frustum marks frustum-visible leaves.
    pub camera: Option<Camera>,
    /// Image width in pixels (height follows the plan's aspect).
    pub width: u32,
    /// Portal windings to draw as lines.
    pub portals: Vec<Vec<DVec3>>,
    /// A leak path, from the entity to the void.
    pub leak: Vec<DVec3>,
}

/// A plan and the categories it found.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The picture.
    pub image: Image,
    /// Leaves drawn as PVS or frustum leaves, ascending.
    pub pvs_leaves: Vec<u32>,
    /// Leaves drawn as frustum-visible, ascending.
    pub frustum_leaves: Vec<u32>,
}

/// Category of a leaf, by priority.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Solid,
    Sky,
    Open,
    Pvs,
    Frustum,
    Eye,
}

/// The four side planes of a camera's frustum as `(normal, point)`, normals pointing inwards.
fn frustum_planes(cam: &Camera) -> [DVec3; 4] {
    let (f, r, u) = cam.basis();
    let tx = (cam.fov.to_radians() * 0.5).tan();
    let ty = tx * f64::from(cam.height) / f64::from(cam.width.max(1));
    [
        (f * tx + r).cross(u).normalize() * -1.0,
        (f * tx - r).cross(u).normalize(),
        (f * ty + u).cross(r).normalize(),
        (f * ty - u).cross(r).normalize() * -1.0,
    ]
}

/// True when the box `mins..maxs` reaches inside every plane through `eye` with inward `normals`.
fn box_in_frustum(eye: DVec3, normals: &[DVec3; 4], mins: DVec3, maxs: DVec3) -> bool {
    normals.iter().all(|n| {
        let far = DVec3::new(
            if n.x >= 0.0 { maxs.x } else { mins.x },
            if n.y >= 0.0 { maxs.y } else { mins.y },
            if n.z >= 0.0 { maxs.z } else { mins.z },
        );
        n.dot(far - eye) >= 0.0
    })
}

/// Draw the plan.
pub fn render_plan(
    tree: &BspTree<'_>,
    pvs: Option<&BitMatrix>,
    opts: &PlanOptions,
) -> Result<Plan, RenderError> {
    let level = tree.level();
    let (z0, z1) = opts.z;
    if !(z0.is_finite() && z1.is_finite() && z0 <= z1) {
        return Err(RenderError::Slab { z0, z1 });
    }
    if opts.width == 0 || opts.width > 8192 {
        return Err(RenderError::PlanWidth { width: opts.width });
    }
    // Bounds: open leaves meeting the slab, the eye and the leak path.
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (i, l) in level.leaves.iter().enumerate() {
        if tree.is_open(i) && f64::from(l.mins[2]) <= z1 && f64::from(l.maxs[2]) >= z0 {
            lo = lo.min(DVec3::from(l.mins.map(f64::from)));
            hi = hi.max(DVec3::from(l.maxs.map(f64::from)));
        }
    }
    for p in opts.leak.iter().chain(opts.from.as_ref()) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if lo.x > hi.x {
        return Err(RenderError::EmptySlab { z0, z1 });
    }
    let margin = 0.03 * (hi - lo).max_element().max(64.0);
    let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
    let scale = f64::from(opts.width) / (hi.x - lo.x);
    let height = (((hi.y - lo.y) * scale).ceil() as u32).clamp(1, 8192);
    let to_px = |p: DVec3| (((p.x - lo.x) * scale) as i64, ((hi.y - p.y) * scale) as i64);

    let eye = opts.from.map(|e| (e, tree.leaf_at(e)));
    let eye_cluster = eye.and_then(|(_, l)| tree.cluster(l));
    let frustum = opts.camera.map(|c| (c.eye, frustum_planes(&c)));
    let kinds: Vec<Kind> = (0..level.leaves.len())
        .map(|i| {
            let l = &level.leaves[i];
            if eye.is_some_and(|(_, e)| e == i) {
                return Kind::Eye;
            }
            if !tree.is_open(i) {
                return if l.contents == Contents::Sky { Kind::Sky } else { Kind::Solid };
            }
            let in_pvs = match (eye_cluster, tree.cluster(i), pvs) {
                (Some(e), Some(c), Some(m)) => m.get(e as usize, c as usize),
                _ => false,
            };
            if !in_pvs {
                return Kind::Open;
            }
            let (mins, maxs) = (DVec3::from(l.mins.map(f64::from)), DVec3::from(l.maxs.map(f64::from)));
            match frustum {
                Some((e, n)) if box_in_frustum(e, &n, mins, maxs) => Kind::Frustum,
                _ => Kind::Pvs,
            }
        })
        .collect();

    let rows: Vec<Vec<(Rgb, Kind)>> = (0..height)
        .into_par_iter()
        .map(|py| {
            (0..opts.width)
                .map(|px| {
                    let x = lo.x + (f64::from(px) + 0.5) / scale;
                    let y = hi.y - (f64::from(py) + 0.5) / scale;
                    let (mut best, mut leaf) = (Kind::Solid, 0);
                    for k in 0..PLAN_Z_SAMPLES {
                        let z = z0 + (z1 - z0) * (k as f64 + 0.5) / PLAN_Z_SAMPLES as f64;
                        let l = tree.leaf_at(DVec3::new(x, y, z));
                        if kinds[l] > best || k == 0 {
                            (best, leaf) = (kinds[l], l);
                        }
                    }
                    (colour(best, leaf as u32), best)
                })
                .collect()
        })
        .collect();
    let mut image = Image::new(opts.width, height, SOLID);
    let mut drawn = [false; 6];
    for (y, row) in rows.iter().enumerate() {
        for (x, &(c, kind)) in row.iter().enumerate() {
            image.put(x as i64, y as i64, c);
            drawn[kind as usize] = true;
        }
    }
    for w in &opts.portals {
        let (pmin, pmax) =
            w.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.z), b.max(p.z)));
        if pmin > z1 || pmax < z0 {
            continue;
        }
        for (i, &a) in w.iter().enumerate() {
            let b = w[(i + 1) % w.len()];
            image.line(to_px(a), to_px(b), PORTAL, 1);
        }
    }
    for pair in opts.leak.windows(2) {
        image.line(to_px(pair[0]), to_px(pair[1]), LEAK, 3);
    }
    if let (Some(first), Some(last)) = (opts.leak.first(), opts.leak.last()) {
        let (fx, fy) = to_px(*first);
        image.dot(fx, fy, LEAK_START, 9);
        let (lx, ly) = to_px(*last);
        image.dot(lx, ly, LEAK_END, 9);
    }
    if let Some((e, _)) = eye {
        let (ex, ey) = to_px(e);
        image.line((ex - 6, ey), (ex + 6, ey), [0, 0, 0], 2);
        image.line((ex, ey - 6), (ex, ey + 6), [0, 0, 0], 2);
        if let Some(c) = opts.camera {
            let (f, _, _) = c.basis();
            let tip = e + DVec3::new(f.x, f.y, 0.0).normalize_or_zero() * (24.0 / scale);
            image.line((ex, ey), to_px(tip), [0, 0, 0], 2);
        }
    }
    let mut entries: Vec<(Rgb, &str)> = [
        (Kind::Eye, EYE, "eye"),
        (Kind::Frustum, FRUSTUM, "in view"),
        (Kind::Pvs, PVS, "pvs"),
        (Kind::Open, OPEN, "open"),
        (Kind::Sky, SKY, "sky"),
        (Kind::Solid, SOLID, "solid"),
    ]
    .into_iter()
    .filter(|(k, _, _)| drawn[*k as usize])
    .map(|(_, c, t)| (c, t))
    .collect();
    if !opts.portals.is_empty() {
        entries.push((PORTAL, "portal"));
    }
    if !opts.leak.is_empty() {
        entries.push((LEAK, "leak"));
    }
    let image = legend(image, &entries, scale);
    let pick = |want: &[Kind]| {
        kinds.iter().enumerate().filter(|(_, k)| want.contains(k)).map(|(i, _)| i as u32).collect::<Vec<_>>()
    };
    Ok(Plan { image, pvs_leaves: pick(&[Kind::Pvs, Kind::Frustum]), frustum_leaves: pick(&[Kind::Frustum]) })
}

/// Font pixels per legend pixel.
const LEGEND_SCALE: i64 = 2;

/// `image` with a band below it: a swatch and a name per entry, flowing into rows, then a scale
/// bar whose length is the largest power of two of map units (8 to 65536) that fits in a third
/// of the width, labelled with it; `scale` is pixels per map unit.
fn legend(image: Image, entries: &[(Rgb, &str)], scale: f64) -> Image {
    let s = LEGEND_SCALE;
    let (w, pad, row_h) = (i64::from(image.width), 6, GLYPH_H * s + 6);
    let swatch = GLYPH_H * s;
    // Lay the entries out in rows; the scale bar takes the row after them.
    let mut at = Vec::with_capacity(entries.len());
    let (mut x, mut y) = (pad, 0);
    for (_, text) in entries {
        let item = swatch + s * 2 + text_width(text, s);
        if x > pad && x + item > w - pad {
            (x, y) = (pad, y + row_h);
        }
        at.push((x, y));
        x += item + s * 6;
    }
    let scale_row = if entries.is_empty() { 0 } else { y + row_h };
    let band = scale_row + row_h + pad;
    let top = i64::from(image.height) + pad;
    let mut out = Image::new(image.width, image.height + band as u32, BAND);
    out.pixels[..image.pixels.len()].copy_from_slice(&image.pixels);
    for ((colour, text), (x, y)) in entries.iter().zip(at) {
        for dy in 0..swatch {
            for dx in 0..swatch {
                out.put(x + dx, top + y + dy, *colour);
            }
        }
        // An outline, so a dark swatch (solid, sky) still shows on the band.
        let (x1, y0, y1) = (x + swatch - 1, top + y, top + y + swatch - 1);
        for (a, b) in [((x, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x, y1)), ((x, y1), (x, y0))] {
            out.line(a, b, OUTLINE, 1);
        }
        draw_text(&mut out, x + swatch + s * 2, top + y, text, LABEL, s);
    }
    let units = (3..=16)
        .map(|p| 1u32 << p)
        .take_while(|&u| f64::from(u) * scale <= w as f64 / 3.0)
        .last()
        .unwrap_or(8);
    let len = (f64::from(units) * scale).round().max(1.0) as i64;
    let y = top + scale_row + swatch / 2;
    out.line((pad, y), (pad + len, y), LABEL, 2);
    for end in [pad, pad + len] {
        out.line((end, y - swatch / 2), (end, y + swatch / 2), LABEL, 1);
    }
    draw_text(&mut out, pad + len + s * 4, top + scale_row, &format!("{units} units"), LABEL, s);
    out
}

/// The colour of a category, tinted 1/8 of the way towards the leaf's own colour.
fn colour(kind: Kind, leaf: u32) -> Rgb {
    let base = match kind {
        Kind::Solid => return SOLID,
        Kind::Sky => return SKY,
        Kind::Open => OPEN,
        Kind::Pvs => PVS,
        Kind::Frustum => FRUSTUM,
        Kind::Eye => return EYE,
    };
    let tint = leaf_colour(leaf);
    std::array::from_fn(|i| ((u16::from(base[i]) * 7 + u16::from(tint[i])) / 8) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsp::tests::corridor;

    #[test]
    fn frustum_takes_in_what_is_ahead_only() {
        let cam = Camera { eye: DVec3::ZERO, yaw: 0.0, pitch: 0.0, fov: 90.0, width: 4, height: 3 };
        let n = frustum_planes(&cam);
        assert!(box_in_frustum(cam.eye, &n, DVec3::new(10.0, -1.0, -1.0), DVec3::new(12.0, 1.0, 1.0)));
        assert!(!box_in_frustum(cam.eye, &n, DVec3::new(-12.0, -1.0, -1.0), DVec3::new(-10.0, 1.0, 1.0)));
        assert!(!box_in_frustum(cam.eye, &n, DVec3::new(1.0, 20.0, -1.0), DVec3::new(2.0, 22.0, 1.0)));
    }

    #[test]
    fn corridor_plan_marks_eye_pvs_and_solid() {
        let level = corridor();
        let tree = BspTree::new(&level).unwrap();
        let mut pvs = BitMatrix::new(3);
        for (a, b) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)] {
            pvs.set(a, b);
        }
        let eye = DVec3::new(10.0, 0.0, 32.0);
        let cam = Camera { eye, yaw: 0.0, pitch: 0.0, fov: 90.0, width: 4, height: 3 };
        let opts = PlanOptions {
            from: Some(eye),
            z: (0.0, 64.0),
            camera: Some(cam),
            width: 200,
            ..Default::default()
        };
        let plan = render_plan(&tree, Some(&pvs), &opts).unwrap();
        assert_eq!(plan.pvs_leaves, vec![2]);
        assert_eq!(plan.frustum_leaves, vec![2]);
        assert!(plan.image.count(EYE) > 100, "the eye leaf must be drawn");
        assert!(plan.image.count(SOLID) > 100, "the wall must be drawn");
    }
}
