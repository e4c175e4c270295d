// Log-luminance statistics of an HDR image: mean, max and min of ln(L_w) over pixels whose
// exposed Rec. 709 luminance L_w is finite and > 0 (missing NaN/Inf pixels and black pixels are
// left out). Keeping logs means an image near 1e-30 or 1e30 never under- or overflows; the
// summands are O(10), so f32 partial sums (Kahan per thread, a tree per workgroup) are stable.
// CPU reference: src/tonemap/cpu/mod.rs `luminance_log_stats`.
//
// Two passes, both in this file:
//   partial_stats  dispatch (G, 1, 1) workgroups of 256 per band of rows (G >= 1 and <= 64);
//                  each thread strides over the band by G * 256 pixels. Writes
//                  partials[workgroup] of the band's window of `partials`.
//   finish_stats   dispatch (1, 1, 1); combines arrayLength(&partials) partials into `stats`.
//
// Bindings (group 0):
//   @binding(0) params    uniform    ToneMapParams  (partial_stats: width, height, exposure_ev)
//   @binding(1) image     storage, read        array<vec4<f32>>  (partial_stats)
//   @binding(3) stats     storage, read_write  LuminanceStats    (finish_stats)
//   @binding(6) partials  storage, read_write  array<vec4<f32>>, exactly G elements:
//                         (sum ln L, count, max ln L, min ln L) per workgroup

#include "shared/tonemap_common.wgsl"

const WORKGROUP: u32 = 256u;
const LN2: f32 = 0.6931471805599453;
// Stand-ins for -inf / +inf (WGSL has no infinite literals).
const LOW: f32 = -3.0e38;
const HIGH: f32 = 3.0e38;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> stats: LuminanceStats;
@group(0) @binding(6) var<storage, read_write> partials: array<vec4<f32>>;

var<workgroup> shared_acc: array<vec4<f32>, WORKGROUP>;

fn combine(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(a.x + b.x, a.y + b.y, max(a.z, b.z), min(a.w, b.w));
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
fn partial_stats(
    @builtin(local_invocation_index) local: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    // The band's pixels (the image window starts at its first row).
    let n = params.width * params.band_rows;
    let stride = groups.x * WORKGROUP;
    let exposure_log = params.exposure_ev * LN2;
    var sum = 0.0;
    var compensation = 0.0;
    var count = 0.0;
    var hi = LOW;
    var lo = HIGH;
    for (var i = group.x * WORKGROUP + local; i < n; i = i + stride) {
        let p = image[i];
        if is_missing(p) {
            continue;
        }
        let y = dot(max(p.rgb, vec3<f32>(0.0)), REC709);
        if y <= 0.0 {
            continue;
        }
        let v = log(y) + exposure_log;
        // Kahan summation over the thread's strided pixels.
        let t = v - compensation;
        let s = sum + t;
        compensation = (s - sum) - t;
        sum = s;
        count = count + 1.0;
        hi = max(hi, v);
        lo = min(lo, v);
    }
    let total = reduce_workgroup(local, vec4<f32>(sum, count, hi, lo));
    if local == 0u {
        partials[group.x] = total;
    }
}

@compute @workgroup_size(256)
fn finish_stats(@builtin(local_invocation_index) local: u32) {
    let groups = arrayLength(&partials);
    var acc = vec4<f32>(0.0, 0.0, LOW, HIGH);
    for (var i = local; i < groups; i = i + WORKGROUP) {
        acc = combine(acc, partials[i]);
    }
    let total = reduce_workgroup(local, acc);
    if local == 0u {
        let count = u32(round(total.y));
        stats.count = count;
        if count > 0u {
            stats.mean_log = total.x / total.y;
            stats.max_log = total.z;
            stats.min_log = total.w;
        } else {
            stats.mean_log = 0.0;
            stats.max_log = 0.0;
            stats.min_log = 0.0;
        }
    }
}
