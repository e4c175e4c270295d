//! Benchmarks of bricked rendering (`hdrvis bench bricks`, `hdrvis bench large`): the speed-up
//! from empty-space skipping on the paper's mantle, and an f32 volume larger than the memory
//! budget rendered out of core with its peak memory. Timings live here, never in tests.

use super::{mantle_fig5_tf, max_diff, median, peak_memory_mib, time_runs, Timings};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Axis, Camera, LutTransfer, TransferFunction};
use crate::render::bricked::BrickedStats;
use crate::render::{Bricking, FilterMode, VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

/// One timed configuration.
#[derive(Clone, Debug)]
pub struct BrickBenchRow {
    pub scene: String,
    pub path: String,
    pub runs_ms: Vec<f64>,
    /// CPU milliseconds of each run (see `process_cpu_ms`).
    pub cpu_ms: Vec<f64>,
    pub stats: Option<BrickedStats>,
    /// Largest difference from the plain exact render, relative to its peak colour.
    pub diff: f64,
}

/// The mantle's Fig. 5 transfer function (symlog of the temperature fluctuation), and the same
/// with everything below the hot anomalies transparent.
pub fn mantle_tfs() -> Vec<(&'static str, TransferFunction)> {
    let fig5 = mantle_fig5_tf();
    let plumes = LutTransfer {
        transparent_below: 0.62,
        ..fig5.clone()
    };
    vec![
        ("mantle Fig. 5 TF", TransferFunction::Lut(fig5)),
        ("mantle hot plumes only", TransferFunction::Lut(plumes)),
    ]
}

/// A render's pixels and, for the bricked path, what it did.
type Rendered = (Vec<[f32; 4]>, Option<BrickedStats>);

/// The mantle's temperature fluctuation at n³ rendered at size² (orbit view, one sample per
/// voxel): the plain ray caster (auto and exact filter) and the bricked one, each without and
/// with empty-space skipping.
pub fn bench_skipping(
    ctx: Arc<GpuContext>,
    n: usize,
    size: u32,
    brick: usize,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<BrickBenchRow>> {
    log(&format!("generating the {n}^3 mantle ..."));
    let vol = Arc::new(super::mantle_fluctuation(n, 7)?);
    let session = super::timing_session(ctx);
    let source = VolumeSource::Memory(vol.clone());
    // One run through the session's entry point: the render's own seconds, image and stats.
    let render = |o: &VolumeRenderOptions| -> Result<(Rendered, f64)> {
        let r = session.render_volume_detailed(&source, o)?;
        Ok(((r.image.pixels.clone(), r.bricks.clone()), r.seconds))
    };
    let mut rows = Vec::new();
    for (scene, tf) in mantle_tfs() {
        let mut o = VolumeRenderOptions::new(Camera::orbit(&vol.bounds(), 35.0, 20.0, 25.0)?, tf);
        o.width = size;
        o.height = size;
        o.step = 1.0;
        o.empty_space_skipping = false;
        let mut exact = o.clone();
        exact.filter = FilterMode::Exact;
        let reference = render(&exact)?.0 .0;
        let mut record = |path: &str, (runs_ms, cpu_ms): Timings, img: &[[f32; 4]], stats| {
            log(&format!("{scene}, {path}: {:.1} ms", median(&runs_ms)));
            rows.push(BrickBenchRow {
                scene: scene.into(),
                path: path.into(),
                runs_ms,
                cpu_ms,
                stats,
                diff: max_diff(img, &reference),
            });
        };
        let skipping = |base: &VolumeRenderOptions| VolumeRenderOptions {
            empty_space_skipping: true,
            ..base.clone()
        };
        let plain = [
            ("plain (auto filter)", o.clone()),
            ("plain + skipping (auto filter)", skipping(&o)),
            ("plain (exact)", exact.clone()),
            ("plain + skipping (exact)", skipping(&exact)),
        ];
        for (path, opts) in &plain {
            let (timings, (img, _)) = time_runs(runs, || render(opts))?;
            record(path, timings, &img, None);
        }
        for (path, skip) in [("bricked", false), ("bricked + skipping", true)] {
            let mut b = o.clone();
            b.empty_space_skipping = skip;
            b.bricking = Bricking {
                brick: Some(brick),
                ..Default::default()
            };
            let (timings, (img, st)) = time_runs(runs, || render(&b))?;
            record(path, timings, &img, st);
        }
    }
    Ok(rows)
}

pub fn format_skipping_table(adapter: &str, n: usize, size: u32, rows: &[BrickBenchRow]) -> String {
    let mut s = format!(
        "adapter: {adapter}\nempty-space skipping: mantle fluctuation {n}^3 -> {size}^2, orbit view, 1 sample/voxel, f32, median of runs\n"
    );
    s.push_str(&format!(
        "{:<24} {:<20} {:>10} {:>9} {:>11} {:>9} {:>16} {:>11}\n",
        "scene",
        "path",
        "median ms",
        "speed-up",
        "CPU ms",
        "speed-up",
        "bricks skipped",
        "max diff"
    ));
    let (mut base, mut cpu_base) = (f64::NAN, f64::NAN);
    for r in rows {
        if r.path.starts_with("plain (auto") {
            base = median(&r.runs_ms);
            cpu_base = median(&r.cpu_ms);
        }
        let skipped = r
            .stats
            .as_ref()
            .map(|st| format!("{} / {}", st.skipped, st.skipped + st.needed))
            .unwrap_or_else(|| "-".into());
        // Process CPU time comes in 10 ms ticks: tiny renders read 0, which has no ratio.
        let cpu = median(&r.cpu_ms);
        let cpu_speedup = if cpu > 0.0 && cpu_base > 0.0 {
            format!("{:.2}x", cpu_base / cpu)
        } else {
            "-".into()
        };
        s.push_str(&format!(
            "{:<24} {:<20} {:>10.1} {:>8.2}x {:>11.0} {:>9} {:>16} {:>11.1e}\n",
            r.scene,
            r.path,
            median(&r.runs_ms),
            base / median(&r.runs_ms),
            cpu,
            cpu_speedup,
            skipped,
            r.diff
        ));
    }
    s.push_str("speed-up: against the plain ray caster with the auto filter (wall clock, and CPU time of this process, which other jobs on the machine disturb less); max diff: against the plain exact render, relative to its peak\n");
    s
}

/// What `hdrvis bench large` measured.
#[derive(Clone, Debug)]
pub struct LargeReport {
    pub path: std::path::PathBuf,
    pub file_bytes: u64,
    pub generated_s: Option<f64>,
    pub index_s: f64,
    pub render_s: Vec<f64>,
    pub stats: BrickedStats,
    pub budget_mib: f64,
    pub peak_rss_mib: Option<f64>,
    pub n: usize,
    pub size: u32,
    pub brick: usize,
}

/// The HDR blobs of `hdrvis bench volume` at n³ (five decades over a 1e-4 floor), one z-slice.
fn blob_slice(n: usize, k: usize, out: &mut [f32]) {
    use rayon::prelude::*;
    let z = k as f64 + 0.5;
    out.par_chunks_mut(n).enumerate().for_each(|(j, row)| {
        let y = j as f64 + 0.5;
        for (i, o) in row.iter_mut().enumerate() {
            *o = super::hdr_blobs_at(n, i as f64 + 0.5, y, z) as f32;
        }
    });
}

/// An n³ f32 volume written to the dataset cache as `.npy` (streamed, once), opened as bricks
/// by positioned reads and rendered at size² along z with `budget_mib` of GPU memory. The
/// transfer function is the volume benchmark's with the 1e-4 floor made transparent.
pub fn bench_large(
    ctx: Arc<GpuContext>,
    n: usize,
    size: u32,
    budget_mib: f64,
    brick: usize,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<LargeReport> {
    // A cache entry like any dataset: checked when used, made again when damaged.
    let mut generated_s = None;
    let path = crate::datasets::cache::cached("bench-large-blobs", &n.to_string(), "npy", |tmp| {
        let bytes = (n as u64).pow(3) * 4;
        log(&format!(
            "writing the {n}^3 blobs to the cache ({:.1} GB) ...",
            bytes as f64 / 1e9
        ));
        let t = std::time::Instant::now();
        crate::datasets::bricked::write_npy_f32_streaming(tmp, [n; 3], &|k, out| {
            blob_slice(n, k, out)
        })?;
        generated_s = Some(t.elapsed().as_secs_f64());
        Ok(())
    })?;
    let file_bytes = std::fs::metadata(&path)
        .map_err(|e| Error::io(&path, e))?
        .len();
    log("building the brick index (one streamed pass over the file) ...");
    let t = std::time::Instant::now();
    let bv = Arc::new(crate::datasets::bricked::open_bricked(&path, None, brick)?);
    let index_s = t.elapsed().as_secs_f64();
    let tf = match super::bench_tf() {
        TransferFunction::Lut(l) => TransferFunction::Lut(LutTransfer {
            transparent_below: 0.15,
            ..l
        }),
        other => other,
    };
    let mut o = VolumeRenderOptions::new(Camera::axis(Axis::Z, &bv.bounds()), tf);
    o.width = size;
    o.height = size;
    o.step = 1.0;
    o.bricking = Bricking {
        memory_budget: Some((budget_mib * (1u64 << 20) as f64) as u64),
        ..Default::default()
    };
    let session = super::timing_session(ctx);
    let source = VolumeSource::Bricked(bv);
    let mut render_s = Vec::new();
    let mut stats = BrickedStats::default();
    for r in 0..runs.max(1) {
        log(&format!("rendering, run {} ...", r + 1));
        let st = session
            .render_volume_detailed(&source, &o)?
            .bricks
            .clone()
            .expect("a bricked source renders bricked");
        log(&format!(
            "{:.1} s, {} passes, {} bricks uploaded",
            st.seconds, st.passes, st.uploaded
        ));
        render_s.push(st.seconds);
        stats = st;
    }
    Ok(LargeReport {
        path,
        file_bytes,
        generated_s,
        index_s,
        render_s,
        stats,
        budget_mib,
        peak_rss_mib: peak_memory_mib(),
        n,
        size,
        brick,
    })
}

pub fn format_large_report(adapter: &str, r: &LargeReport) -> String {
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    let mut s = format!("adapter: {adapter}\nout-of-core: {0}^3 f32 HDR blobs ({1:.2} GiB, {2}) -> {3}^2, axis view, 1 sample/voxel, skipping on\n",
        r.n, gib(r.file_bytes), r.path.display(), r.size);
    if let Some(g) = r.generated_s {
        s.push_str(&format!("written (streamed .npy):    {g:.1} s\n"));
    }
    s.push_str(&format!("brick index (1 pass): {:.1} s\n", r.index_s));
    s.push_str(&format!(
        "render (median of {}):      {:.1} s\n",
        r.render_s.len(),
        median(&r.render_s)
    ));
    s.push_str(&format!(
        "GPU memory budget:          {:.0} MiB (used {:.0} MiB: cache of {} bricks of {}^3 + apron, image, ray state)\n",
        r.budget_mib,
        r.stats.gpu_bytes as f64 / (1u64 << 20) as f64,
        r.stats.capacity,
        r.brick,
    ));
    s.push_str(&format!(
        "bricks:                     {} needed, {} skipped, {} passes ({} repair), {} uploaded\n",
        r.stats.needed, r.stats.skipped, r.stats.passes, r.stats.repair_passes, r.stats.uploaded
    ));
    s.push_str(&format!(
        "peak resident memory:       {} (VmHWM of this process; the volume is {:.0} MiB)\n",
        r.peak_rss_mib
            .map(|m| format!("{m:.0} MiB"))
            .unwrap_or_else(|| "unknown".into()),
        r.file_bytes as f64 / (1u64 << 20) as f64
    ));
    s
}
