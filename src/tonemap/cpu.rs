//! f64 CPU references for every tone-mapping operator in `shaders/tonemap/`, plus the sRGB
//! encoders, auto-exposure and a false-colour view of log10 luminance. The GPU passes are
//! compared against these. Conventions shared with the shaders: a pixel whose R, G, B or A is
//! NaN or infinite is missing: it stays out of every reduction and blur (normalised convolution)
//! and comes out as [0, 0, 0, 0]. Negative colour components are clamped to 0. Pixels of zero
//! luminance are black: they come out black and are left out of the log-luminance statistics
//! (instead of Reinhard's absolute delta, which would dominate an image whose values are near
//! 1e-30 and make the operators depend on the data's units). Colour is premultiplied; alpha
//! passes through, clamped to [0, 1].

use rayon::prelude::*;

use super::params::{
    blur_sigma, gaussian_radius, grid_sigma, reinhard_level, DurandGrid, Gamut, Operator,
    ToneMapSettings, DURAND_MIN_LOG_WEIGHT,
};
use crate::error::{Error, Result};
use crate::model::colormap::srgb_to_linear;
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

/// Scene colour after exposure, with missing pixels as `None`.
struct Scene {
    width: usize,
    height: usize,
    colour: Vec<Option<[f64; 3]>>,
    /// Rec. 709 luminance; NaN where missing.
    lum: Vec<f64>,
}

impl Scene {
    fn new(img: &HdrImage, exposure_ev: f64) -> Scene {
        let gain = exposure_ev.exp2();
        let colour: Vec<Option<[f64; 3]>> = img
            .pixels
            .iter()
            .map(|p| {
                if p.iter().all(|v| v.is_finite()) {
                    Some([0, 1, 2].map(|k| (p[k] as f64).max(0.0) * gain))
                } else {
                    None
                }
            })
            .collect();
        let lum = colour
            .iter()
            .map(|c| match c {
                Some(c) => REC709[0] * c[0] + REC709[1] * c[1] + REC709[2] * c[2],
                None => f64::NAN,
            })
            .collect();
        Scene {
            width: img.width as usize,
            height: img.height as usize,
            colour,
            lum,
        }
    }

    fn stats(&self) -> Option<LogLuminanceStats> {
        log_stats(&self.lum)
    }
}

fn log_stats(lum: &[f64]) -> Option<LogLuminanceStats> {
    let logs: Vec<f64> = lum
        .iter()
        .filter(|l| l.is_finite() && **l > 0.0)
        .map(|l| l.ln())
        .collect();
    if logs.is_empty() {
        return None;
    }
    let max_log = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min_log = logs.iter().copied().fold(f64::INFINITY, f64::min);
    Some(LogLuminanceStats {
        mean_log: pairwise_sum(&logs) / logs.len() as f64,
        max_log,
        min_log,
        count: logs.len(),
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
    Scene::new(img, exposure_ev).stats()
}

/// Tone-maps `img` on the CPU in f64. The result holds display-referred linear values in
/// [0, 1] (apply `HdrImage::to_srgb8` or `HdrImage::to_srgb16` for a display image); missing pixels are
/// [0, 0, 0, 0]. Extra channels and metadata are carried over.
pub fn tonemap_cpu(img: &HdrImage, s: &ToneMapSettings) -> Result<HdrImage> {
    s.validate()?;
    check_size(img)?;
    let scene = Scene::new(img, s.exposure_ev);
    let display_lum = display_luminance(&scene, &s.op);
    let inv_gamma = 1.0 / s.gamma;
    let pixels = img
        .pixels
        .iter()
        .zip(&scene.colour)
        .zip(scene.lum.iter().zip(&display_lum))
        .map(|((p, colour), (&lw, &ld))| {
            let Some(colour) = colour else {
                return [0.0; 4];
            };
            let mut out = [0.0f32; 4];
            let mut c = [0.0f64; 3];
            for k in 0..3 {
                c[k] = if lw > 0.0 && ld.is_finite() {
                    (colour[k] / lw).powf(s.saturation) * ld
                } else {
                    0.0
                } + s.offset;
            }
            let c = into_gamut(c, s.gamut);
            for k in 0..3 {
                out[k] = c[k].clamp(0.0, 1.0).powf(inv_gamma) as f32;
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
    result.set_meta("transfer", "display-linear");
    Ok(result)
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

/// Display luminance L_d per pixel (NaN where missing; may exceed 1 before the final clamp).
fn display_luminance(scene: &Scene, op: &Operator) -> Vec<f64> {
    let Some(stats) = scene.stats() else {
        // Nothing positive: every valid pixel is black.
        return scene
            .lum
            .iter()
            .map(|l| if l.is_nan() { *l } else { 0.0 })
            .collect();
    };
    let global = |f: &dyn Fn(f64) -> f64| -> Vec<f64> {
        scene
            .lum
            .iter()
            .map(|&l| {
                if l.is_nan() {
                    l
                } else if l > 0.0 && l.is_finite() {
                    f(l)
                } else {
                    0.0
                }
            })
            .collect()
    };
    match *op {
        Operator::Linear => global(&|l| l.min(1.0)),
        Operator::Drago { bias, ld_max } => global(&|l| drago(l, &stats, bias, ld_max)),
        Operator::Reinhard { key, white } => {
            let white = white.unwrap_or_else(|| key * (stats.max_log - stats.mean_log).exp());
            global(&|l| reinhard_global(key * (l.ln() - stats.mean_log).exp(), white))
        }
        Operator::WardHistogram {
            ld_min,
            ld_max,
            bins,
        } => {
            let ward = WardMapping::new(&scene.lum, &stats, ld_min, ld_max, bins);
            global(&|l| ward.map(l))
        }
        Operator::Aces => global(&aces),
        Operator::ReinhardLocal {
            key,
            alpha1,
            ratio,
            phi,
            epsilon,
            scales,
        } => reinhard_local(scene, &stats, key, alpha1, ratio, phi, epsilon, scales),
        Operator::DurandBilateral {
            contrast,
            sigma_spatial,
            sigma_range,
        } => durand(scene, contrast, sigma_spatial, sigma_range),
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

/// Reinhard's Gaussians by normalised convolution, sum(w L m) / sum(w m) with m = 0 at missing
/// pixels and outside the image, on a pyramid of (L m, m) pairs: level k has cells of 2^k
/// pixels, each the mean of four cells of level k - 1. Scale i's Gaussian (sigma_i pixels) is
/// blurred separably on level [`reinhard_level`] with [`grid_sigma`] cells and read back
/// bilinearly (level 0: the image itself, exactly the full-resolution blur). Returns V_i per
/// pixel for i in 0..=scales.
fn reinhard_blurs(
    scaled: &[f64],
    mask: &[f64],
    width: usize,
    height: usize,
    sigmas: &[f64],
) -> Vec<Vec<f64>> {
    let levels: Vec<u32> = sigmas.iter().map(|&s| reinhard_level(s)).collect();
    let deepest = levels.iter().copied().max().unwrap_or(0);
    let mut pyramid: Vec<(usize, usize, Vec<[f64; 2]>)> = vec![(
        width,
        height,
        scaled
            .iter()
            .zip(mask)
            .map(|(v, m)| if *m > 0.0 { [v * m, *m] } else { [0.0, 0.0] })
            .collect(),
    )];
    for _ in 0..deepest {
        let (pw, ph, prev) = pyramid.last().expect("level 0");
        let (w, h) = (pw.div_ceil(2), ph.div_ceil(2));
        let next = (0..w * h)
            .map(|c| {
                let (cx, cy) = (c % w, c / w);
                let mut acc = [0.0, 0.0];
                for (sx, sy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (x, y) = (2 * cx + sx, 2 * cy + sy);
                    if x < *pw && y < *ph {
                        let v = prev[y * pw + x];
                        acc[0] += 0.25 * v[0];
                        acc[1] += 0.25 * v[1];
                    }
                }
                acc
            })
            .collect();
        pyramid.push((w, h, next));
    }
    sigmas
        .par_iter()
        .zip(&levels)
        .map(|(&sigma, &k)| {
            let (w, h, plane) = &pyramid[k as usize];
            let cell = 1u32 << k;
            let sigma_cells = grid_sigma(sigma, cell);
            let radius = gaussian_radius(sigma_cells) as isize;
            let weights: Vec<f64> = (-radius..=radius)
                .map(|t| (-((t * t) as f64) / (2.0 * sigma_cells * sigma_cells)).exp())
                .collect();
            let blurred = blur_pairs(
                &blur_pairs(plane, *w, *h, &weights, true),
                *w,
                *h,
                &weights,
                false,
            );
            (0..width * height)
                .map(|p| {
                    let [num, den] =
                        bilinear_on(&blurred, cell, *w as u32, *h as u32, p % width, p / width);
                    if den > 0.0 {
                        num / den
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// Reinhard 2002 automatic dodging-and-burning: per pixel, the largest scale s_m at which the
/// centre-surround activity |V1 - V2| / (2^phi a / s^2 + V1) stays below epsilon (scanning up
/// from s = 1 and stopping at the first failure), then L_d = L / (1 + V1(s_m)).
#[allow(clippy::too_many_arguments)]
fn reinhard_local(
    scene: &Scene,
    stats: &LogLuminanceStats,
    key: f64,
    alpha1: f64,
    ratio: f64,
    phi: f64,
    epsilon: f64,
    scales: u32,
) -> Vec<f64> {
    let scaled: Vec<f64> = scene
        .lum
        .iter()
        .map(|&l| {
            if l.is_finite() && l > 0.0 {
                key * (l.ln() - stats.mean_log).exp()
            } else {
                0.0
            }
        })
        .collect();
    let mask: Vec<f64> = scene
        .lum
        .iter()
        .map(|l| if l.is_nan() { 0.0 } else { 1.0 })
        .collect();
    let sigmas: Vec<f64> = (0..=scales).map(|i| blur_sigma(alpha1, ratio, i)).collect();
    let blurs = reinhard_blurs(&scaled, &mask, scene.width, scene.height, &sigmas);
    let sharpness = phi.exp2() * key;
    (0..scaled.len())
        .map(|p| {
            if mask[p] == 0.0 {
                return f64::NAN;
            }
            let mut chosen = blurs[0][p];
            for i in 0..scales as usize {
                let s = ratio.powi(i as i32);
                let (v1, v2) = (blurs[i][p], blurs[i + 1][p]);
                let activity = (v1 - v2) / (sharpness / (s * s) + v1);
                if activity.abs() >= epsilon {
                    break;
                }
                chosen = v1;
            }
            scaled[p] / (1.0 + chosen)
        })
        .collect()
}

/// Durand & Dorsey 2002 with their piecewise-linear acceleration ([`DurandGrid`]): log10
/// luminance l (missing and black pixels have weight 0) is box-averaged onto the grid; per
/// intensity level, range-weighted pairs are blurred on the grid; each pixel interpolates its
/// two levels (bilinear on the grid, linear in l). The base is compressed so that its range
/// becomes log10(contrast) (never expanded) with its maximum at 1; the detail layer is kept.
fn durand(scene: &Scene, contrast: f64, sigma_spatial: f64, sigma_range: f64) -> Vec<f64> {
    let (width, height) = (scene.width, scene.height);
    let log_l: Vec<f64> = scene
        .lum
        .iter()
        .map(|&l| {
            if l.is_finite() && l > 0.0 {
                l.log10()
            } else {
                f64::NAN
            }
        })
        .collect();
    let finite_l = log_l.iter().copied().filter(|l| l.is_finite());
    let l_max = finite_l.clone().fold(f64::NEG_INFINITY, f64::max);
    let l_min = finite_l.fold(f64::INFINITY, f64::min);
    let grid = DurandGrid::new(
        width as u32,
        height as u32,
        sigma_spatial,
        sigma_range,
        l_min,
        l_max,
    );
    let levels = durand_levels(&log_l, width, height, &grid, sigma_range);
    let base: Vec<f64> = (0..width * height)
        .into_par_iter()
        .map(|p| {
            let l = log_l[p];
            if l.is_nan() {
                return f64::NAN;
            }
            let (j, f) = grid.bracket(l);
            let at = |level: u32| {
                let plane = &levels[level as usize];
                let [num, den] = bilinear_pair(plane, &grid, p % width, p / width);
                num / den
            };
            (1.0 - f) * at(j) + f * at(j + 1)
        })
        .collect();
    let finite = base.iter().copied().filter(|b| b.is_finite());
    let base_max = finite.clone().fold(f64::NEG_INFINITY, f64::max);
    let base_min = finite.fold(f64::INFINITY, f64::min);
    let range = base_max - base_min;
    let compression = if range > 0.0 {
        (contrast.log10() / range).min(1.0)
    } else {
        1.0
    };
    scene
        .lum
        .iter()
        .zip(base.iter().zip(&log_l))
        .map(|(&l, (&b, &ll))| {
            if l.is_nan() {
                f64::NAN
            } else if b.is_finite() {
                10f64.powf((b - base_max) * compression + (ll - b))
            } else {
                0.0
            }
        })
        .collect()
}

/// Durand's grid, blurred per level: `levels[j][cell]` = (sum w mean, sum w) of level j.
fn durand_levels(
    log_l: &[f64],
    width: usize,
    height: usize,
    grid: &DurandGrid,
    sigma_range: f64,
) -> Vec<Vec<[f64; 2]>> {
    let z = grid.cell as usize;
    let (gw, gh) = (grid.grid_width as usize, grid.grid_height as usize);
    // Box average of l over each cell's valid pixels: (mean, count).
    let cells: Vec<[f64; 2]> = (0..gw * gh)
        .map(|c| {
            let (cx, cy) = (c % gw, c / gw);
            let (mut sum, mut count) = (0.0, 0.0);
            for y in cy * z..((cy + 1) * z).min(height) {
                for x in cx * z..((cx + 1) * z).min(width) {
                    let l = log_l[y * width + x];
                    if !l.is_nan() {
                        sum += l;
                        count += 1.0;
                    }
                }
            }
            [if count > 0.0 { sum / count } else { 0.0 }, count]
        })
        .collect();
    let radius = grid.radius as isize;
    let spatial: Vec<f64> = (-radius..=radius)
        .map(|k| (-((k * k) as f64) / (2.0 * grid.sigma_cells * grid.sigma_cells)).exp())
        .collect();
    (0..grid.levels)
        .into_par_iter()
        .map(|j| {
            let level = grid.first_level + j as f64 * grid.level_step;
            let weighted: Vec<[f64; 2]> = cells
                .iter()
                .map(|&[mean, count]| {
                    if count == 0.0 {
                        return [0.0, 0.0];
                    }
                    let d = (mean - level) / sigma_range;
                    let w = count * (-0.5 * d * d).max(DURAND_MIN_LOG_WEIGHT).exp();
                    [w * mean, w]
                })
                .collect();
            let across = blur_pairs(&weighted, gw, gh, &spatial, true);
            blur_pairs(&across, gw, gh, &spatial, false)
        })
        .collect()
}

/// One direction of a separable blur of (value, weight) pairs on a `width` x `height` grid with
/// the taps `weights` (offsets -r..=r); taps outside the grid are left out.
fn blur_pairs(
    src: &[[f64; 2]],
    width: usize,
    height: usize,
    weights: &[f64],
    horizontal: bool,
) -> Vec<[f64; 2]> {
    let radius = (weights.len() / 2) as isize;
    (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as isize, (i / width) as isize);
            let mut acc = [0.0, 0.0];
            for (k, w) in (-radius..=radius).zip(weights) {
                let (sx, sy) = if horizontal { (x + k, y) } else { (x, y + k) };
                if sx < 0 || sy < 0 || sx >= width as isize || sy >= height as isize {
                    continue;
                }
                let s = src[sy as usize * width + sx as usize];
                acc[0] += w * s[0];
                acc[1] += w * s[1];
            }
            acc
        })
        .collect()
}

/// Bilinear interpolation at full-resolution pixel (x, y) of pairs stored on a grid of
/// `cell`-pixel cells (`grid_width` x `grid_height`): cell c's centre is pixel
/// (c + 0.5) cell - 0.5; outside the outermost centres the edge cells are used.
fn bilinear_pair(plane: &[[f64; 2]], grid: &DurandGrid, x: usize, y: usize) -> [f64; 2] {
    bilinear_on(plane, grid.cell, grid.grid_width, grid.grid_height, x, y)
}

fn bilinear_on(plane: &[[f64; 2]], cell: u32, gw: u32, gh: u32, x: usize, y: usize) -> [f64; 2] {
    let axis = |p: usize, n: u32| -> (usize, usize, f64) {
        let u = ((p as f64 + 0.5) / cell as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let i0 = u.floor() as usize;
        let i1 = (i0 + 1).min(n as usize - 1);
        (i0, i1, u - i0 as f64)
    };
    let (x0, x1, fx) = axis(x, gw);
    let (y0, y1, fy) = axis(y, gh);
    let gw = gw as usize;
    let at = |cx: usize, cy: usize| plane[cy * gw + cx];
    [0, 1].map(|k| {
        let top = at(x0, y0)[k] * (1.0 - fx) + at(x1, y0)[k] * fx;
        let bottom = at(x0, y1)[k] * (1.0 - fx) + at(x1, y1)[k] * fx;
        top * (1.0 - fy) + bottom * fy
    })
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
    [c.r, c.g, c.b].map(|v| srgb_to_linear(v as f64) as f32)
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
        None => match luminance_log_stats(img, exposure_ev) {
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
    if !exposure_ev.is_finite() {
        return Err(Error::invalid(
            "exposure_ev",
            format!("{exposure_ev} must be finite"),
        ));
    }
    let scene = Scene::new(img, exposure_ev);
    let (low, high) = false_colour_decades(img, exposure_ev, decades)?;
    let (width, height) = (img.width as usize, img.height as usize);
    let mut pixels: Vec<[f32; 4]> = scene
        .lum
        .iter()
        .map(|&l| {
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
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(values: &[f32], width: u32) -> HdrImage {
        let pixels = values.iter().map(|&v| [v, v, v, 1.0]).collect::<Vec<_>>();
        HdrImage::from_pixels(width, values.len() as u32 / width, pixels)
    }

    fn settings(op: Operator) -> ToneMapSettings {
        ToneMapSettings {
            op,
            ..Default::default()
        }
    }

    fn out_lum(img: &HdrImage) -> Vec<f64> {
        img.pixels
            .iter()
            .map(|p| REC709[0] * p[0] as f64 + REC709[1] * p[1] as f64 + REC709[2] * p[2] as f64)
            .collect()
    }

    #[test]
    fn reinhard_global_matches_closed_form() {
        // Grey pixels: Rec. 709 weights sum to 1, so L_w is the grey value.
        // Lbar = (0.01 * 0.1 * 1 * 10)^(1/4) = 10^-0.5; L = 0.18 / Lbar * L_w (Reinhard 2002 eq. 2).
        let values = [0.01f32, 0.1, 1.0, 10.0];
        let img = grey(&values, 4);
        let lbar = 10f64.powf(-0.5);
        let l_max = 0.18 / lbar * 10.0;
        for white in [None, Some(2.0)] {
            let out =
                tonemap_cpu(&img, &settings(Operator::Reinhard { key: 0.18, white })).unwrap();
            let w = white.unwrap_or(l_max);
            for (i, &v) in values.iter().enumerate() {
                let l = 0.18 / lbar * v as f64;
                let expected = (l * (1.0 + l / (w * w)) / (1.0 + l)).min(1.0);
                assert!(
                    (out.pixels[i][0] as f64 - expected).abs() < 1e-6,
                    "white {white:?} L_w {v}: {} vs {expected}",
                    out.pixels[i][0]
                );
            }
        }
        // With L_white = max L the brightest pixel maps to exactly 1.
        let out = tonemap_cpu(&img, &settings(Operator::REINHARD)).unwrap();
        assert!((out.pixels[3][1] - 1.0).abs() < 1e-6);
        // Spot values: L_w = 1 -> L = 0.569, L_d = 0.569 (1 + 0.569 / 5.692^2) / 1.569 = 0.36911.
        assert!(
            (out.pixels[2][0] - 0.369_110).abs() < 1e-5,
            "{}",
            out.pixels[2][0]
        );
    }

    #[test]
    fn drago_matches_closed_form() {
        // L_w = 1 and 100: L_wa = 10, so x = 0.1 and x_max = 10. Drago 2003 eq. 4 with b = 0.85,
        // Ld_max = 100: L_d = 1 / log10(11) * ln(1.1) / ln(2 + 8 * 0.01^(ln 0.85 / ln 0.5))
        // = 0.0589982; the maximum maps to Ld_max / 100 = 1.
        let out = tonemap_cpu(&grey(&[1.0, 100.0], 2), &settings(Operator::DRAGO)).unwrap();
        assert!(
            (out.pixels[0][0] as f64 - 0.058_998_18).abs() < 1e-6,
            "{}",
            out.pixels[0][0]
        );
        assert!((out.pixels[1][0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn ward_equalises_a_log_uniform_histogram() {
        // Ward 1997: a flat histogram of ln L over 4 decades is under the linear ceiling
        // (T * bin width / ln(100) is twice each count), so P(ln L) is linear and
        // L_d = Ld_min (Ld_max / Ld_min)^P: 10^-2..10^2 -> 1..100 cd/m2, L_w = 1 -> 10 -> 0.1.
        let n = 2001;
        let values: Vec<f32> = (0..n)
            .map(|i| 10f64.powf(-2.0 + 4.0 * i as f64 / (n - 1) as f64) as f32)
            .collect();
        let out =
            out_lum(&tonemap_cpu(&grey(&values, n as u32), &settings(Operator::WARD)).unwrap());
        for (i, expected) in [(0, 0.01), (500, 10f64.powf(-1.5)), (1000, 0.1), (2000, 1.0)] {
            assert!(
                (out[i] / expected - 1.0).abs() < 0.01,
                "{i}: {} vs {expected}",
                out[i]
            );
        }
    }

    #[test]
    fn ward_ceiling_never_exaggerates_contrast() {
        // 90 % of the pixels crowd into L_w in [1, 1.1]; plain histogram equalisation would
        // stretch that 10 % step over most of the display. The linear ceiling limits
        // dL_d / dL_w to L_d / L_w (Ward 1997 eq. 7), so the step stays at most 1.1 (plus the
        // 2.5 % trimming tolerance and one bin of interpolation).
        let mut values: Vec<f32> = (0..900).map(|i| 1.0 + 0.1 * i as f32 / 899.0).collect();
        values.extend((0..100).map(|i| 10f32.powf(-3.0 + 6.0 * i as f32 / 99.0)));
        let out = out_lum(&tonemap_cpu(&grey(&values, 1000), &settings(Operator::WARD)).unwrap());
        let ratio = out[899] / out[0];
        assert!(
            ratio > 1.0 && ratio < 1.1 * 1.05,
            "display contrast {ratio} for 1.1 in the scene"
        );
    }

    #[test]
    fn one_stop_doubles_linear_values() {
        let values = [0.001f32, 0.01, 0.1, 0.2, 0.45];
        let img = grey(&values, 5);
        let base = tonemap_cpu(&img, &settings(Operator::Linear)).unwrap();
        let brighter = tonemap_cpu(
            &img,
            &ToneMapSettings {
                exposure_ev: 1.0,
                ..settings(Operator::Linear)
            },
        )
        .unwrap();
        for (a, b) in base.pixels.iter().zip(&brighter.pixels) {
            for k in 0..3 {
                assert!((b[k] as f64 - 2.0 * a[k] as f64).abs() < 1e-7 * b[k] as f64);
            }
        }
    }

    #[test]
    fn global_operators_are_monotonic_over_twelve_decades() {
        let n = 1201;
        let values: Vec<f32> = (0..n)
            .map(|i| 10f64.powf(-6.0 + 12.0 * i as f64 / (n - 1) as f64) as f32)
            .collect();
        let img = grey(&values, n as u32);
        for op in Operator::ALL.iter().filter(|op| !op.is_local()) {
            let out = out_lum(&tonemap_cpu(&img, &settings(*op)).unwrap());
            for i in 1..n {
                assert!(
                    out[i] >= out[i - 1] - 1e-7,
                    "{} not monotonic at {}: {} < {}",
                    op.name(),
                    values[i],
                    out[i],
                    out[i - 1]
                );
            }
            assert!(out[n - 1] > out[0], "{} is flat", op.name());
        }
    }

    fn hard_images() -> Vec<(&'static str, HdrImage)> {
        let mut outlier = vec![1e-3f32; 64];
        for (i, v) in outlier.iter_mut().enumerate() {
            *v *= 1.0 + (i % 7) as f32 * 0.1;
        }
        outlier[27] = 1e30;
        vec![
            ("all zeros", grey(&[0.0; 48], 8)),
            ("outlier", grey(&outlier, 8)),
            (
                "denormals",
                grey(&[1e-40, 3e-41, 1e-44, 0.0, 2e-39, 1e-42], 3),
            ),
            ("1x1", grey(&[0.5], 1)),
            ("0x0", HdrImage::new(0, 0)),
            ("1xN", grey(&[0.1, 10.0, 1e3, 0.0, 1e-4, 2.0, f32::NAN], 7)),
            (
                "Nx1",
                grey(&[0.1, 10.0, 1e3, 0.0, 1e-4, f32::INFINITY, 2.0], 1),
            ),
        ]
    }

    #[test]
    fn hard_images_stay_finite_and_in_range() {
        for (name, img) in hard_images() {
            for op in Operator::ALL {
                for ev in [0.0, 40.0, -40.0] {
                    let s = ToneMapSettings {
                        exposure_ev: ev,
                        ..settings(op)
                    };
                    let out = tonemap_cpu(&img, &s).unwrap();
                    for (p, q) in out.pixels.iter().zip(&img.pixels) {
                        assert!(
                            p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
                            "{name} {} ev {ev}: {p:?}",
                            op.name()
                        );
                        if !q.iter().all(|v| v.is_finite()) {
                            assert_eq!(*p, [0.0; 4], "missing pixel must map to 0, alpha 0");
                        }
                    }
                }
            }
        }
        // Among values near 1e-3 the 1e30 pixel maps to white and the rest stay visible.
        let (_, img) = &hard_images()[1];
        for op in [Operator::REINHARD, Operator::DRAGO, Operator::WARD] {
            let out = out_lum(&tonemap_cpu(img, &settings(op)).unwrap());
            assert!(out[27] > 0.99, "{}: {}", op.name(), out[27]);
            assert!(out[0] > 0.005, "{}: {}", op.name(), out[0]);
        }
        // Reinhard: the outlier lifts mean ln L by about (ln 1e30 - ln 1.3e-3) / 64 = 1.18, so
        // a 1e-3 pixel gets L = 0.18 e^-1.18 (1e-3 / 1.3e-3), about 0.04, and L_white is huge.
        let out = out_lum(&tonemap_cpu(img, &settings(Operator::REINHARD)).unwrap());
        let stats = luminance_log_stats(img, 0.0).unwrap();
        let l = 0.18 * ((1e-3f32 as f64).ln() - stats.mean_log).exp();
        assert!(
            (out[0] - l / (1.0 + l)).abs() < 1e-6,
            "{} vs {}",
            out[0],
            l / (1.0 + l)
        );
    }

    #[test]
    fn log_average_of_tiny_values_is_exact() {
        // Alternating 4e-30 and 0.25e-30 (powers of two times f32(1e-30)): the geometric mean
        // is f32(1e-30) exactly. 2^18 pixels exercise the pairwise sum.
        let tiny = 1e-30f32;
        let values: Vec<f32> = (0..1 << 18)
            .map(|i| if i % 2 == 0 { tiny * 4.0 } else { tiny * 0.25 })
            .collect();
        let img = grey(&values, 512);
        let stats = luminance_log_stats(&img, 0.0).unwrap();
        let expected = (tiny as f64).ln();
        assert!(
            (stats.mean_log - expected).abs() < 1e-12 * expected.abs(),
            "{} vs {expected}",
            stats.mean_log
        );
        // The same holds for f32 denormals (1e-42 < f32's smallest normal 1.2e-38).
        let denormal = grey(&[1e-42, 4e-42, 1e-42, 4e-42], 2);
        let stats = luminance_log_stats(&denormal, 0.0).unwrap();
        let expected = ((1e-42f32 as f64) * (4e-42f32 as f64)).sqrt().ln();
        assert!((stats.mean_log - expected).abs() < 1e-12 * expected.abs());
        // And Reinhard is then independent of the data's units.
        let scaled: Vec<f32> = values.iter().map(|v| v * 1e30).collect();
        let a = tonemap_cpu(&img, &settings(Operator::REINHARD)).unwrap();
        let b = tonemap_cpu(&grey(&scaled, 512), &settings(Operator::REINHARD)).unwrap();
        assert!((a.pixels[0][0] - b.pixels[0][0]).abs() < 1e-6);
        assert!((a.pixels[1][0] - b.pixels[1][0]).abs() < 1e-6);
    }

    #[test]
    fn missing_pixels_do_not_spread_through_local_blurs() {
        let (w, h) = (64usize, 64usize);
        let mut values: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                10f64.powf(2.0 * (x / 7.0).sin() * (y / 9.0).cos()) as f32
            })
            .collect();
        let hole = 3 * w + 3;
        // Without the NaN, the hole holds the others' geometric mean, so Lbar is unchanged.
        let others: Vec<f64> = (0..w * h)
            .filter(|&i| i != hole)
            .map(|i| (values[i] as f64).ln())
            .collect();
        values[hole] = (others.iter().sum::<f64>() / others.len() as f64).exp() as f32;
        let clean = grey(&values, w as u32);
        values[hole] = f32::NAN;
        let holed = grey(&values, w as u32);
        for op in [Operator::REINHARD_LOCAL, Operator::DURAND] {
            let a = tonemap_cpu(&clean, &settings(op)).unwrap();
            let b = tonemap_cpu(&holed, &settings(op)).unwrap();
            assert_eq!(b.pixels[hole], [0.0; 4]);
            for (i, p) in b.pixels.iter().enumerate() {
                assert!(p.iter().all(|v| v.is_finite()), "{} spread NaN", op.name());
                let (x, y) = (i % w, i / w);
                if x > 40 || y > 40 {
                    // Reinhard's widest surround: sigma 10.6 px, window 32 px; Durand's 3 px.
                    for (got, want) in p.iter().zip(&a.pixels[i]) {
                        assert!(
                            (got - want).abs() < 1e-5,
                            "{} at ({x}, {y}): {got} vs {want}",
                            op.name()
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn local_operators_reduce_to_sensible_values() {
        // A uniform image: every surround equals the centre, so Reinhard local selects the
        // largest scale and L_d = L / (1 + L) with L = key = 0.18 -> 0.152542.
        let img = grey(&[3.0; 100], 10);
        let out = tonemap_cpu(&img, &settings(Operator::REINHARD_LOCAL)).unwrap();
        assert!((out.pixels[55][0] as f64 - 0.18 / 1.18).abs() < 1e-6);
        // Durand on a uniform image: base = log10 3, no detail, base max maps to 1.
        let out = tonemap_cpu(&img, &settings(Operator::DURAND)).unwrap();
        assert!((out.pixels[55][0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn durand_compresses_the_base_to_the_target_contrast() {
        // Two flat halves 10^4 apart: the bilateral base keeps the step (range weight at
        // 4 / 0.4 = 10 sigma is e^-50), so the halves come out log10(5) apart: 1 and 0.2.
        let (w, h) = (40u32, 8u32);
        let values: Vec<f32> = (0..w * h)
            .map(|i| if i % w < w / 2 { 1e-2 } else { 1e2 })
            .collect();
        let out = tonemap_cpu(&grey(&values, w), &settings(Operator::DURAND)).unwrap();
        assert!((out.pixels[(w + w - 1) as usize][0] - 1.0).abs() < 1e-5);
        assert!(
            (out.pixels[w as usize][0] - 0.2).abs() < 1e-5,
            "{}",
            out.pixels[w as usize][0]
        );
    }

    #[test]
    fn saturation_and_colour_ratio() {
        // C_d = (C / L_w)^s L_d: with s = 0 every channel equals L_d.
        let img = HdrImage::from_pixels(1, 1, vec![[0.3, 0.1, 0.05, 1.0]]);
        let lw = 0.2126 * 0.3 + 0.7152 * 0.1 + 0.0722 * 0.05;
        let s = ToneMapSettings {
            saturation: 0.0,
            ..settings(Operator::Linear)
        };
        let out = tonemap_cpu(&img, &s).unwrap();
        for k in 0..3 {
            assert!((out.pixels[0][k] as f64 - lw).abs() < 1e-7);
        }
        let out = tonemap_cpu(&img, &settings(Operator::Linear)).unwrap();
        assert!((out.pixels[0][0] - 0.3).abs() < 1e-7);
        // Offset then gamma on the display side: (0.3 - 0.1)^(1 / 2) = 0.4472136.
        let s = ToneMapSettings {
            offset: -0.1,
            gamma: 2.0,
            ..settings(Operator::Linear)
        };
        let out = tonemap_cpu(&img, &s).unwrap();
        assert!((out.pixels[0][0] - 0.447_213_6).abs() < 1e-6);
        assert_eq!(out.pixels[0][2], 0.0); // 0.05 - 0.1 clamps to 0
    }

    #[test]
    fn auto_exposure_hits_key_and_percentile() {
        let img = grey(&[0.01, 0.1, 1.0, 10.0], 4);
        // Lbar = 10^-0.5 -> EV = log2(0.18 / 10^-0.5).
        let ev = auto_exposure_key(&img, 0.18).unwrap();
        assert!((ev - (0.18f64 / 10f64.powf(-0.5)).log2()).abs() < 1e-6);
        // The 50th percentile by nearest rank is the 2nd of 4 values, 0.1.
        let ev = auto_exposure_percentile(&img, 50.0, 0.5).unwrap();
        assert!((ev - (0.5f64 / 0.1).log2()).abs() < 1e-6);
        assert_eq!(auto_exposure_key(&grey(&[0.0], 1), 0.18).unwrap(), 0.0);
        assert!(auto_exposure_key(&img, 0.0).is_err());
    }

    #[test]
    fn false_colour_maps_decades_and_draws_a_legend() {
        let values: Vec<f32> = (0..32 * 32)
            .map(|i| 10f32.powf(-2.0 + 4.0 * (i % 32) as f32 / 31.0))
            .collect();
        let mut img = grey(&values, 32);
        img.pixels[0] = [f32::NAN; 4];
        let out = false_colour_log10(&img, 0.0, None).unwrap();
        assert_eq!(out.meta("false_colour.log10_min"), Some("-2"));
        assert_eq!(out.meta("false_colour.log10_max"), Some("2"));
        // Its colour bar labels the decades 0.01 to 100.
        let bar = crate::model::text::ColourBar::of(&out).unwrap();
        let labels: Vec<String> = bar.ticks(10).into_iter().map(|(_, l)| l).collect();
        assert_eq!(labels, ["0.01", "0.1", "1", "10", "100"]);
        assert_eq!(
            out.pixels[0],
            [MISSING_GREY, MISSING_GREY, MISSING_GREY, 1.0]
        );
        // Pixel (31, 0) is at 10^2, the top of the map.
        let top = turbo_linear(1.0);
        assert!((0..3).all(|k| (out.pixels[31][k] - top[k]).abs() < 1e-6));
        // The legend's bottom row has white ticks at the 5 decades, including both ends.
        let last = &out.pixels[31 * 32..];
        let ticks = last.iter().filter(|p| p[..3] == [1.0, 1.0, 1.0]).count();
        assert_eq!(ticks, 5);
        assert!(out.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
    }

    #[test]
    fn invalid_parameters_name_the_field_and_range() {
        let err = |r: Result<Operator>| r.unwrap_err().to_string();
        assert!(err(Operator::parse("reinhard", &[("key", 0.0)])).starts_with("reinhard.key:"));
        assert!(err(Operator::parse("reinhard", &[("white", -1.0)])).starts_with("reinhard.white:"));
        assert!(err(Operator::parse("drago", &[("bias", 1.5)])).contains("(0, 1]"));
        assert!(err(Operator::parse("drago", &[("bias", 0.0)])).contains("(0, 1]"));
        let unknown = err(Operator::parse("mantiuk", &[]));
        for name in Operator::NAMES {
            assert!(unknown.contains(name), "{unknown}");
        }
        assert!(err(Operator::parse("ward", &[("key", 1.0)])).contains("ld_min, ld_max, bins"));
        let bad = |s: ToneMapSettings| s.validate().unwrap_err().to_string();
        let ok = ToneMapSettings::default();
        assert!(bad(ToneMapSettings {
            exposure_ev: f64::NAN,
            ..ok
        })
        .starts_with("exposure_ev:"));
        assert!(bad(ToneMapSettings {
            saturation: -0.1,
            ..ok
        })
        .starts_with("saturation:"));
        let img = grey(&[1.0], 1);
        assert!(tonemap_cpu(
            &img,
            &ToneMapSettings {
                exposure_ev: f64::INFINITY,
                ..ok
            }
        )
        .is_err());
        for name in Operator::NAMES {
            assert_eq!(Operator::parse(name, &[]).unwrap().name(), name);
        }
    }

    #[test]
    fn every_tonemap_shader_parses_and_validates() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders/tonemap");
        let mut checked = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().and_then(|e| e.to_str()) != Some("wgsl") {
                continue;
            }
            // Through the project's loader, which resolves `#include "shared/..."`.
            let name = format!("tonemap/{}", path.file_name().unwrap().to_string_lossy());
            let source = crate::gpu::shader::load(&name, &[]).unwrap();
            let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| {
                panic!(
                    "{}",
                    e.emit_to_string_with_path(&source, &path.display().to_string())
                )
            });
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
            // The Rust mirrors must keep the WGSL structs' sizes and member counts.
            for ty in module.types.iter().map(|(_, ty)| ty) {
                let expected = match ty.name.as_deref() {
                    Some("ToneMapParams") => {
                        Some((size_of::<crate::tonemap::params::ToneMapParams>(), 36))
                    }
                    Some("LuminanceStats") => {
                        Some((size_of::<crate::tonemap::params::LuminanceStats>(), 4))
                    }
                    _ => None,
                };
                if let (Some((size, count)), naga::TypeInner::Struct { members, span }) =
                    (expected, &ty.inner)
                {
                    assert_eq!(
                        (*span as usize, members.len()),
                        (size, count),
                        "{}",
                        path.display()
                    );
                }
            }
            checked += 1;
        }
        assert!(checked >= 6, "only {checked} shaders in {}", dir.display());
    }
}
