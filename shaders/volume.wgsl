// HDR volume ray casting: one invocation per pixel, front-to-back emission–absorption
// compositing in f32 with premultiplied colour, optical depth accumulated (not transmittance
// multiplied), per-segment emission integrated exactly for a homogeneous segment, early ray
// termination when the optical depth passes a threshold. Keep Params in sync with
// src/render/volume.rs (VolumeParams).
#include "shared/optics.wgsl"
#include "shared/camera.wgsl"

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
    // x: step in world units, y: voxels per world unit, z: optical depth at which rays stop
    march: vec4<f32>,
    // x: width, y: height, z: jitter seed
    image: vec4<u32>,
}

// 0: lookup table, 1: emission–absorption e·v, a·v.
override TF_KIND: u32 = 0u;
// 0: linear, 1: log10, 2: symlog.
override SCALE_KIND: u32 = 0u;
override USE_LENS: bool = false;
override JITTER: bool = false;

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var volume_tex: texture_3d<f32>;
// The transfer table as an N x 1 texture read with textureLoad (GLES has no 1-D textures): on CPU rasterizers texel loads
// are cheaper than storage-buffer gathers, and the f32 interpolation below matches the CPU
// reference exactly (no fixed-point filter weights).
@group(0) @binding(2) var lut: texture_2d<f32>;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba32float, write>;
#if HW_FILTER
@group(0) @binding(4) var volume_sampler: sampler;
#endif

fn sample_volume(uvw: vec3<f32>) -> f32 {
#if HW_FILTER
    return textureSampleLevel(volume_tex, volume_sampler, uvw, 0.0).r;
#else
    // Exact trilinear interpolation of cell-centred voxels, clamp to edge.
    let dims = vec3<i32>(textureDimensions(volume_tex));
    let g = uvw * vec3<f32>(dims) - 0.5;
    let g0 = floor(g);
    let f = g - g0;
    let top = dims - vec3<i32>(1);
    let a = clamp(vec3<i32>(g0), vec3<i32>(0), top);
    let b = clamp(vec3<i32>(g0) + vec3<i32>(1), vec3<i32>(0), top);
    let c000 = textureLoad(volume_tex, vec3<i32>(a.x, a.y, a.z), 0).r;
    let c100 = textureLoad(volume_tex, vec3<i32>(b.x, a.y, a.z), 0).r;
    let c010 = textureLoad(volume_tex, vec3<i32>(a.x, b.y, a.z), 0).r;
    let c110 = textureLoad(volume_tex, vec3<i32>(b.x, b.y, a.z), 0).r;
    let c001 = textureLoad(volume_tex, vec3<i32>(a.x, a.y, b.z), 0).r;
    let c101 = textureLoad(volume_tex, vec3<i32>(b.x, a.y, b.z), 0).r;
    let c011 = textureLoad(volume_tex, vec3<i32>(a.x, b.y, b.z), 0).r;
    let c111 = textureLoad(volume_tex, vec3<i32>(b.x, b.y, b.z), 0).r;
    let x00 = mix(c000, c100, f.x);
    let x10 = mix(c010, c110, f.x);
    let x01 = mix(c001, c101, f.x);
    let x11 = mix(c011, c111, f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
#endif
}

const LOG10_2: f32 = 0.30102999566;

// Data value -> table coordinate in [0, 1] (see ScaleMapping::map).
fn scaled(v: f32) -> f32 {
    var s = v;
    if (SCALE_KIND == 1u) {
        s = log2(max(v, 1.1754944e-38)) * LOG10_2;
    } else if (SCALE_KIND == 2u) {
        s = sign(v) * log2(1.0 + abs(v) / P.scale.z) * LOG10_2;
    }
    var t = clamp((s - P.scale.x) * P.scale.y, 0.0, 1.0);
    if (USE_LENS) {
        let l = P.lens;
        if (t < l.x) {
            t = select(l.z, t * l.z / l.x, l.x > 0.0);
        } else if (t <= l.y) {
            t = l.z + (t - l.x) * (l.w - l.z) / (l.y - l.x);
        } else {
            t = select(l.w, l.w + (t - l.y) * (1.0 - l.w) / (1.0 - l.y), l.y < 1.0);
        }
    }
    return t;
}

// Emission (rgb, per voxel length) and extinction (a, per voxel length) of a data value.
fn transfer(v: f32) -> vec4<f32> {
    if (TF_KIND == 1u) {
        let c = max(v, 0.0);
        return vec4<f32>(vec3<f32>(P.tf.x * c), P.tf.y * c);
    }
    let x = scaled(v) * P.scale.w;
    let i = min(i32(x), i32(P.scale.w) - 1);
    return mix(textureLoad(lut, vec2<i32>(i, 0), 0), textureLoad(lut, vec2<i32>(i + 1, 0), 0), x - f32(i));
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = P.image.x;
    let h = P.image.y;
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let ray = camera_ray(gid.x, gid.y, w, h, P.eye.xyz, P.forward.xyz, P.right.xyz, P.up.xyz, P.proj);
    let size = P.box_size.xyz;
    let hit = box_hit(ray.origin, ray.dir, size);
    let t_enter = max(hit.x, 0.0);
    let t_exit = hit.y;
    var tau = 0.0;
    var transmittance = 1.0;
    var color = vec3<f32>(0.0);
    if (t_exit > t_enter) {
        let ds = P.march.x;
        let voxels_per_unit = P.march.y;
        let stop_tau = P.march.z;
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
        let uvw0 = ray.origin * inv_size;
        let duvw = ray.dir * inv_size;
        var ta = t_enter;
        for (var k = 0u; k < n; k++) {
            let tb = min(t_enter + first + f32(k) * ds, t_exit);
            let mid = 0.5 * (ta + tb);
            let len = (tb - ta) * voxels_per_unit;
            ta = tb;
            let v = sample_volume(uvw0 + duvw * mid);
            // Missing values (NaN/Inf nearby) emit and absorb nothing; a select rather than a
            // branch keeps the SIMD lanes of CPU rasterizers together.
            let ea = select(vec4<f32>(0.0), transfer(v), is_finite_f32(v));
            let x = ea.a * len;
            // One exponential per step: the segment's absorbed fraction gives both its escape
            // fraction and the transmittance update. The optical depth is still accumulated
            // separately, for alpha and for the stopping test.
            let absorbed = one_minus_exp_neg(x);
            let escape = select(1.0 - x * (0.5 - x * (0.16666667 - x * 0.041666668)), absorbed / x, x >= 0.03);
            color += transmittance * ea.rgb * (len * escape);
            transmittance *= 1.0 - absorbed;
            tau += x;
            if (tau > stop_tau) {
                break;
            }
        }
    }
    let alpha = one_minus_exp_neg(tau);
    textureStore(out_image, vec2<i32>(gid.xy), vec4<f32>(color + exp(-tau) * P.background.rgb, alpha));
}
