//! What one volume render tells the ray caster's shader: the uniform block (`VolumeParams`, the
//! host mirror of `Params` in shaders/shared/volume_params.wgsl), the mapped-geometry variant
//! bits, the limits on steps per ray, and the geometry and fixed quantities of a frame.

use super::super::VolumeRenderOptions;
use super::PipelineKey;
use crate::error::{Error, Result};
use crate::model::transfer::{ResolvedTransfer, LUT_SIZE};
use crate::model::VolumeStats;

/// Host mirror of `Params` in shaders/volume.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct VolumeParams {
    pub(super) eye: [f32; 4],
    pub(super) forward: [f32; 4],
    pub(super) right: [f32; 4],
    pub(super) up: [f32; 4],
    pub(super) proj: [f32; 4],
    pub(super) box_size: [f32; 4],
    pub(super) background: [f32; 4],
    pub(super) scale: [f32; 4],
    pub(super) lens: [f32; 4],
    pub(super) tf: [f32; 4],
    pub(super) march: [f32; 4],
    pub(super) image: [u32; 4],
    pub(super) shading: [f32; 4],
    pub(super) skip: [f32; 4],
    pub(super) slab: [f32; 4],
    pub(super) hull: [[f32; 4]; 7],
    pub(super) gradient: [f32; 4],
}

/// Pipeline variants of the mapped ray caster, as bits of `PipelineKey::mapped`.
pub(crate) const RECTILINEAR: u32 = 1;
pub(crate) const SPHERICAL: u32 = 2;
/// Some axis is uneven: its centres are bisected.
pub(crate) const UNEVEN: u32 = 4;
/// The longitude closes the circle across a gap other than its step.
pub(crate) const SEAM: u32 = 8;
/// Radius, latitude and longitude on texture axes z, y and x: a CF variable stored (level,
/// latitude, longitude), compiled to a swizzle instead of the general axis rows.
pub(crate) const CF_AXES: u32 = 16;
/// A whole shell: every latitude and a longitude that closes the circle, so a ray's parts are
/// the outer sphere's chord less the inner sphere's, in closed form.
pub(crate) const SHELL: u32 = 32;
/// `missing: "renormalise"`: values over the finite voxels alone, with the shader's exact filter.
pub(crate) const RENORMALISE: u32 = 64;

/// Most steps one ray may take: the shader advances four steps per loop iteration, and llvmpipe
/// (lavapipe, and GL on Mesa) ends any loop after 65535 iterations.
pub(crate) const MAX_STEPS_PER_RAY: u64 = 4 * LOOP_ITERATIONS;

/// The most iterations llvmpipe lets a shader loop run.
pub(crate) const LOOP_ITERATIONS: u64 = 65535;

/// The most steps a ray across the volume's diagonal takes.
pub(crate) fn steps_per_ray(opts: &VolumeRenderOptions, voxel: f64, size: [f64; 3]) -> f64 {
    let diagonal = size.iter().map(|s| s * s).sum::<f64>().sqrt();
    diagonal / (opts.step * voxel) + 2.0
}

/// Rejects a step so small that a ray across the volume's diagonal would take more than
/// [`MAX_STEPS_PER_RAY`] steps.
pub(super) fn check_steps_per_ray(
    opts: &VolumeRenderOptions,
    voxel: f64,
    size: [f64; 3],
) -> Result<()> {
    let diagonal = size.iter().map(|s| s * s).sum::<f64>().sqrt();
    let steps = steps_per_ray(opts, voxel, size);
    if steps > MAX_STEPS_PER_RAY as f64 {
        return Err(Error::invalid(
            "step",
            format!(
                "a ray through this volume would take up to {steps:.0} steps at step {}; at most {MAX_STEPS_PER_RAY} are supported, so use a step of at least {:.2e} voxels",
                opts.step,
                diagonal / voxel / (MAX_STEPS_PER_RAY as f64 - 2.0)
            ),
        ));
    }
    Ok(())
}

/// The shader parameters of one render: camera relative to the volume's corner, projection,
/// scale mapping, lens, transfer-function constants, marching and shading.
pub(super) fn volume_params(
    volume: &Geometry,
    opts: &VolumeRenderOptions,
    tf: &ResolvedTransfer,
    tf_consts: [f32; 4],
    voxel: f64,
    size: [f64; 3],
) -> VolumeParams {
    let cam = &opts.camera;
    let lo = volume.origin;
    let eye = [cam.eye[0] - lo[0], cam.eye[1] - lo[1], cam.eye[2] - lo[2]];
    let v4 = |v: [f64; 3], w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
    let proj = cam
        .shader_projection(opts.width, opts.height)
        .map(|v| v as f32);
    let lens = tf.mapping.lens.unwrap_or([0.0, 1.0, 0.0, 1.0]);
    VolumeParams {
        eye: v4(eye, 0.0),
        forward: v4(cam.forward, 0.0),
        right: v4(cam.right, 0.0),
        up: v4(cam.up, 0.0),
        proj,
        box_size: v4(size, 0.0),
        background: v4(opts.background, 0.0),
        scale: [
            tf.mapping.s_lo as f32,
            tf.mapping.inv_range as f32,
            tf.mapping.linthresh() as f32,
            (LUT_SIZE - 1) as f32,
        ],
        lens: lens.map(|v| v as f32),
        tf: tf_consts,
        march: [
            (opts.step * voxel) as f32,
            (1.0 / voxel) as f32,
            opts.stop_optical_depth().min(f32::MAX as f64) as f32,
            // The shader's opaque 1.0 (see composite in shaders/shared/march.wgsl).
            1.0,
        ],
        image: [opts.width, opts.height, opts.seed, 0],
        shading: opts.shading.map_or([0.0; 4], |s| {
            [
                s.ambient as f32,
                s.diffuse as f32,
                s.specular as f32,
                s.shininess as f32,
            ]
        }),
        skip: [0.0; 4],
        slab: [0.0; 4],
        hull: [[0.0; 4]; 7],
        gradient: [0.0; 4],
    }
}

/// The smallest of three spacings: a regular box's voxel length.
pub(crate) fn min_spacing(spacing: [f64; 3]) -> f64 {
    spacing.iter().cloned().fold(f64::INFINITY, f64::min)
}

/// What a render needs to know of a volume's geometry, resident or bricked.
pub(crate) struct Geometry<'a> {
    pub name: &'a str,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    pub stats: &'a VolumeStats,
    /// The length `step`, emission and extinction count in (the smallest spacing of a box).
    pub voxel: f64,
}

impl Geometry<'_> {
    pub(super) fn size(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| self.dims[a] as f64 * self.spacing[a])
    }
}

/// One render's fixed quantities (see [`VolumeRenderer::frame`]).
pub(crate) struct Frame {
    pub key: PipelineKey,
    pub tf: ResolvedTransfer,
    pub params: VolumeParams,
}
