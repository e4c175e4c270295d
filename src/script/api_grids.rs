//! Script API: statistics, derived properties and subsets of grids — the surface counterpart of
//! the volume functions. Derived grids are new grids (with new identities, so the surface
//! renderer's cache never confuses them with their source).

use super::api_surface::ScriptGrid;
use super::convert::{err, int, to_rhai, RResult};
use crate::model::grid::{Grid, GridCoords};
use rhai::{Array, Dynamic, Engine, Map};
use std::sync::Arc;

/// A copy of `g` with `extra` properties appended (or replacing ones of the same name).
fn with_properties(g: &Grid, extra: Vec<(String, Vec<f64>, String)>) -> crate::Result<Grid> {
    let mut props: Vec<(String, Vec<f64>, String)> = (0..g.property_names().len())
        .map(|i| {
            let (n, v) = g.property_at(i);
            (n.to_string(), v.to_vec(), g.units(i).to_string())
        })
        .collect();
    for e in extra {
        props.retain(|p| p.0 != e.0);
        props.push(e);
    }
    g.derived(g.name(), props)
}

pub(crate) fn register(engine: &mut Engine) {
    engine.register_fn("grid_stats", grid_stats);
    engine.register_fn("grid_derive", grid_derive);
    engine.register_fn("grid_magnitude", grid_magnitude);
    engine.register_fn("grid_subset", grid_subset);
}

/// `grid_stats(g, property)`: min, max, smallest positive, finite and missing counts.
fn grid_stats(g: &mut ScriptGrid, property: &str) -> RResult<Map> {
    let v = g.property(property).map_err(to_rhai)?;
    let finite: Vec<f64> = v.iter().cloned().filter(|x| x.is_finite()).collect();
    let mut m = Map::new();
    let fold = |f: fn(f64, f64) -> f64, init: f64| finite.iter().cloned().fold(init, f);
    m.insert("min".into(), Dynamic::from(fold(f64::min, f64::INFINITY)));
    m.insert(
        "max".into(),
        Dynamic::from(fold(f64::max, f64::NEG_INFINITY)),
    );
    let min_pos = finite
        .iter()
        .cloned()
        .filter(|x| *x > 0.0)
        .fold(f64::INFINITY, f64::min);
    m.insert(
        "min_positive".into(),
        if min_pos.is_finite() {
            Dynamic::from(min_pos)
        } else {
            Dynamic::UNIT
        },
    );
    m.insert("finite".into(), Dynamic::from(finite.len() as i64));
    m.insert(
        "missing".into(),
        Dynamic::from((v.len() - finite.len()) as i64),
    );
    Ok(m)
}

/// `grid_derive(g, property, op, name)`: a copy of `g` with property `name` = op(property).
fn grid_derive(g: &mut ScriptGrid, property: &str, op: &str, name: &str) -> RResult<ScriptGrid> {
    let i = g.property_index(property).map_err(to_rhai)?;
    let v = g.property(property).map_err(to_rhai)?;
    let (data, units): (Vec<f64>, String) = match op {
        // Zeros and negatives have no logarithm: they become missing values (NaN).
        "log10" => (
            v.iter()
                .map(|&x| if x > 0.0 { x.log10() } else { f64::NAN })
                .collect(),
            format!("log10({})", g.units(i)),
        ),
        "abs" => (v.iter().map(|x| x.abs()).collect(), g.units(i).to_string()),
        _ => {
            return err(
                "grid_derive",
                format!("unknown operation {op:?}; known: log10, abs"),
            )
        }
    };
    Ok(Arc::new(
        with_properties(g, vec![(name.to_string(), data, units)]).map_err(to_rhai)?,
    ))
}

/// `grid_magnitude(g, [p, q, ...], name)`: a copy of `g` with property `name` = the pointwise
/// Euclidean norm of the named properties (in the units of the first).
fn grid_magnitude(g: &mut ScriptGrid, properties: Array, name: &str) -> RResult<ScriptGrid> {
    let names: Vec<String> = properties
        .into_iter()
        .map(|p| {
            p.into_string().map_err(|t| {
                to_rhai(crate::Error::invalid(
                    "grid_magnitude",
                    format!("expected property names, got {t}"),
                ))
            })
        })
        .collect::<RResult<_>>()?;
    if names.is_empty() {
        return err("grid_magnitude", "expected at least one property name");
    }
    let parts: Vec<&[f64]> = names
        .iter()
        .map(|n| g.property(n))
        .collect::<crate::Result<_>>()
        .map_err(to_rhai)?;
    let data = (0..parts[0].len())
        .map(|k| parts.iter().map(|p| p[k] * p[k]).sum::<f64>().sqrt())
        .collect();
    let units = g
        .units(g.property_index(&names[0]).map_err(to_rhai)?)
        .to_string();
    Ok(Arc::new(
        with_properties(g, vec![(name.to_string(), data, units)]).map_err(to_rhai)?,
    ))
}

/// `grid_subset(g, [i, j], [i, j])`: the nodes from lo (inclusive) to hi (exclusive), corners
/// clamped to the grid, with every property, the elevation and the units.
fn grid_subset(g: &mut ScriptGrid, lo: Array, hi: Array) -> RResult<ScriptGrid> {
    let corner = |a: &Array, what: &str| -> RResult<[usize; 2]> {
        if a.len() != 2 {
            return err(what, "expected [i, j]");
        }
        Ok([
            int(&a[0], what)?.clamp(0, g.nx() as i64) as usize,
            int(&a[1], what)?.clamp(0, g.ny() as i64) as usize,
        ])
    };
    let (lo, hi) = (
        corner(&lo, "grid_subset lo")?,
        corner(&hi, "grid_subset hi")?,
    );
    if hi[0] <= lo[0] || hi[1] <= lo[1] {
        return err(
            "grid_subset",
            format!(
                "expected lo < hi within [{}, {}], got {lo:?} .. {hi:?}",
                g.nx(),
                g.ny()
            ),
        );
    }
    let cut = |v: &[f64]| -> Vec<f64> {
        (lo[1]..hi[1])
            .flat_map(|j| v[j * g.nx() + lo[0]..j * g.nx() + hi[0]].to_vec())
            .collect()
    };
    let axis = |c: &GridCoords, a: usize, b: usize| GridCoords {
        name: c.name.clone(),
        units: c.units.clone(),
        values: c.values[a..b].to_vec(),
        kind: c.kind,
        edges: None,
    };
    let props: Vec<(String, Vec<f64>)> = (0..g.property_names().len())
        .map(|i| {
            let (n, v) = g.property_at(i);
            (n.to_string(), cut(v))
        })
        .collect();
    let mut out = Grid::with_coords(
        g.name(),
        axis(g.x(), lo[0], hi[0]),
        axis(g.y(), lo[1], hi[1]),
        props,
        g.elevation().map(cut),
    )
    .map_err(to_rhai)?;
    for i in 0..g.property_names().len() {
        out.set_units(g.property_at(i).0, g.units(i))
            .map_err(to_rhai)?;
    }
    out.keep_placement_of(g);
    Ok(Arc::new(out))
}
