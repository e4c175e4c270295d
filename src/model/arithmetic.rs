//! Arithmetic on fields: `+ − × ÷` between grids on the same axes (or volumes on the same voxels)
//! and between a field and a number, and reductions over several fields (mean, minimum, maximum,
//! standard deviation), so an anomaly or a climatology is one line of a script. Values are
//! combined in f64 (a volume's f32 voxels are widened, the result rounded back to f32); a missing
//! value makes the result missing, except in reductions, which skip missing values as xarray
//! does (a node missing in every field stays missing). The standard deviation is the population
//! one (numpy's and xarray's default, ddof = 0), computed as numpy's `nanstd` does: the mean
//! first, then the mean squared deviation.
//!
//! Units follow simply: a sum or difference of fields keeps their common units (fields in other
//! units are refused: set them first), and so does a field with a number added, subtracted or
//! scaled — K − 273.15 stays "K" until `with_units` says "degC"; a product joins the units
//! ("K m"), a quotient divides them ("K/m", "1" for equal units). Grids pair their properties by
//! name, or their only properties when each has one.

use super::{Grid, Volume};
use crate::error::{Error, Result};

/// One of the four operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
}

impl Op {
    pub fn symbol(self) -> &'static str {
        match self {
            Op::Add => "+",
            Op::Sub => "-",
            Op::Mul => "*",
            Op::Div => "/",
        }
    }

    fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Op::Add => a + b,
            Op::Sub => a - b,
            Op::Mul => a * b,
            Op::Div => a / b,
        }
    }

    /// The units of `a op b` for fields in units `a` and `b` (empty: none).
    fn units(self, a: &str, b: &str) -> Result<String> {
        let (a, b) = (a.trim(), b.trim());
        let wrap = |u: &str| {
            if u.contains([' ', '/', '*']) {
                format!("({u})")
            } else {
                u.to_string()
            }
        };
        Ok(match self {
            Op::Add | Op::Sub if a == b || b.is_empty() => a.to_string(),
            Op::Add | Op::Sub if a.is_empty() => b.to_string(),
            Op::Add | Op::Sub => {
                return Err(Error::invalid(
                    "units",
                    format!(
                    "{a:?} {} {b:?}: fields in other units; give them one with with_units first",
                    self.symbol()
                ),
                ))
            }
            Op::Mul if a.is_empty() || b.is_empty() => format!("{a}{b}"),
            Op::Mul => format!("{a} {b}"),
            Op::Div if a == b => "1".to_string(),
            Op::Div if b.is_empty() => a.to_string(),
            Op::Div if a.is_empty() => format!("1/{}", wrap(b)),
            Op::Div => format!("{}/{}", wrap(a), wrap(b)),
        })
    }
}

/// Which side of an operation a number stands on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// field op number
    Right,
    /// number op field
    Left,
}

/// A reduction over several fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduction {
    Mean,
    Min,
    Max,
    Std,
}

impl Reduction {
    pub fn name(self) -> &'static str {
        match self {
            Reduction::Mean => "mean",
            Reduction::Min => "min",
            Reduction::Max => "max",
            Reduction::Std => "std",
        }
    }

    /// The reduction of the finite values among `values` (NaN when there is none); `finite` is
    /// scratch, reused from node to node.
    fn of(self, values: impl Iterator<Item = f64>, finite: &mut Vec<f64>) -> f64 {
        finite.clear();
        finite.extend(values.filter(|v| v.is_finite()));
        if finite.is_empty() {
            return f64::NAN;
        }
        let mean = || finite.iter().fold(0.0, |s, v| s + v) / finite.len() as f64;
        match self {
            Reduction::Mean => mean(),
            Reduction::Min => finite.iter().copied().fold(f64::INFINITY, f64::min),
            Reduction::Max => finite.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            Reduction::Std => {
                let m = mean();
                let sq = finite.iter().fold(0.0, |s, v| s + (v - m) * (v - m));
                (sq / finite.len() as f64).sqrt()
            }
        }
    }
}

/// That `b`'s axes are `a`'s (the same node counts, coordinates within a millionth of a node
/// spacing).
fn same_axes(a: &Grid, b: &Grid) -> Result<()> {
    let close = |p: &super::GridCoords, q: &super::GridCoords| {
        let tol = 1e-6 * p.spacing().abs().max(f64::MIN_POSITIVE);
        p.values.len() == q.values.len()
            && p.values
                .iter()
                .zip(&q.values)
                .all(|(u, v)| (u - v).abs() <= tol)
    };
    if close(a.x(), b.x()) && close(a.y(), b.y()) {
        return Ok(());
    }
    let span = |c: &super::GridCoords| {
        format!(
            "{} {}..{}",
            c.values.len(),
            c.values[0],
            c.values[c.values.len() - 1]
        )
    };
    Err(Error::invalid(
        "grid",
        format!(
            "{:?} and {:?} lie on other axes ({} by {} against {} by {}); fields combine node by node on the same axes",
            a.name(),
            b.name(),
            span(a.x()),
            span(a.y()),
            span(b.x()),
            span(b.y())
        ),
    ))
}

/// The properties that pair across `grids`: by name where every grid has it, or the only
/// property of each; as (name of the result, each grid's property index).
fn paired(grids: &[&Grid]) -> Result<Vec<(String, Vec<usize>)>> {
    let first = grids[0];
    if grids.iter().all(|g| g.property_names().len() == 1) {
        return Ok(vec![(
            first.property_at(0).0.to_string(),
            vec![0; grids.len()],
        )]);
    }
    let pairs: Vec<(String, Vec<usize>)> = first
        .property_names()
        .into_iter()
        .filter_map(|name| {
            let at: Option<Vec<usize>> = grids
                .iter()
                .map(|g| g.property_names().iter().position(|n| *n == name))
                .collect();
            at.map(|at| (name.to_string(), at))
        })
        .collect();
    if pairs.is_empty() {
        let names: Vec<String> = grids
            .iter()
            .map(|g| format!("{:?} has {:?}", g.name(), g.property_names()))
            .collect();
        return Err(Error::invalid(
            "grid",
            format!(
                "no property pairs across the grids ({}); pick one each with load_grid's variable",
                names.join(", ")
            ),
        ));
    }
    Ok(pairs)
}

/// `a op b`, node by node, for the properties that pair ([`paired`]).
pub fn grids(a: &Grid, op: Op, b: &Grid) -> Result<Grid> {
    same_axes(a, b)?;
    let mut props = Vec::new();
    for (name, at) in paired(&[a, b])? {
        let (x, y) = (a.property_at(at[0]).1, b.property_at(at[1]).1);
        let units = op.units(a.units(at[0]), b.units(at[1]))?;
        let values = x.iter().zip(y).map(|(&u, &v)| op.apply(u, v)).collect();
        props.push((name, values, units));
    }
    a.derived(&format!("{} {} {}", a.name(), op.symbol(), b.name()), props)
}

/// Every property of `g` with the number `x` on `side` of `op`.
pub fn grid_number(g: &Grid, op: Op, x: f64, side: Side) -> Result<Grid> {
    let mut props = Vec::new();
    for i in 0..g.property_names().len() {
        let (name, values) = g.property_at(i);
        let u = g.units(i);
        let units = match (op, side) {
            (Op::Div, Side::Left) => op.units("", u)?,
            _ => u.to_string(),
        };
        let values = values
            .iter()
            .map(|&v| match side {
                Side::Right => op.apply(v, x),
                Side::Left => op.apply(x, v),
            })
            .collect();
        props.push((name.to_string(), values, units));
    }
    let name = match side {
        Side::Right => format!("{} {} {x}", g.name(), op.symbol()),
        Side::Left => format!("{x} {} {}", op.symbol(), g.name()),
    };
    g.derived(&name, props)
}

/// The reduction `how` over `grids` (at least one, all on the first's axes), node by node, for
/// the properties that pair.
pub fn reduce_grids(grids: &[&Grid], how: Reduction) -> Result<Grid> {
    let Some(first) = grids.first() else {
        return Err(Error::invalid(how.name(), "expected at least one grid"));
    };
    for g in &grids[1..] {
        same_axes(first, g)?;
    }
    let mut props = Vec::new();
    for (name, at) in paired(grids)? {
        let units = first.units(at[0]).to_string();
        for (g, &i) in grids.iter().zip(&at) {
            if g.units(i).trim() != units.trim() {
                return Err(Error::invalid(
                    "units",
                    format!(
                        "{:?} is in {:?} where {:?} is in {units:?}; give them one with with_units first",
                        g.name(),
                        g.units(i),
                        first.name()
                    ),
                ));
            }
        }
        let columns: Vec<&[f64]> = grids
            .iter()
            .zip(&at)
            .map(|(g, &i)| g.property_at(i).1)
            .collect();
        let mut finite = Vec::with_capacity(grids.len());
        let values = (0..first.nx() * first.ny())
            .map(|k| how.of(columns.iter().map(|c| c[k]), &mut finite))
            .collect();
        props.push((name, values, units));
    }
    let name = format!(
        "{} of {} grids from {}",
        how.name(),
        grids.len(),
        first.name()
    );
    first.derived(&name, props)
}

/// That `b`'s voxels are `a`'s (counts, spacing, origin and geometry).
fn same_voxels(a: &Volume, b: &Volume) -> Result<()> {
    if a.dims == b.dims
        && a.spacing == b.spacing
        && a.origin == b.origin
        && a.geometry == b.geometry
    {
        return Ok(());
    }
    Err(Error::invalid(
        "volume",
        format!(
            "{:?} ({}x{}x{}) and {:?} ({}x{}x{}) lie on other voxels; volumes combine voxel by voxel on the same grid",
            a.name, a.dims[0], a.dims[1], a.dims[2], b.name, b.dims[0], b.dims[1], b.dims[2]
        ),
    ))
}

/// A volume of `data` and `units` on `like`'s voxels.
fn volume_like(like: &Volume, name: String, units: String, data: Vec<f32>) -> Volume {
    Volume {
        name,
        units,
        dims: like.dims,
        spacing: like.spacing,
        origin: like.origin,
        data,
        geometry: like.geometry.clone(),
    }
}

/// `a op b`, voxel by voxel.
pub fn volumes(a: &Volume, op: Op, b: &Volume) -> Result<Volume> {
    same_voxels(a, b)?;
    let units = op.units(&a.units, &b.units)?;
    let data = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(&u, &v)| op.apply(u as f64, v as f64) as f32)
        .collect();
    let name = format!("{} {} {}", a.name, op.symbol(), b.name);
    Ok(volume_like(a, name, units, data))
}

/// Every voxel of `v` with the number `x` on `side` of `op`.
pub fn volume_number(v: &Volume, op: Op, x: f64, side: Side) -> Result<Volume> {
    let units = match (op, side) {
        (Op::Div, Side::Left) => op.units("", &v.units)?,
        _ => v.units.clone(),
    };
    let data = v
        .data
        .iter()
        .map(|&u| match side {
            Side::Right => op.apply(u as f64, x) as f32,
            Side::Left => op.apply(x, u as f64) as f32,
        })
        .collect();
    let name = match side {
        Side::Right => format!("{} {} {x}", v.name, op.symbol()),
        Side::Left => format!("{x} {} {}", op.symbol(), v.name),
    };
    Ok(volume_like(v, name, units, data))
}

/// The reduction `how` over `volumes` (at least one, all on the first's voxels), voxel by voxel.
pub fn reduce_volumes(volumes: &[&Volume], how: Reduction) -> Result<Volume> {
    let Some(first) = volumes.first() else {
        return Err(Error::invalid(how.name(), "expected at least one volume"));
    };
    for v in &volumes[1..] {
        same_voxels(first, v)?;
        if v.units.trim() != first.units.trim() {
            return Err(Error::invalid(
                "units",
                format!(
                    "{:?} is in {:?} where {:?} is in {:?}; give them one with with_units first",
                    v.name, v.units, first.name, first.units
                ),
            ));
        }
    }
    let mut finite = Vec::with_capacity(volumes.len());
    let data = (0..first.data.len())
        .map(|k| how.of(volumes.iter().map(|v| v.data[k] as f64), &mut finite) as f32)
        .collect();
    let name = format!(
        "{} of {} volumes from {}",
        how.name(),
        volumes.len(),
        first.name
    );
    Ok(volume_like(first, name, first.units.clone(), data))
}

/// `g` with every property in `units` (a new grid, so nothing drawn from `g` is taken for it).
pub fn grid_with_units(g: &Grid, units: &str) -> Result<Grid> {
    let props = (0..g.property_names().len())
        .map(|i| {
            let (name, values) = g.property_at(i);
            (name.to_string(), values.to_vec(), units.to_string())
        })
        .collect();
    g.derived(g.name(), props)
}
