//! GPU tone mapping: the host side of the compute shaders in `shaders/tonemap/`. One
//! [`GpuToneMapper`] per GPU context builds each entry point's pipeline once and caches it; a
//! call uploads the HDR image once, records every pass of the chosen operator (log-luminance
//! statistics, then the global, histogram, dodging-and-burning or bilateral passes) into one
//! command buffer, submits it once and reads the display-referred result back. The f64 CPU
//! references in [`super::cpu`] define what each pass must compute; the integration tests
//! compare the two.

use super::cpu::{false_colour_decades, legend_height, turbo_lut};
use super::params::{blur_sigma, gaussian_radius, Operator, ToneMapParams, ToneMapSettings};
use crate::error::{Error, Result};
use crate::gpu::{shader, GpuContext};
use crate::model::HdrImage;
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
    pipelines: Mutex<HashMap<(&'static str, &'static str), Arc<wgpu::ComputePipeline>>>,
}

/// One tone-mapping call being recorded: the context, its encoder and the uploaded image.
struct Recording<'a> {
    mapper: &'a GpuToneMapper,
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
    ) -> Result<Arc<wgpu::ComputePipeline>> {
        if let Some(p) = self
            .pipelines
            .lock()
            .expect("pipeline cache poisoned")
            .get(&(file, entry))
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
            compilation_options: Default::default(),
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
            .insert((file, entry), pipeline.clone());
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

    fn storage(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        // wgpu zero-initialises new buffers, which the histogram counts rely on.
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
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
        let lifted = lift_tiny_values(&img.pixels);
        let (upload, lift_ev): (&[[f32; 4]], i32) = match &lifted {
            Some((pixels, k)) => (pixels, *k),
            None => (&img.pixels, 0),
        };
        let mut base = ToneMapParams::new(settings, w, h);
        base.exposure_ev = (settings.exposure_ev - lift_ev as f64) as f32;
        let device = &self.ctx.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);

        let params = self.uniform(&base);
        let image = self.storage_init("hdr image", bytemuck::cast_slice(upload));
        let output = self.storage("display image", px_bytes);
        let groups = reduce_groups(n);
        let partials = self.storage("partials", groups as u64 * 16);
        let stats = self.storage("luminance stats", 16);
        let mut rec = self.record(w, h);
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
                let state = self.storage("reinhard state", px_bytes);
                let weighted = self.storage("reinhard weighted", n as u64 * 8);
                let tmp = self.storage("reinhard blur tmp", n as u64 * 8);
                let mut centre = self.storage("reinhard centre", n as u64 * 8);
                let mut surround = self.storage("reinhard surround", n as u64 * 8);
                let file = "tonemap/reinhard_local.wgsl";
                rec.pixels(
                    file,
                    "prepare",
                    &[
                        (0, &params),
                        (1, &image),
                        (3, &stats),
                        (7, &state),
                        (9, &weighted),
                    ],
                )?;
                let blur = |rec: &mut Recording, index: u32, dst: &wgpu::Buffer| -> Result<()> {
                    let sigma = blur_sigma(alpha1, ratio, index);
                    for (direction, src, out) in [(0u32, &weighted, &tmp), (1, &tmp, dst)] {
                        let u = self.uniform(&ToneMapParams {
                            sigma: sigma as f32,
                            radius: gaussian_radius(sigma),
                            direction,
                            ..base
                        });
                        rec.pixels(file, "blur", &[(0, &u), (8, src), (9, out)])?;
                    }
                    Ok(())
                };
                blur(&mut rec, 0, &centre)?;
                for i in 0..scales {
                    blur(&mut rec, i + 1, &surround)?;
                    let u = self.uniform(&ToneMapParams {
                        pass_index: i,
                        scale: ratio.powi(i as i32) as f32,
                        ..base
                    });
                    rec.pixels(
                        file,
                        "select_scale",
                        &[(0, &u), (7, &state), (10, &centre), (11, &surround)],
                    )?;
                    std::mem::swap(&mut centre, &mut surround);
                }
                rec.pixels(
                    file,
                    "apply",
                    &[(0, &params), (1, &image), (2, &output), (7, &state)],
                )?;
            }
            Operator::DurandBilateral { .. } => {
                let layers = self.storage("durand layers", px_bytes);
                let range = self.storage("durand base range", 16);
                let file = "tonemap/durand_bilateral.wgsl";
                rec.pixels(
                    file,
                    "bilateral",
                    &[(0, &params), (1, &image), (12, &layers)],
                )?;
                rec.reduce(
                    file,
                    "range_partial",
                    &[(0, &params), (6, &partials), (12, &layers)],
                )?;
                rec.single(file, "range_finish", &[(6, &partials), (13, &range)])?;
                rec.pixels(
                    file,
                    "apply",
                    &[
                        (0, &params),
                        (1, &image),
                        (2, &output),
                        (12, &layers),
                        (13, &range),
                    ],
                )?;
            }
            _ => {
                let cdf = self.storage("ward cdf", 257 * 4);
                if let Operator::WardHistogram { .. } = settings.op {
                    let counts = self.storage("ward counts", 256 * 4);
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
        let pixels = rec.finish(&output, validation, oom)?;
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
        let lifted = lift_tiny_values(&img.pixels);
        let (upload, lift_ev): (&[[f32; 4]], i32) = match &lifted {
            Some((pixels, k)) => (pixels, *k),
            None => (&img.pixels, 0),
        };
        let device = &self.ctx.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let params = self.uniform(&ToneMapParams {
            width: w,
            height: h,
            exposure_ev: (exposure_ev - lift_ev as f64) as f32,
            ld_min: low as f32,
            ld_max: high as f32,
            radius: legend_height(h),
            ..Default::default()
        });
        let image = self.storage_init("hdr image", bytemuck::cast_slice(upload));
        let output = self.storage("false colour", w as u64 * h as u64 * 16);
        let lut = self.storage_init("turbo lut", bytemuck::cast_slice(&turbo_lut()));
        let mut rec = self.record(w, h);
        rec.pixels(
            "tonemap/false_colour.wgsl",
            "false_colour",
            &[(0, &params), (1, &image), (2, &output), (14, &lut)],
        )?;
        let pixels = rec.finish(&output, validation, oom)?;
        let mut out = HdrImage::from_pixels(w, h, pixels);
        out.metadata = img.metadata.clone();
        out.set_meta("false_colour.log10_min", format!("{low}"));
        out.set_meta("false_colour.log10_max", format!("{high}"));
        out.set_meta("transfer", "display-linear");
        out.set_meta(DISPLAY_REFERRED, "1");
        Ok(out)
    }

    fn record(&self, width: u32, height: u32) -> Recording<'_> {
        Recording {
            mapper: self,
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
        let pipeline = self.mapper.pipeline(file, entry)?;
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

    /// Copies `output` out, submits everything once, waits and checks the error scopes.
    fn finish(
        self,
        output: &wgpu::Buffer,
        validation: wgpu::ErrorScopeGuard,
        oom: wgpu::ErrorScopeGuard,
    ) -> Result<Vec<[f32; 4]>> {
        let ctx = &self.mapper.ctx;
        let n = self.width as u64 * self.height as u64;
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tonemap readback"),
            size: output.size(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.encoder;
        encoder.copy_buffer_to_buffer(output, 0, &staging, 0, output.size());
        ctx.queue.submit([encoder.finish()]);
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
        crate::gpu::readback::read_mapped::<[f32; 4]>(ctx, &staging, n * 16)
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
    let mut has_tiny = false;
    let mut largest = 0.0f32;
    for p in pixels {
        for &v in &p[..3] {
            let a = v.abs();
            if a.is_finite() {
                has_tiny |= a != 0.0 && a < TINY;
                largest = largest.max(a);
            }
        }
    }
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
