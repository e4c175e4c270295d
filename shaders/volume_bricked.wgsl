// Bricked volume ray casting: the rays, samples and compositing of volume.wgsl, with voxels read
// from an atlas of bricks (B³ voxels plus a one-voxel apron each) through a page table. A page
// entry is a slot in the atlas, EMPTY (the transfer function makes the whole brick transparent:
// the ray jumps to the brick's exit), or ABSENT (not resident in this pass: the ray saves its
// state, asks for the brick and waits for a later pass). Out-of-core renders run one pass per
// batch of bricks in front-to-back order, carrying each ray's state in a storage buffer, so every
// sample is taken exactly once and composited in ray order: the image equals the in-core render.
// Keep Params in sync with src/render/volume.rs (VolumeParams) and Bricks with
// src/render/bricked.rs (BrickParams).
#include "shared/optics.wgsl"
#include "shared/camera.wgsl"
#include "shared/march.wgsl"

struct Params {
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    proj: vec4<f32>,
    box_size: vec4<f32>,
    background: vec4<f32>,
    scale: vec4<f32>,
    lens: vec4<f32>,
    tf: vec4<f32>,
    march: vec4<f32>,
    image: vec4<u32>,
}

struct Bricks {
    // Voxels per axis, and the brick edge B in w.
    dims: vec4<u32>,
    // Bricks per axis, and the stored edge B + 2 in w.
    grid: vec4<u32>,
    // Atlas slots per axis; w: flags (1: first pass, 2: last pass, 4: keep ray state).
    slots: vec4<u32>,
}

override TF_KIND: u32 = 0u;
override SCALE_KIND: u32 = 0u;
override USE_LENS: bool = false;
override JITTER: bool = false;
override PRECISION: u32 = 0u;

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

// The fixed quantities of one ray's march (as in volume.wgsl), plus the ray in voxel units.
struct March {
    t_enter: f32,
    t_exit: f32,
    first: f32,
    ds: f32,
    voxels_per_unit: f32,
    stop_tau: f32,
    steps: u32,
    uvw0: vec3<f32>,
    duvw: vec3<f32>,
}

// Where the ray is: next sample, the brick it last looked up, and whether it waits for one.
struct Cursor {
    k: u32,
    brick: u32,
    entry: u32,
    blocked: bool,
}

// Trilinear sample at voxel position `pv` (voxel centres at i + 0.5) inside brick `bc`, whose
// stored copy sits in atlas slot `slot`.
fn sample_brick(pv: vec3<f32>, bc: vec3<u32>, slot: u32) -> f32 {
    let edge = i32(BR.grid.w);
    let sc = vec3<i32>(
        i32(slot % BR.slots.x),
        i32((slot / BR.slots.x) % BR.slots.y),
        i32(slot / (BR.slots.x * BR.slots.y)),
    ) * edge;
    // Global index of the stored brick's first voxel (one before the brick's corner).
    let base = vec3<i32>(bc * BR.dims.w) - vec3<i32>(1);
#if HW_FILTER
    let uvw = (vec3<f32>(sc - base) + pv) / vec3<f32>(textureDimensions(atlas));
    return textureSampleLevel(atlas, volume_sampler, uvw, 0.0).r;
#else
    // The same interpolation as volume.wgsl's exact path: global indices clamped to the volume,
    // then moved into the slot (the apron holds every voxel a sample in this brick can touch).
    let g = pv - 0.5;
    let g0 = floor(g);
    let f = g - g0;
    let top = vec3<i32>(BR.dims.xyz) - vec3<i32>(1);
    let lo = vec3<i32>(0);
    let hi = vec3<i32>(edge - 1);
    let a = clamp(clamp(vec3<i32>(g0), vec3<i32>(0), top) - base, lo, hi) + sc;
    let b = clamp(clamp(vec3<i32>(g0) + vec3<i32>(1), vec3<i32>(0), top) - base, lo, hi) + sc;
    let c000 = textureLoad(atlas, vec3<i32>(a.x, a.y, a.z), 0).r;
    let c100 = textureLoad(atlas, vec3<i32>(b.x, a.y, a.z), 0).r;
    let c010 = textureLoad(atlas, vec3<i32>(a.x, b.y, a.z), 0).r;
    let c110 = textureLoad(atlas, vec3<i32>(b.x, b.y, a.z), 0).r;
    let c001 = textureLoad(atlas, vec3<i32>(a.x, a.y, b.z), 0).r;
    let c101 = textureLoad(atlas, vec3<i32>(b.x, a.y, b.z), 0).r;
    let c011 = textureLoad(atlas, vec3<i32>(a.x, b.y, b.z), 0).r;
    let c111 = textureLoad(atlas, vec3<i32>(b.x, b.y, b.z), 0).r;
    let x00 = mix(c000, c100, f.x);
    let x10 = mix(c010, c110, f.x);
    let x01 = mix(c001, c101, f.x);
    let x11 = mix(c011, c111, f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
#endif
}

fn segment_end(m: March, k: u32) -> f32 {
    return min(m.t_enter + m.first + f32(k) * m.ds, m.t_exit);
}

// Sample k of the ray (or a jump over an empty brick).
fn march_step(s: ptr<function, RayState>, c: ptr<function, Cursor>, m: March) {
    if ((*s).stopped || (*c).blocked || (*c).k >= m.steps) {
        return;
    }
    let k = (*c).k;
    let tb = segment_end(m, k);
    let mid = 0.5 * ((*s).ta + tb);
    let uvw = m.uvw0 + m.duvw * mid;
    let pv = uvw * vec3<f32>(BR.dims.xyz);
    // The brick that owns this sample: a pure function of its position, so every sample belongs
    // to exactly one brick in every pass. B is a power of two, so the scaling is exact.
    let bc = vec3<u32>(clamp(floor(pv / f32(BR.dims.w)), vec3<f32>(0.0), vec3<f32>(BR.grid.xyz - vec3<u32>(1u))));
    let id = bc.x + BR.grid.x * (bc.y + BR.grid.y * bc.z);
    if (id != (*c).brick) {
        (*c).brick = id;
        (*c).entry = pages[id];
    }
    let entry = (*c).entry;
    if (entry == ABSENT) {
        atomicStore(&requests[id], 1u);
        (*c).blocked = true;
        return;
    }
    if (entry == EMPTY) {
        // Every sample up to the brick's exit is transparent: jump to the last segment that ends
        // a full step before the exit (the rest are stepped, each owned by a brick again).
        let ov = m.uvw0 * vec3<f32>(BR.dims.xyz);
        let dv = m.duvw * vec3<f32>(BR.dims.xyz);
        let safe = select(dv, vec3<f32>(1e-30), abs(dv) < vec3<f32>(1e-30));
        let face = vec3<f32>(bc + select(vec3<u32>(0u), vec3<u32>(1u), dv > vec3<f32>(0.0))) * f32(BR.dims.w);
        let tf = (face - ov) / safe;
        let t_out = min(min(tf.x, tf.y), tf.z);
        let jump = floor((t_out - m.t_enter - m.first) / m.ds);
        var next = k + 1u;
        if (jump > f32(next)) {
            next = u32(min(jump, f32(m.steps)));
        }
        (*s).ta = segment_end(m, next - 1u);
        (*c).k = next;
        return;
    }
    let len = (tb - (*s).ta) * m.voxels_per_unit;
    (*s).ta = tb;
    (*c).k = k + 1u;
    let v = sample_brick(pv, bc, entry);
    composite(s, select(vec4<f32>(0.0), transfer(v), is_finite_f32(v)), len, m.stop_tau);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
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
    var c = Cursor(0u, 0xffffffffu, 0u, false);
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
        var first = ds;
        if (JITTER) {
            let r = hash_u32(gid.x + w * (gid.y + h * P.image.z));
            first = ds * (1.0 - f32(r >> 8u) * (1.0 / 16777216.0));
        }
        let span = t_exit - t_enter;
        var n = 1u;
        if (span > first) {
            n = u32(ceil((span - first) / ds)) + 1u;
        }
        let inv_size = 1.0 / size;
        let m = March(t_enter, t_exit, first, ds, P.march.y, P.march.z, n, ray.origin * inv_size, ray.dir * inv_size);
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
    var alpha = one_minus_exp_neg(s.tau);
    if (PRECISION == 1u) {
        alpha = 1.0 - s.transmittance;
        let col = s.color + s.transmittance * P.background.rgb;
        textureStore(out_image, vec2<i32>(gid.xy), vec4<f32>(quantize8(col.x), quantize8(col.y), quantize8(col.z), alpha));
        return;
    }
    textureStore(out_image, vec2<i32>(gid.xy), vec4<f32>(s.color + exp(-s.tau) * P.background.rgb, alpha));
}
