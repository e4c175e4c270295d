//! The accuracy report's surface scenes: the interference phase methods timed on the fringe
//! pass and scored against the fringe evaluated in f64 at each node.

use std::sync::Arc;

use super::{reference_row, scored_row, AccuracyRow, TimedImage, PER_NODE};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::Grid;
use crate::render::surface::{fringe_f64, PhaseMethod, SurfaceOptions, SurfaceRenderer};

/// The fringe intensity of a map-view image as an opaque grey image (missing pixels 0).
fn grey(fringe: impl Iterator<Item = f64>) -> Vec<[f64; 4]> {
    fringe
        .map(|f| {
            if f.is_finite() {
                [f, f, f, 1.0]
            } else {
                [0.0; 4]
            }
        })
        .collect()
}

/// The phase methods on one surface scene: each fringe pass timed (the data pass is cached)
/// and its fringe intensity compared with (1 + cos 2πν·d)/2 evaluated in f64 at the node each
/// pixel shows (map view, one pixel per node); the f64 evaluation on the CPU is timed too.
pub(super) fn bench_surface_scene(
    ctx: Arc<GpuContext>,
    name: &str,
    grid: &Grid,
    options: &SurfaceOptions,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>> {
    let renderer = SurfaceRenderer::new(ctx);
    let (nx, ny) = (grid.nx(), grid.ny());
    log(&format!("{name}: f64 fringes on the CPU ..."));
    let (reference, f64_ms) = surface_reference(grid, options.nu[0], runs);
    let mut rows = Vec::new();
    for (phase, variant) in [
        (PhaseMethod::Naive, "naive f32"),
        (PhaseMethod::Reduced, "reduced"),
    ] {
        // One pixel per node: each pixel's fringe is compared with its node's.
        let o = SurfaceOptions {
            phase,
            width: Some(nx as u32),
            height: Some(ny as u32),
            ..options.clone()
        };
        let (ms, got) = time_fringe_pass(&renderer, grid, &o, runs)?;
        let r = scored_row(
            name,
            variant.into(),
            &ms,
            &got,
            &reference,
            (nx as u32, ny as u32),
            PER_NODE,
        )?;
        log(&format!(
            "{name} {variant}: {:.1} ms, rel RMS {:.2e}",
            r.median_ms, r.rel_rms
        ));
        rows.push(r);
    }
    rows.push(reference_row(name, &f64_ms, PER_NODE));
    Ok(rows)
}

/// The fringe intensity evaluated in f64 at the node each pixel of the map view shows, and the
/// milliseconds of each of `runs` evaluations.
fn surface_reference(grid: &Grid, nu: f64, runs: usize) -> (Vec<[f64; 4]>, Vec<f64>) {
    use rayon::prelude::*;
    let (nx, ny) = (grid.nx(), grid.ny());
    let d = grid.property_at(0).1;
    let mut f64_ms = Vec::new();
    let mut reference = Vec::new();
    for _ in 0..runs.max(1) {
        let t = std::time::Instant::now();
        // Pixel (i, r) shows node (i, ny − 1 − r) in map view.
        reference = grey(
            (0..nx * ny)
                .into_par_iter()
                .map(|k| fringe_f64(nu, d[(ny - 1 - k / nx) * nx + k % nx]))
                .collect::<Vec<_>>()
                .into_iter(),
        );
        f64_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    (reference, f64_ms)
}

/// One warm-up render, then `runs` timed ones: the fringe pass's milliseconds of each, and the
/// last one's fringe intensity as a grey image.
fn time_fringe_pass(
    renderer: &SurfaceRenderer,
    grid: &Grid,
    o: &SurfaceOptions,
    runs: usize,
) -> Result<TimedImage> {
    renderer.render(grid, o)?;
    let mut ms = Vec::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        let (mut images, timing) = renderer.render_timed(grid, o)?;
        ms.push(timing.fringe_ms);
        last = Some(images.remove(0));
    }
    let img = last.expect("at least one run");
    let fringe = img
        .extra_channels
        .iter()
        .find(|(n, _)| n == "fringe")
        .map(|(_, v)| v)
        .ok_or_else(|| Error::Gpu("surface image without a fringe channel".into()))?;
    Ok((ms, grey(fringe.iter().map(|&v| v as f64))))
}
