// HDR volume ray casting: one invocation per pixel, front-to-back emission–absorption
// compositing in f32 with premultiplied colour, optical depth accumulated (not transmittance
// multiplied), per-segment emission integrated exactly for a homogeneous segment, early ray
// termination when the optical depth passes a threshold.
#include "shared/optics.wgsl"
#include "shared/camera.wgsl"
#include "shared/march.wgsl"
#include "shared/volume_params.wgsl"

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
#if SKIPPING
// Empty-space skipping (src/render/skipping.rs): per octant of ray directions (stacked along
// z) and per cell of P.skip.x voxels, the edge d in cells of the largest cube of cells the
// transfer function leaves empty that has the cell at a corner and reaches into the octant
// (0: this cell is not empty), as bytes read as unorm (d / 255) through a nearest sampler.
@group(0) @binding(5) var skip_grid: texture_3d<f32>;
@group(0) @binding(6) var skip_sampler: sampler;
#endif

// Voxel counts of the whole volume: the texture's, or with SLAB the texture's x and y and the
// global z count (the texture holds this rank's slab and its ghost slices).
fn volume_dims() -> vec3<f32> {
#if SLAB
    return vec3<f32>(vec2<f32>(textureDimensions(volume_tex).xy), P.slab.w);
#else
    return vec3<f32>(textureDimensions(volume_tex));
#endif
}

fn sample_volume(uvw: vec3<f32>) -> f32 {
#if SLAB
    // Global texture coordinates, exact trilinear interpolation of the slab's slices: the ghost
    // slices hold the neighbours' voxels, and the clamps act only at the volume's own faces.
    let dims = vec3<i32>(textureDimensions(volume_tex));
    let g = uvw * volume_dims() - 0.5 - vec3<f32>(0.0, 0.0, P.slab.z);
    let g0 = floor(g);
    let f = g - g0;
    let top = dims - vec3<i32>(1);
    let a = clamp(vec3<i32>(g0), vec3<i32>(0), top);
    let b = clamp(vec3<i32>(g0) + vec3<i32>(1), vec3<i32>(0), top);
    return trilinear_texels(volume_tex, a, b, f);
#else
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
    return trilinear_texels(volume_tex, a, b, f);
#endif
#endif
}

#if SHADING
// Blinn–Phong factor at texture coordinate uvw under a headlight (light and eye along -dir, so
// the half vector is the light vector), two-sided; the normal is the gradient of the data value
// from central differences one voxel apart. Where the gradient vanishes or touches a missing
// value the sample keeps its unshaded emission (factor 1). Matches shading_factor in
// src/render/cpu_reference.rs.
fn shading_factor(uvw: vec3<f32>, dir: vec3<f32>) -> f32 {
    let dims = volume_dims();
    let h = 1.0 / dims;
    let spacing = P.box_size.xyz / dims;
    let gx = sample_volume(uvw + vec3<f32>(h.x, 0.0, 0.0)) - sample_volume(uvw - vec3<f32>(h.x, 0.0, 0.0));
    let gy = sample_volume(uvw + vec3<f32>(0.0, h.y, 0.0)) - sample_volume(uvw - vec3<f32>(0.0, h.y, 0.0));
    let gz = sample_volume(uvw + vec3<f32>(0.0, 0.0, h.z)) - sample_volume(uvw - vec3<f32>(0.0, 0.0, h.z));
    return headlight(vec3<f32>(gx, gy, gz) / (2.0 * spacing), dir);
}
#endif

// Segment k of the ray: sample at its midpoint, integrate emission and absorption over it.
fn march_step(s: ptr<function, RayState>, m: March, k: u32) {
    if ((*s).stopped || k >= m.steps) {
        return;
    }
    let tb = segment_end(m, k);
    let mid = 0.5 * ((*s).ta + tb);
    let len = (tb - (*s).ta) * m.voxels_per_unit;
    (*s).ta = tb;
    var ea = sample_work(m.uvw0 + m.duvw * mid);
#if SHADING
    if (any(ea.rgb > vec3<f32>(0.0))) {
        ea = vec4<f32>(ea.rgb * shading_factor(m.uvw0 + m.duvw * mid, m.dir), ea.a);
    }
#endif
    composite(s, ea, len, m.stop_tau);
}

#if PREINTEGRATED
#include "shared/preintegrate.wgsl"

// Segment k of a pre-integrated ray: sample at its back end, composite the transfer function's
// mean between the front and back values.
fn march_step_pre(s: ptr<function, RayState>, front: ptr<function, Front>, m: March, k: u32) {
    if ((*s).stopped || k >= m.steps) {
        return;
    }
    let tb = segment_end(m, k);
    let mid = 0.5 * ((*s).ta + tb);
    let len = (tb - (*s).ta) * m.voxels_per_unit;
    (*s).ta = tb;
    let back = front_at(sample_volume(m.uvw0 + m.duvw * tb));
    let piece = segment_between(*front, back, len);
    var ea = piece.ea;
#if SHADING
    if (any(ea.rgb > vec3<f32>(0.0))) {
        ea = vec4<f32>(ea.rgb * shading_factor(m.uvw0 + m.duvw * mid, m.dir), ea.a);
    }
#endif
    *front = back;
    composite(s, ea, piece.len, m.stop_tau);
}
#endif

// The fixed quantities of the interior segments 1..last (all but the first and the last few):
// texture coordinate of the midpoint of segment 0 (as if it had length ds), the step between
// midpoints, the length in voxels, the stopping depth, the unit ray direction, and the first
// segment past the interior (shared/march.wgsl interior_end).
struct Inner {
    uvw: vec3<f32>,
    step: vec3<f32>,
    len: f32,
    stop_tau: f32,
    dir: vec3<f32>,
    last: u32,
}

// Emission–absorption at uvw, or with WORK < 4 only the first parts of that work and a
// meaningless result that still depends on them (so the compiler keeps them). Missing values
// (NaN/Inf nearby) emit and absorb nothing; a select rather than a branch keeps the SIMD lanes of
// CPU rasterizers together.
fn sample_work(uvw: vec3<f32>) -> vec4<f32> {
    if (WORK == 0u) {
        return vec4<f32>(uvw.z * 1e-3);
    }
    return value_work(sample_volume(uvw));
}

// sample_work of a sample of value v.
fn value_work(v: f32) -> vec4<f32> {
    if (WORK == 1u || (WORK < 4u && TF_KIND == 1u)) {
        return vec4<f32>(abs(v) * 1e-3);
    }
    let finite = is_finite_f32(v);
    if (WORK == 2u) {
        return select(vec4<f32>(0.0), vec4<f32>(scaled(v) * 1e-3), finite);
    }
    if (WORK == 3u) {
        let x = scaled(v) * P.scale.w;
        let t = x - f32(min(i32(x), i32(P.scale.w) - 1));
        return select(vec4<f32>(0.0), vec4<f32>(t, 0.5 * t, 0.25 * t, 1e-3 * t), finite);
    }
    return select(vec4<f32>(0.0), transfer(v), finite);
}

// Interior segment k: march_step without the clamp at the exit and the carried end point.
fn inner_step(s: ptr<function, RayState>, c: Inner, k: u32) {
    if ((*s).stopped) {
        return;
    }
    let uvw = c.uvw + c.step * f32(k);
    var ea = sample_work(uvw);
#if SHADING
    if (any(ea.rgb > vec3<f32>(0.0))) {
        ea = vec4<f32>(ea.rgb * shading_factor(uvw, c.dir), ea.a);
    }
#endif
    composite(s, ea, c.len, c.stop_tau);
}

// Adds the block's sums to the ray's totals and empties it.
fn join_block(s: ptr<function, RayState>, block: ptr<function, RayState>) {
    (*s).color += (*block).color;
    (*s).tau += (*block).tau;
    (*block).color = vec3<f32>(0.0);
    (*block).tau = 0.0;
}

#if SKIPPING
// Segment k's emission–absorption (at its midpoint, shaded with SHADING) and its length in
// voxels. An interior segment (1 <= k < c.last) samples on the arithmetic sequence of midpoints
// and has length ds; the first (from the box entry, its length perhaps jittered) and the last
// ones (the very last cut at the exit) sample between their ends (segment_end). The bricked ray
// caster places its samples the same way.
struct Lit {
    ea: vec4<f32>,
    len: f32,
    // The sample's value (NaN with WORK 0, which reads none).
    v: f32,
}

fn lit_segment(m: March, c: Inner, k: u32) -> Lit {
    let interior = k >= 1u && k < c.last;
    let ta = select(segment_end(m, k - 1u), m.t_enter, k == 0u);
    let tb = segment_end(m, k);
    let uvw = select(m.uvw0 + m.duvw * (0.5 * (ta + tb)), c.uvw + c.step * f32(k), interior);
    var v = bitcast<f32>(0x7fc00000u);
    var ea = vec4<f32>(uvw.z * 1e-3);
    if (WORK > 0u) {
        v = sample_volume(uvw);
        ea = value_work(v);
    }
#if SHADING
    if (any(ea.rgb > vec3<f32>(0.0))) {
        ea = vec4<f32>(ea.rgb * shading_factor(uvw, c.dir), ea.a);
    }
#endif
    return Lit(ea, select((tb - ta) * m.voxels_per_unit, c.len, interior), v);
}

// The segment the march takes after sampling segment k at value v: k + 1, or further past the
// interior segments that the gradient skip (GradientSkip in src/render/skipping.rs) proves
// transparent. v lies `margin` inside a transparent range at the bottom or the top of the
// data's values; each interior segment changes the value by at most 1 / r.inv_change, so the
// next n samples with n / r.inv_change <= margin stay in that range and composite exactly nothing. Only
// from an interior segment over interior ones: their samples lie on the arithmetic sequence, so
// their distance is exactly n steps.
fn next_segment(r: SkipRay, last: u32, k: u32, v: f32) -> u32 {
    // Without it each sample's position waits for no other's value.
    if (!GRADIENT_SKIP) {
        return k + 1u;
    }
    let margin = max(P.skip.y - v, v - P.skip.z) - P.skip.w;
    let room = select(0u, last - 1u - k, k >= 1u && k + 1u < last);
    let n = select(0.0, floor(margin * r.inv_change), margin > 0.0);
    return k + 1u + u32(min(n, f32(room)));
}

// Segment k composited onto the ray's totals, as u8, f16 and compensated sums add every
// segment; nothing once the ray stopped or at and past `end`. Returns the next segment to take.
fn segment_step(s: ptr<function, RayState>, m: March, c: Inner, r: SkipRay, k: u32, end: u32) -> u32 {
    if ((*s).stopped || k >= end) {
        return k + 1u;
    }
    let lit = lit_segment(m, c, k);
    composite(s, lit.ea, lit.len, c.stop_tau);
    return next_segment(r, c.last, k, lit.v);
}

// Segment k in f32 (PRECISION 0). An interior segment is summed in its block of 64 segments
// (sum_block), which joins the ray's totals when the next block begins: a 64th of the additions
// to the large running sums, so about a 64th of their rounding drift on long rays of nearly
// equal contributions. The first and the last few segments join the totals at once (a block
// of their own). The blocks are those of the segment index, so a march that jumps over empty
// segments, and may start a group of UNROLL anywhere, sums exactly as the march without jumps.
// Returns the next segment to take.
fn blocked_step(s: ptr<function, RayState>, block: ptr<function, RayState>, block_index: ptr<function, u32>, m: March, c: Inner, r: SkipRay, k: u32, end: u32) -> u32 {
    if ((*s).stopped || k >= end) {
        return k + 1u;
    }
    let interior = k >= 1u && k < c.last;
    let b = select(0x80000000u + k, sum_block(k), interior);
    if (b != *block_index) {
        join_block(s, block);
        *block_index = b;
    }
    let lit = lit_segment(m, c, k);
    // The block stops where the ray would: its depth is counted from the totals'.
    composite(block, lit.ea, lit.len, c.stop_tau - (*s).tau);
    (*s).transmittance = (*block).transmittance;
    (*s).stopped = (*block).stopped;
    if (!interior) {
        join_block(s, block);
        (*s).stopped = (*s).tau > c.stop_tau;
        (*block).stopped = (*s).stopped;
    }
    return next_segment(r, c.last, k, lit.v);
}

// The edge in cells of the empty cube reaching from the cell holding q (skip-grid cell
// coordinates) into the ray's octant: 0 where that cell is not empty.
fn empty_extent(r: SkipRay, cell: vec3<i32>) -> f32 {
    return round(255.0 * textureSampleLevel(skip_grid, skip_sampler, (vec3<f32>(cell + vec3<i32>(0, 0, r.layer)) + 0.5) * r.inv_cells, 0.0).r);
}

fn cell_of(r: SkipRay, q: vec3<f32>) -> vec3<i32> {
    return clamp(vec3<i32>(floor(q)), vec3<i32>(0), r.top);
}

// Where the march goes on from interior segment k: past every segment whose midpoint lies in
// the empty cube of cells ahead of k's cell, at most to `last` (any other k stays). Skipped segments would have
// composited exactly nothing: their samples interpolate voxels of empty cells only (each cell's
// range covers its one-voxel apron). Not empty, or the cube ends before the next segment: k
// itself. The march goes on from the segment it lands on, not from the start of that segment's
// group of UNROLL, so a ray meets a wall with no samples spent in front of it.
fn skip_empty(r: SkipRay, k: u32, last: u32) -> u32 {
    let q = r.q0 + r.dq * f32(k);
    let cell = cell_of(r, q);
    let d = empty_extent(r, cell);
    let c = vec3<f32>(cell);
    let exits = (select(c - (d - 1.0), c + d, r.up) - q) * r.inv_dq;
    let t = min(exits.x, min(exits.y, exits.z));
    // Only interior segments jump (their midpoints are the sequence the cells are found on).
    let room = select(0u, last - k, k >= 1u && k < last);
    return k + u32(clamp(floor(t), 0.0, f32(room)));
}

// A ray's interior segments in skip-grid cells: the midpoint of segment k lies at q0 + dq k;
// inv_dq is 1 / dq, or huge along an axis the ray does not move on (whose exit then never comes
// first); `up` picks the cube's upper face as the exit; `top` is the last cell, `layer` the
// first z of the ray's octant in the grid and inv_cells the grid's texel size; inv_change is
// 1 / the most an interior segment can change the value (next_segment). Found once per ray, so
// each lookup (on the samples' critical path: their position waits for it) multiplies where it
// divided.
struct SkipRay {
    q0: vec3<f32>,
    dq: vec3<f32>,
    inv_dq: vec3<f32>,
    up: vec3<bool>,
    top: vec3<i32>,
    layer: i32,
    inv_cells: vec3<f32>,
    inv_change: f32,
}

// Skip-grid cells per unit of texture coordinate, along each axis.
fn cells_per_uvw() -> vec3<f32> {
    return vec3<f32>(textureDimensions(volume_tex)) / P.skip.x;
}

fn skip_ray(c: Inner) -> SkipRay {
    let to_cells = cells_per_uvw();
    let dq = c.step * to_cells;
    let moves = abs(dq) > vec3<f32>(1e-30);
    let inv_dq = select(vec3<f32>(3.0e38), 1.0 / dq, moves);
    let up = select(vec3<bool>(true), dq >= vec3<f32>(0.0), moves);
    let cells = vec3<i32>(textureDimensions(skip_grid)) / vec3<i32>(1, 1, 8);
    let octant = select(1, 0, up.x) + select(2, 0, up.y) + select(4, 0, up.z);
    let change = dot(P.gradient.xyz, abs(c.step * vec3<f32>(textureDimensions(volume_tex))));
    return SkipRay(c.uvw * to_cells, dq, inv_dq, up, cells - vec3<i32>(1), octant * cells.z, 1.0 / vec3<f32>(textureDimensions(skip_grid)), 1.0 / max(change, 1e-30));
}

// The ray's parameter interval within one slab of the hull: between the planes where its
// projection on n is lh.x and lh.y (a ray parallel to them gets a huge interval, or an empty
// one outside them).
fn hull_slab(t: vec2<f32>, o: vec3<f32>, d: vec3<f32>, n: vec3<f32>, lh: vec2<f32>) -> vec2<f32> {
    let po = dot(o, n);
    let pd = dot(d, n);
    let inv = 1.0 / select(pd, 1e-30, abs(pd) < 1e-30);
    let a = (lh.x - po) * inv;
    let b = (lh.y - po) * inv;
    return vec2<f32>(max(t.x, min(a, b)), min(t.y, max(a, b)));
}

// Where the ray uvw0 + duvw t lies in the hull of the cells that are not empty (empty when
// x > y): outside it every sample is in an empty cell.
fn hull_span(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    var t = vec2<f32>(-3.0e38, 3.0e38);
    t = hull_slab(t, o, d, vec3<f32>(1.0, 0.0, 0.0), P.hull[0].xy);
    t = hull_slab(t, o, d, vec3<f32>(0.0, 1.0, 0.0), P.hull[0].zw);
    t = hull_slab(t, o, d, vec3<f32>(0.0, 0.0, 1.0), P.hull[1].xy);
    t = hull_slab(t, o, d, vec3<f32>(1.0, 1.0, 0.0), P.hull[1].zw);
    t = hull_slab(t, o, d, vec3<f32>(1.0, -1.0, 0.0), P.hull[2].xy);
    t = hull_slab(t, o, d, vec3<f32>(1.0, 0.0, 1.0), P.hull[2].zw);
    t = hull_slab(t, o, d, vec3<f32>(1.0, 0.0, -1.0), P.hull[3].xy);
    t = hull_slab(t, o, d, vec3<f32>(0.0, 1.0, 1.0), P.hull[3].zw);
    t = hull_slab(t, o, d, vec3<f32>(0.0, 1.0, -1.0), P.hull[4].xy);
    t = hull_slab(t, o, d, vec3<f32>(1.0, 1.0, 1.0), P.hull[4].zw);
    t = hull_slab(t, o, d, vec3<f32>(1.0, 1.0, -1.0), P.hull[5].xy);
    t = hull_slab(t, o, d, vec3<f32>(1.0, -1.0, 1.0), P.hull[5].zw);
    t = hull_slab(t, o, d, vec3<f32>(1.0, -1.0, -1.0), P.hull[6].xy);
    return t;
}
#endif

#if SLAB
// The segments of a ray this rank composites: those whose midpoints lie in its slab's z range
// [P.slab.x, P.slab.y), the samples where the whole volume's march puts them (the same first
// segment and step from the global box entry, the same positions to the last bit), every
// segment its full length, no early termination (what lies in front is another rank's).
// Returns premultiplied colour and optical depth, the depth's sign bit set when the ray runs
// towards -z (compositing order).
fn march_slab(m: March, origin_z: f32, dir_z: f32) -> RayState {
    var s = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, m.t_enter, false);
    // The candidate segments from where the ray crosses the slab's planes, widened by two on
    // each side; the midpoint test below decides, the same on every rank.
    var k_lo = 0.0;
    var k_hi = f32(m.steps) - 1.0;
    if (abs(dir_z) > 0.0) {
        let ta = (P.slab.x - origin_z) / dir_z;
        let tb = (P.slab.y - origin_z) / dir_z;
        let t0 = clamp(min(ta, tb), m.t_enter, m.t_exit);
        let t1 = clamp(max(ta, tb), m.t_enter, m.t_exit);
        k_lo = max(floor((t0 - m.t_enter - m.first) / m.ds) - 2.0, 0.0);
        k_hi = min(ceil((t1 - m.t_enter - m.first) / m.ds) + 2.0, k_hi);
    }
    for (var k = u32(k_lo); f32(k) <= k_hi; k += 1u) {
        let ta = select(segment_end(m, k - 1u), m.t_enter, k == 0u);
        let tb = segment_end(m, k);
        let mid = 0.5 * (ta + tb);
        let z = origin_z + dir_z * mid;
        if (z >= P.slab.x && z < P.slab.y) {
            // The single process's positions and lengths (shared/march.wgsl interior_end).
            let interior = k >= 1u && k < interior_end(m.steps);
            let uvw = select(m.uvw0 + m.duvw * mid, interior_origin(m) + (m.duvw * m.ds) * f32(k), interior);
            var ea = sample_work(uvw);
#if SHADING
            if (any(ea.rgb > vec3<f32>(0.0))) {
                ea = vec4<f32>(ea.rgb * shading_factor(uvw, m.dir), ea.a);
            }
#endif
            let len = select((tb - ta) * m.voxels_per_unit, m.ds * m.voxels_per_unit, interior);
            composite(&s, ea, len, 3.0e38);
        }
    }
    return s;
}
#endif

#if SKIPPING
// The march with empty-space skipping: one loop takes every segment, UNROLL at a time, jumping
// over empty ones. lavapipe runs each loop's body at least once, with all lanes masked off if
// none enters, so a loop of its own for the first or the last segments would cost a sample of
// every ray that needs none there (most of them, here).
fn march_skipping(m: March) -> RayState {
    var s = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, m.t_enter, false);
    // Only segments in the hull can composite anything: the march begins at the segment
    // before the hull's entry and ends after the one after its exit.
    let span = hull_span(m.uvw0, m.duvw);
    let k_in = max(u32(clamp(floor((span.x - m.t_enter - m.first) / m.ds), 0.0, f32(m.steps))), 1u);
    let k_out = u32(clamp(floor((span.y - m.t_enter - m.first) / m.ds) + 3.0, 1.0, f32(m.steps)));
    let end = select(0u, k_out, span.x <= span.y);
    // Segments last.. sample between their ends, as in the march without skipping (and the
    // bricked ray caster), so every sample lies where theirs do to the last bit.
    let last = interior_end(m.steps);
    let inner = Inner(interior_origin(m), m.duvw * m.ds, m.ds * m.voxels_per_unit, m.stop_tau, m.dir, last);
    let sr = skip_ray(inner);
    // The first segment only where its sample is not in an empty cell (elsewhere it would
    // composite nothing); else the march starts at the hull.
    let first_uvw = m.uvw0 + m.duvw * (0.5 * (m.t_enter + segment_end(m, 0u)));
    let first_empty = empty_extent(sr, cell_of(sr, first_uvw * cells_per_uvw())) > 0.0;
    var k = select(0u, k_in, first_empty);
    var block = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, m.t_enter, false);
    var block_index = 0u;
    loop {
        if (k >= end || s.stopped) {
            break;
        }
        // Jump from empty block to empty block until the next segment is not empty: a loop
        // of lookups only, which runs as long as one of its lanes still jumps.
        loop {
            let next = skip_empty(sr, k, last);
            if (next == k) {
                break;
            }
            k = next;
        }
        // SAMPLES_PER_PASS samples (march_plan in src/render/volume/mod.rs), each followed by
        // the segments it proves transparent.
        if (PRECISION == 0u) {
            k = blocked_step(&s, &block, &block_index, m, inner, sr, k, end);
            if (SAMPLES_PER_PASS >= 2u) {
                k = blocked_step(&s, &block, &block_index, m, inner, sr, k, end);
            }
            if (SAMPLES_PER_PASS >= 4u) {
                k = blocked_step(&s, &block, &block_index, m, inner, sr, k, end);
                k = blocked_step(&s, &block, &block_index, m, inner, sr, k, end);
            }
        } else {
            k = segment_step(&s, m, inner, sr, k, end);
            if (SAMPLES_PER_PASS >= 2u) {
                k = segment_step(&s, m, inner, sr, k, end);
            }
            if (SAMPLES_PER_PASS >= 4u) {
                k = segment_step(&s, m, inner, sr, k, end);
                k = segment_step(&s, m, inner, sr, k, end);
            }
        }
        // Leave as the last lane finishes, not after a masked pass more.
        continuing {
            break if k >= end || s.stopped;
        }
    }
    if (PRECISION == 0u) {
        join_block(&s, &block);
    }
    return s;
}
#else
// The march without skipping: the first segment (its length may be jittered) and the last ones
// (cut at the exit) through march_step; the segments between all have length ds, so their
// midpoints form an arithmetic sequence and need no clamping or carried end point. Every ray
// takes the first and the last segments, so their own code costs nothing masked; the interior
// loop's simple positions keep the per-sample work at its least.
fn march_plain(m: March) -> RayState {
    var s = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, m.t_enter, false);
    march_step(&s, m, 0u);
    let last = interior_end(m.steps);
    let inner = Inner(interior_origin(m), m.duvw * m.ds, m.ds * m.voxels_per_unit, m.stop_tau, m.dir, last);
    // f32 sums the interior segments in blocks of 64 (16 iterations) that join the ray's
    // totals together: a 64th of the additions to the large running sums, so about a 64th of
    // their rounding drift on long rays of nearly equal contributions. The other precisions
    // add each segment to the totals, as the arithmetic they emulate does.
    var block = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, s.transmittance, s.ta, false);
    var block_index = 0u;
    var k = 1u;
    while (k < last && !s.stopped) {
        if (PRECISION == 0u) {
            let b = sum_block(k);
            if (b != block_index) {
                join_block(&s, &block);
                block_index = b;
            }
            // The block stops where the ray would: its depth is counted from the totals'.
            let rest = Inner(inner.uvw, inner.step, inner.len, inner.stop_tau - s.tau, inner.dir, last);
            inner_step(&block, rest, k);
            inner_step(&block, rest, k + 1u);
            inner_step(&block, rest, k + 2u);
            inner_step(&block, rest, k + 3u);
            s.transmittance = block.transmittance;
            s.stopped = block.stopped;
        } else {
            inner_step(&s, inner, k);
            inner_step(&s, inner, k + 1u);
            inner_step(&s, inner, k + 2u);
            inner_step(&s, inner, k + 3u);
        }
        k += UNROLL;
    }
    if (PRECISION == 0u) {
        join_block(&s, &block);
    }
    // At most three interior segments and the last one remain, in a loop rather than four
    // calls: a group of rays that all stopped takes no samples here beyond the loop's one
    // masked pass.
    s.ta = segment_end(m, last - 1u);
    for (var i = 0u; i < UNROLL; i += 1u) {
        if (s.stopped) {
            break;
        }
        march_step(&s, m, last + i);
    }
    return s;
}
#endif

// UNROLL (shared/march.wgsl) steps per loop iteration. llvmpipe ends any loop after 65535
// iterations, so a ray can take at most 4 * 65535 steps (src/render/volume/params.rs refuses renders
// that would need more).

// One invocation per pixel, in 8 x 8 tiles (shared/camera.wgsl tile_pixel).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) tile: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let gid = tile_pixel(tile, l);
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
#if SLAB
    var partial = vec4<f32>(0.0);
    if (t_exit > t_enter) {
        let ds = P.march.x;
        let first = first_segment(gid.xy, w, h, ds);
        let n = segment_count(t_exit - t_enter, first, ds);
        let inv_size = 1.0 / size;
        let m = March(t_enter, t_exit, first, ds, P.march.y, P.march.z, n, ray.origin * inv_size, ray.dir * inv_size, ray.dir);
        let s = march_slab(m, ray.origin.z, ray.dir.z);
        partial = vec4<f32>(s.color, s.tau);
    }
    let sign = select(0u, 0x80000000u, ray.dir.z < 0.0);
    partial.w = bitcast<f32>(bitcast<u32>(partial.w) | sign);
    textureStore(out_image, vec2<i32>(gid.xy), partial);
#else
    var s = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, t_enter, false);
    if (t_exit > t_enter) {
        let ds = P.march.x;
        let first = first_segment(gid.xy, w, h, ds);
        let n = segment_count(t_exit - t_enter, first, ds);
        let inv_size = 1.0 / size;
        let m = March(t_enter, t_exit, first, ds, P.march.y, P.march.z, n, ray.origin * inv_size, ray.dir * inv_size, ray.dir);
#if PREINTEGRATED
        var front = front_at(sample_volume(m.uvw0 + m.duvw * t_enter));
        for (var k = 0u; k < n; k += UNROLL) {
            march_step_pre(&s, &front, m, k);
            march_step_pre(&s, &front, m, k + 1u);
            march_step_pre(&s, &front, m, k + 2u);
            march_step_pre(&s, &front, m, k + 3u);
            if (s.stopped) {
                break;
            }
        }
#else
#if SKIPPING
        s = march_skipping(m);
#else
        s = march_plain(m);
#endif
#endif
    }
    textureStore(out_image, vec2<i32>(gid.xy), ray_pixel(s));
#endif
}
