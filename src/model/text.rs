//! Text drawn into HDR images for legends: the 8×8 bitmap glyphs of the `font8x8` crate (Basic
//! Latin and Greek, so "ν" prints), scaled by whole pixels, and the number format legends use.
//! Pixels are written as linear values, so text stays crisp in the EXR and in any PNG view.

use super::HdrImage;
use font8x8::{UnicodeFonts, BASIC_FONTS, GREEK_FONTS};

/// Glyph cell size in font pixels.
pub(crate) const GLYPH: u32 = 8;

/// The 8×8 bitmap of `c` (row 0 at the top, bit 0 the leftmost pixel); `?` for characters the
/// font lacks.
pub fn glyph(c: char) -> [u8; 8] {
    BASIC_FONTS
        .get(c)
        .or_else(|| GREEK_FONTS.get(c))
        .or_else(|| BASIC_FONTS.get('?'))
        .unwrap_or([0; 8])
}

/// Width in image pixels of `text` drawn at `scale`.
pub(crate) fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * GLYPH * scale
}

/// Draws `text` with its top-left corner at (x, y), each font pixel a `scale` × `scale` block
/// of `colour`; parts outside the image are clipped. Background pixels are left alone.
pub(crate) fn draw_text(
    img: &mut HdrImage,
    x: i64,
    y: i64,
    text: &str,
    scale: u32,
    colour: [f32; 4],
) {
    let s = scale.max(1) as i64;
    for (i, c) in text.chars().enumerate() {
        let rows = glyph(c);
        let x0 = x + i as i64 * GLYPH as i64 * s;
        for (gy, bits) in rows.iter().enumerate() {
            for gx in 0..GLYPH as i64 {
                if bits & (1 << gx) == 0 {
                    continue;
                }
                for dy in 0..s {
                    for dx in 0..s {
                        let (px, py) = (x0 + gx * s + dx, y + gy as i64 * s + dy);
                        if px >= 0 && py >= 0 && px < img.width as i64 && py < img.height as i64 {
                            img.pixels[(py as u64 * img.width as u64 + px as u64) as usize] =
                                colour;
                        }
                    }
                }
            }
        }
    }
}

/// A number for a legend: four significant digits without trailing zeros, plain between 1e-3
/// and 1e6, scientific outside (0.125, 12.5, 0.3333, 2.5e-7).
pub(crate) fn format_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    let trim = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if (1e-3..1e6).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        trim(format!("{v:.decimals$}"))
    } else {
        let s = format!("{v:.3e}");
        let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{exponent}", trim(mantissa.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_written() {
        assert_eq!(format_number(1.0 / 8.0), "0.125");
        assert_eq!(format_number(12.5), "12.5");
        assert_eq!(format_number(1.0 / 3.0), "0.3333");
        assert_eq!(format_number(2000.0), "2000");
        assert_eq!(format_number(2.5e-7), "2.5e-7");
        assert_eq!(format_number(-1.25e9), "-1.25e9");
    }

    #[test]
    fn glyphs_land_pixel_for_pixel() {
        let mut img = HdrImage::new(40, 20);
        let white = [1.0, 1.0, 1.0, 1.0];
        draw_text(&mut img, 3, 2, "1=", 2, white);
        let one = glyph('1');
        assert!(one.iter().any(|r| *r != 0));
        for (gy, bits) in one.iter().enumerate() {
            for gx in 0..8 {
                let lit = bits & (1 << gx) != 0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let p = img.pixels[(2 + gy * 2 + dy) * 40 + 3 + gx * 2 + dx];
                    assert_eq!(p == white, lit, "glyph pixel ({gx}, {gy})");
                }
            }
        }
        // Nothing outside the two glyph cells (3..35 x 2..18).
        for (i, p) in img.pixels.iter().enumerate() {
            let (x, y) = (i % 40, i / 40);
            if !(3..35).contains(&x) || !(2..18).contains(&y) {
                assert_eq!(*p, [0.0; 4]);
            }
        }
        assert_ne!(glyph('ν'), glyph('?'), "Greek nu is in the font");
        assert_eq!(text_width("ν = 8", 2), 80);
        // Clipping: drawing off the edges is harmless.
        draw_text(&mut img, -5, 15, "xyz", 3, white);
    }
}
