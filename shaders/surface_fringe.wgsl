// Interference surfaces, step 2 (the fringe pass): I = (1 + cos 2πν·d)/2 per pixel from the data
// pass's targets, with a colour lookup: cyclic (colour from the wrapped phase frac(ν·d), one cycle
// of a cyclic map per fringe), modulated (colour over the data range, optionally log-scaled, times
// the fringes) or direct (colour only). The phase keeps f64 precision: d − d_ref arrives as
// hi + rest (two f32s), ν as three f32 parts; hi and ν's leading parts have 12 significant bits
// (hi is split here by masking mantissa bits), so their products are exact in f32 and their
// fractions are taken before anything is added; frac(ν·d_ref) comes from the host in f64.
// Antialiasing: the fringe averaged over the pixel's footprint, a Gaussian of σ = 0.5 pixel along
// the data's gradient, is (1 + cos 2πν·d · exp(−2π²ν²σ²|∇d|²))/2 for a field linear across the
// footprint; ∇d (data units per pixel) comes from central differences of the neighbouring
// pixels (one-sided beside a missing pixel), so it is the screen-space derivative in 3-D views.
// Keep Params in sync with src/render/surface/params.rs (FringeParams).

struct Params {
    // ν split: x (12 bits) + y (12 bits) + z (rest) = ν; w = f32(ν)
    nu: vec4<f32>,
    // x: frac(ν·d_ref) from f64; y: f32(d_ref); z: colour lower bound (linear: minus d_ref; log:
    // log10 of the floor); w: 1 / colour range
    refs: vec4<f32>,
    // x: modulation depth, y: floor of |d| for log colour
    shade: vec4<f32>,
    // x: property slot (also the SLOT constant), y: mode (0 cyclic, 1 modulated, 2 direct), z: absolute, w: log colour
    mode: vec4<u32>,
    // x: width, y: height, z: LUT size
    dims: vec4<u32>,
    // xyz: the cyclic map's mean colour (what fringes above the pixel rate fade to in cyclic
    // mode); w: ν·σ with σ = 0.5 pixel, the footprint's width in fringes per data-unit-per-pixel
    footprint: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
// Storage buffers, pixels row-major from the top (plain loads and stores are fast on CPU
// rasterizers). The property slot is a pipeline constant, so no vector is indexed dynamically.
@group(0) @binding(1) var<storage, read> data_hi: array<f32>;
@group(0) @binding(2) var<storage, read> data_rest: array<f32>;
@group(0) @binding(3) var<storage, read> data_mask: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read> lut: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> out_color: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> out_value: array<f32>;
@group(0) @binding(7) var<storage, read_write> out_filtered: array<f32>;

override SLOT: u32 = 0u;
// The colour mode (0 cyclic, 1 modulated, 2 direct), `absolute`, `log_color`, and whether the
// value plane is written (not when the host already holds it from an earlier pass) are
// pipeline constants too: Mesa's CPU rasterizers run both sides of branches on uniforms.
override MODE: u32 = 0u;
override ABSOLUTE: bool = false;
override LOG_COLOR: bool = false;
override WRITE_VALUE: bool = true;
// The naive phase (src/render/surface/options.rs `PhaseMethod::Naive`): d as one f32 and cos(2π·ν·d)
// evaluated directly, as a straightforward implementation would; only for measuring what the
// reduction buys.
override NAIVE_PHASE: bool = false;
// Whether the colour uses the footprint-filtered fringe (`antialias`, on by default); the
// filtered fringe is written either way.
override ANTIALIAS: bool = true;

const TAU: f32 = 6.283185307179586;

fn fr(x: f32) -> f32 {
    return x - floor(x);
}

// The leading 12 significant bits of x (the low 12 of the 23 mantissa bits cleared).
fn lead12(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) & 0xFFFFF000u);
}

// frac(ν·(d_ref + hi + rest)) in [0, 1).
fn phase(hi: f32, rest: f32) -> f32 {
    let h1 = lead12(hi);
    let h2 = hi - h1;
    let nu = params.nu;
    let small = nu.y * h2 + nu.z * hi + nu.w * rest;
    return fr(fr(nu.x * h1) + fr(nu.x * h2) + fr(nu.y * h1) + fr(small) + params.refs.x);
}

fn colormap(t: f32) -> vec3<f32> {
    let n = params.dims.z;
    let x = clamp(t, 0.0, 1.0) * f32(n - 1u);
    let i = min(u32(x), n - 2u);
    let f = x - f32(i);
    let a = lut[i].xyz;
    let b = lut[i + 1u].xyz;
    return mix(a, b, f);
}

// d − d_ref at pixel `px` of this slot's plane.
fn offset_at(px: u32) -> f32 {
    let plane = SLOT * params.dims.x * params.dims.y + px;
    return data_hi[plane] + data_rest[plane];
}

fn valid_at(px: u32) -> bool {
    return (u32(data_mask[px].x) & (1u << SLOT)) != 0u;
}

// The derivative of d along one image axis at pixel `px` (data units per pixel): the central
// difference of the neighbours `before` and `after`, one-sided where one of them is missing or
// off the image (`has_*` false; the index is then `px` itself, so no load leaves the buffers),
// 0 where both are.
fn derivative(px: u32, centre: f32, before: u32, has_before: bool, after: u32, has_after: bool) -> f32 {
    let b = has_before && valid_at(before);
    let a = has_after && valid_at(after);
    let db = centre - offset_at(before);
    let da = offset_at(after) - centre;
    if (a && b) {
        return 0.5 * (da + db);
    }
    return select(0.0, da, a) + select(0.0, db, b);
}

// exp(−2π²ν²σ²|∇d|²): how much of the fringe's contrast survives the pixel's footprint.
fn footprint_contrast(gid: vec2<u32>, px: u32, centre: f32) -> f32 {
    let w = params.dims.x;
    let left = gid.x > 0u;
    let right = gid.x + 1u < w;
    let up = gid.y > 0u;
    let down = gid.y + 1u < params.dims.y;
    let gx = derivative(px, centre, select(px, px - 1u, left), left, select(px, px + 1u, right), right);
    let gy = derivative(px, centre, select(px, px - w, up), up, select(px, px + w, down), down);
    let s = params.footprint.w * length(vec2<f32>(gx, gy));
    return exp(-2.0 * 9.869604401089358 * s * s);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.dims.x || gid.y >= params.dims.y) {
        return;
    }
    let px = gid.y * params.dims.x + gid.x;
    let slot = SLOT;
    let m = data_mask[px];
    let bits = u32(m.x);
    if ((bits & (1u << slot)) == 0u) {
        // Missing (a hole or no surface): fringe −1 tells the host, red the surface's shading
        // there (−1: no surface, the background), for the host's missing colour.
        out_color[px] = vec4<f32>(m.y, 0.0, 0.0, -1.0);
        if (WRITE_VALUE) {
            out_value[px] = 0.0;
        }
        out_filtered[px] = 0.0;
        return;
    }
    let plane = slot * params.dims.x * params.dims.y + px;
    let hi = data_hi[plane];
    let rest = data_rest[plane];
    let d = params.refs.y + (hi + rest);
    var ph: f32;
    var fringe: f32;
    if (NAIVE_PHASE) {
        let arg = TAU * params.nu.w * d;
        ph = fr(params.nu.w * d);
        if (ABSOLUTE && d < 0.0) {
            ph = fr(1.0 - ph);
        }
        fringe = 0.5 + 0.5 * cos(arg);
    } else {
        ph = phase(hi, rest);
        if (ABSOLUTE && d < 0.0) {
            ph = fr(1.0 - ph);
        }
        // cos of an argument in [−π, π] for the best f32 accuracy.
        let centred = ph - round(ph);
        fringe = 0.5 + 0.5 * cos(TAU * centred);
    }
    let contrast = footprint_contrast(gid.xy, px, hi + rest);
    let filtered = 0.5 + (fringe - 0.5) * contrast;
    var shown = fringe;
    if (ANTIALIAS) {
        shown = filtered;
    }
    var colour: vec3<f32>;
    var t: f32;
    if (MODE == 0u) {
        t = ph;
    } else if (LOG_COLOR) {
        let a = max(abs(d), params.shade.y);
        t = (log(a) * 0.4342944819032518 - params.refs.z) * params.refs.w;
    } else if (ABSOLUTE) {
        t = (abs(d) - params.refs.z) * params.refs.w;
    } else {
        t = ((hi + rest) - params.refs.z) * params.refs.w;
    }
    colour = colormap(t);
    if (MODE == 0u && ANTIALIAS) {
        // The phase's colour cycle fades to the map's mean as the fringes do.
        colour = params.footprint.xyz + (colour - params.footprint.xyz) * contrast;
    }
    if (MODE != 2u) {
        let depth = params.shade.x;
        colour *= (1.0 - depth) + depth * shown;
    }
    colour *= m.y;
    out_color[px] = vec4<f32>(colour, fringe);
    out_filtered[px] = filtered;
    if (WRITE_VALUE) {
        out_value[px] = d;
    }
}
