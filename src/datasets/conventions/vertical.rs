//! CF parametric vertical coordinates (CF appendix D): model levels whose pressure or height
//! varies from column to column, computed from `formula_terms` — hybrid sigma–pressure
//! (`p = a·p0 + b·ps` or `ap + b·ps`), sigma (`p = ptop + σ·(ps − ptop)`), hybrid height
//! (`z = a + b·orog`), ocean sigma (`z = η + σ·(depth + η)`) and ocean s-coordinates g1 and g2 —
//! and NCAR's older `A_var`/`B_var`/`PS_var` attributes (p0 = 1000 hPa when the file has no `P0`).
//! `at: #{ pressure: P }` (hPa), `at: #{ height: z }` and `at: #{ depth: d }` (metres) interpolate
//! every column to that level: linearly in ln p for pressure, as NCL's `vinth2p` does, linearly
//! in z for heights; a column the level lies outside of is missing, never extrapolated.

use std::collections::HashMap;
use std::path::Path;

use super::cf::attr_text;
use super::select::{self, At, Selection};
use crate::datasets::readers::variables::{self, Dims, NcAttribute, NcVariable};
use crate::error::{Error, Result};

/// The level asked for: a pressure in Pa or a height in metres (up).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Target {
    Pressure(f64),
    Height(f64),
}

/// The `at` keys that ask for a level on a parametric coordinate.
const KEYS: [&str; 3] = ["pressure", "height", "depth"];

/// Whether a selection asks for a level on a parametric coordinate (`pressure`, `height`,
/// `depth`) that is not one of `dims`.
pub(crate) fn asks_level(sel: &Selection, dims: &Dims) -> bool {
    sel.at
        .iter()
        .any(|(k, _)| KEYS.contains(&k.as_str()) && !dims.iter().any(|(d, _)| d == k))
}

/// A vertical coordinate's formula: its name and the variable of each term.
struct Formula {
    name: String,
    terms: HashMap<String, String>,
    /// p0 in Pa when the file gives none (NCAR's A_var/B_var form).
    default_p0: Option<f64>,
}

/// The parametric coordinate among `dims`: its dimension's index and formula.
fn formula_of(path: &Path, dims: &Dims) -> Result<Option<(usize, Formula)>> {
    for (a, (dim, _)) in dims.iter().enumerate() {
        let Ok(attrs) = variables::variable_attributes(path, dim) else {
            continue;
        };
        if let (Some(name), Some(terms)) = (
            attr_text(&attrs, "standard_name"),
            attr_text(&attrs, "formula_terms"),
        ) {
            let words: Vec<&str> = terms.split_whitespace().collect();
            let terms = words
                .chunks(2)
                .filter_map(|p| Some((p[0].strip_suffix(':')?.to_string(), p.get(1)?.to_string())))
                .collect();
            return Ok(Some((
                a,
                Formula {
                    name: name.to_string(),
                    terms,
                    default_p0: None,
                },
            )));
        }
        if let (Some(a_var), Some(b_var), Some(ps)) = (
            attr_text(&attrs, "A_var"),
            attr_text(&attrs, "B_var"),
            attr_text(&attrs, "PS_var"),
        ) {
            let mut terms = HashMap::from([
                ("a".to_string(), a_var.to_string()),
                ("b".to_string(), b_var.to_string()),
                ("ps".to_string(), ps.to_string()),
            ]);
            let has_p0 = variables::list_variables(path)?
                .iter()
                .any(|(n, _)| n == "P0");
            if has_p0 {
                terms.insert("p0".into(), "P0".into());
            }
            let formula = Formula {
                name: "atmosphere_hybrid_sigma_pressure_coordinate".into(),
                terms,
                default_p0: (!has_p0).then_some(100_000.0),
            };
            return Ok(Some((a, formula)));
        }
    }
    Ok(None)
}

/// A term's values on `kept` (the read variable's dimensions): read under the selection's
/// entries for the term's own dimensions, then looked up by dimension name.
struct Term {
    data: Vec<f64>,
    /// For each kept dimension, the term's stride along it (0 where the term lacks it).
    strides: Vec<usize>,
}

impl Term {
    fn at(&self, index: &[usize]) -> f64 {
        self.data[index
            .iter()
            .zip(&self.strides)
            .map(|(i, s)| i * s)
            .sum::<usize>()]
    }
}

fn read_term(
    path: &Path,
    var: &str,
    formula: &Formula,
    term: &str,
    rest: &Selection,
    kept: &Dims,
) -> Result<Term> {
    if term == "p0" && !formula.terms.contains_key("p0") {
        if let Some(p0) = formula.default_p0 {
            return Ok(Term {
                data: vec![p0],
                strides: vec![0; kept.len()],
            });
        }
    }
    let name = formula.terms.get(term).ok_or_else(|| {
        Error::format(
            path,
            format!(
                "'{var}': the vertical coordinate's formula_terms ({}) name no '{term}'",
                formula.name
            ),
        )
    })?;
    let listed = variables::list_variables(path)?;
    let dims = variables::dims_in(&listed, name);
    if !listed.iter().any(|(n, _)| n == name) {
        return Err(Error::format(
            path,
            format!("'{var}': formula term '{term}' names '{name}', which the file lacks"),
        ));
    }
    let own = Selection {
        index: rest
            .index
            .iter()
            .filter(|(d, _)| dims.iter().any(|(x, _)| x == d))
            .cloned()
            .collect(),
        at: rest
            .at
            .iter()
            .filter(|(d, _)| dims.iter().any(|(x, _)| x == d))
            .cloned()
            .collect(),
    };
    let plan = select::plan(path, name, &dims, &own)?;
    let v = select::read(path, name, &plan)?;
    // Pressures in hPa (some files keep ps so) become Pa.
    let scale = match v.units.as_deref().map(str::trim) {
        Some("hPa" | "mb" | "millibar" | "mbar") if matches!(term, "ps" | "p0" | "ptop" | "ap") => {
            100.0
        }
        _ => 1.0,
    };
    let mut strides = vec![0; kept.len()];
    let mut stride = 1;
    for (d, n) in v.dims.iter().rev() {
        let a = kept.iter().position(|(k, _)| k == d).ok_or_else(|| {
            Error::format(
                path,
                format!("'{var}': formula term '{name}' has dimension '{d}', which '{var}' lacks"),
            )
        })?;
        strides[a] = stride;
        stride *= n;
    }
    Ok(Term {
        data: v.data.iter().map(|x| x * scale).collect(),
        strides,
    })
}

/// A level's vertical position from its index in the read variable's layout.
type Position = Box<dyn Fn(&[usize]) -> f64>;

/// Every level's vertical position in the read variable's layout: pressure (Pa) or height (m).
fn levels(
    path: &Path,
    var: &str,
    formula: &Formula,
    rest: &Selection,
    kept: &Dims,
) -> Result<(Vec<f64>, bool)> {
    let t = |term: &str| read_term(path, var, formula, term, rest, kept);
    let count: usize = kept.iter().map(|(_, n)| *n).product();
    let mut index = vec![0; kept.len()];
    let mut out = Vec::with_capacity(count);
    let pressure = formula.name.starts_with("atmosphere_")
        && formula.name != "atmosphere_hybrid_height_coordinate";
    let f: Position = match formula.name.as_str() {
        "atmosphere_hybrid_sigma_pressure_coordinate" => {
            let (b, ps) = (t("b")?, t("ps")?);
            if formula.terms.contains_key("ap") {
                let ap = t("ap")?;
                Box::new(move |i| ap.at(i) + b.at(i) * ps.at(i))
            } else {
                let (a, p0) = (t("a")?, t("p0")?);
                Box::new(move |i| a.at(i) * p0.at(i) + b.at(i) * ps.at(i))
            }
        }
        "atmosphere_sigma_coordinate" => {
            let (s, ps, top) = (t("sigma")?, t("ps")?, t("ptop")?);
            Box::new(move |i| top.at(i) + s.at(i) * (ps.at(i) - top.at(i)))
        }
        "atmosphere_hybrid_height_coordinate" => {
            let (a, b, orog) = (t("a")?, t("b")?, t("orog")?);
            Box::new(move |i| a.at(i) + b.at(i) * orog.at(i))
        }
        "ocean_sigma_coordinate" => {
            let (s, eta, depth) = (t("sigma")?, t("eta")?, t("depth")?);
            Box::new(move |i| eta.at(i) + s.at(i) * (depth.at(i) + eta.at(i)))
        }
        "ocean_s_coordinate_g1" | "ocean_s_coordinate_g2" => {
            let (s, c, eta, depth, dc) = (t("s")?, t("C")?, t("eta")?, t("depth")?, t("depth_c")?);
            let g2 = formula.name.ends_with("g2");
            Box::new(move |i| {
                let (h, e) = (depth.at(i), eta.at(i));
                if g2 {
                    let big_s = (dc.at(i) * s.at(i) + h * c.at(i)) / (dc.at(i) + h);
                    e + (e + h) * big_s
                } else {
                    let big_s = dc.at(i) * s.at(i) + (h - dc.at(i)) * c.at(i);
                    big_s + e * (1.0 + big_s / h)
                }
            })
        }
        other => {
            return Err(Error::format(
                path,
                format!("'{var}': vertical coordinate '{other}' is not read (read: atmosphere_hybrid_sigma_pressure_coordinate, atmosphere_sigma_coordinate, atmosphere_hybrid_height_coordinate, ocean_sigma_coordinate, ocean_s_coordinate_g1, ocean_s_coordinate_g2)"),
            ))
        }
    };
    for _ in 0..count {
        out.push(f(&index));
        for a in (0..kept.len()).rev() {
            index[a] += 1;
            if index[a] < kept[a].1 {
                break;
            }
            index[a] = 0;
        }
    }
    Ok((out, pressure))
}

/// The `at` entry asking for a level: its key, its value, and the level in Pa or metres up.
fn target_of(sel: &Selection) -> Result<(&String, f64, Target)> {
    let (key, at) = sel
        .at
        .iter()
        .find(|(k, _)| KEYS.contains(&k.as_str()))
        .expect("asked");
    let value = match at {
        At::Value(v) if v.is_finite() => *v,
        _ => return Err(Error::invalid(format!("at.{key}"), "expected a number")),
    };
    let target = match key.as_str() {
        "pressure" if value > 0.0 => Target::Pressure(value * 100.0),
        "pressure" => {
            return Err(Error::invalid(
                "at.pressure",
                format!("{value} hPa; expected a pressure above 0"),
            ))
        }
        "height" => Target::Height(value),
        _ => Target::Height(-value),
    };
    Ok((key, value, target))
}

/// Variable `var` (dimensions `dims`) at the level `sel` asks for on its parametric vertical
/// coordinate, every column interpolated; the other entries of `sel` select as usual. `None`
/// when `sel` asks for no such level.
pub(crate) fn at_level(
    path: &Path,
    var: &str,
    dims: &Dims,
    sel: &Selection,
) -> Result<Option<(NcVariable, Vec<String>)>> {
    if !asks_level(sel, dims) {
        return Ok(None);
    }
    let (key, value, target) = target_of(sel)?;
    let Some((axis, formula)) = formula_of(path, dims)? else {
        let names: Vec<&str> = dims.iter().map(|(d, _)| d.as_str()).collect();
        return Err(Error::format(
            path,
            format!(
                "variable '{var}' has no dimension '{key}' and none of its dimensions ({}) is a parametric vertical coordinate (formula_terms, or A_var/B_var/PS_var)",
                names.join(", ")
            ),
        ));
    };
    let vertical = &dims[axis].0;
    let rest = Selection {
        index: sel.index.clone(),
        at: sel.at.iter().filter(|(k, _)| k != key).cloned().collect(),
    };
    if rest.dims().any(|d| d == vertical) {
        return Err(Error::invalid(
            format!("at.{key}"),
            format!("'{vertical}' is selected too; give one or the other"),
        ));
    }
    let plan = select::plan(path, var, dims, &rest)?;
    let v = select::read(path, var, &plan)?;
    let kept: Dims = v.dims.clone();
    let (positions, pressure) = levels(path, var, &formula, &rest, &kept)?;
    match (target, pressure) {
        (Target::Pressure(_), false) => {
            return Err(Error::format(
                path,
                format!(
                    "'{var}' is on {} (heights); ask for height or depth, not pressure",
                    formula.name
                ),
            ))
        }
        (Target::Height(_), true) => {
            return Err(Error::format(
                path,
                format!(
                    "'{var}' is on {} (pressures); ask for pressure, not {key}",
                    formula.name
                ),
            ))
        }
        _ => {}
    }
    let v_axis = kept.iter().position(|(d, _)| d == vertical).expect("kept");
    let data = interpolate(&v.data, &positions, &kept, v_axis, target);
    if data.iter().all(|x| x.is_nan()) && !v.data.iter().all(|x| x.is_nan()) {
        return Err(outside(path, var, (key, value), &positions, pressure));
    }
    let mut out_dims = kept.clone();
    out_dims.remove(v_axis);
    let rule = if pressure {
        "linearly in ln p (NCL's vinth2p rule)"
    } else {
        "linearly in height"
    };
    let mut notes = plan.notes;
    notes.push(format!(
        "{key} {value}{}: interpolated {rule} between the levels of '{vertical}' ({}) in each column; missing where a column does not reach it",
        if pressure { " hPa" } else { " m" },
        formula.name
    ));
    Ok(Some((
        NcVariable {
            dims: out_dims,
            data,
            ..v
        },
        notes,
    )))
}

/// The error for a level outside every column, with the span the columns cover.
fn outside(
    path: &Path,
    var: &str,
    (key, value): (&str, f64),
    positions: &[f64],
    pressure: bool,
) -> Error {
    let (lo, hi) = positions
        .iter()
        .filter(|p| p.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &p| {
            (a.min(p), b.max(p))
        });
    let (unit, scale) = if pressure { ("hPa", 0.01) } else { ("m", 1.0) };
    Error::format(
        path,
        format!(
            "'{var}': {key} {value} lies outside every column (its levels span {:.6} to {:.6} {unit}); nothing to interpolate",
            lo * scale,
            hi * scale
        ),
    )
}

/// `values` (dimensions `kept`) interpolated along axis `v_axis` to `target`, with the vertical
/// positions of every value in `positions`.
fn interpolate(
    values: &[f64],
    positions: &[f64],
    kept: &Dims,
    v_axis: usize,
    target: Target,
) -> Vec<f64> {
    let nv = kept[v_axis].1;
    let inner: usize = kept[v_axis + 1..].iter().map(|(_, n)| *n).product();
    let outer: usize = kept[..v_axis].iter().map(|(_, n)| *n).product();
    let (t, coord): (f64, fn(f64) -> f64) = match target {
        Target::Pressure(p) => (p.ln(), |x| if x > 0.0 { x.ln() } else { f64::NAN }),
        Target::Height(z) => (z, |x| x),
    };
    let mut out = Vec::with_capacity(outer * inner);
    for o in 0..outer {
        for i in 0..inner {
            let at = |k: usize| o * nv * inner + k * inner + i;
            let mut found = f64::NAN;
            for k in 0..nv.saturating_sub(1) {
                let (x0, x1) = (coord(positions[at(k)]), coord(positions[at(k + 1)]));
                let (lo, hi) = (x0.min(x1), x0.max(x1));
                if t >= lo && t <= hi {
                    let w = if x1 == x0 { 0.0 } else { (t - x0) / (x1 - x0) };
                    found = values[at(k)] + w * (values[at(k + 1)] - values[at(k)]);
                    break;
                }
            }
            out.push(found);
        }
    }
    out
}

/// Pressure levels are no lengths: a dimension whose coordinate is a pressure (a vertical axis
/// in hPa, Pa, mbar) is placed at the geopotential heights of the 1976 US Standard Atmosphere
/// (km, up), so the surface is at the bottom and the vertical spacing follows log-pressure, as
/// meteorologists draw it. Returns the note that says so, or `None` when no axis is pressure.
pub(crate) fn pressure_as_height(coords: &mut [super::cf::DimCoord]) -> Option<String> {
    for d in coords.iter_mut() {
        let Some(c) = d.coord.as_mut() else { continue };
        let units = c.units.clone().unwrap_or_default();
        let Some(heights) = super::atmosphere::heights_km(&c.data, &units) else {
            continue;
        };
        let (first, last) = (c.data.first().copied()?, c.data.last().copied()?);
        c.data = heights;
        c.units = Some("km".into());
        c.attributes
            .retain(|(k, _)| !["units", "positive", "standard_name", "axis"].contains(&k.as_str()));
        for (key, value) in [
            ("units", "km"),
            ("positive", "up"),
            ("standard_name", "geopotential_height"),
        ] {
            c.attributes
                .push((key.into(), NcAttribute::Text(value.into())));
        }
        return Some(format!(
            "{} {first}–{last} {units} placed at the 1976 standard atmosphere's heights, {:.2}–{:.2} km",
            d.name,
            c.data[0],
            c.data[c.data.len() - 1]
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_interpolate_in_ln_p_and_stay_missing_outside() {
        // One column of three levels at 1000, 500 and 250 hPa holding 0, 1 and 2.
        let kept: Dims = vec![("lev".into(), 3), ("x".into(), 1)];
        let p = [100_000.0, 50_000.0, 25_000.0];
        let values = [0.0, 1.0, 2.0];
        let at = |hpa: f64| interpolate(&values, &p, &kept, 0, Target::Pressure(hpa * 100.0))[0];
        assert_eq!(at(500.0), 1.0);
        // ln-p midway between 1000 and 500 hPa is √(1000·500) = 707.1 hPa.
        assert!((at(500f64.sqrt() * 1000f64.sqrt()) - 0.5).abs() < 1e-12);
        assert!(at(1013.0).is_nan() && at(100.0).is_nan());
        let z = [-50.0, -10.0, 0.0];
        let h = interpolate(&values, &z, &kept, 0, Target::Height(-30.0))[0];
        assert!((h - 0.5).abs() < 1e-12);
    }
}
