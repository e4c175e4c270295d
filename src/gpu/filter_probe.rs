//! How exact the texture unit's trilinear filter is on this adapter, measured once per context.
//!
//! The WebGPU and Vulkan specifications leave the precision of filter weights to the device:
//! CPU rasterizers (lavapipe, llvmpipe) weigh texels in f32, while many GPUs keep 8 fractional
//! bits (NVIDIA's H100 among them: about 2e-3 of the step between two texels). For data that
//! spans five decades that is a visible error, so `filter: "auto"` takes the texture unit only
//! where this probe finds its weights as exact as the shader's own.

use super::layout::{filtering_sampler, storage_buffer, texture};
use super::pipeline::{compute_with_layout, ComputeSpec, RuntimeChecks, Shader};
use super::readback::read_mapped;
use super::GpuContext;
use crate::error::Result;

/// Probe positions between the two texel centres.
const POSITIONS: u32 = 256;

/// The largest error the probe accepts as "exact in f32": float weights land within a few ulp
/// of the fraction (about 1e-7); 8-bit weights miss by up to 2e-3.
pub(crate) const EXACT_FILTER_TOLERANCE: f64 = 1e-5;

/// The probe samples a 2×1×1 texture holding 0 and 1 at fractions f between the two texel
/// centres; an exact filter returns f itself.
const PROBE_WGSL: &str = r"
@group(0) @binding(0) var tex: texture_3d<f32>;
@group(0) @binding(1) var smp: sampler;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = arrayLength(&out);
    if (id.x >= n) { return; }
    let f = (f32(id.x) + 0.37) / f32(n);
    // Texel centres of a two-texel axis sit at u = 1/4 and 3/4.
    let u = 0.25 + 0.5 * f;
    out[id.x] = textureSampleLevel(tex, smp, vec3<f32>(u, 0.5, 0.5), 0.0).x;
}
";

/// The largest difference between the texture unit's trilinear result and the exact weight,
/// over [`POSITIONS`] fractions, for texels 0 and 1 (so in units of the step between texels).
pub(crate) fn measure_filter_error(ctx: &GpuContext) -> Result<f64> {
    let device = &ctx.device;
    let entries = [
        texture(0, wgpu::TextureViewDimension::D3, true),
        filtering_sampler(1),
        storage_buffer(2, false),
    ];
    let (pipeline, layout) = compute_with_layout(
        ctx,
        ComputeSpec {
            label: "filter probe",
            what: "the filter precision probe",
            shader: Shader::Wgsl {
                label: "filter_probe",
                source: PROBE_WGSL.to_string(),
                checks: RuntimeChecks::checked(),
            },
            entry: "main",
            constants: &[],
        },
        &entries,
    )?;
    let tex = ctx.r32f_texture_3d("filter probe", [2, 1, 1]);
    ctx.queue.write_texture(
        tex.as_image_copy(),
        bytemuck::cast_slice(&[0.0f32, 1.0]),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(8),
            rows_per_image: Some(1),
        },
        wgpu::Extent3d {
            width: 2,
            height: 1,
            depth_or_array_layers: 1,
        },
    );
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("filter probe"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    let bytes = u64::from(POSITIONS) * 4;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("filter probe out"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("filter probe staging"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let view = tex.create_view(&Default::default());
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("filter probe"),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: out.as_entire_binding(),
            },
        ],
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(POSITIONS.div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &staging, 0, bytes);
    ctx.queue.submit([enc.finish()]);
    let got: Vec<f32> = read_mapped(ctx, &staging, bytes)?;
    Ok(got
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let f = (i as f32 + 0.37) / POSITIONS as f32;
            if v.is_finite() {
                (f64::from(v) - f64::from(f)).abs()
            } else {
                f64::INFINITY
            }
        })
        .fold(0.0, f64::max))
}
