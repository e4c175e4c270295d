//! The empty-space skipping benchmark (`hdrvis bench skipping`): the in-core ray caster with
//! and without skipping, side by side in one run (pairs of runs back to back, each side first
//! in turn), on the paper's mantle under its Fig. 5 transfer function (missing data outside the
//! shell and in the core) and on the HDR blobs (nothing to skip), and the mapped ray caster on
//! the mantle's native spherical shell, with the largest difference between the two images.

use super::volume::VolumeScene;
use super::{max_diff, median, process_cpu_ms, timing_session};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::{Axis, Camera, Volume};
use crate::render::{RenderPath, VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

/// One scene measured with skipping off and on.
#[derive(Clone, Debug)]
pub struct SkippingRow {
    pub scene: String,
    /// Wall-clock ms of each run, without and with skipping.
    pub plain_ms: Vec<f64>,
    pub skipping_ms: Vec<f64>,
    /// Process CPU ms of each run, without and with skipping.
    pub plain_cpu_ms: Vec<f64>,
    pub skipping_cpu_ms: Vec<f64>,
    /// The ray-casting pass on the device's clock, without and with skipping (empty without
    /// timestamp queries).
    pub plain_gpu_ms: Vec<f64>,
    pub skipping_gpu_ms: Vec<f64>,
    /// The path the render with skipping asked took (skipping only where enough is empty).
    pub path: RenderPath,
    /// Largest difference between the two images, relative to the plain one's peak colour.
    pub diff: f64,
}

/// The view the skipping benchmark renders from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkippingView {
    /// 35° azimuth, 20° elevation, 25° field of view: rays at every angle to the grid.
    Orbit,
    /// Along the z axis, the x/y extent framed: `hdrvis bench volume`'s view, where VTK's
    /// mappers run beside hdrvis.
    Axis,
}

impl SkippingView {
    fn camera(self, vol: &Volume) -> Result<Camera> {
        match self {
            SkippingView::Orbit => Camera::orbit(&vol.bounds(), 35.0, 20.0, 25.0),
            SkippingView::Axis => Ok(Camera::axis(Axis::Z, &vol.bounds())),
        }
    }

    fn name(self) -> &'static str {
        match self {
            SkippingView::Orbit => "orbit view",
            SkippingView::Axis => "axis view",
        }
    }
}

/// The scenes: (scene, volume side, image side). `quick` keeps the small sizes only.
fn scenes(quick: bool) -> Vec<(VolumeScene, usize, u32)> {
    let (mantle, blobs) = (VolumeScene::Mantle, VolumeScene::Blobs);
    let mut v = vec![(mantle, 257, 512), (mantle, 257, 1024)];
    if !quick {
        v.extend([(mantle, 513, 512), (mantle, 513, 1024)]);
    }
    v.push((blobs, 256, 512));
    if !quick {
        v.push((blobs, 513, 1024));
    }
    v
}

/// Times every scene from `view` with skipping off and on, `runs` times each after a warm-up.
pub fn bench_skipping(
    ctx: Arc<GpuContext>,
    runs: usize,
    quick: bool,
    view: SkippingView,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<SkippingRow>> {
    let mut rows = Vec::new();
    let mut current: Option<(VolumeScene, usize, Arc<Volume>)> = None;
    for (scene, n, px) in scenes(quick) {
        let vol = match &current {
            Some((s, m, v)) if *s == scene && *m == n => v.clone(),
            _ => {
                log(&format!(
                    "generating the {} volume at {n}^3 ...",
                    scene.name()
                ));
                let v = Arc::new(scene.volume(n)?);
                current = Some((scene, n, v.clone()));
                v
            }
        };
        let mut o = VolumeRenderOptions::new(view.camera(&vol)?, scene.tf()?);
        (o.width, o.height, o.step) = (px, px, 1.0);
        let name = format!("{} {n}^3 -> {px}^2", scene.name());
        log(&format!("{name} ..."));
        rows.push(time_pair(ctx.clone(), &name, &vol, &o, runs)?);
    }
    // The mapped ray caster on the mantle's native shell: under the Fig. 5 transfer function
    // (nothing inside the shell is empty: its core and corners are clipped analytically) and
    // with all but the hot plumes transparent; and on a tomography-like model showing only its
    // slabs.
    let (n, px) = if quick { (64, 256) } else { (128, 512) };
    log(&format!(
        "generating the mantle's native shell for {n}^3 ..."
    ));
    let shell = Arc::new(super::spherical::native_mantle(n)?);
    let tomography = Arc::new(super::spherical::tomography_shell(n)?);
    let mut shells = super::bricks::mantle_tfs()
        .into_iter()
        .map(|(name, tf)| {
            (
                format!("shell {n}: {}", name.trim_start_matches("mantle ")),
                &shell,
                tf,
            )
        })
        .collect::<Vec<_>>();
    shells.push((
        format!("tomography {n}: slabs only"),
        &tomography,
        super::spherical::tomography_slabs_tf(),
    ));
    for (name, v, tf) in shells {
        let mut o = super::spherical::shell_options(v, px)?;
        o.camera = view.camera(v)?;
        o.tf = tf;
        let name = format!("{name} -> {px}^2");
        log(&format!("{name} ..."));
        rows.push(time_pair(ctx.clone(), &name, v, &o, runs)?);
    }
    Ok(rows)
}

/// One scene without and with skipping: a warm-up of each, then pairs of runs back to back, in
/// turn plain first and skipping first, so that drift of the machine's speed spreads over both.
fn time_pair(
    ctx: Arc<GpuContext>,
    scene: &str,
    vol: &Arc<Volume>,
    o: &VolumeRenderOptions,
    runs: usize,
) -> Result<SkippingRow> {
    let session = timing_session(ctx);
    let source = VolumeSource::Memory(vol.clone());
    let plain = VolumeRenderOptions {
        empty_space_skipping: false,
        ..o.clone()
    };
    let skipping = VolumeRenderOptions {
        empty_space_skipping: true,
        ..o.clone()
    };
    let reference = session.render_volume_detailed(&source, &plain)?;
    let skipped = session.render_volume_detailed(&source, &skipping)?;
    super::warm_up(|| {
        session.render_volume_detailed(&source, &plain)?;
        session.render_volume_detailed(&source, &skipping).map(drop)
    })?;
    let mut row = SkippingRow {
        scene: scene.into(),
        plain_ms: Vec::new(),
        skipping_ms: Vec::new(),
        plain_cpu_ms: Vec::new(),
        skipping_cpu_ms: Vec::new(),
        plain_gpu_ms: Vec::new(),
        skipping_gpu_ms: Vec::new(),
        path: skipped.path,
        diff: max_diff(&skipped.image.pixels, &reference.image.pixels),
    };
    for run in 0..runs.max(1) {
        let mut pair = [
            (
                &plain,
                &mut row.plain_ms,
                &mut row.plain_cpu_ms,
                &mut row.plain_gpu_ms,
            ),
            (
                &skipping,
                &mut row.skipping_ms,
                &mut row.skipping_cpu_ms,
                &mut row.skipping_gpu_ms,
            ),
        ];
        // Every other pair runs skipping first, so that neither side is always the one after
        // the other (plain, skip, skip, plain, ...).
        if run % 2 == 1 {
            pair.reverse();
        }
        for (opts, ms, cpu, gpu) in pair {
            let c0 = process_cpu_ms().unwrap_or(f64::NAN);
            let r = session.render_volume_detailed(&source, opts)?;
            cpu.push(process_cpu_ms().unwrap_or(f64::NAN) - c0);
            ms.push(r.seconds * 1e3);
            gpu.extend(r.gpu_seconds.map(|g| g * 1e3));
        }
    }
    Ok(row)
}

/// The median over runs of plain / skipping, each ratio from the pair of runs made back to
/// back: on a shared machine whose speed drifts over seconds, a pair sees the same machine
/// where the medians of the two series may not (runs with no time, CPU ticks of 0, are left out).
pub(crate) fn paired_speed_up(plain: &[f64], skipping: &[f64]) -> f64 {
    let ratios: Vec<f64> = plain
        .iter()
        .zip(skipping)
        .filter(|(_, &k)| k > 0.0)
        .map(|(p, k)| p / k)
        .collect();
    median(&ratios)
}

pub fn format_skipping_table(adapter: &str, view: SkippingView, rows: &[SkippingRow]) -> String {
    let mut s = format!(
        "adapter: {adapter}\nempty-space skipping in the in-core ray caster (boxes: 1 sample/voxel) and the mapped one (spherical shells: 2 samples per radial spacing): {}, f32, auto filter, pairs of runs back to back, plain or skipping first in turn\n",
        view.name()
    );
    s.push_str(&format!(
        "{:<36} {:>9} {:>9} {:>9} {:>8} {:>8} {:>9} {:>8} {:>8} {:>9} {:>10}  {}\n",
        "scene",
        "plain ms",
        "skip ms",
        "speed-up",
        "CPU ms",
        "CPU ms",
        "CPU s-up",
        "GPU ms",
        "GPU ms",
        "GPU s-up",
        "max diff",
        "path taken"
    ));
    for r in rows {
        let (p, k) = (median(&r.plain_ms), median(&r.skipping_ms));
        let (pc, kc) = (median(&r.plain_cpu_ms), median(&r.skipping_cpu_ms));
        // Process CPU time comes in 10 ms ticks: tiny renders read 0, which has no ratio.
        let cpu_ratio = if pc > 0.0 && kc > 0.0 {
            format!(
                "{:.2}x",
                paired_speed_up(&r.plain_cpu_ms, &r.skipping_cpu_ms)
            )
        } else {
            "-".into()
        };
        let (pg, kg) = (median(&r.plain_gpu_ms), median(&r.skipping_gpu_ms));
        let gpu = |v: f64| {
            if r.plain_gpu_ms.is_empty() {
                "-".to_string()
            } else {
                format!("{v:.2}")
            }
        };
        let gpu_ratio = if r.plain_gpu_ms.is_empty() {
            "-".to_string()
        } else {
            format!(
                "{:.2}x",
                paired_speed_up(&r.plain_gpu_ms, &r.skipping_gpu_ms)
            )
        };
        let path = match r.path {
            RenderPath::InCore { skipping: true } => "in-core, skipping",
            RenderPath::InCore { skipping: false } => "in-core, too little empty to skip",
            RenderPath::Mapped { skipping: true } => "mapped, skipping",
            RenderPath::Mapped { skipping: false } => "mapped, too little empty to skip",
            _ => "other",
        };
        s.push_str(&format!(
            "{:<36} {:>9.1} {:>9.1} {:>8.2}x {:>8.0} {:>8.0} {:>9} {:>8} {:>8} {:>9} {:>10.1e}  {path}\n",
            r.scene,
            p,
            k,
            paired_speed_up(&r.plain_ms, &r.skipping_ms),
            pc,
            kc,
            cpu_ratio,
            gpu(pg),
            gpu(kg),
            gpu_ratio,
            r.diff
        ));
    }
    s.push_str("speed-up: the median over runs of plain / skipping, each pair run back to back (wall clock; CPU time of this process, which other jobs on the machine disturb less; the ray-casting pass on the GPU's own clock where the adapter has timestamps); max diff: between the two images, relative to the plain one's peak colour\n");
    s
}
