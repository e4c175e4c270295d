//! GPU tone mapping: the host side of the compute shaders in `shaders/tonemap/`. One
//! [`GpuToneMapper`] per GPU context builds each entry point's pipeline once and caches it; a
//! call uploads the HDR image once, records every pass of the chosen operator (log-luminance
//! statistics, then the global, histogram, dodging-and-burning or bilateral passes) into one
//! command buffer, submits it once and reads the display-referred result back. The image,
//! output and scratch buffers are kept between calls (a new 16 MiB buffer costs page faults and
//! wgpu's zero fill every time), and on CPU adapters the image and output buffers are mapped
//! directly ([`crate::gpu::transfer`]). The f64 CPU references in [`super::cpu`] define what
//! each pass must compute; the integration tests compare the two.

use super::bands::{self, Band, Window};
use super::cpu::{false_colour_decades, legend_height, turbo_lut};
use super::params::{
    blur_sigma, gaussian_radius, grid_sigma, reinhard_level, DurandGrid, Operator, ToneMapParams,
    ToneMapSettings,
};
use crate::error::{Error, Result};
use crate::gpu::transfer::{ReadbackBuffer, UploadBuffer};
use crate::gpu::{pipeline, shader, GpuContext};
use crate::model::HdrImage;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// Pixels per workgroup in every shader of `shaders/tonemap/`.
const WORKGROUP: u32 = 256;
/// Most workgroups a reduction (statistics, histogram, base range) dispatches; the shaders
/// stride over the rest of the image. Few and long-running: every workgroup ends in a tree of
/// barriers, which CPU rasterizers pay for by switching between the workgroup's invocations
/// (at 1024 the statistics of a 1024² image took 13 ms on lavapipe, at 64 about 5 ms).
const MAX_REDUCE_GROUPS: u32 = 64;

/// Metadata key marking an image whose values are display-referred linear in [0, 1] (written
/// by tone mapping and the false-colour view): PNG writers then apply only the sRGB curve.
pub const DISPLAY_REFERRED: &str = "display_referred";

/// Builds and caches the tone-mapping pipelines of one GPU context and runs them.
pub struct GpuToneMapper {
    ctx: Arc<GpuContext>,
    modules: Mutex<HashMap<&'static str, Arc<wgpu::ShaderModule>>>,
    pipelines: Mutex<HashMap<PipelineKey, Arc<wgpu::ComputePipeline>>>,
    /// Buffers kept between calls; the lock is held for a whole call, so concurrent calls on
    /// one mapper take turns.
    buffers: Mutex<BufferCache>,
    /// Most bytes one binding of an image-sized buffer may span: the adapter's storage-binding
    /// limit, or less for tests ([`Self::with_window_limit`]).
    window_limit: u64,
}

/// (shader file, entry point, specialisation).
type PipelineKey = (&'static str, &'static str, Specialisation);

/// Values of the pipeline-overridable constants of `shaders/shared/tonemap_common.wgsl`: the
/// operator and whether saturation and gamma are 1. Branches on uniforms cost as much as both
/// sides on Mesa's CPU rasterizers (the global pass ran every operator for every pixel), so
/// each combination gets its own pipeline with the others compiled out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
struct Specialisation {
    op: u32,
    plain_saturation: bool,
    plain_gamma: bool,
    gamut_clip: bool,
}

impl Specialisation {
    fn of(p: &ToneMapParams) -> Specialisation {
        Specialisation {
            op: p.op,
            plain_saturation: p.saturation == 1.0,
            plain_gamma: p.inv_gamma == 1.0,
            gamut_clip: p.gamut_clip != 0,
        }
    }

    fn constants(&self) -> [(&'static str, f64); 4] {
        [
            ("OP", self.op as f64),
            ("PLAIN_SATURATION", self.plain_saturation as u8 as f64),
            ("PLAIN_GAMMA", self.plain_gamma as u8 as f64),
            ("GAMUT_CLIP", self.gamut_clip as u8 as f64),
        ]
    }
}

/// The buffers of the last call, reused while the sizes stay the same.
#[derive(Default)]
struct BufferCache {
    image: Option<UploadBuffer>,
    output: Option<ReadbackBuffer>,
    scratch: HashMap<&'static str, wgpu::Buffer>,
}

impl BufferCache {
    fn image(&mut self, ctx: &GpuContext, bytes: u64) -> &UploadBuffer {
        let size = bytes.max(16).next_multiple_of(16);
        if self.image.as_ref().map(|b| b.buffer.size()) != Some(size) {
            self.image = Some(UploadBuffer::new(
                ctx,
                "hdr image",
                size,
                wgpu::BufferUsages::empty(),
            ));
        }
        self.image.as_ref().expect("just made")
    }

    fn output(&mut self, ctx: &GpuContext, bytes: u64) -> &ReadbackBuffer {
        let size = bytes.max(16).next_multiple_of(16);
        if self.output.as_ref().map(|b| b.buffer.size()) != Some(size) {
            self.output = Some(ReadbackBuffer::new(
                ctx,
                "display image",
                size,
                wgpu::BufferUsages::empty(),
            ));
        }
        self.output.as_ref().expect("just made")
    }

    /// A scratch storage buffer of exactly `bytes` (rounded up to 16) under `label`: shaders
    /// take lengths from `arrayLength`, so a larger cached buffer would not do.
    fn scratch(&mut self, ctx: &GpuContext, label: &'static str, bytes: u64) -> wgpu::Buffer {
        let size = bytes.max(16).next_multiple_of(16);
        self.scratch
            .entry(label)
            .and_modify(|b| {
                if b.size() != size {
                    *b = new_storage(ctx, label, size);
                }
            })
            .or_insert_with(|| new_storage(ctx, label, size))
            .clone()
    }
}

fn new_storage(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// One tone-mapping call being recorded: the context, its encoder and the uploaded image.
struct Recording<'a> {
    mapper: &'a GpuToneMapper,
    spec: Specialisation,
    encoder: wgpu::CommandEncoder,
    width: u32,
    height: u32,
    /// Windows (byte ranges) for the next dispatch's bindings; the rest are bound whole.
    windows: Vec<(u32, Window)>,
}

impl GpuToneMapper {
    /// A mapper for `ctx`. Pipelines are built on first use of each operator; the device was
    /// opened with the adapter's own limits, so images up to the adapter's storage-buffer
    /// binding size (16 bytes a pixel) fit.
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        Self::with_window_limit(ctx, u64::MAX)
    }

    /// A mapper that binds at most `bytes` of any image-sized buffer at once (never more than
    /// the adapter allows), so that the banded paths for images beyond one binding run on small
    /// images in tests. The per-grid buffers of Durand's filter (at most 32 MiB by
    /// construction, within every adapter's binding limit) are always bound whole.
    pub fn with_window_limit(ctx: Arc<GpuContext>, bytes: u64) -> Self {
        let window_limit = bytes.min(ctx.caps.max_storage_buffer_binding_size);
        GpuToneMapper {
            ctx,
            modules: Mutex::new(HashMap::new()),
            pipelines: Mutex::new(HashMap::new()),
            buffers: Mutex::new(BufferCache::default()),
            window_limit,
        }
    }

    /// Byte alignment of binding offsets.
    fn align(&self) -> u64 {
        (self.ctx.device.limits().min_storage_buffer_offset_alignment as u64).max(16)
    }

    /// The pixel bands of a `w` × `h` image: as many rows per band as keep every image-sized
    /// window (16 bytes a pixel) within the window limit and `fits` (an operator's own
    /// buffers), in multiples that keep window offsets aligned.
    fn plan(&self, w: u32, h: u32, fits: impl Fn(u32) -> bool) -> Result<PixelPlan> {
        let align = self.align();
        let step = bands::row_step(w as u64 * 8, align);
        let rows = bands::band_rows(h, step, "tone mapping", |r| {
            r as u64 * w as u64 * 16 <= self.window_limit && fits(r)
        })?;
        let group_step = bands::row_step(16, align);
        let groups = reduce_groups(rows * w).next_multiple_of(group_step);
        Ok(PixelPlan {
            width: w,
            bands: bands::split(h, rows),
            groups,
            align,
        })
    }

    /// How many bands of rows a `width` × `height` image is tone-mapped in with `op`: 1 when
    /// every image-sized buffer fits one binding (4096² RGBA f32 takes 2 on lavapipe's
    /// 128 MiB bindings, more for Reinhard's blurred scales).
    pub fn bands_for(&self, width: u32, height: u32, op: &Operator) -> Result<usize> {
        Ok(self.plan_for(width, height, op)?.1.bands.len())
    }

    /// The bands of a call with `op`, and Reinhard's pyramid where `op` is Reinhard local (its
    /// blurred scales decide how many rows a band may hold).
    fn plan_for(
        &self,
        width: u32,
        height: u32,
        op: &Operator,
    ) -> Result<(Option<ReinhardPlan>, PixelPlan)> {
        let reinhard = match *op {
            Operator::ReinhardLocal {
                alpha1,
                ratio,
                scales,
                ..
            } => Some(ReinhardPlan::new(width, height, alpha1, ratio, scales)),
            _ => None,
        };
        let plan = self.plan(width, height, |rows| {
            reinhard
                .as_ref()
                .is_none_or(|r| r.band_fits(rows, self.window_limit, self.align()))
        })?;
        Ok((reinhard, plan))
    }

    /// `base` for one band of items.
    fn band_uniform(&self, base: &ToneMapParams, band: Band) -> wgpu::Buffer {
        self.uniform(&ToneMapParams {
            band_first: band.first,
            band_rows: band.rows,
            ..*base
        })
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    fn module(&self, file: &'static str) -> Result<Arc<wgpu::ShaderModule>> {
        let mut cache = self.modules.lock().expect("shader cache poisoned");
        if let Some(m) = cache.get(file) {
            return Ok(m.clone());
        }
        let src = shader::load(file, &[])?;
        let module = pipeline::compile(&self.ctx, file, src, pipeline::RuntimeChecks::checked())?;
        let module = Arc::new(module);
        cache.insert(file, module.clone());
        Ok(module)
    }

    /// The pipeline of one entry point, built with the layout wgpu derives from the shader
    /// (each entry point binds only what it uses, as documented at the top of its file).
    fn pipeline(
        &self,
        file: &'static str,
        entry: &'static str,
        spec: Specialisation,
    ) -> Result<Arc<wgpu::ComputePipeline>> {
        if let Some(p) = self
            .pipelines
            .lock()
            .expect("pipeline cache poisoned")
            .get(&(file, entry, spec))
        {
            return Ok(p.clone());
        }
        let module = self.module(file)?;
        let build = pipeline::ComputeSpec {
            label: entry,
            what: &format!("{file} entry point {entry}"),
            shader: pipeline::Shader::Module(&module),
            entry,
            constants: &spec.constants(),
        };
        let pipeline = pipeline::compute(&self.ctx, build)?;
        let pipeline = Arc::new(pipeline);
        self.pipelines
            .lock()
            .expect("pipeline cache poisoned")
            .insert((file, entry, spec), pipeline.clone());
        Ok(pipeline)
    }

    /// Number of pipelines built so far (for tests of the cache).
    pub fn cached_pipelines(&self) -> usize {
        self.pipelines
            .lock()
            .expect("pipeline cache poisoned")
            .len()
    }

    fn check_image(&self, img: &HdrImage) -> Result<()> {
        let n = img.width as u64 * img.height as u64;
        if n == 0 {
            return Err(Error::invalid("image", "cannot tone-map an empty image"));
        }
        if img.pixels.len() as u64 != n {
            return Err(Error::invalid(
                "image",
                format!(
                    "{} pixels do not fill {}x{}",
                    img.pixels.len(),
                    img.width,
                    img.height
                ),
            ));
        }
        // Buffers larger than one binding are bound in windows of rows; the buffer itself must
        // fit the adapter's largest buffer.
        let bytes = n * 16;
        let limit = self.ctx.caps.max_buffer_size;
        if bytes > limit {
            return Err(Error::invalid(
                "image",
                format!(
                    "{}x{} needs {} MiB per RGBA f32 buffer but this adapter's buffers hold at most {} MiB; tone-map a smaller image",
                    img.width,
                    img.height,
                    bytes >> 20,
                    limit >> 20
                ),
            ));
        }
        Ok(())
    }

    fn storage_init(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            })
    }

    fn uniform(&self, p: &ToneMapParams) -> wgpu::Buffer {
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("tonemap params"),
                contents: bytemuck::bytes_of(p),
                usage: wgpu::BufferUsages::UNIFORM,
            })
    }

    /// Tone-maps `img` with `settings`: display-referred linear RGBA in [0, 1] (before the sRGB
    /// curve), missing pixels (any NaN/Inf component) as (0, 0, 0, 0). Images holding values
    /// below ~2^-110 (denormals) are uploaded lifted by 2^k with k stops taken off the exposure,
    /// so GPUs that flush denormals still see them (`PixelScan::lift`). The result carries the
    /// input's metadata plus `tonemap` (operator name), `transfer = display-linear` and
    /// `display_referred = 1`.
    pub fn tonemap(&self, img: &HdrImage, settings: &ToneMapSettings) -> Result<HdrImage> {
        settings.validate()?;
        self.check_image(img)?;
        let (w, h) = (img.width, img.height);
        let n = w * h;
        let px_bytes = n as u64 * 16;
        let ctx = &*self.ctx;
        let mut cache = self.buffers.lock().expect("tone-mapping buffers poisoned");
        let profile = Profile::start();
        let wants_range = matches!(settings.op, Operator::DurandBilateral { .. });
        let scan = upload_image(ctx, cache.image(ctx, px_bytes), &img.pixels, wants_range)?;
        let image = cache.image(ctx, px_bytes).buffer.clone();
        profile.mark("upload");
        let mut base = ToneMapParams::new(settings, w, h);
        base.exposure_ev = (settings.exposure_ev - scan.lift_ev as f64) as f32;
        let device = &ctx.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);

        let output = cache.output(ctx, px_bytes).buffer.clone();
        let (reinhard, plan) = self.plan_for(w, h, &settings.op)?;
        let stats = cache.scratch(ctx, "luminance stats", 16);
        let partials = cache.scratch(ctx, "partials", plan.partials_bytes());
        let mut rec = self.record(w, h, Specialisation::of(&base));
        let call = ToneMapCall {
            plan: &plan,
            base,
            image,
            output,
            stats,
            partials,
        };
        // Linear and ACES map each pixel on its own: no statistics pass, one read of the image
        // less (global.wgsl never reads `stats` for them).
        if !matches!(settings.op, Operator::Linear | Operator::Aces) {
            self.record_statistics(&mut rec, &call)?;
        }
        match settings.op {
            Operator::ReinhardLocal { .. } => {
                let r = reinhard.as_ref().expect("planned above");
                self.record_reinhard(&mut rec, &mut cache, r, &call)?;
            }
            Operator::DurandBilateral {
                sigma_spatial,
                sigma_range,
                ..
            } => {
                let (lo, hi) = scan.log10_luminance.unwrap_or((0.0, 0.0));
                let grid = DurandGrid::new(w, h, sigma_spatial, sigma_range, lo, hi);
                self.record_durand(&mut rec, &mut cache, &grid, &call)?;
            }
            _ => self.record_global(&mut rec, &mut cache, &settings.op, &call)?,
        }
        profile.mark("record");
        let pixels = rec.finish(cache.output(ctx, px_bytes), validation, oom, &profile)?;
        drop(cache);
        Ok(tonemapped_image(img, settings, pixels))
    }

    /// The log-luminance statistics: partial sums per band, then one workgroup combining them.
    fn record_statistics(&self, rec: &mut Recording<'_>, call: &ToneMapCall<'_>) -> Result<()> {
        let plan = call.plan;
        for (b, &band) in plan.bands.iter().enumerate() {
            let u = self.band_uniform(&call.base, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(6, plan.partials_window(b));
            rec.dispatch(
                "tonemap/luminance_stats.wgsl",
                "partial_stats",
                &[(0, &u), (1, &call.image), (6, &call.partials)],
                (plan.groups, 1),
            )?;
        }
        rec.single(
            "tonemap/luminance_stats.wgsl",
            "finish_stats",
            &[(3, &call.stats), (6, &call.partials)],
        )
    }

    /// The global operators after the statistics (Ward's histogram and its capped CDF first):
    /// one pass per band.
    fn record_global(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        op: &Operator,
        call: &ToneMapCall<'_>,
    ) -> Result<()> {
        let ctx = &*self.ctx;
        let (plan, base) = (call.plan, &call.base);
        let (image, stats) = (&call.image, &call.stats);
        let cdf = cache.scratch(ctx, "ward cdf", 257 * 4);
        if let Operator::WardHistogram { .. } = op {
            let counts = cache.scratch(ctx, "ward counts", 256 * 4);
            rec.encoder.clear_buffer(&counts, 0, None);
            let file = "tonemap/ward_histogram.wgsl";
            for &band in &plan.bands {
                let u = self.band_uniform(base, band);
                rec.window(1, plan.pixel_window(band, 16));
                rec.dispatch(
                    file,
                    "histogram",
                    &[(0, &u), (1, image), (3, stats), (5, &counts)],
                    (plan.groups, 1),
                )?;
            }
            let params = self.uniform(base);
            rec.single(
                file,
                "ceiling_cdf",
                &[(0, &params), (3, stats), (4, &cdf), (5, &counts)],
            )?;
        }
        for &band in &plan.bands {
            let u = self.band_uniform(base, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                "tonemap/global.wgsl",
                "apply_global",
                &[
                    (0, &u),
                    (1, image),
                    (2, &call.output),
                    (3, stats),
                    (4, &cdf),
                ],
            )?;
        }
        Ok(())
    }

    /// Durand and Dorsey's bilateral filter on a bilateral grid: the grid (splat and blurs),
    /// then per band the base layer, its range, and the recombination.
    fn record_durand(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        grid: &DurandGrid,
        call: &ToneMapCall<'_>,
    ) -> Result<()> {
        let ctx = &*self.ctx;
        let durand = ToneMapParams {
            cell: grid.cell,
            grid_width: grid.grid_width,
            grid_height: grid.grid_height,
            levels: grid.levels,
            first_level: grid.first_level as f32,
            level_step: grid.level_step as f32,
            sigma: grid.sigma_cells as f32,
            radius: grid.radius,
            ..call.base
        };
        let px_bytes = (rec.width * rec.height) as u64 * 16;
        let cells = grid.cells();
        let planes = cells as u64 * grid.levels as u64 * 8;
        let buffers = DurandBuffers {
            layers: cache.scratch(ctx, "durand layers", px_bytes),
            cells: cache.scratch(ctx, "durand cells", cells as u64 * 8),
            tmp: cache.scratch(ctx, "durand tmp", planes),
            levels: cache.scratch(ctx, "durand levels", planes),
            range: cache.scratch(ctx, "durand base range", 16),
        };
        self.record_durand_grid(rec, grid, &durand, &call.image, &buffers)?;
        self.record_durand_layers(rec, &durand, call, &buffers)
    }

    /// The bilateral grid: the splat of the image's log luminance in bands of grid rows, then
    /// the blur along x and along y.
    fn record_durand_grid(
        &self,
        rec: &mut Recording<'_>,
        grid: &DurandGrid,
        durand: &ToneMapParams,
        image: &wgpu::Buffer,
        buffers: &DurandBuffers,
    ) -> Result<()> {
        let (w, h) = (rec.width, rec.height);
        let u = self.uniform(durand);
        // The splat reads `cell` pixel rows per grid row: bands of grid rows whose
        // pixel rows fit one window.
        let row_bytes = w as u64 * 16;
        let align = self.align();
        let limit = self.window_limit;
        let grid_rows = bands::band_rows(grid.grid_height, 1, "durand splat", |r| {
            (r as u64 * grid.cell as u64 + bands::row_step(row_bytes, align) as u64) * row_bytes
                <= limit
        })?;
        for band in bands::split(grid.grid_height, grid_rows) {
            let rows = bands::window(
                0,
                row_bytes,
                band.first * grid.cell,
                (band.end() * grid.cell).min(h),
                align,
            );
            let u = self.uniform(&ToneMapParams {
                band_first: band.first,
                band_rows: band.rows,
                window_first: rows.first_row,
                ..*durand
            });
            rec.window(1, rows);
            rec.items(
                grid.grid_width * band.rows,
                DURAND_SHADER,
                "grid_splat",
                &[(0, &u), (1, image), (15, &buffers.cells)],
            )?;
        }
        let items = grid.cells() * grid.levels;
        rec.items(
            items,
            DURAND_SHADER,
            "grid_blur_x",
            &[(0, &u), (15, &buffers.cells), (16, &buffers.tmp)],
        )?;
        rec.items(
            items,
            DURAND_SHADER,
            "grid_blur_y",
            &[(0, &u), (16, &buffers.tmp), (17, &buffers.levels)],
        )
    }

    /// Per band the base layer sliced from the grid and its partial range, the range combined,
    /// then per band the recombination of base and detail.
    fn record_durand_layers(
        &self,
        rec: &mut Recording<'_>,
        durand: &ToneMapParams,
        call: &ToneMapCall<'_>,
        buffers: &DurandBuffers,
    ) -> Result<()> {
        let plan = call.plan;
        let (image, layers, range) = (&call.image, &buffers.layers, &buffers.range);
        for (b, &band) in plan.bands.iter().enumerate() {
            let u = self.band_uniform(durand, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(12, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                DURAND_SHADER,
                "base",
                &[(0, &u), (1, image), (12, layers), (17, &buffers.levels)],
            )?;
            rec.window(12, plan.pixel_window(band, 16))
                .window(6, plan.partials_window(b));
            rec.dispatch(
                DURAND_SHADER,
                "range_partial",
                &[(0, &u), (6, &call.partials), (12, layers)],
                (plan.groups, 1),
            )?;
        }
        rec.single(
            DURAND_SHADER,
            "range_finish",
            &[(6, &call.partials), (13, range)],
        )?;
        for &band in &plan.bands {
            let u = self.band_uniform(durand, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16))
                .window(12, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                DURAND_SHADER,
                "apply",
                &[
                    (0, &u),
                    (1, image),
                    (2, &call.output),
                    (12, layers),
                    (13, range),
                ],
            )?;
        }
        Ok(())
    }

    /// False-colour view of log10 luminance (after `exposure_ev`) through turbo, over the whole
    /// decades `decades` or those spanning the image, with the legend strip along the bottom;
    /// the GPU twin of [`super::cpu::false_colour_log10`] (same metadata keys).
    pub fn false_colour(
        &self,
        img: &HdrImage,
        exposure_ev: f64,
        decades: Option<(f64, f64)>,
    ) -> Result<HdrImage> {
        if !exposure_ev.is_finite() || exposure_ev.abs() > 200.0 {
            return Err(Error::invalid(
                "exposure_ev",
                format!("{exposure_ev} must be a finite number of stops in [-200, 200]"),
            ));
        }
        self.check_image(img)?;
        let (low, high) = false_colour_decades(img, exposure_ev, decades)?;
        let (w, h) = (img.width, img.height);
        let px_bytes = w as u64 * h as u64 * 16;
        let ctx = &*self.ctx;
        let mut cache = self.buffers.lock().expect("tone-mapping buffers poisoned");
        let scan = upload_image(ctx, cache.image(ctx, px_bytes), &img.pixels, false)?;
        let image = cache.image(ctx, px_bytes).buffer.clone();
        let output = cache.output(ctx, px_bytes).buffer.clone();
        let device = &ctx.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let base = ToneMapParams {
            width: w,
            height: h,
            exposure_ev: (exposure_ev - scan.lift_ev as f64) as f32,
            ld_min: low as f32,
            ld_max: high as f32,
            radius: legend_height(h),
            ..Default::default()
        };
        let lut = self.storage_init("turbo lut", bytemuck::cast_slice(&turbo_lut()));
        let plan = self.plan(w, h, |_| true)?;
        let mut rec = self.record(w, h, Specialisation::default());
        for &band in &plan.bands {
            let u = self.band_uniform(&base, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                "tonemap/false_colour.wgsl",
                "false_colour",
                &[(0, &u), (1, &image), (2, &output), (14, &lut)],
            )?;
        }
        let pixels = rec.finish(
            cache.output(ctx, px_bytes),
            validation,
            oom,
            &Profile::start(),
        )?;
        drop(cache);
        let mut out = HdrImage::from_pixels(w, h, pixels);
        out.metadata = img.metadata.clone();
        out.set_meta("false_colour.log10_min", format!("{low}"));
        out.set_meta("false_colour.log10_max", format!("{high}"));
        super::cpu::false_colour_bar(low, high).record(&mut out);
        out.set_meta("transfer", "display-linear");
        out.set_meta(DISPLAY_REFERRED, "1");
        Ok(out)
    }

    fn record(&self, width: u32, height: u32, spec: Specialisation) -> Recording<'_> {
        Recording {
            mapper: self,
            spec,
            encoder: self
                .ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("tonemap"),
                }),
            width,
            height,
            windows: Vec::new(),
        }
    }

    /// Reinhard's dodging and burning after the statistics: the pyramid, the blurs, and per
    /// pixel band the rows of every blurred scale that band reads, then the scale selection.
    /// Pyramid levels alternate between two buffers (a downsample reads one and writes the
    /// other), each scale's horizontal blur is kept whole, and the vertical blur writes only
    /// the rows a band needs into a band-sized buffer (one band: the whole image, as before).
    fn record_reinhard(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        r: &ReinhardPlan,
        call: &ToneMapCall<'_>,
    ) -> Result<()> {
        let ctx = &*self.ctx;
        let offsets = r.pyramid_offsets(self.align());
        let parity_bytes = |p: u32| {
            (0..=r.deepest)
                .filter(|k| k % 2 == p)
                .map(|k| offsets[k as usize] + r.level_bytes(k))
                .max()
                .unwrap_or(16)
        };
        let pyramid = [
            cache.scratch(ctx, "reinhard pyramid even", parity_bytes(0)),
            cache.scratch(ctx, "reinhard pyramid odd", parity_bytes(1)),
        ];
        let tmp: Vec<wgpu::Buffer> = r
            .levels
            .iter()
            .enumerate()
            .map(|(i, &k)| cache.scratch(ctx, TMP_LABELS[i], r.level_bytes(k)))
            .collect();
        let buffers = ReinhardBuffers {
            offsets,
            pyramid,
            tmp,
        };
        self.record_reinhard_pyramid(rec, r, call, &buffers)?;
        self.record_reinhard_blur_x(rec, r, &call.base, &buffers)?;
        self.record_reinhard_scales(rec, cache, r, call, &buffers)
    }

    /// Level 0 of the pyramid (the pixels' (L m, m)) per pixel band, then each deeper level
    /// downsampled from the one above in bands that keep both windows within the limit.
    fn record_reinhard_pyramid(
        &self,
        rec: &mut Recording<'_>,
        r: &ReinhardPlan,
        call: &ToneMapCall<'_>,
        buffers: &ReinhardBuffers,
    ) -> Result<()> {
        let (plan, base, offsets) = (call.plan, &call.base, &buffers.offsets);
        let align = self.align();
        let limit = self.window_limit;
        // Level 0: the pixels' (L m, m).
        for &band in &plan.bands {
            let u = self.band_uniform(base, band);
            rec.window(1, plan.pixel_window(band, 16)).window(
                10,
                bands::window(
                    offsets[0],
                    r.width as u64 * 8,
                    band.first,
                    band.end(),
                    align,
                ),
            );
            rec.pixels(
                band,
                REINHARD_SHADER,
                "prepare",
                &[
                    (0, &u),
                    (1, &call.image),
                    (3, &call.stats),
                    (10, buffers.level(0)),
                ],
            )?;
        }
        for k in 1..=r.deepest {
            let (gw, gh) = r.level_size(k);
            let (sw, sh) = r.level_size(k - 1);
            let (row, src_row) = (gw as u64 * 8, sw as u64 * 8);
            let rows =
                bands::band_rows(gh, bands::row_step(row, align), "reinhard pyramid", |n| {
                    n as u64 * row <= limit
                        && (2 * n as u64 + bands::row_step(src_row, align) as u64) * src_row
                            <= limit
                })?;
            for band in bands::split(gh, rows) {
                let src = bands::window(
                    offsets[k as usize - 1],
                    src_row,
                    2 * band.first,
                    (2 * band.end()).min(sh),
                    align,
                );
                let u = self.uniform(&ToneMapParams {
                    band_first: band.first,
                    band_rows: band.rows,
                    window_first: src.first_row,
                    ..r.level_params(base, k)
                });
                rec.window(8, src).window(
                    9,
                    bands::window(offsets[k as usize], row, band.first, band.end(), align),
                );
                rec.items(
                    gw * band.rows,
                    REINHARD_SHADER,
                    "downsample",
                    &[(0, &u), (8, buffers.level(k - 1)), (9, buffers.level(k))],
                )?;
            }
        }
        Ok(())
    }

    /// Each scale's horizontal blur, whole, on its level.
    fn record_reinhard_blur_x(
        &self,
        rec: &mut Recording<'_>,
        r: &ReinhardPlan,
        base: &ToneMapParams,
        buffers: &ReinhardBuffers,
    ) -> Result<()> {
        let align = self.align();
        let limit = self.window_limit;
        for (i, &k) in r.levels.iter().enumerate() {
            let (gw, gh) = r.level_size(k);
            let row = gw as u64 * 8;
            let rows = bands::band_rows(gh, bands::row_step(row, align), "reinhard blur", |n| {
                n as u64 * row <= limit
            })?;
            let blur = ToneMapParams {
                sigma: r.sigma_cells[i] as f32,
                radius: r.radius[i],
                ..r.level_params(base, k)
            };
            for band in bands::split(gh, rows) {
                let u = self.band_uniform(&blur, band);
                rec.window(
                    8,
                    bands::window(
                        buffers.offsets[k as usize],
                        row,
                        band.first,
                        band.end(),
                        align,
                    ),
                )
                .window(9, bands::window(0, row, band.first, band.end(), align));
                rec.items(
                    gw * band.rows,
                    REINHARD_SHADER,
                    "blur_x",
                    &[(0, &u), (8, buffers.level(k)), (9, &buffers.tmp[i])],
                )?;
            }
        }
        Ok(())
    }

    /// Per pixel band: the vertical blur of the rows of every scale the band reads, into one
    /// band-sized buffer, then the scale selection over them.
    fn record_reinhard_scales(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        r: &ReinhardPlan,
        call: &ToneMapCall<'_>,
        buffers: &ReinhardBuffers,
    ) -> Result<()> {
        let (plan, base) = (call.plan, &call.base);
        let align = self.align();
        let band_planes: Vec<Vec<Band>> = plan.bands.iter().map(|&b| r.planes_for(b)).collect();
        let largest = band_planes
            .iter()
            .map(|planes| r.planes_bytes(planes))
            .max()
            .unwrap_or(16);
        let blurred = cache.scratch(&self.ctx, "reinhard blurred", largest);
        for (&band, planes) in plan.bands.iter().zip(&band_planes) {
            let mut table = [[0u32; 4]; 17];
            let mut at = 0u32;
            for (i, (&k, rows)) in r.levels.iter().zip(planes).enumerate() {
                let (gw, gh) = r.level_size(k);
                let halo = bands::window(
                    0,
                    gw as u64 * 8,
                    rows.first.saturating_sub(r.radius[i]),
                    (rows.end() + r.radius[i]).min(gh),
                    align,
                );
                let u = self.uniform(&ToneMapParams {
                    sigma: r.sigma_cells[i] as f32,
                    radius: r.radius[i],
                    band_first: rows.first,
                    band_rows: rows.rows,
                    window_first: halo.first_row,
                    dst_offset: at,
                    ..r.level_params(base, k)
                });
                rec.window(8, halo);
                rec.items(
                    gw * rows.rows,
                    REINHARD_SHADER,
                    "blur_y",
                    &[(0, &u), (8, &buffers.tmp[i]), (9, &blurred)],
                )?;
                let scale = r.ratio.powi(i as i32) as f32;
                table[i] = [at, k, scale.to_bits(), rows.first];
                at += gw * rows.rows;
            }
            let table_buffer =
                self.ctx
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("reinhard scales"),
                        contents: bytemuck::cast_slice(&table),
                        usage: wgpu::BufferUsages::UNIFORM,
                    });
            let u = self.band_uniform(
                &ToneMapParams {
                    levels: r.levels.len() as u32,
                    ..*base
                },
                band,
            );
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                REINHARD_SHADER,
                "apply",
                &[
                    (0, &u),
                    (1, &call.image),
                    (2, &call.output),
                    (3, &call.stats),
                    (11, &blurred),
                    (18, &table_buffer),
                ],
            )?;
        }
        Ok(())
    }
}

/// The shader file of Reinhard's dodging and burning.
const REINHARD_SHADER: &str = "tonemap/reinhard_local.wgsl";
/// The shader file of Durand and Dorsey's bilateral operator.
const DURAND_SHADER: &str = "tonemap/durand_bilateral.wgsl";

/// What every pass of one tone-mapping call shares: the pixel bands, the parameters before
/// any operator's own, and the buffers all operators bind.
struct ToneMapCall<'a> {
    plan: &'a PixelPlan,
    base: ToneMapParams,
    image: wgpu::Buffer,
    output: wgpu::Buffer,
    stats: wgpu::Buffer,
    partials: wgpu::Buffer,
}

/// The scratch buffers of Durand's operator: base and detail layers, the grid as splatted,
/// blurred along x, and blurred (its levels), and the base layer's range.
struct DurandBuffers {
    layers: wgpu::Buffer,
    cells: wgpu::Buffer,
    tmp: wgpu::Buffer,
    levels: wgpu::Buffer,
    range: wgpu::Buffer,
}

/// Reinhard's pyramid, its levels alternating between two buffers at `offsets`, and each
/// scale's horizontal blur.
struct ReinhardBuffers {
    offsets: Vec<u64>,
    pyramid: [wgpu::Buffer; 2],
    tmp: Vec<wgpu::Buffer>,
}

impl ReinhardBuffers {
    /// The buffer holding pyramid level k.
    fn level(&self, k: u32) -> &wgpu::Buffer {
        &self.pyramid[(k % 2) as usize]
    }
}

/// The display-referred result of [`GpuToneMapper::tonemap`]: `img`'s extra channels and
/// metadata plus what tone mapping records.
fn tonemapped_image(img: &HdrImage, settings: &ToneMapSettings, pixels: Vec<[f32; 4]>) -> HdrImage {
    let mut out = HdrImage::from_pixels(img.width, img.height, pixels);
    out.extra_channels = img.extra_channels.clone();
    out.metadata = img.metadata.clone();
    out.set_meta("tonemap", settings.op.name());
    out.set_meta("gamut", settings.gamut.name());
    out.set_meta("tonemap.exposure_ev", format!("{}", settings.exposure_ev));
    out.set_meta("transfer", "display-linear");
    out.set_meta(DISPLAY_REFERRED, "1");
    out
}

/// Labels of the per-scale horizontal-blur buffers of Reinhard's operator (at most 17 scales).
const TMP_LABELS: [&str; 17] = [
    "reinhard blur 0",
    "reinhard blur 1",
    "reinhard blur 2",
    "reinhard blur 3",
    "reinhard blur 4",
    "reinhard blur 5",
    "reinhard blur 6",
    "reinhard blur 7",
    "reinhard blur 8",
    "reinhard blur 9",
    "reinhard blur 10",
    "reinhard blur 11",
    "reinhard blur 12",
    "reinhard blur 13",
    "reinhard blur 14",
    "reinhard blur 15",
    "reinhard blur 16",
];

/// The pixel bands of one call and the reduction layout over them.
struct PixelPlan {
    width: u32,
    bands: Vec<Band>,
    /// Workgroups of a strided reduction per band (a multiple that keeps the partials'
    /// windows aligned); the partials buffer holds `groups` entries per band.
    groups: u32,
    align: u64,
}

impl PixelPlan {
    /// The window of a per-pixel buffer of `bytes` a pixel over `band` (it starts at the band's
    /// first row: bands are multiples of the alignment step).
    fn pixel_window(&self, band: Band, bytes: u64) -> Window {
        let w = bands::window(
            0,
            self.width as u64 * bytes,
            band.first,
            band.end(),
            self.align,
        );
        debug_assert_eq!(w.first_row, band.first);
        w
    }

    fn partials_bytes(&self) -> u64 {
        self.bands.len() as u64 * self.groups as u64 * 16
    }

    fn partials_window(&self, band_index: usize) -> Window {
        let size = self.groups as u64 * 16;
        Window {
            offset: band_index as u64 * size,
            size,
            first_row: 0,
        }
    }
}

/// Reinhard's scales on their pyramid levels (params.rs: `blur_sigma`, `reinhard_level`,
/// `grid_sigma`) for one image size.
struct ReinhardPlan {
    width: u32,
    height: u32,
    ratio: f64,
    /// Pyramid level of each scale.
    levels: Vec<u32>,
    sigma_cells: Vec<f64>,
    radius: Vec<u32>,
    deepest: u32,
}

impl ReinhardPlan {
    fn new(width: u32, height: u32, alpha1: f64, ratio: f64, scales: u32) -> Self {
        let sigmas: Vec<f64> = (0..=scales).map(|i| blur_sigma(alpha1, ratio, i)).collect();
        let levels: Vec<u32> = sigmas.iter().map(|&s| reinhard_level(s)).collect();
        let sigma_cells: Vec<f64> = sigmas
            .iter()
            .zip(&levels)
            .map(|(&s, &k)| grid_sigma(s, 1 << k))
            .collect();
        ReinhardPlan {
            width,
            height,
            ratio,
            radius: sigma_cells.iter().map(|&s| gaussian_radius(s)).collect(),
            deepest: levels.iter().copied().max().unwrap_or(0),
            levels,
            sigma_cells,
        }
    }

    /// `base` on the cells of pyramid level k (2^k pixels a side).
    fn level_params(&self, base: &ToneMapParams, k: u32) -> ToneMapParams {
        let cell = 1u32 << k;
        ToneMapParams {
            cell,
            grid_width: self.width.div_ceil(cell),
            grid_height: self.height.div_ceil(cell),
            ..*base
        }
    }

    fn level_size(&self, k: u32) -> (u32, u32) {
        (self.width.div_ceil(1 << k), self.height.div_ceil(1 << k))
    }

    fn level_bytes(&self, k: u32) -> u64 {
        let (gw, gh) = self.level_size(k);
        gw as u64 * gh as u64 * 8
    }

    /// Byte offset of each level in its parity's buffer (aligned, so windows can start there).
    fn pyramid_offsets(&self, align: u64) -> Vec<u64> {
        let mut next = [0u64; 2];
        (0..=self.deepest)
            .map(|k| {
                let p = (k % 2) as usize;
                let here = next[p];
                next[p] = (here + self.level_bytes(k)).next_multiple_of(align);
                here
            })
            .collect()
    }

    /// The cell rows of level k that the bilinear read of pixel row y touches (as the apply
    /// pass: cell centres at (c + 0.5)·2^k − 0.5, clamped to the outermost).
    fn cell_rows(&self, k: u32, y: u32) -> (u32, u32) {
        if k == 0 {
            return (y, y);
        }
        let gh = self.level_size(k).1;
        let cell = (1u32 << k) as f64;
        let v = ((y as f64 + 0.5) / cell - 0.5).clamp(0.0, (gh - 1) as f64);
        let y0 = v.floor() as u32;
        (y0, (y0 + 1).min(gh - 1))
    }

    /// Per scale, the rows of its level that pixel rows `band` read.
    fn planes_for(&self, band: Band) -> Vec<Band> {
        self.levels
            .iter()
            .map(|&k| {
                let first = self.cell_rows(k, band.first).0;
                let last = self.cell_rows(k, band.end() - 1).1;
                Band {
                    first,
                    rows: last - first + 1,
                }
            })
            .collect()
    }

    fn planes_bytes(&self, planes: &[Band]) -> u64 {
        planes
            .iter()
            .zip(&self.levels)
            .map(|(p, &k)| p.rows as u64 * self.level_size(k).0 as u64 * 8)
            .sum()
    }

    /// Whether a band of `rows` pixel rows keeps Reinhard's windows within `limit`: level 0
    /// of the pyramid, the band's blurred rows of every scale, and each vertical blur's input
    /// (the band's rows plus the blur's radius on both sides).
    fn band_fits(&self, rows: u32, limit: u64, align: u64) -> bool {
        let rows = rows.min(self.height);
        let worst = Band {
            first: (self.height - rows) / 2,
            rows,
        };
        let planes = self.planes_for(worst);
        let halo_fits = planes
            .iter()
            .zip(&self.levels)
            .zip(&self.radius)
            .all(|((p, &k), &r)| {
                let row = self.level_size(k).0 as u64 * 8;
                (p.rows as u64 + 2 * r as u64 + bands::row_step(row, align) as u64) * row <= limit
            });
        rows as u64 * self.width as u64 * 8 <= limit
            && self.planes_bytes(&planes) <= limit
            && halo_fits
    }
}

impl Recording<'_> {
    fn dispatch(
        &mut self,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
        groups: (u32, u32),
    ) -> Result<()> {
        let pipeline = self.mapper.pipeline(file, entry, self.spec)?;
        let windows = std::mem::take(&mut self.windows);
        let entries: Vec<wgpu::BindGroupEntry> = bindings
            .iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding: *binding,
                resource: match windows.iter().find(|(b, _)| b == binding) {
                    Some((_, w)) => wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer,
                        offset: w.offset,
                        size: wgpu::BufferSize::new(w.size),
                    }),
                    None => buffer.as_entire_binding(),
                },
            })
            .collect();
        let bind_group = self
            .mapper
            .ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(entry),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
        let mut pass = self
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(entry),
                timestamp_writes: None,
            });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
        Ok(())
    }

    /// Binds `window` of the buffer at `binding` in the next dispatch.
    fn window(&mut self, binding: u32, window: Window) -> &mut Self {
        self.windows.push((binding, window));
        self
    }

    /// One invocation per pixel of `band`.
    fn pixels(
        &mut self,
        band: Band,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        let groups = pixel_groups(self.width * band.rows);
        self.dispatch(file, entry, bindings, groups)
    }

    /// One invocation per item (grid cells, pyramid cells, cells x levels).
    fn items(
        &mut self,
        count: u32,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        self.dispatch(file, entry, bindings, pixel_groups(count))
    }

    /// One workgroup (combining partial results).
    fn single(
        &mut self,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        self.dispatch(file, entry, bindings, (1, 1))
    }

    /// Submits everything once, waits, checks the error scopes and reads `output` back.
    fn finish(
        self,
        output: &ReadbackBuffer,
        validation: wgpu::ErrorScopeGuard,
        oom: wgpu::ErrorScopeGuard,
        profile: &Profile,
    ) -> Result<Vec<[f32; 4]>> {
        let ctx = &self.mapper.ctx;
        let bytes = self.width as u64 * self.height as u64 * 16;
        let mut encoder = self.encoder;
        output.record_copy(&mut encoder, bytes);
        ctx.queue.submit([encoder.finish()]);
        if profile.on() {
            ctx.wait()?;
            profile.mark("passes");
        }
        let invalid = pollster::block_on(validation.pop());
        let out_of_memory = pollster::block_on(oom.pop());
        if let Some(e) = out_of_memory {
            return Err(Error::Gpu(format!(
                "out of GPU memory while tone mapping: {e}"
            )));
        }
        if let Some(e) = invalid {
            return Err(Error::Gpu(format!("tone-mapping pass failed: {e}")));
        }
        let pixels = output.read(ctx, bytes);
        profile.mark("readback");
        pixels
    }
}

/// Stage times on stderr when `HDRVIS_TONEMAP_PROFILE` is set (for finding where a call's time
/// goes; the benchmark measures whole calls).
struct Profile(Option<std::time::Instant>);

impl Profile {
    fn start() -> Profile {
        Profile(std::env::var_os("HDRVIS_TONEMAP_PROFILE").map(|_| std::time::Instant::now()))
    }

    fn on(&self) -> bool {
        self.0.is_some()
    }

    fn mark(&self, stage: &str) {
        if let Some(t) = self.0 {
            eprintln!("tonemap {stage}: {:.2} ms", t.elapsed().as_secs_f64() * 1e3);
        }
    }
}

/// Smallest component magnitude passed to the shaders unchanged: below it (denormals
/// included), a Rec. 709 weighted sum can reach the denormal range, which GPUs may flush to
/// zero (lavapipe does).
const TINY: f32 = 7.7e-34; // about 2^-110

/// What one pass over the pixels learns: whether finite non-zero components below [`TINY`]
/// occur, the largest finite component magnitude, and (when asked) the smallest and largest
/// positive finite Rec. 709 luminance, in f64 as the CPU reference computes it.
#[derive(Clone, Copy, Debug)]
struct PixelScan {
    tiny: bool,
    largest: f32,
    luminance: (f64, f64),
}

impl PixelScan {
    const EMPTY: PixelScan = PixelScan {
        tiny: false,
        largest: 0.0,
        luminance: (f64::INFINITY, 0.0),
    };

    fn of(chunk: &[[f32; 4]], with_luminance: bool) -> PixelScan {
        let mut scan = PixelScan::EMPTY;
        for p in chunk {
            for &v in &p[..3] {
                let a = v.abs();
                if a.is_finite() {
                    scan.tiny |= a != 0.0 && a < TINY;
                    scan.largest = scan.largest.max(a);
                }
            }
            if with_luminance && p.iter().all(|v| v.is_finite()) {
                let y = 0.2126 * (p[0] as f64).max(0.0)
                    + 0.7152 * (p[1] as f64).max(0.0)
                    + 0.0722 * (p[2] as f64).max(0.0);
                if y > 0.0 {
                    scan.luminance = (scan.luminance.0.min(y), scan.luminance.1.max(y));
                }
            }
        }
        scan
    }

    fn merge(self, o: PixelScan) -> PixelScan {
        PixelScan {
            tiny: self.tiny | o.tiny,
            largest: self.largest.max(o.largest),
            luminance: (
                self.luminance.0.min(o.luminance.0),
                self.luminance.1.max(o.luminance.1),
            ),
        }
    }

    fn of_all(pixels: &[[f32; 4]], with_luminance: bool) -> PixelScan {
        pixels
            .par_chunks(SCAN_CHUNK)
            .map(|c| PixelScan::of(c, with_luminance))
            .reduce(|| PixelScan::EMPTY, PixelScan::merge)
    }

    /// log10 of the luminance range, when any pixel is lit.
    fn log10_luminance(&self) -> Option<(f64, f64)> {
        let (lo, hi) = self.luminance;
        (hi > 0.0).then(|| (lo.log10(), hi.log10()))
    }

    /// Stops k to lift the image by (×2^k, taken off the exposure: exact, as a power of two, no
    /// overflow by construction, and invisible in the result since the shaders apply exposure
    /// to ln L after the weighted sum) when it holds tiny values and has headroom below
    /// f32::MAX.
    fn lift(&self) -> Option<i32> {
        if !self.tiny {
            return None;
        }
        let headroom = (f32::MAX / self.largest.max(f32::MIN_POSITIVE))
            .log2()
            .floor() as i32
            - 2;
        Some(headroom.clamp(0, 96)).filter(|&k| k > 0)
    }
}

/// Pixels per chunk of the parallel scans and copies (256 KiB: stays in cache between the
/// copy and the scan of the same chunk).
const SCAN_CHUNK: usize = 1 << 14;

/// When `pixels` hold finite non-zero values below [`TINY`], a copy multiplied by 2^k and the
/// k (stops) to take off the exposure: what [`upload_image`] does, as one function for tests.
#[cfg(test)]
fn lift_tiny_values(pixels: &[[f32; 4]]) -> Option<(Vec<[f32; 4]>, i32)> {
    let k = PixelScan::of_all(pixels, false).lift()?;
    Some((lift_by(pixels, k), k))
}

fn lift_by(pixels: &[[f32; 4]], k: i32) -> Vec<[f32; 4]> {
    let gain = 2f32.powi(k);
    pixels
        .par_iter()
        .map(|p| [p[0] * gain, p[1] * gain, p[2] * gain, p[3]])
        .collect()
}

/// A disjoint piece of a write-only mapping, handed to a worker thread.
struct Piece<'a>(wgpu::WriteOnly<'a, [u8]>);

// SAFETY: a `WriteOnly<[u8]>` is exclusive, write-only access to its bytes, like `&mut [u8]`,
// which is Send; wgpu implements Send for `WriteOnly<T>` with sized `T` only. The pieces come
// from `split_at`, so no two threads reach the same byte.
unsafe impl Send for Piece<'_> {}

/// What [`upload_image`] learnt about the image on its way to the GPU.
struct UploadScan {
    /// Stops the upload was lifted by ([`PixelScan::lift`]); taken off the exposure.
    lift_ev: i32,
    /// log10 of the smallest and largest positive Rec. 709 luminance of the uploaded values
    /// (when asked for).
    log10_luminance: Option<(f64, f64)>,
}

/// Writes `pixels` into `target` (lifted by 2^k when they hold values the GPU would flush) and
/// reports the luminance range when `wants_range`. One parallel pass copies each chunk and
/// scans it while it is in cache; only an image with tiny values is written a second time.
fn upload_image(
    ctx: &GpuContext,
    target: &UploadBuffer,
    pixels: &[[f32; 4]],
    wants_range: bool,
) -> Result<UploadScan> {
    let mut scan = PixelScan::EMPTY;
    target.write_with(ctx, std::mem::size_of_val(pixels) as u64, |mut dst| {
        let mut pieces = Vec::with_capacity(pixels.len().div_ceil(SCAN_CHUNK));
        for src in pixels.chunks(SCAN_CHUNK) {
            let (head, rest) = dst.split_at(std::mem::size_of_val(src));
            pieces.push((Piece(head), src));
            dst = rest;
        }
        scan = pieces
            .into_par_iter()
            .map(|(Piece(mut d), s)| {
                d.copy_from_slice(bytemuck::cast_slice(s));
                PixelScan::of(s, wants_range)
            })
            .reduce(|| PixelScan::EMPTY, PixelScan::merge);
    })?;
    let Some(k) = scan.lift() else {
        return Ok(UploadScan {
            lift_ev: 0,
            log10_luminance: if wants_range {
                scan.log10_luminance()
            } else {
                None
            },
        });
    };
    let lifted = lift_by(pixels, k);
    target.write(ctx, bytemuck::cast_slice(&lifted))?;
    Ok(UploadScan {
        lift_ev: k,
        log10_luminance: if wants_range {
            PixelScan::of_all(&lifted, true).log10_luminance()
        } else {
            None
        },
    })
}

/// Per-pixel dispatch size (X, Y) with X * Y * 256 >= n and X within the 65535 limit; the
/// shaders index pixels as global_id.x + global_id.y * X * 256.
fn pixel_groups(n: u32) -> (u32, u32) {
    let groups = n.div_ceil(WORKGROUP).max(1);
    let x = groups.min(65535);
    (x, groups.div_ceil(x))
}

/// Workgroups of a strided reduction: one per 256 pixels, at most [`MAX_REDUCE_GROUPS`].
fn reduce_groups(n: u32) -> u32 {
    n.div_ceil(WORKGROUP).clamp(1, MAX_REDUCE_GROUPS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_sizes_cover_every_pixel() {
        for n in [1u32, 255, 256, 257, 1 << 20, 1 << 24, (1 << 24) + 1] {
            let (x, y) = pixel_groups(n);
            assert!(x <= 65535 && x as u64 * y as u64 * 256 >= n as u64, "{n}");
            let g = reduce_groups(n);
            assert!((1..=MAX_REDUCE_GROUPS).contains(&g));
        }
    }

    #[test]
    fn tiny_values_are_lifted_exactly() {
        assert!(lift_tiny_values(&[[1e-3, 1.0, 1e30, 1.0]]).is_none());
        let (lifted, k) = lift_tiny_values(&[[1e-40, 0.0, 1e-3, 0.5], [f32::NAN; 4]]).unwrap();
        assert!(k > 0);
        assert_eq!(lifted[0][0] as f64, 1e-40f32 as f64 * 2f64.powi(k));
        assert_eq!(lifted[0][3], 0.5);
        assert!(lifted[1][0].is_nan());
    }
}
