//! f64 CPU references for every tone-mapping operator in `shaders/tonemap/`, plus the sRGB
//! encoders, auto-exposure and a false-colour view of log10 luminance. The GPU passes are
//! compared against these. Conventions shared with the shaders: a pixel whose R, G, B or A is
//! NaN or infinite is missing: it stays out of every reduction and blur (normalised convolution)
//! and comes out as [0, 0, 0, 0]. Negative colour components are clamped to 0. Pixels of zero
//! luminance are black: they come out black and are left out of the log-luminance statistics
//! (instead of Reinhard's absolute delta, which would dominate an image whose values are near
//! 1e-30 and make the operators depend on the data's units). Colour is premultiplied; alpha
//! passes through, clamped to [0, 1].

mod local;

pub(crate) mod exact;

use local::{durand, reinhard_local, ReinhardLocal};
use rayon::prelude::*;

use super::params::{Gamut, Operator, ToneMapSettings};
use crate::error::{Error, Result};
use crate::model::colormap::decode_srgb_f32;
use crate::model::image::HdrImage;

const REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Narkowicz 2016 ACES fit coefficients (published values).
const ACES_A: f64 = 2.51;
const ACES_B: f64 = 0.03;
const ACES_C: f64 = 2.43;
const ACES_D: f64 = 0.59;
const ACES_E: f64 = 0.14;

/// Ward's ceiling loop stops when less than this fraction of the counts was trimmed (paper: 2.5 %).
const WARD_TOLERANCE: f64 = 0.025;
const WARD_MAX_ITERATIONS: u32 = 100;

/// Statistics of ln(L_w) over pixels whose exposed luminance is finite and > 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LogLuminanceStats {
    /// ln of the log-average luminance Lbar = exp(mean ln L_w).
    pub mean_log: f64,
    pub max_log: f64,
    pub min_log: f64,
    pub count: usize,
}

/// Scene luminance after exposure, for the operators that need it as a plane (the local
/// operators, Ward's histogram, the false-colour view).
struct Scene {
    width: usize,
    height: usize,
    /// Rec. 709 luminance; NaN where missing.
    lum: Vec<f64>,
}

impl Scene {
    fn new(img: &HdrImage, exposure_ev: f64) -> Scene {
        let gain = exposure_ev.exp2();
        Scene {
            width: img.width as usize,
            height: img.height as usize,
            lum: img.pixels.par_iter().map(|p| luminance(p, gain)).collect(),
        }
    }

    fn stats(&self) -> Option<LogLuminanceStats> {
        log_stats(&self.lum, |&l| l)
    }
}

/// A pixel's colour times `gain`, negative components clamped to 0; `None` where any of its
/// R, G, B, A is NaN or infinite (missing).
fn exposed(p: &[f32; 4], gain: f64) -> Option<[f64; 3]> {
    if p.iter().all(|v| v.is_finite()) {
        Some([0, 1, 2].map(|k| (p[k] as f64).max(0.0) * gain))
    } else {
        None
    }
}

/// Rec. 709 luminance of a colour.
fn luminance_of(c: [f64; 3]) -> f64 {
    REC709[0] * c[0] + REC709[1] * c[1] + REC709[2] * c[2]
}

/// Rec. 709 luminance of a pixel after `gain`; NaN where it is missing.
fn luminance(p: &[f32; 4], gain: f64) -> f64 {
    exposed(p, gain).map_or(f64::NAN, luminance_of)
}

/// Pixels per task of [`log_stats`]: fixed, so that the sum is the same on any number of
/// threads.
const STATS_CHUNK: usize = 1 << 14;

/// Statistics of ln L over the finite positive luminances `lum` of `items` gives, without a
/// plane of logarithms: each fixed chunk sums its logarithms in runs of 64 and then pairwise,
/// and the chunks' sums are added pairwise ([`pairwise_sum`]'s error bound, the same sum on any
/// number of threads).
fn log_stats<T: Sync>(items: &[T], lum: impl Fn(&T) -> f64 + Sync) -> Option<LogLuminanceStats> {
    let parts: Vec<(f64, usize, f64, f64)> = items
        .par_chunks(STATS_CHUNK)
        .map(|chunk| {
            let mut runs = Vec::with_capacity(chunk.len().div_ceil(64));
            let (mut count, mut max, mut min) = (0, f64::NEG_INFINITY, f64::INFINITY);
            for run in chunk.chunks(64) {
                let mut sum = 0.0;
                for l in run.iter().map(&lum) {
                    if l.is_finite() && l > 0.0 {
                        let v = l.ln();
                        sum += v;
                        count += 1;
                        max = max.max(v);
                        min = min.min(v);
                    }
                }
                runs.push(sum);
            }
            (pairwise_sum(&runs), count, max, min)
        })
        .collect();
    let count: usize = parts.iter().map(|p| p.1).sum();
    if count == 0 {
        return None;
    }
    let sums: Vec<f64> = parts.iter().map(|p| p.0).collect();
    Some(LogLuminanceStats {
        mean_log: pairwise_sum(&sums) / count as f64,
        max_log: parts.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max),
        min_log: parts.iter().map(|p| p.3).fold(f64::INFINITY, f64::min),
        count,
    })
}

/// Pairwise summation: error grows as O(log n) ulps instead of O(n), so a mean over a
/// 100-megapixel image keeps full f64 precision.
fn pairwise_sum(values: &[f64]) -> f64 {
    if values.len() <= 64 {
        values.iter().sum()
    } else {
        let (a, b) = values.split_at(values.len() / 2);
        pairwise_sum(a) + pairwise_sum(b)
    }
}

/// Log-luminance statistics of an image after `exposure_ev`; `None` when no pixel has a finite
/// luminance > 0.
pub(crate) fn luminance_log_stats(img: &HdrImage, exposure_ev: f64) -> Option<LogLuminanceStats> {
    let gain = exposure_ev.exp2();
    log_stats(&img.pixels, |p| luminance(p, gain))
}

/// Tone-maps `img` on the CPU in f64. The result holds display-referred linear values in
/// [0, 1] (apply `HdrImage::to_srgb8` or `HdrImage::to_srgb16` for a display image); missing pixels are
/// [0, 0, 0, 0]. Extra channels and metadata are carried over.
pub fn tonemap_cpu(img: &HdrImage, s: &ToneMapSettings) -> Result<HdrImage> {
    tonemap_cpu_with(img, s, Filters::Accelerated)
}

/// How the local operators filter: as the GPU does, or by the definitions they accelerate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Filters {
    /// Durand's piecewise-linear grid, Reinhard's Gaussians on a pyramid (what the GPU runs).
    Accelerated,
    /// A brute-force bilateral filter and full-resolution Gaussians (`exact.rs`): slow, the
    /// yardstick the accelerations are measured against.
    Exact,
}

/// [`tonemap_cpu`] with the local operators' filters chosen; the global operators are the same
/// either way.
pub(crate) fn tonemap_cpu_with(
    img: &HdrImage,
    s: &ToneMapSettings,
    filters: Filters,
) -> Result<HdrImage> {
    s.validate()?;
    check_size(img)?;
    let gain = s.exposure_ev.exp2();
    let display = display_luminance(img, s.exposure_ev, &s.op, filters);
    let (saturate, encode) = (power(s.saturation), power(1.0 / s.gamma));
    let pixels = img
        .pixels
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let Some(colour) = exposed(p, gain) else {
                return [0.0; 4];
            };
            let lw = luminance_of(colour);
            let ld = display.at(i, lw);
            let mut out = [0.0f32; 4];
            let mut c = [0.0f64; 3];
            for k in 0..3 {
                c[k] = if lw > 0.0 && ld.is_finite() {
                    saturate(colour[k] / lw) * ld
                } else {
                    0.0
                } + s.offset;
            }
            let c = into_gamut(c, s.gamut);
            for k in 0..3 {
                out[k] = encode(c[k].clamp(0.0, 1.0)) as f32;
            }
            out[3] = p[3].clamp(0.0, 1.0);
            out
        })
        .collect();
    let mut result = HdrImage::from_pixels(img.width, img.height, pixels);
    result.extra_channels = img.extra_channels.clone();
    result.metadata = img.metadata.clone();
    result.set_meta("tonemap", s.op.name());
    result.set_meta("gamut", s.gamut.name());
    result.set_meta("tonemap.exposure_ev", format!("{}", s.exposure_ev));
    result.set_meta("transfer", "display-linear");
    result.set_meta(crate::tonemap::DISPLAY_REFERRED, "1");
    Ok(result)
}

/// x ↦ x^e, without the power where e is 1 (the defaults of saturation and gamma): x^1 is x
/// exactly, and libm's pow, whose error is under one ulp, returns x there too. Chosen once per
/// image: a branch on e inside the pixel loop is folded back into the power by the compiler.
fn power(e: f64) -> Box<dyn Fn(f64) -> f64 + Sync> {
    if e == 1.0 {
        Box::new(|x| x)
    } else {
        Box::new(move |x: f64| x.powf(e))
    }
}

/// A display colour with its largest channel above 1 scaled by 1 / that channel (`Gamut::Scale`,
/// hue and saturation kept), or left for the per-channel clamp (`Gamut::Clip`).
pub(crate) fn into_gamut(c: [f64; 3], gamut: Gamut) -> [f64; 3] {
    let largest = c[0].max(c[1]).max(c[2]);
    if gamut == Gamut::Scale && largest > 1.0 {
        c.map(|v| v / largest)
    } else {
        c
    }
}

fn check_size(img: &HdrImage) -> Result<()> {
    if img.pixels.len() != img.width as usize * img.height as usize {
        return Err(Error::invalid(
            "image",
            format!(
                "{} pixels do not fill {}x{}",
                img.pixels.len(),
                img.width,
                img.height
            ),
        ));
    }
    Ok(())
}

/// Display luminance L_d: a function of the pixel's own luminance for the global operators
/// (mapped in the final pass, no plane written), a plane for the local ones.
enum DisplayLuminance<'a> {
    Global(Box<dyn Fn(f64) -> f64 + Sync + 'a>),
    /// Per pixel, NaN where missing.
    Plane(Vec<f64>),
}

impl DisplayLuminance<'_> {
    /// L_d (may exceed 1 before the final clamp) of pixel `i`, present, of luminance `lw`.
    fn at(&self, i: usize, lw: f64) -> f64 {
        match self {
            DisplayLuminance::Global(f) if lw > 0.0 && lw.is_finite() => f(lw),
            DisplayLuminance::Global(_) => 0.0,
            DisplayLuminance::Plane(ld) => ld[i],
        }
    }
}

/// `op`'s display luminance for `img` after `exposure_ev`. Linear and ACES need no statistics;
/// the other global operators take them from the pixels, the local ones and Ward's histogram
/// from their luminance plane. Where no pixel has a positive luminance every present pixel is
/// black.
fn display_luminance<'a>(
    img: &HdrImage,
    exposure_ev: f64,
    op: &'a Operator,
    filters: Filters,
) -> DisplayLuminance<'a> {
    use DisplayLuminance::{Global, Plane};
    let black = || Global(Box::new(|_| 0.0));
    let with_stats = |f: &dyn Fn(LogLuminanceStats) -> DisplayLuminance<'a>| {
        luminance_log_stats(img, exposure_ev).map_or_else(black, f)
    };
    let with_scene = |f: &dyn Fn(&Scene, LogLuminanceStats) -> DisplayLuminance<'a>| {
        let scene = Scene::new(img, exposure_ev);
        scene.stats().map_or_else(black, |stats| f(&scene, stats))
    };
    match *op {
        Operator::Linear => Global(Box::new(|l| l.min(1.0))),
        Operator::Aces => Global(Box::new(aces)),
        Operator::Drago { bias, ld_max } => {
            with_stats(&|stats| Global(Box::new(move |l| drago(l, &stats, bias, ld_max))))
        }
        Operator::Reinhard { key, white } => with_stats(&|stats| {
            let white = white.unwrap_or_else(|| key * (stats.max_log - stats.mean_log).exp());
            Global(Box::new(move |l| {
                reinhard_global(key * (l.ln() - stats.mean_log).exp(), white)
            }))
        }),
        Operator::WardHistogram {
            ld_min,
            ld_max,
            bins,
        } => with_scene(&|scene, stats| {
            let ward = WardMapping::new(&scene.lum, &stats, ld_min, ld_max, bins);
            Global(Box::new(move |l| ward.map(l)))
        }),
        Operator::ReinhardLocal {
            key,
            alpha1,
            ratio,
            phi,
            epsilon,
            scales,
        } => {
            let params = ReinhardLocal {
                key,
                alpha1,
                ratio,
                phi,
                epsilon,
                scales,
            };
            with_scene(&|scene, stats| Plane(reinhard_local(scene, &stats, &params, filters)))
        }
        Operator::DurandBilateral {
            contrast,
            sigma_spatial,
            sigma_range,
        } => with_scene(&|scene, _| {
            Plane(durand(scene, contrast, sigma_spatial, sigma_range, filters))
        }),
    }
}

/// Drago 2003 eq. 4 on luminance normalised by the log-average (the paper's L_wa), with the
/// scene maximum mapping to ld_max / 100.
fn drago(lw: f64, stats: &LogLuminanceStats, bias: f64, ld_max: f64) -> f64 {
    let x = (lw.ln() - stats.mean_log).exp();
    let x_max = (stats.max_log - stats.mean_log).exp();
    let exponent = bias.ln() / 0.5f64.ln();
    let relative = (exponent * (lw.ln() - stats.max_log)).exp(); // (L_w / L_wmax)^exponent
    (ld_max * 0.01) / (x_max.ln_1p() / std::f64::consts::LN_10) * x.ln_1p()
        / (2.0 + 8.0 * relative).ln()
}

/// Reinhard 2002 eq. 4. Written with L / white / white so that a white near f32's limit does
/// not overflow when squared.
pub(crate) fn reinhard_global(l: f64, white: f64) -> f64 {
    l * (1.0 + l / white / white) / (1.0 + l)
}

/// Narkowicz's ACES fit; for x > 1 numerator and denominator are divided by x^2 so that a
/// luminance of 1e30 does not overflow in f32 (the shader uses the same form).
pub fn aces(x: f64) -> f64 {
    let y = if x > 1.0 {
        let r = 1.0 / x;
        (ACES_A + ACES_B * r) / (ACES_C + ACES_D * r + ACES_E * r * r)
    } else {
        x * (ACES_A * x + ACES_B) / (x * (ACES_C * x + ACES_D) + ACES_E)
    };
    y.clamp(0.0, 1.0)
}

/// Ward Larson 1997 histogram adjustment with the linear ceiling: the cumulative distribution
/// of ln luminance, its bins trimmed to T * bin_width / ln(Ld_max / Ld_min) until under 2.5 % of
/// the counts are trimmed, maps ln L_w onto ln Ld_min .. ln Ld_max. When the scene's range fits
/// the display's, the paper's fallback is linear scaling, here with the scene maximum at
/// Ld_max. When trimming drives the total under the tolerance (the paper's failure case, e.g. a
/// lone outlier decades above the rest) the last trimmed histogram is used instead.
struct WardMapping {
    min_log: f64,
    max_log: f64,
    bin_width: f64,
    bins: usize,
    /// Cumulative counts at each bin's lower edge, normalised to 1 at the top; empty = linear.
    cdf: Vec<f64>,
    ld_min: f64,
    ld_max: f64,
}

impl WardMapping {
    fn new(lum: &[f64], stats: &LogLuminanceStats, ld_min: f64, ld_max: f64, bins: u32) -> Self {
        let display_range = (ld_max / ld_min).ln();
        let mut mapping = WardMapping {
            min_log: stats.min_log,
            max_log: stats.max_log,
            bin_width: (stats.max_log - stats.min_log) / bins as f64,
            bins: bins as usize,
            cdf: Vec::new(),
            ld_min,
            ld_max,
        };
        if stats.max_log - stats.min_log <= display_range {
            return mapping;
        }
        let mut counts = vec![0.0f64; bins as usize];
        for &l in lum {
            if l.is_finite() && l > 0.0 {
                counts[mapping.bin_of(l.ln()).0] += 1.0;
            }
        }
        let tolerance = WARD_TOLERANCE * stats.count as f64;
        for _ in 0..WARD_MAX_ITERATIONS {
            let total: f64 = counts.iter().sum();
            if total < tolerance {
                // Ward returns failure here and falls back to a linear map, which turns a
                // scene with one outlier 30 decades up black; the trimmed histogram is still
                // a monotonic map under the ceiling, so use it.
                break;
            }
            let ceiling = total * mapping.bin_width / display_range;
            let mut trimmed = 0.0;
            for c in counts.iter_mut() {
                if *c > ceiling {
                    trimmed += *c - ceiling;
                    *c = ceiling;
                }
            }
            if trimmed <= tolerance {
                break;
            }
        }
        let total: f64 = counts.iter().sum();
        let mut running = 0.0;
        mapping.cdf = std::iter::once(0.0)
            .chain(counts.iter().map(|c| {
                running += c;
                running / total
            }))
            .collect();
        mapping
    }

    /// Bin index and position within it for a ln luminance.
    fn bin_of(&self, log_l: f64) -> (usize, f64) {
        let t = ((log_l - self.min_log) / self.bin_width).max(0.0);
        let index = t.floor().min(self.bins as f64 - 1.0);
        (index as usize, (t - index).clamp(0.0, 1.0))
    }

    fn map(&self, lw: f64) -> f64 {
        if self.cdf.is_empty() {
            return (lw.ln() - self.max_log).exp();
        }
        let (bin, frac) = self.bin_of(lw.ln());
        let p = self.cdf[bin] + frac * (self.cdf[bin + 1] - self.cdf[bin]);
        (self.ld_min.ln() + (self.ld_max / self.ld_min).ln() * p).exp() / self.ld_max
    }
}

/// Largest exposure magnitude the helpers return, inside what [`ToneMapSettings`] accepts.
const MAX_AUTO_EV: f64 = 200.0;

/// Exposure in stops that maps the log-average luminance to `key` (0 for an image with no
/// positive luminance).
pub fn auto_exposure_key(img: &HdrImage, key: f64) -> Result<f64> {
    if !(key > 0.0 && key.is_finite()) {
        return Err(Error::invalid(
            "auto_exposure.key",
            format!("{key} must be a finite number > 0 (photographic middle grey: 0.18)"),
        ));
    }
    Ok(match luminance_log_stats(img, 0.0) {
        Some(stats) => {
            ((key.ln() - stats.mean_log) / std::f64::consts::LN_2).clamp(-MAX_AUTO_EV, MAX_AUTO_EV)
        }
        None => 0.0,
    })
}

/// Exposure in stops that maps the `percentile` (0..=100, nearest rank over pixels of positive
/// luminance) luminance to `target`.
pub fn auto_exposure_percentile(img: &HdrImage, percentile: f64, target: f64) -> Result<f64> {
    if !(0.0..=100.0).contains(&percentile) {
        return Err(Error::invalid(
            "auto_exposure.percentile",
            format!("{percentile} is outside [0, 100]"),
        ));
    }
    if !(target > 0.0 && target.is_finite()) {
        return Err(Error::invalid(
            "auto_exposure.target",
            format!("{target} must be a finite number > 0"),
        ));
    }
    let scene = Scene::new(img, 0.0);
    let mut logs: Vec<f64> = scene
        .lum
        .iter()
        .filter(|l| l.is_finite() && **l > 0.0)
        .map(|l| l.ln())
        .collect();
    if logs.is_empty() {
        return Ok(0.0);
    }
    logs.sort_by(f64::total_cmp);
    let rank = ((percentile / 100.0) * logs.len() as f64).ceil().max(1.0) as usize - 1;
    let at = logs[rank.min(logs.len() - 1)];
    Ok(((target.ln() - at) / std::f64::consts::LN_2).clamp(-MAX_AUTO_EV, MAX_AUTO_EV))
}

/// Linear RGB of the turbo colour map (colorgrad gives sRGB-encoded colours) at t in [0, 1].
pub(crate) fn turbo_linear(t: f64) -> [f32; 3] {
    use colorgrad::Gradient;
    let c = colorgrad::preset::turbo().at(t.clamp(0.0, 1.0) as f32);
    // colorgrad's turbo gives 8-bit codes k / 255 (its map steps between them), which the
    // table of decode_srgb_f32 serves.
    [c.r, c.g, c.b].map(decode_srgb_f32)
}

/// Colour of missing pixels in the false-colour view: mid grey, outside the turbo map's hues.
const MISSING_GREY: f32 = 0.2;

/// Height in pixels of the false-colour legend strip: a tenth of the image, 4 to 24 pixels,
/// none below 16 pixels of image height.
pub(crate) fn legend_height(image_height: u32) -> u32 {
    if image_height >= 16 {
        (image_height / 10).clamp(4, 24)
    } else {
        0
    }
}

/// 256 linear RGBA samples of turbo for `shaders/tonemap/false_colour.wgsl`'s `lut` binding.
pub(crate) fn turbo_lut() -> Vec<[f32; 4]> {
    (0..256)
        .map(|i| {
            let [r, g, b] = turbo_linear(i as f64 / 255.0);
            [r, g, b, 1.0]
        })
        .collect()
}

/// The whole decades (low, high) of log10 luminance the false-colour view spans: `decades` when
/// given (checked), else those spanning the image's positive luminance after `exposure_ev`.
/// Shared by [`false_colour_log10`] and the GPU false-colour pass.
pub(crate) fn false_colour_decades(
    img: &HdrImage,
    exposure_ev: f64,
    decades: Option<(f64, f64)>,
) -> Result<(f64, f64)> {
    match decades {
        Some(_) => decade_range(None, decades),
        None => decade_range(luminance_log_stats(img, exposure_ev), None),
    }
}

/// [`false_colour_decades`] with the image's statistics already taken.
fn decade_range(
    stats: Option<LogLuminanceStats>,
    decades: Option<(f64, f64)>,
) -> Result<(f64, f64)> {
    let range = match decades {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && hi > lo && hi - lo <= 100.0 => {
            (lo, hi)
        }
        Some((lo, hi)) => {
            return Err(Error::invalid(
                "false_colour.decades",
                format!("({lo}, {hi}) must be finite with low < high <= low + 100"),
            ))
        }
        None => match stats {
            Some(s) => {
                // The slack keeps f32(0.01) from opening the decade below.
                let lo = (s.min_log / std::f64::consts::LN_10 + 1e-6).floor();
                let hi = (s.max_log / std::f64::consts::LN_10 - 1e-6).ceil();
                (lo, hi.max(lo + 1.0))
            }
            None => (0.0, 1.0),
        },
    };
    Ok(range)
}

/// The false-colour view's colour bar: turbo over luminance 10^low to 10^high on a log10 scale,
/// so `save_png(view, path, #{legend: true})` labels its decades.
pub(crate) fn false_colour_bar(low: f64, high: f64) -> crate::model::text::ColourBar {
    crate::model::text::ColourBar {
        colormap: "turbo".into(),
        scale: crate::model::text::BarScale::Log10,
        lo: 10f64.powf(low),
        hi: 10f64.powf(high),
        units: "luminance (image units)".into(),
        label: String::new(),
        extend: [false; 2],
    }
}

/// False-colour view of log10 luminance (after `exposure_ev`) through turbo, over whole decades
/// `decades` = (low, high) or, by default, those spanning the image. Black pixels take the low
/// end, missing ones a neutral grey. When the image is at least 16 pixels tall a legend strip is
/// drawn along the bottom: the colour bar with a tick (black over white) at every decade, the
/// range being recorded in the metadata keys `false_colour.log10_min` / `_max`. Display-linear.
pub fn false_colour_log10(
    img: &HdrImage,
    exposure_ev: f64,
    decades: Option<(f64, f64)>,
) -> Result<HdrImage> {
    check_size(img)?;
    crate::tonemap::check_ev("exposure_ev", exposure_ev)?;
    let stats = if decades.is_none() {
        luminance_log_stats(img, exposure_ev)
    } else {
        None
    };
    let (low, high) = decade_range(stats, decades)?;
    let (width, height) = (img.width as usize, img.height as usize);
    let gain = exposure_ev.exp2();
    let mut pixels: Vec<[f32; 4]> = img
        .pixels
        .par_iter()
        .map(|p| {
            let l = luminance(p, gain);
            if l.is_nan() {
                [MISSING_GREY, MISSING_GREY, MISSING_GREY, 1.0]
            } else {
                let t = if l > 0.0 {
                    (l.log10() - low) / (high - low)
                } else {
                    0.0
                };
                let [r, g, b] = turbo_linear(t);
                [r, g, b, 1.0]
            }
        })
        .collect();
    let strip = legend_height(img.height) as usize;
    if strip > 0 && width >= 2 {
        let tick_x: Vec<usize> = (low.ceil() as i64..=high.floor() as i64)
            .map(|d| (((d as f64 - low) / (high - low)) * (width - 1) as f64).round() as usize)
            .collect();
        for y in height - strip..height {
            let in_upper_half = y < height - strip / 2;
            for x in 0..width {
                let [r, g, b] = turbo_linear(x as f64 / (width - 1) as f64);
                let mut px = [r, g, b, 1.0];
                if tick_x.contains(&x) {
                    let v = if in_upper_half { 0.0 } else { 1.0 };
                    px = [v, v, v, 1.0];
                }
                pixels[y * width + x] = px;
            }
        }
    }
    let mut out = HdrImage::from_pixels(img.width, img.height, pixels);
    out.metadata = img.metadata.clone();
    out.set_meta("false_colour.log10_min", format!("{low}"));
    out.set_meta("false_colour.log10_max", format!("{high}"));
    false_colour_bar(low, high).record(&mut out);
    out.set_meta("transfer", "display-linear");
    out.set_meta(crate::tonemap::DISPLAY_REFERRED, "1");
    Ok(out)
}

#[cfg(test)]
mod tests;
