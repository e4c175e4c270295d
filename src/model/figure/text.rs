//! Text drawn into HDR images for legends and figures, and the number format and ticks they use.
//! Type is DejaVu Sans, a proportional sans-serif (matplotlib's default face; Bitstream Vera
//! licence, see docs/surfaces.md) that the `dejavu` crate embeds, rasterised by `ab_glyph` into
//! anti-aliased coverage, so labels scale to any size and carry ν, °, the minus sign U+2212, µ and
//! superscript powers of ten (10⁻³). [`Type`] is a text size with the line metrics layouts use.
//! Pixels are blended in linear light, so text stays crisp in the EXR and in any PNG view.
//! [`ColourBar`] is the colour bar a render records in its metadata (colour map, scale, domain,
//! units, which ends clip) and [`with_colour_bar`] draws it under an image with labelled ticks —
//! every decade on log10 and symlog scales — for `save_png(img, path, #{legend: true})`.

use crate::model::HdrImage;
use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

/// The embedded typeface, parsed once.
fn face() -> &'static FontRef<'static> {
    static FACE: OnceLock<FontRef<'static>> = OnceLock::new();
    FACE.get_or_init(|| {
        FontRef::try_from_slice(dejavu::sans::regular())
            .expect("the embedded DejaVu Sans typeface parses")
    })
}

/// A text size: the font's em in pixels, with the metrics layouts need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Type {
    pub px: f32,
}

/// The smallest and largest text sizes, in pixels per em: below 6 glyphs blur into each other,
/// and the limit above keeps a mistyped size from allocating a poster.
pub(crate) const TYPE_MIN: f64 = 6.0;
pub(crate) const TYPE_MAX: f64 = 400.0;

impl Type {
    pub(crate) fn new(px: f64) -> Type {
        Type {
            px: px.clamp(TYPE_MIN, TYPE_MAX) as f32,
        }
    }

    /// The default size for a figure around a picture `width × height`: 2.8 % of the shorter
    /// side (matplotlib's 10 pt on its 6.4 × 4.8 inch figure at 100 dpi is 2.9 %), at least 11
    /// pixels, so labels read alike at 512² and at 4096².
    pub(crate) fn for_figure(width: u32, height: u32) -> Type {
        Type::new((0.028 * width.min(height) as f64).max(11.0))
    }

    /// The face at this size: `px` is the em (ab_glyph's own scale is the line height).
    fn scaled(self) -> ab_glyph::PxScaleFont<&'static FontRef<'static>> {
        let f = face();
        let per_em = f.height_unscaled() / f.units_per_em().unwrap_or(f.height_unscaled());
        f.as_scaled(PxScale::from(self.px * per_em))
    }

    /// Height of a line of text: ascent + descent and a pixel above and below, which
    /// anti-aliased edges of the tallest glyphs reach.
    pub(crate) fn line(self) -> u32 {
        let f = self.scaled();
        (f.ascent() - f.descent()).ceil() as u32 + 2
    }

    /// Space between a tick and its label, between lines and around a figure: a third of an em,
    /// at least 2 pixels.
    pub(crate) fn gap(self) -> u32 {
        ((self.px / 3.0).round() as u32).max(2)
    }

    /// Width of `text` in pixels (advances and kerning).
    pub(crate) fn width(self, text: &str) -> u32 {
        let f = self.scaled();
        let mut w = 0.0f32;
        let mut last = None;
        for c in text.chars() {
            let id = f.glyph_id(c);
            if let Some(prev) = last {
                w += f.kern(prev, id);
            }
            w += f.h_advance(id);
            last = Some(id);
        }
        w.ceil() as u32
    }

    /// The size `scale` times larger (a title).
    pub(crate) fn times(self, scale: f64) -> Type {
        Type::new(self.px as f64 * scale)
    }
}

/// Draws `text` with the top-left corner of its line box ([`Type::line`]: a pixel, the ascent
/// above the baseline, the descent below, a pixel) at (x, y), blending `colour` over the image by each pixel's coverage; parts outside
/// the image are clipped.
pub(crate) fn draw_text(
    img: &mut HdrImage,
    x: i64,
    y: i64,
    text: &str,
    ty: Type,
    colour: [f32; 4],
) {
    let f = ty.scaled();
    let baseline = y as f32 + 1.0 + f.ascent();
    let mut pen = x as f32;
    let mut last = None;
    let (w, h) = (img.width as i64, img.height as i64);
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(prev) = last {
            pen += f.kern(prev, id);
        }
        let glyph = id.with_scale_and_position(f.scale(), ab_glyph::point(pen, baseline));
        pen += f.h_advance(id);
        last = Some(id);
        let Some(outline) = face().outline_glyph(glyph) else {
            continue;
        };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let px = bounds.min.x as i64 + gx as i64;
            let py = bounds.min.y as i64 + gy as i64;
            if coverage <= 0.0 || px < 0 || py < 0 || px >= w || py >= h {
                return;
            }
            let a = coverage.min(1.0);
            let p = &mut img.pixels[(py * w + px) as usize];
            for k in 0..4 {
                p[k] = p[k] * (1.0 - a) + colour[k] * a;
            }
        });
    }
}

/// Superscript forms of the characters of an exponent.
fn superscript(exponent: &str) -> String {
    exponent
        .chars()
        .filter_map(|c| match c {
            '-' | '\u{2212}' => Some('\u{207b}'),
            '0' => Some('\u{2070}'),
            '1' => Some('\u{b9}'),
            '2' => Some('\u{b2}'),
            '3' => Some('\u{b3}'),
            '4'..='9' => char::from_u32(0x2074 + (c as u32 - '4' as u32)),
            _ => None,
        })
        .collect()
}

/// A number as typeset on a figure: [`format_number`] with the minus sign U+2212 and powers of
/// ten in superscript (−2.5×10⁻⁷; 10⁻³ for a bare power).
pub(crate) fn typeset_number(v: f64) -> String {
    let plain = format_number(v);
    let (mantissa, exponent) = match plain.split_once('e') {
        Some((m, e)) => (m.replace('-', "\u{2212}"), Some(e)),
        None => (plain.replace('-', "\u{2212}"), None),
    };
    match exponent {
        None => mantissa,
        Some(e) if mantissa == "1" => format!("10{}", superscript(e)),
        Some(e) if mantissa == "\u{2212}1" => format!("\u{2212}10{}", superscript(e)),
        Some(e) => format!("{mantissa}×10{}", superscript(e)),
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
    // Within 1e-9 of a step counts as on it: ends computed through an offset may miss a round
    // value by an ulp.
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
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
    /// What the bar measures, as its caption says it ("sea surface temperature (K)"); empty:
    /// the units alone.
    pub label: String,
    /// Whether data lie below `lo` and above `hi` (drawn in the end colours): a triangle is
    /// drawn at that end of the bar, as matplotlib's `extend`.
    pub extend: [bool; 2],
}

/// Metadata keys a render records its colour bar under.
const BAR_KEYS: [&str; 6] = [
    "legend_colormap",
    "legend_scale",
    "legend_domain",
    "legend_units",
    "legend_extend",
    "legend_label",
];

/// The `extend` words of matplotlib, indexed by [low, high] clipping.
const EXTEND_WORDS: [&str; 4] = ["neither", "min", "max", "both"];

impl ColourBar {
    /// Records the bar in `img`'s metadata.
    pub(crate) fn record(&self, img: &mut HdrImage) {
        img.set_meta(BAR_KEYS[0], self.colormap.as_str());
        img.set_meta(BAR_KEYS[1], self.scale.describe());
        img.set_meta(BAR_KEYS[2], format!("{} {}", self.lo, self.hi));
        img.set_meta(BAR_KEYS[3], self.units.as_str());
        let word = EXTEND_WORDS[self.extend[0] as usize + 2 * self.extend[1] as usize];
        img.set_meta(BAR_KEYS[4], word);
        if !self.label.is_empty() {
            img.set_meta(BAR_KEYS[5], self.label.as_str());
        }
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
            label: img.meta(BAR_KEYS[5]).unwrap_or("").to_string(),
            extend: match img.meta(BAR_KEYS[4]) {
                Some("min") => [true, false],
                Some("max") => [false, true],
                Some("both") => [true, true],
                _ => [false, false],
            },
        })
    }

    /// Where the colours run along a bar `len` pixels long whose extend triangles are `tri`
    /// long: `[start, end)`, short of each end that has a triangle.
    pub(crate) fn extent(&self, len: u32, tri: u32) -> (u32, u32) {
        let start = if self.extend[0] { tri } else { 0 };
        let end = len.saturating_sub(if self.extend[1] { tri } else { 0 });
        (start.min(end.saturating_sub(1)), end.max(1))
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

    /// The bar's label (or its units) and a scale other than linear as one line of at most
    /// `width` pixels ("sea surface temperature (K)", "m, log10 scale", then shorter forms;
    /// empty when even the shortest does not fit).
    pub(crate) fn caption(&self, width: u32, ty: Type) -> String {
        let units = match self.units.as_str() {
            "" => "data units".to_string(),
            "1" => "dimensionless".to_string(),
            u => u.to_string(),
        };
        let scale = self.scale.describe();
        let linear = matches!(self.scale, BarScale::Linear);
        let candidates = if self.label.is_empty() {
            vec![
                format!("{units}, {scale} scale"),
                format!("{units}, {scale}"),
                units,
            ]
        } else if linear {
            vec![self.label.clone(), units]
        } else {
            vec![
                format!("{}, {scale} scale", self.label),
                self.label.clone(),
                format!("{units}, {scale}"),
                units,
            ]
        };
        candidates
            .into_iter()
            .find(|c| ty.width(c) <= width)
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
                format!("10{}", superscript(&k.to_string()))
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
                    .map(|k| (-(10f64.powi(k)), format!("\u{2212}{}", decade_label(k))))
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
                .map(|v| (v, typeset_number(v)))
                .collect(),
        };
        // As in `nice_ticks`, a round value an ulp beyond an end still counts.
        let tol = 1e-9 * (hi - lo).abs();
        ticks.retain(|(v, _)| *v >= lo - tol && *v <= hi + tol);
        ticks
    }
}

/// The length of an extend triangle on a bar `len` long and `thickness` across: as long as the
/// bar is thick (matplotlib's default), at most a quarter of the bar.
pub(crate) fn extend_length(len: u32, thickness: u32) -> u32 {
    thickness.min(len / 4)
}

/// Paints the pixels whose centres lie inside (or on) the triangle `corners`, clipped to the
/// image.
pub(crate) fn fill_triangle(img: &mut HdrImage, corners: [(f64, f64); 3], colour: [f32; 4]) {
    let [a, b, c] = corners;
    let edge = |p: (f64, f64), q: (f64, f64), x: f64, y: f64| {
        (q.0 - p.0) * (y - p.1) - (q.1 - p.1) * (x - p.0)
    };
    let area = edge(a, b, c.0, c.1);
    if area == 0.0 {
        return;
    }
    let lo = |i: fn(&(f64, f64)) -> f64| corners.iter().map(i).fold(f64::INFINITY, f64::min);
    let hi = |i: fn(&(f64, f64)) -> f64| corners.iter().map(i).fold(f64::NEG_INFINITY, f64::max);
    let (x0, x1) = (lo(|p| p.0).floor().max(0.0), hi(|p| p.0).ceil());
    let (y0, y1) = (lo(|p| p.1).floor().max(0.0), hi(|p| p.1).ceil());
    for y in y0 as u32..(y1.min(img.height as f64)) as u32 {
        for x in x0 as u32..(x1.min(img.width as f64)) as u32 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let inside = [(a, b), (b, c), (c, a)]
                .iter()
                .all(|(p, q)| edge(*p, *q, px, py) * area.signum() >= -1e-9);
            if inside {
                img.pixels[(y * img.width + x) as usize] = colour;
            }
        }
    }
}

/// The extend triangles of `bar` in the rectangle [x0, x1) × [y0, y1) that holds the bar and its
/// triangles, in the colours of the map's ends: pointing left and right along a horizontal bar,
/// down and up along an `upright` one (the high end at the top).
pub(crate) fn draw_extend_triangles(
    img: &mut HdrImage,
    bar: &ColourBar,
    cmap: &crate::model::colormap::Colormap,
    (x0, x1): (u32, u32),
    (y0, y1): (u32, u32),
    upright: bool,
) {
    let (x0, x1, y0, y1) = (x0 as f64, x1 as f64, y0 as f64, y1 as f64);
    let along = if upright { y1 - y0 } else { x1 - x0 };
    let across = if upright { x1 - x0 } else { y1 - y0 };
    let tri = extend_length(along as u32, across as u32) as f64;
    let colour = |t: f64| {
        let c = cmap.linear_rgb(t);
        [c[0] as f32, c[1] as f32, c[2] as f32, 1.0]
    };
    let (mx, my) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let ends = if upright {
        [
            [(mx, y1), (x0, y1 - tri), (x1, y1 - tri)],
            [(mx, y0), (x0, y0 + tri), (x1, y0 + tri)],
        ]
    } else {
        [
            [(x0, my), (x0 + tri, y0), (x0 + tri, y1)],
            [(x1, my), (x1 - tri, y0), (x1 - tri, y1)],
        ]
    };
    for (k, corners) in ends.into_iter().enumerate() {
        if bar.extend[k] {
            fill_triangle(img, corners, colour(k as f64));
        }
    }
}

/// `img` with `bar` drawn beneath it on black in type `ty`: the colour bar across the full width
/// (colours in linear light, as the image's; a line of text thick, extend triangles at the ends
/// that clip), a white tick at each of [`ColourBar::ticks`] with its label a gap below it
/// (labels that would overlap the previous one are left out), and the units at the right. The
/// metadata records the bar's rows (`legend_bar_rows`, "top bottom") and the ticks drawn
/// (`legend_ticks`, "value@x ...").
pub(crate) fn with_colour_bar(
    img: &HdrImage,
    bar: &ColourBar,
    ty: Type,
) -> crate::Result<HdrImage> {
    let cmap = crate::model::colormap::Colormap::by_name(&bar.colormap)?;
    let (w, h) = (img.width, img.height);
    let (gap, line) = (ty.gap(), ty.line());
    let thick = line;
    let strip = gap + thick + gap + gap + line + gap + line + gap;
    let mut out = HdrImage::new(w, h + strip);
    out.metadata = img.metadata.clone();
    out.pixels[..img.pixels.len()].copy_from_slice(&img.pixels);
    // A white band with black ink, as a figure's page: legible whatever the picture's colours.
    for p in out.pixels[img.pixels.len()..].iter_mut() {
        *p = [1.0, 1.0, 1.0, 1.0];
    }
    let top = h + gap;
    let (x0, x1) = bar.extent(w, extend_length(w, thick));
    for x in x0..x1 {
        let t = (x as f64 - x0 as f64 + 0.5) / (x1 - x0) as f64;
        let c = cmap.linear_rgb(t);
        for y in top..top + thick {
            out.pixels[(y * w + x) as usize] = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
        }
    }
    draw_extend_triangles(&mut out, bar, &cmap, (0, w), (top, top + thick), false);
    let ink = [0.0, 0.0, 0.0, 1.0];
    let tick_end = top + thick + gap;
    let label_top = tick_end + gap;
    let most = (w / (ty.width("0") * 6).max(1)).clamp(2, 10) as usize;
    let mut drawn = Vec::new();
    let mut free_from = 0i64;
    for (v, label) in bar.ticks(most) {
        let x = x0 + (bar.position(v) * (x1 - x0 - 1) as f64).round() as u32;
        for y in top + thick..tick_end {
            out.pixels[(y * w + x) as usize] = ink;
        }
        let lw = ty.width(&label) as i64;
        let lx = (x as i64 - lw / 2).clamp(0, (w as i64 - lw).max(0));
        if lx >= free_from {
            draw_text(&mut out, lx, label_top as i64, &label, ty, ink);
            free_from = lx + lw + ty.width("0") as i64;
            drawn.push(format!("{v}@{x}"));
        }
    }
    let caption = bar.caption(w.saturating_sub(2 * gap), ty);
    let cx = (w as i64 - ty.width(&caption) as i64 - gap as i64).max(0);
    draw_text(
        &mut out,
        cx,
        (label_top + line + gap) as i64,
        &caption,
        ty,
        ink,
    );
    out.set_meta("legend_bar_rows", format!("{top} {}", top + thick));
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
            label: String::new(),
            extend: [false; 2],
        }
    }

    #[test]
    fn colour_bar_ticks_label_decades() {
        let log = bar(BarScale::Log10, 1e-3, 5.0).ticks(10);
        let labels: Vec<&str> = log.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["10⁻³", "0.01", "0.1", "1"]);
        assert!((bar(BarScale::Log10, 1e-3, 5.0).position(0.01) - 1.0 / 3.69897).abs() < 1e-5);
        let wide = bar(BarScale::Log10, 1e-12, 1e6).ticks(6);
        assert!(
            wide.len() <= 6 && wide.iter().any(|(_, l)| l == "10⁻¹²"),
            "{wide:?}"
        );
        let sym = bar(BarScale::Symlog { linthresh: 1e-3 }, -0.3, 0.45).ticks(10);
        let labels: Vec<&str> = sym.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(
            labels,
            ["−0.1", "−0.01", "−10⁻³", "0", "10⁻³", "0.01", "0.1"]
        );
        let lin = bar(BarScale::Linear, -0.7, 2.3).ticks(10);
        let labels: Vec<&str> = lin.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels, ["−0.5", "0", "0.5", "1", "1.5", "2"]);
    }

    #[test]
    fn colour_bar_round_trips_through_metadata_and_draws_under_the_image() {
        let mut b = bar(BarScale::Symlog { linthresh: 0.01 }, -1.0, 2.0);
        let mut img = HdrImage::new(200, 10);
        b.record(&mut img);
        assert_eq!(ColourBar::of(&img), Some(b.clone()));
        b.extend = [false, true];
        b.record(&mut img);
        assert_eq!(img.meta("legend_extend"), Some("max"));
        assert_eq!(ColourBar::of(&img), Some(b.clone()));
        b.extend = [false; 2];
        let ty = Type::new(11.0);
        let out = with_colour_bar(&img, &b, ty).unwrap();
        let (gap, line) = (ty.gap(), ty.line());
        assert_eq!((out.width, out.height), (200, 10 + 5 * gap + 3 * line));
        // The bar's first row is the colour map from end to end; each drawn tick sits where
        // `position` puts its value, in the gap under the bar.
        let cmap = crate::model::colormap::Colormap::by_name("viridis").unwrap();
        let row = (10 + gap) as usize;
        assert_eq!(
            out.meta("legend_bar_rows"),
            Some(format!("{row} {}", row as u32 + line).as_str())
        );
        let c = cmap.linear_rgb(0.5 / 200.0);
        assert!((out.pixels[row * 200][0] as f64 - c[0]).abs() < 1e-6);
        let ticks = out.meta("legend_ticks").unwrap().to_string();
        assert!(ticks.split(' ').count() >= 4, "{ticks}");
        for t in ticks.split(' ') {
            let (v, x) = t.split_once('@').unwrap();
            let (v, x): (f64, u32) = (v.parse().unwrap(), x.parse().unwrap());
            assert_eq!(x, (b.position(v) * 199.0).round() as u32);
            let below = row + line as usize;
            assert_eq!(out.pixels[below * 200 + x as usize], [0.0, 0.0, 0.0, 1.0]);
            // The tick stops a gap above the labels: the row under it is the white band there.
            let after = below + gap as usize;
            assert_eq!(out.pixels[after * 200 + x as usize], [1.0; 4]);
        }
    }

    #[test]
    fn numbers_read_as_written_and_as_typeset() {
        assert_eq!(format_number(1.0 / 8.0), "0.125");
        assert_eq!(format_number(12.5), "12.5");
        assert_eq!(format_number(1.0 / 3.0), "0.3333");
        assert_eq!(format_number(2000.0), "2000");
        assert_eq!(format_number(2.5e-7), "2.5e-7");
        assert_eq!(format_number(-1.25e9), "-1.25e9");
        assert_eq!(typeset_number(-0.5), "−0.5");
        assert_eq!(typeset_number(2.5e-7), "2.5×10⁻⁷");
        assert_eq!(typeset_number(-1.25e9), "−1.25×10⁹");
        assert_eq!(typeset_number(1e-4), "10⁻⁴");
        assert_eq!(typeset_number(1e-3), "0.001");
    }

    /// The coverage of `text` drawn white on black at `px`, as a bitmap with its ink rows.
    fn ink(text: &str, px: f64) -> (HdrImage, Vec<u32>) {
        let ty = Type::new(px);
        let mut img = HdrImage::new(ty.width(text) + 4, ty.line() + 4);
        draw_text(&mut img, 2, 2, text, ty, [1.0; 4]);
        let w = img.width as usize;
        let rows = (0..img.height)
            .filter(|y| (0..w).any(|x| img.pixels[*y as usize * w + x][0] > 0.5))
            .collect();
        (img, rows)
    }

    #[test]
    fn glyph_height_scales_with_the_type_and_ink_stays_in_the_line_box() {
        let (_, small) = ink("H", 12.0);
        let (_, large) = ink("H", 96.0);
        let (hs, hl) = (small.len() as f64, large.len() as f64);
        // DejaVu Sans' cap height is 0.73 em.
        assert!((hs - 0.73 * 12.0).abs() <= 1.5, "{hs}");
        assert!((hl / hs - 8.0).abs() < 0.8, "{hl} / {hs}");
        for (text, px) in [("Hgjy°ν10⁻³", 12.0), ("Hgjy°ν10⁻³", 40.0)] {
            let ty = Type::new(px);
            let (img, rows) = ink(text, px);
            assert!(
                rows[0] >= 2 && *rows.last().unwrap() < 2 + ty.line(),
                "{rows:?}"
            );
            assert!(img.width <= ty.width(text) + 4);
        }
        // The figure's default size: 11 px at 300², 2.8 % of the shorter side at 4096 × 2048.
        assert_eq!(Type::for_figure(300, 300).px, 11.0);
        assert!((Type::for_figure(4096, 2048).px - 57.344).abs() < 1e-3);
    }

    #[test]
    fn greek_minus_degree_and_superscripts_have_their_own_glyphs() {
        for c in "ν°−µ⁻⁰¹²³⁴⁵⁶⁷⁸⁹×".chars() {
            assert_ne!(face().glyph_id(c).0, 0, "{c} is in the typeface");
        }
        let differs = |a: &str, b: &str| {
            let (x, _) = ink(a, 24.0);
            let (y, _) = ink(b, 24.0);
            x.width != y.width || x.pixels != y.pixels
        };
        assert!(differs("ν", "v"));
        assert!(differs("−", "-"));
        assert!(differs("°", "o"));
        assert!(differs("10⁻³", "10-3"));
        let (deg, rows) = ink("°", 24.0);
        assert!(!rows.is_empty() && deg.pixels.iter().any(|p| p[0] > 0.9));
        // Clipping: drawing off the edges is harmless.
        let mut img = HdrImage::new(8, 8);
        draw_text(&mut img, -5, 5, "xyz", Type::new(30.0), [1.0; 4]);
    }
}
