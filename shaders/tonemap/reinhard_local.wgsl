// Reinhard, Stark, Shirley, Ferwerda 2002 automatic dodging-and-burning (their eqs. 5-9).
// Gaussian i (0-based) has sigma_i = alpha1 ratio^i / sqrt 2 px (params.rs `blur_sigma`); the
// blurs are normalised convolutions, sum(w L m) / sum(w m) with mask m = 0 at missing pixels
// and outside the image, done separably on (L m, m) pairs with a sampled Gaussian over
// radius = ceil(3 sigma) (params.rs `gaussian_radius`). Per pixel, the scale is the last one,
// scanning up from s = 1, whose activity |V_i - V_i+1| / (2^phi key / s^2 + V_i) < epsilon;
// L_d = L / (1 + V_chosen). CPU reference: src/tonemap/cpu.rs `reinhard_local`.
//
// Host sequence (all dispatches (X, Y, 1) workgroups of 256 with X * Y * 256 >= n,
// pixel = global_id.x + global_id.y * X * 256), `stats` from luminance_stats.wgsl:
//   prepare                                   image, stats -> state, weighted
//   blur (direction 0, sigma_0), (direction 1) weighted -> tmp -> A
//   for i in 0..scales:
//     blur (0, sigma_i+1), blur (1, sigma_i+1) weighted -> tmp -> B
//     select_scale (pass_index i, scale = ratio^i)  state, centre A, surround B
//     swap A and B
//   apply                                     image, state -> output
// Each dispatch's uniform sets the pass fields (direction, sigma, radius, pass_index, scale).
//
// Bindings (group 0):
//   @binding(0)  params    uniform    ToneMapParams
//   @binding(1)  image     storage, read        array<vec4<f32>>  (prepare, apply)
//   @binding(2)  output    storage, read_write  array<vec4<f32>>  (apply)
//   @binding(3)  stats     storage, read        LuminanceStats    (prepare)
//   @binding(7)  state     storage, read_write  array<vec4<f32>>  (L, mask, chosen V, done)
//   @binding(8)  blur_in   storage, read        array<vec2<f32>>  (blur)
//   @binding(9)  blur_out  storage, read_write  array<vec2<f32>>  (prepare: weighted; blur)
//   @binding(10) centre    storage, read        array<vec2<f32>>  (select_scale)
//   @binding(11) surround  storage, read        array<vec2<f32>>  (select_scale)

#include "shared/tonemap_common.wgsl"

const LN2: f32 = 0.6931471805599453;
const MAX_LOG: f32 = 88.0;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> stats: LuminanceStats;
@group(0) @binding(7) var<storage, read_write> state: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> blur_in: array<vec2<f32>>;
@group(0) @binding(9) var<storage, read_write> blur_out: array<vec2<f32>>;
@group(0) @binding(10) var<storage, read> centre: array<vec2<f32>>;
@group(0) @binding(11) var<storage, read> surround: array<vec2<f32>>;

fn normalised(v: vec2<f32>) -> f32 {
    return select(0.0, v.x / v.y, v.y > 0.0);
}

@compute @workgroup_size(256)
fn prepare(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.height {
        return;
    }
    let p = image[i];
    if is_missing(p) {
        state[i] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        blur_out[i] = vec2<f32>(0.0);
        return;
    }
    let y = dot(max(p.rgb, vec3<f32>(0.0)), REC709);
    var l = 0.0;
    if y > 0.0 && stats.count > 0u {
        l = exp(min(log(params.key) + log(y) + params.exposure_ev * LN2 - stats.mean_log, MAX_LOG));
    }
    state[i] = vec4<f32>(l, 1.0, 0.0, 0.0);
    blur_out[i] = vec2<f32>(l, 1.0);
}

@compute @workgroup_size(256)
fn blur(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.height {
        return;
    }
    let x = i32(i % params.width);
    let y = i32(i / params.width);
    let r = i32(params.radius);
    let inv_two_var = 1.0 / (2.0 * params.sigma * params.sigma);
    var acc = vec2<f32>(0.0);
    for (var k = -r; k <= r; k = k + 1) {
        var sx = x;
        var sy = y;
        if params.direction == 0u {
            sx = x + k;
        } else {
            sy = y + k;
        }
        if sx < 0 || sy < 0 || sx >= i32(params.width) || sy >= i32(params.height) {
            continue;
        }
        let w = exp(-f32(k * k) * inv_two_var);
        acc = acc + w * blur_in[u32(sy) * params.width + u32(sx)];
    }
    blur_out[i] = acc;
}

@compute @workgroup_size(256)
fn select_scale(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.height {
        return;
    }
    var s = state[i];
    if s.y == 0.0 {
        return;
    }
    let v1 = normalised(centre[i]);
    let v2 = normalised(surround[i]);
    if params.pass_index == 0u {
        s.z = v1;
        s.w = 0.0;
    }
    if s.w == 0.0 {
        let activity = (v1 - v2) / (params.sharpness / (params.scale * params.scale) + v1);
        if abs(activity) >= params.epsilon {
            s.w = 1.0;
        } else {
            s.z = v1;
        }
    }
    state[i] = s;
}

@compute @workgroup_size(256)
fn apply(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.height {
        return;
    }
    let p = image[i];
    if is_missing(p) {
        output[i] = vec4<f32>(0.0);
        return;
    }
    let colour = max(p.rgb, vec3<f32>(0.0));
    let y = dot(colour, REC709);
    let s = state[i];
    var rgb = compose(vec3<f32>(0.0), 1.0, 0.0);
    if y > 0.0 && s.x > 0.0 {
        rgb = compose(colour, y, s.x / (1.0 + s.z));
    }
    output[i] = vec4<f32>(rgb, clamp(p.a, 0.0, 1.0));
}
