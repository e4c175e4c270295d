//! `hdrvis info --json`: one variable described for machines, in the terms xarray and
//! cf-xarray use, so that a test can set hdrvis's reading of a file beside theirs: the
//! variable's dimensions and each one's CF role, its shape and units, the values of its
//! dimensions' coordinate variables (masked and unpacked, times as stored), its time axis's dates,
//! and the missing count, minimum and maximum of its values once decoded.

use std::path::Path;

use serde_json::{json, Value};

use super::readers::variables;
use super::select::Selection;
use super::{cf, Format};
use crate::error::Result;

/// The JSON object describing variable `var` of `path` (else the variable `hdrvis info` would
/// describe) under the selection `sel`.
pub fn describe_json(path: &Path, var: Option<&str>, sel: &Selection) -> Result<String> {
    let format = Format::of(path)?;
    let (array, stats, _) = super::info::read_with_stats(
        path,
        var,
        sel,
        super::info::STREAM_ABOVE,
        super::slabs::SLAB_VALUES,
    )?;
    let mut roles = Vec::new();
    let mut coords = serde_json::Map::new();
    let mut times = Value::Null;
    let mut notes: Vec<String> = array.notes.clone();
    for dim in &array.dims {
        let coord = match format.reader().variables() {
            Some(v) => v.coordinate(path, dim)?,
            None => None,
        };
        let Some(coord) = coord else {
            roles.push("other");
            continue;
        };
        let role = cf::axis_role(path, &coord).unwrap_or(cf::AxisRole::Other);
        roles.push(role_name(&role));
        if let Some(k) = variables::rolled_by(path, dim)? {
            notes.push(format!(
                "'{dim}' is read in geographic order: its longitudes are stored in numeric order across the seam, and the reading starts at stored index {k}"
            ));
        }
        coords.insert(dim.clone(), json!(finite_or_null(&coord.data)));
        if role == cf::AxisRole::Time && times.is_null() {
            match cf::time_decoding(path, &coord) {
                cf::TimeDecoding::Dates { dates, note } => {
                    times = json!(dates);
                    notes.extend(note);
                }
                cf::TimeDecoding::Raw { why } => notes.push(why),
            }
        }
    }
    let finite = |v: Option<f64>| v.map_or(Value::Null, |x| json!(x));
    let mut out = json!({
        "file": path.display().to_string(),
        "variable": array.name,
        "dims": array.dims,
        "shape": array.shape,
        "roles": roles,
        "units": array.units,
        "coords": coords,
        "times": times,
        "missing": stats.nan,
        "min": finite(stats.min),
        "max": finite(stats.max),
    });
    if !notes.is_empty() {
        out["note"] = json!(notes.join("; "));
    }
    Ok(out.to_string())
}

/// A CF role as cf-xarray's axes and coordinates name it.
fn role_name(role: &cf::AxisRole) -> &'static str {
    match role {
        cf::AxisRole::Time => "time",
        cf::AxisRole::Latitude => "latitude",
        cf::AxisRole::Longitude => "longitude",
        cf::AxisRole::Vertical { .. } | cf::AxisRole::Levels | cf::AxisRole::Pressure => "vertical",
        cf::AxisRole::Other => "other",
    }
}

/// Values with NaN as JSON null (xarray's masked values).
fn finite_or_null(values: &[f64]) -> Vec<Value> {
    values
        .iter()
        .map(|&v| if v.is_nan() { Value::Null } else { json!(v) })
        .collect()
}
