//! GPU tone mapping: the host side of the compute shaders in `shaders/tonemap/`. One
//! [`GpuToneMapper`] per GPU context builds each entry point's pipeline once and caches it; a
//! call uploads the HDR image once, records every pass of the chosen operator (log-luminance
//! statistics, then the global, histogram, dodging-and-burning or bilateral passes) into one
//! command buffer, submits it once and reads the display-referred result back. The image,
//! output and scratch buffers are kept between calls (a new 16 MiB buffer costs page faults and
//! wgpu's zero fill every time), and on CPU adapters the image and output buffers are mapped
//! directly ([`crate::gpu::transfer`]). The f64 CPU references in [`super::cpu`] define what
//! each pass must compute; the integration tests compare the two.

//!
//! The rooms: this file holds the mapper (pipelines, plans, the call itself and the statistics
//! pass every adaptive operator reads); `buffers` the buffers kept between calls; `recording`
//! the recording and submission of passes; `upload` the image's upload with its scan for
//! values GPUs flush; one file per operator family beside its shader: `global` (global.wgsl and
//! ward_histogram.wgsl), `reinhard_local`, `durand` (durand_bilateral.wgsl) and `false_colour`.

mod buffers;
mod durand;
mod false_colour;
mod global;
mod recording;
mod reinhard_local;
mod upload;

use super::bands::{self, Band, Window};
use super::params::{DurandGrid, Operator, ToneMapParams, ToneMapSettings};
use crate::error::{Error, Result};
use crate::gpu::{pipeline, shader, GpuContext};
use crate::model::HdrImage;
use crate::tonemap::StageClock;
use buffers::BufferCache;
use recording::Recording;
use reinhard_local::ReinhardPlan;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use upload::upload_image;
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
pub(crate) const DISPLAY_REFERRED: &str = "display_referred";

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
            reinhard.as_ref().is_none_or(|r| {
                r.band_fits(
                    rows,
                    self.window_limit,
                    self.align(),
                    self.ctx.caps.max_texture_2d,
                )
            })
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

    /// Builds the pipelines a call with `settings` (or, with `false_colour`, the false-colour
    /// view) will use, by mapping a small image, so that a caller can do it while it reads the
    /// real one: on a CPU rasterizer, building the local operators' pipelines takes about as
    /// long as reading a 1024² EXR.
    pub fn prepare(&self, settings: &ToneMapSettings, false_colour: bool) -> Result<()> {
        const SIDE: u32 = 64;
        let pixels = (0..SIDE * SIDE)
            .map(|i| {
                let l = 10f32.powf((i % SIDE) as f32 / 16.0 - 2.0) * (1.0 + (i / SIDE) as f32);
                [l, 0.7 * l, 0.4 * l, 1.0]
            })
            .collect();
        let img = HdrImage::from_pixels(SIDE, SIDE, pixels);
        if false_colour {
            self.false_colour(&img, settings.exposure_ev, None)?;
        } else {
            self.tonemap(&img, settings)?;
        }
        Ok(())
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
        self.uniform_bytes("tonemap params", bytemuck::bytes_of(p))
    }

    /// A uniform buffer holding `bytes`.
    fn uniform_bytes(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
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
        let profile = StageClock::start();
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
            textures: Vec::new(),
        }
    }
}

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
}
