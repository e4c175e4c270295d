// Shared by the tone-mapping shaders (shaders/tonemap/). ToneMapParams and LuminanceStats
// mirror src/tonemap/params.rs — keep in sync.

struct ToneMapParams {
    width: u32, height: u32, op: u32, bins: u32,
    exposure_ev: f32, offset: f32, inv_gamma: f32, saturation: f32,
    key: f32, white: f32, bias: f32, ld_max: f32,
    ld_min: f32, contrast_log10: f32, sigma_spatial_px: f32, sigma_range: f32,
    sharpness: f32, epsilon: f32, out_stride: u32, in_stride: u32,
    fine_scales: u32, sigma: f32, radius: u32, pad4: u32,
    cell: u32, grid_width: u32, grid_height: u32, levels: u32,
    first_level: f32, level_step: f32, band_first: u32, dst_offset: u32,
    band_rows: u32, window_first: u32, gamut_clip: u32, pad1: u32,
}

struct LuminanceStats { mean_log: f32, max_log: f32, min_log: f32, count: u32 }

// Specialisation (src/tonemap/gpu/mod.rs `Specialisation`): the operator (ToneMapParams.op) and
// whether saturation and 1 / gamma are exactly 1, as pipeline constants, so that no pass
// branches on them at run time (Mesa's CPU rasterizers run both sides of such branches).
override OP: u32 = 0u;
override PLAIN_SATURATION: bool = true;
override PLAIN_GAMMA: bool = true;
// Gamut (src/tonemap/params.rs `Gamut`): false scales a colour whose largest channel exceeds 1
// by 1 / max (hue kept), true clips each channel.
override GAMUT_CLIP: bool = false;

const REC709 = vec3<f32>(0.2126, 0.7152, 0.0722);

fn is_missing(p: vec4<f32>) -> bool {
    let exponent = bitcast<vec4<u32>>(p) & vec4<u32>(0x7f800000u);
    return any(exponent == vec4<u32>(0x7f800000u));
}

fn pixel_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * 256u;
}

// Bands: an image larger than one storage binding is processed in bands of rows
// [band_first, band_first + band_rows) (of pixels, or of a pass's grid cells); per-pixel
// buffers are bound as windows starting at the band's first row, so an item index within the
// band is also its index in those windows. Global coordinates add band_first back.

// (C / L_w)^s * L_d, + offset, into the gamut (scaled by 1 / max above 1 unless clipping), clamped,
// ^(1 / gamma). pow(0, y) is indeterminate in WGSL,
// hence the selects.
fn compose(colour: vec3<f32>, y: f32, ld: f32) -> vec3<f32> {
    var ratio = colour / y;
    if !PLAIN_SATURATION {
        let powered = pow(ratio, vec3<f32>(params.saturation));
        ratio = select(powered, vec3<f32>(0.0), ratio <= vec3<f32>(0.0));
        if params.saturation == 0.0 {
            ratio = vec3<f32>(1.0);
        }
    }
    var c = ratio * ld + params.offset;
    if !GAMUT_CLIP {
        c /= max(max(max(c.r, c.g), c.b), 1.0);
    }
    let v = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    if PLAIN_GAMMA {
        return v;
    }
    // The select discards pow's indeterminate value at 0.
    return select(pow(v, vec3<f32>(params.inv_gamma)), vec3<f32>(0.0), v <= vec3<f32>(0.0));
}
