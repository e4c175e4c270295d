//! The one entry point for every volume render: [`RenderSession::render_volume`]. Scripts, the
//! CLI, the TUI, the benchmarks and the tests hand it a [`VolumeSource`] and the options; it
//! decides, here and nowhere else, how the render runs ([`RenderSession::choose_path`]):
//!
//! * a coarser quick-look level first, when the options ask for one (`bricking.level`);
//! * f64 compositing on the GPU where the adapter has shader f64, else on the CPU reference;
//! * the in-core ray caster when the volume is in memory and fits the GPU memory budget, with
//!   empty-space skipping ([`super::skipping`]) where enough of it is empty under the transfer
//!   function;
//! * the bricked ray caster (skipping empty bricks, streamed out of core through a brick cache
//!   when the needed bricks exceed the budget) for opened volumes, volumes over the budget, and
//!   renders that ask for bricks;
//! * before all of these, when the session is one of several ranks (MPI), the distributed
//!   render ([`super::distributed`]): a slab per rank, composited sort-last.
//!
//! Every intermediate — the level, the in-memory volume cut into bricks, the GPU brick cache,
//! the upload, the image — is an entry of the session's result cache, so every path shows in
//! the pass log (`--stats`) and a repeated render is answered from the cache. A new geometry or
//! a distributed render plugs in as another [`RenderPath`], chosen in `choose_path` and run in
//! `run_path`.

use super::bricked::{BrickCache, BrickedStats};
use super::cache::KeyBuilder;
use super::distributed;
use super::session::{append_pass, image_bytes, raycast_effects, RenderSession};
use super::skipping::{CellRanges, SkipGrid};
use super::volume::RenderTiming;
use super::{Precision, TfSampling, VolumeRenderOptions};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::bricks::{BrickedVolume, DEFAULT_BRICK};
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Aabb, Cut, HdrImage, Missing, Volume, VolumeStats};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Coarsest quick-look level: 16 times fewer voxels per axis.
pub(crate) const MAX_LEVEL: u32 = 4;

/// The volume a render reads: loaded whole, or opened as bricks and never loaded whole.
#[derive(Clone, Debug)]
pub enum VolumeSource {
    Memory(Arc<Volume>),
    Bricked(Arc<BrickedVolume>),
}

impl VolumeSource {
    pub fn name(&self) -> &str {
        match self {
            VolumeSource::Memory(v) => &v.name,
            VolumeSource::Bricked(b) => &b.name,
        }
    }

    pub fn bounds(&self) -> Aabb {
        match self {
            VolumeSource::Memory(v) => v.bounds(),
            VolumeSource::Bricked(b) => b.bounds(),
        }
    }
}

/// How a render may cut its volume into bricks: the options of the bricked and out-of-core paths.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bricking {
    /// GPU memory the render may use, in bytes; `None` is unlimited. An in-memory volume that
    /// does not fit renders bricked, streamed through a cache of this size.
    pub memory_budget: Option<u64>,
    /// Brick edge in voxels; `Some` sends an in-memory volume to the bricked path.
    pub brick: Option<usize>,
    /// Render a 2^level-times coarser copy (0 is full resolution).
    pub level: u32,
}

impl Bricking {
    pub fn validate(&self) -> Result<()> {
        if self.level > MAX_LEVEL {
            return Err(Error::invalid(
                "level",
                format!(
                    "expected 0 (full resolution) to {MAX_LEVEL}, got {}",
                    self.level
                ),
            ));
        }
        if self.memory_budget == Some(0) {
            return Err(Error::invalid("memory_budget", "expected MiB > 0, got 0"));
        }
        Ok(())
    }
}

/// How one render runs; chosen by `RenderSession::choose_path`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderPath {
    /// The whole volume in one 3-D texture, ray cast in one pass (u8, f16, f32, f32c), jumping
    /// over empty cells when `skipping`.
    InCore { skipping: bool },
    /// f64 compositing in a GPU compute shader (adapters with shader f64).
    F64Gpu,
    /// f64 compositing on the CPU reference.
    F64Cpu,
    /// Bricks in a GPU atlas with a page table; streamed front to back through the atlas when
    /// the bricks the transfer function needs exceed it (out of core).
    Bricked { brick: usize, skip: bool },
    /// Voxels placed by coordinate axes (spherical shells and wedges, rectilinear boxes, boxes
    /// with a cut-away): each ray cut analytically to the domain, each sample mapped through
    /// the axes, jumping over empty world-space cells when `skipping`.
    Mapped { skipping: bool },
    /// One slab of the volume per rank of the session's group (MPI), partial images
    /// composited sort-last onto rank 0 and handed to every rank.
    Distributed { ranks: usize },
}

/// How a render runs, as `choose_path` decided it, with the skip grid the decision classified
/// when the in-core march skips: the ray cast takes it from here, so a render classifies its
/// cells once even when the cache keeps nothing.
pub(crate) struct Route {
    pub path: RenderPath,
    pub skip_grid: Option<Arc<SkipGrid>>,
}

impl From<RenderPath> for Route {
    fn from(path: RenderPath) -> Route {
        Route {
            path,
            skip_grid: None,
        }
    }
}

/// A finished volume render: the image and how it was made.
#[derive(Debug)]
pub struct VolumeRender {
    pub image: Arc<HdrImage>,
    pub path: RenderPath,
    /// Seconds the render itself took, from submission to the image in host memory (not
    /// counting levels, bricking or uploads).
    pub seconds: f64,
    /// The ray-casting pass alone on the device's clock (GPU timestamps), on the in-core and
    /// mapped paths where the adapter has them.
    pub gpu_seconds: Option<f64>,
    /// What the bricked path did (passes, bricks read, GPU memory).
    pub bricks: Option<BrickedStats>,
    /// Whether the render had to compile its pipeline first (in-core path).
    pub compiled_pipeline: bool,
}

/// How a volume placed by coordinate axes renders: f64 on the CPU reference (the f64 GPU shader
/// knows boxes only), everything else in the mapped ray caster, whole; bricks are refused.
fn mapped_path(v: &Volume, opts: &VolumeRenderOptions) -> Result<RenderPath> {
    if opts.precision == Precision::F64 {
        return Ok(RenderPath::F64Cpu);
    }
    let placed = if !v.is_regular() {
        format!("a {} volume placed by coordinate axes", v.geometry.name())
    } else if opts.cut.is_some() {
        "a box with a cut-away".to_string()
    } else {
        "a box with missing: \"renormalise\"".to_string()
    };
    let refuse = |field: &str, what: &str| {
        Err(Error::invalid(
            field,
            format!(
                "{} is {placed}, which renders whole in GPU memory; {what}",
                v.name
            ),
        ))
    };
    if opts.bricking.brick.is_some() {
        return refuse("brick", "bricks are for regular boxes (leave brick out)");
    }
    if !fits_in_core(v, opts) {
        return refuse(
            "memory_budget",
            "it does not fit this budget (raise memory_budget, or resample it to a box with resample())",
        );
    }
    Ok(RenderPath::Mapped { skipping: false })
}

/// A cut-away is for volumes in memory, and must leave part of the volume: latitude, longitude
/// and depth ranges of a spherical volume (its path is chosen as without a cut), world x, y, z
/// ranges of a box, which the mapped ray caster clips (regular boxes too: the in-core and
/// bricked ray casters march one piece a ray) and the f64 ones (`Some` of that path: the f64
/// CPU reference, or for a regular box the f64 GPU shader where it runs).
fn check_cut(
    source: &VolumeSource,
    cut: &Cut,
    opts: &VolumeRenderOptions,
) -> Result<Option<RenderPath>> {
    let v = match source {
        VolumeSource::Memory(v) => v,
        VolumeSource::Bricked(b) => {
            let what = format!("{} is an opened (bricked) box", b.name);
            return Err(Error::invalid(
                "cut",
                format!("{what}; cut-aways need the volume in memory (load_volume)"),
            ));
        }
    };
    if let crate::model::Geometry::Spherical(g) = &v.geometry {
        return cut.check(g).map(|_| None);
    }
    cut.check_box(&v.name, &v.bounds())?;
    mapped_path(v, opts).map(Some)
}

fn source_is_regular(source: &VolumeSource) -> bool {
    matches!(source, VolumeSource::Memory(v) if v.is_regular())
}

/// The path of `missing: "renormalise"`: the f64 CPU reference with `precision: "f64"`, else the
/// mapped GPU ray caster, the one GPU ray caster that renormalises (in its exact filter), whole
/// and without skipping; the bricked and in-core ray casters sample strictly.
fn renormalised_path(source: &VolumeSource, opts: &VolumeRenderOptions) -> Result<RenderPath> {
    match source {
        VolumeSource::Memory(_) if opts.precision == Precision::F64 => Ok(RenderPath::F64Cpu),
        VolumeSource::Memory(v) => mapped_path(v, opts),
        VolumeSource::Bricked(_) => Err(Error::invalid(
            "missing",
            "\"renormalise\" needs the volume in memory (bricks are sampled strictly): use load_volume",
        )),
    }
}

/// Whether `v` renders whole in GPU memory under the render's budget (none: always): its f32
/// voxels and 32 bytes a pixel (the image, its read back and the ray state).
fn fits_in_core(v: &Volume, opts: &VolumeRenderOptions) -> bool {
    let pixels = opts.width as u64 * opts.height as u64;
    opts.bricking
        .memory_budget
        .is_none_or(|m| v.voxel_count() as u64 * 4 + pixels * 32 <= m)
}

/// The coastlines and graticule `opts` ask for over a render of `source` (spherical volumes in
/// memory), planned before any GPU work; `None` when none are asked for.
fn volume_overlay(
    source: &VolumeSource,
    opts: &VolumeRenderOptions,
) -> Result<Option<super::surface::overlay::Overlay>> {
    let (coast, graticule) = (opts.coastlines.as_ref(), opts.graticule);
    match source {
        VolumeSource::Memory(v) => super::surface::overlay::Overlay::for_volume(
            v,
            &opts.camera,
            opts.cut.as_ref(),
            coast,
            graticule,
        ),
        VolumeSource::Bricked(b) if coast.is_some() || graticule.is_some() => Err(Error::invalid(
            if coast.is_some() { "coastlines" } else { "graticule" },
            format!(
                "lines are drawn on the outer surface of spherical volumes; {} is an opened (bricked) box",
                b.name
            ),
        )),
        VolumeSource::Bricked(_) => Ok(None),
    }
}

/// A GPU brick cache as a result-cache entry: renders through it take turns.
pub(crate) struct SharedBrickCache(Mutex<BrickCache>);

impl RenderSession {
    /// Renders `source` with `opts`: the one call behind every volume render.
    pub fn render_volume(
        &self,
        source: &VolumeSource,
        opts: &VolumeRenderOptions,
    ) -> Result<Arc<HdrImage>> {
        Ok(self.render_volume_detailed(source, opts)?.image.clone())
    }

    /// [`Self::render_volume`] with the path it took and its statistics (benchmarks, tests).
    pub fn render_volume_detailed(
        &self,
        source: &VolumeSource,
        opts: &VolumeRenderOptions,
    ) -> Result<Arc<VolumeRender>> {
        opts.validate()?;
        opts.bricking.validate()?;
        let source = match opts.bricking.level {
            0 => source.clone(),
            _ if matches!(source, VolumeSource::Memory(v) if !v.is_regular()) => {
                return Err(Error::invalid(
                    "level",
                    format!(
                        "{} is placed by coordinate axes; quick-look levels are for regular boxes",
                        source.name()
                    ),
                ))
            }
            level => VolumeSource::Memory(self.level(source, level)?),
        };
        let route = self.choose_path(&source, opts)?;
        let path = route.path;
        let overlay = volume_overlay(&source, opts)?;
        if matches!(
            path,
            RenderPath::InCore { .. }
                | RenderPath::Bricked { .. }
                | RenderPath::Mapped { .. }
                | RenderPath::Distributed { .. }
        ) {
            super::check_output_fits(&self.context()?.caps, opts.width, opts.height)?;
        }
        let key = KeyBuilder::new("raycast")
            .u64(self.source_key(&source))
            .debug(&path)
            .debug(opts)
            .finish();
        // A distributed render always runs: every rank must take part in the compositing, and
        // the ranks' caches need not agree on what they still hold.
        let rerun = self.renders_rerun() || matches!(path, RenderPath::Distributed { .. });
        self.stage_with(
            "raycast",
            key,
            rerun,
            |r: &VolumeRender| image_bytes(&r.image),
            |r, rec| {
                if r.compiled_pipeline {
                    rec.note = "pipeline built".into();
                }
                if let Some(img) = Arc::get_mut(&mut r.image) {
                    append_pass(img, rec);
                }
            },
            || {
                let mut r = self.run_path(&source, &route, opts)?;
                if let Some(o) = &overlay {
                    o.draw(Arc::make_mut(&mut r.image));
                }
                let mut detail = raycast_effects(opts);
                if let Some(b) = &r.bricks {
                    detail.push(bricked_detail(path, b));
                }
                if route.skip_grid.is_some() {
                    detail.push("empty-space skipping".into());
                }
                if let (RenderPath::Distributed { ranks }, Some(world)) = (path, self.cluster()) {
                    detail.push(format!(
                        "distributed over {ranks} ranks ({}, {})",
                        world.transport(),
                        distributed::Scheme::for_ranks(ranks).name()
                    ));
                }
                Ok((r, detail.join(", ")))
            },
        )
    }

    /// The decision of how a render runs, in one place (see the module documentation).
    pub(crate) fn choose_path(
        &self,
        source: &VolumeSource,
        opts: &VolumeRenderOptions,
    ) -> Result<Route> {
        let b = &opts.bricking;
        if let Some(cut) = &opts.cut {
            if let Some(path) = check_cut(source, cut, opts)? {
                // A regular box's f64 cut runs where its uncut render would (the f64 GPU
                // shader draws no cut faces); the mapped ray caster skips empty space as
                // without a cut.
                return match (path, source) {
                    (RenderPath::F64Cpu, _)
                        if source_is_regular(source) && opts.cut_faces.is_none() =>
                    {
                        self.f64_path(opts).map(Route::from)
                    }
                    (RenderPath::Mapped { .. }, VolumeSource::Memory(v)) => {
                        self.mapped_route(v, opts)
                    }
                    (path, _) => Ok(path.into()),
                };
            }
        }
        if let Some(world) = self.cluster().filter(|w| w.size() > 1) {
            if let VolumeSource::Memory(v) = source {
                if !v.is_regular() {
                    return Err(Error::invalid(
                        "ranks",
                        format!(
                            "{} is a {} volume placed by coordinate axes; distributed renders split regular boxes into slabs (run it on one rank)",
                            v.name,
                            v.geometry.name()
                        ),
                    ));
                }
            }
            let nz = match source {
                VolumeSource::Memory(v) => v.dims[2],
                VolumeSource::Bricked(b) => b.dims[2],
            };
            distributed::check_options(source.name(), nz, opts, world.size())?;
            return Ok(RenderPath::Distributed {
                ranks: world.size(),
            }
            .into());
        }
        if opts.missing == Missing::Renormalise {
            return renormalised_path(source, opts).map(Route::from);
        }
        let path = match source {
            VolumeSource::Memory(v) if !v.is_regular() => return self.mapped_route(v, opts),
            VolumeSource::Memory(_) if opts.precision == Precision::F64 => {
                return self.f64_path(opts).map(Route::from)
            }
            VolumeSource::Memory(v) => {
                if fits_in_core(v, opts) && b.brick.is_none() {
                    let skip_grid = self.paying_skip_grid(v, opts)?;
                    return Ok(Route {
                        path: RenderPath::InCore {
                            skipping: skip_grid.is_some(),
                        },
                        skip_grid,
                    });
                }
                RenderPath::Bricked {
                    brick: b.brick.unwrap_or(DEFAULT_BRICK),
                    skip: opts.empty_space_skipping,
                }
            }
            VolumeSource::Bricked(bv) => {
                if opts.precision == Precision::F64 {
                    return Err(Error::invalid(
                        "precision",
                        "f64 runs on the CPU reference, which needs the volume in memory: use load_volume",
                    ));
                }
                if let Some(e) = b.brick.filter(|&e| e != bv.layout.brick) {
                    return Err(Error::invalid(
                        "brick",
                        format!(
                            "{} was opened with bricks of {}; give brick: {e} to open_volume instead",
                            bv.name, bv.layout.brick
                        ),
                    ));
                }
                RenderPath::Bricked {
                    brick: bv.layout.brick,
                    skip: opts.empty_space_skipping,
                }
            }
        };
        check_bricked_options(source.name(), opts)?;
        Ok(path.into())
    }

    /// Where a regular box renders in f64 (no bricked variant, no budget): the GPU shader where
    /// the adapter has shader f64 and the options need nothing it lacks, else the CPU reference.
    fn f64_path(&self, opts: &VolumeRenderOptions) -> Result<RenderPath> {
        let gpu = opts.shading.is_none()
            && opts.tf_sampling == TfSampling::Point
            && self.f64_gpu_available()?;
        Ok(if gpu {
            RenderPath::F64Gpu
        } else {
            RenderPath::F64Cpu
        })
    }

    /// The route of a volume the mapped ray caster renders (or, in f64, the CPU reference),
    /// skipping where [`Self::paying_skip_grid`]'s conditions hold for its world-space cells.
    fn mapped_route(&self, v: &Arc<Volume>, opts: &VolumeRenderOptions) -> Result<Route> {
        let path = mapped_path(v, opts)?;
        // Pre-integrated segments skip as well: one left out lies in empty cells, and the
        // field runs continuously along it through values whose every transfer is zero.
        if !matches!(path, RenderPath::Mapped { .. }) || !opts.empty_space_skipping {
            return Ok(path.into());
        }
        let grid = self.mapped_skip_grid(v, opts)?;
        let skip_grid =
            (grid.empty_fraction() >= super::mapped_skipping::MIN_EMPTY_FRACTION).then_some(grid);
        Ok(Route {
            path: RenderPath::Mapped {
                skipping: skip_grid.is_some(),
            },
            skip_grid,
        })
    }

    /// The skip grid the in-core render of `volume` skips with, or `None` when it does not
    /// skip: skipping is when asked (the default), for point-sampled transfer functions
    /// (pre-integration carries each segment's value into the next), and when enough cells are
    /// empty for the jumps to pay for the lookups.
    fn paying_skip_grid(
        &self,
        volume: &Arc<Volume>,
        opts: &VolumeRenderOptions,
    ) -> Result<Option<Arc<SkipGrid>>> {
        if !opts.empty_space_skipping || opts.tf_sampling != TfSampling::Point {
            return Ok(None);
        }
        let grid = self.skip_grid(volume, opts)?;
        Ok((grid.empty_fraction() >= super::skipping::MIN_EMPTY_FRACTION).then_some(grid))
    }

    fn run_path(
        &self,
        source: &VolumeSource,
        route: &Route,
        opts: &VolumeRenderOptions,
    ) -> Result<VolumeRender> {
        let t = Instant::now();
        let path = route.path;
        let (image, timing, bricks) = match (path, source) {
            (RenderPath::InCore { .. }, VolumeSource::Memory(v)) => {
                let gv = self.upload(v)?;
                let grid = route.skip_grid.as_deref();
                let (img, timing) = self.volume_renderer()?.render(&gv, opts, grid)?;
                (img, timing, None)
            }
            (RenderPath::F64Gpu, VolumeSource::Memory(v)) => {
                let gv = self.upload(v)?;
                let pixels = self.f64_renderer()?.render(&gv, opts)?;
                let mut img = HdrImage::from_pixels(
                    opts.width,
                    opts.height,
                    pixels.iter().map(|p| p.map(|v| v as f32)).collect(),
                );
                img.set_meta("precision", "f64 (GPU)");
                img.set_meta("tf", opts.tf.describe());
                img.set_meta("camera", opts.camera.describe());
                img.set_meta("adapter", self.context()?.describe());
                (img, wall_seconds(t.elapsed().as_secs_f64()), None)
            }
            (RenderPath::F64Cpu, VolumeSource::Memory(v)) => {
                let mut img = super::cpu_reference::render_volume_cpu(v, opts)?;
                img.set_meta("precision", "f64 (CPU)");
                img.set_meta("tf", opts.tf.describe());
                img.set_meta("tf_sampling", opts.tf_sampling.name());
                (img, wall_seconds(t.elapsed().as_secs_f64()), None)
            }
            (RenderPath::Mapped { .. }, VolumeSource::Memory(v)) => {
                let gv = self.upload(v)?;
                let grid = route.skip_grid.as_deref();
                let (img, timing) = self.volume_renderer()?.render_mapped(v, &gv, opts, grid)?;
                (img, timing, None)
            }
            (RenderPath::Bricked { brick, skip }, _) => {
                let bricked = match source {
                    VolumeSource::Memory(v) => self.bricks_of(v, brick)?,
                    VolumeSource::Bricked(b) => b.clone(),
                };
                let cache = self.brick_cache(&bricked, opts)?;
                let mut cache = cache.0.lock().expect("brick cache poisoned");
                let (img, stats) = self
                    .volume_renderer()?
                    .render_bricked(&mut cache, opts, skip)?;
                (img, wall_seconds(stats.seconds), Some(stats))
            }
            (RenderPath::Distributed { .. }, _) => {
                let world = self.cluster().expect("choose_path saw the session's group");
                let r = self.render_distributed(world.as_ref(), source, opts)?;
                let timing = RenderTiming {
                    seconds: r.render_seconds + r.composite_seconds,
                    compiled_pipeline: r.compiled_pipeline,
                    gpu_seconds: None,
                };
                (r.image, timing, None)
            }
            (_, VolumeSource::Bricked(_)) => {
                unreachable!("choose_path sends bricked sources to the bricked path")
            }
        };
        Ok(VolumeRender {
            image: Arc::new(image),
            path,
            seconds: timing.seconds,
            gpu_seconds: timing.gpu_seconds,
            bricks,
            compiled_pipeline: timing.compiled_pipeline,
        })
    }

    /// The content key of a source: a memory volume's data hash, a bricked volume's identity
    /// (its source, layout and per-brick ranges, which change when the file's data change).
    pub(super) fn source_key(&self, source: &VolumeSource) -> u64 {
        match source {
            VolumeSource::Memory(v) => self.volume_key(v),
            VolumeSource::Bricked(b) => {
                let mut k = KeyBuilder::new("bricked volume");
                k.str(&b.name)
                    .str(&b.units)
                    .str(&b.source().describe())
                    .debug(&(b.dims, b.spacing, b.origin, b.layout, &b.stats));
                for r in &b.ranges {
                    let [lo, hi] = r.unwrap_or([f32::NAN; 2]);
                    k.u64(u64::from(lo.to_bits()) << 32 | u64::from(hi.to_bits()));
                }
                k.finish()
            }
        }
    }

    /// The 2^level-times coarser copy of a source, built from the next finer level.
    fn level(&self, source: &VolumeSource, level: u32) -> Result<Arc<Volume>> {
        let key = KeyBuilder::new("level")
            .u64(self.source_key(source))
            .u64(level as u64)
            .finish();
        self.stage_with(
            "level",
            key,
            false,
            |v: &Volume| v.data.len() as u64 * 4,
            |_, _| {},
            || {
                let mut coarse = match (level, source) {
                    (1, VolumeSource::Bricked(b)) => b.downsampled()?,
                    (1, VolumeSource::Memory(v)) => {
                        BrickedVolume::from_volume(v.clone(), DEFAULT_BRICK)?.downsampled()?
                    }
                    _ => BrickedVolume::from_volume(self.level(source, level - 1)?, DEFAULT_BRICK)?
                        .downsampled()?,
                };
                coarse.name = format!("{} (level {level})", source.name());
                let detail = format!("{:?}", coarse.dims);
                Ok((coarse, detail))
            },
        )
    }

    /// An in-memory volume cut into bricks of `brick` voxels.
    fn bricks_of(&self, volume: &Arc<Volume>, brick: usize) -> Result<Arc<BrickedVolume>> {
        let key = KeyBuilder::new("bricks")
            .u64(self.volume_key(volume))
            .u64(brick as u64)
            .finish();
        self.stage_with(
            "bricks",
            key,
            false,
            |b: &BrickedVolume| b.bytes(),
            |_, _| {},
            || {
                let b = BrickedVolume::from_volume(volume.clone(), brick)?;
                let detail = format!("{} bricks of {brick}³", b.layout.count());
                Ok((b, detail))
            },
        )
    }

    /// The GPU brick cache of a bricked volume under the render's budget. Under a budget only
    /// this cache may hold GPU memory, so the other volumes' caches are dropped first.
    fn brick_cache(
        &self,
        volume: &Arc<BrickedVolume>,
        opts: &VolumeRenderOptions,
    ) -> Result<Arc<SharedBrickCache>> {
        let budget = opts.bricking.memory_budget;
        let key = KeyBuilder::new("brick cache")
            .u64(self.source_key(&VolumeSource::Bricked(volume.clone())))
            .debug(&budget)
            .finish();
        let (w, h) = (opts.width, opts.height);
        // Under a budget only this volume's cache may hold GPU memory; a cache made for a
        // smaller image is made anew.
        self.cache().remove_where(|k, c: &SharedBrickCache| {
            if k == key {
                !c.0.lock().is_ok_and(|c| c.serves(budget, w, h))
            } else {
                budget.is_some()
            }
        });
        let ctx = self.context()?;
        self.stage_with(
            "brick-cache",
            key,
            false,
            |c: &SharedBrickCache| c.0.lock().map_or(0, |c| c.atlas_bytes()),
            |_, _| {},
            || {
                let c = BrickCache::new(&ctx, volume.clone(), budget, w, h)?;
                let detail = format!("{} slots", c.capacity());
                Ok((SharedBrickCache(Mutex::new(c)), detail))
            },
        )
    }
}

impl RenderSession {
    /// The per-cell value ranges of `volume`, read once and cached.
    pub(crate) fn cell_ranges(&self, volume: &Arc<Volume>) -> Result<Arc<CellRanges>> {
        let key = KeyBuilder::new("cell ranges")
            .u64(self.volume_key(volume))
            .finish();
        self.stage_with(
            "cell-ranges",
            key,
            false,
            |c: &CellRanges| c.count() as u64 * 12,
            |_, _| {},
            || {
                let c = CellRanges::of(volume.clone())?;
                let detail = format!("{} cells of {}³", c.count(), c.edge());
                Ok((c, detail))
            },
        )
    }

    /// The skip grid of `volume` under the options' transfer function, cached per function.
    pub(crate) fn skip_grid(
        &self,
        volume: &Arc<Volume>,
        opts: &VolumeRenderOptions,
    ) -> Result<Arc<SkipGrid>> {
        let cells = self.cell_ranges(volume)?;
        self.skip_grid_stage("skip grid", volume, opts, cells.stats(), |ctx, tf| {
            let g = SkipGrid::new(ctx, &cells, tf);
            let detail = g.describe();
            (g, detail)
        })
    }

    /// The `skip-grid` stage: the grid `build` classifies under the options' transfer function
    /// (resolved on `stats`), cached per volume, function and kind of grid (`kind`: the box's
    /// cells or the mapped ray caster's world cells).
    pub(crate) fn skip_grid_stage(
        &self,
        kind: &str,
        volume: &Arc<Volume>,
        opts: &VolumeRenderOptions,
        stats: &VolumeStats,
        build: impl FnOnce(&GpuContext, &ResolvedTransfer) -> (SkipGrid, String),
    ) -> Result<Arc<SkipGrid>> {
        let key = KeyBuilder::new(kind)
            .u64(self.volume_key(volume))
            .debug(&opts.tf)
            .finish();
        let ctx = self.context()?;
        self.stage_with(
            "skip-grid",
            key,
            false,
            |g: &SkipGrid| g.bytes(),
            |_, _| {},
            || Ok(build(&ctx, &opts.tf.resolve(stats)?)),
        )
    }
}

/// The options the bricked ray caster lacks, refused with what to do instead.
fn check_bricked_options(name: &str, opts: &VolumeRenderOptions) -> Result<()> {
    if opts.shading.is_some() {
        return Err(Error::invalid(
            "shading",
            format!(
                "{name} renders bricked here (open_volume, brick or a memory_budget it exceeds), \
                 and the bricked ray caster has no shading: its one-voxel brick apron is too \
                 narrow for the gradient; to shade, load_volume it and render without brick or \
                 memory_budget"
            ),
        ));
    }
    if opts.tf_sampling != TfSampling::Point {
        return Err(Error::invalid(
            "tf_sampling",
            format!(
                "{name} renders bricked, and the bricked ray caster samples the transfer function \
                 at segment midpoints only; load_volume it and render without brick or \
                 memory_budget to pre-integrate"
            ),
        ));
    }
    Ok(())
}

/// The pass record's detail for a bricked render.
fn bricked_detail(path: RenderPath, s: &BrickedStats) -> String {
    let (brick, skip) = match path {
        RenderPath::Bricked { brick, skip } => (brick, skip),
        _ => (0, false),
    };
    let kind = if s.passes > 1 {
        "out-of-core"
    } else {
        "bricked"
    };
    format!(
        "{kind} {brick}³{}: {} needed, {} skipped, {} uploaded, {} pass{}",
        if skip { " skipping" } else { "" },
        s.needed,
        s.skipped,
        s.uploaded,
        s.passes,
        if s.passes == 1 { "" } else { "es" }
    )
}

/// The timing of a render measured on the host alone.
fn wall_seconds(seconds: f64) -> RenderTiming {
    RenderTiming {
        seconds,
        ..Default::default()
    }
}
