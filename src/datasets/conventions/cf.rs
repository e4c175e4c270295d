//! The CF conventions a viewer needs to place a NetCDF volume in the world: which coordinate is
//! latitude (`degrees_north` or `standard_name: latitude`), longitude (`degrees_east`), and the
//! vertical axis — depth (`positive: down` or `standard_name: depth`), radius, or height (positive
//! up) — in metres or kilometres. A variable on latitude, longitude and a vertical axis becomes a
//! spherical volume ([`SphericalGrid`]) in the vertical axis's length unit; any other becomes a
//! Cartesian box, rectilinear where a coordinate is unevenly spaced.

use std::path::Path;

use super::cf_time::TimeUnits;
use crate::datasets::netcdf::{self, NcAttribute, NcVariable};
use crate::datasets::readers::variables;
use crate::error::{Error, Result};
use crate::model::{CoordAxis, RotatedPole, SphericalGrid};

/// Earth's mean radius, used when neither the file nor the script gives one.
pub(crate) const EARTH_RADIUS_KM: f64 = 6371.0;

/// What a coordinate variable is under CF.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum AxisRole {
    /// CF time: `<unit> since <date>` units, `axis: T` or `standard_name: time`.
    Time,
    Latitude,
    Longitude,
    /// A vertical coordinate; `to_unit` converts its values to `unit` (m or km).
    Vertical {
        kind: Vertical,
        unit: &'static str,
        to_unit: f64,
    },
    /// A vertical coordinate in units that are not a length (model levels, sigma): placed by
    /// index, since it says nothing of where its levels are.
    Levels,
    /// A vertical coordinate in units of pressure: placed at the standard atmosphere's heights
    /// (`vertical::pressure_as_height`).
    Pressure,
    Other,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Vertical {
    Depth,
    Radius,
    Height,
}

impl Vertical {
    fn name(self) -> &'static str {
        match self {
            Vertical::Depth => "depth",
            Vertical::Radius => "radius",
            Vertical::Height => "height",
        }
    }
}

/// One dimension of a variable with its coordinate variable, if the file has one.
pub(crate) struct DimCoord {
    pub name: String,
    pub coord: Option<NcVariable>,
}

/// The text attribute `key` of `v`, trimmed.
pub(crate) fn text<'a>(v: &'a NcVariable, key: &str) -> Option<&'a str> {
    attr_text(&v.attributes, key)
}

/// The text attribute `key` among `attrs`, trimmed.
pub(crate) fn attr_text<'a>(attrs: &'a [(String, NcAttribute)], key: &str) -> Option<&'a str> {
    attrs.iter().find_map(|(k, v)| match v {
        NcAttribute::Text(t) if k == key => Some(t.trim()),
        _ => None,
    })
}

/// The first number of the attribute `key` among `attrs`.
pub(crate) fn attr_number(attrs: &[(String, NcAttribute)], key: &str) -> Option<f64> {
    attrs.iter().find_map(|(k, v)| match v {
        NcAttribute::Numbers(n) if k == key => n.first().copied(),
        _ => None,
    })
}

/// The length unit of `units` as (canonical name, factor to it), or `None` for a non-length.
fn length_unit(units: &str) -> Option<(&'static str, f64)> {
    // Vertical axes are placed in metres or kilometres; centimetres and millimetres are not
    // what a planet's depth is given in.
    let metres = crate::model::grid::metres_per_unit(units)?;
    if metres == 1.0 {
        Some(("m", 1.0))
    } else if metres == 1e3 {
        Some(("km", 1.0))
    } else {
        None
    }
}

/// The CF role of coordinate variable `v`; a vertical axis without usable units is an error
/// naming `path` and the variable.
pub(crate) fn axis_role(path: &Path, v: &NcVariable) -> Result<AxisRole> {
    let units = v.units.as_deref().unwrap_or("").trim().to_ascii_lowercase();
    let standard = text(v, "standard_name").unwrap_or("").to_ascii_lowercase();
    let positive = text(v, "positive").unwrap_or("").to_ascii_lowercase();
    let name = v.name.to_ascii_lowercase();
    let lat_units = [
        "degrees_north",
        "degree_north",
        "degree_n",
        "degrees_n",
        "degreen",
        "degreesn",
    ];
    if super::cf_time::is_time_units(&units) || standard == "time" || text(v, "axis") == Some("T") {
        return Ok(AxisRole::Time);
    }
    if standard == "latitude" || lat_units.contains(&units.as_str()) {
        return Ok(AxisRole::Latitude);
    }
    if standard == "longitude" || netcdf::LONGITUDE_UNITS.contains(&units.as_str()) {
        return Ok(AxisRole::Longitude);
    }
    let kind =
        if positive == "down" || standard == "depth" || (positive.is_empty() && name == "depth") {
            Some(Vertical::Depth)
        } else if standard == "radius" || name == "radius" {
            Some(Vertical::Radius)
        } else if positive == "up"
            || ["height", "altitude", "height_above_reference_ellipsoid"]
                .contains(&standard.as_str())
            || (positive.is_empty() && ["height", "altitude"].contains(&name.as_str()))
        {
            Some(Vertical::Height)
        } else {
            None
        };
    let Some(kind) = kind else {
        return Ok(AxisRole::Other);
    };
    if units.is_empty() {
        return Err(Error::format(
            path,
            format!(
                "vertical coordinate '{}' has no units; expected units of length (m or km)",
                v.name
            ),
        ));
    }
    match length_unit(&units) {
        Some((unit, to_unit)) => Ok(AxisRole::Vertical {
            kind,
            unit,
            to_unit,
        }),
        None if super::atmosphere::is_pressure_unit(&units) => Ok(AxisRole::Pressure),
        None => Ok(AxisRole::Levels),
    }
}

/// The auxiliary coordinate named by `vertical:` (a hybrid level's `level_height`, say) in place
/// of the coordinate of the dimension it lies on, which must be one of `dims`: one-dimensional,
/// strictly monotonic, in units of length; without `positive` or a vertical `standard_name` it
/// is a height (positive up).
pub(crate) fn use_vertical(path: &Path, name: &str, dims: &mut [DimCoord]) -> Result<()> {
    let fail = |msg: String| {
        Err(Error::invalid(
            "vertical",
            format!("{}: {msg}", path.display()),
        ))
    };
    let mut v = match variables::read_variable(path, name) {
        Ok(v) => v,
        Err(_) => return fail(format!("no variable '{name}' in the file")),
    };
    let Some(d) = dims
        .iter_mut()
        .find(|d| v.dims.len() == 1 && v.dims[0].0 == d.name)
    else {
        let along: Vec<&str> = dims.iter().map(|d| d.name.as_str()).collect();
        return fail(format!(
            "'{name}' lies on {:?}; expected one of the variable's dimensions {along:?}",
            v.dims.iter().map(|d| d.0.as_str()).collect::<Vec<_>>()
        ));
    };
    let units = v.units.clone().unwrap_or_default();
    if length_unit(&units).is_none() {
        return fail(format!(
            "'{name}' is in '{units}'; expected units of length (m or km)"
        ));
    }
    netcdf::check_monotonic(&v.data).or_else(|msg| fail(format!("'{name}' {msg}")))?;
    if !matches!(axis_role(path, &v)?, AxisRole::Vertical { .. }) {
        v.attributes
            .push(("positive".into(), NcAttribute::Text("up".into())));
    }
    d.coord = Some(v);
    Ok(())
}

impl AxisRole {
    /// The role as `hdrvis info` names it.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            AxisRole::Time => "time",
            AxisRole::Latitude => "latitude",
            AxisRole::Longitude => "longitude",
            AxisRole::Vertical { .. } => "vertical",
            AxisRole::Levels => "vertical levels (not a length: placed by index)",
            AxisRole::Pressure => "vertical pressure (placed at the standard atmosphere's heights)",
            AxisRole::Other => "other",
        }
    }
}

/// The CF time units and calendar of a time coordinate, or `None` when its units are not
/// `<unit> since <date>` (or CDO's absolute `day as %Y%m%d.%f`); units or a calendar that cannot be read are an error naming the file
/// and the coordinate.
pub(crate) fn time_units(path: &Path, v: &NcVariable) -> Result<Option<TimeUnits>> {
    let Some(units) = v
        .units
        .as_deref()
        .filter(|u| super::cf_time::is_time_units(u))
    else {
        return Ok(None);
    };
    TimeUnits::parse(units, text(v, "calendar"))
        .map(Some)
        .map_err(|e| match e {
            Error::Invalid { field, msg } => Error::format(
                path,
                format!("time coordinate '{}': {field}: {msg}", v.name),
            ),
            other => other,
        })
}

/// A time coordinate's values as dates, or why they stay numbers.
pub(crate) enum TimeDecoding {
    /// One date per value (`None` for a missing value), and how a unit of no fixed length was
    /// read.
    Dates {
        dates: Vec<Option<String>>,
        note: Option<String>,
    },
    /// The axis cannot be decoded (no `since` in its units, an unknown unit or calendar, only
    /// missing values): its values stay numbers, and the reason is said, not raised, so that
    /// the file's other variables read as xarray leaves such an axis undecoded.
    Raw { why: String },
}

/// The dates of time coordinate `v`, or why they cannot be had (see [`TimeDecoding`]).
pub(crate) fn time_decoding(path: &Path, v: &NcVariable) -> TimeDecoding {
    let raw = |why: String| TimeDecoding::Raw {
        why: format!(
            "time coordinate '{}' {why}; its values are left as numbers",
            v.name
        ),
    };
    match time_units(path, v) {
        Ok(Some(_)) if !v.data.is_empty() && v.data.iter().all(|x| x.is_nan()) => {
            raw("holds only missing values".to_string())
        }
        Ok(Some(t)) => TimeDecoding::Dates {
            dates: v
                .data
                .iter()
                .map(|&x| x.is_finite().then(|| t.date(x)))
                .collect(),
            note: t.unit_note.clone(),
        },
        Ok(None) => raw(format!(
            "has units {:?}, not '<unit> since <date>'",
            v.units.as_deref().unwrap_or("")
        )),
        Err(Error::Format { msg, .. }) => raw(format!("cannot be decoded ({msg})")),
        Err(e) => raw(format!("cannot be decoded ({e})")),
    }
}

/// The domain `[lo, hi]` from the CF `bounds` variable of a coordinate, when it names one.
pub(crate) fn cf_bounds(path: &Path, v: &NcVariable) -> Result<Option<(f64, f64)>> {
    let Some(name) = text(v, "bounds") else {
        return Ok(None);
    };
    let mut b = variables::read_variable(path, name)?;
    // Longitudes unwrapped across the seam: each cell's bounds move by whole turns to lie beside
    // its centre, as the centre moved.
    let pairs = b.data.len() == 2 * v.data.len() && !v.data.is_empty();
    if pairs && matches!(axis_role(path, v), Ok(AxisRole::Longitude)) {
        for (pair, &centre) in b.data.chunks_mut(2).zip(&v.data) {
            for x in pair {
                *x += ((centre - *x) / 360.0).round() * 360.0;
            }
        }
    }
    let finite = b.data.iter().filter(|x| x.is_finite());
    let lo = finite.clone().fold(f64::INFINITY, |a, &x| a.min(x));
    let hi = finite.fold(f64::NEG_INFINITY, |a, &x| a.max(x));
    Ok((lo < hi).then_some((lo, hi)))
}

/// Reads the coordinate variable of each dimension of `var` (slowest first).
pub(crate) fn dim_coords(path: &Path, dims: &[(String, usize)]) -> Result<Vec<DimCoord>> {
    let mut out = Vec::new();
    for (name, _) in dims {
        out.push(DimCoord {
            name: name.clone(),
            coord: read_coordinate(path, name)?,
        });
    }
    Ok(out)
}

/// The coordinate variable of dimension `dim` (see [`variables::coordinate_variable`]), checked to
/// be finite and strictly monotonic, since cell positions are derived from it. Longitudes are
/// first unwrapped by whole turns in storage order ([`unwrap_longitudes`]): a region across the
/// prime meridian stored 322.5 … 357.5, 2.5 reads 322.5 … 362.5.
pub(crate) fn read_coordinate(path: &Path, dim: &str) -> Result<Option<NcVariable>> {
    let Some(mut v) = variables::coordinate_variable(path, dim)? else {
        return Ok(None);
    };
    if matches!(axis_role(path, &v), Ok(AxisRole::Longitude)) {
        if let Some(unwrapped) = unwrap_longitudes(&v.data) {
            v.data = unwrapped;
        }
    }
    netcdf::check_monotonic(&v.data)
        .map_err(|msg| Error::format(path, format!("coordinate '{dim}' {msg}")))?;
    Ok(Some(v))
}

/// Longitudes made monotonic by whole turns in storage order, or `None` when they are monotonic
/// already or cannot be made so. The first step, taken the short way round, gives the direction:
/// increasing values that drop continue one turn on (357.5, 2.5 → 357.5, 362.5), decreasing ones
/// that rise one turn back. The result must be strictly monotonic and span less than a turn.
pub(crate) fn unwrap_longitudes(values: &[f64]) -> Option<Vec<f64>> {
    let [first, second, ..] = values else {
        return None;
    };
    if values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let increasing = (second - first).rem_euclid(360.0) < 180.0;
    let sign = if increasing { 1.0 } else { -1.0 };
    let mut turns = 0.0;
    let mut out = Vec::with_capacity(values.len());
    out.push(*first);
    for w in values.windows(2) {
        if sign * (w[1] - w[0]) < 0.0 {
            turns += sign * 360.0;
        }
        out.push(w[1] + turns);
    }
    let monotonic = out.windows(2).all(|w| sign * (w[1] - w[0]) > 0.0);
    let span = (out[out.len() - 1] - out[0]).abs();
    (turns != 0.0 && monotonic && span < 360.0).then_some(out)
}

/// Options that shape a spherical volume: a planet radius in the vertical axis's unit that
/// overrides the file's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct SphereOptions {
    pub planet_radius: Option<f64>,
}

/// The spherical grid of a variable on (vertical, latitude, longitude) in any order, or `None`
/// when its dimensions are not those three. `dims` are the variable's last three dimensions,
/// slowest first, so volume axis `a` is `dims[2 - a]`.
pub(crate) fn spherical_grid(
    path: &Path,
    var: &str,
    dims: &[DimCoord],
    declared: Option<(f64, Option<&'static str>)>,
    opts: &SphereOptions,
) -> Result<Option<SphericalGrid>> {
    let field = |d: &DimCoord| {
        format!(
            "{}: variable '{var}', coordinate '{}'",
            path.display(),
            d.name
        )
    };
    // A rotated-pole grid's grid_latitude and grid_longitude are its latitude and longitude on
    // the rotated sphere.
    let pole = rotated_pole(path, var)?;
    let mut roles = Vec::new();
    for d in dims {
        roles.push(match &d.coord {
            Some(c) if pole.is_some() && text(c, "standard_name") == Some("grid_latitude") => {
                AxisRole::Latitude
            }
            Some(c) if pole.is_some() && text(c, "standard_name") == Some("grid_longitude") => {
                AxisRole::Longitude
            }
            Some(c) => axis_role(path, c)?,
            None => AxisRole::Other,
        });
    }
    let find = |want: fn(&AxisRole) -> bool| roles.iter().position(want);
    let (Some(lat), Some(lon), Some(vert)) = (
        find(|r| matches!(r, AxisRole::Latitude)),
        find(|r| matches!(r, AxisRole::Longitude)),
        find(|r| matches!(r, AxisRole::Vertical { .. })),
    ) else {
        return Ok(None);
    };
    let AxisRole::Vertical {
        kind,
        unit,
        to_unit,
    } = roles[vert]
    else {
        unreachable!("found as vertical")
    };
    let coord = |i: usize| dims[i].coord.as_ref().expect("a role needs a coordinate");
    let metres_to_unit = if unit == "km" { 1e-3 } else { 1.0 };
    let planet_radius = match (opts.planet_radius, declared) {
        (Some(r), _) => r,
        (None, Some((r, None))) => r,
        (None, Some((r, Some(_metres)))) => r * metres_to_unit,
        (None, None) => EARTH_RADIUS_KM * 1e3 * metres_to_unit,
    };
    if !(planet_radius.is_finite() && planet_radius > 0.0) {
        return Err(Error::invalid(
            "planet_radius",
            format!("expected a length > 0, got {planet_radius}"),
        ));
    }
    let to_radius = |x: f64| match kind {
        Vertical::Depth => planet_radius - x * to_unit,
        Vertical::Radius => x * to_unit,
        Vertical::Height => planet_radius + x * to_unit,
    };
    let vc = coord(vert);
    let radii: Vec<f64> = vc.data.iter().map(|&x| to_radius(x)).collect();
    let bounds = cf_bounds(path, vc)?.map(|(a, b)| (to_radius(a), to_radius(b)));
    let radius = CoordAxis::new(radii, bounds, &field(&dims[vert]))?;
    if radius.lo < 0.0 {
        return Err(Error::format(
            path,
            format!(
                "variable '{var}': {} '{}' reaches {} {unit}, deeper than the planet's radius {planet_radius} {unit} (set planet_radius)",
                kind.name(),
                dims[vert].name,
                planet_radius - radius.lo
            ),
        ));
    }
    let latitude = latitude_axis(path, coord(lat), &field(&dims[lat]))?;
    let (longitude, lon_wraps) = longitude_axis(path, coord(lon), &field(&dims[lon]))?;
    let grid = SphericalGrid {
        axis_of: [2 - vert, 2 - lat, 2 - lon],
        radius,
        latitude,
        longitude,
        lon_wraps,
        planet_radius,
        length_unit: unit.to_string(),
        vertical: kind.name().to_string(),
        rotated_pole: pole,
    };
    grid.check(&format!("{}: variable '{var}'", path.display()))?;
    Ok(Some(grid))
}

/// Latitudes in degrees; a domain that ends within one spacing of a pole extends to it.
fn latitude_axis(path: &Path, v: &NcVariable, field: &str) -> Result<CoordAxis> {
    if let Some(bad) = v.data.iter().find(|x| x.abs() > 90.0) {
        return Err(Error::invalid(
            field,
            format!("latitude {bad} is beyond ±90 degrees"),
        ));
    }
    let mut axis = CoordAxis::new(v.data.clone(), cf_bounds(path, v)?, field)?;
    let step = axis.min_spacing();
    if 90.0 - axis.hi <= step {
        axis.hi = 90.0;
    }
    if axis.lo + 90.0 <= step {
        axis.lo = -90.0;
    }
    Ok(axis)
}

/// Longitudes in degrees (unwrapped by [`read_coordinate`]), and whether they cover the whole
/// circle: the gap across the seam is no wider than 1.5 of the axis's widest spacing, and no
/// spacing is wider than four times the median one (a region stored in numeric order across
/// the meridian, 0.5, 325.5 … 355.5, has such a hole: it is not the circle). A circle's domain
/// is one turn from its lowest cell edge, so values stored from −180 or from 0 describe the
/// same domain.
fn longitude_axis(path: &Path, v: &NcVariable, field: &str) -> Result<(CoordAxis, bool)> {
    let axis = CoordAxis::new(v.data.clone(), cf_bounds(path, v)?, field)?;
    let n = axis.len();
    if n < 2 {
        return Ok((axis, false));
    }
    let first = axis.centres[0];
    let last = axis.centres[n - 1];
    let span = (last - first).abs();
    let widest = axis
        .centres
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    let gap = 360.0 - span;
    let mut steps: Vec<f64> = axis
        .centres
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .collect();
    steps.sort_by(f64::total_cmp);
    let median = steps[steps.len() / 2];
    if span > 360.0 {
        return Err(Error::invalid(
            field,
            format!("longitudes span {span} degrees; expected at most 360"),
        ));
    }
    if gap > 0.0 && gap <= 1.5 * widest && widest <= 4.0 * median {
        let lo = first.min(last) - 0.5 * gap;
        let wrapped = CoordAxis {
            centres: axis.centres,
            lo,
            hi: lo + 360.0,
        };
        return Ok((wrapped, true));
    }
    Ok((axis, false))
}

/// A planet radius the file declares, with its unit: a global or variable attribute
/// `planet_radius` (in the vertical axis's unit, `None` as unit) or CF's grid-mapping
/// `earth_radius` (metres).
#[allow(clippy::type_complexity)]
pub(crate) fn declared_radius(
    path: &Path,
    attributes: &[(String, NcAttribute)],
) -> Result<Option<(f64, Option<&'static str>)>> {
    if let Some(r) = attr_number(attributes, "planet_radius") {
        return Ok(Some((r, None)));
    }
    if let Some(r) = attr_number(&variables::global_attributes(path)?, "planet_radius") {
        return Ok(Some((r, None)));
    }
    if let Some((_, m)) = grid_mapping(path, attributes)? {
        if let Some(r) = attr_number(&m, "earth_radius") {
            return Ok(Some((r, Some("m"))));
        }
    }
    Ok(None)
}

/// A variable's attributes in file order.
type Attributes = Vec<(String, NcAttribute)>;

/// The grid-mapping variable a variable's `grid_mapping` names (CF 5.6: "crs" or the extended
/// "crs: lat lon" form, whose first name is the mapping) with its attributes. A mapping is an
/// attribute container whatever its type: CORDEX writes `char rotated_pole`, others an integer
/// or a scalar, and its value is never read. A name the file lacks gives `None`, as it leaves
/// the variable unplaced rather than unreadable.
fn grid_mapping(
    path: &Path,
    attributes: &[(String, NcAttribute)],
) -> Result<Option<(String, Attributes)>> {
    let Some(mapping) = attr_text(attributes, "grid_mapping")
        .and_then(|m| m.split([':', ' ']).next())
        .filter(|m| !m.is_empty())
    else {
        return Ok(None);
    };
    Ok(variables::variable_attributes(path, mapping)
        .ok()
        .map(|m| (mapping.to_string(), m)))
}

/// The 2-D latitude and longitude of `variable` on a curvilinear grid: the auxiliary
/// coordinates its `coordinates` attribute names whose dimensions are its last two (`dims`, in
/// that order) and whose CF role is latitude and longitude; `None` unless both are there, and
/// for a grid placed otherwise — by 1-D latitude and longitude axes (which the 2-D coordinates
/// only repeat) or a rotated pole (CORDEX writes both).
pub(crate) fn curvilinear_coords(
    path: &Path,
    variable: &str,
    attributes: &[(String, NcAttribute)],
    dims: &[String],
) -> Result<Option<(NcVariable, NcVariable)>> {
    let (Some(names), [.., y, x]) = (attr_text(attributes, "coordinates"), dims) else {
        return Ok(None);
    };
    let geographic = |dim: &str| -> Result<bool> {
        Ok(variables::coordinate_variable(path, dim)?.is_some_and(|c| {
            matches!(
                axis_role(path, &c),
                Ok(AxisRole::Latitude | AxisRole::Longitude)
            )
        }))
    };
    if (geographic(y)? && geographic(x)?) || rotated_pole(path, variable)?.is_some() {
        return Ok(None);
    }
    let listed = variables::list_variables(path)?;
    let (mut lat, mut lon) = (None, None);
    for name in names.split_whitespace() {
        let on_grid = variables::dims_in(&listed, name)
            .iter()
            .map(|d| d.0.as_str())
            .eq([y.as_str(), x.as_str()]);
        if !on_grid {
            continue;
        }
        let v = variables::read_variable(path, name)?;
        match axis_role(path, &v) {
            Ok(AxisRole::Latitude) => lat = Some(v),
            Ok(AxisRole::Longitude) => lon = Some(v),
            _ => {}
        }
    }
    Ok(lat.zip(lon))
}

/// The rotated pole of `variable`'s CF grid mapping: its `grid_mapping` names a variable whose
/// `grid_mapping_name` is `rotated_latitude_longitude`; `None` for another mapping or none. A
/// rotated mapping without its pole, or with one out of range, is an error naming the file, the
/// mapping and the attribute.
pub(crate) fn rotated_pole(path: &Path, variable: &str) -> Result<Option<RotatedPole>> {
    let attrs = variables::variable_attributes(path, variable)?;
    let Some((mapping, m)) = grid_mapping(path, &attrs)? else {
        return Ok(None);
    };
    if attr_text(&m, "grid_mapping_name") != Some("rotated_latitude_longitude") {
        return Ok(None);
    }
    let required = |key: &str| {
        attr_number(&m, key).ok_or_else(|| {
            Error::format(
                path,
                format!("grid mapping {mapping:?} (rotated_latitude_longitude) has no {key}"),
            )
        })
    };
    RotatedPole::new(
        required("grid_north_pole_latitude")?,
        required("grid_north_pole_longitude")?,
        attr_number(&m, "north_pole_grid_longitude").unwrap_or(0.0),
    )
    .map(Some)
    .map_err(|e| Error::format(path, format!("grid mapping {mapping:?}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn longitudes_unwrap_by_whole_turns_in_storage_order() {
        let across = [322.5, 327.5, 352.5, 357.5, 2.5, 7.5];
        assert_eq!(
            unwrap_longitudes(&across).unwrap(),
            [322.5, 327.5, 352.5, 357.5, 362.5, 367.5]
        );
        // Decreasing across the seam: one turn back.
        assert_eq!(
            unwrap_longitudes(&[10.0, 5.0, 0.0, 355.0]).unwrap(),
            [10.0, 5.0, 0.0, -5.0]
        );
        // Monotonic already, or not monotonic even unwrapped, or more than a turn: unchanged.
        assert_eq!(unwrap_longitudes(&[0.5, 325.5, 330.5]), None);
        assert_eq!(unwrap_longitudes(&[350.0, 10.0, 5.0]), None);
        assert_eq!(unwrap_longitudes(&[0.0, 120.0, 240.0, 0.0, 120.0]), None);
    }

    fn lon(values: &[f64]) -> NcVariable {
        NcVariable {
            name: "lon".into(),
            dims: vec![("lon".into(), values.len())],
            data: values.to_vec(),
            units: Some("degrees_east".into()),
            long_name: None,
            attributes: Vec::new(),
            stored_nan: 0,
        }
    }

    #[test]
    fn only_an_evenly_sampled_circle_wraps() {
        let path = Path::new("l.nc");
        let global: Vec<f64> = (0..36).map(|i| 5.0 + 10.0 * f64::from(i)).collect();
        let (axis, wraps) = longitude_axis(path, &lon(&global), "lon").unwrap();
        assert!(wraps);
        assert_eq!((axis.lo, axis.hi), (0.0, 360.0));
        // A region stored in numeric order across the meridian has a 325 degree hole.
        let sorted = [0.5, 325.5, 330.5, 335.5, 340.5, 345.5, 350.5, 355.5];
        let (_, wraps) = longitude_axis(path, &lon(&sorted), "lon").unwrap();
        assert!(!wraps);
        let unwrapped = unwrap_longitudes(&[345.5, 350.5, 355.5, 0.5, 5.5]).unwrap();
        let (axis, wraps) = longitude_axis(path, &lon(&unwrapped), "lon").unwrap();
        assert!(!wraps);
        assert_eq!((axis.lo, axis.hi), (345.5, 365.5));
    }
}
