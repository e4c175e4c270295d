//! Script API for looking inside volumes: `section(volume, #{...})` (a great-circle section of a
//! spherical volume), `slice(volume, #{...})` (an axis slice of a box), `slice_plane(volume,
//! #{...})` (an oblique plane of a box) and `save_grid(grid, path)`, which writes any grid as CF
//! NetCDF under the output folder. Sections and slices are grids, so `render_surface` draws them
//! with interference fringes and framed axes.

use super::api_render::ScriptVolume;
use super::api_surface::ScriptGrid;
use super::convert::{err, int, pair, to_rhai, vec3, RResult};
use super::options::{opt, Given, Kind, OptionTable};
use super::ScriptHost;
use crate::model::section::{
    axis_slice, great_circle_section, plane_slice, PlaneSpec, SectionSpec, SliceSpec,
    MAX_SECTION_SIDE,
};
use crate::model::{Geometry, Missing};
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

/// The `missing` option of every function that samples a volume.
macro_rules! missing_option {
    () => {
        opt(
            "missing",
            Kind::Choice(Missing::NAMES),
            "\"strict\"",
            "strict: a missing voxel among a sample's 8 neighbours makes it missing; renormalise: the finite neighbours' weights renormalised, so a missing voxel costs only its own cells",
        )
    };
}

pub(crate) const SECTION: OptionTable = OptionTable {
    function: "section",
    options: &[
        opt("from", Kind::Value("[latitude, longitude] in degrees", "[0.0, 0.0]"), "required", "where the section starts"),
        opt("to", Kind::Value("[latitude, longitude] in degrees", "[10.0, 20.0]"), "required", "where it ends: the short great-circle arc joins them (not the same point, not antipodal)"),
        opt("depth", Kind::Value("[top, bottom] in the volume's length unit", "[100.0, 200.0]"), "the volume's depths", "depths of the first and last rows below the surface (planet radius − radius), within the volume"),
        opt("n", Kind::Value("[columns, rows], integers 2..=16384", "[3, 2]"), "[256, 128]", "nodes along the arc and down"),
        missing_option!(),
    ],
    call: "section(load_volume(generate(\"mantle\", #{ n: 4, native: true })), OPTS)",
    base: "#{ from: [0.0, 0.0], to: [10.0, 20.0] }",
};

pub(crate) const SLICE_PLANE: OptionTable = OptionTable {
    function: "slice_plane",
    options: &[
        opt("origin", Kind::Value("[x, y, z]", "[0.0, 0.0, 0.0]"), "required", "a point of the plane (world coordinates)"),
        opt("normal", Kind::Value("[x, y, z], not zero", "[1.0, 1.0, 0.0]"), "required", "the plane's normal"),
        opt("n", Kind::Value("[nodes along u, nodes along v], integers 2..=16384", "[3, 2]"), "[256, 256]", "nodes over the plane's part of the box (u: the world axis least aligned with the normal, made perpendicular to it; v = normal × u)"),
        missing_option!(),
    ],
    call: "slice_plane(generate_mantle(#{ n: 4 }), OPTS)",
    base: "#{ origin: [0.0, 0.0, 0.0], normal: [0.0, 0.0, 1.0] }",
};

pub(crate) const SLICE: OptionTable = OptionTable {
    function: "slice",
    options: &[
        opt(
            "axis",
            Kind::Choice(&["x", "y", "z"]),
            "required",
            "the world axis the plane is perpendicular to",
        ),
        opt(
            "at",
            Kind::Finite,
            "required",
            "the plane's world coordinate along that axis, within the volume",
        ),
        missing_option!(),
    ],
    call: "slice(generate_mantle(#{ n: 4 }), OPTS)",
    base: "#{ axis: \"x\", at: 0.0 }",
};

fn missing(given: &Given) -> RResult<Missing> {
    match given.string("missing")? {
        Some(m) => Missing::parse(&m).map_err(to_rhai),
        None => Ok(Missing::Strict),
    }
}

/// `section`'s options ([`SECTION`]) for the volume `v`.
fn section_spec(v: &crate::model::Volume, opts: &Map) -> RResult<SectionSpec> {
    let given = SECTION.read(opts)?;
    let required = |name: &str| -> RResult<[f64; 2]> {
        match given.value(name)? {
            Some(x) => pair(x, &format!("section {name}")),
            None => err(
                "section",
                format!("expected #{{ from: [lat, lon], to: [lat, lon] }}: {name} is missing"),
            ),
        }
    };
    let (from, to) = (required("from")?, required("to")?);
    let depth = match (given.value("depth")?, &v.geometry) {
        (Some(d), _) => pair(d, "section depth")?,
        (None, Geometry::Spherical(g)) => {
            [g.planet_radius - g.radius.hi, g.planet_radius - g.radius.lo]
        }
        // A box is refused by the section itself, naming what to use instead.
        (None, _) => [0.0, 1.0],
    };
    let n = match given.value("n")? {
        Some(x) => counts(x, "section n")?,
        None => [256, 128],
    };
    Ok(SectionSpec {
        from,
        to,
        depth,
        n,
        missing: missing(&given)?,
    })
}

/// An `[a, b]` pair of node counts, each clamped to just past the largest allowed (the model
/// refuses it, quoting it).
fn counts(v: &Dynamic, field: &str) -> RResult<[usize; 2]> {
    let a = v
        .clone()
        .into_array()
        .or_else(|t| err(field, format!("expected [a, b], got {t}")))?;
    if a.len() != 2 {
        return err(field, format!("expected 2 integers, got {}", a.len()));
    }
    let count = |d: &Dynamic| -> RResult<usize> {
        Ok(int(d, field)?.clamp(0, MAX_SECTION_SIDE as i64 + 1) as usize)
    };
    Ok([count(&a[0])?, count(&a[1])?])
}

fn slice_spec(opts: &Map) -> RResult<SliceSpec> {
    let given = SLICE.read(opts)?;
    let (Some(axis), Some(at)) = (given.string("axis")?, given.num("at")?) else {
        return err(
            "slice",
            "expected #{ axis: \"x\" | \"y\" | \"z\", at: coordinate }",
        );
    };
    Ok(SliceSpec {
        axis: ["x", "y", "z"].iter().position(|a| *a == axis).unwrap_or(0),
        at,
        missing: missing(&given)?,
    })
}

fn plane_spec(opts: &Map) -> RResult<PlaneSpec> {
    let given = SLICE_PLANE.read(opts)?;
    let (Some(origin), Some(normal)) = (given.value("origin")?, given.value("normal")?) else {
        return err(
            "slice_plane",
            "expected #{ origin: [x, y, z], normal: [x, y, z] }",
        );
    };
    Ok(PlaneSpec {
        origin: vec3(origin, "slice_plane origin")?,
        normal: vec3(normal, "slice_plane normal")?,
        n: match given.value("n")? {
            Some(n) => counts(n, "slice n")?,
            None => [256, 256],
        },
        missing: missing(&given)?,
    })
}

pub(crate) fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
    engine.register_fn(
        "section",
        |v: &mut ScriptVolume, opts: Map| -> RResult<ScriptGrid> {
            let spec = section_spec(v, &opts)?;
            Ok(Arc::new(great_circle_section(v, &spec).map_err(to_rhai)?))
        },
    );
    engine.register_fn(
        "slice",
        |v: &mut ScriptVolume, opts: Map| -> RResult<ScriptGrid> {
            let spec = slice_spec(&opts)?;
            Ok(Arc::new(axis_slice(v, &spec).map_err(to_rhai)?))
        },
    );
    engine.register_fn(
        "slice_plane",
        |v: &mut ScriptVolume, opts: Map| -> RResult<ScriptGrid> {
            let spec = plane_spec(&opts)?;
            Ok(Arc::new(plane_slice(v, &spec).map_err(to_rhai)?))
        },
    );
    engine.register_fn(
        "save_grid",
        move |grid: &mut ScriptGrid, path: &str| -> RResult<()> {
            let p = host.sandbox.write_path(path).map_err(to_rhai)?;
            if crate::datasets::Format::from_extension(&p) != Some(crate::datasets::Format::NetCdf)
            {
                return err(
                    "save_grid",
                    format!("{path}: expected a NetCDF file name ending in .nc"),
                );
            }
            if host.planned(&p) || host.already_done(&p) || !host.write_outputs {
                return Ok(());
            }
            host.write_output(&p, |p| crate::datasets::grid_out::save_grid(grid, p))
                .map_err(to_rhai)?;
            Ok(())
        },
    );
}
