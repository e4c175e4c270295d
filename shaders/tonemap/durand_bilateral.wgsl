// Durand & Dorsey 2002 fast bilateral tone mapping with their own acceleration (section 5.1):
// the bilateral filter of log10 luminance l as a piecewise-linear function of intensity,
// computed on a downsampled grid (params.rs `DurandGrid`). Levels i_j = first_level +
// j level_step; per level, a cell holds (sum w l, sum w) over its cell x cell valid pixels, each
// with its own w = exp(max(-(l - i_j)^2 / 2 sigma_r^2, -80)); the pairs are blurred by a Gaussian
// of `sigma` cells within `radius` cells; a pixel interpolates the two levels around its own l,
// each read bilinearly from the grid as (sum w l) / (sum w).
// Missing and black pixels have weight 0. The base B is compressed by
// c = min(log10(contrast) / (max B - min B), 1) with max B mapped to 1, the detail l - B kept:
// L_d = 10^((B - max B) c + l - B). CPU reference: src/tonemap/cpu/local.rs `durand`.
//
// Host sequence (dispatches (X, Y, 1) workgroups of 256, X * Y * 256 >= items,
// item = global_id.x + global_id.y * X * 256). The splat and the per-pixel passes run over
// bands of rows [band_first, band_first + band_rows) (grid rows for the splat, pixel rows
// otherwise; one band when every buffer fits one binding), with image, output and layers bound
// as windows from the band's first row (the splat's image window from row window_first):
//   grid_splat     one item per cell            image -> grid_levels
//   grid_blur_x    one item per (level, cell)   grid_levels -> tmp
//   grid_blur_y    one item per (level, cell)   tmp -> levels
//   base           one item per pixel           image, levels -> layers
//   range_partial  (G, 1, 1), G = min(ceil(n / 256), 64): layers -> partials (G elements)
//   range_finish   (1, 1, 1):     partials -> base_range
//   apply          one item per pixel           image, layers, base_range -> output
//
// Bindings (group 0):
//   @binding(0)  params      uniform    ToneMapParams (width, height, cell, grid_width,
//                                       grid_height, levels, first_level, level_step, sigma,
//                                       radius, sigma_range, contrast_log10; exposure cancels)
//   @binding(1)  image       storage, read        array<vec4<f32>>
//   @binding(2)  output      storage, read_write  array<vec4<f32>>  (apply)
//   @binding(6)  partials    storage, read_write  array<vec4<f32>>  (unused, count, max B, min B)
//   @binding(12) layers      storage, read_write  array<vec4<f32>>  (B, l, kind, 0), kind:
//                                       0 missing, 1 black, 2 positive luminance
//   @binding(13) base_range  storage, read_write  vec4<f32>         (min B, max B, count, 0)
//   @binding(16) tmp         storage, read_write  array<vec2<f32>>  levels x cells
//   @binding(17) grid_levels storage, read_write  array<vec2<f32>>  levels x cells

#include "shared/tonemap_common.wgsl"

const WORKGROUP: u32 = 256u;
const LOG10_E: f32 = 0.4342944819032518;
const LN10: f32 = 2.302585092994046;
const LOW: f32 = -3.0e38;
const HIGH: f32 = 3.0e38;
const MIN_LOG_WEIGHT: f32 = -80.0;
// params.rs DURAND_MAX_LEVELS: the splat keeps one (sum w l, sum w) per level of its cell.
const MAX_LEVELS: u32 = 64u;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> partials: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> layers: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read_write> base_range: vec4<f32>;
@group(0) @binding(16) var<storage, read_write> tmp: array<vec2<f32>>;
@group(0) @binding(17) var<storage, read_write> grid_levels: array<vec2<f32>>;

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
fn grid_splat(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // One item per cell of the band; the image window starts at pixel row window_first. Each
    // valid pixel's log luminance is computed once and weighs into every level by its own l,
    // so a highlight smaller than a cell keeps its intensity at its own level.
    let c = pixel_index(id, groups);
    if c >= params.grid_width * params.band_rows {
        return;
    }
    var acc: array<vec2<f32>, MAX_LEVELS>;
    let dd = params.level_step / params.sigma_range;
    let x0 = (c % params.grid_width) * params.cell;
    let y0 = (params.band_first + c / params.grid_width) * params.cell;
    let x1 = min(x0 + params.cell, params.width);
    let y1 = min(y0 + params.cell, params.height);
    for (var y = y0; y < y1; y = y + 1u) {
        for (var x = x0; x < x1; x = x + 1u) {
            let l = log_luminance(image[(y - params.window_first) * params.width + x]);
            if l.y == 2.0 {
                let d0 = (l.x - params.first_level) / params.sigma_range;
                for (var j = 0u; j < params.levels; j = j + 1u) {
                    let d = d0 - f32(j) * dd;
                    let w = exp(max(-0.5 * d * d, MIN_LOG_WEIGHT));
                    acc[j] = acc[j] + vec2<f32>(w * l.x, w);
                }
            }
        }
    }
    let n_cells = params.grid_width * params.grid_height;
    let cell = params.band_first * params.grid_width + c;
    for (var j = 0u; j < params.levels; j = j + 1u) {
        grid_levels[j * n_cells + cell] = acc[j];
    }
}

fn spatial_weight(k: i32) -> f32 {
    return exp(-f32(k * k) / (2.0 * params.sigma * params.sigma));
}

@compute @workgroup_size(256)
fn grid_blur_x(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let item = pixel_index(id, groups);
    let n_cells = params.grid_width * params.grid_height;
    if item >= n_cells * params.levels {
        return;
    }
    let c = item % n_cells;
    let x = i32(c % params.grid_width);
    let row = item - u32(x);
    let r = i32(params.radius);
    var acc = vec2<f32>(0.0);
    for (var k = -r; k <= r; k = k + 1) {
        let sx = x + k;
        if sx < 0 || sx >= i32(params.grid_width) {
            continue;
        }
        acc = acc + spatial_weight(k) * grid_levels[row + u32(sx)];
    }
    tmp[item] = acc;
}

@compute @workgroup_size(256)
fn grid_blur_y(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let item = pixel_index(id, groups);
    let n_cells = params.grid_width * params.grid_height;
    if item >= n_cells * params.levels {
        return;
    }
    let c = item % n_cells;
    let plane = item - c;
    let x = c % params.grid_width;
    let y = i32(c / params.grid_width);
    let r = i32(params.radius);
    var acc = vec2<f32>(0.0);
    for (var k = -r; k <= r; k = k + 1) {
        let sy = y + k;
        if sy < 0 || sy >= i32(params.grid_height) {
            continue;
        }
        acc = acc + spatial_weight(k) * tmp[plane + u32(sy) * params.grid_width + x];
    }
    grid_levels[item] = acc;
}

// Bilinear interpolation of one level at pixel (x, y): cell c's centre is at pixel
// (c + 0.5) cell - 0.5, clamped to the outermost centres. As cpu/local.rs `bilinear_on`.
fn grid_axis(p: u32, n: u32) -> vec3<f32> {
    let u = clamp((f32(p) + 0.5) / f32(params.cell) - 0.5, 0.0, f32(n - 1u));
    let i0 = floor(u);
    return vec3<f32>(i0, min(i0 + 1.0, f32(n - 1u)), u - i0);
}

fn level_value(level: u32, ax: vec3<f32>, ay: vec3<f32>) -> f32 {
    let plane = level * params.grid_width * params.grid_height;
    let w = params.grid_width;
    let r0 = plane + u32(ay.x) * w;
    let r1 = plane + u32(ay.y) * w;
    let top = mix(grid_levels[r0 + u32(ax.x)], grid_levels[r0 + u32(ax.y)], ax.z);
    let bottom = mix(grid_levels[r1 + u32(ax.x)], grid_levels[r1 + u32(ax.y)], ax.z);
    let v = mix(top, bottom, ay.z);
    return v.x / v.y;
}

@compute @workgroup_size(256)
fn base(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.band_rows {
        return;
    }
    let centre = log_luminance(image[i]);
    if centre.y < 2.0 {
        layers[i] = vec4<f32>(0.0, 0.0, centre.y, 0.0);
        return;
    }
    let t = (centre.x - params.first_level) / params.level_step;
    let j = clamp(floor(t), 0.0, f32(params.levels - 2u));
    let f = clamp(t - j, 0.0, 1.0);
    let ax = grid_axis(i % params.width, params.grid_width);
    let ay = grid_axis(params.band_first + i / params.width, params.grid_height);
    let lower = level_value(u32(j), ax, ay);
    let upper = level_value(u32(j) + 1u, ax, ay);
    layers[i] = vec4<f32>(mix(lower, upper, f), centre.x, 2.0, 0.0);
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
    let n = params.width * params.band_rows;
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
    if i >= params.width * params.band_rows {
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
