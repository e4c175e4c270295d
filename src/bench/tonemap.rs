//! `hdrvis bench tonemap`: every operator on synthetic HDR images (1024², 2048² and 4096² by
//! default; sizes beyond one storage binding run in bands of rows, and the table says how many;
//! a size whose RGBA f32 buffer exceeds the adapter's largest buffer is reported as skipped),
//! timed end to end through [`GpuToneMapper::tonemap`] — upload, every pass, readback — after
//! one warm-up call that builds the pipelines. Reports the adapter and the median of the runs,
//! against the targets on 1024² (global operators 30 ms, local ones 300 ms).

use super::{median, process_cpu_ms};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::HdrImage;
use crate::tonemap::gpu::GpuToneMapper;
use crate::tonemap::params::{Operator, ToneMapSettings};
use std::sync::Arc;
use std::time::Instant;

/// One operator on one image size.
#[derive(Clone, Debug)]
pub struct ToneMapBenchRow {
    pub op: &'static str,
    pub local: bool,
    pub size: u32,
    pub runs_ms: Vec<f64>,
    /// Processor time of the whole process (every thread, the CPU rasterizer's included) per
    /// run, where the OS reports it: less sensitive than wall time to other work on the machine.
    pub cpu_ms: Option<f64>,
    /// Bands of rows the image was processed in (1: every buffer bound whole).
    pub bands: usize,
    /// Why this size was not run (the image does not fit this adapter's largest buffer).
    pub skipped: Option<String>,
}

impl ToneMapBenchRow {
    pub(crate) fn median_ms(&self) -> f64 {
        median(&self.runs_ms)
    }

    /// The target for 1024² images (30 ms global, 300 ms local); none for other sizes.
    pub(crate) fn target_ms(&self) -> Option<f64> {
        (self.size == 1024).then_some(if self.local { 300.0 } else { 30.0 })
    }
}

/// A smooth synthetic HDR image spanning about seven decades, with coloured structure at
/// several scales (the same pattern at any size), alpha 1.
pub(crate) fn synthetic_hdr(width: u32, height: u32) -> HdrImage {
    let sx = width as f64 / 1024.0;
    let sy = height as f64 / 1024.0;
    let pixels = (0..width as u64 * height as u64)
        .map(|i| {
            let x = (i % width as u64) as f64 / sx;
            let y = (i / width as u64) as f64 / sy;
            let l = 10f64
                .powf(3.0 * (x / 130.0).sin() * (y / 110.0).cos() + 0.5 * (x * y / 5000.0).sin());
            [l as f32, (l * 0.7) as f32, (l * 0.4) as f32, 1.0]
        })
        .collect();
    HdrImage::from_pixels(width, height, pixels)
}

/// The image sides of the benchmark: 1024, 2048 and 4096, or with `quick` only 1024.
pub fn sizes(quick: bool) -> &'static [u32] {
    if quick {
        &[1024]
    } else {
        &[1024, 2048, 4096]
    }
}

/// Times every operator on square synthetic images of each size: one warm-up, then `runs`.
pub fn bench_tonemap(
    ctx: Arc<GpuContext>,
    sizes: &[u32],
    runs: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<ToneMapBenchRow>> {
    let mapper = GpuToneMapper::new(ctx);
    let runs = runs.max(1);
    let mut rows = Vec::new();
    let caps = mapper.context().caps.clone();
    let limit = caps.max_buffer_size;
    for &size in sizes {
        let bytes = size as u64 * size as u64 * 16;
        if bytes > limit {
            let why = format!(
                "{size}x{size} RGBA f32 is {} MiB; this adapter's buffers hold at most {} MiB",
                bytes >> 20,
                limit >> 20
            );
            progress(&format!("skipping: {why}"));
            rows.extend(Operator::ALL.iter().map(|op| ToneMapBenchRow {
                op: op.name(),
                local: op.is_local(),
                size,
                runs_ms: Vec::new(),
                cpu_ms: None,
                bands: 0,
                skipped: Some(why.clone()),
            }));
            continue;
        }
        progress(&format!("generating a {size}x{size} HDR image"));
        let img = synthetic_hdr(size, size);
        for op in Operator::ALL {
            let settings = ToneMapSettings {
                op,
                ..Default::default()
            };
            mapper.tonemap(&img, &settings)?;
            let mut runs_ms = Vec::with_capacity(runs);
            let cpu_before = process_cpu_ms();
            for _ in 0..runs {
                let t = Instant::now();
                let out = mapper.tonemap(&img, &settings)?;
                runs_ms.push(t.elapsed().as_secs_f64() * 1e3);
                drop(out);
            }
            let cpu_ms = match (cpu_before, process_cpu_ms()) {
                (Some(a), Some(b)) => Some((b - a) / runs as f64),
                _ => None,
            };
            let row = ToneMapBenchRow {
                op: op.name(),
                local: op.is_local(),
                size,
                runs_ms,
                cpu_ms,
                bands: mapper.bands_for(size, size, &op)?,
                skipped: None,
            };
            progress(&format!(
                "{:15} {size}x{size}: median {:.1} ms ({} band{})",
                row.op,
                row.median_ms(),
                row.bands,
                if row.bands == 1 { "" } else { "s" }
            ));
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The benchmark's table: adapter, then one line per operator and size.
pub fn format_tonemap_table(adapter: &str, rows: &[ToneMapBenchRow]) -> String {
    let mut s = format!(
        "adapter: {adapter}\ntone mapping, end to end (upload, passes, readback), median of {} runs after a warm-up\n",
        rows.iter().map(|r| r.runs_ms.len()).max().unwrap_or(0)
    );
    s += &format!(
        "{:15} {:>6} {:>11} {:>6} {:>11} {:>11} {:>11}  {}\n",
        "operator", "kind", "image", "bands", "median ms", "CPU ms/run", "Mpx/s", "target"
    );
    for r in rows {
        if let Some(why) = &r.skipped {
            s += &format!(
                "{:15} {:>6} {:>11}  skipped: {why}\n",
                r.op,
                if r.local { "local" } else { "global" },
                format!("{}x{}", r.size, r.size),
            );
            continue;
        }
        let mpx = (r.size as f64).powi(2) / 1e6 / (r.median_ms() / 1e3);
        let target = match r.target_ms() {
            Some(t) if r.median_ms() <= t => format!("<= {t} ms: met"),
            Some(t) => format!("<= {t} ms: MISSED"),
            None => String::new(),
        };
        s += &format!(
            "{:15} {:>6} {:>11} {:>6} {:>11.1} {:>11} {:>11.1}  {}\n",
            r.op,
            if r.local { "local" } else { "global" },
            format!("{}x{}", r.size, r.size),
            r.bands,
            r.median_ms(),
            r.cpu_ms.map_or("-".to_string(), |c| format!("{c:.0}")),
            mpx,
            target
        );
    }
    s
}
