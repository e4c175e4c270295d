// The f64 ray caster: the same rays, segments, trilinear sampling, transfer table and
// emission–absorption integral as the f64 CPU reference (src/render/cpu_reference.rs), in double
// precision on adapters with shader f64 (lavapipe has it). SPIR-V's GLSL.std.450 offers exp and
// log only for 16- and 32-bit floats, so both are computed here from ldexp/frexp, which take f64.
// An accuracy path, not a fast one: flags are uniforms, not pipeline constants.
// Keep Params64 in sync with src/render/volume_f64.rs.

struct Params64 {
    eye: vec4<f64>,
    forward: vec4<f64>,
    right: vec4<f64>,
    up: vec4<f64>,
    // x: 1 for perspective; y, z: tan of the half angles (perspective) or half extents
    proj: vec4<f64>,
    box_size: vec4<f64>,
    background: vec4<f64>,
    // x: scaled lower bound, y: 1 / scaled range, z: symlog threshold, w: table size - 1
    scale: vec4<f64>,
    lens: vec4<f64>,
    // emission–absorption: x = e, y = a
    tf: vec4<f64>,
    // x: step in world units, y: world length of one voxel, z: optical depth at which rays stop
    march: vec4<f64>,
    // x: width, y: height, z: jitter seed, w: jitter on
    image: vec4<u32>,
    // x: 0 table, 1 emission–absorption; y: 0 linear, 1 log10, 2 symlog; z: lens on
    flags: vec4<u32>,
    // A box cut-away (model::cut::Cut's x, y, z) in the box's frame; w 1 when there is one.
    cut_lo: vec4<f64>,
    cut_hi: vec4<f64>,
    // Its planes (Cut::planes_in_frame): the removed half-space n·p >= c as (n, c); unused
    // slots (0, 0, 0, -1) hold everywhere.
    cut_planes: array<vec4<f64>, 3>,
}

@group(0) @binding(0) var<uniform> P: Params64;
@group(0) @binding(1) var volume_tex: texture_3d<f32>;
@group(0) @binding(2) var<storage, read> lut: array<vec4<f64>>;
// Row-major RGBA in f64, so the result can be compared with the CPU reference unrounded.
@group(0) @binding(3) var<storage, read_write> out_image: array<vec4<f64>>;

const LN2_HI: f64 = 0.6931471803691238lf;
const LN2_LO: f64 = 1.9082149292705877e-10lf;
const LOG2E: f64 = 1.4426950408889634lf;
const LN2: f64 = 0.6931471805599453lf;
const LN10: f64 = 2.302585092994046lf;

// exp(x) in f64: x = k ln2 + r with |r| <= ln2/2, a degree-13 Taylor polynomial for exp(r)
// (truncation below 1e-17 relative), then the exponent added with ldexp.
fn exp64(x: f64) -> f64 {
    if (x < -746.0lf) {
        return 0.0lf;
    }
    let k = floor(x * LOG2E + 0.5lf);
    let r = (x - k * LN2_HI) - k * LN2_LO;
    var p = 1.0lf / 6227020800.0lf;
    p = fma(p, r, 1.0lf / 479001600.0lf);
    p = fma(p, r, 1.0lf / 39916800.0lf);
    p = fma(p, r, 1.0lf / 3628800.0lf);
    p = fma(p, r, 1.0lf / 362880.0lf);
    p = fma(p, r, 1.0lf / 40320.0lf);
    p = fma(p, r, 1.0lf / 5040.0lf);
    p = fma(p, r, 1.0lf / 720.0lf);
    p = fma(p, r, 1.0lf / 120.0lf);
    p = fma(p, r, 1.0lf / 24.0lf);
    p = fma(p, r, 1.0lf / 6.0lf);
    p = fma(p, r, 0.5lf);
    p = fma(p, r, 1.0lf);
    p = fma(p, r, 1.0lf);
    // Two steps so that 2^k stays representable near the subnormal range.
    let k1 = i32(k) / 2;
    return ldexp(ldexp(p, k1), i32(k) - k1);
}

// ln(x) for finite x > 0: x = m 2^e with m in [sqrt(1/2), sqrt(2)), then
// ln m = 2 atanh(s), s = (m - 1)/(m + 1), |s| <= 0.172, as an odd series to s^25. (naga's
// frexp of an f64 needs 64-bit integers, so e is estimated from an f32 log2 and corrected.)
fn ln64(x: f64) -> f64 {
    var y = x;
    var e = 0;
    for (var i = 0; i < 12 && y > 1.0e30lf; i++) {
        y = ldexp(y, -100);
        e += 100;
    }
    for (var i = 0; i < 12 && y < 1.0e-30lf; i++) {
        y = ldexp(y, 100);
        e -= 100;
    }
    let k = i32(floor(log2(f32(y))));
    var m = ldexp(y, -k);
    e += k;
    for (var i = 0; i < 2; i++) {
        if (m >= 1.4142135623730951lf) {
            m = m * 0.5lf;
            e += 1;
        } else if (m < 0.7071067811865476lf) {
            m = m * 2.0lf;
            e -= 1;
        }
    }
    let s = (m - 1.0lf) / (m + 1.0lf);
    let s2 = s * s;
    var p = 1.0lf / 25.0lf;
    p = fma(p, s2, 1.0lf / 23.0lf);
    p = fma(p, s2, 1.0lf / 21.0lf);
    p = fma(p, s2, 1.0lf / 19.0lf);
    p = fma(p, s2, 1.0lf / 17.0lf);
    p = fma(p, s2, 1.0lf / 15.0lf);
    p = fma(p, s2, 1.0lf / 13.0lf);
    p = fma(p, s2, 1.0lf / 11.0lf);
    p = fma(p, s2, 1.0lf / 9.0lf);
    p = fma(p, s2, 1.0lf / 7.0lf);
    p = fma(p, s2, 1.0lf / 5.0lf);
    p = fma(p, s2, 1.0lf / 3.0lf);
    p = fma(p, s2, 1.0lf);
    return f64(e) * LN2 + 2.0lf * s * p;
}

// ln(1 + y) for y >= 0 without losing small y (Goldberg: the rounding of 1 + y cancels).
fn ln1p64(y: f64) -> f64 {
    let u = 1.0lf + y;
    if (u == 1.0lf) {
        return y;
    }
    return ln64(u) * y / (u - 1.0lf);
}

// 1 - exp(-x) for x >= 0: the alternating series where it converges fast, else exp64.
fn one_minus_exp_neg64(x: f64) -> f64 {
    if (x < 0.25lf) {
        // x - x^2/2! + x^3/3! - ... to x^16 (the next term is below 1e-26 at x = 0.25)
        var p = -1.0lf / 20922789888000.0lf;
        p = fma(p, x, 1.0lf / 1307674368000.0lf);
        p = fma(p, x, -1.0lf / 87178291200.0lf);
        p = fma(p, x, 1.0lf / 6227020800.0lf);
        p = fma(p, x, -1.0lf / 479001600.0lf);
        p = fma(p, x, 1.0lf / 39916800.0lf);
        p = fma(p, x, -1.0lf / 3628800.0lf);
        p = fma(p, x, 1.0lf / 362880.0lf);
        p = fma(p, x, -1.0lf / 40320.0lf);
        p = fma(p, x, 1.0lf / 5040.0lf);
        p = fma(p, x, -1.0lf / 720.0lf);
        p = fma(p, x, 1.0lf / 120.0lf);
        p = fma(p, x, -1.0lf / 24.0lf);
        p = fma(p, x, 1.0lf / 6.0lf);
        p = fma(p, x, -0.5lf);
        p = fma(p, x, 1.0lf);
        return p * x;
    }
    return 1.0lf - exp64(-x);
}

// (1 - exp(-x)) / x, 1 at x = 0.
fn escape_fraction64(x: f64) -> f64 {
    if (x == 0.0lf) {
        return 1.0lf;
    }
    if (x < 0.25lf) {
        return one_minus_exp_neg64(x) / x;
    }
    return (1.0lf - exp64(-x)) / x;
}

// Finite test on the f32 voxel's bit pattern (compilers may fold `v != v` away; naga has no
// bitcast of f64).
fn is_finite_f32(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7f800000u) != 0x7f800000u;
}

struct Sample64 {
    value: f64,
    // false when any of the eight neighbours is missing (Volume::sample_trilinear gives NaN)
    finite: bool,
}

// Trilinear interpolation of cell-centred voxels with clamp to edge.
fn sample64(rel: vec3<f64>) -> Sample64 {
    let dims = vec3<i32>(textureDimensions(volume_tex));
    let g = rel / (P.box_size.xyz / vec3<f64>(dims)) - vec3<f64>(0.5lf);
    let g0 = floor(g);
    let f = g - g0;
    let top = dims - vec3<i32>(1);
    let base = vec3<i32>(g0);
    var acc = 0.0lf;
    for (var corner = 0u; corner < 8u; corner++) {
        let d = vec3<i32>(i32(corner & 1u), i32((corner >> 1u) & 1u), i32((corner >> 2u) & 1u));
        let w = select(1.0lf - f.x, f.x, d.x == 1) * select(1.0lf - f.y, f.y, d.y == 1)
            * select(1.0lf - f.z, f.z, d.z == 1);
        let v = textureLoad(volume_tex, clamp(base + d, vec3<i32>(0), top), 0).r;
        if (!is_finite_f32(v)) {
            return Sample64(0.0lf, false);
        }
        acc += w * f64(v);
    }
    return Sample64(acc, true);
}

fn lens_map64(t: f64) -> f64 {
    let l = P.lens;
    if (t < l.x) {
        return select(l.z, t * l.z / l.x, l.x > 0.0lf);
    } else if (t <= l.y) {
        return l.z + (t - l.x) * (l.w - l.z) / (l.y - l.x);
    }
    return select(l.w, l.w + (t - l.y) * (1.0lf - l.w) / (1.0lf - l.y), l.y < 1.0lf);
}

// Emission (rgb) and extinction (a) per voxel length, as TransferFunction::eval.
fn transfer64(v: f64) -> vec4<f64> {
    if (P.flags.x == 1u) {
        let c = max(v, 0.0lf);
        return vec4<f64>(vec3<f64>(P.tf.x * c), P.tf.y * c);
    }
    var s = v;
    if (P.flags.y == 1u) {
        s = ln64(max(v, 1.1754944e-38lf)) / LN10;
    } else if (P.flags.y == 2u) {
        s = sign(v) * ln1p64(abs(v) / P.scale.z) / LN10;
        if (v == 0.0lf) {
            s = 0.0lf;
        }
    }
    var t = clamp((s - P.scale.x) * P.scale.y, 0.0lf, 1.0lf);
    if (P.flags.z == 1u) {
        t = lens_map64(t);
    }
    let x = t * P.scale.w;
    let i = min(u32(floor(x)), u32(P.scale.w) - 1u);
    let f = x - f64(i);
    let a = lut[i];
    let b = lut[i + 1u];
    return a + (b - a) * f;
}

// The same hash as shared/optics.wgsl and render::jitter_fraction.
fn hash_u32(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Entry and exit of the ray through [0, size] as Aabb::intersect: a ray parallel to a slab
// misses when it starts outside it and ignores that axis otherwise.
fn box_hit64(o: vec3<f64>, d: vec3<f64>, size: vec3<f64>) -> vec3<f64> {
    var t0 = -1.0e308lf;
    var t1 = 1.0e308lf;
    for (var a = 0; a < 3; a++) {
        if (d[a] == 0.0lf) {
            if (o[a] < 0.0lf || o[a] > size[a]) {
                return vec3<f64>(0.0lf, 0.0lf, 0.0lf);
            }
            continue;
        }
        let ta = -o[a] / d[a];
        let tb = (size[a] - o[a]) / d[a];
        t0 = max(t0, min(ta, tb));
        t1 = min(t1, max(ta, tb));
    }
    return vec3<f64>(t0, t1, select(0.0lf, 1.0lf, t1 > t0));
}

struct State64 {
    color: vec3<f64>,
    tau: f64,
    stopped: bool,
}

// Composites piece [ta, tb] of the ray, sampled at its middle (nothing where it is empty).
fn piece64(s: ptr<function, State64>, ta: f64, tb: f64, o: vec3<f64>, d: vec3<f64>) {
    if ((*s).stopped || !(tb > ta)) {
        return;
    }
    let len = (tb - ta) / P.march.y;
    let v = sample64(o + d * (0.5lf * (ta + tb)));
    if (!v.finite) {
        return;
    }
    let ea = transfer64(v.value);
    let x = ea.a * len;
    let weight = exp64(-(*s).tau) * len * escape_fraction64(x);
    (*s).color += weight * ea.rgb;
    (*s).tau += x;
    if ((*s).tau > P.march.z) {
        (*s).stopped = true;
    }
}

// Segment k of the ray's grid from t_enter, cut to the ray's parts: [t_enter, a1] and
// [b0, t1] (one part where a1 = t1), each piece sampled at its middle, as the CPU reference's
// march does.
fn step64(s: ptr<function, State64>, k: u32, n: u32, t_enter: f64, first: f64, parts: vec4<f64>,
          o: vec3<f64>, d: vec3<f64>) {
    if ((*s).stopped || k >= n) {
        return;
    }
    let ds = P.march.x;
    let ta = select(t_enter + first + f64(k - 1u) * ds, t_enter, k == 0u);
    let tb = t_enter + first + f64(k) * ds;
    piece64(s, max(ta, parts.x), min(tb, parts.y), o, d);
    piece64(s, max(ta, parts.z), min(tb, parts.w), o, d);
}

// The ray's pieces inside the box [t0, t1] less its piece inside the cut-away's box and planes
// (the slab method, as Cut::clip_box): (a0, a1, b0, b1), an empty piece where a part is missing.
fn ray_parts64(o: vec3<f64>, d: vec3<f64>, t0: f64, t1: f64) -> vec4<f64> {
    let none = vec4<f64>(t0, t1, 1.0lf, 0.0lf);
    if (P.cut_lo.w < 0.5lf) {
        return none;
    }
    var c0 = -1.0e308lf;
    var c1 = 1.0e308lf;
    for (var a = 0; a < 3; a++) {
        if (d[a] == 0.0lf) {
            if (o[a] < P.cut_lo[a] || o[a] > P.cut_hi[a]) {
                return none;
            }
            continue;
        }
        let ta = (P.cut_lo[a] - o[a]) / d[a];
        let tb = (P.cut_hi[a] - o[a]) / d[a];
        c0 = max(c0, min(ta, tb));
        c1 = min(c1, max(ta, tb));
    }
    for (var i = 0; i < 3; i++) {
        let pl = P.cut_planes[i];
        let no = pl.x * o.x + pl.y * o.y + pl.z * o.z;
        let nd = pl.x * d.x + pl.y * d.y + pl.z * d.z;
        if (nd == 0.0lf) {
            if (no < pl.w) {
                return none;
            }
        } else if (nd > 0.0lf) {
            c0 = max(c0, (pl.w - no) / nd);
        } else {
            c1 = min(c1, (pl.w - no) / nd);
        }
    }
    if (c1 <= c0) {
        return none;
    }
    return vec4<f64>(t0, min(c0, t1), max(c1, t0), t1);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = P.image.x;
    let h = P.image.y;
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let sx = 2.0lf * (f64(gid.x) + 0.5lf) / f64(w) - 1.0lf;
    let sy = 1.0lf - 2.0lf * (f64(gid.y) + 0.5lf) / f64(h);
    var o = P.eye.xyz;
    var d = P.forward.xyz;
    if (P.proj.x > 0.5lf) {
        let u = P.forward.xyz + (sx * P.proj.y) * P.right.xyz + (sy * P.proj.z) * P.up.xyz;
        d = u / sqrt(dot(u, u));
    } else {
        o = P.eye.xyz + (sx * P.proj.y) * P.right.xyz + (sy * P.proj.z) * P.up.xyz;
    }
    var s = State64(vec3<f64>(0.0lf), 0.0lf, false);
    let hit = box_hit64(o, d, P.box_size.xyz);
    var parts = ray_parts64(o, d, max(hit.x, 0.0lf), hit.y);
    // The march starts where the first non-empty part does and ends where the last one ends.
    if (!(parts.y > parts.x)) {
        parts = vec4<f64>(parts.z, parts.w, 1.0lf, 0.0lf);
    }
    let t_enter = parts.x;
    let t1 = max(parts.y, select(parts.y, parts.w, parts.w > parts.z));
    if (hit.z > 0.5lf && t1 > t_enter) {
        let ds = P.march.x;
        var first = ds;
        if (P.image.w != 0u) {
            let r = hash_u32(gid.x + w * (gid.y + h * P.image.z));
            first = ds * (1.0lf - f64(r >> 8u) / 16777216.0lf);
        }
        let span = t1 - t_enter;
        var n = 1u;
        if (span > first) {
            n = u32(ceil((span - first) / ds)) + 1u;
        }
        // Four steps per iteration: llvmpipe ends any loop after 65535 iterations.
        for (var k = 0u; k < n; k += 4u) {
            step64(&s, k, n, t_enter, first, parts, o, d);
            step64(&s, k + 1u, n, t_enter, first, parts, o, d);
            step64(&s, k + 2u, n, t_enter, first, parts, o, d);
            step64(&s, k + 3u, n, t_enter, first, parts, o, d);
            if (s.stopped) {
                break;
            }
        }
    }
    let t = exp64(-s.tau);
    out_image[gid.y * w + gid.x] = vec4<f64>(s.color + t * P.background.xyz, one_minus_exp_neg64(s.tau));
}
