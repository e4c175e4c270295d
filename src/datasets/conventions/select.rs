//! Selection by dimension, as xarray's `isel` and `sel`: a NetCDF variable read with some of its
//! dimensions fixed, by position (`index: #{ time: 5 }`) or by coordinate value
//! (`at: #{ depth: 600.0, time: "2011-03-11T06:00" }`), has those dimensions no more. A date
//! picks the nearest step of a CF time axis; a number the level it names, or, between two
//! levels of a numeric axis, their linear interpolation (as xarray's `interp`, and the loaded
//! variable's description says so). A value more than half a step beyond the axis's ends is an
//! error, as are an unknown dimension, an index out of range and a date that is not ISO 8601.
//! Only the picked hyperslabs are read.

use std::path::Path;

use super::cf;
use super::cf_time::TimeUnits;
use crate::datasets::netcdf::{self, NcVariable};
use crate::datasets::readers::variables;
use crate::error::{Error, Result};

/// A coordinate value to select at.
#[derive(Clone, Debug, PartialEq)]
pub enum At {
    /// A value in the coordinate's units.
    Value(f64),
    /// An ISO 8601 date on a CF time axis.
    Date(String),
}

/// Dimensions fixed by position (`index`) or coordinate value (`at`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection {
    pub index: Vec<(String, i64)>,
    pub at: Vec<(String, At)>,
}

impl Selection {
    pub fn is_empty(&self) -> bool {
        self.index.is_empty() && self.at.is_empty()
    }

    /// The dimensions the selection fixes.
    pub(crate) fn dims(&self) -> impl Iterator<Item = &str> {
        self.index
            .iter()
            .map(|(d, _)| d.as_str())
            .chain(self.at.iter().map(|(d, _)| d.as_str()))
    }
}

/// What a read takes from one dimension.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pick {
    All,
    One(usize),
    /// Linear interpolation: `(1 - w) * [lo] + w * [hi]`.
    Between(usize, usize, f64),
}

/// How a variable is read under a selection: one pick per dimension and a description of each
/// selected one.
#[derive(Clone, Debug)]
pub(crate) struct Plan {
    picks: Vec<Pick>,
    pub notes: Vec<String>,
}

impl Plan {
    /// The dimensions the read keeps.
    pub(crate) fn kept<'a>(&self, dims: &'a [(String, usize)]) -> Vec<&'a (String, usize)> {
        dims.iter()
            .zip(&self.picks)
            .filter(|(_, p)| **p == Pick::All)
            .map(|(d, _)| d)
            .collect()
    }

    /// The plan of a selection that fixes only positions (`open_volume`'s hyperslabs):
    /// `Some(i)` per fixed dimension, `None` for a kept one, or an error naming the
    /// interpolated dimension.
    pub(crate) fn positions(&self, path: &Path, var: &str) -> Result<Vec<Option<usize>>> {
        self.picks
            .iter()
            .map(|p| match p {
                Pick::All => Ok(None),
                Pick::One(i) => Ok(Some(*i)),
                Pick::Between(..) => Err(Error::format(
                    path,
                    format!("variable '{var}': an `at` between two levels interpolates, which only load_volume and load_grid do; choose a level"),
                )),
            })
            .collect()
    }
}

/// The plan of `sel` on variable `var` of dimensions `dims`.
pub(crate) fn plan(
    path: &Path,
    var: &str,
    dims: &[(String, usize)],
    sel: &Selection,
) -> Result<Plan> {
    let mut picks = vec![Pick::All; dims.len()];
    let mut notes = Vec::new();
    let field = |dim: &str| format!("{}: variable '{var}', dimension '{dim}'", path.display());
    for dim in sel.dims() {
        if !dims.iter().any(|(d, _)| d == dim) {
            let names: Vec<&str> = dims.iter().map(|(d, _)| d.as_str()).collect();
            return Err(Error::format(
                path,
                format!(
                    "variable '{var}' has no dimension '{dim}'; its dimensions are {}",
                    names.join(", ")
                ),
            ));
        }
        if sel.dims().filter(|d| d == &dim).count() > 1 {
            return Err(Error::invalid(field(dim), "selected twice"));
        }
    }
    for (dim, i) in &sel.index {
        let a = dims.iter().position(|(d, _)| d == dim).expect("checked");
        let n = dims[a].1;
        if *i < 0 || *i as usize >= n {
            return Err(Error::invalid(
                field(dim),
                format!("index {i} is out of range; expected 0..={}", n as i64 - 1),
            ));
        }
        picks[a] = Pick::One(*i as usize);
        notes.push(format!(
            "{dim} index {i}{}",
            date_note(path, dim, *i as usize)?
        ));
    }
    for (dim, at) in &sel.at {
        let a = dims.iter().position(|(d, _)| d == dim).expect("checked");
        let (pick, note) = locate(path, dim, at).map_err(|e| match e {
            Error::Invalid { msg, .. } => Error::invalid(field(dim), msg),
            other => other,
        })?;
        picks[a] = pick;
        notes.push(note);
    }
    Ok(Plan { picks, notes })
}

/// " (2011-03-11T06:00:00)" when `dim` is a CF time axis, else "".
fn date_note(path: &Path, dim: &str, i: usize) -> Result<String> {
    // Unchecked: an index needs no monotonic axis, and an undecodable one gives no date.
    let Some(coord) = variables::coordinate_variable(path, dim)? else {
        return Ok(String::new());
    };
    Ok(match cf::time_decoding(path, &coord) {
        cf::TimeDecoding::Dates { dates, .. } => dates
            .get(i)
            .cloned()
            .flatten()
            .map_or(String::new(), |d| format!(" ({d})")),
        cf::TimeDecoding::Raw { .. } => String::new(),
    })
}

/// The pick of coordinate value `at` on dimension `dim`, and its description.
fn locate(path: &Path, dim: &str, at: &At) -> Result<(Pick, String)> {
    let Some(coord) = cf::read_coordinate(path, dim)? else {
        return Err(Error::invalid(
            dim,
            "has no coordinate variable to select a value on; choose a position with index",
        ));
    };
    let time = cf::time_units(path, &coord)?;
    locate_on(
        dim,
        at,
        &coord.data,
        coord.units.as_deref().unwrap_or(""),
        time.as_ref(),
    )
}

/// The pick of coordinate value `at` on an axis of coordinates `c` (in `units`; a time axis
/// with `time`), and its description.
fn locate_on(
    dim: &str,
    at: &At,
    c: &[f64],
    units: &str,
    time: Option<&TimeUnits>,
) -> Result<(Pick, String)> {
    let (target, shown) = match (at, time) {
        (At::Date(date), Some(t)) => (t.value(date)?, date.clone()),
        (At::Date(date), None) => {
            return Err(Error::invalid(
                dim,
                format!("'{date}' is a date but the axis is not CF time (units '{units}')"),
            ))
        }
        (At::Value(v), _) => (*v, format!("{v} {units}").trim_end().to_string()),
    };
    let n = c.len();
    let half = |i: usize, j: usize| 0.5 * (c[i] - c[j]).abs();
    let (lo, hi) = (c[0].min(c[n - 1]), c[0].max(c[n - 1]));
    let reach = if n > 1 {
        half(0, 1).max(half(n - 1, n - 2))
    } else {
        0.0
    };
    let show = |i: usize| match time {
        Some(t) => t.date(c[i]),
        None => format!("{}", c[i]),
    };
    if target < lo - reach || target > hi + reach || !target.is_finite() {
        return Err(Error::invalid(
            dim,
            format!(
                "{shown} is outside the axis ({} to {}, half a step beyond allowed)",
                show(0),
                show(n - 1)
            ),
        ));
    }
    let nearest = (0..n)
        .min_by(|&i, &j| (c[i] - target).abs().total_cmp(&(c[j] - target).abs()))
        .expect("an axis has a value");
    let exact = (c[nearest] - target).abs() <= 1e-9 * c[nearest].abs().max(1.0);
    if time.is_some() || exact || target <= lo || target >= hi {
        return Ok((
            Pick::One(nearest),
            format!("{dim} {} (index {nearest})", show(nearest)),
        ));
    }
    // Strictly between two levels of a numeric axis: the pair that brackets the value.
    let k = (0..n - 1)
        .find(|&k| (c[k] - target) * (c[k + 1] - target) < 0.0)
        .expect("inside the axis and on no level");
    let w = (target - c[k]) / (c[k + 1] - c[k]);
    Ok((
        Pick::Between(k, k + 1, w),
        format!(
            "{dim} {shown}, interpolated linearly between {} (index {k}) and {} (index {})",
            show(k),
            show(k + 1),
            k + 1
        ),
    ))
}

/// Reads variable `var` under `plan`: the picked hyperslab, or for interpolated dimensions the
/// weighted sum of the hyperslabs on each side.
pub(crate) fn read(path: &Path, var: &str, plan: &Plan) -> Result<NcVariable> {
    let between: Vec<usize> = (0..plan.picks.len())
        .filter(|&a| matches!(plan.picks[a], Pick::Between(..)))
        .collect();
    let mut total: Option<NcVariable> = None;
    for corner in 0..1usize << between.len() {
        let mut weight = 1.0;
        let picks: Vec<Option<usize>> = plan
            .picks
            .iter()
            .enumerate()
            .map(|(a, p)| match *p {
                Pick::All => None,
                Pick::One(i) => Some(i),
                Pick::Between(lo, hi, w) => {
                    let upper = (corner >> between.iter().position(|&b| b == a).unwrap_or(0)) & 1;
                    weight *= if upper == 1 { w } else { 1.0 - w };
                    Some(if upper == 1 { hi } else { lo })
                }
            })
            .collect();
        let part = variables::read_variable_picked(path, var, &picks)?;
        total = Some(match total {
            None => NcVariable {
                data: part.data.iter().map(|v| weight * v).collect(),
                ..part
            },
            Some(mut sum) => {
                sum.data
                    .iter_mut()
                    .zip(&part.data)
                    .for_each(|(s, v)| *s += weight * v);
                sum.stored_nan = sum.stored_nan.max(part.stored_nan);
                sum
            }
        });
    }
    Ok(total.expect("at least one corner"))
}

/// Refuses to read a variable whose kept dimensions include a CF time axis of more than one
/// step as space: the error names the axis, its length and dates and how to choose a step.
pub(crate) fn refuse_time(path: &Path, var: &str, kept: &[&(String, usize)]) -> Result<()> {
    for (dim, n) in kept {
        if *n < 2 {
            continue;
        }
        let Some(coord) = variables::coordinate_variable(path, dim)? else {
            continue;
        };
        if !matches!(cf::axis_role(path, &coord), Ok(cf::AxisRole::Time)) {
            continue;
        }
        let span = match (
            cf::time_units(path, &coord),
            cf::time_decoding(path, &coord),
        ) {
            (Ok(Some(t)), cf::TimeDecoding::Dates { dates, .. }) => format!(
                ", {} to {} ({} calendar)",
                dates[0].as_deref().unwrap_or("missing"),
                dates[n - 1].as_deref().unwrap_or("missing"),
                t.calendar.name()
            ),
            _ => String::new(),
        };
        return Err(time_is_not_space(path, var, dim, *n, &span));
    }
    Ok(())
}

/// The error for a time axis of `n` steps (`span`: ", FIRST to LAST (CALENDAR calendar)") read
/// without a step chosen: it names the axis and how to choose.
pub(crate) fn time_is_not_space(path: &Path, var: &str, dim: &str, n: usize, span: &str) -> Error {
    Error::format(
        path,
        format!(
            "variable '{var}': dimension '{dim}' is time ({n} steps{span}), not space; choose a step with index: #{{ {dim}: 0 }} or at: #{{ {dim}: \"DATE\" }} (hdrvis info --index {dim}=0)"
        ),
    )
}

/// The step that `sel` fixes on the time axis `dim` of variable `var` (coordinates `values` in
/// `time`'s units), for files whose time axis is not a NetCDF coordinate (MintPy's `date`
/// list), with its description; `None` when `sel` leaves the axis alone. Checks as [`plan`]
/// does: an index in range, a date within half a step of the axis.
pub(crate) fn time_step(
    path: &Path,
    var: &str,
    dim: &str,
    values: &[f64],
    time: &TimeUnits,
    sel: &Selection,
) -> Result<Option<(usize, String)>> {
    let field = format!("{}: variable '{var}', dimension '{dim}'", path.display());
    if sel.dims().filter(|d| *d == dim).count() > 1 {
        return Err(Error::invalid(field, "selected twice"));
    }
    if let Some((_, i)) = sel.index.iter().find(|(d, _)| d == dim) {
        let n = values.len();
        if *i < 0 || *i as usize >= n {
            return Err(Error::invalid(
                field,
                format!("index {i} is out of range; expected 0..={}", n as i64 - 1),
            ));
        }
        let i = *i as usize;
        return Ok(Some((
            i,
            format!("{dim} index {i} ({})", time.date(values[i])),
        )));
    }
    let Some((_, at)) = sel.at.iter().find(|(d, _)| d == dim) else {
        return Ok(None);
    };
    match locate_on(dim, at, values, "", Some(time)) {
        Ok((Pick::One(i), note)) => Ok(Some((i, note))),
        Ok(_) => unreachable!("a time axis picks its nearest step"),
        Err(Error::Invalid { msg, .. }) => Err(Error::invalid(field, msg)),
        Err(other) => Err(other),
    }
}

/// The dates of the CF time axis of variable `var` of a NetCDF file (else of the first data
/// variable that has one), in ISO 8601 ([`crate::datasets::time_steps`] serves every format).
pub fn time_steps(path: &Path, var: Option<&str>) -> Result<Vec<String>> {
    Ok(time_axis(path, var)?.dates)
}

/// A variable's CF time axis: the variable, its time dimension and the dates of its steps.
pub(crate) struct TimeAxis {
    pub variable: String,
    pub dim: String,
    pub dates: Vec<String>,
}

/// The CF time axis of variable `var`, else of the first data variable that has one.
pub(crate) fn time_axis(path: &Path, var: Option<&str>) -> Result<TimeAxis> {
    let listed = crate::datasets::list_arrays(path)?;
    let vars = variables::list_variables(path)?;
    let wanted: Vec<&(String, netcdf::Dims)> = match var {
        Some(name) => {
            let found = vars.iter().find(|(n, _)| n == name);
            vec![found.ok_or_else(|| crate::datasets::missing_array(path, name, &listed))?]
        }
        None => vars
            .iter()
            .filter(|(n, _)| listed.iter().any(|a| &a.name == n && a.is_data()))
            .collect(),
    };
    for (name, dims) in &wanted {
        for (dim, _) in dims {
            let Some(coord) = cf::read_coordinate(path, dim)? else {
                continue;
            };
            if let Some(t) = cf::time_units(path, &coord)? {
                return Ok(TimeAxis {
                    variable: name.clone(),
                    dim: dim.clone(),
                    dates: coord.data.iter().map(|&v| t.date(v)).collect(),
                });
            }
        }
    }
    Err(Error::format(
        path,
        match var {
            Some(name) => format!(
                "variable '{name}' has no CF time axis (a coordinate with units '<unit> since <date>')"
            ),
            None => "no data variable has a CF time axis (a coordinate with units '<unit> since <date>')".to_string(),
        },
    ))
}
