//! GPU tone mapping: the host side of the compute shaders in `shaders/tonemap/`. One
//! [`GpuToneMapper`] per GPU context builds each entry point's pipeline once and caches it; a
//! call uploads the HDR image once, records every pass of the chosen operator (log-luminance
//! statistics, then the global, histogram, dodging-and-burning or bilateral passes) into one
//! command buffer, submits it once and reads the display-referred result back. The image,
//! output and scratch buffers are kept between calls (a new 16 MiB buffer costs page faults and
//! wgpu's zero fill every time), and on CPU adapters the image and output buffers are mapped
//! directly ([`crate::gpu::transfer`]). The f64 CPU references in [`super::cpu`] define what
//! each pass must compute; the integration tests compare the two.

use super::cpu::{false_colour_decades, legend_height, turbo_lut};
use super::params::{
    blur_sigma, gaussian_radius, grid_sigma, reinhard_level, DurandGrid, Operator, ToneMapParams,
    ToneMapSettings,
};
use crate::error::{Error, Result};
use crate::gpu::transfer::{ReadbackBuffer, UploadBuffer};
use crate::gpu::{shader, GpuContext};
use crate::model::HdrImage;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// Pixels per workgroup in every shader of `shaders/tonemap/`.
const WORKGROUP: u32 = 256;
/// Most workgroups a reduction (statistics, histogram, base range) dispatches; the shaders
/// stride over the rest of the image.
const MAX_REDUCE_GROUPS: u32 = 1024;

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
}

impl Specialisation {
    fn of(p: &ToneMapParams) -> Specialisation {
        Specialisation {
            op: p.op,
            plain_saturation: p.saturation == 1.0,
            plain_gamma: p.inv_gamma == 1.0,
        }
    }

    fn constants(&self) -> [(&'static str, f64); 3] {
        [
            ("OP", self.op as f64),
            ("PLAIN_SATURATION", self.plain_saturation as u8 as f64),
            ("PLAIN_GAMMA", self.plain_gamma as u8 as f64),
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
}

impl GpuToneMapper {
    /// A mapper for `ctx`. Pipelines are built on first use of each operator; the device was
    /// opened with the adapter's own limits, so images up to the adapter's storage-buffer
    /// binding size (16 bytes a pixel) fit.
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        GpuToneMapper {
            ctx,
            modules: Mutex::new(HashMap::new()),
            pipelines: Mutex::new(HashMap::new()),
            buffers: Mutex::new(BufferCache::default()),
        }
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
        let device = &self.ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(file),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("{file} failed to compile: {e}")));
        }
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
        let device = &self.ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &spec.constants(),
                // Every shader writes its workgroup memory before reading it.
                zero_initialize_workgroup_memory: false,
            },
            cache: self.ctx.pipeline_cache(),
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!(
                "{file} entry point {entry} failed to build: {e}"
            )));
        }
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
        let bytes = n * 16;
        let caps = &self.ctx.caps;
        let limit = caps
            .max_storage_buffer_binding_size
            .min(caps.max_buffer_size);
        if bytes > limit {
            return Err(Error::invalid(
                "image",
                format!(
                    "{}x{} needs {} MiB per RGBA f32 buffer but this adapter binds at most {} MiB; tone-map a smaller image",
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
    /// so GPUs that flush denormals still see them (`lift_tiny_values`). The result carries the
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

        let params = self.uniform(&base);
        let output = cache.output(ctx, px_bytes).buffer.clone();
        let groups = reduce_groups(n);
        let partials = cache.scratch(ctx, "partials", groups as u64 * 16);
        let stats = cache.scratch(ctx, "luminance stats", 16);
        let mut rec = self.record(w, h, Specialisation::of(&base));
        rec.reduce(
            "tonemap/luminance_stats.wgsl",
            "partial_stats",
            &[(0, &params), (1, &image), (6, &partials)],
        )?;
        rec.single(
            "tonemap/luminance_stats.wgsl",
            "finish_stats",
            &[(3, &stats), (6, &partials)],
        )?;
        match settings.op {
            Operator::ReinhardLocal {
                alpha1,
                ratio,
                scales,
                ..
            } => {
                let file = "tonemap/reinhard_local.wgsl";
                let sigmas: Vec<f64> = (0..=scales).map(|i| blur_sigma(alpha1, ratio, i)).collect();
                let levels: Vec<u32> = sigmas.iter().map(|&s| reinhard_level(s)).collect();
                let deepest = levels.iter().copied().max().unwrap_or(0);
                let level_cells = |k: u32| -> u32 { w.div_ceil(1 << k) * h.div_ceil(1 << k) };
                // Pyramid levels one after another; each scale's blur after the previous one.
                let pyramid_offsets: Vec<u32> = (0..=deepest)
                    .scan(0u32, |at, k| {
                        let here = *at;
                        *at += level_cells(k);
                        Some(here)
                    })
                    .collect();
                let pyramid_len = pyramid_offsets[deepest as usize] + level_cells(deepest);
                let mut table = Vec::with_capacity(levels.len());
                let mut blurred_len = 0u32;
                for (i, &k) in levels.iter().enumerate() {
                    let scale = ratio.powi(i as i32) as f32;
                    table.push([blurred_len, k, scale.to_bits(), 0]);
                    blurred_len += level_cells(k);
                }
                let pyramid = cache.scratch(ctx, "reinhard pyramid", pyramid_len as u64 * 8);
                let blurred = cache.scratch(ctx, "reinhard blurred", blurred_len as u64 * 8);
                let largest = levels.iter().map(|&k| level_cells(k)).max().unwrap_or(n);
                let tmp = cache.scratch(ctx, "reinhard blur tmp", largest as u64 * 8);
                let mut table_padded = [[0u32; 4]; 17];
                table_padded[..table.len()].copy_from_slice(&table);
                let table_buffer =
                    self.ctx
                        .device
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("reinhard scales"),
                            contents: bytemuck::cast_slice(&table_padded),
                            usage: wgpu::BufferUsages::UNIFORM,
                        });
                rec.pixels(
                    file,
                    "prepare",
                    &[(0, &params), (1, &image), (3, &stats), (10, &pyramid)],
                )?;
                for k in 1..=deepest {
                    let cell = 1u32 << k;
                    let u = self.uniform(&ToneMapParams {
                        cell,
                        grid_width: w.div_ceil(cell),
                        grid_height: h.div_ceil(cell),
                        src_offset: pyramid_offsets[k as usize - 1],
                        dst_offset: pyramid_offsets[k as usize],
                        ..base
                    });
                    rec.items(
                        level_cells(k),
                        file,
                        "downsample",
                        &[(0, &u), (10, &pyramid)],
                    )?;
                }
                for (i, (&sigma, &k)) in sigmas.iter().zip(&levels).enumerate() {
                    let cell = 1u32 << k;
                    let sigma_cells = grid_sigma(sigma, cell);
                    let pass = |src_offset: u32, dst_offset: u32| ToneMapParams {
                        sigma: sigma_cells as f32,
                        radius: gaussian_radius(sigma_cells),
                        cell,
                        grid_width: w.div_ceil(cell),
                        grid_height: h.div_ceil(cell),
                        src_offset,
                        dst_offset,
                        ..base
                    };
                    let across = self.uniform(&pass(pyramid_offsets[k as usize], 0));
                    rec.items(
                        level_cells(k),
                        file,
                        "blur_x",
                        &[(0, &across), (8, &pyramid), (9, &tmp)],
                    )?;
                    let down = self.uniform(&pass(0, table[i][0]));
                    rec.items(
                        level_cells(k),
                        file,
                        "blur_y",
                        &[(0, &down), (8, &tmp), (9, &blurred)],
                    )?;
                }
                let u = self.uniform(&ToneMapParams {
                    levels: scales + 1,
                    ..base
                });
                rec.pixels(
                    file,
                    "apply",
                    &[
                        (0, &u),
                        (1, &image),
                        (2, &output),
                        (3, &stats),
                        (11, &blurred),
                        (18, &table_buffer),
                    ],
                )?;
            }
            Operator::DurandBilateral {
                sigma_spatial,
                sigma_range,
                ..
            } => {
                let (lo, hi) = scan.log10_luminance.unwrap_or((0.0, 0.0));
                let grid = DurandGrid::new(w, h, sigma_spatial, sigma_range, lo, hi);
                let u = self.uniform(&ToneMapParams {
                    cell: grid.cell,
                    grid_width: grid.grid_width,
                    grid_height: grid.grid_height,
                    levels: grid.levels,
                    first_level: grid.first_level as f32,
                    level_step: grid.level_step as f32,
                    sigma: grid.sigma_cells as f32,
                    radius: grid.radius,
                    ..base
                });
                let cells = grid.cells();
                let planes = cells as u64 * grid.levels as u64 * 8;
                let layers = cache.scratch(ctx, "durand layers", px_bytes);
                let grid_cells = cache.scratch(ctx, "durand cells", cells as u64 * 8);
                let tmp = cache.scratch(ctx, "durand tmp", planes);
                let grid_levels = cache.scratch(ctx, "durand levels", planes);
                let range = cache.scratch(ctx, "durand base range", 16);
                let file = "tonemap/durand_bilateral.wgsl";
                rec.items(
                    cells,
                    file,
                    "grid_splat",
                    &[(0, &u), (1, &image), (15, &grid_cells)],
                )?;
                let items = cells * grid.levels;
                rec.items(
                    items,
                    file,
                    "grid_blur_x",
                    &[(0, &u), (15, &grid_cells), (16, &tmp)],
                )?;
                rec.items(
                    items,
                    file,
                    "grid_blur_y",
                    &[(0, &u), (16, &tmp), (17, &grid_levels)],
                )?;
                rec.pixels(
                    file,
                    "base",
                    &[(0, &u), (1, &image), (12, &layers), (17, &grid_levels)],
                )?;
                rec.reduce(
                    file,
                    "range_partial",
                    &[(0, &u), (6, &partials), (12, &layers)],
                )?;
                rec.single(file, "range_finish", &[(6, &partials), (13, &range)])?;
                rec.pixels(
                    file,
                    "apply",
                    &[
                        (0, &u),
                        (1, &image),
                        (2, &output),
                        (12, &layers),
                        (13, &range),
                    ],
                )?;
            }
            _ => {
                let cdf = cache.scratch(ctx, "ward cdf", 257 * 4);
                if let Operator::WardHistogram { .. } = settings.op {
                    let counts = cache.scratch(ctx, "ward counts", 256 * 4);
                    rec.encoder.clear_buffer(&counts, 0, None);
                    let file = "tonemap/ward_histogram.wgsl";
                    rec.reduce(
                        file,
                        "histogram",
                        &[(0, &params), (1, &image), (3, &stats), (5, &counts)],
                    )?;
                    rec.single(
                        file,
                        "ceiling_cdf",
                        &[(0, &params), (3, &stats), (4, &cdf), (5, &counts)],
                    )?;
                }
                rec.pixels(
                    "tonemap/global.wgsl",
                    "apply_global",
                    &[
                        (0, &params),
                        (1, &image),
                        (2, &output),
                        (3, &stats),
                        (4, &cdf),
                    ],
                )?;
            }
        }
        profile.mark("record");
        let pixels = rec.finish(cache.output(ctx, px_bytes), validation, oom, &profile)?;
        drop(cache);
        let mut out = HdrImage::from_pixels(w, h, pixels);
        out.extra_channels = img.extra_channels.clone();
        out.metadata = img.metadata.clone();
        out.set_meta("tonemap", settings.op.name());
        out.set_meta("tonemap.exposure_ev", format!("{}", settings.exposure_ev));
        out.set_meta("transfer", "display-linear");
        out.set_meta(DISPLAY_REFERRED, "1");
        Ok(out)
    }

    /// Scene-referred exposure, `img` × 2^EV on colour (alpha kept). This is one multiply per
    /// value, so it runs on the CPU: an upload and a readback would cost more than the work.
    pub fn exposure(&self, img: &HdrImage, exposure_ev: f64) -> Result<HdrImage> {
        super::exposure(img, exposure_ev)
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
        let params = self.uniform(&ToneMapParams {
            width: w,
            height: h,
            exposure_ev: (exposure_ev - scan.lift_ev as f64) as f32,
            ld_min: low as f32,
            ld_max: high as f32,
            radius: legend_height(h),
            ..Default::default()
        });
        let lut = self.storage_init("turbo lut", bytemuck::cast_slice(&turbo_lut()));
        let mut rec = self.record(w, h, Specialisation::default());
        rec.pixels(
            "tonemap/false_colour.wgsl",
            "false_colour",
            &[(0, &params), (1, &image), (2, &output), (14, &lut)],
        )?;
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
        }
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
        let entries: Vec<wgpu::BindGroupEntry> = bindings
            .iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding: *binding,
                resource: buffer.as_entire_binding(),
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

    /// One invocation per pixel.
    fn pixels(
        &mut self,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        let groups = pixel_groups(self.width * self.height);
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

    /// A strided reduction over the image in [`reduce_groups`] workgroups.
    fn reduce(
        &mut self,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        let groups = reduce_groups(self.width * self.height);
        self.dispatch(file, entry, bindings, (groups, 1))
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

/// When `pixels` hold finite non-zero values below [`TINY`], a copy multiplied by 2^k and the
/// k (stops) to take off the exposure: exact (a power of two, no overflow by construction) and
/// invisible in the result, since the shaders apply exposure to ln L, after the weighted sum.
fn lift_tiny_values(pixels: &[[f32; 4]]) -> Option<(Vec<[f32; 4]>, i32)> {
    let (has_tiny, largest) = pixels
        .par_chunks(1 << 14)
        .map(|chunk| {
            let (mut tiny, mut largest) = (false, 0.0f32);
            for p in chunk {
                for &v in &p[..3] {
                    let a = v.abs();
                    if a.is_finite() {
                        tiny |= a != 0.0 && a < TINY;
                        largest = largest.max(a);
                    }
                }
            }
            (tiny, largest)
        })
        .reduce(|| (false, 0.0), |a, b| (a.0 | b.0, a.1.max(b.1)));
    if !has_tiny {
        return None;
    }
    let headroom = (f32::MAX / largest.max(f32::MIN_POSITIVE)).log2().floor() as i32 - 2;
    let k = headroom.clamp(0, 96);
    if k == 0 {
        return None;
    }
    let gain = 2f32.powi(k);
    let lifted = pixels
        .iter()
        .map(|p| [p[0] * gain, p[1] * gain, p[2] * gain, p[3]])
        .collect();
    Some((lifted, k))
}

/// What [`upload_image`] learnt about the image on its way to the GPU.
struct UploadScan {
    /// Stops the upload was lifted by ([`lift_tiny_values`]); taken off the exposure.
    lift_ev: i32,
    /// log10 of the smallest and largest positive Rec. 709 luminance of the uploaded values
    /// (none when no pixel has one): where Durand's intensity levels go.
    log10_luminance: Option<(f64, f64)>,
}

/// Writes `pixels` into `target` (lifted by 2^k first when they hold values the GPU would
/// flush) and reports the luminance range when `wants_range`, scanning the image in parallel.
fn upload_image(
    ctx: &GpuContext,
    target: &UploadBuffer,
    pixels: &[[f32; 4]],
    wants_range: bool,
) -> Result<UploadScan> {
    let lifted = lift_tiny_values(pixels);
    let (upload, lift_ev): (&[[f32; 4]], i32) = match &lifted {
        Some((p, k)) => (p, *k),
        None => (pixels, 0),
    };
    target.write(ctx, bytemuck::cast_slice(upload))?;
    Ok(UploadScan {
        lift_ev,
        log10_luminance: if wants_range {
            luminance_range(upload).map(|(lo, hi)| (lo.log10(), hi.log10()))
        } else {
            None
        },
    })
}

/// Smallest and largest positive finite Rec. 709 luminance (in f64, as the CPU reference).
fn luminance_range(pixels: &[[f32; 4]]) -> Option<(f64, f64)> {
    let (lo, hi) = pixels
        .par_chunks(1 << 14)
        .map(|chunk| {
            let mut range = (f64::INFINITY, 0.0f64);
            for p in chunk {
                if p.iter().all(|v| v.is_finite()) {
                    let y = 0.2126 * (p[0] as f64).max(0.0)
                        + 0.7152 * (p[1] as f64).max(0.0)
                        + 0.0722 * (p[2] as f64).max(0.0);
                    if y > 0.0 {
                        range = (range.0.min(y), range.1.max(y));
                    }
                }
            }
            range
        })
        .reduce(|| (f64::INFINITY, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    (hi > 0.0).then_some((lo, hi))
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
