//! The GPU f64 ray caster, for adapters with shader f64 (lavapipe has it): the f64 CPU
//! reference's arithmetic in a compute shader (`shaders/volume_f64.wgsl`), so `precision: "f64"`
//! runs on the GPU where it can and on the CPU elsewhere. The volume is the same R32Float texture
//! as the f32 path (voxels are f32 data); positions, interpolation weights, the transfer table,
//! the scale, the exponentials and the sums are f64, and the image comes back in f64.

use super::volume::{min_spacing, steps_per_ray, GpuVolume, MAX_STEPS_PER_RAY};
use super::VolumeRenderOptions;
use crate::error::{Error, Result};
use crate::gpu::{pipeline, readback, shader, GpuContext};
use crate::model::transfer::{ResolvedTransfer, TfKind};
use crate::model::{Cut, MAX_CUT_PLANES};
use std::sync::{Arc, OnceLock};

/// Keep in sync with Params64 in shaders/volume_f64.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params64 {
    eye: [f64; 4],
    forward: [f64; 4],
    right: [f64; 4],
    up: [f64; 4],
    proj: [f64; 4],
    box_size: [f64; 4],
    background: [f64; 4],
    scale: [f64; 4],
    lens: [f64; 4],
    tf: [f64; 4],
    march: [f64; 4],
    image: [u32; 4],
    flags: [u32; 4],
    cut_lo: [f64; 4],
    cut_hi: [f64; 4],
    cut_planes: [[f64; 4]; MAX_CUT_PLANES],
}

/// Renders in f64 on the GPU; one per GPU context.
pub struct F64RayCaster {
    ctx: Arc<GpuContext>,
    pipeline: OnceLock<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
}

impl F64RayCaster {
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        F64RayCaster {
            ctx,
            pipeline: OnceLock::new(),
        }
    }

    /// Whether this adapter can run it.
    pub fn available(&self) -> bool {
        self.ctx.caps.shader_f64
    }

    fn pipeline(&self) -> Result<&(wgpu::ComputePipeline, wgpu::BindGroupLayout)> {
        if let Some(p) = self.pipeline.get() {
            return Ok(p);
        }
        use crate::gpu::layout;
        let entries = [
            layout::uniform_buffer(0),
            layout::texture(1, wgpu::TextureViewDimension::D3, false),
            layout::storage_buffer(2, true),
            layout::storage_buffer(3, false),
        ];
        let spec = pipeline::ComputeSpec {
            label: "volume f64 ray cast",
            what: "f64 volume pipeline",
            shader: pipeline::Shader::Wgsl {
                label: "volume_f64.wgsl",
                source: shader::load("volume_f64.wgsl", &[])?,
                checks: pipeline::RuntimeChecks::checked(),
            },
            entry: "main",
            constants: &[],
        };
        let (pipeline, layout) = pipeline::compute_with_layout(&self.ctx, spec, &entries)?;
        Ok(self.pipeline.get_or_init(|| (pipeline, layout)))
    }

    /// Renders `volume` in f64: row-major RGBA, premultiplied, as `render_volume_f64`.
    pub fn render(&self, volume: &GpuVolume, opts: &VolumeRenderOptions) -> Result<Vec<[f64; 4]>> {
        let out_bytes = self.check_options(opts)?;
        let voxel = min_spacing(volume.spacing);
        let size = [0, 1, 2].map(|a| volume.dims[a] as f64 * volume.spacing[a]);
        if steps_per_ray(opts, voxel, size) > MAX_STEPS_PER_RAY as f64 {
            return Err(Error::invalid(
                "step",
                format!(
                    "too many steps per ray at step {}; at most {MAX_STEPS_PER_RAY}",
                    opts.step
                ),
            ));
        }
        let tf = opts.tf.resolve(&volume.stats)?;
        let lut: Vec<[f64; 4]> = if tf.lut.is_empty() {
            vec![[0.0; 4]; 2]
        } else {
            tf.lut.clone()
        };
        let params = params64(volume, opts, &tf, lut.len(), voxel, &size);
        self.dispatch(volume, opts, &params, &lut, out_bytes)
    }

    /// Checks that this adapter can render these options in f64; the image's size in bytes.
    fn check_options(&self, opts: &VolumeRenderOptions) -> Result<u64> {
        opts.validate()?;
        if !self.available() {
            return Err(Error::invalid(
                "precision",
                "this adapter has no shader f64; f64 renders run on the CPU reference",
            ));
        }
        if opts.shading.is_some() {
            return Err(Error::invalid(
                "shading",
                "the GPU f64 ray caster has no shading; f64 with shading runs on the CPU",
            ));
        }
        let pixels = opts.width as u64 * opts.height as u64;
        let out_bytes = pixels * 32;
        let limit = self.ctx.caps.max_storage_buffer_binding_size;
        if out_bytes > limit {
            return Err(Error::invalid(
                "width",
                format!(
                    "an f64 image of {}x{} needs {} MiB, above this adapter's {} MiB storage binding",
                    opts.width,
                    opts.height,
                    out_bytes >> 20,
                    limit >> 20
                ),
            ));
        }
        Ok(out_bytes)
    }

    /// Uploads the parameters and the table, runs the shader and reads the image back.
    fn dispatch(
        &self,
        volume: &GpuVolume,
        opts: &VolumeRenderOptions,
        params: &Params64,
        lut: &[[f64; 4]],
        out_bytes: u64,
    ) -> Result<Vec<[f64; 4]>> {
        let (pipeline, layout) = self.pipeline()?;
        let device = &self.ctx.device;
        use wgpu::util::DeviceExt;
        let params_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("volume f64 params"),
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let lut_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("volume f64 table"),
            contents: bytemuck::cast_slice(lut),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume f64 image"),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume f64 readback"),
            size: out_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volume f64"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(volume.view()),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: lut_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: out.as_entire_binding(),
                },
            ],
        });
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(opts.width.div_ceil(8), opts.height.div_ceil(8), 1);
        }
        enc.copy_buffer_to_buffer(&out, 0, &staging, 0, out_bytes);
        self.ctx.queue.submit([enc.finish()]);
        readback::read_mapped::<[f64; 4]>(&self.ctx, &staging, out_bytes)
    }
}

/// The shader parameters of one f64 render (a table of `lut_len` entries).
fn params64(
    volume: &GpuVolume,
    opts: &VolumeRenderOptions,
    tf: &ResolvedTransfer,
    lut_len: usize,
    voxel: f64,
    size: &[f64],
) -> Params64 {
    let cam = &opts.camera;
    let lo = volume.origin;
    let cut = cut_corners(opts, lo);
    let v4 = |v: [f64; 3]| [v[0], v[1], v[2], 0.0];
    let proj = cam.shader_projection(opts.width, opts.height);
    let (tf_kind, tf_consts) = match tf.kind {
        TfKind::Lut => (0u32, [0.0; 4]),
        TfKind::EmissionAbsorption {
            emission,
            absorption,
        } => (1, [emission, absorption, 0.0, 0.0]),
    };
    Params64 {
        eye: v4([cam.eye[0] - lo[0], cam.eye[1] - lo[1], cam.eye[2] - lo[2]]),
        forward: v4(cam.forward),
        right: v4(cam.right),
        up: v4(cam.up),
        proj,
        box_size: [size[0], size[1], size[2], 0.0],
        background: v4(opts.background),
        scale: [
            tf.mapping.s_lo,
            tf.mapping.inv_range,
            tf.mapping.linthresh(),
            (lut_len - 1) as f64,
        ],
        lens: tf.mapping.lens.unwrap_or([0.0, 1.0, 0.0, 1.0]),
        tf: tf_consts,
        march: [
            opts.step * voxel,
            voxel,
            opts.stop_optical_depth().min(f64::MAX),
            0.0,
        ],
        image: [opts.width, opts.height, opts.seed, opts.jitter as u32],
        flags: [
            tf_kind,
            tf.mapping.scale_code(),
            tf.mapping.lens.is_some() as u32,
            0,
        ],
        cut_lo: cut[0],
        cut_hi: cut[1],
        cut_planes: opts
            .cut
            .as_ref()
            .map_or(Cut::default().planes_in_frame(lo), |c| {
                c.planes_in_frame(lo)
            }),
    }
}

/// A box cut-away's lower and upper corners in the box's frame ([`crate::model::Cut::box_in_frame`]), w 1
/// when there is one; all zero without.
fn cut_corners(opts: &VolumeRenderOptions, lo: [f64; 3]) -> [[f64; 4]; 2] {
    opts.cut.as_ref().map_or([[0.0; 4]; 2], |c| {
        c.box_in_frame(lo).map(|[x, y, z]| [x, y, z, 1.0])
    })
}
