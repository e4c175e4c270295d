//! The surface benchmark (`hdrvis bench surface`): on an n² grid rendered in map view at one pixel
//! per node, the median time of (a) a ν change — step 2 only, the data pass cached — and (b) a
//! full two-step render of a new grid (upload, data pass, fringe pass, readback). Each timing ends
//! with the image in host memory. The grid is an Okada-like field with ν·d spanning ~10⁴ fringes.

use super::median;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::Grid;
use crate::render::surface::{FringeMode, SurfaceOptions, SurfaceRenderer};
use std::sync::Arc;
use std::time::Instant;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct SurfaceBenchRow {
    pub name: String,
    pub runs_ms: Vec<f64>,
    /// Data passes run during the timed runs (0 for the ν-change row).
    pub data_passes: u64,
}

impl SurfaceBenchRow {
    pub(crate) fn median_ms(&self) -> f64 {
        median(&self.runs_ms)
    }
}

fn bench_grid(n: usize, seed: f64) -> Result<Grid> {
    Grid::from_fn("bench", n, n, |i, j| {
        let (x, y) = (i as f64 / n as f64 - 0.5, j as f64 / n as f64 - 0.41);
        let r2 = x * x + y * y + 1e-3;
        1.0e3 * (x + seed) / r2 + 30.0 * (7.0 * y).sin()
    })
}

/// Runs both measurements with `runs` timed runs each after one warm-up.
pub fn bench_surface(
    ctx: Arc<GpuContext>,
    n: usize,
    runs: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<SurfaceBenchRow>> {
    let runs = runs.max(1);
    let renderer = SurfaceRenderer::new(ctx);
    let grid = bench_grid(n, 0.0)?;
    // One pixel per node, whatever `n` (the default would enlarge a small grid to a figure).
    let mut o = SurfaceOptions {
        nu: vec![1.0],
        mode: FringeMode::Cyclic,
        width: Some(n as u32),
        height: Some(n as u32),
        ..Default::default()
    };
    progress(&format!("surface {n}^2: warm-up"));
    renderer.render(&grid, &o)?;
    let before = renderer.counters().data_passes;
    let mut nu_ms = Vec::with_capacity(runs);
    for r in 0..runs {
        o.nu = vec![1.0 + 0.37 * (r + 1) as f64];
        o.mode = if r % 2 == 0 {
            FringeMode::Cyclic
        } else {
            FringeMode::Modulated
        };
        let t = Instant::now();
        let img = renderer.render(&grid, &o)?;
        nu_ms.push(t.elapsed().as_secs_f64() * 1e3);
        if std::env::var_os("HDRVIS_SURFACE_PROFILE").is_some() {
            eprintln!("render {:.2} ms", nu_ms[r]);
        }
        std::hint::black_box(img);
    }
    let nu_row = SurfaceBenchRow {
        name: format!("nu change (step 2 only), {n}^2"),
        runs_ms: nu_ms,
        data_passes: renderer.counters().data_passes - before,
    };
    progress(&format!("surface {n}^2: full renders"));
    let grids: Vec<Grid> = (0..runs)
        .map(|r| bench_grid(n, 0.01 * (r + 1) as f64))
        .collect::<Result<_>>()?;
    let before = renderer.counters().data_passes;
    let mut full_ms = Vec::with_capacity(runs);
    for g in &grids {
        let t = Instant::now();
        let img = renderer.render(g, &o)?;
        full_ms.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(img);
    }
    let full_row = SurfaceBenchRow {
        name: format!("full two-step render, {n}^2"),
        runs_ms: full_ms,
        data_passes: renderer.counters().data_passes - before,
    };
    Ok(vec![nu_row, full_row])
}

/// The `hdrvis bench surface` table.
pub fn format_surface_table(adapter: &str, rows: &[SurfaceBenchRow]) -> String {
    let mut s = format!("adapter: {adapter}\n");
    s.push_str(&format!(
        "{:<36} {:>10} {:>12} {:>6}\n",
        "case", "median ms", "data passes", "runs"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<36} {:>10.2} {:>12} {:>6}\n",
            r.name,
            r.median_ms(),
            r.data_passes,
            r.runs_ms.len()
        ));
    }
    s
}
