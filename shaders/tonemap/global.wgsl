// Global tone-mapping operators, one pixel per invocation: linear clamp (op 0), Drago 2003 (1),
// Reinhard 2002 global (2), Ward Larson 1997 histogram adjustment (3), Narkowicz ACES fit (4).
// Luminance is handled as ln(L_w) throughout so that 1e-30 and 1e30 stay in f32 range. Output
// is display-referred linear RGBA in [0, 1]: C_d = (C / L_w)^saturation * L_d, + offset,
// clamped, ^(1 / gamma). Missing pixels (any NaN/Inf component) come out (0, 0, 0, 0); black
// pixels come out black with their alpha. CPU reference: src/tonemap/cpu/mod.rs `tonemap_cpu`.
//
// Needs `stats` from luminance_stats.wgsl (all operators but linear and ACES; count == 0 gives
// a black image) and, for Ward, the `cdf` from ward_histogram.wgsl (bind any buffer of >= 1
// f32 for other ops).
//
// Entry point apply_global: workgroups of 256; dispatch (X, Y, 1) with X * Y * 256 >= n,
// pixel index = global_id.x + global_id.y * X * 256 (so images over 16.7 Mpx fit the 65535
// limit on X).
//
// Bindings (group 0):
//   @binding(0) params  uniform    ToneMapParams
//   @binding(1) image   storage, read        array<vec4<f32>>  scene-referred linear RGBA
//   @binding(2) output  storage, read_write  array<vec4<f32>>  display-referred linear RGBA
//   @binding(3) stats   storage, read        LuminanceStats
//   @binding(4) cdf     storage, read        array<f32>, bins + 1 entries (cdf[0] < 0: linear)

#include "shared/tonemap_common.wgsl"

const LN2: f32 = 0.6931471805599453;
const LN10: f32 = 2.302585092994046;
// ln of the largest L kept finite after exp (e^88 = 1.65e38 < f32 max).
const MAX_LOG: f32 = 88.0;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> stats: LuminanceStats;
@group(0) @binding(4) var<storage, read> cdf: array<f32>;

// ln(1 + e^t) without overflow for large t or cancellation for small e^t.
fn ln1p_exp(t: f32) -> f32 {
    if t > 20.0 {
        return t + exp(-t);
    }
    let x = exp(t);
    if x < 1.0e-4 {
        return x * (1.0 - 0.5 * x);
    }
    return log(1.0 + x);
}

fn drago(log_lw: f32) -> f32 {
    let exponent = log(params.bias) / log(0.5);
    let relative = exp(exponent * (log_lw - stats.max_log));
    let log10_max = ln1p_exp(stats.max_log - stats.mean_log) / LN10;
    return (params.ld_max * 0.01) / log10_max * ln1p_exp(log_lw - stats.mean_log)
        / log(2.0 + 8.0 * relative);
}

fn reinhard(log_lw: f32) -> f32 {
    let l = exp(min(log(params.key) + log_lw - stats.mean_log, MAX_LOG));
    var white = params.white;
    if white <= 0.0 {
        white = exp(min(log(params.key) + stats.max_log - stats.mean_log, MAX_LOG));
    }
    return (1.0 + l / white / white) * (l / (1.0 + l));
}

fn ward(log_lw: f32) -> f32 {
    if cdf[0] < 0.0 {
        return exp(min(log_lw - stats.max_log, 0.0));
    }
    let bins = f32(params.bins);
    let width = (stats.max_log - stats.min_log) / bins;
    let t = max((log_lw - stats.min_log) / width, 0.0);
    let index = clamp(floor(t), 0.0, bins - 1.0);
    let frac = clamp(t - index, 0.0, 1.0);
    let i = u32(index);
    let p = cdf[i] + frac * (cdf[i + 1u] - cdf[i]);
    return exp(log(params.ld_min) + log(params.ld_max / params.ld_min) * p) / params.ld_max;
}

fn aces(log_lw: f32) -> f32 {
    let a = 2.51;
    let b = 0.03;
    let c = 2.43;
    let d = 0.59;
    let e = 0.14;
    if log_lw > 0.0 {
        // Divided through by x^2 so that x = 1e30 does not overflow.
        let r = exp(-log_lw);
        return clamp((a + b * r) / (c + d * r + e * r * r), 0.0, 1.0);
    }
    let x = exp(log_lw);
    return clamp(x * (a * x + b) / (x * (c * x + d) + e), 0.0, 1.0);
}

fn display_luminance(log_lw: f32) -> f32 {
    switch OP {
        case 0u: { return exp(min(log_lw, 0.0)); }
        case 1u: { return drago(log_lw); }
        case 2u: { return reinhard(log_lw); }
        case 3u: { return ward(log_lw); }
        case 4u: { return aces(log_lw); }
        default: { return 0.0; }
    }
}

@compute @workgroup_size(256)
fn apply_global(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    // Index within the band (image and output are bound from its first row).
    let i = id.x + id.y * groups.x * 256u;
    if i >= params.width * params.band_rows {
        return;
    }
    let p = image[i];
    if is_missing(p) {
        output[i] = vec4<f32>(0.0);
        return;
    }
    let colour = max(p.rgb, vec3<f32>(0.0));
    let y = dot(colour, REC709);
    var rgb = vec3<f32>(0.0);
    // Linear (0) and ACES (4) run without the statistics pass: a pixel that is lit is enough.
    if y > 0.0 && (OP == 0u || OP == 4u || stats.count > 0u) {
        let ld = display_luminance(log(y) + params.exposure_ev * LN2);
        rgb = compose(colour, y, ld);
    } else {
        rgb = compose(vec3<f32>(0.0), 1.0, 0.0);
    }
    output[i] = vec4<f32>(rgb, clamp(p.a, 0.0, 1.0));
}
