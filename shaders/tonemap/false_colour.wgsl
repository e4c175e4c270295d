// False-colour view of log10 luminance through a colour-map table, with the legend strip along
// the bottom (colour bar plus a black-over-white tick at every decade), as
// src/tonemap/cpu/mod.rs `false_colour_log10` draws it. The table is `turbo_lut()` (256 linear RGB
// entries sampled from colorgrad's turbo), interpolated linearly. Missing pixels are grey
// (0.2), black pixels take the low end. Output is display-referred linear RGBA, alpha 1.
//
// Entry point false_colour: workgroups of 256, dispatch (X, Y, 1) with X * Y * 256 >= n,
// pixel = global_id.x + global_id.y * X * 256.
//
// Bindings (group 0):
//   @binding(0)  params   uniform    ToneMapParams: width, height, exposure_ev, and
//                         ld_min / ld_max = low / high decade (log10 units), radius = legend
//                         strip height in pixels (0: no legend; cpu/mod.rs `legend_height`)
//   @binding(1)  image    storage, read        array<vec4<f32>>
//   @binding(2)  output   storage, read_write  array<vec4<f32>>
//   @binding(14) lut      storage, read        array<vec4<f32>>  (>= 2 entries)

#include "shared/tonemap_common.wgsl"

const LOG10_2: f32 = 0.3010299956639812;
const LOG10_E: f32 = 0.4342944819032518;
const MISSING_GREY: f32 = 0.2;

@group(0) @binding(0) var<uniform> params: ToneMapParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read> lut: array<vec4<f32>>;

fn colour_map(t: f32) -> vec4<f32> {
    let last = arrayLength(&lut) - 1u;
    let x = clamp(t, 0.0, 1.0) * f32(last);
    let i = min(u32(floor(x)), last - 1u);
    return vec4<f32>(mix(lut[i].rgb, lut[i + 1u].rgb, x - f32(i)), 1.0);
}

@compute @workgroup_size(256)
fn false_colour(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // Index within the band (image and output are bound from its first row); y is global.
    let i = id.x + id.y * groups.x * 256u;
    if i >= params.width * params.band_rows {
        return;
    }
    let low = params.ld_min;
    let high = params.ld_max;
    let x = i % params.width;
    let y = params.band_first + i / params.width;
    if params.radius > 0u && y >= params.height - params.radius && params.width >= 2u {
        let span = f32(params.width - 1u);
        var colour = colour_map(f32(x) / span);
        for (var d = ceil(low); d <= high; d = d + 1.0) {
            if u32(round((d - low) / (high - low) * span)) == x {
                let in_upper_half = y < params.height - params.radius / 2u;
                colour = select(vec4<f32>(1.0), vec4<f32>(0.0, 0.0, 0.0, 1.0), in_upper_half);
            }
        }
        output[i] = colour;
        return;
    }
    let p = image[i];
    if is_missing(p) {
        output[i] = vec4<f32>(vec3<f32>(MISSING_GREY), 1.0);
        return;
    }
    let lum = dot(max(p.rgb, vec3<f32>(0.0)), REC709);
    var t = 0.0;
    if lum > 0.0 {
        t = (log(lum) * LOG10_E + params.exposure_ev * LOG10_2 - low) / (high - low);
    }
    output[i] = colour_map(t);
}
