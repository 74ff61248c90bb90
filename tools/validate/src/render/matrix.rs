//! The PVS as a picture: cluster `a`'s row is image row `a`, a lit pixel at column `b` means `a`
//! sees `b`. Matrices wider than the image are reduced: a pixel is lit when any pair it covers is
//! visible, and its brightness grows with the share of visible pairs. With a sampled matrix,
//! pairs the rays proved visible are green, PVS-only pairs grey and sampled pairs missing from the
//! PVS [`ALARM_RED`].

use super::image::{ALARM_RED, Image, Rgb};
use crate::pvs::BitMatrix;

/// PVS pairs the rays did not prove (or all PVS pairs without a sampled matrix).
pub const PVS_ONLY: Rgb = [200, 200, 200];
/// PVS pairs the rays proved.
pub const PROVED: Rgb = [60, 220, 90];

/// Draw `pvs` (and optionally `sampled`) at most `max_size` pixels wide.
pub fn render_matrix(pvs: &BitMatrix, sampled: Option<&BitMatrix>, max_size: u32) -> Image {
    let n = pvs.len().max(1);
    let max_size = max_size.max(1) as usize;
    // Whole pixels per cluster when the matrix is small, whole clusters per pixel when it is big.
    let (size, per_px) = if n <= max_size {
        ((max_size / n) * n, 1)
    } else {
        (n.div_ceil(n.div_ceil(max_size)), n.div_ceil(max_size))
    };
    let px_per = (size / n).max(1);
    let mut img = Image::new(size as u32, size as u32, [0, 0, 0]);
    for py in 0..size / px_per {
        for px in 0..size / px_per {
            let (mut lit, mut proved, mut missed, mut total) = (0u32, 0u32, 0u32, 0u32);
            for a in py * per_px..((py + 1) * per_px).min(n) {
                for b in px * per_px..((px + 1) * per_px).min(n) {
                    total += 1;
                    let (v, s) = (pvs.get(a, b), sampled.is_some_and(|m| m.get(a, b)));
                    lit += u32::from(v);
                    proved += u32::from(v && s);
                    missed += u32::from(!v && s);
                }
            }
            let c = if missed > 0 {
                ALARM_RED
            } else if lit == 0 {
                continue;
            } else {
                let base = if proved * 2 >= lit && sampled.is_some() { PROVED } else { PVS_ONLY };
                let k = 0.4 + 0.6 * f64::from(lit) / f64::from(total.max(1));
                base.map(|x| (f64::from(x) * k) as u8)
            };
            for oy in 0..px_per {
                for ox in 0..px_per {
                    img.put((px * px_per + ox) as i64, (py * px_per + oy) as i64, c);
                }
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_matrix_is_scaled_up_and_shows_misses() {
        let mut pvs = BitMatrix::new(4);
        pvs.set(0, 0);
        pvs.set(1, 2);
        let mut sampled = BitMatrix::new(4);
        sampled.set(0, 0);
        sampled.set(3, 3);
        let img = render_matrix(&pvs, Some(&sampled), 64);
        assert_eq!((img.width, img.height), (64, 64));
        assert_eq!(img.get(0, 0), Some(PROVED));
        assert_eq!(img.get(2 * 16 + 3, 16 + 3), Some(PVS_ONLY.map(|x| (f64::from(x) * 1.0) as u8)));
        assert_eq!(img.get(63, 63), Some(ALARM_RED));
        assert_eq!(img.get(0, 63), Some([0, 0, 0]));
    }

    #[test]
    fn big_matrix_is_reduced() {
        let mut pvs = BitMatrix::new(1000);
        for i in 0..1000 {
            pvs.set(i, i);
        }
        let img = render_matrix(&pvs, None, 256);
        assert!(img.width <= 256 && img.width >= 200);
        assert!(img.get(0, 0).is_some_and(|c| c != [0, 0, 0]));
        assert_eq!(img.get(img.width as i64 - 1, 0), Some([0, 0, 0]));
    }
}
