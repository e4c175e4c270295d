// The uniform parameters and pipeline constants of the f32 ray casters (volume.wgsl and
// volume_bricked.wgsl). Keep Params in sync with src/render/volume/params.rs (VolumeParams).

struct Params {
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    proj: vec4<f32>,
    box_size: vec4<f32>,
    background: vec4<f32>,
    // x: scaled lower bound, y: 1 / scaled range, z: symlog threshold, w: LUT size - 1
    scale: vec4<f32>,
    // lens: base [x, y] maps onto [z, w]
    lens: vec4<f32>,
    // emission–absorption: x = e, y = a
    tf: vec4<f32>,
    // x: step in world units, y: voxels per world unit, z: optical depth at which rays stop,
    // w: 1.0, which the shader compiler cannot see
    march: vec4<f32>,
    // x: width, y: height, z: jitter seed
    image: vec4<u32>,
    // Blinn–Phong under a headlight: x ambient, y diffuse, z specular, w shininess (SHADING only)
    shading: vec4<f32>,
    // Empty-space skipping (SKIPPING only): x voxels per cell edge of the skip grid; y, z: every
    // value up to y and from z on is transparent; w: the slack of a gradient skip (GradientSkip
    // in src/render/skipping.rs)
    skip: vec4<f32>,
    // One slab of a distributed render (SLAB only): x, y the z range (world units from the
    // box's lower corner) whose segment midpoints this rank composites, z the global index of
    // the first z-slice in the texture, w the volume's global slice count.
    slab: vec4<f32>,
    // Empty-space skipping (SKIPPING only): the hull of the cells that are not empty, the lowest
    // and highest projection on each of 13 directions (HULL_DIRECTIONS in
    // src/render/skipping.rs), direction i in hull[i / 2].xy (even i) or .zw (odd i).
    hull: array<vec4<f32>, 7>,
    // Gradient skip (SKIPPING only): xyz the largest change of the data between neighbouring
    // voxels along each axis
    gradient: vec4<f32>,
}

// 0: lookup table, 1: emission–absorption e·v, a·v.
override TF_KIND: u32 = 0u;
// 0: linear, 1: log10, 2: symlog.
override SCALE_KIND: u32 = 0u;
override USE_LENS: bool = false;
override JITTER: bool = false;
// 0: f32, 1: 8-bit framebuffer emulation, 2: binary16 emulation, 3: f32 with compensated sums.
override PRECISION: u32 = 0u;
// How much of the per-sample work point samples do (SampleWork in src/render/volume/mod.rs, for the
// cost breakdown of `hdrvis bench volume --breakdown`): 0 no volume read, 1 the sample, 2 its
// scale, 3 the table index, 4 everything (images).
override WORK: u32 = 4u;
// Skipping by the gradient bound inside cells that are not empty (SKIPPING only; GradientSkip in
// src/render/skipping.rs).
override GRADIENT_SKIP: bool = false;
// Samples the skipping march takes between lookups: 1, 2 or 4 (SKIPPING only).
override SAMPLES_PER_PASS: u32 = 4u;
