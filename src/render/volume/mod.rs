//! The GPU volume ray caster (`shaders/volume.wgsl`): uploads a volume once as an R32Float 3-D
//! texture (in slabs, so no single copy exceeds buffer limits), builds one compute pipeline per
//! needed specialisation — hardware or exact filtering, transfer-function kind, data scale,
//! lens, jitter — and renders HDR images of any camera.

mod params;

use super::skipping::SkipGrid;
use super::{FilterMode, TfSampling, VolumeRenderOptions};
use crate::error::{Error, Result};
use crate::gpu::timestamps::PassTimestamps;
use crate::gpu::{pipeline, readback, shader, GpuContext};
use crate::model::transfer::{ResolvedTransfer, TfKind};
use crate::model::{HdrImage, Volume, VolumeStats};
use params::{check_steps_per_ray, volume_params, LOOP_ITERATIONS};
pub(crate) use params::{
    min_spacing, steps_per_ray, Frame, Geometry, CF_AXES, MAX_STEPS_PER_RAY, RECTILINEAR,
    RENORMALISE, SEAM, SHELL, SPHERICAL, UNEVEN,
};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// A volume resident on the GPU, with what the renderer needs to know about it.
pub struct GpuVolume {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pub name: String,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    pub stats: VolumeStats,
}

impl GpuVolume {
    /// The R32Float 3-D texture view, for other ray casters of the same volume.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    pub fn upload(ctx: &GpuContext, volume: &Volume) -> Result<GpuVolume> {
        let limit = ctx.caps.max_texture_3d as usize;
        if volume.dims.iter().any(|&d| d > limit) {
            return Err(Error::Gpu(format!(
                "volume {} is {}x{}x{} voxels but this adapter's 3-D textures hold at most {limit} per axis",
                volume.name, volume.dims[0], volume.dims[1], volume.dims[2]
            )));
        }
        let [nx, ny, nz] = volume.dims;
        let texture = ctx.r32f_texture_3d("volume", [nx as u32, ny as u32, nz as u32]);
        // Slabs of whole z-slices, at most 64 MiB each, keep staging copies small.
        let slice_bytes = nx * ny * 4;
        let slab = ((64usize << 20) / slice_bytes).clamp(1, nz);
        let mut z = 0;
        while z < nz {
            let count = slab.min(nz - z);
            let data = &volume.data[z * nx * ny..(z + count) * nx * ny];
            ctx.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d {
                        x: 0,
                        y: 0,
                        z: z as u32,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(data),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(nx as u32 * 4),
                    rows_per_image: Some(ny as u32),
                },
                wgpu::Extent3d {
                    width: nx as u32,
                    height: ny as u32,
                    depth_or_array_layers: count as u32,
                },
            );
            ctx.queue.submit([]);
            z += count;
        }
        ctx.wait()?;
        let view = texture.create_view(&Default::default());
        Ok(GpuVolume {
            texture,
            view,
            name: volume.name.clone(),
            dims: volume.dims,
            spacing: volume.spacing,
            origin: volume.origin,
            stats: volume.stats(),
        })
    }

    /// The geometry the ray caster needs, from the resident volume.
    pub(crate) fn geometry(&self) -> Geometry<'_> {
        Geometry {
            name: &self.name,
            dims: self.dims,
            spacing: self.spacing,
            origin: self.origin,
            stats: &self.stats,
            voxel: min_spacing(self.spacing),
        }
    }

    pub fn bytes(&self) -> u64 {
        (self.texture.width() as u64)
            * (self.texture.height() as u64)
            * (self.texture.depth_or_array_layers() as u64)
            * 4
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PipelineKey {
    /// The bricked ray caster (volume_bricked.wgsl) rather than the single-texture one.
    pub bricked: bool,
    pub hw_filter: bool,
    tf_kind: u32,
    scale: u32,
    lens: bool,
    jitter: bool,
    precision: u32,
    shading: bool,
    pub preintegrated: bool,
    /// Empty-space skipping through a skip grid (plain ray caster, point sampling).
    pub skipping: bool,
    /// And inside the cells that are not empty, by the gradient bound (`GradientSkip`).
    pub gradient_skip: bool,
    /// Samples the skipping march takes between lookups: 1, 2 or 4 ([`march_plan`]).
    pub samples_per_pass: u32,
    /// Voxels placed by coordinate axes (volume_mapped.wgsl): bits of `mapped::RECTILINEAR`,
    /// `SPHERICAL`, `UNEVEN`, `SEAM`, `CF_AXES`, `SHELL`, `RENORMALISE`.
    pub mapped: u32,
    /// One slab of a distributed render (plain ray caster): partial images.
    pub slab: bool,
    work: SampleWork,
}

/// How much of the per-sample work the point samples of the plain ray caster do: the cost
/// breakdown of `hdrvis bench volume --breakdown` renders with each stage in turn. Anything
/// short of `Full` gives a meaningless image; only the benchmark asks for it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SampleWork {
    /// The march and compositing only: no volume read.
    March,
    /// Plus the trilinear sample of the volume.
    Sample,
    /// Plus the transfer function's scale (log10, symlog, lens) of the sample.
    Scale,
    /// Plus the table index and weight: everything but the table's texel loads.
    Index,
    /// The ray caster as it renders images.
    #[default]
    Full,
}

impl SampleWork {
    /// Every stage, from the least work to the full ray caster.
    pub const ALL: [SampleWork; 5] = [
        SampleWork::March,
        SampleWork::Sample,
        SampleWork::Scale,
        SampleWork::Index,
        SampleWork::Full,
    ];

    /// What the stage adds to the one before it.
    pub fn describe(self) -> &'static str {
        match self {
            SampleWork::March => {
                "march + compositing, no volume read (plus dispatch and read-back)"
            }
            SampleWork::Sample => "+ trilinear sample of the volume",
            SampleWork::Scale => "+ transfer-function scale of the sample",
            SampleWork::Index => "+ table index and weight (all but the table loads)",
            SampleWork::Full => "+ the table's texel loads: the full ray caster",
        }
    }

    fn shader_code(self) -> u32 {
        self as u32
    }
}

/// From this share of empty cells on, the skipping march takes one sample between lookups: a
/// vector's lanes mostly jump, and a pass of one sample is the cheapest for those that do.
/// Measured (two rounds each; 1 / 2 / 4 samples a pass): `bench volume --quick` sparse blobs,
/// 98 % empty, 34 / 35 / 39 ms; the mantle box under Fig. 5, 56 % empty, 281 / 245 / 233 ms;
/// `bench bricks --n 257 --size 512` the mantle's hot plumes, 81 % empty, 70 / 65 / 66 ms.
const SPARSE_EMPTY_FRACTION: f64 = 0.9;

/// How the skipping march samples a ray of up to `steps` steps through a skip grid with this
/// share of empty cells, with or without a gradient skip: whether the gradient skip runs, and
/// the samples the march takes between lookups. With the gradient skip two (its samples go on
/// past what they prove transparent by themselves: on the opaque wall 1 / 2 / 3 / 4 a pass took
/// 47.4 / 46.0 / 48.0 / 49.6 ms), where nearly every cell is empty one, else four. A loop
/// iteration advances at least that many steps and llvmpipe ends a loop after LOOP_ITERATIONS of
/// them, so a ray too long for the plan marches four at a time without the gradient skip.
pub(crate) fn march_plan(gradient: bool, empty_fraction: f64, steps: f64) -> (bool, u32) {
    let samples = if gradient {
        2
    } else if empty_fraction >= SPARSE_EMPTY_FRACTION {
        1
    } else {
        4
    };
    if steps <= (LOOP_ITERATIONS * u64::from(samples)) as f64 {
        (gradient, samples)
    } else {
        (false, 4)
    }
}

/// Builds pipelines on demand and renders volumes; one per GPU context.
pub struct VolumeRenderer {
    ctx: Arc<GpuContext>,
    pipelines: Mutex<HashMap<PipelineKey, Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>>>,
    sampler: wgpu::Sampler,
    /// The same with texture axis x, y or z repeating (a longitude that closes the circle).
    repeating: [wgpu::Sampler; 3],
    /// Nearest texel, clamped to the edges: the skip grid's bytes are sampled through it rather
    /// than loaded (on lavapipe the skipping march ran 1.55x against 1.47x the plain march,
    /// mean of five alternating builds).
    nearest: wgpu::Sampler,
}

/// What a render did, for benchmarks and `--stats`.
#[derive(Clone, Debug, Default)]
pub struct RenderTiming {
    /// From submission to the image in host memory, seconds.
    pub seconds: f64,
    /// Whether the pipeline for this variant had to be compiled first.
    pub compiled_pipeline: bool,
    /// The ray-casting pass alone on the device's clock, where the adapter has timestamps.
    pub gpu_seconds: Option<f64>,
}

impl VolumeRenderer {
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        let sampler = trilinear_sampler(&ctx.device, None);
        let repeating = [0, 1, 2].map(|axis| trilinear_sampler(&ctx.device, Some(axis)));
        let nearest = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("nearest"),
            ..Default::default()
        });
        VolumeRenderer {
            ctx,
            pipelines: Mutex::new(HashMap::new()),
            sampler,
            repeating,
            nearest,
        }
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// The nearest-texel sampler the skip grids are read through.
    pub(crate) fn nearest_sampler(&self) -> &wgpu::Sampler {
        &self.nearest
    }

    pub(crate) fn pipeline(
        &self,
        key: PipelineKey,
    ) -> Result<(Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>, bool)> {
        let mut cache = self.pipelines.lock().expect("pipeline cache poisoned");
        if let Some(p) = cache.get(&key) {
            return Ok((p.clone(), false));
        }
        // Absent effects are left out of the source, not just switched off.
        let mut defines = Vec::new();
        if key.hw_filter {
            defines.push("HW_FILTER");
        }
        if key.shading {
            defines.push("SHADING");
        }
        if key.preintegrated {
            defines.push("PREINTEGRATED");
        }
        if key.skipping {
            defines.push("SKIPPING");
        }
        if key.mapped & SPHERICAL != 0 {
            defines.push("SPHERICAL");
        }
        if key.mapped & UNEVEN != 0 {
            defines.push("UNEVEN");
        }
        if key.mapped & CF_AXES != 0 {
            defines.push("CF_AXES");
        }
        if key.mapped & SHELL != 0 {
            defines.push("SHELL");
        }
        if key.mapped & SEAM != 0 {
            defines.push("SEAM");
        }
        if key.mapped & RENORMALISE != 0 {
            defines.push("RENORMALISE");
        }
        if key.slab {
            defines.push("SLAB");
        }
        let name = if key.bricked {
            "volume_bricked.wgsl"
        } else if key.mapped > 0 {
            "volume_mapped.wgsl"
        } else {
            "volume.wgsl"
        };
        use crate::gpu::layout;
        let mut entries = vec![
            layout::uniform_buffer(0),
            layout::texture(1, wgpu::TextureViewDimension::D3, key.hw_filter),
            layout::texture(2, wgpu::TextureViewDimension::D2, false),
            layout::storage_texture_rgba32f(3),
        ];
        if key.hw_filter {
            entries.push(layout::filtering_sampler(4));
        }
        if key.skipping {
            // The mapped ray caster's geometry takes 5 and 6.
            let at = if key.mapped > 0 { 7 } else { 5 };
            entries.extend([
                layout::texture(at, wgpu::TextureViewDimension::D3, false),
                layout::nearest_sampler(at + 1),
            ]);
        }
        if key.mapped > 0 {
            entries.extend([layout::uniform_buffer(5), layout::storage_buffer(6, true)]);
        }
        if key.bricked {
            entries.extend([
                layout::uniform_buffer(5),
                layout::storage_buffer(6, true),
                layout::storage_buffer(7, false),
                layout::storage_buffer(8, false),
                layout::storage_buffer(9, false),
            ]);
        }
        let constants = [
            ("TF_KIND", key.tf_kind as f64),
            ("SCALE_KIND", key.scale as f64),
            ("USE_LENS", key.lens as u32 as f64),
            ("JITTER", key.jitter as u32 as f64),
            ("PRECISION", key.precision as f64),
            ("WORK", key.work.shader_code() as f64),
            ("GRADIENT_SKIP", key.gradient_skip as u32 as f64),
            ("SAMPLES_PER_PASS", key.samples_per_pass as f64),
        ];
        // SAFETY: wgpu's injected runtime checks (buffer index clamps, loop counters) cost about
        // a third of the ray caster's time on lavapipe. The shader needs neither: every table
        // index is clamped to [0, LUT_SIZE - 2] by construction, texel loads clamp their
        // coordinates to the texture, stores are guarded by the image size, and the one loop
        // runs a finite, precomputed number of steps.
        let checks = unsafe { pipeline::RuntimeChecks::unchecked() };
        let spec = pipeline::ComputeSpec {
            label: "volume ray cast",
            what: "volume pipeline",
            shader: pipeline::Shader::Wgsl {
                label: name,
                source: shader::load(name, &defines)?,
                checks,
            },
            entry: "main",
            constants: &constants,
        };
        let (pipeline, layout) = pipeline::compute_with_layout(&self.ctx, spec, &entries)?;
        let entry = Arc::new((pipeline, layout));
        cache.insert(key, entry.clone());
        Ok((entry, true))
    }

    /// Renders an HDR image of `volume`, skipping the empty space `skip` marks when given.
    pub(crate) fn render(
        &self,
        volume: &GpuVolume,
        opts: &VolumeRenderOptions,
        skip: Option<&SkipGrid>,
    ) -> Result<(HdrImage, RenderTiming)> {
        let geometry = volume.geometry();
        self.render_with(volume, &geometry, opts, SampleWork::Full, skip, None)
    }

    /// The partial image of one slab of a distributed render: `volume` holds the slab's
    /// z-slices and its ghost slices, `whole` is the geometry of the whole volume, `slab` the
    /// shader's slab parameters (see `Params.slab` in shaders/shared/volume_params.wgsl). Each
    /// pixel holds premultiplied colour and signed optical depth ([`super::distributed`]).
    pub(crate) fn render_slab(
        &self,
        volume: &GpuVolume,
        whole: &Geometry,
        opts: &VolumeRenderOptions,
        slab: [f32; 4],
    ) -> Result<(HdrImage, RenderTiming)> {
        self.render_with(volume, whole, opts, SampleWork::Full, None, Some(slab))
    }

    /// The plain march (no skipping) with the samples doing only `work` (see SampleWork): for
    /// timing what each part of a sample costs, not for images.
    pub fn render_work(
        &self,
        volume: &GpuVolume,
        opts: &VolumeRenderOptions,
        work: SampleWork,
    ) -> Result<(HdrImage, RenderTiming)> {
        let geometry = volume.geometry();
        self.render_with(volume, &geometry, opts, work, None, None)
    }

    fn render_with(
        &self,
        volume: &GpuVolume,
        geometry: &Geometry,
        opts: &VolumeRenderOptions,
        work: SampleWork,
        skip: Option<&SkipGrid>,
        slab: Option<[f32; 4]>,
    ) -> Result<(HdrImage, RenderTiming)> {
        let mut frame = self.frame(geometry, opts, false)?;
        frame.key.work = work;
        frame.key.skipping = skip.is_some();
        if let Some(g) = skip {
            let steps = steps_per_ray(opts, geometry.voxel, geometry.size());
            (frame.key.gradient_skip, frame.key.samples_per_pass) =
                march_plan(g.gradient.is_some(), g.empty_fraction(), steps);
            (frame.params.skip, frame.params.gradient) = g.skip_params();
            frame.params.hull = g.hull_params();
        }
        if let Some(slab) = slab {
            // Slabs interpolate exactly: the texture unit's filter would see the slab's
            // texture, not the volume's.
            frame.key.slab = true;
            frame.key.hw_filter = false;
            frame.params.slab = slab;
        }
        let (pipeline, compiled) = self.pipeline(frame.key)?;
        let (pipeline, layout) = (&pipeline.0, &pipeline.1);
        let device = &self.ctx.device;
        use wgpu::util::DeviceExt;
        let params_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("volume params"),
            contents: bytemuck::bytes_of(&frame.params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let lut_view = self.lut_view(&frame.tf, frame.key.preintegrated);
        let out = self.output_texture(opts);
        let out_view = out.create_view(&Default::default());
        let mut entries =
            self.common_entries(&frame.key, &params_buf, &volume.view, &lut_view, &out_view);
        if let Some(grid) = skip {
            entries.push(wgpu::BindGroupEntry {
                binding: 5,
                resource: wgpu::BindingResource::TextureView(grid.view()),
            });
            entries.push(wgpu::BindGroupEntry {
                binding: 6,
                resource: wgpu::BindingResource::Sampler(&self.nearest),
            });
        }
        let (pixels, mut timing) = self.dispatch(pipeline, layout, &entries, &out, opts)?;
        let image = self.finish_image(geometry, opts, frame.key.hw_filter, pixels);
        timing.compiled_pipeline = compiled;
        Ok((image, timing))
    }

    /// Runs one ray-casting pass with these bindings and reads the image back: the pixels, the
    /// seconds from submission to host memory and, where the adapter has timestamps, the pass's
    /// own time on the device.
    pub(crate) fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        layout: &wgpu::BindGroupLayout,
        entries: &[wgpu::BindGroupEntry],
        out: &wgpu::Texture,
        opts: &VolumeRenderOptions,
    ) -> Result<(Vec<[f32; 4]>, RenderTiming)> {
        let device = &self.ctx.device;
        let stamps = PassTimestamps::new(&self.ctx);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volume"),
            layout,
            entries,
        });
        let start = std::time::Instant::now();
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("ray cast"),
                timestamp_writes: stamps.as_ref().map(PassTimestamps::writes),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(opts.width.div_ceil(8), opts.height.div_ceil(8), 1);
        }
        if let Some(s) = &stamps {
            s.resolve(&mut enc);
        }
        self.ctx.queue.submit([enc.finish()]);
        let pixels = readback::read_rgba32f_texture(&self.ctx, out)?;
        let seconds = start.elapsed().as_secs_f64();
        let gpu_seconds = stamps.map(|s| s.seconds(&self.ctx)).transpose()?;
        Ok((
            pixels,
            RenderTiming {
                seconds,
                compiled_pipeline: false,
                gpu_seconds,
            },
        ))
    }

    /// Everything one render fixes before dispatch: checked options, the resolved transfer
    /// function, the pipeline variant and the shader parameters.
    pub(crate) fn frame(
        &self,
        volume: &Geometry,
        opts: &VolumeRenderOptions,
        bricked: bool,
    ) -> Result<Frame> {
        self.check_image_options(opts)?;
        let voxel = volume.voxel;
        let size = volume.size();
        check_steps_per_ray(opts, voxel, size)?;
        let tf = opts.tf.resolve(volume.stats)?;
        let hw_filter = self.hardware_filtering(opts.filter)?;
        let (tf_kind, tf_consts) = match tf.kind {
            TfKind::Lut => (0u32, [0.0f32; 4]),
            TfKind::EmissionAbsorption {
                emission,
                absorption,
            } => (1, [emission as f32, absorption as f32, 0.0, 0.0]),
        };
        let key = PipelineKey {
            bricked,
            hw_filter,
            tf_kind,
            scale: tf.mapping.scale_code(),
            lens: tf.mapping.lens.is_some(),
            jitter: opts.jitter,
            precision: opts.precision.shader_code(),
            shading: opts.shading.is_some(),
            preintegrated: opts.tf_sampling == TfSampling::PreIntegrated,
            skipping: false,
            gradient_skip: false,
            samples_per_pass: 4,
            mapped: 0,
            slab: false,
            work: SampleWork::Full,
        };
        let params = volume_params(volume, opts, &tf, tf_consts, voxel, size);
        Ok(Frame { key, tf, params })
    }

    /// Checks the options, that the precision is one the GPU composites in, and that the image
    /// fits this adapter's textures.
    fn check_image_options(&self, opts: &VolumeRenderOptions) -> Result<()> {
        opts.validate()?;
        if opts.precision == super::Precision::F64 {
            return Err(Error::invalid(
                "precision",
                "f64 compositing runs on the CPU reference path, not in the GPU ray caster",
            ));
        }
        let max2d = self.ctx.caps.max_texture_2d;
        if opts.width > max2d || opts.height > max2d {
            return Err(Error::invalid(
                "width",
                format!("this adapter's images hold at most {max2d} pixels per side"),
            ));
        }
        Ok(())
    }

    /// Whether the volume is sampled with the texture unit's filter, as `filter` asks and the
    /// adapter allows.
    fn hardware_filtering(&self, filter: FilterMode) -> Result<bool> {
        Ok(match filter {
            FilterMode::Exact => false,
            FilterMode::Auto => self.ctx.auto_filter_is_hardware(),
            FilterMode::Hardware => {
                if !self.ctx.caps.float32_filterable {
                    return Err(Error::invalid(
                        "filter",
                        "this adapter cannot filter float32 textures; use \"exact\" or \"auto\"",
                    ));
                }
                true
            }
        })
    }

    /// The trilinear sampler with texture axis `axis` repeating (a longitude that closes the
    /// circle) and the others clamped to their edges.
    pub(crate) fn sampler_repeating(&self, axis: usize) -> &wgpu::Sampler {
        &self.repeating[axis]
    }

    pub(crate) fn common_entries<'a>(
        &'a self,
        key: &PipelineKey,
        params: &'a wgpu::Buffer,
        volume: &'a wgpu::TextureView,
        lut: &'a wgpu::TextureView,
        out: &'a wgpu::TextureView,
    ) -> Vec<wgpu::BindGroupEntry<'a>> {
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(volume),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(lut),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(out),
            },
        ];
        if key.hw_filter {
            entries.push(wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::Sampler(&self.sampler),
            });
        }
        entries
    }

    /// The transfer table as an N x 1 texture; N x 3 with the pre-integration rows (the table's
    /// running integral, hi and lo) when `integral` is set.
    pub(crate) fn lut_view(&self, tf: &ResolvedTransfer, integral: bool) -> wgpu::TextureView {
        use wgpu::util::DeviceExt;
        let mut lut: Vec<[f32; 4]> = if tf.lut.is_empty() {
            vec![[0.0; 4]; 2]
        } else {
            tf.lut_f32()
        };
        let width = lut.len() as u32;
        let mut height = 1;
        if integral && !tf.lut.is_empty() {
            let (hi, lo) = tf.table_integral_f32();
            lut.extend(hi);
            lut.extend(lo);
            height = 3;
        }
        let lut_tex = self.ctx.device.create_texture_with_data(
            &self.ctx.queue,
            &wgpu::TextureDescriptor {
                label: Some("transfer lut texture"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(&lut),
        );
        lut_tex.create_view(&Default::default())
    }

    /// The HDR output image the ray caster writes.
    pub(crate) fn output_texture(&self, opts: &VolumeRenderOptions) -> wgpu::Texture {
        self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("hdr image"),
            size: wgpu::Extent3d {
                width: opts.width,
                height: opts.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    }

    /// The image with the metadata every render records.
    pub(crate) fn finish_image(
        &self,
        volume: &Geometry,
        opts: &VolumeRenderOptions,
        hw_filter: bool,
        pixels: Vec<[f32; 4]>,
    ) -> HdrImage {
        let cam = &opts.camera;
        let mut image = HdrImage::from_pixels(opts.width, opts.height, pixels);
        image.set_meta(
            "dataset",
            format!(
                "{} {}x{}x{} spacing {:?}",
                volume.name, volume.dims[0], volume.dims[1], volume.dims[2], volume.spacing
            ),
        );
        image.set_meta("camera", cam.describe());
        image.set_meta("tf", opts.tf.describe());
        image.set_meta("tf_sampling", opts.tf_sampling.name());
        image.set_meta("precision", opts.precision.name());
        image.set_meta(
            "step",
            format!(
                "{} voxels{}",
                opts.step,
                if opts.jitter { ", jittered" } else { "" }
            ),
        );
        image.set_meta(
            "filter",
            if hw_filter {
                "hardware trilinear"
            } else {
                "exact trilinear"
            },
        );
        if let Some(sh) = &opts.shading {
            image.set_meta(
                "shading",
                format!(
                    "Blinn-Phong headlight ambient {} diffuse {} specular {} shininess {}",
                    sh.ambient, sh.diffuse, sh.specular, sh.shininess
                ),
            );
        }
        image.set_meta("adapter", self.ctx.describe());
        image
    }
}

/// A trilinear sampler clamped to the edges, except texture axis `repeat` (0 x, 1 y, 2 z), which
/// repeats.
fn trilinear_sampler(device: &wgpu::Device, repeat: Option<usize>) -> wgpu::Sampler {
    let mode = |axis| {
        if repeat == Some(axis) {
            wgpu::AddressMode::Repeat
        } else {
            wgpu::AddressMode::ClampToEdge
        }
    };
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("volume trilinear"),
        address_mode_u: mode(0),
        address_mode_v: mode(1),
        address_mode_w: mode(2),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Nearest,
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_march_plan_takes_two_samples_with_the_gradient_skip_and_one_where_all_but_is_empty() {
        assert_eq!(march_plan(true, 0.5, 1000.0), (true, 2));
        assert_eq!(march_plan(true, 0.95, 1000.0), (true, 2));
        assert_eq!(march_plan(false, 0.95, 1000.0), (false, 1));
        assert_eq!(march_plan(false, 0.9, 1000.0), (false, 1));
        assert_eq!(march_plan(false, 0.89, 1000.0), (false, 4));
        // A ray longer than the plan's loop can take marches four at a time, without the
        // gradient skip.
        assert_eq!(march_plan(false, 0.95, 65535.0), (false, 1));
        assert_eq!(march_plan(false, 0.95, 65536.0), (false, 4));
        assert_eq!(march_plan(true, 0.5, 131070.0), (true, 2));
        assert_eq!(march_plan(true, 0.5, 131071.0), (false, 4));
    }
}
