//! The colour side of a surface render: the colour domain of the fringe pass, the colour bar
//! recorded with an image, the separate colour-bar image and the legend.

use super::options::{property_indices, FringeMode, SurfaceOptions};
use super::params::FringeParams;
use super::phase::fringe_f64;
use crate::error::{Error, Result};
use crate::model::colormap::Colormap;
use crate::model::{Grid, HdrImage};

/// Where colour starts, 1 / its span, and the floor of log colour, for data in [lo, hi]:
/// log10 of magnitudes (above a floor) for log colour outside cyclic mode, magnitudes for
/// absolute, else the offset from d_ref over the data range.
pub(super) fn colour_domain(
    opts: &SurfaceOptions,
    (lo, hi): (f64, f64),
    d_ref: f64,
) -> (f64, f64, f64) {
    if opts.log_color && opts.mode != FringeMode::Cyclic {
        let amax = lo.abs().max(hi.abs());
        let amin_pos = if lo > 0.0 {
            lo
        } else if hi < 0.0 {
            -hi
        } else {
            0.0
        };
        let floor = if amin_pos > 0.0 {
            amin_pos
        } else {
            amax * 1e-6
        };
        let floor = if floor > 0.0 { floor } else { 1.0 };
        let (a, b) = (floor.log10(), amax.max(floor).log10());
        (a, if b > a { 1.0 / (b - a) } else { 0.0 }, floor)
    } else if opts.absolute {
        let (a, b) = if lo >= 0.0 {
            (lo, hi)
        } else if hi <= 0.0 {
            (-hi, -lo)
        } else {
            (0.0, lo.abs().max(hi.abs()))
        };
        (a, if b > a { 1.0 / (b - a) } else { 0.0 }, 0.0)
    } else {
        (lo - d_ref, if hi > lo { 1.0 / (hi - lo) } else { 0.0 }, 0.0)
    }
}

/// The colour bar of a fringe pass: one fringe period (0 to 1/ν) in cyclic mode, otherwise the
/// colour domain the pass used (log10 of magnitudes for log colour, magnitudes for absolute).
pub(super) fn surface_colour_bar(
    opts: &SurfaceOptions,
    params: &FringeParams,
    nu: f64,
    colormap: &str,
    units: &str,
) -> crate::model::text::ColourBar {
    use crate::model::text::{BarScale, ColourBar};
    let [_, d_ref, c_lo, c_inv] = params.refs.map(|v| v as f64);
    let span = if c_inv > 0.0 { 1.0 / c_inv } else { 0.0 };
    let (scale, lo, hi) = match opts.mode {
        FringeMode::Cyclic => (BarScale::Linear, 0.0, 1.0 / nu),
        _ if opts.log_color => (BarScale::Log10, 10f64.powf(c_lo), 10f64.powf(c_lo + span)),
        _ if opts.absolute => (BarScale::Linear, c_lo, c_lo + span),
        _ => (BarScale::Linear, c_lo + d_ref, c_lo + d_ref + span),
    };
    ColourBar {
        colormap: colormap.to_string(),
        scale,
        lo,
        hi,
        units: units.to_string(),
    }
}

/// The tallest colour bar, in pixels: a bar is a strip, and the limit keeps a mistyped size from
/// allocating gigabytes.
pub(crate) const MAX_COLORBAR_HEIGHT: u32 = 1024;

/// A colour bar for a surface render (a separate image): horizontal, `width × height`, left to
/// right over the colour domain — for cyclic mode one fringe period (0 to 1/ν), otherwise the
/// property's data range — with the fringes of ν drawn in unless the mode is direct. The
/// resolution 1/ν and the domain are recorded in the metadata.
pub(crate) fn colorbar(
    grid: &Grid,
    opts: &SurfaceOptions,
    width: u32,
    height: u32,
) -> Result<HdrImage> {
    opts.validate()?;
    let side = crate::render::MAX_IMAGE_SIDE;
    for (field, v, max) in [
        ("width", width, side),
        ("height", height, MAX_COLORBAR_HEIGHT),
    ] {
        if v == 0 || v > max {
            return Err(Error::invalid(
                field,
                format!("expected 1 to {max} pixels, got {v}"),
            ));
        }
    }
    let p = property_indices(grid, opts)?[0];
    let nu = opts.nu_for(0);
    let cmap = Colormap::by_name(opts.colormap_name())?;
    let (lo, hi) = match opts.mode {
        FringeMode::Cyclic => (0.0, 1.0 / nu),
        _ => grid.range(p).unwrap_or((0.0, 1.0)),
    };
    let (lo, hi) = if opts.absolute && opts.mode != FringeMode::Cyclic {
        (
            if lo < 0.0 && hi > 0.0 {
                0.0
            } else {
                lo.abs().min(hi.abs())
            },
            lo.abs().max(hi.abs()),
        )
    } else {
        (lo, hi)
    };
    let mut img = HdrImage::new(width, height);
    for x in 0..width {
        let d = lo + (hi - lo) * (x as f64 + 0.5) / width as f64;
        let t = match opts.mode {
            FringeMode::Cyclic => (nu * d).rem_euclid(1.0),
            _ if opts.log_color => {
                let floor = if lo > 0.0 { lo } else { hi.abs() * 1e-6 };
                let (a, b) = (
                    floor.max(f64::MIN_POSITIVE).log10(),
                    hi.abs().max(floor).log10(),
                );
                if b > a {
                    (d.abs().max(floor).log10() - a) / (b - a)
                } else {
                    0.0
                }
            }
            _ => {
                if hi > lo {
                    (d - lo) / (hi - lo)
                } else {
                    0.0
                }
            }
        };
        let mut c = cmap.linear_rgb(t);
        if opts.mode != FringeMode::Direct {
            let k = (1.0 - opts.modulation) + opts.modulation * fringe_f64(nu, d);
            c = c.map(|v| v * k);
        }
        for y in 0..height {
            img.pixels[(y * width + x) as usize] = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
        }
    }
    let (name, _) = grid.property_at(p);
    let units = grid.units(p);
    let u = if units.is_empty() {
        "data units"
    } else {
        units
    };
    img.set_meta("property", name);
    img.set_meta("resolution", format!("{} {u} per fringe (1/nu)", 1.0 / nu));
    img.set_meta("colorbar_domain", format!("{lo} {hi} {u}"));
    img.set_meta("mode", opts.mode.name());
    img.set_meta("colormap", cmap.name());
    Ok(img)
}

/// The legend's statement of the resolution: "1 fringe = 0.125 m" (1/ν in the property's
/// units, "data units" when it has none).
pub fn resolution_label(nu: f64, units: &str) -> String {
    let u = if units.is_empty() {
        "data units"
    } else {
        units
    };
    format!(
        "1 fringe = {} {u}",
        crate::model::text::format_number(1.0 / nu)
    )
}

/// Height in pixels of the colour bar at the top of a [`legend`].
pub const LEGEND_BAR_HEIGHT: u32 = 16;

/// A legend for a surface render, `width` pixels wide: the colour bar of [`colorbar`] on top,
/// then in white text on black the resolution ("1 fringe = 0.125 m"), ν and the mode, and the
/// bar's domain (its ends, left and right). Text is drawn twice as large when it fits.
pub fn legend(grid: &Grid, opts: &SurfaceOptions, width: u32) -> Result<HdrImage> {
    use crate::model::text::{draw_text, format_number, text_width, GLYPH};
    let bar = colorbar(grid, opts, width, LEGEND_BAR_HEIGHT)?;
    let p = property_indices(grid, opts)?[0];
    let nu = opts.nu_for(0);
    let units = grid.units(p);
    let label = resolution_label(nu, units);
    let detail = format!("ν = {} ({})", format_number(nu), opts.mode.name());
    let domain: Vec<f64> = bar
        .meta("colorbar_domain")
        .unwrap_or("")
        .split_whitespace()
        .take(2)
        .filter_map(|v| v.parse().ok())
        .collect();
    let (left, right) = match domain[..] {
        [lo, hi] => (format_number(lo), format_number(hi)),
        _ => (String::new(), String::new()),
    };
    let widest = [label.as_str(), detail.as_str()]
        .iter()
        .map(|t| text_width(t, 1))
        .max()
        .unwrap_or(0)
        .max(text_width(&left, 1) + text_width(&right, 1) + GLYPH);
    let scale = if 2 * widest + 4 <= width { 2 } else { 1 };
    let line = GLYPH * scale + 4;
    let height = LEGEND_BAR_HEIGHT + 4 + 3 * line;
    let mut img = HdrImage::new(width, height);
    for px in img.pixels.iter_mut() {
        *px = [0.0, 0.0, 0.0, 1.0];
    }
    img.pixels[..bar.pixels.len()].copy_from_slice(&bar.pixels);
    let white = [1.0, 1.0, 1.0, 1.0];
    let top = (LEGEND_BAR_HEIGHT + 4) as i64;
    let right_x = width as i64 - text_width(&right, scale) as i64 - 2;
    draw_text(&mut img, 2, top, &left, scale, white);
    draw_text(&mut img, right_x.max(2), top, &right, scale, white);
    draw_text(&mut img, 2, top + line as i64, &label, scale, white);
    draw_text(&mut img, 2, top + 2 * line as i64, &detail, scale, white);
    img.metadata = bar.metadata.clone();
    img.set_meta("legend", label.as_str());
    Ok(img)
}
