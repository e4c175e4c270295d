// Ward Larson, Rushmeier, Piatko 1997 histogram adjustment, the two passes before
// global.wgsl's op 3: a histogram of ln(L_w) over [stats.min_log, stats.max_log] in
// params.bins (<= 256) bins, then the linear-ceiling trimming loop (ceiling = T * bin_width /
// ln(ld_max / ld_min), until at most 2.5 % of the original counts are trimmed) and the
// normalised cumulative distribution. cdf[0] = -1 tells global.wgsl to fall back to the
// paper's linear mapping (scene range within the display's). Where the paper gives up (total
// trimmed under the tolerance) the last trimmed histogram is used instead.
// CPU reference: src/tonemap/cpu/mod.rs `WardMapping`.
//
// Entry points:
//   histogram    dispatch (G, 1, 1) workgroups of 256, G = min(ceil(n / 256), 64); threads
//                stride over the image. `counts` must be zeroed before (clear_buffer).
//   ceiling_cdf  dispatch (1, 1, 1); one invocation (the loop is at most 100 x 256 steps).
//
// Bindings (group 0):
//   @binding(0) params  uniform    ToneMapParams (width, height, bins, exposure_ev, ld_min, ld_max)
//   @binding(1) image   storage, read        array<vec4<f32>>          (histogram)
//   @binding(3) stats   storage, read        LuminanceStats            (from luminance_stats.wgsl)
//   @binding(4) cdf     storage, read_write  array<f32>, >= bins + 1    (ceiling_cdf)
//   @binding(5) counts  storage, read_write  array<atomic<u32>, 256>

#include "shared/tonemap_common.wgsl"

const MAX_BINS: u32 = 256u;
const WORKGROUP: u32 = 256u;
const LN2: f32 = 0.6931471805599453;
const TOLERANCE: f32 = 0.025;
const MAX_ITERATIONS: u32 = 100u;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> stats: LuminanceStats;
@group(0) @binding(4) var<storage, read_write> cdf: array<f32>;
@group(0) @binding(5) var<storage, read_write> counts: array<atomic<u32>, MAX_BINS>;

var<workgroup> local_counts: array<atomic<u32>, MAX_BINS>;

@compute @workgroup_size(256)
fn histogram(
    @builtin(local_invocation_index) local: u32,
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    atomicStore(&local_counts[local], 0u);
    workgroupBarrier();
    let n = params.width * params.band_rows;
    let bins = min(params.bins, MAX_BINS);
    let width = (stats.max_log - stats.min_log) / f32(bins);
    if width > 0.0 {
        let stride = groups.x * WORKGROUP;
        for (var i = group.x * WORKGROUP + local; i < n; i = i + stride) {
            let p = image[i];
            if is_missing(p) {
                continue;
            }
            let y = dot(max(p.rgb, vec3<f32>(0.0)), REC709);
            if y <= 0.0 {
                continue;
            }
            let t = (log(y) + params.exposure_ev * LN2 - stats.min_log) / width;
            let bin = u32(clamp(floor(t), 0.0, f32(bins - 1u)));
            atomicAdd(&local_counts[bin], 1u);
        }
    }
    workgroupBarrier();
    let mine = atomicLoad(&local_counts[local]);
    if mine > 0u {
        atomicAdd(&counts[local], mine);
    }
}

@compute @workgroup_size(1)
fn ceiling_cdf() {
    let bins = min(params.bins, MAX_BINS);
    let display_range = log(params.ld_max / params.ld_min);
    let scene_range = stats.max_log - stats.min_log;
    if stats.count == 0u || scene_range <= display_range {
        cdf[0] = -1.0;
        return;
    }
    let bin_width = scene_range / f32(bins);
    var trimmed_counts: array<f32, MAX_BINS>;
    for (var b = 0u; b < bins; b = b + 1u) {
        trimmed_counts[b] = f32(atomicLoad(&counts[b]));
    }
    let tolerance = TOLERANCE * f32(stats.count);
    for (var iteration = 0u; iteration < MAX_ITERATIONS; iteration = iteration + 1u) {
        var total = 0.0;
        for (var b = 0u; b < bins; b = b + 1u) {
            total = total + trimmed_counts[b];
        }
        if total < tolerance {
            // The paper's failure case (e.g. one outlier far above the rest): the trimmed
            // histogram is still a monotonic map under the ceiling, so keep it.
            break;
        }
        let ceiling = total * bin_width / display_range;
        var trimmed = 0.0;
        for (var b = 0u; b < bins; b = b + 1u) {
            if trimmed_counts[b] > ceiling {
                trimmed = trimmed + trimmed_counts[b] - ceiling;
                trimmed_counts[b] = ceiling;
            }
        }
        if trimmed <= tolerance {
            break;
        }
    }
    var total = 0.0;
    for (var b = 0u; b < bins; b = b + 1u) {
        total = total + trimmed_counts[b];
    }
    var running = 0.0;
    cdf[0] = 0.0;
    for (var b = 0u; b < bins; b = b + 1u) {
        running = running + trimmed_counts[b];
        cdf[b + 1u] = running / total;
    }
}
