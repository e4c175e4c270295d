// Bricked volume ray casting: the rays, samples and compositing of volume.wgsl, with voxels read
// from an atlas of bricks (B³ voxels plus a one-voxel apron each) through a page table. A page
// entry is a slot in the atlas, EMPTY (the transfer function makes the whole brick transparent:
// the ray jumps to the brick's exit), or ABSENT (not resident in this pass: the ray saves its
// state, asks for the brick and waits for a later pass). Out-of-core renders run one pass per
// batch of bricks in front-to-back order, carrying each ray's state in a storage buffer, so every
// sample is taken exactly once and composited in ray order: the image equals the in-core render.
// Keep Bricks in sync with src/render/bricked.rs (BrickParams).
#include "shared/optics.wgsl"
#include "shared/camera.wgsl"
#include "shared/march.wgsl"
#include "shared/volume_params.wgsl"

struct Bricks {
    // Voxels per axis, and the brick edge B in w.
    dims: vec4<u32>,
    // Bricks per axis, and the stored edge B + 2 in w.
    grid: vec4<u32>,
    // Atlas slots per axis; w: flags (1: first pass, 2: last pass, 4: keep ray state).
    slots: vec4<u32>,
    // 1 / atlas size in texels (xyz).
    inv_atlas: vec4<f32>,
}

const EMPTY: u32 = 0xfffffffeu;
const ABSENT: u32 = 0xffffffffu;
const FIRST_PASS: u32 = 1u;
const LAST_PASS: u32 = 2u;
const KEEP_STATE: u32 = 4u;
// Progress word: the next sample index, with these flags in the top bits.
const RAY_DONE: u32 = 0x80000000u;
const K_MASK: u32 = 0x3fffffffu;

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var atlas: texture_3d<f32>;
@group(0) @binding(2) var lut: texture_2d<f32>;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba32float, write>;
#if HW_FILTER
@group(0) @binding(4) var volume_sampler: sampler;
#endif
@group(0) @binding(5) var<uniform> BR: Bricks;
@group(0) @binding(6) var<storage, read> pages: array<u32>;
// Per pixel: (colour, tau), (colour carry, tau carry), (transmittance, ta, -, -).
@group(0) @binding(7) var<storage, read_write> ray_state: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> ray_progress: array<u32>;
@group(0) @binding(9) var<storage, read_write> requests: array<atomic<u32>>;

// Where the ray is: next sample, the current brick's page entry and the atlas offset of its
// stored copy relative to global voxel indices, and whether it waits for a brick.
struct Cursor {
    k: u32,
    // Samples before this index lie in the current brick.
    k_end: u32,
    entry: u32,
    offset: vec3<i32>,
    blocked: bool,
}

// Trilinear sample at voxel position `pv` (voxel centres at i + 0.5) of the brick whose stored
// copy starts at atlas texel `offset` + (global voxel index).
fn sample_brick(pv: vec3<f32>, offset: vec3<i32>) -> f32 {
#if HW_FILTER
    let uvw = (vec3<f32>(offset) + pv) * BR.inv_atlas.xyz;
    return textureSampleLevel(atlas, volume_sampler, uvw, 0.0).r;
#else
    // The same interpolation as volume.wgsl's exact path: global indices clamped to the volume,
    // then moved into the slot. The sample's brick is floor(pv / B), so its footprint lies in
    // the brick's interior and apron by construction.
    let g = pv - 0.5;
    let g0 = floor(g);
    let f = g - g0;
    let top = vec3<i32>(BR.dims.xyz) - vec3<i32>(1);
    let a = clamp(vec3<i32>(g0), vec3<i32>(0), top) + offset;
    let b = clamp(vec3<i32>(g0) + vec3<i32>(1), vec3<i32>(0), top) + offset;
    return trilinear_texels(atlas, a, b, f);
#endif
}

// Sample k of the ray (or a jump over an empty brick). When a sample leaves the samples known to
// lie in the current brick, its brick is looked up (the brick that owns its position) and the
// run of samples that stay in that brick is computed from the brick's exit: samples whose
// segment ends before the exit face have their midpoint inside the brick (to within rounding,
// far less than the half voxel of apron), so they read the brick's stored copy without further
// checks. Each sample is still taken once, in order, from a copy holding its footprint.
fn march_step(s: ptr<function, RayState>, c: ptr<function, Cursor>, m: March) {
    if ((*s).stopped || (*c).blocked || (*c).k >= m.steps) {
        return;
    }
    let k = (*c).k;
    let tb = segment_end(m, k);
    // The in-core march's positions and lengths (shared/march.wgsl interior_end).
    let interior = k >= 1u && k < interior_end(m.steps);
    let mid = 0.5 * ((*s).ta + tb);
    let uvw = select(m.uvw0 + m.duvw * mid, interior_origin(m) + (m.duvw * m.ds) * f32(k), interior);
    let pv = uvw * vec3<f32>(BR.dims.xyz);
    if (k >= (*c).k_end) {
        // B is a power of two, so the scaling is exact.
        let bc = vec3<u32>(clamp(floor(pv / f32(BR.dims.w)), vec3<f32>(0.0), vec3<f32>(BR.grid.xyz - vec3<u32>(1u))));
        let id = bc.x + BR.grid.x * (bc.y + BR.grid.y * bc.z);
        let entry = pages[id];
        if (entry == ABSENT) {
            atomicStore(&requests[id], 1u);
            (*c).blocked = true;
            return;
        }
        (*c).entry = entry;
        let slot = select(entry, 0u, entry == EMPTY);
        let sc = vec3<i32>(
            i32(slot % BR.slots.x),
            i32((slot / BR.slots.x) % BR.slots.y),
            i32(slot / (BR.slots.x * BR.slots.y)),
        ) * i32(BR.grid.w);
        // The stored copy's first voxel is one before the brick's corner.
        (*c).offset = sc - (vec3<i32>(bc * BR.dims.w) - vec3<i32>(1));
        // Where the ray leaves the brick, in the ray's own parameter.
        let ov = m.uvw0 * vec3<f32>(BR.dims.xyz);
        let dv = m.duvw * vec3<f32>(BR.dims.xyz);
        let safe = select(dv, vec3<f32>(1e-30), abs(dv) < vec3<f32>(1e-30));
        let face = vec3<f32>(bc + select(vec3<u32>(0u), vec3<u32>(1u), dv > vec3<f32>(0.0))) * f32(BR.dims.w);
        let tf = (face - ov) / safe;
        let t_out = min(min(tf.x, tf.y), tf.z);
        // Samples j < last end no later than t_out.
        let last = floor((t_out - m.t_enter - m.first) / m.ds) + 1.0;
        var end = k + 1u;
        if (last > f32(end)) {
            end = u32(min(last, f32(m.steps)));
        }
        (*c).k_end = end;
        if (entry == EMPTY) {
            // Every sample up to the exit is transparent: they would add exactly nothing. A jump
            // into another f32 block ends the block the samples before it were summed in.
            if (PRECISION == 0u && sum_block(end) != sum_block(k - 1u)) {
                end_block(s);
            }
            (*s).ta = segment_end(m, end - 1u);
            (*c).k = end;
            return;
        }
    }
    let len = select((tb - (*s).ta) * m.voxels_per_unit, m.ds * m.voxels_per_unit, interior);
    (*s).ta = tb;
    (*c).k = k + 1u;
    let v = sample_brick(pv, (*c).offset);
    let ea = select(vec4<f32>(0.0), transfer(v), is_finite_f32(v));
    if (PRECISION == 0u) {
        // The in-core march's f32 sums: interior segments in blocks of 64, the others onto the
        // totals directly.
        if (!interior || sum_block(k) != sum_block(k - 1u)) {
            end_block(s);
        }
        if (interior) {
            var block = RayState((*s).color_carry, vec3<f32>(0.0), (*s).tau_carry, 0.0, (*s).transmittance, (*s).ta, false);
            composite(&block, ea, len, m.stop_tau - (*s).tau);
            (*s).color_carry = block.color;
            (*s).tau_carry = block.tau;
            (*s).transmittance = block.transmittance;
            (*s).stopped = block.stopped;
            return;
        }
    }
    composite(s, ea, len, m.stop_tau);
}

// f32: the block of interior segments being summed (kept in the carry fields, which only f32c
// uses otherwise) joins the ray's totals. A block with nothing in it adds exactly zero.
fn end_block(s: ptr<function, RayState>) {
    (*s).color += (*s).color_carry;
    (*s).tau += (*s).tau_carry;
    (*s).color_carry = vec3<f32>(0.0);
    (*s).tau_carry = 0.0;
}

// One invocation per pixel, in 8 x 8 tiles (shared/camera.wgsl tile_pixel).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) tile: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let gid = tile_pixel(tile, l);
    let w = P.image.x;
    let h = P.image.y;
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let pixel = gid.y * w + gid.x;
    let flags = BR.slots.w;
    let ray = camera_ray(gid.x, gid.y, w, h, P.eye.xyz, P.forward.xyz, P.right.xyz, P.up.xyz, P.proj);
    let size = P.box_size.xyz;
    let hit = box_hit(ray.origin, ray.dir, size);
    let t_enter = max(hit.x, 0.0);
    let t_exit = hit.y;
    var s = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, t_enter, false);
    var c = Cursor(0u, 0u, 0u, vec3<i32>(0), false);
    var done = !(t_exit > t_enter);
    if ((flags & FIRST_PASS) == 0u) {
        let a = ray_state[3u * pixel];
        let b = ray_state[3u * pixel + 1u];
        let d = ray_state[3u * pixel + 2u];
        let progress = ray_progress[pixel];
        s = RayState(a.rgb, b.rgb, a.a, b.a, d.x, d.y, false);
        c.k = progress & K_MASK;
        done = (progress & RAY_DONE) != 0u;
    }
    if (!done) {
        let ds = P.march.x;
        let first = first_segment(gid.xy, w, h, ds);
        let n = segment_count(t_exit - t_enter, first, ds);
        let inv_size = 1.0 / size;
        let m = March(t_enter, t_exit, first, ds, P.march.y, P.march.z, n, ray.origin * inv_size, ray.dir * inv_size, ray.dir);
        // Four steps per iteration: llvmpipe ends loops after 65535 iterations, and a ray takes at
        // most 4 * 65535 samples (jumps only shorten that).
        for (var it = 0u; it < 65535u; it++) {
            march_step(&s, &c, m);
            march_step(&s, &c, m);
            march_step(&s, &c, m);
            march_step(&s, &c, m);
            if (s.stopped || c.blocked || c.k >= n) {
                break;
            }
        }
        done = s.stopped || c.k >= n;
    }
    if ((flags & KEEP_STATE) != 0u) {
        ray_state[3u * pixel] = vec4<f32>(s.color, s.tau);
        ray_state[3u * pixel + 1u] = vec4<f32>(s.color_carry, s.tau_carry);
        ray_state[3u * pixel + 2u] = vec4<f32>(s.transmittance, s.ta, 0.0, 0.0);
        ray_progress[pixel] = c.k | select(0u, RAY_DONE, done);
    }
    if ((flags & LAST_PASS) == 0u) {
        return;
    }
    if (PRECISION == 0u) {
        end_block(&s);
    }
    textureStore(out_image, vec2<i32>(gid.xy), ray_pixel(s));
}
