//! What each effect costs (`hdrvis bench effects`): one scene — a generated mantle shell, ray
//! cast at one sample per voxel — timed plain, with gradient shading, with jitter, and both; then
//! the pass graph's saving: a ten-image exposure sweep from one render against ten full renders
//! (a session whose cache holds nothing, so every image runs the upload and ray cast again). Each timing ends
//! with the images in host memory; medians of several runs after one warm-up.

use super::median;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::{Camera, LutTransfer, Scale, TransferFunction, Volume};
use crate::render::passes::count_ran;
use crate::render::session::RenderSession;
use crate::render::{Shading, VolumeRenderOptions};
use std::sync::Arc;
use std::time::Instant;

/// One measured case.
#[derive(Clone, Debug)]
pub struct EffectRow {
    pub name: String,
    pub runs_ms: Vec<f64>,
    /// Ray casts executed per timed run.
    pub raycasts: usize,
}

impl EffectRow {
    pub(crate) fn median_ms(&self) -> f64 {
        median(&self.runs_ms)
    }
}

fn scene(n: usize) -> Result<Volume> {
    let seed = crate::datasets::mantle::MantleOptions::default().seed;
    super::mantle_fluctuation(n, seed)
}

fn tf() -> Result<TransferFunction> {
    Ok(TransferFunction::Lut(LutTransfer {
        scale: Scale::parse("symlog", Some(1e-3))?,
        colormap: "turbo".into(),
        opacity: vec![[0.0, -3.0], [1.0, -0.5]],
        ..Default::default()
    }))
}

/// Times every case `runs` times after a warm-up; `n` voxels per side, `size` pixels per side.
pub fn bench_effects(
    ctx: Arc<GpuContext>,
    n: usize,
    size: u32,
    runs: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<EffectRow>> {
    let runs = runs.max(1);
    progress(&format!("effects: generating the {n}^3 mantle"));
    let volume = Arc::new(scene(n)?);
    let cam = Camera::orbit(&volume.bounds(), 30.0, 25.0, 35.0)?;
    let mut base = VolumeRenderOptions::new(cam, tf()?);
    (base.width, base.height) = (size, size);
    let source = crate::render::VolumeSource::Memory(volume.clone());
    let timing = super::timing_session(ctx.clone());
    let mut rows = Vec::new();
    let cases: [(&str, Option<Shading>, bool); 4] = [
        ("ray cast, no effects", None, false),
        ("ray cast + shading", Some(Shading::default()), false),
        ("ray cast + jitter", None, true),
        (
            "ray cast + shading + jitter",
            Some(Shading::default()),
            true,
        ),
    ];
    for (name, shading, jitter) in cases {
        let mut o = base.clone();
        o.shading = shading;
        o.jitter = jitter;
        progress(&format!("effects: {name}"));
        let (super::RenderRuns { ms, .. }, _) = super::time_renders(&timing, &source, &o, runs)?;
        rows.push(EffectRow {
            name: name.into(),
            runs_ms: ms,
            raycasts: 1,
        });
    }
    // A budget of zero caches nothing: every request runs all its passes, upload included.
    let uncached = RenderSession::with_context(ctx.clone(), 0);
    let evs: Vec<f64> = (0..10).map(|i| i as f64 - 5.0).collect();
    let sweep = |session: &RenderSession, salt: usize| -> Result<(f64, usize)> {
        session.log().take();
        // A fresh background value per run keeps earlier runs' results out of the cache.
        let mut o = base.clone();
        o.background = [0.0, 0.0, 1e-30 * salt as f64];
        let t = Instant::now();
        for &ev in &evs {
            let img = session.render_volume(&source, &o)?;
            session.exposure(&img, ev)?;
        }
        let ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((ms, count_ran(&session.log().take(), "raycast")))
    };
    let cached = RenderSession::with_context(ctx, 1 << 30);
    cached.upload(&volume)?;
    for (name, session) in [
        ("10 exposures, one render (pass graph)", &cached),
        ("10 exposures, 10 full renders (no cache)", &uncached),
    ] {
        progress(&format!("effects: {name}"));
        sweep(session, 0)?;
        let mut ms = Vec::with_capacity(runs);
        let mut raycasts = 0;
        for r in 0..runs {
            let (t, n) = sweep(session, r + 1)?;
            ms.push(t);
            raycasts = n;
        }
        rows.push(EffectRow {
            name: name.into(),
            runs_ms: ms,
            raycasts,
        });
    }
    Ok(rows)
}

/// The table `hdrvis bench effects` prints: median, spread and ratio to the plain ray cast.
pub fn format_effects_table(adapter: &str, n: usize, size: u32, rows: &[EffectRow]) -> String {
    let mut s = format!(
        "adapter: {adapter}\nscene: mantle {n}^3 f32 -> {size}x{size}, one sample per voxel, symlog LUT\n{:<40} {:>10} {:>10} {:>10} {:>9} {:>9}\n",
        "case", "median ms", "min ms", "max ms", "vs plain", "raycasts"
    );
    let plain = rows.first().map_or(1.0, |r| r.median_ms());
    for r in rows {
        let min = r.runs_ms.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = r.runs_ms.iter().cloned().fold(0.0, f64::max);
        s += &format!(
            "{:<40} {:>10.1} {:>10.1} {:>10.1} {:>8.2}x {:>9}\n",
            r.name,
            r.median_ms(),
            min,
            max,
            r.median_ms() / plain,
            r.raycasts
        );
    }
    s
}
