//! The pass graph of a scene, run through one session: load → upload → ray cast (or surface data
//! pass → fringe pass) → exposure / tone mapping → sinks. Each stage's result is cached under a
//! hash of its inputs ([`super::cache`]), so a change re-runs only what depends on it: an
//! exposure or operator change re-runs the post pass alone, a ν change the fringe pass alone, a
//! camera or transfer-function change the ray cast but not the load or the upload. Every stage
//! appends a [`PassRecord`] to the session's log, and every image carries the records of the
//! passes that produced it in its `passes` metadata. A session outlives a script run, so a TUI
//! or a sweep that re-runs a script reuses what earlier runs computed.

use super::cache::{KeyBuilder, ResultCache};
use super::distributed::Exchange;
use super::passes::{describe, PassLog, PassRecord};
use super::surface::{SurfaceOptions, SurfaceRenderer, SurfaceTiming};
use super::volume::{GpuVolume, VolumeRenderer};
use super::volume_f64::F64RayCaster;
use super::{Precision, TfSampling, VolumeRenderOptions};
use crate::error::Result;
use crate::gpu::{BackendChoice, GpuContext};
use crate::model::mesh::MeshField;
use crate::model::{Grid, HdrImage, Volume};
use crate::tonemap::{MapperChoice, ToneMapSettings, ToneMapper};
use std::any::Any;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock, Weak};
use std::time::Instant;

/// Metadata key under which an image records the passes that produced it.
pub(crate) const PASSES_META: &str = "passes";

struct Gpu {
    volume: Arc<VolumeRenderer>,
    volume_f64: Arc<F64RayCaster>,
    surface: Arc<SurfaceRenderer>,
    tonemap: Arc<ToneMapper>,
}

/// Renderers on one GPU context (created on first use), the result cache and the pass log.
pub struct RenderSession {
    backend: BackendChoice,
    gpu: OnceLock<Gpu>,
    cache: ResultCache,
    log: PassLog,
    /// Content hashes of volumes and images already hashed, by address; the weak reference tells
    /// whether the address still holds the same value.
    volume_keys: Mutex<HashMap<usize, (Weak<Volume>, u64)>>,
    image_keys: Mutex<HashMap<usize, (Weak<HdrImage>, u64)>>,
    /// Renders run even when the cache holds their image (benchmarks time every render; what
    /// they read and upload is still reused).
    rerun_renders: bool,
    /// The ranks this session renders with (MPI, or threads in tests); every volume render is
    /// split over them when there are several.
    cluster: Option<Arc<dyn Exchange>>,
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

pub(super) fn image_bytes(img: &HdrImage) -> u64 {
    (img.pixels.len() * 16
        + img
            .extra_channels
            .iter()
            .map(|(_, c)| c.len() * 4)
            .sum::<usize>()) as u64
}

/// A file's identity for the load cache: its canonical path, size and modification time, so an
/// edited file is read again.
fn file_key(stage: &str, path: &Path, var: Option<&str>) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| crate::Error::io(path, e))?;
    let canonical = path.canonicalize().map_err(|e| crate::Error::io(path, e))?;
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos() as u64);
    Ok(KeyBuilder::new(stage)
        .str(&canonical.to_string_lossy())
        .u64(meta.len())
        .u64(mtime)
        .debug(&var)
        .finish())
}

impl RenderSession {
    pub fn new(backend: BackendChoice, cache_budget_bytes: u64) -> Self {
        RenderSession {
            backend,
            gpu: OnceLock::new(),
            cache: ResultCache::new(cache_budget_bytes),
            log: PassLog::default(),
            volume_keys: Mutex::new(HashMap::new()),
            image_keys: Mutex::new(HashMap::new()),
            rerun_renders: false,
            cluster: None,
        }
    }

    /// This session as one rank of `world`: every volume render is split over its ranks
    /// ([`super::distributed`]), and each rank must run the same renders in the same order.
    pub fn with_cluster(mut self, world: Arc<dyn Exchange>) -> Self {
        self.cluster = Some(world);
        self
    }

    /// The ranks this session renders with, when it is one of a group.
    pub fn cluster(&self) -> Option<&Arc<dyn Exchange>> {
        self.cluster.as_ref()
    }

    /// This session with every render run afresh, for timing: loads, uploads, bricks and brick
    /// caches are still reused.
    pub(crate) fn rerunning_renders(mut self) -> Self {
        self.rerun_renders = true;
        self
    }

    pub(super) fn renders_rerun(&self) -> bool {
        self.rerun_renders
    }

    /// A session sharing an existing GPU context (tests, benchmarks).
    pub fn with_context(ctx: Arc<GpuContext>, cache_budget_bytes: u64) -> Self {
        let s = RenderSession::new(BackendChoice::Auto, cache_budget_bytes);
        let _ = s.gpu.set(Gpu::new(ctx));
        s
    }

    fn gpu(&self) -> Result<&Gpu> {
        if let Some(g) = self.gpu.get() {
            return Ok(g);
        }
        let ctx = GpuContext::new(self.backend)?;
        Ok(self.gpu.get_or_init(|| Gpu::new(ctx)))
    }

    pub fn context(&self) -> Result<Arc<GpuContext>> {
        Ok(self.gpu()?.volume.context().clone())
    }

    pub(crate) fn volume_renderer(&self) -> Result<Arc<VolumeRenderer>> {
        Ok(self.gpu()?.volume.clone())
    }

    /// Whether the adapter runs the f64 ray-casting shader.
    pub(super) fn f64_gpu_available(&self) -> Result<bool> {
        Ok(self.gpu()?.volume_f64.available())
    }

    pub(super) fn f64_renderer(&self) -> Result<Arc<F64RayCaster>> {
        Ok(self.gpu()?.volume_f64.clone())
    }

    pub fn surface_renderer(&self) -> Result<Arc<SurfaceRenderer>> {
        Ok(self.gpu()?.surface.clone())
    }

    pub(crate) fn tonemapper(&self) -> Result<Arc<ToneMapper>> {
        Ok(self.gpu()?.tonemap.clone())
    }

    /// The records of the passes run since the last call, in the order they finished.
    pub fn take_passes(&self) -> Vec<PassRecord> {
        self.log.take()
    }

    pub(crate) fn log(&self) -> &PassLog {
        &self.log
    }

    pub fn cache(&self) -> &ResultCache {
        &self.cache
    }

    /// Runs `compute` unless the cache holds the result under `key`; logs the pass either way.
    /// `annotate` sees the fresh value and its record before it is cached (images append the
    /// record to their `passes` metadata).
    fn stage<T: Any + Send + Sync>(
        &self,
        name: &str,
        key: u64,
        bytes: impl FnOnce(&T) -> u64,
        annotate: impl FnOnce(&mut T, &PassRecord),
        compute: impl FnOnce() -> Result<(T, String)>,
    ) -> Result<Arc<T>> {
        let annotate = |value: &mut T, record: &mut PassRecord| annotate(value, record);
        self.stage_with(name, key, false, bytes, annotate, compute)
    }

    /// [`Self::stage`], computing afresh when `rerun` is set (the result is still cached).
    pub(super) fn stage_with<T: Any + Send + Sync>(
        &self,
        name: &str,
        key: u64,
        rerun: bool,
        bytes: impl FnOnce(&T) -> u64,
        annotate: impl FnOnce(&mut T, &mut PassRecord),
        compute: impl FnOnce() -> Result<(T, String)>,
    ) -> Result<Arc<T>> {
        if !rerun {
            if let Some(v) = self.cache.get::<T>(key) {
                self.log.push(PassRecord::cached(name));
                return Ok(v);
            }
        }
        let t = Instant::now();
        let (mut value, detail) = compute()?;
        let mut r = PassRecord::ran(name, ms_since(t)).with_detail(detail);
        annotate(&mut value, &mut r);
        let value = Arc::new(value);
        self.cache.put(key, value.clone(), bytes(&value));
        self.log.push(r);
        Ok(value)
    }

    /// Reads a volume file; the same unchanged file is read once per session and options.
    pub fn load_volume(
        &self,
        path: &Path,
        opts: &crate::datasets::LoadOptions,
    ) -> Result<Arc<Volume>> {
        let key = file_key("load volume", path, Some(&format!("{opts:?}")))?;
        self.stage(
            "load",
            key,
            volume_bytes,
            |_, _| {},
            || {
                Ok((
                    crate::datasets::load_volume_with(path, opts)?,
                    String::new(),
                ))
            },
        )
    }

    /// Reads a 2-D grid file (optionally one named array, a selection of its dimensions) once
    /// per session.
    pub fn load_grid(&self, path: &Path, opts: &crate::datasets::LoadOptions) -> Result<Arc<Grid>> {
        let key = file_key("load grid", path, Some(&format!("{opts:?}")))?;
        self.stage(
            "load",
            key,
            |g: &Grid| g.bytes(),
            |_, _| {},
            || Ok((crate::datasets::load_grid_with(path, opts)?, String::new())),
        )
    }

    /// Reads an EXR once per session.
    pub fn load_image(&self, path: &Path) -> Result<Arc<HdrImage>> {
        let key = file_key("load image", path, None)?;
        self.stage(
            "load",
            key,
            image_bytes,
            |_, _| {},
            || Ok((crate::io::exr::read_exr(path)?, String::new())),
        )
    }

    /// A generated volume, cached under the generator's parameters.
    pub(crate) fn generated_volume(
        &self,
        params: &impl std::fmt::Debug,
        generate: impl FnOnce() -> Result<Volume>,
    ) -> Result<Arc<Volume>> {
        let key = KeyBuilder::new("generate").debug(params).finish();
        self.stage(
            "generate",
            key,
            volume_bytes,
            |_, _| {},
            || Ok((generate()?, String::new())),
        )
    }

    /// The content hash of a volume (data, geometry, name), computed once per Arc.
    pub(crate) fn volume_key(&self, volume: &Arc<Volume>) -> u64 {
        let addr = Arc::as_ptr(volume) as usize;
        let mut keys = self.volume_keys.lock().expect("volume keys poisoned");
        if let Some((w, k)) = keys.get(&addr) {
            if w.upgrade().is_some_and(|v| Arc::ptr_eq(&v, volume)) {
                return *k;
            }
        }
        keys.retain(|_, (w, _)| w.strong_count() > 0);
        let key = KeyBuilder::new("volume")
            .str(&volume.name)
            .str(&volume.units)
            .debug(&(volume.dims, volume.spacing, volume.origin, &volume.geometry))
            .bytes(bytemuck::cast_slice(&volume.data))
            .finish();
        keys.insert(addr, (Arc::downgrade(volume), key));
        key
    }

    /// The content hash of an image (pixels, extra channels, metadata), computed once per Arc.
    pub(crate) fn image_key(&self, img: &Arc<HdrImage>) -> u64 {
        let addr = Arc::as_ptr(img) as usize;
        let mut keys = self.image_keys.lock().expect("image keys poisoned");
        if let Some((w, k)) = keys.get(&addr) {
            if w.upgrade().is_some_and(|v| Arc::ptr_eq(&v, img)) {
                return *k;
            }
        }
        keys.retain(|_, (w, _)| w.strong_count() > 0);
        let mut k = KeyBuilder::new("image");
        k.u64(img.width as u64)
            .u64(img.height as u64)
            .bytes(bytemuck::cast_slice(&img.pixels));
        for (name, c) in &img.extra_channels {
            k.str(name).bytes(bytemuck::cast_slice(c));
        }
        k.debug(&img.metadata);
        let key = k.finish();
        keys.insert(addr, (Arc::downgrade(img), key));
        key
    }

    /// The volume on the GPU: uploaded once per volume content and session.
    pub fn upload(&self, volume: &Arc<Volume>) -> Result<Arc<GpuVolume>> {
        let key = KeyBuilder::new("upload")
            .u64(self.volume_key(volume))
            .finish();
        let ctx = self.context()?;
        self.stage(
            "upload",
            key,
            |g: &GpuVolume| g.bytes(),
            |_, _| {},
            || Ok((GpuVolume::upload(&ctx, volume)?, String::new())),
        )
    }

    /// Tone mapping of an HDR image; the result keeps the input's metadata.
    pub fn tonemap(&self, img: &Arc<HdrImage>, s: &ToneMapSettings) -> Result<Arc<HdrImage>> {
        let key = KeyBuilder::new("tonemap")
            .u64(self.image_key(img))
            .debug(s)
            .finish();
        self.stage("tonemap", key, image_bytes, append_pass, || {
            Ok((self.tonemapper()?.tonemap(img, s)?, s.op.name().to_string()))
        })
    }

    /// Exposure in stops.
    pub fn exposure(&self, img: &Arc<HdrImage>, ev: f64) -> Result<Arc<HdrImage>> {
        crate::tonemap::check_ev("exposure", ev)?;
        let key = KeyBuilder::new("exposure")
            .u64(self.image_key(img))
            .debug(&ev)
            .finish();
        self.stage("exposure", key, image_bytes, append_pass, || {
            Ok((crate::tonemap::exposure(img, ev)?, String::new()))
        })
    }

    /// The false-colour view of log luminance.
    pub fn false_colour(
        &self,
        img: &Arc<HdrImage>,
        decades: Option<(f64, f64)>,
    ) -> Result<Arc<HdrImage>> {
        let key = KeyBuilder::new("false colour")
            .u64(self.image_key(img))
            .debug(&decades)
            .finish();
        self.stage("false-colour", key, image_bytes, append_pass, || {
            Ok((
                self.tonemapper()?.false_colour(img, 0.0, decades)?,
                String::new(),
            ))
        })
    }

    /// A surface render: the data pass runs when the grid, view, size or property set changed
    /// (the surface renderer keeps its targets), the fringe pass when anything else did.
    pub fn surface(&self, grid: &Arc<Grid>, opts: &SurfaceOptions) -> Result<Arc<Vec<HdrImage>>> {
        self.surface_of(grid.id(), opts, |r| r.render_timed(grid, opts))
    }

    /// A field on a mesh drawn cell by cell, cached as [`Self::surface`].
    pub fn mesh_surface(
        &self,
        field: &Arc<MeshField>,
        opts: &SurfaceOptions,
    ) -> Result<Arc<Vec<HdrImage>>> {
        self.surface_of(field.id(), opts, |r| r.render_mesh_timed(field, opts))
    }

    /// The surface images of the thing `id` names under `opts`, from the cache or `render`.
    fn surface_of(
        &self,
        id: u64,
        opts: &SurfaceOptions,
        render: impl FnOnce(&SurfaceRenderer) -> Result<(Vec<HdrImage>, SurfaceTiming)>,
    ) -> Result<Arc<Vec<HdrImage>>> {
        let key = KeyBuilder::new("surface").u64(id).debug(opts).finish();
        if let Some(v) = self.cache.get::<Vec<HdrImage>>(key) {
            self.log.push(PassRecord::cached("surface-data"));
            self.log.push(PassRecord::cached("fringe"));
            return Ok(v);
        }
        let renderer = self.surface_renderer()?;
        let (mut images, timing) = render(&renderer)?;
        let data = match timing.data_ms {
            Some(ms) => PassRecord::ran("surface-data", ms).with_detail(opts.view.describe()),
            None => PassRecord::cached("surface-data"),
        };
        let fringe = PassRecord::ran("fringe", timing.fringe_ms).with_detail(opts.mode.name());
        let chain = describe(&[data.clone(), fringe.clone()]);
        for img in &mut images {
            img.set_meta(PASSES_META, chain.clone());
        }
        self.log.push(data);
        self.log.push(fringe);
        let images = Arc::new(images);
        let bytes = images.iter().map(image_bytes).sum();
        self.cache.put(key, images.clone(), bytes);
        Ok(images)
    }

    /// A field on an unstructured mesh, read once per session ([`crate::datasets::load_mesh`]).
    pub fn load_mesh(
        &self,
        path: &Path,
        opts: &crate::datasets::LoadOptions,
    ) -> Result<Arc<MeshField>> {
        let key = file_key("load mesh", path, Some(&format!("{opts:?}")))?;
        self.stage(
            "load",
            key,
            |f: &MeshField| (f.values().len() * 8 + f.mesh().bytes()) as u64,
            |_, _| {},
            || Ok((crate::datasets::load_mesh(path, opts)?, String::new())),
        )
    }

    /// Records a sink (a written file, a preview) that took `ms`.
    pub(crate) fn record_sink(&self, name: &str, ms: f64) {
        self.log.push(PassRecord::ran(name, ms));
    }
}

impl std::fmt::Debug for RenderSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = self.cache.counters();
        write!(
            f,
            "RenderSession({} cached results, {} of {} bytes)",
            c.entries,
            c.bytes,
            self.cache.budget()
        )
    }
}

impl Gpu {
    fn new(ctx: Arc<GpuContext>) -> Self {
        Gpu {
            volume: Arc::new(VolumeRenderer::new(ctx.clone())),
            volume_f64: Arc::new(F64RayCaster::new(ctx.clone())),
            surface: Arc::new(SurfaceRenderer::new(ctx.clone())),
            tonemap: Arc::new(ToneMapper::new(ctx, MapperChoice::Auto)),
        }
    }
}

/// The effects compiled into a ray cast, for the pass record's detail.
pub(super) fn raycast_effects(opts: &VolumeRenderOptions) -> Vec<String> {
    let mut effects = Vec::new();
    if opts.precision == Precision::F64 {
        effects.push("f64".to_string());
    } else if opts.precision != Precision::F32 {
        effects.push(opts.precision.name().to_string());
    }
    if opts.shading.is_some() {
        effects.push("shading".into());
    }
    if opts.tf_sampling == TfSampling::PreIntegrated {
        effects.push("pre-integrated".into());
    }
    if opts.jitter {
        effects.push("jitter".into());
    }
    effects
}

/// Appends a pass to the image's `passes` metadata, so the image says how it was made.
pub(super) fn append_pass(img: &mut HdrImage, r: &PassRecord) {
    let this = describe(std::slice::from_ref(r));
    let chain = match img.meta(PASSES_META) {
        Some(prev) if !prev.is_empty() => format!("{prev}; {this}"),
        _ => this,
    };
    img.set_meta(PASSES_META, chain);
}

fn volume_bytes(v: &Volume) -> u64 {
    v.data.len() as u64 * 4
}
