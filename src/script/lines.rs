//! The line options that surfaces and spherical volume renders share (coastlines, graticules,
//! depth rings) and a surface's contours and vectors: one table per styled option and one
//! reading of each.

use super::convert::{boolean, num, numbers, to_rhai, RResult};
use super::options::{opt, Kind, OptionTable};
use crate::datasets::coastlines::CoastResolution;
use crate::model::DepthRings;
use crate::render::surface::{
    check_graticule, CoastlineStyle, ContourLevels, ContourStyle, VectorStyle,
};
use rhai::Dynamic;

pub(crate) const COASTLINES: OptionTable = OptionTable {
    function: "render_surface coastlines",
    options: &[
        opt("colour", Kind::Text("\"white\""), "\"black\"", "a colour name or #rrggbb (drawn as its linear RGB)"),
        opt("width", Kind::Finite, "1", "line width in pixels, > 0 and at most 64 (antialiased)"),
        opt("resolution", Kind::Text("\"50m\""), "50m for maps spanning under 60°, else 110m", "the Natural Earth scale: \"110m\" or \"50m\""),
    ],
    call: "render_surface(load_grid(\"geo.nc\"), #{ width: 8, height: 8, mode: \"modulated\", coastlines: OPTS })",
    base: "#{}",
};

pub(crate) const CELL_EDGES: OptionTable = OptionTable {
    function: "render_surface cell_edges",
    options: &[
        opt("colour", Kind::Text("\"white\""), "\"black\"", "a colour name or #rrggbb (drawn as its linear RGB)"),
        opt("width", Kind::Finite, "0.5", "line width in pixels, > 0 and at most 64 (antialiased)"),
    ],
    call: "render_surface(load_mesh(\"mesh.nc\", #{ variable: \"h\" }), #{ width: 8, height: 8, mode: \"modulated\", cell_edges: OPTS })",
    base: "#{}",
};

/// Width in pixels of cell edges drawn with `cell_edges: true`.
const CELL_EDGE_WIDTH: f64 = 0.5;

/// `cell_edges: true` (black, half a pixel), `false`, or a map ([`CELL_EDGES`]).
pub(crate) fn cell_edge_style(v: &Dynamic) -> RResult<Option<CoastlineStyle>> {
    CELL_EDGES.switch_or_map(v, "cell_edges", |given| {
        let mut style = CoastlineStyle {
            width: CELL_EDGE_WIDTH,
            ..CoastlineStyle::default()
        };
        if let Some(c) = given.string("colour")? {
            style = style.with_colour("cell_edges", &c).map_err(to_rhai)?;
        }
        style.width = given.num("width")?.unwrap_or(style.width);
        style.validate("cell_edges").map_err(to_rhai)?;
        Ok(style)
    })
}

/// `coastlines: true` (black, 1 pixel, the scale by the extent), `false`, or a map
/// ([`COASTLINES`]).
pub(crate) fn coastline_style(v: &Dynamic) -> RResult<Option<CoastlineStyle>> {
    COASTLINES.switch_or_map(v, "coastlines", |given| {
        let mut style = CoastlineStyle::default();
        if let Some(c) = given.string("colour")? {
            style = style.with_colour("coastlines", &c).map_err(to_rhai)?;
        }
        style.width = given.num("width")?.unwrap_or(style.width);
        if let Some(r) = given.string("resolution")? {
            style.resolution = Some(CoastResolution::parse(&r).map_err(to_rhai)?);
        }
        style.validate("coastlines").map_err(to_rhai)?;
        Ok(style)
    })
}

/// `graticule: true` (every 10°), `false`, or a step in degrees.
pub(crate) fn graticule_step(v: &Dynamic) -> RResult<Option<f64>> {
    let step = if v.is_bool() {
        if !boolean(v, "graticule")? {
            return Ok(None);
        }
        10.0
    } else {
        num(v, "graticule")?
    };
    check_graticule(step).map_err(to_rhai)?;
    Ok(Some(step))
}

/// `depth_rings: true` (the Earth's 410 km, 660 km and core–mantle boundary), `false`, or a
/// list of depths, for the option `field`.
pub(crate) fn depth_rings(v: &Dynamic, field: &str) -> RResult<Option<DepthRings>> {
    if v.is_bool() {
        return Ok(boolean(v, field)?.then_some(DepthRings::Earth));
    }
    Ok(Some(DepthRings::Depths(super::convert::numbers(v, field)?)))
}

pub(crate) const CONTOURS: OptionTable = OptionTable {
    function: "render_surface contours",
    options: &[
        opt("levels", Kind::Value("count | [level, ...]", "[-0.5, 0.0, 0.5]"), "10", "about this many round levels (1, 2 or 5 × 10ⁿ apart) inside the property's range, or these levels"),
        opt("property", Kind::Text("\"uz\""), "the rendered property", "the property contoured"),
        opt("grid", Kind::Value("Grid", "load_grid(\"geo.nc\")"), "the rendered grid", "another grid to contour (placed by its own coordinates; a mesh's lines come from a grid)"),
        opt("colour", Kind::Text("\"white\""), "\"black\"", "a colour name or #rrggbb (drawn as its linear RGB)"),
        opt("width", Kind::Finite, "1", "line width in pixels, > 0 and at most 64 (antialiased)"),
        opt("labels", Kind::Bool, "false", "each line's level written at its middle, the line broken under it"),
    ],
    call: "render_surface(load_grid(\"geo.nc\"), #{ width: 240, height: 180, mode: \"modulated\", contours: OPTS })",
    base: "#{}",
};

/// `contours: true` (10 round levels), a count, an array of levels, or a map ([`CONTOURS`]).
pub(crate) fn contour_style(v: &Dynamic) -> RResult<Option<ContourStyle>> {
    let levels = |v: &Dynamic, field: &str| -> RResult<ContourLevels> {
        if v.is_array() {
            let values = numbers(v, field)?;
            if values.is_empty() || values.iter().any(|x| !x.is_finite()) {
                return Err(to_rhai(crate::Error::invalid(
                    field,
                    "expected finite levels",
                )));
            }
            return Ok(ContourLevels::Values(values));
        }
        let n = num(v, field)?;
        if !((1.0..=100.0).contains(&n) && n.fract() == 0.0) {
            return Err(to_rhai(crate::Error::invalid(
                field,
                format!("expected a count of levels from 1 to 100 or an array of levels, got {n}"),
            )));
        }
        Ok(ContourLevels::Count(n as usize))
    };
    if v.is_array() || v.is_int() || v.is_float() {
        return Ok(Some(ContourStyle {
            levels: levels(v, "contours")?,
            ..ContourStyle::default()
        }));
    }
    CONTOURS.switch_or_map(v, "contours", |given| {
        let mut style = ContourStyle::default();
        if let Some(l) = given.value("levels")? {
            style.levels = levels(l, "contours.levels")?;
        }
        style.property = given.string("property")?;
        style.grid = given_grid(&given, "contours.grid")?;
        let mut line = CoastlineStyle::default();
        if let Some(c) = given.string("colour")? {
            line = line.with_colour("contours", &c).map_err(to_rhai)?;
        }
        line.width = given.num("width")?.unwrap_or(line.width);
        line.validate("contours").map_err(to_rhai)?;
        (style.colour, style.linear, style.width) = (line.colour, line.linear, line.width);
        style.labels = given.bool("labels")?.unwrap_or(false);
        Ok(style)
    })
}

pub(crate) const VECTORS: OptionTable = OptionTable {
    function: "render_surface vectors",
    options: &[
        opt("u", Kind::Text("\"uz\""), "required", "the property along x: eastward on a longitude/latitude grid"),
        opt("v", Kind::Text("\"uz\""), "required", "the property along y: northward on a longitude/latitude grid"),
        opt("grid", Kind::Value("Grid", "load_grid(\"geo.nc\")"), "the rendered grid", "another grid holding u and v (placed by its own coordinates)"),
        opt("spacing", Kind::Num(4.0, 4096.0), "32", "pixels between arrows, on a lattice centred on the picture"),
        opt("scale", Kind::NumAbove(0.0, f64::INFINITY), "the 90th percentile of the magnitudes drawn 0.9 of the spacing", "arrow length in pixels per unit of magnitude"),
        opt("reference", Kind::NumAbove(0.0, f64::INFINITY), "1, 2 or 5 × 10ⁿ nearest the 90th percentile", "the magnitude of the reference arrow drawn with its value in the lower-right corner"),
        opt("colour", Kind::Text("\"white\""), "\"black\"", "a colour name or #rrggbb (drawn as its linear RGB)"),
        opt("width", Kind::Finite, "1", "line width in pixels, > 0 and at most 64 (antialiased)"),
    ],
    call: "render_surface(load_grid(\"geo.nc\"), #{ width: 160, height: 120, mode: \"modulated\", vectors: OPTS })",
    base: "#{ u: \"uz\", v: \"uz\", spacing: 16.0 }",
};

/// `vectors: #{ u, v, … }` ([`VECTORS`]).
pub(crate) fn vector_style(v: &Dynamic) -> RResult<VectorStyle> {
    let map = v.clone().try_cast::<rhai::Map>().ok_or_else(|| {
        to_rhai(crate::Error::invalid(
            "vectors",
            format!("expected a map #{{ {} }}", VECTORS.names().join(", ")),
        ))
    })?;
    let given = VECTORS.read(&map)?;
    let component = |k: &str| -> RResult<String> {
        given.string(k)?.ok_or_else(|| {
            to_rhai(crate::Error::invalid(
                "vectors",
                format!(
                    "{k} is required: the property of the vector's component along {}",
                    if k == "u" { "x (east)" } else { "y (north)" }
                ),
            ))
        })
    };
    let mut style = VectorStyle::new(&component("u")?, &component("v")?);
    style.grid = given_grid(&given, "vectors.grid")?;
    style.spacing = given.num("spacing")?.unwrap_or(style.spacing);
    style.scale = given.num("scale")?;
    style.reference = given.num("reference")?;
    let mut line = CoastlineStyle::default();
    if let Some(c) = given.string("colour")? {
        line = line.with_colour("vectors", &c).map_err(to_rhai)?;
    }
    line.width = given.num("width")?.unwrap_or(line.width);
    line.validate("vectors").map_err(to_rhai)?;
    (style.colour, style.linear, style.width) = (line.colour, line.linear, line.width);
    Ok(style)
}

/// A `grid:` option's grid.
fn given_grid(
    given: &super::options::Given,
    field: &str,
) -> RResult<Option<std::sync::Arc<crate::model::Grid>>> {
    match given.value("grid")? {
        None => Ok(None),
        Some(g) => g
            .clone()
            .try_cast::<std::sync::Arc<crate::model::Grid>>()
            .map(Some)
            .ok_or_else(|| {
                to_rhai(crate::Error::invalid(
                    field,
                    format!("expected a grid (load_grid), got {}", g.type_name()),
                ))
            }),
    }
}
