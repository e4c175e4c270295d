//! Benchmarks (`hdrvis bench …`): timings live here, never in pass/fail tests. Each reports the
//! adapter, the median of several runs and derived rates, and can run a named peer side by side
//! on the same data in the same run.

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Axis, Camera, LutTransfer, Scale, TransferFunction, Volume};
use crate::render::volume::{GpuVolume, SampleWork, VolumeRenderer};
use crate::render::VolumeRenderOptions;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub mod accuracy;
pub mod bricks;
pub mod chart;
pub mod effects;
pub mod surface;
pub mod tonemap;
pub mod tui;

pub use accuracy::{lost_detail, relative_rms};

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub name: String,
    pub image: (u32, u32),
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

impl BenchRow {
    pub fn median_ms(&self) -> f64 {
        median(&self.runs_ms)
    }
    pub fn msamples_per_s(&self) -> f64 {
        self.samples as f64 / 1e6 / (self.median_ms() / 1e3)
    }
}

/// The mantle's temperature fluctuation on n³ voxels over [-1, 1]³ (missing outside the shell):
/// the volume of the effects, skipping and accuracy benchmarks.
pub fn mantle_fluctuation(n: usize, seed: u64) -> Result<Volume> {
    use crate::datasets::mantle::{generate, MantleField, MantleFields, MantleOptions};
    let m = generate(
        &MantleOptions {
            n,
            seed,
            fields: MantleFields::only(MantleField::Fluctuation),
            ..Default::default()
        },
        &mut |_| {},
    )?;
    Volume::new(
        format!("mantle fluctuation {n}^3"),
        [n; 3],
        [2.0 / n as f64; 3],
        [-1.0; 3],
        m.fluctuation,
    )
}

/// The benchmark volume: Gaussian blobs spanning five decades over a faint floor, like the
/// HDR fields of the paper, generated in memory (not timed).
pub fn bench_volume(n: usize) -> Result<Volume> {
    let f = n as f64;
    Volume::from_fn(&format!("hdr-blobs {n}^3"), [n, n, n], move |x, y, z| {
        let g = |cx: f64, cy: f64, cz: f64, s: f64, amp: f64| {
            let d2 = (x - cx * f).powi(2) + (y - cy * f).powi(2) + (z - cz * f).powi(2);
            amp * (-d2 / (2.0 * (s * f).powi(2))).exp()
        };
        1e-4 + g(0.35, 0.4, 0.5, 0.10, 10.0)
            + g(0.65, 0.6, 0.45, 0.14, 0.05)
            + g(0.5, 0.3, 0.65, 0.06, 1e-3)
    })
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

/// Times the volume ray caster on `sizes` (volume side, image side), axis view, one sample per
/// voxel; with `breakdown`, also each stage of the per-sample work (SampleWork), alternating the
/// stages run by run so that drift of the machine's speed spreads over all of them.
pub fn bench_volume_render(
    ctx: Arc<GpuContext>,
    sizes: &[(usize, u32)],
    runs: usize,
    peer: Option<&Path>,
    breakdown: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<BenchRow>> {
    let renderer = VolumeRenderer::new(ctx);
    let mut rows = Vec::new();
    for &(n, px) in sizes {
        log(&format!("generating {n}^3 volume ..."));
        let vol = bench_volume(n)?;
        let gv = GpuVolume::upload(renderer.context(), &vol)?;
        let mut opts = VolumeRenderOptions::new(Camera::axis(Axis::Z, &vol.bounds()), bench_tf());
        opts.width = px;
        opts.height = px;
        opts.step = 1.0;
        // Warm-up: pipeline compilation and first-touch costs are not part of a frame.
        renderer.render(&gv, &opts)?;
        let mut runs_ms = Vec::new();
        for _ in 0..runs.max(1) {
            let (_, t) = renderer.render(&gv, &opts)?;
            runs_ms.push(t.seconds * 1e3);
        }
        let name = format!("{n}^3 -> {px}^2");
        log(&format!("{name}: median {:.1} ms", median(&runs_ms)));
        let mut stages: Vec<(SampleWork, Vec<f64>)> = Vec::new();
        if breakdown {
            log(&format!("{name}: timing the stages of a sample ..."));
            stages = SampleWork::ALL.iter().map(|&w| (w, Vec::new())).collect();
            for (work, _) in &stages {
                renderer.render_work(&gv, &opts, *work)?;
            }
            for _ in 0..runs.max(1) {
                for (work, times) in stages.iter_mut() {
                    let (_, t) = renderer.render_work(&gv, &opts, *work)?;
                    times.push(t.seconds * 1e3);
                }
            }
        }
        let peer_result = peer.map(|script| run_vtk_peer(script, &vol, px, runs, log));
        rows.push(BenchRow {
            name,
            image: (px, px),
            samples: px as u64 * px as u64 * n as u64,
            runs_ms,
            peer: peer_result,
            stages,
        });
    }
    Ok(rows)
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
    let npy = dir.path().join("volume.npy");
    if let Err(e) = crate::datasets::npy::write_npy_f32(
        &npy,
        &[vol.dims[2], vol.dims[1], vol.dims[0]],
        &vol.data,
    ) {
        return fail(e.to_string());
    }
    // VTK's transfer functions are piecewise linear in the value: sample ours at log-spaced values.
    let tf = match bench_tf().resolve(&vol.stats()) {
        Ok(t) => t,
        Err(e) => return fail(e.to_string()),
    };
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
    let json = format!(
        "{{\"color\": [{}], \"opacity\": [{}], \"scalar_opacity_unit_distance\": 1.0}}",
        color.join(", "),
        opacity.join(", ")
    );
    let tf_path = dir.path().join("tf.json");
    if let Err(e) = std::fs::write(&tf_path, json) {
        return fail(e.to_string());
    }
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
    let text = String::from_utf8_lossy(&out.stdout);
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
        Some(m) => PeerResult {
            name: "vtk".into(),
            detail: format!(
                "VTK {} on {}",
                field("vtk_version").unwrap_or_default(),
                field("gl_renderer").unwrap_or_default()
            ),
            median_ms: Some(m),
            error: None,
        },
        None => fail(format!("unexpected peer output: {line}")),
    }
}

/// The peer script, looked up beside the working directory or the crate's source.
pub fn vtk_peer_script() -> Result<PathBuf> {
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

/// Peak resident memory of this process so far (Linux VmHWM), in MiB.
pub fn peak_memory_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// One generator timing: name, median seconds of the runs, and the process's peak memory after it.
#[derive(Clone, Debug)]
pub struct GeneratorTiming {
    pub name: String,
    pub runs_s: Vec<f64>,
    pub peak_mib: Option<f64>,
}

/// Times the dataset generators at the sizes, each writing its NetCDF output to a
/// temporary folder: Okada on a 1001² grid (the paper's case II), the 513³ mantle (temperature
/// only), and the linear tsunami on 1000² cells for two simulated hours. Run in that order
/// because peak memory is a high-water mark.
pub fn bench_generators(
    runs: usize,
    quick: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<GeneratorTiming>> {
    use crate::datasets::generate::{Job, MantleJob, OkadaJob, TsunamiJob};
    use crate::datasets::mantle::{MantleField, MantleFields, MantleOptions};
    let dir = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let mut tsunami = TsunamiJob::default();
    tsunami.options.duration_s = 7200.0;
    let mut mantle = MantleOptions {
        fields: MantleFields::only(MantleField::Temperature),
        ..Default::default()
    };
    let mut okada = OkadaJob::default();
    if quick {
        okada.n = 201;
        mantle.n = 129;
        tsunami.bathymetry = crate::datasets::generate::BathymetrySource::Synthetic {
            n: 250,
            extent_m: crate::datasets::tsunami::SOUTH_CHINA_SEA_EXTENT_M,
        };
    }
    let jobs = [
        (
            format!("okada {0}x{0} (paper case II)", okada.n),
            Job::Okada(okada),
        ),
        (
            format!("mantle {0}^3 temperature", mantle.n),
            Job::Mantle(MantleJob { options: mantle }),
        ),
        (
            "tsunami synthetic basin, 2 h".to_string(),
            Job::Tsunami(tsunami),
        ),
    ];
    let mut out = Vec::new();
    for (name, job) in jobs {
        let mut runs_s = Vec::new();
        for r in 0..runs.max(1) {
            let path = dir.path().join(format!("{}-{r}.nc", job.kind()));
            let start = std::time::Instant::now();
            job.run(&path, &mut |_| {})?;
            runs_s.push(start.elapsed().as_secs_f64());
            let _ = std::fs::remove_file(&path);
        }
        log(&format!("{name}: median {:.2} s", median(&runs_s)));
        out.push(GeneratorTiming {
            name,
            runs_s,
            peak_mib: peak_memory_mib(),
        });
    }
    Ok(out)
}

pub fn format_generator_table(rows: &[GeneratorTiming]) -> String {
    let mut s = format!(
        "dataset generators (NetCDF output included), {} threads\n",
        rayon::current_num_threads()
    );
    s.push_str(&format!(
        "{:<34} {:>10} {:>6} {:>16}\n",
        "generator", "median s", "runs", "peak memory MiB"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<34} {:>10.2} {:>6} {:>16}\n",
            r.name,
            median(&r.runs_s),
            r.runs_s.len(),
            r.peak_mib
                .map(|m| format!("{m:.0}"))
                .unwrap_or_else(|| "?".into())
        ));
    }
    s
}
