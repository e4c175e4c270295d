// Emission–absorption optics shared by the ray casters (Max 1995). Keep in sync with
// src/render/cpu_reference.rs, which evaluates the same expressions in f64.

// 1 - exp(-x) for x >= 0 without cancellation: a short series where exp(-x) is close to 1, so
// tiny extinctions are not rounded to zero.
fn one_minus_exp_neg(x: f32) -> f32 {
    if (x < 0.03) {
        return x * (1.0 - x * (0.5 - x * (0.16666667 - x * 0.041666668)));
    }
    return 1.0 - exp(-x);
}

// Finite test on the bit pattern: compilers may fold `v != v` away, a bit test they cannot.
fn is_finite_f32(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7f800000u) != 0x7f800000u;
}

// PCG-style integer hash, for per-pixel jitter that is the same on every run and backend.
fn hash_u32(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
