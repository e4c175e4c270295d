//! From a captured HDR image to what the TUI shows and saves: channel choice, exposure, the
//! tone-mapping operator with its main parameter, false colour, area-averaged downsampling to the
//! terminal's pixel size, and the saved view (EXR of the exposed scene-referred image plus the
//! display PNG). Every step works on the HDR image the script produced: changing exposure or
//! operator never re-runs the script. Tone mapping uses the f64 CPU operators of
//! [`crate::tonemap::cpu`] on the preview-sized image (a few milliseconds) and on the full image
//! when saving.

use crate::error::{Error, Result};
use crate::model::image::rec709_luminance;
use crate::model::HdrImage;
use crate::tonemap::cpu::{false_colour_log10, tonemap_cpu};
use crate::tonemap::{Operator, ToneMapSettings, DISPLAY_REFERRED};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The display operators the `o` key cycles through: the plain exposure view (scene × 2^EV,
/// clipped, as `save_png(image, path, ev)`), then every tone-mapping operator of
/// [`Operator::NAMES`] (a test holds the two lists to the same operators), global ones first.
pub(crate) const VIEW_OPERATORS: [&str; 8] = [
    "exposure",
    "linear",
    "reinhard",
    "drago",
    "ward",
    "aces",
    "reinhard-local",
    "durand",
];

/// The index of the display operator `name` in [`VIEW_OPERATORS`].
pub(crate) fn view_operator(name: &str) -> Option<usize> {
    VIEW_OPERATORS.iter().position(|op| *op == name)
}

/// The main parameter of each entry of [`VIEW_OPERATORS`]: (name, default, step, min, max), the
/// default being the operator's own; `None` where the operator has none worth a key.
pub(crate) fn main_parameter(op: &str) -> Option<(&'static str, f64, f64, f64, f64)> {
    let (name, step, lo, hi) = match op {
        "reinhard" | "reinhard-local" => ("key", 0.03, 0.01, 1.0),
        "drago" => ("bias", 0.05, 0.05, 1.0),
        "ward" => ("ld_max", 20.0, 10.0, 1000.0),
        "durand" => ("contrast", 1.0, 2.0, 50.0),
        _ => return None,
    };
    let default = Operator::parse(op, &[]).ok()?.param(name)?;
    Some((name, default, step, lo, hi))
}

/// Which part of the image is shown: colour, one channel as grey, luminance, or an extra
/// channel the image carries (a surface's data value or fringe intensity).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Channel {
    Rgb,
    Red,
    Green,
    Blue,
    Alpha,
    Luminance,
    Extra(String),
}

impl Channel {
    pub(crate) fn label(&self) -> String {
        match self {
            Channel::Rgb => "RGB".into(),
            Channel::Red => "R".into(),
            Channel::Green => "G".into(),
            Channel::Blue => "B".into(),
            Channel::Alpha => "A".into(),
            Channel::Luminance => "Y".into(),
            Channel::Extra(name) => name.clone(),
        }
    }

    /// Every channel `img` offers, in cycling order.
    pub(crate) fn all(img: Option<&HdrImage>) -> Vec<Channel> {
        let mut v = vec![
            Channel::Rgb,
            Channel::Red,
            Channel::Green,
            Channel::Blue,
            Channel::Alpha,
            Channel::Luminance,
        ];
        if let Some(img) = img {
            v.extend(
                img.extra_channels
                    .iter()
                    .map(|(n, _)| Channel::Extra(n.clone())),
            );
        }
        v
    }
}

/// How the HDR image is turned into a display image.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ViewSettings {
    pub exposure_ev: f64,
    /// Index into [`VIEW_OPERATORS`].
    pub operator: usize,
    /// The operator's main parameter ([`main_parameter`]); `None` keeps its default.
    pub op_param: Option<f64>,
    pub false_colour: bool,
    pub channel: Channel,
}

impl Default for ViewSettings {
    fn default() -> Self {
        ViewSettings {
            exposure_ev: 0.0,
            operator: 0,
            op_param: None,
            false_colour: false,
            channel: Channel::Rgb,
        }
    }
}

impl ViewSettings {
    pub(crate) fn operator_name(&self) -> &'static str {
        VIEW_OPERATORS[self.operator % VIEW_OPERATORS.len()]
    }

    /// The operator and its main parameter as one label, e.g. `reinhard key=0.18`.
    pub(crate) fn operator_label(&self) -> String {
        let name = self.operator_name();
        match main_parameter(name) {
            Some((p, default, ..)) => format!("{name} {p}={}", self.op_param.unwrap_or(default)),
            None => name.to_string(),
        }
    }

    /// Whether exposure leaves the picture as it is: under an operator that divides it out
    /// ([`Operator::divides_out_exposure`]). The false-colour view's decades are absolute
    /// luminance, so exposure moves its colours under any operator.
    pub(crate) fn picture_ignores_exposure(&self) -> bool {
        !self.false_colour
            && matches!(self.tonemap_settings(), Ok(Some(s)) if s.op.divides_out_exposure())
    }

    /// Tone-mapping settings for operators other than the plain exposure view.
    pub(crate) fn tonemap_settings(&self) -> Result<Option<ToneMapSettings>> {
        let name = self.operator_name();
        if name == "exposure" {
            return Ok(None);
        }
        let params: Vec<(&str, f64)> = match (main_parameter(name), self.op_param) {
            (Some((p, ..)), Some(v)) => vec![(p, v)],
            _ => Vec::new(),
        };
        let op = Operator::parse(name, &params)?;
        Ok(Some(ToneMapSettings {
            exposure_ev: self.exposure_ev,
            op,
            ..ToneMapSettings::default()
        }))
    }
}

/// The chosen channel as an image: colour as is, a single channel as grey (alpha kept).
pub(crate) fn select_channel(img: &HdrImage, channel: &Channel) -> Result<HdrImage> {
    let grey = |f: &dyn Fn(usize, [f32; 4]) -> f32| -> HdrImage {
        let pixels = img
            .pixels
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let v = f(i, *p);
                [v, v, v, 1.0]
            })
            .collect();
        let mut out = HdrImage::from_pixels(img.width, img.height, pixels);
        out.metadata = img.metadata.clone();
        out
    };
    Ok(match channel {
        Channel::Rgb => img.clone(),
        Channel::Red => grey(&|_, p| p[0]),
        Channel::Green => grey(&|_, p| p[1]),
        Channel::Blue => grey(&|_, p| p[2]),
        Channel::Alpha => grey(&|_, p| p[3]),
        Channel::Luminance => grey(&|_, p| rec709_luminance(p)),
        Channel::Extra(name) => {
            let (_, values) = img
                .extra_channels
                .iter()
                .find(|(n, _)| n == name)
                .ok_or_else(|| {
                    Error::invalid("channel", format!("the image has no channel {name:?}"))
                })?;
            grey(&|i, _| values[i])
        }
    })
}

/// Resampling to the largest size with the same aspect inside `max_w` × `max_h`: each output
/// pixel averages the source pixels its footprint touches (area averaging when shrinking,
/// nearest pixels when enlarging a quick low-resolution render). Missing (non-finite) values
/// are left out of each average; a footprint with none left stays NaN.
pub(crate) fn resample(img: &HdrImage, max_w: u32, max_h: u32) -> HdrImage {
    let (w, h) = fit_within(img.width, img.height, max_w, max_h);
    if (w, h) == (img.width, img.height) {
        return img.clone();
    }
    let (sx, sy) = (img.width as f64 / w as f64, img.height as f64 / h as f64);
    let mut pixels = vec![[0f32; 4]; w as usize * h as usize];
    pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let (y0, y1) = span(y as u32, sy, img.height);
            for (x, out) in row.iter_mut().enumerate() {
                let (x0, x1) = span(x as u32, sx, img.width);
                let mut sum = [0f64; 4];
                let mut count = [0u32; 4];
                for yy in y0..y1 {
                    for xx in x0..x1 {
                        let p = img.pixel(xx, yy);
                        for k in 0..4 {
                            if p[k].is_finite() {
                                sum[k] += p[k] as f64;
                                count[k] += 1;
                            }
                        }
                    }
                }
                *out = std::array::from_fn(|k| {
                    if count[k] > 0 {
                        (sum[k] / count[k] as f64) as f32
                    } else {
                        f32::NAN
                    }
                });
            }
        });
    let mut out = HdrImage::from_pixels(w, h, pixels);
    out.metadata = img.metadata.clone();
    out
}

/// `img` enlarged to `w` × `h` by repeating pixels: output pixel x shows source pixel
/// ⌊(x + ½) · width / w⌋ (likewise rows). Rows that repeat the one above are copied whole:
/// this runs on every key that changes an enlarged view, where `image`'s general resize cost
/// as much as the tone mapping it follows.
pub(crate) fn enlarge_nearest(img: &image::RgbImage, w: u32, h: u32) -> image::RgbImage {
    let raw = enlarge_nearest_raw(img.as_raw(), img.width(), img.height(), 3, w, h);
    image::RgbImage::from_raw(w, h, raw).expect("w * h pixels")
}

/// [`enlarge_nearest`] of a `width` × `height` raster of `channels` bytes a pixel (palette
/// indices for sixel: one).
pub(crate) fn enlarge_nearest_raw(
    src: &[u8],
    width: u32,
    height: u32,
    channels: usize,
    w: u32,
    h: u32,
) -> Vec<u8> {
    let source = |i: u32, n: u32, of: u32| {
        (((i as f64 + 0.5) * of as f64 / n as f64) as u32).min(of.saturating_sub(1))
    };
    let columns: Vec<usize> = (0..w).map(|x| source(x, w, width) as usize).collect();
    let (row_len, src_len) = (channels * w as usize, channels * width as usize);
    let mut out = vec![0u8; row_len * h as usize];
    let mut previous: Option<u32> = None;
    for y in 0..h {
        let sy = source(y, h, height);
        let at = y as usize * row_len;
        if previous == Some(sy) {
            out.copy_within(at - row_len..at, at);
            continue;
        }
        let row = &src[sy as usize * src_len..][..src_len];
        for (x, &sx) in columns.iter().enumerate() {
            let to = at + channels * x;
            out[to..to + channels].copy_from_slice(&row[channels * sx..channels * sx + channels]);
        }
        previous = Some(sy);
    }
    out
}

/// The source rows (or columns) [start, end) that output index `i` averages at scale `s`.
fn span(i: u32, s: f64, n: u32) -> (u32, u32) {
    let a = ((i as f64 * s).floor() as u32).min(n - 1);
    let b = (((i + 1) as f64 * s).ceil() as u32).clamp(a + 1, n);
    (a, b)
}

/// The largest size with the aspect of `w` × `h` inside `max_w` × `max_h`, at least 1 × 1.
pub(crate) fn fit_within(w: u32, h: u32, max_w: u32, max_h: u32) -> (u32, u32) {
    if w == 0 || h == 0 {
        return (w, h);
    }
    let scale = (max_w as f64 / w as f64).min(max_h as f64 / h as f64);
    (
        ((w as f64 * scale).round() as u32).max(1),
        ((h as f64 * scale).round() as u32).max(1),
    )
}

/// The display-referred linear image (values in [0, 1]) of `hdr` under `view`.
pub(crate) fn display_image(hdr: &HdrImage, view: &ViewSettings) -> Result<HdrImage> {
    let img = select_channel(hdr, &view.channel)?;
    let mut out = if view.false_colour {
        false_colour_log10(&img, view.exposure_ev, None)?
    } else if let Some(settings) = view.tonemap_settings()? {
        tonemap_cpu(&img, &settings)?
    } else {
        let mut e = crate::tonemap::exposure(&img, view.exposure_ev)?;
        for p in &mut e.pixels {
            for c in p.iter_mut() {
                // Missing values show as black, like the PNG writer's view.
                *c = if c.is_finite() {
                    c.clamp(0.0, 1.0)
                } else {
                    0.0
                };
            }
        }
        e.metadata.retain(|(k, _)| k != "exposure_ev");
        e
    };
    out.set_meta(DISPLAY_REFERRED, "1");
    out.set_meta("tui.view", describe(view));
    Ok(out)
}

/// One line naming every view setting, stored in saved files.
pub(crate) fn describe(view: &ViewSettings) -> String {
    format!(
        "exposure {:+} EV, {}, channel {}{}",
        view.exposure_ev,
        view.operator_label(),
        view.channel.label(),
        if view.false_colour {
            ", false colour"
        } else {
            ""
        }
    )
}

/// Saves the current view at full resolution into `out_dir`: `<stem>_view<NNN>.exr`, the
/// chosen channel exposed by 2^EV (scene-referred, linear), and `<stem>_view<NNN>.png`, the
/// display image. The number is the first one free. Both are written atomically.
pub(crate) fn save_view(
    hdr: &HdrImage,
    view: &ViewSettings,
    out_dir: &Path,
    stem: &str,
) -> Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let (exr, png) = (1..10_000)
        .map(|i| {
            (
                out_dir.join(format!("{stem}_view{i:03}.exr")),
                out_dir.join(format!("{stem}_view{i:03}.png")),
            )
        })
        .find(|(e, p)| !e.exists() && !p.exists())
        .ok_or_else(|| Error::invalid("save", format!("{} holds 9999 views", out_dir.display())))?;
    let mut scene =
        crate::tonemap::exposure(&select_channel(hdr, &view.channel)?, view.exposure_ev)?;
    scene.set_meta("tui.view", describe(view));
    crate::io::exr::write_exr(&scene, &exr)?;
    crate::io::png::write_display_png(&display_image(hdr, view)?, &png, false)?;
    Ok((exr, png))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: u32, h: u32) -> HdrImage {
        let pixels = (0..w * h)
            .map(|i| {
                let v = (i + 1) as f32 / 8.0;
                [v, 2.0 * v, 0.5 * v, 1.0]
            })
            .collect();
        HdrImage::from_pixels(w, h, pixels)
    }

    #[test]
    fn the_default_view_is_the_picture_inline_previews_print() {
        // `hdrvis run --preview` prints scene-referred images without this module (the io
        // layer cannot tone-map): the 0 EV view must be the same 8-bit picture.
        let values = [0.0, 0.18, 0.7, 1.0, 3.0, -0.5, f32::NAN, f32::INFINITY];
        let pixels = values.iter().map(|&v| [v, v * 0.5, 1.0 - v, 0.3]).collect();
        let img = HdrImage::from_pixels(4, 2, pixels);
        let shown = display_image(&img, &ViewSettings::default()).unwrap();
        assert_eq!(shown.to_srgb8(), img.to_srgb8());
    }

    #[test]
    fn enlarging_repeats_the_nearest_source_pixel() {
        let src = image::RgbImage::from_fn(3, 2, |x, y| image::Rgb([x as u8, y as u8, 7]));
        let big = enlarge_nearest(&src, 5, 5);
        assert_eq!(big.dimensions(), (5, 5));
        // Columns 0..5 show source columns 0, 0, 1, 2, 2; rows 0..5 source rows 0, 0, 1, 1, 1.
        let (columns, rows) = ([0, 0, 1, 2, 2], [0, 0, 1, 1, 1]);
        for (x, y, p) in big.enumerate_pixels() {
            assert_eq!(
                p.0,
                [columns[x as usize], rows[y as usize], 7],
                "({x}, {y})"
            );
        }
        assert_eq!(enlarge_nearest(&src, 3, 2), src);
    }

    #[test]
    fn resampling_averages_blocks_and_skips_missing_values() {
        let mut img = ramp(4, 2);
        img.pixels[1][0] = f32::NAN;
        let d = resample(&img, 2, 1);
        assert_eq!((d.width, d.height), (2, 1));
        // Block 0: pixels 0, 1, 4, 5 (values (i+1)/8 for R; pixel 1's R missing).
        let expect_r = (1.0 + 5.0 + 6.0) / 3.0 / 8.0;
        assert!((d.pixels[0][0] - expect_r).abs() < 1e-6);
        let expect_g = 2.0 * (1.0 + 2.0 + 5.0 + 6.0) / 4.0 / 8.0;
        assert!((d.pixels[0][1] - expect_g).abs() < 1e-6);
        assert_eq!(fit_within(640, 480, 100, 100), (100, 75));
        assert_eq!(fit_within(10, 10, 100, 50), (50, 50));
        let up = resample(&ramp(2, 1), 4, 2);
        assert_eq!((up.width, up.height), (4, 2));
        assert_eq!(up.pixels[1][0], 1.0 / 8.0);
        assert_eq!(up.pixels[6][0], 2.0 / 8.0);
    }

    #[test]
    fn exposure_view_doubles_per_stop_and_clips() {
        let img = ramp(4, 2);
        let mut view = ViewSettings::default();
        let a = display_image(&img, &view).unwrap();
        view.exposure_ev = 1.0;
        let b = display_image(&img, &view).unwrap();
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            for k in 0..3 {
                assert_eq!(q[k], (2.0 * p[k]).min(1.0));
            }
        }
        assert!(b
            .pixels
            .iter()
            .all(|p| p.iter().all(|v| (0.0..=1.0).contains(v))));
    }

    #[test]
    fn channels_and_operators_select_what_they_name() {
        let mut img = ramp(2, 2);
        img.extra_channels
            .push(("uz".into(), vec![1.0, 2.0, 3.0, 4.0]));
        let g = select_channel(&img, &Channel::Green).unwrap();
        assert_eq!(g.pixels[3], [1.0, 1.0, 1.0, 1.0]);
        let uz = select_channel(&img, &Channel::Extra("uz".into())).unwrap();
        assert_eq!(uz.pixels[2][0], 3.0);
        assert!(select_channel(&img, &Channel::Extra("nope".into())).is_err());
        assert_eq!(Channel::all(Some(&img)).len(), 7);

        let mut view = ViewSettings {
            operator: 2,
            ..ViewSettings::default()
        };
        assert_eq!(view.operator_label(), "reinhard key=0.18");
        view.op_param = Some(0.36);
        let s = view.tonemap_settings().unwrap().unwrap();
        assert_eq!(
            s.op,
            Operator::Reinhard {
                key: 0.36,
                white: None
            }
        );
        // The TUI's display of a tone-mapped view is the CPU reference, exactly.
        let shown = display_image(&img, &view).unwrap();
        let reference = tonemap_cpu(&img, &s).unwrap();
        assert_eq!(shown.pixels, reference.pixels);
    }

    #[test]
    fn saved_view_holds_the_exposed_master_and_the_display_png() {
        let dir = tempfile::tempdir().unwrap();
        let img = ramp(4, 2);
        let view = ViewSettings {
            exposure_ev: 1.0,
            ..ViewSettings::default()
        };
        let (exr, png) = save_view(&img, &view, dir.path(), "t").unwrap();
        assert!(exr.ends_with("t_view001.exr") && png.ends_with("t_view001.png"));
        let back = crate::io::exr::read_exr(&exr).unwrap();
        for (p, q) in img.pixels.iter().zip(&back.pixels) {
            assert_eq!(q[0], 2.0 * p[0]);
        }
        let (exr2, _) = save_view(&img, &view, dir.path(), "t").unwrap();
        assert!(exr2.ends_with("t_view002.exr"));
        let decoded = image::open(&png).unwrap().to_rgb8();
        assert_eq!(decoded.dimensions(), (4, 2));
        // Pixel 0: R = 2 * 1/8 = 0.25 linear -> sRGB 137.
        assert_eq!(
            decoded.get_pixel(0, 0)[0],
            crate::model::colormap::encode_srgb8(0.25)
        );
    }

    #[test]
    fn the_view_operators_are_the_tone_mapping_operators_with_their_defaults() {
        let mut ops: Vec<&str> = VIEW_OPERATORS[1..].to_vec();
        ops.sort();
        let mut known = Operator::NAMES.to_vec();
        known.sort();
        assert_eq!(ops, known);
        assert_eq!(main_parameter("reinhard").unwrap().1, 0.18);
        assert_eq!(main_parameter("drago").unwrap().1, 0.85);
        assert_eq!(main_parameter("ward").unwrap().1, 100.0);
        assert_eq!(main_parameter("durand").unwrap().1, 5.0);
        for op in &VIEW_OPERATORS[1..] {
            if let Some((name, default, _, lo, hi)) = main_parameter(op) {
                assert!((lo..=hi).contains(&default), "{op}.{name}");
            }
        }
    }
}
