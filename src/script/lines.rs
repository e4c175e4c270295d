//! The line options that surfaces and spherical volume renders share (coastlines, graticules,
//! depth rings): one table for the coastlines' style and one reading of each option.

use super::convert::{boolean, num, to_rhai, RResult};
use super::options::{opt, Kind, OptionTable};
use crate::datasets::coastlines::CoastResolution;
use crate::model::DepthRings;
use crate::render::surface::{check_graticule, CoastlineStyle};
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
