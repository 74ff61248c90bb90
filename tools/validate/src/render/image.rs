//! An RGB image in memory, a few drawing primitives, and PNG output (the `png` crate).

use std::io::Write;
use std::path::{Path, PathBuf};

/// Why a PNG could not be encoded or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PngError {
    /// Encoding failed (including a failed write to the output of [`Image::write_png`]).
    #[error(transparent)]
    Encode(#[from] png::EncodingError),
    /// Encoding the image for a file failed.
    #[error("encoding {}", .path.display())]
    EncodeFile {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: png::EncodingError,
    },
    /// Writing the file failed.
    #[error("writing {}", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
}

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Painted where a PVS check fails; nothing else in any picture uses it.
pub const ALARM_RED: Rgb = [255, 0, 0];

/// A `width × height` RGB image, rows top to bottom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels, row-major.
    pub pixels: Vec<Rgb>,
}

impl Image {
    /// A filled image.
    pub fn new(width: u32, height: u32, fill: Rgb) -> Self {
        Self { width, height, pixels: vec![fill; width as usize * height as usize] }
    }

    /// Pixel `(x, y)`; `None` outside.
    pub fn get(&self, x: i64, y: i64) -> Option<Rgb> {
        self.index(x, y).map(|i| self.pixels[i])
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        (x >= 0 && y >= 0 && x < i64::from(self.width) && y < i64::from(self.height))
            .then(|| y as usize * self.width as usize + x as usize)
    }

    /// Set pixel `(x, y)`; ignored outside.
    pub fn put(&mut self, x: i64, y: i64, c: Rgb) {
        if let Some(i) = self.index(x, y) {
            self.pixels[i] = c;
        }
    }

    /// A line from `(x0, y0)` to `(x1, y1)` (Bresenham), `thick` pixels wide.
    pub fn line(&mut self, (x0, y0): (i64, i64), (x1, y1): (i64, i64), c: Rgb, thick: i64) {
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
        let (mut x, mut y, mut err) = (x0, y0, dx + dy);
        // Far-off endpoints (a portal beyond the picture) are cut to a bounded number of steps.
        for _ in 0..=(dx - dy).min(1 << 16) {
            self.dot(x, y, c, thick);
            if x == x1 && y == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// A filled square of side `size` centred on `(x, y)`.
    pub fn dot(&mut self, x: i64, y: i64, c: Rgb, size: i64) {
        let r0 = -(size - 1) / 2;
        for oy in r0..r0 + size.max(1) {
            for ox in r0..r0 + size.max(1) {
                self.put(x + ox, y + oy, c);
            }
        }
    }

    /// Number of pixels of exactly colour `c`.
    pub fn count(&self, c: Rgb) -> usize {
        self.pixels.iter().filter(|&&p| p == c).count()
    }

    /// Encode as an 8-bit RGB PNG.
    pub fn write_png(&self, out: impl Write) -> Result<(), PngError> {
        Ok(self.encode(out)?)
    }

    /// [`Image::write_png`] with the encoder's own error.
    fn encode(&self, out: impl Write) -> Result<(), png::EncodingError> {
        let mut enc = png::Encoder::new(out, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::High);
        let mut w = enc.write_header()?;
        let data: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        w.write_image_data(&data)?;
        w.finish()?;
        Ok(())
    }

    /// Write a PNG file atomically (encoded in memory, then a temporary file renamed into place).
    pub fn save(&self, path: &Path) -> Result<(), PngError> {
        let mut bytes = Vec::new();
        self.encode(&mut bytes)
            .map_err(|source| PngError::EncodeFile { path: path.to_path_buf(), source })?;
        sightline_job::atomic::write_file_atomic(path, &bytes)
            .map_err(|source| PngError::Write { path: path.to_path_buf(), source })
    }
}

/// The colour of a leaf: a hash of its index, bright enough to shade and never [`ALARM_RED`]-like.
pub fn leaf_colour(leaf: u32) -> Rgb {
    let mut h = u64::from(leaf).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    h ^= h >> 29;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 32;
    // Hue, saturation and value from the hash; hues near red are moved away.
    let mut hue = (h % 360) as f64;
    if !(30.0..=330.0).contains(&hue) {
        hue = 30.0 + (hue + 30.0) % 60.0 * 5.0;
    }
    let sat = 0.40 + 0.35 * ((h >> 16) % 64) as f64 / 63.0;
    let val = 0.80 + 0.20 * ((h >> 24) % 64) as f64 / 63.0;
    hsv(hue, sat, val)
}

/// HSV (hue in degrees, saturation and value in 0..1) to RGB.
fn hsv(hue: f64, s: f64, v: f64) -> Rgb {
    let c = v * s;
    let hp = (hue.rem_euclid(360.0)) / 60.0;
    let x = c * (1.0 - (hp % 2.0 - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [((r + m) * 255.0).round() as u8, ((g + m) * 255.0).round() as u8, ((b + m) * 255.0).round() as u8]
}

/// `c` scaled by `k` (0..1).
pub fn shade(c: Rgb, k: f64) -> Rgb {
    c.map(|x| (f64::from(x) * k.clamp(0.0, 1.0)).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_colours_are_distinct_and_never_alarm_red() {
        let mut seen = std::collections::HashSet::new();
        for leaf in 0..2000 {
            let c = leaf_colour(leaf);
            assert_ne!(c, ALARM_RED);
            assert!(!(c[0] > 200 && c[1] < 100 && c[2] < 100), "leaf {leaf} looks red: {c:?}");
            seen.insert(c);
        }
        assert!(seen.len() > 300, "only {} colours", seen.len());
    }

    #[test]
    fn png_round_trips_dimensions() {
        let mut img = Image::new(7, 5, [1, 2, 3]);
        img.line((0, 0), (6, 4), [9, 9, 9], 1);
        assert_eq!(img.get(0, 0), Some([9, 9, 9]));
        assert_eq!(img.get(6, 4), Some([9, 9, 9]));
        let mut bytes = Vec::new();
        img.write_png(&mut bytes).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let reader = dec.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (7, 5));
    }
}
