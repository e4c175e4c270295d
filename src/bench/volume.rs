//! The volume benchmark (`hdrvis bench volume`): the ray caster on the HDR blobs (nothing to
//! skip) and on the paper's mantle under its Fig. 5 transfer function (missing data outside the
//! shell and in the core), axis view, one sample per voxel, optionally with VTK's two volume
//! mappers run side by side on the same data (`--peer vtk`: the GPU ray caster on the same
//! llvmpipe, and the fixed-point CPU ray caster on two threads) and the cost of each stage of a
//! sample (`--breakdown`).

use super::equal_error::{self, EqualError, PeerNode};
use super::peer_scenes;
use super::{bench_tf, bench_volume, mantle_fig5_tf, mantle_fluctuation, median, RenderRuns};
use super::{time_renders, timing_session};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Axis, Camera, Volume};
use crate::model::{Scale, TransferFunction};
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
    /// With `--peer`: each of the peer's mappers on the same scene.
    pub peers: Vec<PeerResult>,
    /// With `--breakdown`: the frame time of each stage of the per-sample work.
    pub stages: Vec<(SampleWork, Vec<f64>)>,
    /// The ray-casting pass of each run on the GPU's own clock (empty without timestamps).
    pub gpu_ms: Vec<f64>,
    /// With `--peer`: the peers at equal error.
    pub equal_error: Option<EqualError>,
}

#[derive(Clone, Debug)]
pub struct PeerResult {
    pub name: String,
    pub detail: String,
    /// The median of the mapper's round medians.
    pub median_ms: Option<f64>,
    /// Per round: the mapper's median over hdrvis's median of the same round.
    pub ratios: Vec<f64>,
    /// Why the mapper's rounds ended early, or why it did not run.
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

/// A scene of the volume benchmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeScene {
    /// Gaussian blobs over five decades under a log10 transfer function: nothing to skip.
    Blobs,
    /// The mantle's temperature fluctuation under the paper's Fig. 5 transfer function, missing
    /// outside the shell and in the core.
    Mantle,
    /// A scene that is not ours ([`peer_scenes`]): `linear`, `opaque`, `sparse` or `dense`.
    Peer(&'static str),
}

impl VolumeScene {
    pub(crate) fn name(self) -> &'static str {
        match self {
            VolumeScene::Blobs => "blobs",
            VolumeScene::Mantle => "mantle",
            VolumeScene::Peer(name) => name,
        }
    }

    pub(crate) fn volume(self, n: usize) -> Result<Volume> {
        match self {
            VolumeScene::Blobs => bench_volume(n),
            VolumeScene::Mantle => mantle_fluctuation(n, 7),
            VolumeScene::Peer(name) => peer_scenes::volume(name, n),
        }
    }

    pub(crate) fn tf(self) -> Result<TransferFunction> {
        match self {
            VolumeScene::Blobs => Ok(bench_tf()),
            VolumeScene::Mantle => Ok(TransferFunction::Lut(mantle_fig5_tf())),
            VolumeScene::Peer(name) => peer_scenes::transfer(name),
        }
    }
}

/// The (scene, volume side, image side) triples of the benchmark for `which`: `ours` (the
/// blobs and the mantle), `peer` (the scenes that are not ours), `all`, or scene names separated
/// by commas; 256³ (257³ for the mantle) → 512², and with `quick` off also 513³ → 1024².
pub fn volume_scenes(quick: bool, which: &str) -> Result<Vec<(VolumeScene, usize, u32)>> {
    let ours = [VolumeScene::Blobs, VolumeScene::Mantle];
    let peer = peer_scenes::PEER_SCENES.map(VolumeScene::Peer);
    let mut scenes = Vec::new();
    for word in which.split(',').map(str::trim) {
        match word {
            "ours" => scenes.extend(ours),
            "peer" => scenes.extend(peer),
            "all" => scenes.extend(ours.into_iter().chain(peer)),
            name => match ours.iter().chain(&peer).find(|s| s.name() == name) {
                Some(s) => scenes.push(*s),
                None => {
                    return Err(Error::invalid(
                        "--scenes",
                        format!("unknown scene {name:?}: expected ours, peer, all or one of blobs, mantle, {}", peer_scenes::PEER_SCENES.join(", ")),
                    ))
                }
            },
        }
    }
    let small = |s: VolumeScene| if s == VolumeScene::Mantle { 257 } else { 256 };
    let mut v: Vec<_> = scenes.iter().map(|&s| (s, small(s), 512)).collect();
    if !quick {
        v.extend(scenes.iter().map(|&s| (s, 513, 1024)));
    }
    Ok(v)
}

/// Times the volume ray caster on `scenes`, axis view, one sample per voxel; with `breakdown`,
/// also each stage of the per-sample work (SampleWork); with `peer`, VTK's mappers, the timing in
/// `rounds` (at least one): hdrvis's `runs`, then each peer mapper's, back to back, so that each
/// round's ratios compare times taken seconds apart on a machine whose speed drifts.
pub fn bench_volume_render(
    ctx: Arc<GpuContext>,
    scenes: &[(VolumeScene, usize, u32)],
    (runs, rounds): (usize, usize),
    peer: Option<&Path>,
    breakdown: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<BenchRow>> {
    let session = timing_session(ctx);
    let mut rows = Vec::new();
    for &(scene, n, px) in scenes {
        log(&format!(
            "generating the {} volume at {n}^3 ...",
            scene.name()
        ));
        let vol = Arc::new(scene.volume(n)?);
        let mut opts = VolumeRenderOptions::new(Camera::axis(Axis::Z, &vol.bounds()), scene.tf()?);
        opts.width = px;
        opts.height = px;
        opts.step = 1.0;
        let name = format!("{} {n}^3 -> {px}^2", scene.name());
        let source = VolumeSource::Memory(vol.clone());
        let peer = match peer {
            Some(script) => Some(PeerInputs::write(
                script,
                &vol,
                &opts.tf.resolve(&vol.stats())?,
            )),
            None => None,
        };
        let mut times = RenderRuns::default();
        let mut peers: Vec<PeerRounds> = Vec::new();
        let rounds = if peer.is_some() { rounds.max(1) } else { 1 };
        for round in 0..rounds {
            // Each round warms up again: pipeline compilation and first-touch costs are not
            // part of a frame, and a peer process has run in between.
            let (r, _) = time_renders(&session, &source, &opts, runs)?;
            let ours = median(&r.ms);
            log(&format!("{name}: round {}: median {ours:.1} ms", round + 1));
            times.ms.extend(r.ms);
            times.gpu_ms.extend(r.gpu_ms);
            if let Some(inputs) = &peer {
                run_vtk_round(inputs, px, runs, ours, &mut peers, log);
            }
        }
        let equal_error = peer
            .as_ref()
            .map(|inputs| compare_at_equal_error(&session, inputs, &opts, runs, &peers, log));
        let mut stages: Vec<(SampleWork, Vec<f64>)> = Vec::new();
        if breakdown {
            log(&format!("{name}: timing the stages of a sample ..."));
            // The shader with its samples cut short (SampleWork): an instrument on the renderer
            // itself, not a render users get; it reads the session's upload.
            let gv = session.upload(&vol)?;
            stages = time_sample_stages(&*session.volume_renderer()?, &gv, &opts, runs)?;
        }
        rows.push(BenchRow {
            name,
            samples: px as u64 * px as u64 * n as u64,
            runs_ms: times.ms,
            gpu_ms: times.gpu_ms,
            peers: peers.into_iter().map(PeerRounds::result).collect(),
            stages,
            equal_error,
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

/// The mappers of the VTK peer: its GPU ray caster and its fixed-point CPU ray caster.
const VTK_MAPPERS: [&str; 2] = ["gpu", "fixedpoint"];

/// Threads of VTK's fixed-point CPU ray caster: the machine's two cores, as lavapipe uses.
const VTK_CPU_THREADS: usize = 2;

/// The peer's script and its inputs, written once per scene into a directory that lives as long
/// as this does (or why they could not be written); the volume it reads (missing values replaced
/// by a stand-in below the transfer function's domain, which it maps to nothing), the nodes of
/// its transfer functions and the scale they were sampled on.
struct PeerInputs {
    script: PathBuf,
    files: std::result::Result<(tempfile::TempDir, PathBuf, PathBuf), String>,
    volume: Arc<Volume>,
    nodes: Vec<PeerNode>,
    scale: Scale,
}

impl PeerInputs {
    fn write(script: &Path, vol: &Volume, tf: &ResolvedTransfer) -> PeerInputs {
        let samples = tf.scaled_samples(129);
        let (lo, hi) = (samples[0], samples[samples.len() - 1]);
        let missing = (vol.data.iter().any(|v| !v.is_finite())).then_some(lo - (hi - lo).abs());
        let mut volume = vol.clone();
        if let Some(m) = missing {
            for v in volume.data.iter_mut().filter(|v| !v.is_finite()) {
                *v = m as f32;
            }
        }
        let nodes = equal_error::peer_nodes(tf, &samples, missing);
        let files = tempfile::tempdir()
            .map_err(|e| e.to_string())
            .and_then(|dir| {
                let (npy, tf) = write_peer_inputs(dir.path(), &volume, &nodes)?;
                Ok((dir, npy, tf))
            });
        PeerInputs {
            script: script.to_path_buf(),
            files,
            volume: Arc::new(volume),
            nodes,
            scale: tf.mapping.scale,
        }
    }

    /// Where the mapper's last frame is saved, in the inputs' directory.
    fn image_path(&self, mapper: &str) -> Option<PathBuf> {
        let (dir, _, _) = self.files.as_ref().ok()?;
        Some(dir.path().join(format!("{mapper}.png")))
    }
}

/// The peers' images of the scene scored against the integral of their optical model, beside
/// every hdrvis setting on the same scene (see [`equal_error`]).
fn compare_at_equal_error(
    session: &crate::render::session::RenderSession,
    inputs: &PeerInputs,
    opts: &VolumeRenderOptions,
    runs: usize,
    peers: &[PeerRounds],
    log: &mut dyn FnMut(&str),
) -> EqualError {
    let images: Vec<(String, f64, PathBuf)> = peers
        .iter()
        .filter(|p| !p.medians.is_empty())
        .filter_map(|p| {
            let png = inputs.image_path(p.mapper).filter(|png| png.exists())?;
            Some((format!("vtk {}", p.mapper), median(&p.medians), png))
        })
        .collect();
    let scene = (inputs.volume.clone(), inputs.nodes.as_slice(), inputs.scale);
    equal_error::measure(session, scene, opts, runs, &images, log).unwrap_or_else(|e| EqualError {
        error: Some(e.to_string()),
        ..Default::default()
    })
}

/// One peer mapper over the rounds so far: its median of each round, its ratio to hdrvis's
/// median of the same round, and the error that ended its rounds, if one did.
struct PeerRounds {
    mapper: &'static str,
    detail: String,
    medians: Vec<f64>,
    ratios: Vec<f64>,
    error: Option<String>,
}

impl PeerRounds {
    fn result(self) -> PeerResult {
        PeerResult {
            name: format!("vtk {}", self.mapper),
            detail: self.detail,
            median_ms: (!self.medians.is_empty()).then(|| median(&self.medians)),
            ratios: self.ratios,
            error: self.error,
        }
    }
}

/// One round of each VTK mapper whose rounds have not failed: its median over `runs` and its
/// ratio to `ours`, hdrvis's median of the same round.
fn run_vtk_round(
    inputs: &PeerInputs,
    px: u32,
    runs: usize,
    ours: f64,
    peers: &mut Vec<PeerRounds>,
    log: &mut dyn FnMut(&str),
) {
    if peers.is_empty() {
        peers.extend(VTK_MAPPERS.map(|mapper| PeerRounds {
            mapper,
            detail: String::new(),
            medians: Vec::new(),
            ratios: Vec::new(),
            error: None,
        }));
    }
    for p in peers.iter_mut().filter(|p| p.error.is_none()) {
        log(&format!("running peer vtk ({}) at {px}^2 ...", p.mapper));
        match run_vtk_mapper(inputs, p.mapper, px, runs) {
            Ok((median_ms, detail)) => {
                p.medians.push(median_ms);
                p.ratios.push(median_ms / ours);
                p.detail = detail;
            }
            Err(e) => p.error = Some(e),
        }
    }
}

/// One VTK mapper through `tests/python/vtk_volume_bench.py` on the same volume, image size,
/// sample distance and (sampled) transfer function: its median ms and what ran, or why it did
/// not.
fn run_vtk_mapper(
    inputs: &PeerInputs,
    mapper: &str,
    px: u32,
    runs: usize,
) -> std::result::Result<(f64, String), String> {
    let (_, npy, tf_path) = inputs.files.as_ref().map_err(Clone::clone)?;
    let mut command = std::process::Command::new("python3");
    command.arg(&inputs.script);
    if let Some(png) = inputs.image_path(mapper) {
        // Its last frame, for the comparison at equal error.
        command.arg("--save-png").arg(png);
    }
    let out = command
        .args(["--npy", &npy.display().to_string()])
        .args(["--width", &px.to_string(), "--height", &px.to_string()])
        .args(["--sample-distance", "1.0"])
        .args(["--runs", &runs.max(1).to_string()])
        .args(["--mapper", mapper])
        .args(["--threads", &VTK_CPU_THREADS.to_string()])
        .args(["--tf", &tf_path.display().to_string()])
        .output()
        .map_err(|e| format!("cannot run python3: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr)
            .lines()
            .last()
            .unwrap_or("failed")
            .to_string());
    }
    parse_peer_output(&String::from_utf8_lossy(&out.stdout))
}

/// Writes the peer's inputs into `dir`: the volume as `volume.npy` and the transfer function's
/// nodes as `tf.json`; returns their paths, or the error's text.
fn write_peer_inputs(
    dir: &Path,
    vol: &Volume,
    nodes: &[PeerNode],
) -> std::result::Result<(PathBuf, PathBuf), String> {
    let npy = dir.join("volume.npy");
    crate::datasets::npy::write_npy_f32(&npy, &[vol.dims[2], vol.dims[1], vol.dims[0]], &vol.data)
        .map_err(|e| e.to_string())?;
    let tf_path = dir.join("tf.json");
    std::fs::write(&tf_path, peer_tf_json(nodes)).map_err(|e| e.to_string())?;
    Ok((npy, tf_path))
}

/// The transfer function as the peer reads it: VTK's transfer functions are piecewise linear in
/// the value, so ours is given as nodes sampled evenly in its own scale.
fn peer_tf_json(nodes: &[PeerNode]) -> String {
    let color: Vec<String> = nodes
        .iter()
        .map(|n| {
            let [r, g, b] = n.colour;
            format!("[{:e}, {r}, {g}, {b}]", n.value)
        })
        .collect();
    let opacity: Vec<String> = nodes
        .iter()
        .map(|n| format!("[{:e}, {}]", n.value, n.alpha))
        .collect();
    format!(
        "{{\"color\": [{}], \"opacity\": [{}], \"scalar_opacity_unit_distance\": 1.0}}",
        color.join(", "),
        opacity.join(", ")
    )
}

/// The peer's median ms and what ran, from the last JSON line of its output, or why there is
/// none.
fn parse_peer_output(text: &str) -> std::result::Result<(f64, String), String> {
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
        Some(m) => Ok((
            m,
            format!(
                "{} (VTK {}) on {}",
                field("mapper").unwrap_or_default(),
                field("vtk_version").unwrap_or_default(),
                field("gl_renderer").unwrap_or_default()
            ),
        )),
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

/// The table `hdrvis bench volume` prints: hdrvis's row, then one line per peer mapper.
pub fn format_volume_table(adapter: &str, rows: &[BenchRow]) -> String {
    let mut s = format!("adapter: {adapter}\nvolume benchmark: axis view, f32, 1 sample/voxel, empty-space skipping as routed, median of runs (wall clock to the image in host memory; GPU ms: the ray-casting pass on the device's clock; a peer's x: the median over rounds of its median over hdrvis's, the two timed back to back); blobs: log10 TF; mantle: Fig. 5 symlog TF, missing data outside the shell and in the core\n");
    s.push_str(&format!(
        "{:<24} {:>12} {:>10} {:>11} {:>10} {:>6}\n",
        "scene", "samples", "median ms", "Msamples/s", "GPU ms", "runs"
    ));
    for r in rows {
        let gpu = if r.gpu_ms.is_empty() {
            "-".to_string()
        } else {
            format!("{:.2}", median(&r.gpu_ms))
        };
        s.push_str(&format!(
            "{:<24} {:>10.1} M {:>10.1} {:>11.1} {:>10} {:>6}\n",
            r.name,
            r.samples as f64 / 1e6,
            r.median_ms(),
            r.msamples_per_s(),
            gpu,
            r.runs_ms.len(),
        ));
        for p in &r.peers {
            let line = match (p.median_ms, &p.error) {
                (Some(m), error) => {
                    let rounds: Vec<String> = p.ratios.iter().map(|x| format!("{x:.2}")).collect();
                    let failed = error
                        .as_ref()
                        .map(|e| format!("; a later round failed: {e}"))
                        .unwrap_or_default();
                    format!(
                        "{m:.1} ms, {:.2}x hdrvis's time (rounds: {}{failed}) [{}]",
                        median(&p.ratios),
                        rounds.join(" "),
                        p.detail
                    )
                }
                (None, Some(e)) => format!("unavailable: {e}"),
                _ => String::new(),
            };
            s.push_str(&format!("  peer {:<18} {line}\n", p.name));
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn row_with_peer(ratios: Vec<f64>, error: Option<String>) -> BenchRow {
        BenchRow {
            name: "mantle 257^3 -> 512^2".into(),
            samples: 1,
            runs_ms: vec![400.0, 500.0, 450.0],
            peers: vec![PeerResult {
                name: "vtk fixedpoint".into(),
                detail: "vtkFixedPointVolumeRayCastMapper (VTK 9.7.2) on llvmpipe".into(),
                median_ms: Some(600.0),
                ratios,
                error,
            }],
            stages: Vec::new(),
            gpu_ms: Vec::new(),
            equal_error: None,
        }
    }

    #[test]
    fn a_peer_ratio_is_the_median_of_its_rounds_not_of_pooled_times() {
        // Pooled medians would give 600 / 450 = 1.33x; the rounds' own ratios say 1.60x.
        let table = format_volume_table("test", &[row_with_peer(vec![1.2, 1.6, 1.7], None)]);
        assert!(
            table.contains("600.0 ms, 1.60x hdrvis's time (rounds: 1.20 1.60 1.70)"),
            "{table}"
        );
        let failed =
            format_volume_table("test", &[row_with_peer(vec![1.5], Some("no EGL".into()))]);
        assert!(
            failed.contains("1.50x hdrvis's time (rounds: 1.50; a later round failed: no EGL)"),
            "{failed}"
        );
    }

    #[test]
    fn the_peer_json_line_gives_its_median_and_what_ran() {
        let out = "VTK chatter\n{\"peer\": \"vtk\", \"mapper\": \"vtkFixedPointVolumeRayCastMapper\", \"vtk_version\": \"9.7.2\", \"gl_renderer\": \"llvmpipe (LLVM 15)\", \"median_ms\": 588.25, \"runs_ms\": [1.0]}\n";
        let (ms, detail) = parse_peer_output(out).unwrap();
        assert_eq!(ms, 588.25);
        assert_eq!(
            detail,
            "vtkFixedPointVolumeRayCastMapper (VTK 9.7.2) on llvmpipe (LLVM 15)"
        );
        assert!(parse_peer_output("no json here").is_err());
    }
}
