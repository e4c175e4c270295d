//! Shared helpers: one GPU context per backend for the whole test binary.

use hdrvis::gpu::{BackendChoice, GpuContext};
use hdrvis::model::{Grid, HdrImage, Volume};
use hdrvis::render::session::RenderSession;
use hdrvis::render::surface::{SurfaceOptions, SurfaceView};
use hdrvis::render::volume::VolumeRenderer;
use hdrvis::render::{RenderPath, VolumeRenderOptions, VolumeSource};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// Something a test needs from outside (a tool, Python modules, a font, root) is missing: the
/// test is skipped with `why` printed, or fails when the environment variable `require` (an
/// `HDRVIS_REQUIRE_*` that `.ci/run` sets) is 1. Returns `None`, so callers can return it.
pub fn missing<T>(require: &str, why: &str) -> Option<T> {
    assert!(
        std::env::var(require).as_deref() != Ok("1"),
        "{require}=1 but {why}"
    );
    eprintln!("skipped: {why}");
    None
}

/// The backends GPU tests run on: Vulkan and the GL fallback, or those `HDRVIS_TEST_BACKENDS`
/// names ("vulkan", "gl", comma-separated) on a machine whose GL cannot run headless (NVIDIA's
/// EGL without a display, on the lent GPU machines).
pub fn backends() -> Vec<BackendChoice> {
    match std::env::var("HDRVIS_TEST_BACKENDS") {
        Ok(list) => list
            .split(',')
            .map(|b| BackendChoice::parse(b.trim()).unwrap_or_else(|e| panic!("{e}")))
            .collect(),
        Err(_) => vec![BackendChoice::Vulkan, BackendChoice::Gl],
    }
}

pub fn renderer(backend: BackendChoice) -> Arc<VolumeRenderer> {
    static VK: OnceLock<Arc<VolumeRenderer>> = OnceLock::new();
    static GL: OnceLock<Arc<VolumeRenderer>> = OnceLock::new();
    let cell = match backend {
        BackendChoice::Gl => &GL,
        _ => &VK,
    };
    cell.get_or_init(|| {
        let ctx = GpuContext::new(backend).unwrap_or_else(|e| panic!("{e}"));
        Arc::new(VolumeRenderer::new(ctx))
    })
    .clone()
}

/// A session per backend on the shared context that keeps nothing (every call renders), so GPU
/// renders in the tests go through the library's one entry point, `render_volume`.
pub fn session(backend: BackendChoice) -> Arc<RenderSession> {
    static VK: OnceLock<Arc<RenderSession>> = OnceLock::new();
    static GL: OnceLock<Arc<RenderSession>> = OnceLock::new();
    let cell = match backend {
        BackendChoice::Gl => &GL,
        _ => &VK,
    };
    cell.get_or_init(|| {
        Arc::new(RenderSession::with_context(
            renderer(backend).context().clone(),
            0,
        ))
    })
    .clone()
}

/// An in-memory volume rendered on the GPU through `render_volume`, checked to take the path
/// `expected`.
pub fn render_on(
    backend: BackendChoice,
    vol: &Volume,
    opts: &VolumeRenderOptions,
    expected: RenderPath,
) -> HdrImage {
    render_where(backend, vol, opts, |p| p == expected)
}

/// An in-memory volume rendered through `render_volume`, checked to take a path `ok` accepts.
fn render_where(
    backend: BackendChoice,
    vol: &Volume,
    opts: &VolumeRenderOptions,
    ok: impl Fn(RenderPath) -> bool,
) -> HdrImage {
    let source = VolumeSource::Memory(Arc::new(vol.clone()));
    let r = session(backend)
        .render_volume_detailed(&source, opts)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(ok(r.path), "unexpected path {:?}", r.path);
    (*r.image).clone()
}

/// [`render_on`] the in-core ray caster, with or without empty-space skipping.
pub fn render(backend: BackendChoice, vol: &Volume, opts: &VolumeRenderOptions) -> HdrImage {
    render_where(backend, vol, opts, |p| {
        matches!(p, RenderPath::InCore { .. })
    })
}

/// Equal values, NaN where the reference is masked, within `tol` relative.
pub fn assert_values(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        if w.is_nan() {
            assert!(g.is_nan(), "{what}[{i}]: {g}, expected missing");
        } else {
            assert!(
                (g - w).abs() <= tol * w.abs().max(1.0),
                "{what}[{i}]: {g}, expected {w}"
            );
        }
    }
}

/// Largest relative difference, measured against `floor` where values are tiny.
pub fn max_rel(a: &[f64], b: &[f64], floor: f64) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(floor))
        .fold(0.0, f64::max)
}

/// The report of the tests/python writer `script` run as `SCRIPT DIR CASE` (it writes case
/// `case`'s files into `dir`): one `KEY VALUE ...` line per reference value, by key; `None`
/// when the Python modules are missing.
pub fn python_reference(
    script: &str,
    dir: &Path,
    case: &str,
) -> Option<HashMap<String, Vec<String>>> {
    python_report(script, &[dir.to_str().unwrap(), case])
}

/// The `KEY VALUE ...` lines of the tests/python writer `script` run with `args`, by key;
/// `None` when the Python modules are missing. The script must exit 0.
pub fn python_report(script: &str, args: &[&str]) -> Option<HashMap<String, Vec<String>>> {
    let report = crate::cli::python_check(script, args)?;
    assert!(report.starts_with("exit 0\n"), "{report}");
    Some(
        report
            .lines()
            .skip(1)
            .filter_map(|l| {
                let mut words = l.split_whitespace();
                let key = words.next()?.to_string();
                Some((key, words.map(str::to_string).collect()))
            })
            .collect(),
    )
}

/// The values of `key` in a [`python_reference`] report, as numbers.
pub fn reference_numbers(r: &HashMap<String, Vec<String>>, key: &str) -> Vec<f64> {
    r.get(key)
        .unwrap_or_else(|| panic!("no {key} in the reference"))
        .iter()
        .map(|w| w.parse().unwrap())
        .collect()
}

/// Writes the CF file `name` in `dir` with tests/python/write_cf_sphere.py and `args`; `None`
/// (skip) without xarray.
pub fn cf_sphere_file(dir: &Path, name: &str, args: &[&str]) -> Option<PathBuf> {
    let path = dir.join(name);
    let mut all = vec![path.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = crate::cli::python_check("write_cf_sphere.py", &all)?;
    assert!(out.starts_with("exit 0"), "{out}");
    Some(path)
}

/// `o` at one pixel per node in map view of a plain grid when it gives no size (the size the
/// node-by-node checks read; the default is a figure of about 1000 pixels).
pub fn at_nodes(grid: &Grid, o: &SurfaceOptions) -> SurfaceOptions {
    let mut o = o.clone();
    let unsized_map = matches!(o.view, SurfaceView::Map) && o.width.is_none() && o.height.is_none();
    if unsized_map && !grid.is_geographic() {
        (o.width, o.height) = (Some(grid.nx() as u32), Some(grid.ny() as u32));
    }
    o
}
