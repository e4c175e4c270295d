// Durand & Dorsey 2002 fast bilateral tone mapping, as a direct windowed bilateral filter (no
// piecewise-linear acceleration) so that it matches the CPU reference: log10 luminance l is
// filtered over the taps at multiples of tap_stride (params.rs `bilateral_stride`: 1 up to
// sigma_s = 8 px, then about sigma_s / 4) within radius = ceil(2 sigma_s) (params.rs
// `bilateral_radius`), with weights exp(-d^2 / 2 sigma_s^2) exp(-(l_q - l_p)^2 / 2 sigma_r^2);
// missing and black pixels have weight 0. The base B is compressed by
// c = min(log10(contrast) / (max B - min B), 1) with max B mapped to 1, the detail l - B kept:
// L_d = 10^((B - max B) c + l - B). CPU reference: src/tonemap/cpu.rs `durand`.
//
// Host sequence (per-pixel dispatches (X, Y, 1) workgroups of 256, X * Y * 256 >= n,
// pixel = global_id.x + global_id.y * X * 256):
//   bilateral                     image -> layers
//   range_partial  (G, 1, 1), G = min(ceil(n / 256), 1024): layers -> partials (G elements)
//   range_finish   (1, 1, 1):     partials -> base_range
//   apply                         image, layers, base_range -> output
//
// Bindings (group 0):
//   @binding(0)  params      uniform    ToneMapParams (sigma_spatial_px, sigma_range, radius,
//                                       tap_stride, contrast_log10; exposure cancels out)
//   @binding(1)  image       storage, read        array<vec4<f32>>  (bilateral, apply)
//   @binding(2)  output      storage, read_write  array<vec4<f32>>  (apply)
//   @binding(6)  partials    storage, read_write  array<vec4<f32>>  (unused, count, max B, min B)
//   @binding(12) layers      storage, read_write  array<vec4<f32>>  (B, l, kind, 0), kind:
//                                       0 missing, 1 black, 2 positive luminance
//   @binding(13) base_range  storage, read_write  vec4<f32>         (min B, max B, count, 0)

#include "shared/tonemap_common.wgsl"

const WORKGROUP: u32 = 256u;
const LOG10_E: f32 = 0.4342944819032518;
const LN10: f32 = 2.302585092994046;
const LOW: f32 = -3.0e38;
const HIGH: f32 = 3.0e38;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> partials: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> layers: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read_write> base_range: vec4<f32>;

var<workgroup> shared_acc: array<vec4<f32>, WORKGROUP>;

// (log10 luminance, kind) of a pixel; exposure only shifts l and cancels in the result.
fn log_luminance(p: vec4<f32>) -> vec2<f32> {
    if is_missing(p) {
        return vec2<f32>(0.0, 0.0);
    }
    let y = dot(max(p.rgb, vec3<f32>(0.0)), REC709);
    if y <= 0.0 {
        return vec2<f32>(0.0, 1.0);
    }
    return vec2<f32>(log(y) * LOG10_E, 2.0);
}

@compute @workgroup_size(256)
fn bilateral(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.height {
        return;
    }
    let centre = log_luminance(image[i]);
    if centre.y < 2.0 {
        layers[i] = vec4<f32>(0.0, 0.0, centre.y, 0.0);
        return;
    }
    let x = i32(i % params.width);
    let y = i32(i / params.width);
    let r = i32(params.radius);
    let stride = i32(max(params.tap_stride, 1u));
    let inv_two_var_s = 1.0 / (2.0 * params.sigma_spatial_px * params.sigma_spatial_px);
    let inv_two_var_r = 1.0 / (2.0 * params.sigma_range * params.sigma_range);
    var num = 0.0;
    var den = 0.0;
    for (var dy = -(r / stride) * stride; dy <= r; dy = dy + stride) {
        let sy = y + dy;
        if sy < 0 || sy >= i32(params.height) {
            continue;
        }
        for (var dx = -(r / stride) * stride; dx <= r; dx = dx + stride) {
            let sx = x + dx;
            if sx < 0 || sx >= i32(params.width) {
                continue;
            }
            let q = log_luminance(image[u32(sy) * params.width + u32(sx)]);
            if q.y < 2.0 {
                continue;
            }
            let d = q.x - centre.x;
            let w = exp(-f32(dx * dx + dy * dy) * inv_two_var_s - d * d * inv_two_var_r);
            num = num + w * q.x;
            den = den + w;
        }
    }
    // den >= 1: the centre's own weight.
    layers[i] = vec4<f32>(num / den, centre.x, 2.0, 0.0);
}

fn combine(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(0.0, a.y + b.y, max(a.z, b.z), min(a.w, b.w));
}

fn reduce_workgroup(local: u32, value: vec4<f32>) -> vec4<f32> {
    shared_acc[local] = value;
    workgroupBarrier();
    for (var half = WORKGROUP / 2u; half > 0u; half = half / 2u) {
        if local < half {
            shared_acc[local] = combine(shared_acc[local], shared_acc[local + half]);
        }
        workgroupBarrier();
    }
    return shared_acc[0];
}

@compute @workgroup_size(256)
fn range_partial(
    @builtin(local_invocation_index) local: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let n = params.width * params.height;
    var acc = vec4<f32>(0.0, 0.0, LOW, HIGH);
    for (var i = group.x * WORKGROUP + local; i < n; i = i + groups.x * WORKGROUP) {
        let layer = layers[i];
        if layer.z == 2.0 {
            acc = combine(acc, vec4<f32>(0.0, 1.0, layer.x, layer.x));
        }
    }
    let total = reduce_workgroup(local, acc);
    if local == 0u {
        partials[group.x] = total;
    }
}

@compute @workgroup_size(256)
fn range_finish(@builtin(local_invocation_index) local: u32) {
    var acc = vec4<f32>(0.0, 0.0, LOW, HIGH);
    for (var i = local; i < arrayLength(&partials); i = i + WORKGROUP) {
        acc = combine(acc, partials[i]);
    }
    let total = reduce_workgroup(local, acc);
    if local == 0u {
        base_range = vec4<f32>(total.w, total.z, total.y, 0.0);
    }
}

@compute @workgroup_size(256)
fn apply(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.height {
        return;
    }
    let p = image[i];
    let layer = layers[i];
    if layer.z == 0.0 {
        output[i] = vec4<f32>(0.0);
        return;
    }
    var rgb = compose(vec3<f32>(0.0), 1.0, 0.0);
    if layer.z == 2.0 {
        let range = base_range.y - base_range.x;
        var compression = 1.0;
        if range > 0.0 {
            compression = min(params.contrast_log10 / range, 1.0);
        }
        let log_ld = (layer.x - base_range.y) * compression + (layer.y - layer.x);
        let colour = max(p.rgb, vec3<f32>(0.0));
        rgb = compose(colour, dot(colour, REC709), exp(min(log_ld * LN10, 88.0)));
    }
    output[i] = vec4<f32>(rgb, clamp(p.a, 0.0, 1.0));
}
