//! A 3 × 5 pixel font for labels on pictures (legends, scales): digits, `A`–`Z` (lower case is
//! drawn as upper case), space, `.` and `-`. Each glyph is five rows, top first, of three bits,
//! the left pixel in bit 2; glyphs sit 4 pixels apart (one column of space), scaled by an integer.

use super::image::{Image, Rgb};

/// Glyph width in pixels, before scaling.
pub const GLYPH_W: i64 = 3;
/// Glyph height in pixels, before scaling.
pub const GLYPH_H: i64 = 5;

/// The rows of `c`'s glyph; `None` for a character the font lacks (drawn as a space).
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c.to_ascii_uppercase() {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [3, 4, 4, 4, 3],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [3, 4, 5, 5, 3],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 2],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'Q' => [2, 5, 5, 6, 3],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        ' ' => [0; 5],
        _ => return None,
    })
}

/// Width in pixels of `text` drawn at `scale`.
pub fn text_width(text: &str, scale: i64) -> i64 {
    let n = text.chars().count() as i64;
    (n * (GLYPH_W + 1) - 1).max(0) * scale
}

/// Draw `text` with its top-left corner at `(x, y)`, each font pixel a `scale` × `scale` square.
pub fn draw_text(image: &mut Image, x: i64, y: i64, text: &str, colour: Rgb, scale: i64) {
    for (i, c) in text.chars().enumerate() {
        let rows = glyph(c).unwrap_or([0; 5]);
        let left = x + i as i64 * (GLYPH_W + 1) * scale;
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..GLYPH_W {
                if bits >> (GLYPH_W - 1 - col) & 1 == 1 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            image.put(left + col * scale + dx, y + r as i64 * scale + dy, colour);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_letter_and_digit_has_a_glyph_and_text_lands_where_measured() {
        assert!(('0'..='9').chain('A'..='Z').all(|c| glyph(c).is_some_and(|g| g.iter().any(|&r| r != 0))));
        let mut image = Image::new(40, 12, [0, 0, 0]);
        draw_text(&mut image, 1, 1, "E1", [255, 255, 255], 2);
        // E: 10 lit pixels, 1: 8 lit pixels; each 2 × 2.
        assert_eq!(image.count([255, 255, 255]), (10 + 8) * 4);
        assert_eq!(text_width("E1", 2), 14);
        assert!(image.get(1 + 14, 1).is_some_and(|p| p == [0, 0, 0]), "nothing past the measured width");
    }
}
