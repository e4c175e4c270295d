//! The accuracy report's `tonemap` scenes: Durand & Dorsey's and Reinhard's local operators as
//! the GPU runs them (their accelerations: the piecewise-linear grid, the Gaussian pyramid)
//! against the operators by their definitions on the CPU (a brute-force bilateral filter,
//! full-resolution Gaussians: `tonemap::cpu::exact`), on four lights of 1, 2 and 16 pixels and on
//! four decades of noise. Errors are of the display values the operators produce.

use std::sync::Arc;
use std::time::Instant;

use super::{lost_detail, max_relative, median, psnr_8bit, relative_rms, AccuracyRow};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::HdrImage;
use crate::tonemap::cpu::exact::{lit_scene, noise_scene};
use crate::tonemap::cpu::{tonemap_cpu_with, Filters};
use crate::tonemap::{GpuToneMapper, Operator, ToneMapSettings};

/// Side of the tone-mapping scenes: the brute-force bilateral filter costs (6 sigma + 1)^2
/// taps per pixel, with sigma 2 % of the side.
pub(crate) const TONEMAP_SIZE: u32 = 256;
/// Reference of the tone-mapping rows.
pub(crate) const EXACT: &str = "exact operator";

/// The scenes, by name.
fn scenes() -> Vec<(String, HdrImage)> {
    let mut scenes: Vec<(String, HdrImage)> = [1u32, 2, 16]
        .iter()
        .map(|&n| (format!("lights{n}"), lit_scene(TONEMAP_SIZE, n, 0)))
        .collect();
    scenes.push(("noise".into(), noise_scene(TONEMAP_SIZE, 7)));
    scenes
}

/// Per scene and local operator: the GPU's time and error against the exact operator, and the
/// exact operator's own time on the CPU.
pub(super) fn tonemap_rows(
    ctx: Arc<GpuContext>,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>> {
    let mapper = GpuToneMapper::new(ctx);
    let mut rows = Vec::new();
    for (scene, img) in scenes() {
        for (name, op) in [
            ("durand", Operator::DURAND),
            ("reinhard-local", Operator::REINHARD_LOCAL),
        ] {
            log(&format!("tonemap {scene}: {name}"));
            let settings = ToneMapSettings {
                op,
                ..Default::default()
            };
            let (exact_ms, exact) = timed(runs.min(3), || {
                tonemap_cpu_with(&img, &settings, Filters::Exact)
            })?;
            mapper.tonemap(&img, &settings)?;
            let (gpu_ms, gpu) = timed(runs, || mapper.tonemap(&img, &settings))?;
            rows.push(display_row(
                &scene,
                format!("{name} (GPU)"),
                &gpu_ms,
                &gpu,
                &exact,
            ));
            rows.push(display_row(
                &scene,
                format!("{name} exact (CPU)"),
                &exact_ms,
                &exact,
                &exact,
            ));
        }
    }
    Ok(rows)
}

/// `runs` runs of `f` (at least one): the milliseconds of each, and the last result.
fn timed(runs: usize, f: impl Fn() -> Result<HdrImage>) -> Result<(Vec<f64>, HdrImage)> {
    let mut ms = Vec::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        last = Some(f()?);
        ms.push(start.elapsed().as_secs_f64() * 1e3);
    }
    Ok((ms, last.expect("at least one run")))
}

/// A row of display values scored against the exact operator's: relative RMS, the largest
/// error relative to the exact value (display values below 1e-3 count as 1e-3), the PSNR of
/// the 8-bit sRGB pictures, and the fraction of pixels off by more than 1 %.
fn display_row(
    scene: &str,
    variant: String,
    ms: &[f64],
    got: &HdrImage,
    exact: &HdrImage,
) -> AccuracyRow {
    let as_f64 =
        |img: &HdrImage| -> Vec<[f64; 4]> { img.pixels.iter().map(|p| p.map(f64::from)).collect() };
    let (g, e) = (as_f64(got), as_f64(exact));
    AccuracyRow {
        scene: scene.to_string(),
        variant,
        median_ms: median(ms),
        rel_rms: relative_rms(&g, &e),
        max_rel: max_relative(&g, &e, 1e-3),
        psnr_8bit: psnr_8bit(&got.to_srgb8(), &exact.to_srgb8()),
        lost_detail: lost_detail(&g, &e),
        reference: EXACT,
        memory_mib: f64::NAN,
        prepare_ms: f64::NAN,
    }
}
