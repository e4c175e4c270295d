//! The local operators by their definitions, without accelerations: the bilateral filter of
//! Durand & Dorsey as the brute-force sum over each pixel's window, and the hard scenes the
//! accelerations are measured on. Slow (a window of
//! (6 sigma + 1)^2 pixels per pixel), so it serves the accuracy report and the tests as the
//! yardstick of the piecewise-linear grid. (Reinhard's exact Gaussians are the pyramid's level
//! 0: `local::reinhard_blurs` with every scale on full resolution.)

use rayon::prelude::*;

use crate::model::image::HdrImage;
use crate::model::numeric::SplitMix64;
use crate::tonemap::params::gaussian_radius;

/// The bilateral filter of log10 luminance `log_l` (NaN: missing or black, weight 0):
/// B_p = sum_q f(q - p) g(l_q - l_p) l_q / sum_q f(q - p) g(l_q - l_p), with Gaussian f of
/// `sigma_px` pixels truncated at [`gaussian_radius`] and Gaussian g of `sigma_range` (log10
/// units), over the valid pixels of the window. NaN where l is NaN.
pub(super) fn bilateral_base(
    log_l: &[f64],
    width: usize,
    height: usize,
    sigma_px: f64,
    sigma_range: f64,
) -> Vec<f64> {
    let radius = gaussian_radius(sigma_px) as isize;
    let spatial: Vec<f64> = (-radius..=radius)
        .map(|k| (-((k * k) as f64) / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    (0..width * height)
        .into_par_iter()
        .map(|p| {
            let lp = log_l[p];
            if lp.is_nan() {
                return f64::NAN;
            }
            let (x, y) = ((p % width) as isize, (p / width) as isize);
            let (mut num, mut den) = (0.0, 0.0);
            for dy in -radius..=radius {
                let qy = y + dy;
                if qy < 0 || qy >= height as isize {
                    continue;
                }
                let fy = spatial[(dy + radius) as usize];
                for dx in -radius..=radius {
                    let qx = x + dx;
                    if qx < 0 || qx >= width as isize {
                        continue;
                    }
                    let lq = log_l[qy as usize * width + qx as usize];
                    if lq.is_nan() {
                        continue;
                    }
                    let d = (lq - lp) / sigma_range;
                    let w = fy * spatial[(dx + radius) as usize] * (-0.5 * d * d).exp();
                    num += w * lq;
                    den += w;
                }
            }
            num / den
        })
        .collect()
}

/// A hard case for local operators: a smooth textured background (0.5 … 2) with four `n` x `n`
/// lights 1000x brighter, their corners shifted `shift` pixels along x (a light smaller than an
/// acceleration's cell moving by one pixel must not change the rest of the picture).
pub(crate) fn lit_scene(size: u32, n: u32, shift: u32) -> HdrImage {
    let at = |f: f64| (f * size as f64) as u32;
    let corners = [
        (at(0.2), at(0.2)),
        (at(0.68), at(0.26)),
        (at(0.31), at(0.73)),
        (at(0.78), at(0.78)),
    ];
    grey_scene(size, |x, y| {
        let lit = corners.iter().any(|&(cx, cy)| {
            (cx + shift..cx + shift + n).contains(&x) && (cy..cy + n).contains(&y)
        });
        let t = (x as f64 / size as f64 * 6.0).sin() * (y as f64 / size as f64 * 4.0).cos();
        2f64.powf(t) * if lit { 1000.0 } else { 1.0 }
    })
}

/// The other hard case: white noise of four decades (log-uniform, fixed seed), where every
/// pixel's scale choice and range weights sit near their thresholds somewhere.
pub(crate) fn noise_scene(size: u32, seed: u64) -> HdrImage {
    let mut rng = SplitMix64(seed);
    let values: Vec<f64> = (0..size * size)
        .map(|_| 10f64.powf(rng.between(-2.0, 2.0)))
        .collect();
    grey_scene(size, |x, y| values[(y * size + x) as usize])
}

fn grey_scene(size: u32, value: impl Fn(u32, u32) -> f64) -> HdrImage {
    let pixels = (0..size * size)
        .map(|i| {
            let v = value(i % size, i / size) as f32;
            [v, v, v, 1.0]
        })
        .collect();
    HdrImage::from_pixels(size, size, pixels)
}
