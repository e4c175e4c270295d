//! Script API: dataset generation through the cache. `generate(kind, options)` returns the path
//! of the cached NetCDF file (generated on a miss), which `load_grid` / `load_volume` then read;
//! the cache folder is readable by every script. The selection options that `load_volume`,
//! `load_grid` and `open_volume` share (`index`, `at`) are read here, and `times(path)` lists a
//! file's time steps.

use super::convert::{err, int, ints, to_rhai, RResult};
use super::options::{opt, Given, Kind, OptionSpec, OptionTable};
use super::ScriptHost;
use crate::datasets::generate::{
    BathymetrySource, Job, MantleJob, OkadaJob, OutputFormat, TsunamiJob, MAX_TSUNAMI_N,
};
use crate::datasets::mantle::{MantleField, MantleFields, MantleOptions, MAX_FEATURES, MAX_N};
use crate::datasets::okada::{DepthRef, MAX_GRID_SIDE};
use crate::datasets::select::{At, Selection};
use crate::datasets::tsunami::Boundary;
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

const MANTLE_FIELDS: &[&str] = &["temperature", "fluctuation", "viscosity"];

/// The generator's options, shared by `generate_mantle` and `generate("mantle", ...)`, followed
/// by the caller's own.
macro_rules! mantle_option_specs {
    ($($own:expr),* $(,)?) => {
        [
            opt(
                "n",
                Kind::Int(2, MAX_N as i64),
                "513",
                "cells per axis of the cube [-1, 1]³",
            ),
            opt(
                "seed",
                Kind::Int(0, i64::MAX),
                "1",
                "random seed of the plumes and slabs",
            ),
            opt(
                "field",
                Kind::Choice(MANTLE_FIELDS),
                "\"fluctuation\"",
                "the field generated",
            ),
            opt(
                "plumes",
                Kind::Int(0, MAX_FEATURES as i64),
                "12",
                "hot plumes rising from the core–mantle boundary",
            ),
            opt(
                "slabs",
                Kind::Int(0, MAX_FEATURES as i64),
                "8",
                "cold slabs sinking from the surface",
            ),
            $($own),*
        ]
    };
}

pub(crate) const GENERATE_MANTLE: OptionTable = OptionTable {
    function: "generate_mantle",
    options: &mantle_option_specs!(),
    call: "generate_mantle(OPTS)",
    base: "#{ n: 4 }",
};

pub(crate) const GENERATE_MANTLE_FILE: OptionTable = OptionTable {
    function: "generate mantle",
    options: &mantle_option_specs!(opt(
        "native",
        Kind::Bool,
        "false",
        "keep the spherical grid: CF on radius (km), latitude and longitude, loaded as a spherical volume"
    )),
    call: "generate(\"mantle\", OPTS)",
    base: "#{ n: 4 }",
};

pub(crate) const GENERATE_OKADA: OptionTable = OptionTable {
    function: "generate okada",
    options: &[
        opt("strike", Kind::Finite, "0", "fault strike, degrees clockwise from north"),
        opt("dip", Kind::Num(-90.0, 90.0), "6", "fault dip, degrees"),
        opt("rake", Kind::Finite, "-90", "slip direction on the fault, degrees"),
        opt("slip", Kind::Finite, "10", "slip, m"),
        opt("length", Kind::NumAbove(0.0, 1e8), "100000", "along strike, m"),
        opt("width", Kind::NumAbove(0.0, 1e8), "50000", "down dip, m"),
        opt("depth", Kind::NumAbove(0.0, 1e7), "50000", "depth of the reference point, m (positive down; the whole fault must lie below the surface)"),
        opt("depth_ref", Kind::Choice(&["top", "centroid", "bottom"]), "\"centroid\"", "the point of the fault that depth gives"),
        opt("extent", Kind::NumAbove(0.0, 1e9), "1000000", "side of the square surface grid, m"),
        opt("n", Kind::Int(2, MAX_GRID_SIDE as i64), "1001", "nodes per side"),
    ],
    call: "generate(\"okada\", OPTS)",
    base: "#{ n: 3, depth_ref: \"top\" }",
};

pub(crate) const GENERATE_TSUNAMI: OptionTable = OptionTable {
    function: "generate tsunami",
    options: &[
        opt(
            "n",
            Kind::Int(2, MAX_TSUNAMI_N as i64),
            "1000",
            "cells per side of the synthetic basin",
        ),
        opt(
            "extent",
            Kind::NumAbove(0.0, 1e8),
            "2000000",
            "side of the basin, m",
        ),
        opt(
            "duration",
            Kind::NumAbove(0.0, 1e7),
            "7200",
            "simulated time, s",
        ),
        opt(
            "boundary",
            Kind::Choice(&["open", "reflective"]),
            "\"open\"",
            "what the basin's edges do to waves",
        ),
    ],
    call: "generate(\"tsunami\", OPTS)",
    base: "#{ n: 8, duration: 1.0 }",
};

/// The mantle options of `generate("mantle", #{…})` (`table` [`GENERATE_MANTLE_FILE`]) and
/// `generate_mantle(#{…})` ([`GENERATE_MANTLE`]), with the one field to generate and whether
/// to keep the native grid.
pub(super) fn mantle_options(
    opts: &Map,
    table: &'static OptionTable,
) -> RResult<(MantleOptions, MantleField, bool)> {
    let given = table.read(opts)?;
    let mut o = MantleOptions::default();
    o.n = given.count("n")?.unwrap_or(o.n);
    o.seed = given.int("seed")?.map_or(o.seed, |s| s as u64);
    o.plumes = given.count("plumes")?.unwrap_or(o.plumes);
    o.slabs = given.count("slabs")?.unwrap_or(o.slabs);
    let field = match given.string("field")? {
        Some(name) => MantleField::parse(&name).map_err(to_rhai)?,
        None => MantleField::Fluctuation,
    };
    o.fields = MantleFields::only(field);
    let native = given.has("native") && given.bool("native")? == Some(true);
    Ok((o, field, native))
}

fn okada_job(opts: &Map) -> RResult<Job> {
    let given = GENERATE_OKADA.read(opts)?;
    let mut job = OkadaJob::default();
    let seg = &mut job.segments[0];
    let set = |target: &mut f64, name: &str| -> RResult<()> {
        if let Some(x) = given.num(name)? {
            *target = x;
        }
        Ok(())
    };
    set(&mut seg.strike_deg, "strike")?;
    set(&mut seg.dip_deg, "dip")?;
    set(&mut seg.rake_deg, "rake")?;
    set(&mut seg.slip_m, "slip")?;
    set(&mut seg.length_m, "length")?;
    set(&mut seg.width_m, "width")?;
    set(&mut seg.depth_m, "depth")?;
    if let Some(r) = given.string("depth_ref")? {
        seg.depth_ref = DepthRef::parse(&r).map_err(to_rhai)?;
    }
    set(&mut job.extent_m, "extent")?;
    job.n = given.count("n")?.unwrap_or(job.n);
    Ok(Job::Okada(job))
}

fn tsunami_job(opts: &Map) -> RResult<Job> {
    let given = GENERATE_TSUNAMI.read(opts)?;
    let mut job = TsunamiJob::default();
    if let Some(d) = given.num("duration")? {
        job.options.duration_s = d;
    }
    if let Some(b) = given.string("boundary")? {
        job.options.boundary = if b == "reflective" {
            Boundary::Reflective
        } else {
            Boundary::Open
        };
    }
    // The default basin is synthetic; n and extent size it.
    if let BathymetrySource::Synthetic { n, extent_m } = &mut job.bathymetry {
        *n = given.count("n")?.unwrap_or(*n);
        *extent_m = given.num("extent")?.unwrap_or(*extent_m);
    }
    Ok(Job::Tsunami(job))
}

/// The selection options of the loading functions, as their tables list them.
pub(crate) const SELECT_INDEX: OptionSpec = opt(
    "index",
    Kind::Value("map of dimension: integer", "#{}"),
    "none",
    "fix dimensions at positions, as xarray's isel: #{ time: 5 } (NetCDF; the time of a MintPy time series)",
);
pub(crate) const SELECT_AT: OptionSpec = opt(
    "at",
    Kind::Value("map of dimension: number or ISO 8601 date", "#{}"),
    "none",
    "fix dimensions at coordinate values, as xarray's sel: #{ depth: 600.0, time: \"2011-03-11T06:00\" } (the nearest time; between two levels, linear interpolation); on model levels with CF formula_terms or a GRIB PV array, #{ pressure: 500.0 } (hPa, each column in ln p as vinth2p), #{ height: z } or #{ depth: d } (m)",
);

/// The `index` and `at` options of a loading function.
pub(crate) fn selection(given: &Given) -> RResult<Selection> {
    let mut sel = Selection::default();
    let map = |name: &str, v: Option<&Dynamic>| -> RResult<Map> {
        match v {
            None => Ok(Map::new()),
            Some(v) => match v.clone().try_cast::<Map>() {
                Some(m) => Ok(m),
                None => err(
                    name,
                    format!("expected a map of dimension names, got {}", v.type_name()),
                ),
            },
        }
    };
    for (dim, v) in map("index", given.value("index")?)? {
        sel.index
            .push((dim.to_string(), int(&v, &format!("index.{dim}"))?));
    }
    for (dim, v) in map("at", given.value("at")?)? {
        let at = if let Ok(s) = v.clone().into_string() {
            At::Date(s)
        } else {
            let x = super::convert::num(&v, &format!("at.{dim}"))?;
            if !x.is_finite() {
                return err(&format!("at.{dim}"), "expected a finite number or a date");
            }
            At::Value(x)
        };
        sel.at.push((dim.to_string(), at));
    }
    Ok(sel)
}

fn job_of(kind: &str, opts: &Map) -> RResult<Job> {
    match kind {
        "okada" => okada_job(opts),
        "tsunami" => tsunami_job(opts),
        "mantle" => {
            let (options, _, native) = mantle_options(opts, &GENERATE_MANTLE_FILE)?;
            Ok(Job::Mantle(MantleJob { options, native }))
        }
        other => super::convert::err(
            "generate",
            format!("unknown dataset {other:?}; known: okada, tsunami, mantle"),
        ),
    }
}

/// `times(path[, variable])`: the steps of the CF time axis of a variable (the named one, the one
/// a `"file.nc:var"` path names, else the file's first data variable that has one), as
/// `[#{ index, date }]` with ISO 8601 dates.
pub(crate) const SERIES_RANGE: OptionTable = OptionTable {
    function: "series_range",
    options: &[
        opt("variable", Kind::Text("\"eta\""), "the first data variable with a time axis", "the variable (\"f.nc:eta\" also picks it)"),
        opt("steps", Kind::Value("array of integers", "[0, 2]"), "every step", "positions along the time axis, as times() numbers them"),
        opt("robust", Kind::Bool, "false", "the 2nd and 98th percentiles instead of the minimum and maximum (as xarray's robust plots)"),
        opt("centre", Kind::Finite, "none", "widen the range to be symmetric about this value (a diverging map's middle)"),
    ],
    call: "series_range(\"series.nc\", OPTS)",
    base: "#{}",
};

/// `series_range(path[, options])`: the value range over the steps of a time series.
fn series_range(host: &ScriptHost, path: &str, opts: &Map) -> RResult<rhai::Array> {
    let given = SERIES_RANGE.read(opts)?;
    let (p, from_path) = host.sandbox.read_data_path(path).map_err(to_rhai)?;
    let steps = given
        .value("steps")?
        .map(|v| ints(v, "series_range.steps"))
        .transpose()?;
    let o = crate::datasets::series::SeriesOptions {
        variable: given.string("variable")?.or(from_path),
        steps,
        robust: given.bool("robust")?.unwrap_or(false),
        centre: given.num("centre")?,
    };
    let [lo, hi] = crate::datasets::series::series_range(&p, &o).map_err(to_rhai)?;
    Ok(vec![Dynamic::from(lo), Dynamic::from(hi)])
}

fn times(host: &ScriptHost, path: &str, variable: Option<&str>) -> RResult<rhai::Array> {
    let (p, from_path) = host.sandbox.read_data_path(path).map_err(to_rhai)?;
    let variable = variable.map(str::to_string).or(from_path);
    let steps = crate::datasets::time_steps(&p, variable.as_deref()).map_err(to_rhai)?;
    Ok(steps
        .into_iter()
        .enumerate()
        .map(|(i, date)| {
            let mut m = Map::new();
            m.insert("index".into(), Dynamic::from(i as i64));
            m.insert("date".into(), Dynamic::from(date));
            Dynamic::from(m)
        })
        .collect())
}

pub(crate) fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn("series_range", move |path: &str| -> RResult<rhai::Array> {
        series_range(&h, path, &Map::new())
    });
    let h = host.clone();
    engine.register_fn(
        "series_range",
        move |path: &str, opts: Map| -> RResult<rhai::Array> { series_range(&h, path, &opts) },
    );
    let h = host.clone();
    engine.register_fn("times", move |path: &str| -> RResult<rhai::Array> {
        times(&h, path, None)
    });
    let h = host.clone();
    engine.register_fn(
        "times",
        move |path: &str, variable: &str| -> RResult<rhai::Array> {
            times(&h, path, Some(variable))
        },
    );
    engine.register_fn(
        "generate",
        move |kind: &str, opts: Map| -> RResult<String> {
            let job = job_of(kind, &opts)?;
            let path = job
                .run_cached(OutputFormat::NetCdf, &mut |_| host.check_deadline())
                .map_err(to_rhai)?;
            Ok(path.display().to_string())
        },
    );
}
