//! Stills of the viewer (`--shots DIR`): the window's pixels as an RGB image, saved as PNG, and
//! counted by what they show.
//!
//! Sky and liquids are drawn unlit in their flat texture colour ([`texture_color`]) and the
//! camera does not tone-map, so a pixel of either has exactly that colour's sRGB bytes (within
//! [`TOLERANCE`] per channel, for rounding and multisampling); edge pixels blended with a
//! neighbour are not counted.

use bevy::image::Image;
use bevy::render::render_resource::TextureFormat;
use sightline_bevy::mesh::texture_color;
use sightline_validate::render::image::{Image as RgbImage, Rgb};

/// Largest difference per channel for a pixel to count as a colour.
const TOLERANCE: u8 = 3;

/// Names whose colour marks each kind of pixel (one per colour `texture_color` gives them).
const SKY_NAMES: [&str; 1] = ["sky"];
const LIQUID_NAMES: [&str; 3] = ["*water", "*slime", "*lava"];

/// Pixels of a still, by what they show.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Sky.
    pub sky: u32,
    /// Water, slime or lava.
    pub liquid: u32,
}

/// The captured window as an RGB image (alpha dropped); `None` for a pixel format it cannot
/// read.
pub fn to_rgb(image: &Image) -> Option<RgbImage> {
    let data = image.data.as_ref()?;
    let (width, height) = (image.width(), image.height());
    let bgra = match image.texture_descriptor.format {
        TextureFormat::Bgra8UnormSrgb | TextureFormat::Bgra8Unorm => true,
        TextureFormat::Rgba8UnormSrgb | TextureFormat::Rgba8Unorm => false,
        _ => return None,
    };
    let pixels: Vec<Rgb> =
        data.chunks_exact(4).map(|p| if bgra { [p[2], p[1], p[0]] } else { [p[0], p[1], p[2]] }).collect();
    (pixels.len() == width as usize * height as usize).then_some(RgbImage { width, height, pixels })
}

/// The pixels of `image` that show sky and liquids.
pub fn count(image: &RgbImage) -> Counts {
    let colours = |names: &[&str]| names.iter().map(|n| srgb(texture_color(n))).collect::<Vec<Rgb>>();
    let (sky, liquid) = (colours(&SKY_NAMES), colours(&LIQUID_NAMES));
    let near = |p: &Rgb, c: &Rgb| p.iter().zip(c).all(|(a, b)| a.abs_diff(*b) <= TOLERANCE);
    let mut counts = Counts::default();
    for p in &image.pixels {
        if sky.iter().any(|c| near(p, c)) {
            counts.sky += 1;
        } else if liquid.iter().any(|c| near(p, c)) {
            counts.liquid += 1;
        }
    }
    counts
}

/// The sRGB bytes of a linear colour.
fn srgb(linear: [f32; 4]) -> Rgb {
    let encode = |c: f32| {
        let c = c.clamp(0.0, 1.0);
        let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0).round() as u8
    };
    [encode(linear[0]), encode(linear[1]), encode(linear[2])]
}
