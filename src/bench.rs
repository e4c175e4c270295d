//! Benchmarks (`hdrvis bench …`): timings live here, never in pass/fail tests. Each reports the
//! adapter, the median of several runs and derived rates, and can run a named peer side by side
//! on the same data in the same run.

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Axis, Camera, LutTransfer, Scale, TransferFunction, Volume};
use crate::render::volume::{GpuVolume, VolumeRenderer};
use crate::render::VolumeRenderOptions;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub name: String,
    pub image: (u32, u32),
    /// Samples a ray-caster takes at one sample per voxel without early termination.
    pub samples: u64,
    pub runs_ms: Vec<f64>,
    pub peer: Option<PeerResult>,
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

/// Times the volume ray caster on `sizes` (volume side, image side), axis view, one sample per voxel.
pub fn bench_volume_render(
    ctx: Arc<GpuContext>,
    sizes: &[(usize, u32)],
    runs: usize,
    peer: Option<&Path>,
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
        let peer_result = peer.map(|script| run_vtk_peer(script, &vol, px, runs, log));
        rows.push(BenchRow {
            name,
            image: (px, px),
            samples: px as u64 * px as u64 * n as u64,
            runs_ms,
            peer: peer_result,
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

/// One precision variant's cost and error against the f64 reference.
#[derive(Clone, Debug)]
pub struct AccuracyRow {
    pub scene: String,
    pub variant: String,
    pub median_ms: f64,
    /// sqrt(Σ(x − ref)²) / sqrt(Σ ref²) over the colour channels of the HDR image.
    pub rel_rms: f64,
    /// Largest |x − ref| / max(|ref|, 1e-3 · peak) over the colour channels.
    pub max_rel: f64,
    /// PSNR of the 8-bit Reinhard-tone-mapped image against the reference's, dB (inf when equal).
    pub psnr_8bit: f64,
    /// Fraction of lit pixels whose HDR luminance is off by more than 1 %.
    pub lost_detail: f64,
}

/// A named accuracy scene: a volume and render options.
pub struct AccuracyScene {
    pub name: String,
    pub volume: Volume,
    pub options: VolumeRenderOptions,
}

/// The built-in accuracy scenes: the mantle's temperature fluctuation (symlog TF, as in the
/// demo) and the HDR blobs of the volume benchmark (log10 TF), both in perspective.
pub fn accuracy_scenes(size: u32, n: usize) -> Result<Vec<AccuracyScene>> {
    use crate::datasets::mantle::{generate, MantleField, MantleFields, MantleOptions};
    use crate::model::transfer::LutTransfer;
    let m = generate(
        &MantleOptions {
            n,
            seed: 7,
            fields: MantleFields::only(MantleField::Fluctuation),
            ..Default::default()
        },
        &mut |_| {},
    )?;
    let mantle = Volume::new(
        format!("mantle fluctuation {n}^3"),
        [n; 3],
        [2.0 / n as f64; 3],
        [-1.0; 3],
        m.fluctuation,
    )?;
    let mantle_tf = TransferFunction::Lut(LutTransfer {
        scale: Scale::Symlog { linthresh: 1e-3 },
        domain: Some([-0.3, 0.45]),
        colormap: "spectral".into(),
        emission: vec![[0.0, -1.0], [0.45, -3.0], [0.55, -3.0], [1.0, -0.5]],
        opacity: vec![[0.0, -1.5], [0.4, -3.5], [0.6, -3.5], [1.0, -1.0]],
        ..Default::default()
    });
    let blobs = bench_volume(n)?;
    let mut scenes = Vec::new();
    for (name, volume, tf) in [("mantle", mantle, mantle_tf), ("blobs", blobs, bench_tf())] {
        let mut o =
            VolumeRenderOptions::new(Camera::orbit(&volume.bounds(), 35.0, 20.0, 25.0)?, tf);
        o.width = size;
        o.height = size;
        o.step = 0.5;
        scenes.push(AccuracyScene {
            name: name.to_string(),
            volume,
            options: o,
        });
    }
    Ok(scenes)
}

/// Relative RMS error of the colour channels of `got` against `reference`.
pub fn relative_rms(got: &[[f64; 4]], reference: &[[f64; 4]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (g, r) in got.iter().zip(reference) {
        for c in 0..3 {
            num += (g[c] - r[c]).powi(2);
            den += r[c].powi(2);
        }
    }
    (num / den.max(1e-300)).sqrt()
}

/// Fraction of lit pixels whose Rec. 709 luminance is off by more than 1 % of the reference's.
pub fn lost_detail(got: &[[f64; 4]], reference: &[[f64; 4]]) -> f64 {
    let y = |p: &[f64; 4]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let lit: Vec<_> = got
        .iter()
        .zip(reference)
        .filter(|(_, r)| y(r) > 0.0)
        .collect();
    lit.iter()
        .filter(|(g, r)| (y(g) - y(r)).abs() > 0.01 * y(r))
        .count() as f64
        / lit.len().max(1) as f64
}

fn accuracy_metrics(
    got: &[[f64; 4]],
    reference: &[[f64; 4]],
    w: u32,
    h: u32,
) -> Result<(f64, f64, f64, f64)> {
    let peak = reference
        .iter()
        .map(|p| p[0].max(p[1]).max(p[2]))
        .fold(0.0, f64::max);
    let max_rel = got
        .iter()
        .zip(reference)
        .flat_map(|(g, r)| (0..3).map(move |c| (g[c] - r[c]).abs() / r[c].abs().max(1e-3 * peak)))
        .fold(0.0f64, f64::max);
    let (rel_rms, lost) = (relative_rms(got, reference), lost_detail(got, reference));
    // The same display transform for both: Reinhard global with the reference's statistics is
    // not available per image, so each is tone-mapped on its own, as a user would see it.
    let to_image = |p: &[[f64; 4]]| {
        crate::model::HdrImage::from_pixels(w, h, p.iter().map(|q| q.map(|v| v as f32)).collect())
    };
    let settings = crate::tonemap::params::ToneMapSettings::default();
    let a = crate::tonemap::cpu::to_srgb8(&crate::tonemap::cpu::tonemap_cpu(
        &to_image(got),
        &settings,
    )?);
    let b = crate::tonemap::cpu::to_srgb8(&crate::tonemap::cpu::tonemap_cpu(
        &to_image(reference),
        &settings,
    )?);
    let mse = a
        .iter()
        .zip(&b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).powi(2)))
        .sum::<f64>()
        / (3 * a.len()) as f64;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    };
    Ok((rel_rms, max_rel, psnr, lost))
}

/// Times every precision variant on each scene and measures its error against the f64 CPU
/// reference (which is also timed, as the `f64` variant).
pub fn bench_accuracy(
    ctx: Arc<GpuContext>,
    scenes: &[AccuracyScene],
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>> {
    use crate::render::cpu_reference::render_volume_f64;
    use crate::render::Precision;
    let renderer = VolumeRenderer::new(ctx);
    let mut rows = Vec::new();
    for scene in scenes {
        log(&format!("{}: f64 reference on the CPU ...", scene.name));
        let mut o = scene.options.clone();
        o.precision = Precision::F64;
        let mut f64_ms = Vec::new();
        let mut reference = Vec::new();
        for _ in 0..runs.clamp(1, 3) {
            let t = std::time::Instant::now();
            reference = render_volume_f64(&scene.volume, &o)?;
            f64_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let gv = GpuVolume::upload(renderer.context(), &scene.volume)?;
        for precision in [
            Precision::U8,
            Precision::F16,
            Precision::F32,
            Precision::F32c,
        ] {
            o.precision = precision;
            renderer.render(&gv, &o)?;
            let mut ms = Vec::new();
            let mut last = None;
            for _ in 0..runs.max(1) {
                let (img, t) = renderer.render(&gv, &o)?;
                ms.push(t.seconds * 1e3);
                last = Some(img);
            }
            let img = last.expect("at least one run");
            let got: Vec<[f64; 4]> = img.pixels.iter().map(|p| p.map(|v| v as f64)).collect();
            let (rel_rms, max_rel, psnr_8bit, lost_detail) =
                accuracy_metrics(&got, &reference, o.width, o.height)?;
            log(&format!(
                "{} {}: {:.1} ms, rel RMS {rel_rms:.2e}",
                scene.name,
                precision.name(),
                median(&ms)
            ));
            rows.push(AccuracyRow {
                scene: scene.name.clone(),
                variant: precision.name().into(),
                median_ms: median(&ms),
                rel_rms,
                max_rel,
                psnr_8bit,
                lost_detail,
            });
        }
        rows.push(AccuracyRow {
            scene: scene.name.clone(),
            variant: "f64 (CPU)".into(),
            median_ms: median(&f64_ms),
            rel_rms: 0.0,
            max_rel: 0.0,
            psnr_8bit: f64::INFINITY,
            lost_detail: 0.0,
        });
    }
    Ok(rows)
}

pub fn format_accuracy_table(adapter: &str, rows: &[AccuracyRow]) -> String {
    let mut s = format!("adapter: {adapter}\naccuracy against the f64 CPU reference (same rays, same transfer table)\n");
    s.push_str(&format!(
        "{:<8} {:<10} {:>10} {:>11} {:>11} {:>12} {:>12}\n",
        "scene", "variant", "median ms", "rel RMS", "max rel", "PSNR 8-bit", "lost detail"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<8} {:<10} {:>10.1} {:>11.2e} {:>11.2e} {:>12} {:>11.2}%\n",
            r.scene,
            r.variant,
            r.median_ms,
            r.rel_rms,
            r.max_rel,
            if r.psnr_8bit.is_finite() {
                format!("{:.1} dB", r.psnr_8bit)
            } else {
                "exact".into()
            },
            100.0 * r.lost_detail
        ));
    }
    s
}

/// CSV and JSON of the accuracy rows, written atomically into `dir`.
pub fn write_accuracy_files(dir: &Path, rows: &[AccuracyRow]) -> Result<(PathBuf, PathBuf)> {
    use std::io::Write;
    let csv = dir.join("accuracy.csv");
    let json = dir.join("accuracy.json");
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            "null".into()
        }
    };
    crate::io::write_atomic(&csv, |w| {
        writeln!(
            w,
            "scene,variant,median_ms,rel_rms,max_rel,psnr_8bit_db,lost_detail"
        )
        .map_err(|e| Error::io(&csv, e))?;
        for r in rows {
            writeln!(
                w,
                "{},{},{},{},{},{},{}",
                r.scene,
                r.variant,
                r.median_ms,
                r.rel_rms,
                r.max_rel,
                num(r.psnr_8bit),
                r.lost_detail
            )
            .map_err(|e| Error::io(&csv, e))?;
        }
        Ok(())
    })?;
    crate::io::write_atomic(&json, |w| {
        let items: Vec<String> = rows
            .iter()
            .map(|r| {
                format!(
                    "{{\"scene\": \"{}\", \"variant\": \"{}\", \"median_ms\": {}, \"rel_rms\": {}, \"max_rel\": {}, \"psnr_8bit_db\": {}, \"lost_detail\": {}}}",
                    r.scene, r.variant, num(r.median_ms), num(r.rel_rms), num(r.max_rel), num(r.psnr_8bit), num(r.lost_detail)
                )
            })
            .collect();
        writeln!(w, "[\n  {}\n]", items.join(",\n  ")).map_err(|e| Error::io(&json, e))
    })?;
    Ok((csv, json))
}
