//! The colour side of a surface render: the colour domain of the fringe pass, the colour bar
//! recorded with an image, the separate colour-bar image and the legend.

use super::options::{property_indices, FringeMode, SurfaceOptions};
use super::phase::fringe_f64;
use crate::error::{Error, Result};
use crate::model::colormap::Colormap;
use crate::model::text::{draw_extend_triangles, draw_text, extend_length, typeset_number, Type};
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
/// colour range of [`SurfaceOptions::colour_range`] on the pass's scale (log10 of magnitudes for
/// log colour, magnitudes for absolute), with an `extend` triangle at each end where the data
/// `data` (finite range, `None` all missing) go beyond it and take the end colour.
pub(super) fn surface_colour_bar(
    opts: &SurfaceOptions,
    nu: f64,
    colormap: &str,
    (units, long_name): (&str, &str),
    (property, d_ref, data): (&str, f64, Option<(f64, f64)>),
) -> Result<crate::model::text::ColourBar> {
    use crate::model::text::{BarScale, ColourBar};
    let colours = opts.colour_range(data, property)?;
    let (c_lo, c_inv, _) = colour_domain(opts, colours.unwrap_or((d_ref, d_ref)), d_ref);
    let span = if c_inv > 0.0 { 1.0 / c_inv } else { 0.0 };
    let (scale, lo, hi) = match opts.mode {
        FringeMode::Cyclic => (BarScale::Linear, 0.0, 1.0 / nu),
        _ if opts.log_color => (BarScale::Log10, 10f64.powf(c_lo), 10f64.powf(c_lo + span)),
        _ if opts.absolute => (BarScale::Linear, c_lo, c_lo + span),
        // The range itself, not through the offset from d_ref, so round ends stay round.
        _ => {
            let (lo, hi) = colours.unwrap_or((d_ref, d_ref));
            (BarScale::Linear, lo, hi)
        }
    };
    let extend = match (opts.mode, data) {
        (FringeMode::Cyclic, _) | (_, None) => [false; 2],
        (_, Some(range)) => {
            // The data's own colour domain on the same scale, against the one drawn.
            let (d_lo, d_inv, _) = colour_domain(opts, range, d_ref);
            let d_span = if d_inv > 0.0 { 1.0 / d_inv } else { 0.0 };
            let tol = 1e-9 * span.max(d_span).max(f64::MIN_POSITIVE);
            [d_lo < c_lo - tol, d_lo + d_span > c_lo + span + tol]
        }
    };
    Ok(ColourBar {
        colormap: colormap.to_string(),
        scale,
        lo,
        hi,
        units: units.to_string(),
        label: bar_label(opts, property, long_name, units),
        extend,
    })
}

/// What a surface's colour bar measures: `label` as given, else the property's long name (its
/// name when it has none) with its units, "sea surface temperature (K)"; in cyclic mode, where
/// the bar spans one fringe, "… within a fringe".
fn bar_label(opts: &SurfaceOptions, property: &str, long_name: &str, units: &str) -> String {
    if let Some(l) = &opts.label {
        return l.clone();
    }
    let what = if long_name.is_empty() {
        property
    } else {
        long_name
    };
    let what = match units {
        "" | "1" => what.to_string(),
        u => format!("{what} ({u})"),
    };
    if opts.mode == FringeMode::Cyclic {
        format!("{what} within a fringe")
    } else {
        what
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
    let (name, _) = grid.property_at(p);
    let units = grid.units(p);
    let data = grid.range(p);
    let d_ref = data.map_or(0.0, |(a, b)| 0.5 * (a + b));
    let bar = surface_colour_bar(
        opts,
        nu,
        cmap.name(),
        (units, grid.long_name(p)),
        (name, d_ref, data),
    )?;
    let (lo, hi) = (bar.lo, bar.hi);
    let mut img = HdrImage::new(width, height);
    let tri = extend_length(width, height);
    let (x0, x1) = bar.extent(width, tri);
    let colour_at = |x: u32| {
        let d = lo + (hi - lo) * (x as f64 - x0 as f64 + 0.5) / (x1 - x0) as f64;
        let t = match opts.mode {
            FringeMode::Cyclic => (nu * d).rem_euclid(1.0),
            _ => bar.position(d),
        };
        let mut c = cmap.linear_rgb(t);
        if opts.mode != FringeMode::Direct {
            let k = (1.0 - opts.modulation) + opts.modulation * fringe_f64(nu, d);
            c = c.map(|v| v * k);
        }
        [c[0] as f32, c[1] as f32, c[2] as f32, 1.0]
    };
    for x in x0..x1 {
        let c = colour_at(x);
        for y in 0..height {
            img.pixels[(y * width + x) as usize] = c;
        }
    }
    draw_extend_triangles(&mut img, &bar, &cmap, (0, width), (0, height), false);
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
    bar.record(&mut img);
    Ok(img)
}

/// The legend's statement of the resolution: "1 fringe = 0.125 m" (1/ν in the property's
/// units, "data units" when it has none; typeset, so 2.5×10⁻⁷ m).
pub fn resolution_label(nu: f64, units: &str) -> String {
    let u = if units.is_empty() {
        "data units"
    } else {
        units
    };
    format!("1 fringe = {} {u}", typeset_number(1.0 / nu))
}

/// Height in pixels of the colour bar at the top of a [`legend`].
pub const LEGEND_BAR_HEIGHT: u32 = 16;

/// A legend for a surface render, `width` pixels wide: the colour bar of [`colorbar`] on top,
/// then in white text on black the resolution ("1 fringe = 0.125 m"), ν and the mode, and the
/// bar's domain (its ends, left and right), in the default type for its width.
pub fn legend(grid: &Grid, opts: &SurfaceOptions, width: u32) -> Result<HdrImage> {
    legend_in(grid, opts, width, legend_type(width, None))
}

/// The legend's type: `font_size` pixels an em, else 3.5 % of its width (at least 11).
pub(crate) fn legend_type(width: u32, font_size: Option<f64>) -> Type {
    Type::new(font_size.unwrap_or((0.035 * width as f64).max(11.0)))
}

/// [`legend`] in type `ty`.
pub(crate) fn legend_in(
    grid: &Grid,
    opts: &SurfaceOptions,
    width: u32,
    ty: Type,
) -> Result<HdrImage> {
    let bar = colorbar(grid, opts, width, LEGEND_BAR_HEIGHT)?;
    let p = property_indices(grid, opts)?[0];
    let nu = opts.nu_for(0);
    let mut label = resolution_label(nu, grid.units(p));
    // A displacement in metres whose fringe is half the radar wavelength: the interferogram's
    // own fringe, which InSAR users read as such.
    if let Some(w) = grid.wavelength().filter(|_| grid.units(p) == "m") {
        if (nu * w / 2.0 - 1.0).abs() < 1e-6 {
            label.push_str(" = λ/2");
        }
    }
    let detail = format!("ν = {} ({})", typeset_number(nu), opts.mode.name());
    let ends = crate::model::text::ColourBar::of(&bar).map(|b| (b.lo, b.hi));
    let (left, right) = match ends {
        Some((lo, hi)) => (typeset_number(lo), typeset_number(hi)),
        None => (String::new(), String::new()),
    };
    let (gap, line) = (ty.gap(), ty.line());
    let height = LEGEND_BAR_HEIGHT + gap + 3 * (line + gap);
    let mut img = HdrImage::new(width, height);
    // Black ink on white, as a figure's page.
    for px in img.pixels.iter_mut() {
        *px = [1.0, 1.0, 1.0, 1.0];
    }
    // The bar's pixels over the white, but not the clear corners beside its extend triangles.
    for (dst, src) in img.pixels.iter_mut().zip(&bar.pixels) {
        if src[3] > 0.0 {
            *dst = *src;
        }
    }
    let ink = [0.0, 0.0, 0.0, 1.0];
    let top = (LEGEND_BAR_HEIGHT + gap) as i64;
    let step = (line + gap) as i64;
    let x = gap as i64;
    let right_x = width as i64 - ty.width(&right) as i64 - x;
    draw_text(&mut img, x, top, &left, ty, ink);
    draw_text(&mut img, right_x.max(x), top, &right, ty, ink);
    // What the bar measures, centred between its end values where it fits.
    if let Some(b) = crate::model::text::ColourBar::of(&bar) {
        let room = (right_x - x - ty.width(&left) as i64 - 2 * ty.width("0") as i64).max(0);
        let caption = b.caption(room as u32, ty);
        if !caption.is_empty() {
            let cx = (width as i64 - ty.width(&caption) as i64) / 2;
            draw_text(&mut img, cx, top, &caption, ty, ink);
        }
    }
    draw_text(&mut img, x, top + step, &label, ty, ink);
    draw_text(&mut img, x, top + 2 * step, &detail, ty, ink);
    img.metadata = bar.metadata.clone();
    img.set_meta("legend", label.as_str());
    Ok(img)
}
