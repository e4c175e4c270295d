// The transfer function, the segments of a ray, the compositing step and the finished pixel,
// shared by the ray casters (volume.wgsl and volume_bricked.wgsl). The including shader declares
// `P` (Params of volume_params.wgsl) and the `lut` texture.

const LOG10_2: f32 = 0.30102999566;

// Rounds to the nearest 8-bit framebuffer level in [0, 1].
fn quantize8(v: f32) -> f32 {
    return round(clamp(v, 0.0, 1.0) * 255.0) / 255.0;
}

// Rounds to binary16 (through the packing builtins, so the same on every adapter).
fn round16(v: f32) -> f32 {
    return unpack2x16float(pack2x16float(vec2<f32>(v, 0.0))).x;
}

// Trilinear interpolation in f32 of the eight texels spanned by corners a and b (b = a + 1
// where inside, clamped at edges) with weights f: the exact filter of both ray casters.
fn trilinear_texels(tex: texture_3d<f32>, a: vec3<i32>, b: vec3<i32>, f: vec3<f32>) -> f32 {
    let c000 = textureLoad(tex, vec3<i32>(a.x, a.y, a.z), 0).r;
    let c100 = textureLoad(tex, vec3<i32>(b.x, a.y, a.z), 0).r;
    let c010 = textureLoad(tex, vec3<i32>(a.x, b.y, a.z), 0).r;
    let c110 = textureLoad(tex, vec3<i32>(b.x, b.y, a.z), 0).r;
    let c001 = textureLoad(tex, vec3<i32>(a.x, a.y, b.z), 0).r;
    let c101 = textureLoad(tex, vec3<i32>(b.x, a.y, b.z), 0).r;
    let c011 = textureLoad(tex, vec3<i32>(a.x, b.y, b.z), 0).r;
    let c111 = textureLoad(tex, vec3<i32>(b.x, b.y, b.z), 0).r;
    let x00 = mix(c000, c100, f.x);
    let x10 = mix(c010, c110, f.x);
    let x01 = mix(c001, c101, f.x);
    let x11 = mix(c011, c111, f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

// As trilinear_texels over the finite texels only, their weights renormalised to sum to one
// (Volume::interpolate with Missing::Renormalise): all eight finite give trilinear_texels' value
// bit for bit, a missing texel of weight zero changes nothing (the finite ones' plain sum), and
// none finite of non-zero weight gives NaN.
fn trilinear_finite(tex: texture_3d<f32>, a: vec3<i32>, b: vec3<i32>, f: vec3<f32>) -> f32 {
    var acc = 0.0;
    var weight = 0.0;
    var any_missing = false;
    var weighted_missing = false;
    for (var corner = 0u; corner < 8u; corner++) {
        let high = vec3<u32>(corner, corner >> 1u, corner >> 2u) & vec3<u32>(1u);
        let on = high == vec3<u32>(1u);
        let v = textureLoad(tex, select(a, b, on), 0).r;
        let w3 = select(vec3<f32>(1.0) - f, f, on);
        let w = w3.x * w3.y * w3.z;
        if (is_finite_f32(v)) {
            acc += w * v;
            weight += w;
        } else {
            any_missing = true;
            weighted_missing = weighted_missing || w > 0.0;
        }
    }
    if (!any_missing) {
        return trilinear_texels(tex, a, b, f);
    }
    if (!weighted_missing) {
        return acc;
    }
    return select(bitcast<f32>(0x7fc00000u), acc / weight, weight > 0.0);
}

// Blinn–Phong factor for data gradient g under a headlight along -dir (light and eye together,
// so the half vector is the light vector), two-sided; 1 (unshaded) where the gradient vanishes
// or touches a missing value.
fn headlight(g: vec3<f32>, dir: vec3<f32>) -> f32 {
    let len2 = dot(g, g);
    if (!(len2 > 0.0) || !is_finite_f32(len2)) {
        return 1.0;
    }
    let c = abs(dot(g, dir)) * inverseSqrt(len2);
    return P.shading.x + P.shading.y * c + P.shading.z * pow(c, P.shading.w);
}

// Data value -> table coordinate in [0, 1] (see ScaleMapping::map).
fn scaled(v: f32) -> f32 {
    var s = v;
    if (SCALE_KIND == 1u) {
        s = log2(max(v, 1.1754944e-38)) * LOG10_2;
    } else if (SCALE_KIND == 2u) {
        s = sign(v) * log2(1.0 + abs(v) / P.scale.z) * LOG10_2;
    }
    var t = clamp((s - P.scale.x) * P.scale.y, 0.0, 1.0);
    if (USE_LENS) {
        let l = P.lens;
        if (t < l.x) {
            t = select(l.z, t * l.z / l.x, l.x > 0.0);
        } else if (t <= l.y) {
            t = l.z + (t - l.x) * (l.w - l.z) / (l.y - l.x);
        } else {
            t = select(l.w, l.w + (t - l.y) * (1.0 - l.w) / (1.0 - l.y), l.y < 1.0);
        }
    }
    return t;
}

// Emission (rgb, per voxel length) and extinction (a, per voxel length) of a data value.
fn transfer(v: f32) -> vec4<f32> {
    if (TF_KIND == 1u) {
        let c = max(v, 0.0);
        return vec4<f32>(vec3<f32>(P.tf.x * c), P.tf.y * c);
    }
    let x = scaled(v) * P.scale.w;
    let i = min(i32(x), i32(P.scale.w) - 1);
    return mix(textureLoad(lut, vec2<i32>(i, 0), 0), textureLoad(lut, vec2<i32>(i + 1, 0), 0), x - f32(i));
}

// The fixed quantities of one ray's march: where it enters and leaves the box, its first
// segment and step (world units), voxels per world unit, the optical depth at which it stops,
// its number of segments, its start and direction in texture coordinates and its unit direction
// in world space (the headlight shines along it).
struct March {
    t_enter: f32,
    t_exit: f32,
    first: f32,
    ds: f32,
    voxels_per_unit: f32,
    stop_tau: f32,
    steps: u32,
    uvw0: vec3<f32>,
    duvw: vec3<f32>,
    dir: vec3<f32>,
}

// Where segment k of the ray ends: the first segment, then steps of ds, the last cut at the exit.
fn segment_end(m: March, k: u32) -> f32 {
    return min(m.t_enter + m.first + f32(k) * m.ds, m.t_exit);
}

// The in-core ray caster takes its interior segments four at a time; the bricked one takes the
// same segments one at a time, at the same positions and with the same sums.
const UNROLL: u32 = 4u;

// The first segment past the interior of a march whose segments 1..n_to are taken: segments
// 1..interior_end(n_to) have length ds and midpoints on the sequence interior_origin(m) + k *
// duvw * ds (no clamp at the exit, no carried end point); segment 0 and those from here on go
// through segment_end. Both ray casters place their samples this way, so a sample that falls
// on a voxel boundary next to a missing voxel is missing in both or in neither.
fn interior_end(n_to: u32) -> u32 {
    return 1u + UNROLL * ((max(n_to, UNROLL + 1u) - UNROLL - 1u + UNROLL - 1u) / UNROLL);
}

// Where interior segment 0 would have its midpoint: segment k's is this plus k * duvw * ds.
fn interior_origin(m: March) -> vec3<f32> {
    return m.uvw0 + m.duvw * (m.t_enter + m.first - 0.5 * m.ds);
}

// The f32 block of 64 interior segments that segment k's sums join (see volume.wgsl).
fn sum_block(k: u32) -> u32 {
    return (k - 1u) / 64u;
}

// Length of a ray's first segment: the step, or with JITTER a fraction of it drawn per pixel
// (the same on every run and backend).
fn first_segment(px: vec2<u32>, w: u32, h: u32, ds: f32) -> f32 {
    if (JITTER) {
        let r = hash_u32(px.x + w * (px.y + h * P.image.z));
        return ds * (1.0 - f32(r >> 8u) * (1.0 / 16777216.0));
    }
    return ds;
}

// Segments of a ray through `span`: the first one, then steps of ds, the last cut at the exit.
fn segment_count(span: f32, first: f32, ds: f32) -> u32 {
    if (span > first) {
        return u32(ceil((span - first) / ds)) + 1u;
    }
    return 1u;
}

// What a ray carries from step to step.
struct RayState {
    color: vec3<f32>,
    color_carry: vec3<f32>,
    tau: f32,
    tau_carry: f32,
    transmittance: f32,
    // End of the previous segment.
    ta: f32,
    stopped: bool,
}

// Composites one segment of `len` voxel lengths with emission–absorption `ea` onto the ray:
// the exact integral over a homogeneous segment, in the arithmetic PRECISION selects.
fn composite(s: ptr<function, RayState>, ea_in: vec4<f32>, len: f32, stop_tau: f32) {
    let ea = ea_in;
    let x = ea.a * len;
    // One exponential per step and no branch: the escape fraction (1 - e^-x) / x, from its
    // series where the quotient would cancel, gives both the emission weight and the absorbed
    // fraction for the transmittance update. The optical depth is still accumulated
    // separately, for alpha and for the stopping test.
    let series = 1.0 - x * (0.5 - x * (0.16666667 - x * 0.041666668));
    let escape = select((1.0 - exp(-x)) / x, series, x < 0.03);
    let absorbed = escape * x;
    let contribution = (*s).transmittance * ea.rgb * (len * escape);
    if (PRECISION == 3u) {
        // Kahan: carry the low-order bits each sum drops. Shader compilers may rewrite
        // (a + b) - a as b (NIR does), which would leave the carry at zero; multiplying the sum
        // by a 1.0 they cannot see through (P.march.w) keeps the difference.
        let one = P.march.w;
        let yc = contribution - (*s).color_carry;
        let tc = (*s).color + yc;
        (*s).color_carry = (tc * one - (*s).color) - yc;
        (*s).color = tc;
        let yt = x - (*s).tau_carry;
        let tt = (*s).tau + yt;
        (*s).tau_carry = (tt * one - (*s).tau) - yt;
        (*s).tau = tt;
        (*s).transmittance = exp(-tt);
    } else if (PRECISION == 1u) {
        // An 8-bit RGBA framebuffer: alpha = 1 - T and colour stored as 8-bit levels.
        let c = (*s).color + contribution;
        (*s).color = vec3<f32>(quantize8(c.x), quantize8(c.y), quantize8(c.z));
        let alpha8 = quantize8(1.0 - (*s).transmittance * (1.0 - absorbed));
        (*s).transmittance = 1.0 - alpha8;
        (*s).tau = select(-log((*s).transmittance), 1e30, (*s).transmittance <= 0.0);
    } else if (PRECISION == 2u) {
        let c = (*s).color + contribution;
        (*s).color = vec3<f32>(round16(c.x), round16(c.y), round16(c.z));
        (*s).transmittance = round16((*s).transmittance * (1.0 - absorbed));
        (*s).tau = round16((*s).tau + x);
    } else {
        (*s).color += contribution;
        (*s).transmittance *= 1.0 - absorbed;
        (*s).tau += x;
    }
    if ((*s).tau > stop_tau) {
        (*s).stopped = true;
    }
}

// The pixel a finished ray leaves: its colour over the background and alpha = 1 - e^-tau; in the
// 8-bit emulation both as that framebuffer holds them.
fn ray_pixel(s: RayState) -> vec4<f32> {
    if (PRECISION == 1u) {
        let c = s.color + s.transmittance * P.background.rgb;
        return vec4<f32>(quantize8(c.x), quantize8(c.y), quantize8(c.z), 1.0 - s.transmittance);
    }
    return vec4<f32>(s.color + exp(-s.tau) * P.background.rgb, one_minus_exp_neg(s.tau));
}
