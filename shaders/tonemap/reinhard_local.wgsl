// Reinhard, Stark, Shirley, Ferwerda 2002 automatic dodging-and-burning (their eqs. 5-9).
// Gaussian i (0-based) has sigma_i = alpha1 ratio^i / sqrt 2 px (params.rs `blur_sigma`); the
// blurs are normalised convolutions, sum(w L m) / sum(w m) with mask m = 0 at missing pixels
// and outside the image, computed on a pyramid of (L m, m) pairs: level k has cells of 2^k
// pixels, each the mean of four cells of level k - 1 (cells outside count as (0, 0)). Scale i
// is blurred separably on level k_i (params.rs `reinhard_level`; level 0 is the image) with a
// sampled Gaussian of `sigma` cells (params.rs `grid_sigma`) over radius = ceil(3 sigma), and
// read back bilinearly. Per pixel, the scale is the last one, scanning up from s = 1, whose
// activity |V_i - V_i+1| / (2^phi key / s^2 + V_i) < epsilon; L_d = L / (1 + V_chosen).
// CPU reference: src/tonemap/cpu/local.rs `reinhard_local` / `reinhard_blurs`.
//
// Host sequence (dispatches (X, Y, 1) workgroups of 256 with X * Y * 256 >= items,
// item = global_id.x + global_id.y * X * 256), `stats` from luminance_stats.wgsl. Every pass
// runs over bands of rows [band_first, band_first + band_rows) of its item grid (one band when
// the buffers fit one binding each; src/tonemap/gpu/reinhard_local.rs `record_reinhard`), with the large
// buffers bound as windows that start at the band's first row unless said otherwise. Scales
// 0 .. fine_scales - 1 are blurred on level 0 ("fine"), the others on coarser levels:
//   prepare     one item per pixel           image, stats -> level 0 (pyramid; rows
//                                            out_stride cells apart, padded to 256 bytes)
//   downsample  one item per cell of level k level k-1 (blur_in, rows in_stride apart, window
//                                            from row window_first) -> level k (blur_out)
//   for each coarse scale i, on its level k_i (cell = 2^k, grid_width x grid_height cells):
//     blur_x    one item per run of RUN cells of a row: level k (blur_in) -> this scale's
//               horizontal blur (blur_out)
//   per pixel band:
//     (copy)    the band's rows of level 0, and a halo of the largest fine radius, -> level0
//     fine_x    per fine scale, one item per run of RUN cells of a row: level0 -> its plane
//               (at dst_offset) of each out_stride-long row of the band's fine buffer
//     (copy)    fine buffer -> `fine` (texture row j: plane j % fine_scales of row j / fine_scales)
//     blur_y    per coarse scale, one item per run of RUN cells of a column: horizontal blur
//               (blur_in, window from row window_first) -> the rows of the scale this band
//               reads, at dst_offset in the band's coarse buffer (rows out_stride cells apart)
//     (copy)    coarse buffer -> `coarse`
//     apply     one item per run of RUN pixels of a column: image, stats, fine, coarse, scales
//               -> output
// Every pass writes storage buffers and the blurs and the selection read textures: Mesa's CPU
// rasterizers load a storage buffer at a per-lane index one lane at a time, and gather texel
// fetches in vector code.
//
// Bindings (group 0):
//   @binding(0)  params    uniform    ToneMapParams (per pass: radius, cell,
//                                     grid_width, grid_height, band_first, band_rows,
//                                     window_first, dst_offset, out_stride, in_stride; apply:
//                                     levels = number of scales + 1, fine_scales, window_first =
//                                     the first pixel row in `fine`)
//   @binding(1)  image     storage, read        array<vec4<f32>>  (prepare, apply)
//   @binding(2)  output    storage, read_write  array<vec4<f32>>  (apply)
//   @binding(3)  stats     storage, read        LuminanceStats    (prepare, apply)
//   @binding(8)  blur_in   storage, read        array<vec2<f32>>  (downsample, blur_x, blur_y)
//   @binding(9)  blur_out  storage, read_write  array<vec2<f32>>  (downsample, blur_x, fine_x,
//                                                                  blur_y)
//   @binding(10) pyramid   storage, read_write  array<vec2<f32>>  (prepare: level 0)
//   @binding(11) coarse    texture_2d<f32>      the band's coarse rows (apply)
//   @binding(12) fine      texture_2d<f32>      the band's fine horizontal blurs (apply)
//   @binding(13) level0    texture_2d<f32>      the band's rows of level 0 (fine_x)
//   @binding(18) scales    uniform    array<vec4<u32>, 17>  per scale i: fine (radius, 0, bits
//                                     of f32 s_i = ratio^i, 0); coarse (first texture row in
//                                     `coarse`, k, bits of s_i, first row of level k held)
//   @binding(19) taps      uniform    array<vec4<f32>, 32>  the blur's Gaussian taps
//                                     exp(-k^2 / (2 sigma^2)), k = 0..=radius, from the host
//                                     (blur_x, fine_x, blur_y): no exp per lane, and no workgroup
//                                     memory, whose barrier costs Mesa's CPU rasterizers a
//                                     switch of every lane's coroutine
//   @binding(20) fine_taps uniform    array<vec4<f32>, 68>  16 taps per fine scale (apply)

#include "shared/tonemap_common.wgsl"

const LN2: f32 = 0.6931471805599453;
const MAX_LOG: f32 = 88.0;
// Taps 0..=radius of a blur's Gaussian, four to a vector (uniform arrays stride 16 bytes).
const MAX_TAPS: u32 = 128u;
const TAP_VECTORS: u32 = 32u;
// Scales + 1 blurs at most (params.rs: scales <= 16).
const MAX_SCALES: u32 = 17u;
// Sixteen taps (radius <= 15) for each scale blurred on level 0, whose sigma is under 3.2 px.
const FINE_TAP_VECTORS: u32 = 68u;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> stats: LuminanceStats;
@group(0) @binding(8) var<storage, read> blur_in: array<vec2<f32>>;
@group(0) @binding(9) var<storage, read_write> blur_out: array<vec2<f32>>;
@group(0) @binding(10) var<storage, read_write> pyramid: array<vec2<f32>>;
@group(0) @binding(11) var coarse: texture_2d<f32>;
@group(0) @binding(12) var fine: texture_2d<f32>;
@group(0) @binding(13) var level0: texture_2d<f32>;
@group(0) @binding(18) var<uniform> scales: array<vec4<u32>, MAX_SCALES>;
@group(0) @binding(19) var<uniform> taps: array<vec4<f32>, TAP_VECTORS>;
@group(0) @binding(20) var<uniform> fine_taps: array<vec4<f32>, FINE_TAP_VECTORS>;


// Scaled luminance L = key / Lbar * L_w (0 for black pixels), as prepare and apply need it.
fn scaled_luminance(p: vec4<f32>) -> f32 {
    let y = dot(max(p.rgb, vec3<f32>(0.0)), REC709);
    if y > 0.0 && stats.count > 0u {
        return exp(min(log(params.key) + log(y) + params.exposure_ev * LN2 - stats.mean_log, MAX_LOG));
    }
    return 0.0;
}

@compute @workgroup_size(256)
fn prepare(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = pixel_index(id, groups);
    if i >= params.width * params.band_rows {
        return;
    }
    let p = image[i];
    // Level 0's rows are out_stride cells apart (padded for the copy into a texture).
    let at = (i / params.width) * params.out_stride + i % params.width;
    if is_missing(p) {
        pyramid[at] = vec2<f32>(0.0);
    } else {
        pyramid[at] = vec2<f32>(scaled_luminance(p), 1.0);
    }
}

@compute @workgroup_size(256)
fn downsample(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = pixel_index(id, groups);
    if c >= params.grid_width * params.band_rows {
        return;
    }
    // The level above has ceil(width / (cell / 2)) x ceil(height / (cell / 2)) cells; its
    // window starts at row window_first.
    let half = params.cell / 2u;
    let sw = (params.width + half - 1u) / half;
    let sh = (params.height + half - 1u) / half;
    let x = 2u * (c % params.grid_width);
    let y = 2u * (params.band_first + c / params.grid_width);
    var acc = vec2<f32>(0.0);
    for (var dy = 0u; dy < 2u; dy = dy + 1u) {
        for (var dx = 0u; dx < 2u; dx = dx + 1u) {
            if x + dx < sw && y + dy < sh {
                acc = acc + 0.25 * blur_in[(y + dy - params.window_first) * params.in_stride + x + dx];
            }
        }
    }
    blur_out[c] = acc;
}

// Tap k of the pass's Gaussian (|k| <= radius).
fn tap(k: i32) -> f32 {
    let a = u32(abs(k));
    return taps[a / 4u][a % 4u];
}

fn blur_radius() -> i32 {
    return i32(min(params.radius, MAX_TAPS - 1u));
}

// Tap k of the pass's Gaussian, 0 beyond its radius r.
fn tap_within(k: i32, r: i32) -> f32 {
    return select(0.0, tap(k), abs(k) <= r);
}

// The taps of input offset d for the four outputs of a run (offsets 0..3 from its start).
fn run_taps(d: i32, r: i32) -> vec4<f32> {
    return vec4<f32>(tap_within(d, r), tap_within(d - 1, r), tap_within(d - 2, r), tap_within(d - 3, r));
}

// Each lane blurs a run of RUN consecutive cells (along x for blur_x and fine_x, along y for
// blur_y and the fine scales in apply), loading each input cell once for the whole run:
// RUN + 2r loads per RUN outputs instead of RUN (2r + 1). On Mesa's CPU rasterizers the loads
// are the blurs' dominant cost (a storage buffer at a per-lane index is read one lane at a
// time, a texture in vector code); the weights are the same for every lane (uniform loops, no
// per-lane bounds), and each output still sums its taps from -r to r in order. Two entry
// points rather than a branch on a uniform: Mesa's CPU rasterizers would run both.
const RUN: u32 = 8u;

// A run's sums: (L m) and m for its eight outputs.
struct RunSums {
    lm0: vec4<f32>,
    lm1: vec4<f32>,
    m0: vec4<f32>,
    m1: vec4<f32>,
}

// Output o (0..7) of a run: its (L m, m).
fn run_output(o: u32, sums: RunSums) -> vec2<f32> {
    if o < 4u {
        return vec2<f32>(sums.lm0[o], sums.m0[o]);
    }
    return vec2<f32>(sums.lm1[o - 4u], sums.m1[o - 4u]);
}

// Adds input value v to a run's sums with the weights w0 (outputs 0..3) and w1 (4..7).
fn add_weighted(sums: RunSums, w0: vec4<f32>, w1: vec4<f32>, v: vec2<f32>) -> RunSums {
    return RunSums(sums.lm0 + w0 * v.x, sums.lm1 + w1 * v.x, sums.m0 + w0 * v.y, sums.m1 + w1 * v.y);
}

// Adds input cell d of a run (offset d from its first output) to its sums, with the pass's taps.
fn add_to_run(sums: RunSums, d: i32, r: i32, v: vec2<f32>) -> RunSums {
    return add_weighted(sums, run_taps(d, r), run_taps(d - 4, r), v);
}

// Writes a row run's outputs that lie inside the grid (last = its last cell).
fn write_row_run(out_row: u32, x0: i32, last: i32, sums: RunSums) {
    for (var o = 0u; o < RUN; o = o + 1u) {
        if x0 + i32(o) <= last {
            blur_out[out_row + u32(x0) + o] = run_output(o, sums);
        }
    }
}

// The horizontal blur of a coarse scale, on its level k (blur_in).
@compute @workgroup_size(256)
fn blur_x(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let r = blur_radius();
    let runs = (params.grid_width + RUN - 1u) / RUN;
    let c = pixel_index(id, groups);
    if c >= runs * params.band_rows {
        return;
    }
    // Rows are independent. The input window starts at row window_first; the output row is
    // out_stride elements long, this scale's cells at dst_offset in it (the scale's own
    // buffer, from the band's first row).
    let x0 = i32((c % runs) * RUN);
    let band_row = c / runs;
    let row = (params.band_first + band_row - params.window_first) * params.grid_width;
    let last = i32(params.grid_width) - 1;
    var sums = RunSums(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var d = -r; d <= r + i32(RUN) - 1; d = d + 1) {
        let sx = x0 + d;
        // Cells outside the grid weigh 0.
        let v = select(vec2<f32>(0.0), blur_in[row + u32(clamp(sx, 0, last))], sx >= 0 && sx <= last);
        sums = add_to_run(sums, d, r, v);
    }
    write_row_run(band_row * params.out_stride + params.dst_offset, x0, last, sums);
}

// The horizontal blur of a fine scale for rows band_first .. band_first + band_rows of level
// 0, read from `level0` (a copy of those rows), into its plane (at dst_offset) of each
// out_stride-long row of the band's fine buffer.
@compute @workgroup_size(256)
fn fine_x(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let r = blur_radius();
    let runs = (params.width + RUN - 1u) / RUN;
    let c = pixel_index(id, groups);
    if c >= runs * params.band_rows {
        return;
    }
    let x0 = i32((c % runs) * RUN);
    let band_row = c / runs;
    let last = i32(params.width) - 1;
    var sums = RunSums(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var d = -r; d <= r + i32(RUN) - 1; d = d + 1) {
        let sx = x0 + d;
        let texel = textureLoad(level0, vec2<i32>(clamp(sx, 0, last), i32(band_row)), 0).xy;
        sums = add_to_run(sums, d, r, select(vec2<f32>(0.0), texel, sx >= 0 && sx <= last));
    }
    write_row_run(band_row * params.out_stride + params.dst_offset, x0, last, sums);
}

@compute @workgroup_size(256)
fn blur_y(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let r = blur_radius();
    let runs = (params.band_rows + RUN - 1u) / RUN;
    let c = pixel_index(id, groups);
    if c >= params.grid_width * runs {
        return;
    }
    // The input window starts at row window_first, at least the radius above the band (or
    // 0), and ends at least the radius below it (or at the last row); the rows a run's tail
    // would read beyond the window only feed outputs past the band, which are not written.
    let x = c % params.grid_width;
    let first = (c / params.grid_width) * RUN;
    let y0 = i32(params.band_first + first);
    let last = min(i32(params.grid_height), i32(params.window_first + arrayLength(&blur_in) / params.grid_width)) - 1;
    var sums = RunSums(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var d = -r; d <= r + i32(RUN) - 1; d = d + 1) {
        let sy = y0 + d;
        let inside = sy >= 0 && sy <= last;
        let v = blur_in[(u32(clamp(sy, i32(params.window_first), max(last, 0))) - params.window_first) * params.grid_width + x];
        sums = add_to_run(sums, d, r, select(vec2<f32>(0.0), v, inside));
    }
    for (var o = 0u; o < RUN; o = o + 1u) {
        if first + o < params.band_rows {
            blur_out[params.dst_offset + (first + o) * params.out_stride + x] = run_output(o, sums);
        }
    }
}

// The values of one scale at the RUN pixels of a column run (rows y0 .. y0 + 7).
struct Run {
    lo: vec4<f32>,
    hi: vec4<f32>,
}

// Tap k of fine scale i's Gaussian (its 16 taps at fine_taps[4 i ..]), 0 beyond its radius r.
fn fine_tap(i: u32, k: i32, r: i32) -> f32 {
    let a = min(u32(abs(k)), 15u);
    return select(0.0, fine_taps[4u * i + a / 4u][a % 4u], abs(k) <= r);
}

fn fine_taps4(i: u32, d: i32, r: i32) -> vec4<f32> {
    return vec4<f32>(fine_tap(i, d, r), fine_tap(i, d - 1, r), fine_tap(i, d - 2, r), fine_tap(i, d - 3, r));
}

// V of fine scale i (blurred on level 0) at the run's pixels: the vertical blur of its
// horizontal blur, which the band's `fine` buffer holds for rows window_first onwards (plane
// i of each row of fine_scales planes), loading each row once for the run.
fn fine_run(i: u32, x: u32, y0: i32) -> Run {
    let r = i32(scales[i].x);
    let planes = i32(params.fine_scales);
    let first = i32(params.window_first);
    // Rows past the band's halo feed only outputs past the band, which are not written.
    let last = min(i32(params.height), first + i32(textureDimensions(fine).y) / planes) - 1;
    var sums = RunSums(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var d = -r; d <= r + i32(RUN) - 1; d = d + 1) {
        let sy = y0 + d;
        let inside = sy >= 0 && sy <= last;
        let row = (clamp(sy, first, max(last, first)) - first) * planes + i32(i);
        let v = select(vec2<f32>(0.0), textureLoad(fine, vec2<i32>(i32(x), row), 0).xy, inside);
        sums = add_weighted(sums, fine_taps4(i, d, r), fine_taps4(i, d - 4, r), v);
    }
    let zero = vec4<f32>(0.0);
    return Run(select(zero, sums.lm0 / sums.m0, sums.m0 > zero), select(zero, sums.lm1 / sums.m1, sums.m1 > zero));
}

// V_i at pixel (x, y) for a scale blurred on a coarser level k, read bilinearly. Cell c's
// centre is at pixel (c + 0.5) 2^k - 0.5, clamped to the outermost centres, as cpu.rs
// `bilinear_on`.
fn coarse_value(i: u32, x: u32, y: u32) -> f32 {
    let entry = scales[i];
    let cell = 1u << entry.y;
    let gw = (params.width + cell - 1u) / cell;
    let gh = (params.height + cell - 1u) / cell;
    let u = clamp((f32(x) + 0.5) / f32(cell) - 0.5, 0.0, f32(gw - 1u));
    let w = clamp((f32(y) + 0.5) / f32(cell) - 0.5, 0.0, f32(gh - 1u));
    let x0 = floor(u);
    let y0 = floor(w);
    let x1 = min(u32(x0) + 1u, gw - 1u);
    let y1 = min(u32(y0) + 1u, gh - 1u);
    // Row c of level k is texture row entry.x + c - entry.w.
    let r0 = i32(entry.x + u32(y0) - entry.w);
    let r1 = i32(entry.x + y1 - entry.w);
    let c0 = i32(x0);
    let c1 = i32(x1);
    let top = mix(textureLoad(coarse, vec2<i32>(c0, r0), 0).xy, textureLoad(coarse, vec2<i32>(c1, r0), 0).xy, u - x0);
    let bottom = mix(textureLoad(coarse, vec2<i32>(c0, r1), 0).xy, textureLoad(coarse, vec2<i32>(c1, r1), 0).xy, u - x0);
    let v = mix(top, bottom, w - y0);
    return select(0.0, v.x / v.y, v.y > 0.0);
}

// V of coarse scale i at the run's pixels (rows past the band repeat its last row).
fn coarse_run(i: u32, x: u32, y0: u32, last: u32) -> Run {
    var lo = vec4<f32>(0.0);
    var hi = vec4<f32>(0.0);
    for (var o = 0u; o < 4u; o = o + 1u) {
        lo[o] = coarse_value(i, x, min(y0 + o, last));
        hi[o] = coarse_value(i, x, min(y0 + o + 4u, last));
    }
    return Run(lo, hi);
}

fn scale_run(i: u32, x: u32, y0: u32, last: u32) -> Run {
    if i < params.fine_scales {
        return fine_run(i, x, i32(y0));
    }
    return coarse_run(i, x, y0, last);
}

// The scale selection's state for a run: the previous scale's V, the chosen V, and whether a
// scale has failed, per pixel.
struct Selection {
    v1: Run,
    chosen: Run,
    done_lo: vec4<bool>,
    done_hi: vec4<bool>,
}

// One step of the scale selection: V_s (in `sel.v1`) against V_s+1 = v2.
fn select_step(sel: Selection, s: u32, v2: Run) -> Selection {
    let scale = bitcast<f32>(scales[s].z);
    let sharp = vec4<f32>(params.sharpness / (scale * scale));
    let eps = vec4<f32>(params.epsilon);
    let done_lo = sel.done_lo | (abs((sel.v1.lo - v2.lo) / (sharp + sel.v1.lo)) >= eps);
    let done_hi = sel.done_hi | (abs((sel.v1.hi - v2.hi) / (sharp + sel.v1.hi)) >= eps);
    let chosen = Run(select(sel.v1.lo, sel.chosen.lo, done_lo), select(sel.v1.hi, sel.chosen.hi, done_hi));
    return Selection(v2, chosen, done_lo, done_hi);
}

// L_d = L / (1 + V_chosen) for pixel i of the band.
fn write_pixel(i: u32, chosen: f32) {
    let p = image[i];
    if is_missing(p) {
        output[i] = vec4<f32>(0.0);
        return;
    }
    let l = scaled_luminance(p);
    let colour = max(p.rgb, vec3<f32>(0.0));
    let y_w = dot(colour, REC709);
    var rgb = compose(vec3<f32>(0.0), 1.0, 0.0);
    if y_w > 0.0 && l > 0.0 {
        rgb = compose(colour, y_w, l / (1.0 + chosen));
    }
    output[i] = vec4<f32>(rgb, clamp(p.a, 0.0, 1.0));
}

@compute @workgroup_size(256)
fn apply(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let runs = (params.band_rows + RUN - 1u) / RUN;
    let c = pixel_index(id, groups);
    if c >= params.width * runs {
        return;
    }
    let x = c % params.width;
    let first = (c / params.width) * RUN;
    let y0 = params.band_first + first;
    let last = params.band_first + params.band_rows - 1u;
    // Scales grow with their index, and so do their levels: the fine_scales on level 0 come
    // first. Two loops rather than a branch on the level, which Mesa's CPU rasterizers would
    // run both sides of. Every lane runs every scale (no per-pixel break), so the loops stay
    // uniform; a pixel's choice freezes at its first failing scale.
    let v0 = scale_run(0u, x, y0, last);
    var sel = Selection(v0, v0, vec4<bool>(false), vec4<bool>(false));
    for (var s = 1u; s < params.fine_scales; s = s + 1u) {
        sel = select_step(sel, s - 1u, fine_run(s, x, i32(y0)));
    }
    for (var s = max(params.fine_scales, 1u); s < params.levels; s = s + 1u) {
        sel = select_step(sel, s - 1u, coarse_run(s, x, y0, last));
    }
    for (var o = 0u; o < 4u; o = o + 1u) {
        if first + o < params.band_rows {
            write_pixel((first + o) * params.width + x, sel.chosen.lo[o]);
        }
        if first + o + 4u < params.band_rows {
            write_pixel((first + o + 4u) * params.width + x, sel.chosen.hi[o]);
        }
    }
}
