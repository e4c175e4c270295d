//! Text drawn into HDR images for legends: the 8×8 bitmap glyphs of the `font8x8` crate (Basic
//! Latin, Latin-1 and Greek, so "ν" and "°" print), scaled by whole pixels, and the number format
//! legends use.
//! Pixels are written as linear values, so text stays crisp in the EXR and in any PNG view.
//! [`ColourBar`] is the colour bar a render records in its metadata (colour map, scale, domain,
//! units) and [`with_colour_bar`] draws it under an image with labelled ticks — every decade on
//! log10 and symlog scales — for `save_png(img, path, #{legend: true})`.

use super::HdrImage;
use font8x8::{UnicodeFonts, BASIC_FONTS, GREEK_FONTS, LATIN_FONTS};

/// Glyph cell size in font pixels.
pub(crate) const GLYPH: u32 = 8;

/// The 8×8 bitmap of `c` (row 0 at the top, bit 0 the leftmost pixel); `?` for characters the
/// font lacks.
pub fn glyph(c: char) -> [u8; 8] {
    BASIC_FONTS
        .get(c)
        .or_else(|| GREEK_FONTS.get(c))
        .or_else(|| LATIN_FONTS.get(c))
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

/// Round values for the ticks of a linear axis over [lo, hi]: multiples of 1, 2 or 5 times a
/// power of ten, the step the smallest giving at most about `most` ticks (one tick, `lo`, for
/// an empty span). A value within 1e-9 of a step of zero is exactly 0.
pub(crate) fn nice_ticks(lo: f64, hi: f64, most: usize) -> Vec<f64> {
    let span = hi - lo;
    if span.is_nan() || span <= 0.0 {
        return vec![lo];
    }
    let raw = span / most.max(1) as f64;
    let power = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|i| i as f64 * step)
        .map(|v| if v.abs() < step * 1e-9 { 0.0 } else { v })
        .collect()
}

/// The scale a colour bar's ticks follow (that of the transfer function or colour mapping).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum BarScale {
    Linear,
    Log10,
    Symlog { linthresh: f64 },
}

impl BarScale {
    fn apply(self, v: f64) -> f64 {
        match self {
            BarScale::Linear => v,
            BarScale::Log10 => v.max(f64::MIN_POSITIVE).log10(),
            BarScale::Symlog { linthresh } => {
                v.signum() * (v.abs() / linthresh).ln_1p() / std::f64::consts::LN_10
            }
        }
    }

    fn describe(self) -> String {
        match self {
            BarScale::Linear => "linear".into(),
            BarScale::Log10 => "log10".into(),
            BarScale::Symlog { linthresh } => format!("symlog {linthresh}"),
        }
    }

    fn parse(text: &str) -> Option<BarScale> {
        let mut words = text.split_whitespace();
        match (words.next()?, words.next().map(str::parse::<f64>)) {
            ("linear", None) => Some(BarScale::Linear),
            ("log10", None) => Some(BarScale::Log10),
            ("symlog", Some(Ok(c))) if c > 0.0 && c.is_finite() => {
                Some(BarScale::Symlog { linthresh: c })
            }
            _ => None,
        }
    }
}

/// The colour bar of a render: `colormap` over [lo, hi] of the data on `scale`, in `units`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ColourBar {
    pub colormap: String,
    pub scale: BarScale,
    pub lo: f64,
    pub hi: f64,
    pub units: String,
}

/// Metadata keys a render records its colour bar under.
const BAR_KEYS: [&str; 4] = [
    "legend_colormap",
    "legend_scale",
    "legend_domain",
    "legend_units",
];

impl ColourBar {
    /// Records the bar in `img`'s metadata.
    pub(crate) fn record(&self, img: &mut HdrImage) {
        img.set_meta(BAR_KEYS[0], self.colormap.as_str());
        img.set_meta(BAR_KEYS[1], self.scale.describe());
        img.set_meta(BAR_KEYS[2], format!("{} {}", self.lo, self.hi));
        img.set_meta(BAR_KEYS[3], self.units.as_str());
    }

    /// The bar `img` records, if it records one.
    pub(crate) fn of(img: &HdrImage) -> Option<ColourBar> {
        let mut domain = img
            .meta(BAR_KEYS[2])?
            .split_whitespace()
            .map(str::parse::<f64>);
        let (Some(Ok(lo)), Some(Ok(hi))) = (domain.next(), domain.next()) else {
            return None;
        };
        Some(ColourBar {
            colormap: img.meta(BAR_KEYS[0])?.to_string(),
            scale: BarScale::parse(img.meta(BAR_KEYS[1])?)?,
            lo,
            hi,
            units: img.meta(BAR_KEYS[3]).unwrap_or("").to_string(),
        })
    }

    /// Where `v` sits along the bar, 0 at `lo` and 1 at `hi`.
    pub(crate) fn position(&self, v: f64) -> f64 {
        let (a, b) = (self.scale.apply(self.lo), self.scale.apply(self.hi));
        if b > a {
            (self.scale.apply(v) - a) / (b - a)
        } else {
            0.0
        }
    }

    /// The bar's units and scale as one line of at most `width` pixels ("m, log10 scale", then
    /// shorter forms; empty when even the units do not fit).
    pub(crate) fn caption(&self, width: u32) -> String {
        let units = match self.units.as_str() {
            "" => "data units".to_string(),
            "1" => "dimensionless".to_string(),
            u => u.to_string(),
        };
        [
            format!("{units}, {} scale", self.scale.describe()),
            format!("{units}, {}", self.scale.describe()),
            units,
        ]
        .into_iter()
        .find(|c| text_width(c, 1) <= width)
        .unwrap_or_default()
    }

    /// Tick values with their labels: every decade (thinned to at most `most`) on log10, zero and
    /// the decades of both signs beyond the linear threshold on symlog, and steps of 1, 2 or 5
    /// times a power of ten on a linear scale.
    pub(crate) fn ticks(&self, most: usize) -> Vec<(f64, String)> {
        let (lo, hi) = (self.lo.min(self.hi), self.lo.max(self.hi));
        let decade_label = |k: i32| {
            if (-2..=3).contains(&k) {
                format_number(10f64.powi(k))
            } else {
                format!("1e{k}")
            }
        };
        let decades = |from: f64, to: f64| -> Vec<i32> {
            if !(from > 0.0 && to >= from) {
                return Vec::new();
            }
            let (a, b) = (from.log10().ceil() as i32, to.log10().floor() as i32);
            let n = (b - a + 1).max(0) as usize;
            let step = n.div_ceil(most.max(1)).max(1);
            (a..=b).step_by(step).collect()
        };
        let mut ticks: Vec<(f64, String)> = match self.scale {
            BarScale::Log10 => decades(lo.max(f64::MIN_POSITIVE), hi)
                .into_iter()
                .map(|k| (10f64.powi(k), decade_label(k)))
                .collect(),
            BarScale::Symlog { linthresh } => {
                let mut t: Vec<(f64, String)> = decades(linthresh, -lo)
                    .into_iter()
                    .rev()
                    .map(|k| (-(10f64.powi(k)), format!("-{}", decade_label(k))))
                    .collect();
                if lo <= 0.0 && hi >= 0.0 {
                    t.push((0.0, "0".into()));
                }
                t.extend(
                    decades(linthresh, hi)
                        .into_iter()
                        .map(|k| (10f64.powi(k), decade_label(k))),
                );
                t
            }
            BarScale::Linear => nice_ticks(lo, hi, most)
                .into_iter()
                .map(|v| (v, format_number(v)))
                .collect(),
        };
        ticks.retain(|(v, _)| *v >= lo && *v <= hi);
        ticks
    }
}

/// Height of the colour bar itself in a [`with_colour_bar`] strip.
pub(crate) const STRIP_BAR: u32 = 12;

/// `img` with `bar` drawn beneath it on black: the colour bar across the full width (colours in
/// linear light, as the image's), a white tick at each of [`ColourBar::ticks`] with its label
/// under it (labels that would overlap the previous one are left out), and the units at the
/// right. The metadata records the ticks drawn (`legend_ticks`, "value@x ...").
pub(crate) fn with_colour_bar(img: &HdrImage, bar: &ColourBar) -> crate::Result<HdrImage> {
    let cmap = super::colormap::Colormap::by_name(&bar.colormap)?;
    let (w, h) = (img.width, img.height);
    let line = GLYPH + 4;
    let strip = 4 + STRIP_BAR + 3 + line + line;
    let mut out = HdrImage::new(w, h + strip);
    out.metadata = img.metadata.clone();
    out.pixels[..img.pixels.len()].copy_from_slice(&img.pixels);
    for p in out.pixels[img.pixels.len()..].iter_mut() {
        *p = [0.0, 0.0, 0.0, 1.0];
    }
    let top = h + 4;
    for x in 0..w {
        let t = (x as f64 + 0.5) / w as f64;
        let c = cmap.linear_rgb(t);
        for y in top..top + STRIP_BAR {
            out.pixels[(y * w + x) as usize] = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
        }
    }
    let white = [1.0, 1.0, 1.0, 1.0];
    let most = (w / (GLYPH * 6)).clamp(2, 10) as usize;
    let mut drawn = Vec::new();
    let mut free_from = 0i64;
    for (v, label) in bar.ticks(most) {
        let x = (bar.position(v) * (w - 1) as f64).round() as u32;
        for y in top + STRIP_BAR..top + STRIP_BAR + 3 {
            out.pixels[(y * w + x) as usize] = white;
        }
        let lw = text_width(&label, 1) as i64;
        let lx = (x as i64 - lw / 2).clamp(0, (w as i64 - lw).max(0));
        if lx >= free_from {
            draw_text(&mut out, lx, (top + STRIP_BAR + 4) as i64, &label, 1, white);
            free_from = lx + lw + GLYPH as i64;
            drawn.push(format!("{v}@{x}"));
        }
    }
    let caption = bar.caption(w.saturating_sub(4));
    let cx = (w as i64 - text_width(&caption, 1) as i64 - 2).max(0);
    draw_text(
        &mut out,
        cx,
        (top + STRIP_BAR + 4 + line) as i64,
        &caption,
        1,
        white,
    );
    out.set_meta("legend_ticks", drawn.join(" "));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bar(scale: BarScale, lo: f64, hi: f64) -> ColourBar {
        ColourBar {
            colormap: "viridis".into(),
            scale,
            lo,
            hi,
            units: "m".into(),
        }
    }

    #[test]
    fn colour_bar_ticks_label_decades() {
        let log = bar(BarScale::Log10, 1e-3, 5.0).ticks(10);
        let labels: Vec<&str> = log.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["1e-3", "0.01", "0.1", "1"]);
        assert!((bar(BarScale::Log10, 1e-3, 5.0).position(0.01) - 1.0 / 3.69897).abs() < 1e-5);
        let wide = bar(BarScale::Log10, 1e-12, 1e6).ticks(6);
        assert!(
            wide.len() <= 6 && wide.iter().any(|(_, l)| l == "1e-12"),
            "{wide:?}"
        );
        let sym = bar(BarScale::Symlog { linthresh: 1e-3 }, -0.3, 0.45).ticks(10);
        let labels: Vec<&str> = sym.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(
            labels,
            ["-0.1", "-0.01", "-1e-3", "0", "1e-3", "0.01", "0.1"]
        );
        let lin = bar(BarScale::Linear, -0.7, 2.3).ticks(10);
        let labels: Vec<&str> = lin.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["-0.5", "0", "0.5", "1", "1.5", "2"]);
    }

    #[test]
    fn colour_bar_round_trips_through_metadata_and_draws_under_the_image() {
        let b = bar(BarScale::Symlog { linthresh: 0.01 }, -1.0, 2.0);
        let mut img = HdrImage::new(200, 10);
        b.record(&mut img);
        assert_eq!(ColourBar::of(&img), Some(b.clone()));
        let out = with_colour_bar(&img, &b).unwrap();
        assert_eq!((out.width, out.height), (200, 10 + 4 + STRIP_BAR + 3 + 24));
        // The bar's first row is the colour map from end to end; each drawn tick sits where
        // `position` puts its value.
        let cmap = super::super::colormap::Colormap::by_name("viridis").unwrap();
        let row = 14usize;
        let c = cmap.linear_rgb(0.5 / 200.0);
        assert!((out.pixels[row * 200][0] as f64 - c[0]).abs() < 1e-6);
        let ticks = out.meta("legend_ticks").unwrap().to_string();
        assert!(ticks.split(' ').count() >= 4, "{ticks}");
        for t in ticks.split(' ') {
            let (v, x) = t.split_once('@').unwrap();
            let (v, x): (f64, u32) = (v.parse().unwrap(), x.parse().unwrap());
            assert_eq!(x, (b.position(v) * 199.0).round() as u32);
            assert_eq!(
                out.pixels[((14 + STRIP_BAR as usize) * 200) + x as usize],
                [1.0; 4]
            );
        }
    }

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
