//! The volume benchmark (`hdrvis bench volume`): the ray caster on the HDR blobs, axis view, one
//! sample per voxel, optionally with VTK's GPU ray caster run side by side on the same data
//! (`--peer vtk`) and the cost of each stage of a sample (`--breakdown`).

use super::{bench_tf, bench_volume, median, time_renders, timing_session};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Axis, Camera, Volume};
use crate::render::volume::{GpuVolume, SampleWork, VolumeRenderer};
use crate::render::{VolumeRenderOptions, VolumeSource};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub name: String,
    /// Samples a ray-caster takes at one sample per voxel without early termination.
    pub samples: u64,
    pub runs_ms: Vec<f64>,
    pub peer: Option<PeerResult>,
    /// With `--breakdown`: the frame time of each stage of the per-sample work.
    pub stages: Vec<(SampleWork, Vec<f64>)>,
}

#[derive(Clone, Debug)]
pub struct PeerResult {
    pub name: String,
    pub detail: String,
    pub median_ms: Option<f64>,
    pub error: Option<String>,
}

impl BenchRow {
    pub(crate) fn median_ms(&self) -> f64 {
        median(&self.runs_ms)
    }
    pub(crate) fn msamples_per_s(&self) -> f64 {
        self.samples as f64 / 1e6 / (self.median_ms() / 1e3)
    }
}

/// The (volume side, image side) pairs of the benchmark: 256³ → 512², and with `quick` off
/// also 513³ → 1024².
pub fn volume_sizes(quick: bool) -> &'static [(usize, u32)] {
    if quick {
        &[(256, 512)]
    } else {
        &[(256, 512), (513, 1024)]
    }
}

/// Times the volume ray caster on `sizes` (volume side, image side), axis view, one sample per
/// voxel; with `breakdown`, also each stage of the per-sample work (SampleWork).
pub fn bench_volume_render(
    ctx: Arc<GpuContext>,
    sizes: &[(usize, u32)],
    runs: usize,
    peer: Option<&Path>,
    breakdown: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<BenchRow>> {
    let session = timing_session(ctx);
    let mut rows = Vec::new();
    for &(n, px) in sizes {
        log(&format!("generating {n}^3 volume ..."));
        let vol = Arc::new(bench_volume(n)?);
        let mut opts = VolumeRenderOptions::new(Camera::axis(Axis::Z, &vol.bounds()), bench_tf());
        opts.width = px;
        opts.height = px;
        opts.step = 1.0;
        // Warm-up: pipeline compilation and first-touch costs are not part of a frame.
        let source = VolumeSource::Memory(vol.clone());
        let (runs_ms, _) = time_renders(&session, &source, &opts, runs)?;
        let name = format!("{n}^3 -> {px}^2");
        log(&format!("{name}: median {:.1} ms", median(&runs_ms)));
        let mut stages: Vec<(SampleWork, Vec<f64>)> = Vec::new();
        if breakdown {
            log(&format!("{name}: timing the stages of a sample ..."));
            // The shader with its samples cut short (SampleWork): an instrument on the renderer
            // itself, not a render users get; it reads the session's upload.
            let gv = session.upload(&vol)?;
            stages = time_sample_stages(&*session.volume_renderer()?, &gv, &opts, runs)?;
        }
        let peer_result = peer.map(|script| run_vtk_peer(script, &vol, px, runs, log));
        rows.push(BenchRow {
            name,
            samples: px as u64 * px as u64 * n as u64,
            runs_ms,
            peer: peer_result,
            stages,
        });
    }
    Ok(rows)
}

/// The frame time of each stage of the per-sample work (SampleWork), after one warm-up each,
/// alternating the stages run by run so that drift of the machine's speed spreads over all of
/// them.
fn time_sample_stages(
    renderer: &VolumeRenderer,
    gv: &GpuVolume,
    opts: &VolumeRenderOptions,
    runs: usize,
) -> Result<Vec<(SampleWork, Vec<f64>)>> {
    let mut stages: Vec<(SampleWork, Vec<f64>)> =
        SampleWork::ALL.iter().map(|&w| (w, Vec::new())).collect();
    for (work, _) in &stages {
        renderer.render_work(gv, opts, *work)?;
    }
    for _ in 0..runs.max(1) {
        for (work, times) in stages.iter_mut() {
            let (_, t) = renderer.render_work(gv, opts, *work)?;
            times.push(t.seconds * 1e3);
        }
    }
    Ok(stages)
}

/// Runs VTK's vtkGPUVolumeRayCastMapper through `tests/python/vtk_volume_bench.py` on the same
/// volume, image size, sample distance and (sampled) transfer function.
fn run_vtk_peer(
    script: &Path,
    vol: &Volume,
    px: u32,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> PeerResult {
    let fail = |e: String| PeerResult {
        name: "vtk".into(),
        detail: String::new(),
        median_ms: None,
        error: Some(e),
    };
    let dir = match tempfile::tempdir() {
        Ok(d) => d,
        Err(e) => return fail(e.to_string()),
    };
    let (npy, tf_path) = match write_peer_inputs(dir.path(), vol) {
        Ok(paths) => paths,
        Err(e) => return fail(e),
    };
    log(&format!("running peer vtk at {px}^2 ..."));
    let out = std::process::Command::new("python3")
        .arg(script)
        .args(["--npy", &npy.display().to_string()])
        .args(["--width", &px.to_string(), "--height", &px.to_string()])
        .args([
            "--sample-distance",
            "1.0",
            "--runs",
            &runs.max(1).to_string(),
        ])
        .args(["--tf", &tf_path.display().to_string()])
        .output();
    let out = match out {
        Ok(o) => o,
        Err(e) => return fail(format!("cannot run python3: {e}")),
    };
    if !out.status.success() {
        return fail(
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("failed")
                .to_string(),
        );
    }
    parse_peer_output(&String::from_utf8_lossy(&out.stdout)).unwrap_or_else(fail)
}

/// Writes the peer's inputs into `dir`: the volume as `volume.npy` and the transfer function
/// as `tf.json`; returns their paths, or the error's text.
fn write_peer_inputs(dir: &Path, vol: &Volume) -> std::result::Result<(PathBuf, PathBuf), String> {
    let npy = dir.join("volume.npy");
    crate::datasets::npy::write_npy_f32(&npy, &[vol.dims[2], vol.dims[1], vol.dims[0]], &vol.data)
        .map_err(|e| e.to_string())?;
    let json = peer_tf_json(vol).map_err(|e| e.to_string())?;
    let tf_path = dir.join("tf.json");
    std::fs::write(&tf_path, json).map_err(|e| e.to_string())?;
    Ok((npy, tf_path))
}

/// The benchmark transfer function as the peer reads it. VTK's transfer functions are piecewise
/// linear in the value: ours is sampled at log-spaced values.
fn peer_tf_json(vol: &Volume) -> Result<String> {
    let tf = bench_tf().resolve(&vol.stats())?;
    let mut color = Vec::new();
    let mut opacity = Vec::new();
    for i in 0..=64 {
        let v = 10f64.powf(-4.0 + 5.0 * i as f64 / 64.0);
        let (e, s) = tf.eval(v);
        color.push(format!(
            "[{v:e}, {}, {}, {}]",
            e[0].min(1.0),
            e[1].min(1.0),
            e[2].min(1.0)
        ));
        opacity.push(format!("[{v:e}, {}]", -(-s).exp_m1()));
    }
    Ok(format!(
        "{{\"color\": [{}], \"opacity\": [{}], \"scalar_opacity_unit_distance\": 1.0}}",
        color.join(", "),
        opacity.join(", ")
    ))
}

/// The peer's result from the last JSON line of its output, or why there is none.
fn parse_peer_output(text: &str) -> std::result::Result<PeerResult, String> {
    let line = text
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .unwrap_or("");
    let field = |key: &str| -> Option<String> {
        let start = line.find(&format!("\"{key}\""))? + key.len() + 3;
        let rest = line[start..].trim_start();
        if let Some(stripped) = rest.strip_prefix('"') {
            Some(stripped[..stripped.find('"')?].to_string())
        } else {
            Some(
                rest[..rest.find([',', '}']).unwrap_or(rest.len())]
                    .trim()
                    .to_string(),
            )
        }
    };
    match field("median_ms").and_then(|m| m.parse::<f64>().ok()) {
        Some(m) => Ok(PeerResult {
            name: "vtk".into(),
            detail: format!(
                "VTK {} on {}",
                field("vtk_version").unwrap_or_default(),
                field("gl_renderer").unwrap_or_default()
            ),
            median_ms: Some(m),
            error: None,
        }),
        None => Err(format!("unexpected peer output: {line}")),
    }
}

/// The script of the peer named by `--peer` (none without one; `vtk` is the only one known).
pub fn peer_script(name: Option<&str>) -> Result<Option<PathBuf>> {
    match name {
        None => Ok(None),
        Some("vtk") => Ok(Some(vtk_peer_script()?)),
        Some(other) => Err(Error::invalid(
            "--peer",
            format!("unknown peer {other:?}; known: vtk"),
        )),
    }
}

/// The peer script, looked up beside the working directory or the crate's source.
fn vtk_peer_script() -> Result<PathBuf> {
    let rel = Path::new("tests/python/vtk_volume_bench.py");
    for base in [
        std::env::current_dir().ok(),
        Some(PathBuf::from(env!("CARGO_MANIFEST_DIR"))),
    ]
    .into_iter()
    .flatten()
    {
        let p = base.join(rel);
        if p.exists() {
            return Ok(p);
        }
    }
    Err(Error::invalid(
        "--peer",
        "tests/python/vtk_volume_bench.py not found; run from the hdrvis source tree",
    ))
}

/// The table `hdrvis bench volume` prints.
pub fn format_volume_table(adapter: &str, rows: &[BenchRow]) -> String {
    let mut s = format!("adapter: {adapter}\nvolume benchmark: HDR blobs, log10 TF, axis view, f32, 1 sample/voxel, median of runs\n");
    s.push_str(&format!(
        "{:<18} {:>12} {:>10} {:>11} {:>11}  {}\n",
        "scene", "samples", "median ms", "Msamples/s", "runs", "peer"
    ));
    for r in rows {
        let peer = match &r.peer {
            None => String::new(),
            Some(p) => match (p.median_ms, &p.error) {
                (Some(m), _) => format!(
                    "{} {:.1} ms ({:.2}x slower than hdrvis) [{}]",
                    p.name,
                    m,
                    m / r.median_ms(),
                    p.detail
                ),
                (None, Some(e)) => format!("peer {} unavailable: {e}", p.name),
                _ => String::new(),
            },
        };
        s.push_str(&format!(
            "{:<18} {:>10.1} M {:>10.1} {:>11.1} {:>11}  {}\n",
            r.name,
            r.samples as f64 / 1e6,
            r.median_ms(),
            r.msamples_per_s(),
            r.runs_ms.len(),
            peer
        ));
    }
    s
}

/// The per-sample cost breakdown of the rows that have one: each stage's median frame time and
/// what it adds to the stage before.
pub fn format_breakdown_table(rows: &[BenchRow]) -> String {
    let mut s = String::new();
    for r in rows.iter().filter(|r| !r.stages.is_empty()) {
        s.push_str(&format!(
            "\n{}: what each part of a sample costs (samples do the stages up to the row)\n",
            r.name
        ));
        s.push_str(&format!(
            "{:<70} {:>10} {:>10}\n",
            "stage", "median ms", "added ms"
        ));
        let mut before = 0.0;
        for (work, times) in &r.stages {
            let m = median(times);
            s.push_str(&format!(
                "{:<70} {:>10.1} {:>10.1}\n",
                work.describe(),
                m,
                m - before
            ));
            before = m;
        }
    }
    s
}
