//! Benchmarks (`hdrvis bench …`), one module per subject: timings live here, never in pass/fail
//! tests. Each reports the adapter, the median of several runs and derived rates, and can run a
//! named peer side by side on the same data in the same run. This module holds what several
//! benchmarks share: the median, the process's peak memory and CPU time, and the benchmark
//! scenes (the HDR blobs with their log10 transfer function, the mantle's fluctuation with the
//! transfer function of the paper's Fig. 5).

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::{LutTransfer, Scale, TransferFunction, Volume};
use crate::render::session::RenderSession;
use crate::render::{VolumeRender, VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

pub mod accuracy;
pub mod bricks;
pub(crate) mod chart;
pub mod datasets;
pub mod distributed;
pub mod effects;
pub mod equal_error;
pub mod mesh_volume;
pub mod meshes;
pub(crate) mod peer_scenes;
pub mod skipping;
pub mod spherical;
pub mod surface;
pub mod tonemap;
pub mod tonemap_peer;
pub mod tui;
pub mod volume;

pub use accuracy::{lost_detail, relative_rms};

/// A render session for timing: every render runs (none is answered from the result cache),
/// while uploads, bricks and brick caches are reused as in a script run.
pub(crate) fn timing_session(ctx: Arc<GpuContext>) -> RenderSession {
    RenderSession::with_context(ctx, 16 << 30).rerunning_renders()
}

/// One warm-up render (pipeline build, upload, bricking), then `runs` timed ones through the
/// session's one entry point: their times in ms (the render's own, submission to image in host
/// memory) and the last render.
pub(crate) fn time_renders(
    session: &RenderSession,
    source: &VolumeSource,
    opts: &VolumeRenderOptions,
    runs: usize,
) -> Result<(RenderRuns, Arc<VolumeRender>)> {
    let mut last = session.render_volume_detailed(source, opts)?;
    warm_up(|| session.render_volume_detailed(source, opts).map(drop))?;
    let mut times = RenderRuns::default();
    for _ in 0..runs.max(1) {
        last = session.render_volume_detailed(source, opts)?;
        times.ms.push(last.seconds * 1e3);
        times.gpu_ms.extend(last.gpu_seconds.map(|g| g * 1e3));
    }
    Ok((times, last))
}

/// How long a benchmark keeps the device busy before it times: a GPU idles at low clocks (an
/// H100 at 345 of its 1980 MHz) and reaches speed only under sustained work, so a single warm-up
/// render of a few milliseconds leaves the timed runs at whatever clock it happened to reach.
const WARM_UP: std::time::Duration = std::time::Duration::from_millis(500);

/// Calls `render` until [`WARM_UP`] has passed (at least once).
pub(crate) fn warm_up(mut render: impl FnMut() -> Result<()>) -> Result<()> {
    let start = std::time::Instant::now();
    loop {
        render()?;
        if start.elapsed() >= WARM_UP {
            return Ok(());
        }
    }
}

/// The milliseconds of timed renders: wall clock from submission to the image in host memory,
/// and the ray-casting pass on the GPU's own clock (empty where the adapter has no timestamps).
#[derive(Clone, Debug, Default)]
pub(crate) struct RenderRuns {
    pub(crate) ms: Vec<f64>,
    pub(crate) gpu_ms: Vec<f64>,
}

/// Wall-clock and process CPU milliseconds of each timed run.
pub(crate) type Timings = (Vec<f64>, Vec<f64>);

/// One warm-up call of `render`, then `runs` (at least one) timed ones: the wall-clock ms each
/// reported and the process's CPU ms each took, and the last output.
pub(crate) fn time_runs<T>(
    runs: usize,
    mut render: impl FnMut() -> Result<(T, f64)>,
) -> Result<(Timings, T)> {
    render()?;
    warm_up(|| render().map(drop))?;
    let mut ms = Vec::new();
    let mut cpu_ms = Vec::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        let c0 = process_cpu_ms().unwrap_or(f64::NAN);
        let (out, seconds) = render()?;
        cpu_ms.push(process_cpu_ms().unwrap_or(f64::NAN) - c0);
        ms.push(seconds * 1e3);
        last = Some(out);
    }
    Ok(((ms, cpu_ms), last.expect("one run")))
}

/// Largest difference over all channels between two images, relative to `b`'s peak colour.
pub(crate) fn max_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let peak = b
        .iter()
        .flat_map(|p| p[..3].iter().map(|&v| v as f64))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..4).map(move |c| (p[c] as f64 - q[c] as f64).abs()))
        .fold(0.0, f64::max)
        / peak
}

pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Peak resident memory of this process so far (Linux VmHWM), in MiB.
pub(crate) fn peak_memory_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// User plus system time of this process so far in ms (every thread, a CPU rasterizer's
/// included), from `/proc/self/stat` (Linux), or `None` elsewhere. It comes in clock ticks of
/// 10 ms, so it means something summed over several runs; unlike wall-clock time it is barely
/// disturbed by other jobs on the machine.
pub(crate) fn process_cpu_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name (which may hold spaces); utime and stime are
    // fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks * 10.0)
}

/// The mantle's temperature fluctuation on n³ voxels over [-1, 1]³ (missing outside the shell):
/// the volume of the effects, skipping and accuracy benchmarks.
pub(crate) fn mantle_fluctuation(n: usize, seed: u64) -> Result<Volume> {
    use crate::datasets::mantle::{generate, MantleField, MantleFields, MantleOptions};
    let m = generate(
        &MantleOptions {
            n,
            seed,
            fields: MantleFields::only(MantleField::Fluctuation),
            ..Default::default()
        },
        &mut |_| Ok(()),
    )?;
    Volume::new(
        format!("mantle fluctuation {n}^3"),
        [n; 3],
        [2.0 / n as f64; 3],
        [-1.0; 3],
        m.fluctuation,
    )
}

/// The transfer function of the paper's Fig. 5 for the mantle's temperature fluctuation: symlog
/// scale, spectral colours, the near-zero middle faint.
pub fn mantle_fig5_tf() -> LutTransfer {
    LutTransfer {
        scale: Scale::Symlog { linthresh: 1e-3 },
        domain: Some([-0.3, 0.45]),
        colormap: "spectral".into(),
        emission: vec![[0.0, -1.0], [0.45, -3.0], [0.55, -3.0], [1.0, -0.5]],
        opacity: vec![[0.0, -1.5], [0.4, -3.5], [0.6, -3.5], [1.0, -1.0]],
        ..Default::default()
    }
}

/// The benchmark volume: Gaussian blobs spanning five decades over a faint floor, like the
/// HDR fields of the paper, generated in memory (not timed).
pub fn bench_volume(n: usize) -> Result<Volume> {
    Volume::from_fn(&format!("hdr-blobs {n}^3"), [n, n, n], move |x, y, z| {
        hdr_blobs_at(n, x, y, z)
    })
}

/// The value of [`bench_volume`] at voxel coordinates (x, y, z) of an n³ grid.
pub(crate) fn hdr_blobs_at(n: usize, x: f64, y: f64, z: f64) -> f64 {
    let f = n as f64;
    let g = |cx: f64, cy: f64, cz: f64, s: f64, amp: f64| {
        let d2 = (x - cx * f).powi(2) + (y - cy * f).powi(2) + (z - cz * f).powi(2);
        amp * (-d2 / (2.0 * (s * f).powi(2))).exp()
    };
    1e-4 + g(0.35, 0.4, 0.5, 0.10, 10.0)
        + g(0.65, 0.6, 0.45, 0.14, 0.05)
        + g(0.5, 0.3, 0.65, 0.06, 1e-3)
}

/// The benchmark transfer function: log10 scale over five decades, log opacity.
pub fn bench_tf() -> TransferFunction {
    TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        domain: Some([1e-4, 10.0]),
        colormap: "inferno".into(),
        emission: vec![[0.0, -1.0], [1.0, 1.0]],
        opacity: vec![[0.0, -4.0], [0.5, -2.5], [1.0, -1.0]],
        ..Default::default()
    })
}
