// Pre-integrated transfer functions: what a march carries from one segment's end to the next,
// and the transfer function's mean over a segment whose value runs linearly between its ends.
// Shared by the ray casters (volume.wgsl, volume_mapped.wgsl); the including shader declares `P`
// and the `lut` texture (with the integral rows).

// What a pre-integrated march carries from one segment's back end to the next one's front: the
// value, and for tables its coordinate and the table's running integral there, as hi + lo.
struct Front {
    v: f32,
    x: f32,
    c_hi: vec4<f32>,
    c_lo: vec4<f32>,
    // The table entries around x (its linear piece), reused when both ends share it.
    e0: vec4<f32>,
    e1: vec4<f32>,
}

// The table, linearly interpolated, at table coordinate x.
fn table_at(x: f32) -> vec4<f32> {
    let i = min(i32(x), i32(P.scale.w) - 1);
    return mix(textureLoad(lut, vec2<i32>(i, 0), 0), textureLoad(lut, vec2<i32>(i + 1, 0), 0), x - f32(i));
}

fn front_at(v: f32) -> Front {
    var f = Front(v, 0.0, vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    if (TF_KIND == 0u && is_finite_f32(v)) {
        let x = scaled(v) * P.scale.w;
        let i = min(i32(x), i32(P.scale.w) - 1);
        let t = x - f32(i);
        let e0 = textureLoad(lut, vec2<i32>(i, 0), 0);
        let e1 = textureLoad(lut, vec2<i32>(i + 1, 0), 0);
        f.x = x;
        f.e0 = e0;
        f.e1 = e1;
        f.c_hi = textureLoad(lut, vec2<i32>(i, 1), 0);
        f.c_lo = textureLoad(lut, vec2<i32>(i, 2), 0) + t * e0 + (0.5 * t * t) * (e1 - e0);
    }
    return f;
}

// Mean emission–absorption over a segment whose value (table coordinate for tables) runs
// linearly from a to b; matches ResolvedTransfer::segment_mean in src/model/transfer.rs.
fn segment_mean(a: Front, b: Front) -> vec4<f32> {
    if (TF_KIND == 1u) {
        var m = 0.5 * (a.v + b.v);
        if (a.v <= 0.0 && b.v <= 0.0) {
            m = 0.0;
        } else if (a.v < 0.0 || b.v < 0.0) {
            let p = max(a.v, b.v);
            m = p * p / (2.0 * abs(a.v - b.v));
        }
        return vec4<f32>(vec3<f32>(P.tf.x * m), P.tf.y * m);
    }
    let top = i32(P.scale.w) - 1;
    let dx = b.x - a.x;
    let ib = min(i32(b.x), top);
    // Within one linear piece the mean is the value at the middle, from the entries already
    // loaded for b.
    if (min(i32(a.x), top) == ib) {
        return mix(b.e0, b.e1, 0.5 * (a.x + b.x) - f32(ib));
    }
    // Tiny spans would lose the difference quotient to rounding.
    if (abs(dx) < 1e-3) {
        return table_at(0.5 * (a.x + b.x));
    }
    return ((b.c_hi - a.c_hi) + (b.c_lo - a.c_lo)) / dx;
}


// What a pre-integrated segment composites: its emission–absorption over `len` lengths.
struct Segment {
    ea: vec4<f32>,
    len: f32,
}

// The segment of `len` lengths between the carried front and `back`: the transfer function's
// mean between two finite ends; where one end is missing, the edge of missing data is taken at
// the middle, so the half next to the finite end carries that end's value (as point sampling
// keeps a segment whose middle is finite); nothing where both are missing.
fn segment_between(front: Front, back: Front, len: f32) -> Segment {
    let front_ok = is_finite_f32(front.v);
    let back_ok = is_finite_f32(back.v);
    if (front_ok && back_ok) {
        return Segment(segment_mean(front, back), len);
    }
    if (!front_ok && !back_ok) {
        return Segment(vec4<f32>(0.0), len);
    }
    if (TF_KIND == 1u) {
        let c = max(select(back.v, front.v, front_ok), 0.0);
        return Segment(vec4<f32>(vec3<f32>(P.tf.x * c), P.tf.y * c), 0.5 * len);
    }
    return Segment(table_at(select(back.x, front.x, front_ok)), 0.5 * len);
}
