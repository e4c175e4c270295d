//! What accuracy costs (`hdrvis bench accuracy`): on the volume scenes (mantle, blobs) each
//! compositing precision (u8, f16, f32, f32c, f64 on the CPU) and coarser steps, timed and
//! compared with the f64 CPU reference on the same rays and transfer table; on the surface scenes
//! of the paper's case studies (tsunami, Fig. 3; fault, Fig. 4) the interference phase evaluated
//! naively in f32 and range-reduced, timed (the fringe pass) and compared with the f64 fringe
//! image — relative RMS and maximum error, PSNR of the 8-bit tone-mapped view, and the fraction
//! of pixels that lost detail — as a table, CSV, JSON and a log–log chart of error against time.
//! The `shell` scene sets the mantle rendered natively on its spherical grid against the paper's
//! way, the shell resampled onto boxes of 128³, 256³ and 513³ voxels (`super::spherical`).

mod report;
mod shell;
mod surface;
mod tonemap;

pub use report::{format_accuracy_table, write_accuracy_chart, write_accuracy_files};
use shell::shell_rows;
use surface::bench_surface_scene;
use tonemap::tonemap_rows;

use super::{bench_tf, bench_volume, mantle_fig5_tf, median};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Camera, Grid, Scale, TransferFunction, Volume};
use crate::render::session::RenderSession;
use crate::render::surface::{FringeMode, SurfaceOptions};
use crate::render::volume::GpuVolume;
use crate::render::VolumeRenderOptions;
use crate::render::VolumeSource;
use std::sync::Arc;

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
    /// What the row is compared with: `SAME_STEP` (arithmetic alone), `CONVERGED` (the
    /// integral itself, for the step and sampling knobs) or the surfaces' per-node f64 phase.
    pub reference: &'static str,
    /// Memory of the voxels rendered, MiB (NaN where not measured: all but the shell scene).
    pub memory_mib: f64,
    /// Milliseconds spent preparing the volume (the shell scene's resampling; NaN elsewhere).
    pub prepare_ms: f64,
}

/// Reference of the precision rows: f64 on the same rays, steps and table.
pub(crate) const SAME_STEP: &str = "f64 same step";
/// Reference of the step and transfer-function-sampling rows: f64 at 1/8 of the scene's step,
/// pre-integrated, close enough to the integral itself that a knob's own error shows.
pub(crate) const CONVERGED: &str = "f64 pre step/8";
/// Reference of the surface rows.
pub(crate) const PER_NODE: &str = "f64 per node";

/// A named accuracy scene.
pub struct AccuracyScene {
    pub name: String,
    pub kind: SceneKind,
}

/// What an accuracy scene renders.
pub enum SceneKind {
    /// A volume ray cast: the compositing precisions and step sizes are compared.
    Volume {
        volume: Volume,
        options: VolumeRenderOptions,
    },
    /// An interference surface in map view at one pixel per node: the phase methods are
    /// compared on its fringe intensity I = (1 + cos 2πν·d)/2.
    Surface {
        grid: Grid,
        options: Box<SurfaceOptions>,
    },
    /// A spherical shell rendered natively and resampled onto boxes of `boxes` voxels a side.
    Shell {
        volume: Volume,
        options: VolumeRenderOptions,
        boxes: Vec<usize>,
    },
    /// The local tone-mapping operators on the GPU against their exact definitions on the
    /// CPU, on lights of 1, 2 and 16 pixels and on noise (`tonemap.rs`; scenes of its own size).
    ToneMap,
}

/// Names of the built-in scenes, in report order.
pub(crate) const SCENE_NAMES: &[&str] = &[
    "mantle", "blobs", "band", "tsunami", "fault", "shell", "tonemap",
];

/// Sides of the resampled boxes of the shell scene: the paper's 513³ and two coarser; `quick`,
/// two small ones for tests.
pub fn shell_boxes(quick: bool) -> Vec<usize> {
    if quick {
        vec![32, 64]
    } else {
        vec![128, 256, 513]
    }
}

/// The built-in accuracy scenes: the mantle's temperature fluctuation (symlog TF, as in the
/// demo), the HDR blobs of the volume benchmark (log10 TF) and the same blobs through a narrow
/// band of the TF (one tenth of a decade around 0.01, bright and opaque: the case that
/// pre-integration is for), all in perspective, `size`²
/// pixels from `n`³ voxels; and the paper's two surface case studies on `grid`² nodes
/// (`tsunami_scene`, `fault_scene`), generated through the dataset cache; and the mantle's
/// shell on the spherical grid of an `n`³ box against its resampled `boxes`.
pub fn accuracy_scenes(
    size: u32,
    n: usize,
    grid: usize,
    only: Option<&str>,
    boxes: &[usize],
) -> Result<Vec<AccuracyScene>> {
    if let Some(name) = only {
        if !SCENE_NAMES.contains(&name) {
            return Err(Error::invalid(
                "scene",
                format!("unknown scene {name:?}; known: {}", SCENE_NAMES.join(", ")),
            ));
        }
    }
    let wants = |name: &str| only.is_none_or(|o| o == name);
    let mut scenes = Vec::new();
    if wants("mantle") || wants("blobs") || wants("band") {
        scenes.extend(volume_scenes(size, n, only)?);
    }
    if wants("tsunami") {
        scenes.push(tsunami_scene(grid)?);
    }
    if wants("fault") {
        scenes.push(fault_scene(grid)?);
    }
    if wants("shell") {
        let volume = super::spherical::native_mantle(n)?;
        let options = super::spherical::shell_options(&volume, size)?;
        scenes.push(AccuracyScene {
            name: "shell".into(),
            kind: SceneKind::Shell {
                volume,
                options,
                boxes: boxes.to_vec(),
            },
        });
    }
    if wants("tonemap") {
        scenes.push(AccuracyScene {
            name: "tonemap".into(),
            kind: SceneKind::ToneMap,
        });
    }
    Ok(scenes)
}

/// The paper's case I (Fig. 3) at large ν·d: the total water column over the sea floor at the
/// wave's maximum, depth + max |η| (m; land missing), of the generated South-China-Sea-like
/// tsunami on `n`² cells, at ν = 10 per metre (one fringe per 10 cm of wave height, as
/// `scripts/tsunami.rhai`): metres of wave on kilometres of water put ν·d at 10⁴–4·10⁴.
pub(crate) fn tsunami_scene(n: usize) -> Result<AccuracyScene> {
    use crate::datasets::generate::{BathymetrySource, Job, OutputFormat, TsunamiJob};
    let job = TsunamiJob {
        bathymetry: BathymetrySource::Synthetic {
            n,
            extent_m: crate::datasets::tsunami::SOUTH_CHINA_SEA_EXTENT_M,
        },
        ..Default::default()
    };
    let path = Job::Tsunami(job).run_cached(OutputFormat::NetCdf, &mut |_| Ok(()))?;
    let g = crate::datasets::load_grid(&path, None)?;
    let (eta, depth) = (g.property("max_abs_eta")?, g.property("depth")?);
    let column: Vec<f64> = eta
        .iter()
        .zip(depth)
        .map(|(&e, &h)| if h > 0.0 { h + e } else { f64::NAN })
        .collect();
    let grid = Grid::from_arrays("tsunami", g.nx(), g.ny(), vec![("column".into(), column)])?;
    Ok(AccuracyScene {
        name: "tsunami".into(),
        kind: SceneKind::Surface {
            grid,
            options: Box::new(surface_options(10.0)),
        },
    })
}

/// The paper's case II (Fig. 4) at large ν·d: the vertical displacement uz of the paper's
/// buried normal fault (Okada 1985) on `n`² nodes at ν = 8 per metre (the paper's value), as
/// an absolute position 100 km from the frame's origin (as projected or geocentric coordinates
/// are): ν·d ≈ 8·10⁵, while the displacement itself varies by metres.
pub(crate) fn fault_scene(n: usize) -> Result<AccuracyScene> {
    use crate::datasets::generate::{Job, OkadaJob, OutputFormat};
    let job = OkadaJob {
        n,
        ..Default::default()
    };
    let path = Job::Okada(job).run_cached(OutputFormat::NetCdf, &mut |_| Ok(()))?;
    let g = crate::datasets::load_grid(&path, None)?;
    let uz: Vec<f64> = g.property("uz")?.iter().map(|&v| 1.0e5 + v).collect();
    let grid = Grid::from_arrays("fault", g.nx(), g.ny(), vec![("uz".into(), uz)])?;
    Ok(AccuracyScene {
        name: "fault".into(),
        kind: SceneKind::Surface {
            grid,
            options: Box::new(surface_options(8.0)),
        },
    })
}

fn surface_options(nu: f64) -> SurfaceOptions {
    SurfaceOptions {
        nu: vec![nu],
        mode: FringeMode::Cyclic,
        ..Default::default()
    }
}

fn volume_scenes(size: u32, n: usize, only: Option<&str>) -> Result<Vec<AccuracyScene>> {
    use crate::model::transfer::LutTransfer;
    let mantle = super::mantle_fluctuation(n, 7)?;
    let mantle_tf = TransferFunction::Lut(mantle_fig5_tf());
    let blobs = bench_volume(n)?;
    // t = 0.4 is 10^-2 on the blobs' log10 scale over [1e-4, 10].
    let band_tf = TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        domain: Some([1e-4, 10.0]),
        colormap: "inferno".into(),
        emission: vec![
            [0.0, -3.0],
            [0.39, -3.0],
            [0.4, 1.0],
            [0.41, -3.0],
            [1.0, -3.0],
        ],
        opacity: vec![
            [0.0, -5.0],
            [0.39, -5.0],
            [0.4, -0.5],
            [0.41, -5.0],
            [1.0, -5.0],
        ],
        ..Default::default()
    });
    let mut scenes = Vec::new();
    for (name, volume, tf) in [
        ("mantle", mantle, mantle_tf),
        ("blobs", blobs.clone(), bench_tf()),
        ("band", blobs, band_tf),
    ] {
        if only.is_some_and(|o| o != name) {
            continue;
        }
        let mut o =
            VolumeRenderOptions::new(Camera::orbit(&volume.bounds(), 35.0, 20.0, 25.0)?, tf);
        o.width = size;
        o.height = size;
        o.step = 0.5;
        scenes.push(AccuracyScene {
            name: name.to_string(),
            kind: SceneKind::Volume { volume, options: o },
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
    let max_rel = max_relative(got, reference, 1e-3 * peak);
    let (rel_rms, lost) = (relative_rms(got, reference), lost_detail(got, reference));
    // The same display transform for both: Reinhard global with the reference's statistics is
    // not available per image, so each is tone-mapped on its own, as a user would see it.
    let to_image = |p: &[[f64; 4]]| {
        crate::model::HdrImage::from_pixels(w, h, p.iter().map(|q| q.map(|v| v as f32)).collect())
    };
    let settings = crate::tonemap::params::ToneMapSettings::default();
    let a = crate::tonemap::cpu::tonemap_cpu(&to_image(got), &settings)?.to_srgb8();
    let b = crate::tonemap::cpu::tonemap_cpu(&to_image(reference), &settings)?.to_srgb8();
    Ok((rel_rms, max_rel, psnr_8bit(&a, &b), lost))
}

/// Largest |x − ref| / max(|ref|, floor) over the colour channels.
pub(crate) fn max_relative(got: &[[f64; 4]], reference: &[[f64; 4]], floor: f64) -> f64 {
    got.iter()
        .zip(reference)
        .flat_map(|(g, r)| (0..3).map(move |c| (g[c] - r[c]).abs() / r[c].abs().max(floor)))
        .fold(0.0f64, f64::max)
}

/// PSNR of one 8-bit picture against another, dB (infinite when they are equal).
pub(crate) fn psnr_8bit(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    let mse = a
        .iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (f64::from(x[c]) - f64::from(y[c])).powi(2)))
        .sum::<f64>()
        / (3 * a.len()) as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

/// Times every variant on each scene and measures its error against the f64 CPU reference
/// (which is also timed, as the `f64 (CPU)` variant).
pub fn bench_accuracy(
    ctx: Arc<GpuContext>,
    scenes: &[AccuracyScene],
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>> {
    let mut rows = Vec::new();
    for scene in scenes {
        match &scene.kind {
            SceneKind::Volume { volume, options } => rows.extend(bench_volume_scene(
                ctx.clone(),
                &scene.name,
                volume,
                options,
                runs,
                log,
            )?),
            SceneKind::Surface { grid, options } => rows.extend(bench_surface_scene(
                ctx.clone(),
                &scene.name,
                grid,
                options,
                runs,
                log,
            )?),
            SceneKind::Shell {
                volume,
                options,
                boxes,
            } => rows.extend(shell_rows(
                ctx.clone(),
                &scene.name,
                volume,
                options,
                boxes,
                runs,
                log,
            )?),
            SceneKind::ToneMap => rows.extend(tonemap_rows(ctx.clone(), runs, log)?),
        }
    }
    Ok(rows)
}

/// A row scored against `reference`: the median of `ms` and the error metrics of `got`.
pub(crate) fn scored_row(
    scene: &str,
    variant: String,
    ms: &[f64],
    got: &[[f64; 4]],
    reference: &[[f64; 4]],
    (width, height): (u32, u32),
    against: &'static str,
) -> Result<AccuracyRow> {
    let (rel_rms, max_rel, psnr_8bit, lost_detail) =
        accuracy_metrics(got, reference, width, height)?;
    Ok(AccuracyRow {
        scene: scene.to_string(),
        variant,
        median_ms: median(ms),
        rel_rms,
        max_rel,
        psnr_8bit,
        lost_detail,
        reference: against,
        memory_mib: f64::NAN,
        prepare_ms: f64::NAN,
    })
}

/// The row of the f64 CPU reference itself: its time, and no error.
pub(crate) fn reference_row(scene: &str, f64_ms: &[f64], against: &'static str) -> AccuracyRow {
    AccuracyRow {
        scene: scene.to_string(),
        variant: "f64 (CPU)".into(),
        median_ms: median(f64_ms),
        rel_rms: 0.0,
        max_rel: 0.0,
        psnr_8bit: f64::INFINITY,
        lost_detail: 0.0,
        reference: against,
        memory_mib: f64::NAN,
        prepare_ms: f64::NAN,
    }
}

/// The milliseconds of each timed run, and the last run's image.
type TimedImage = (Vec<f64>, Vec<[f64; 4]>);

/// The f64 CPU references of one volume scene.
pub(crate) struct VolumeReferences {
    /// Point-sampled at the scene's step and its settings ([`SAME_STEP`]), the last of several
    /// timed renders.
    same_step: Vec<[f64; 4]>,
    /// Milliseconds of each same-step render.
    pub(crate) same_step_ms: Vec<f64>,
    /// The integral itself ([`CONVERGED`]).
    pub(crate) converged: Vec<[f64; 4]>,
    /// Point-sampled at 1/8 of the step, to be scored against `converged`, and its time.
    fine_point: Vec<[f64; 4]>,
    fine_point_ms: f64,
}

/// Renders the f64 CPU references of a volume scene.
pub(crate) fn volume_references(
    name: &str,
    volume: &Volume,
    options: &VolumeRenderOptions,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<VolumeReferences> {
    use crate::render::cpu_reference::render_volume_f64;
    use crate::render::{Precision, TfSampling};
    log(&format!("{name}: f64 reference on the CPU ..."));
    let mut o = options.clone();
    o.precision = Precision::F64;
    let mut same_step_ms = Vec::new();
    let mut same_step = Vec::new();
    for _ in 0..runs.clamp(1, 3) {
        let t = std::time::Instant::now();
        same_step = render_volume_f64(volume, &o)?;
        same_step_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    // The integral itself, for the step and sampling knobs: pre-integrated at 1/8 of the step,
    // whose error depends on how far the data bend between samples, not on how sharp the
    // transfer function is. The point-sampled f64 render at the same step is scored against
    // it, to show how far the reference itself can be trusted.
    log(&format!("{name}: f64 references at 1/8 of the step ..."));
    o.step = options.step / 8.0;
    o.tf_sampling = TfSampling::PreIntegrated;
    let converged = render_volume_f64(volume, &o)?;
    o.tf_sampling = TfSampling::Point;
    let t = std::time::Instant::now();
    let fine_point = render_volume_f64(volume, &o)?;
    let fine_point_ms = t.elapsed().as_secs_f64() * 1e3;
    Ok(VolumeReferences {
        same_step,
        same_step_ms,
        converged,
        fine_point,
        fine_point_ms,
    })
}

/// One warm-up render (pipeline build), then `runs` timed ones through the session's entry
/// point; the last image is returned.
pub(crate) fn time_volume(
    session: &RenderSession,
    source: &VolumeSource,
    o: &VolumeRenderOptions,
    runs: usize,
) -> Result<TimedImage> {
    let (super::RenderRuns { ms, .. }, last) = super::time_renders(session, source, o, runs)?;
    let got = last
        .image
        .pixels
        .iter()
        .map(|p| p.map(|v| v as f64))
        .collect();
    Ok((ms, got))
}

/// f64 on the GPU where the adapter has shader f64 (lavapipe does): one warm-up render, then
/// `runs` timed ones and the last image; `None` where the adapter has no shader f64. The kernel
/// is called directly, not through `render_volume`: its f64 pixels are scored before an image
/// would round them to f32.
fn time_volume_f64_gpu(
    ctx: Arc<GpuContext>,
    gv: &GpuVolume,
    o: &VolumeRenderOptions,
    runs: usize,
) -> Result<Option<TimedImage>> {
    let f64_gpu = crate::render::volume_f64::F64RayCaster::new(ctx);
    if !f64_gpu.available() {
        return Ok(None);
    }
    f64_gpu.render(gv, o)?;
    let mut ms = Vec::new();
    let mut got = Vec::new();
    for _ in 0..runs.max(1) {
        let t = std::time::Instant::now();
        got = f64_gpu.render(gv, o)?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    Ok(Some((ms, got)))
}

/// A setting as the accuracy and equal-error tables name it: "f32 step 2", "f16 pre step 1".
pub(crate) fn setting_name(
    precision: crate::render::Precision,
    step: f64,
    sampling: crate::render::TfSampling,
) -> String {
    use crate::render::TfSampling;
    match sampling {
        TfSampling::Point => format!("{} step {step}", precision.name()),
        TfSampling::PreIntegrated => format!("{} pre step {step}", precision.name()),
    }
}

/// The compositing precisions and coarser steps on one volume scene.
fn bench_volume_scene(
    ctx: Arc<GpuContext>,
    name: &str,
    volume: &Volume,
    options: &VolumeRenderOptions,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>> {
    use crate::render::{Precision, TfSampling};
    let session = super::timing_session(ctx.clone());
    let shared = Arc::new(volume.clone());
    // One upload serves the timed renders and the f64 kernel.
    let gv = session.upload(&shared)?;
    let source = VolumeSource::Memory(shared);
    let refs = volume_references(name, volume, options, runs, log)?;
    let row = |variant: String, ms: &[f64], got: &[[f64; 4]], against: &'static str| {
        let reference = if against == CONVERGED {
            &refs.converged
        } else {
            &refs.same_step
        };
        let size = (options.width, options.height);
        scored_row(name, variant, ms, got, reference, size, against)
    };
    // The references' settings at the scene's step, point-sampled.
    let mut o = options.clone();
    o.precision = Precision::F64;
    o.tf_sampling = TfSampling::Point;
    let mut rows = Vec::new();
    for precision in [
        Precision::U8,
        Precision::F16,
        Precision::F32,
        Precision::F32c,
    ] {
        o.precision = precision;
        let (ms, got) = time_volume(&session, &source, &o, runs)?;
        let r = row(precision.name().into(), &ms, &got, SAME_STEP)?;
        log(&format!(
            "{name} {}: {:.1} ms, rel RMS {:.2e}",
            r.variant, r.median_ms, r.rel_rms
        ));
        rows.push(r);
    }
    o.precision = Precision::F64;
    if let Some((ms, got)) = time_volume_f64_gpu(ctx, &gv, &o, runs)? {
        rows.push(row("f64 (GPU)".into(), &ms, &got, SAME_STEP)?);
    }
    rows.push(row(
        format!("f64 step {}", options.step / 8.0),
        &[refs.fine_point_ms],
        &refs.fine_point,
        CONVERGED,
    )?);
    // The other knobs, in f32 against the integral itself: coarser steps, and the transfer
    // function pre-integrated over each segment rather than sampled at its middle.
    o.precision = Precision::F32;
    for factor in [1.0, 2.0, 4.0] {
        o.step = options.step * factor;
        for sampling in [TfSampling::Point, TfSampling::PreIntegrated] {
            o.tf_sampling = sampling;
            let (ms, got) = time_volume(&session, &source, &o, runs)?;
            let variant = setting_name(o.precision, o.step, sampling);
            rows.push(row(variant, &ms, &got, CONVERGED)?);
        }
    }
    rows.push(reference_row(name, &refs.same_step_ms, SAME_STEP));
    Ok(rows)
}
