//! MintPy's HDF5 products (`velocity.h5`, `timeseries.h5`, `geo_*.h5`), recognised by the
//! root attributes MintPy writes as strings (`FILE_TYPE`, `WIDTH`, `LENGTH`). A geocoded product
//! has `X_FIRST`/`Y_FIRST`, the longitude and latitude of the *outer corner* of the first
//! pixel (MintPy's docs/api/coord.md: "the upper left corner of the first pixel"), and
//! `X_STEP`/`Y_STEP` (`Y_STEP` negative for a raster stored north to south): pixel centres are
//! `X_FIRST + (i + 0.5) X_STEP` and `Y_FIRST + (j + 0.5) Y_STEP`, which become the grid's nodes,
//! so its map is drawn north up. `X_UNIT`/`Y_UNIT` other than degrees (a UTM product) give plain
//! x/y axes. A product in radar coordinates (no `X_FIRST`) keeps its storage order: row 0 is the
//! grid's first row, drawn at the bottom. `timeseries` is (date, row, column) with the `date`
//! list (`YYYYMMDD`) as a time axis named `time`, chosen with `index`/`at` like a CF one.
//! `UNIT` is the data's unit; `WAVELENGTH` (m) and `REF_LAT`/`REF_LON` are shown by `hdrvis info`.

use std::path::Path;

use super::hdf5;
use crate::datasets::cf_time::TimeUnits;
use crate::datasets::select::{self, Selection};
use crate::datasets::{ArrayData, ArrayListing, GridAxis};
use crate::error::{Error, Result};
use crate::model::CoordKind;

/// The name of the time dimension of a time-series dataset.
const TIME: &str = "time";

/// A MintPy file's root attributes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Product {
    attrs: Vec<(String, String)>,
}

/// The product in `path` when its root attributes are MintPy's, else `None`.
pub(crate) fn open(path: &Path) -> Result<Option<Product>> {
    let attrs = hdf5::root_attributes(path)?;
    let has = |k: &str| attrs.iter().any(|(n, _)| n == k);
    Ok((has("FILE_TYPE") && has("WIDTH") && has("LENGTH")).then_some(Product { attrs }))
}

impl Product {
    fn get(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.trim())
            .filter(|v| !v.is_empty() && *v != "None")
    }

    /// A numeric attribute; text that is not a number is an error naming it.
    fn number(&self, path: &Path, key: &str) -> Result<Option<f64>> {
        self.get(key)
            .map(|v| {
                v.parse::<f64>().map_err(|_| {
                    Error::format(
                        path,
                        format!("MintPy attribute {key} is '{v}'; expected a number"),
                    )
                })
            })
            .transpose()
    }

    /// The radar wavelength in metres (`WAVELENGTH`).
    pub(crate) fn wavelength(&self, path: &Path) -> Result<Option<f64>> {
        self.number(path, "WAVELENGTH")
    }

    fn file_type(&self) -> &str {
        self.get("FILE_TYPE").unwrap_or("")
    }

    /// `[LENGTH, WIDTH]`.
    fn size(&self, path: &Path) -> Result<[usize; 2]> {
        let dim = |key: &str| -> Result<usize> {
            match self.number(path, key)? {
                Some(v) if v >= 1.0 && v.fract() == 0.0 => Ok(v as usize),
                _ => Err(Error::format(
                    path,
                    format!(
                        "MintPy attribute {key} is {:?}; expected a positive integer",
                        self.get(key)
                    ),
                )),
            }
        };
        Ok([dim("LENGTH")?, dim("WIDTH")?])
    }

    /// The geocoding when all four of X_FIRST, X_STEP, Y_FIRST and Y_STEP are given.
    fn geocoding(&self, path: &Path) -> Result<Option<Geocoding>> {
        let keys = ["X_FIRST", "X_STEP", "Y_FIRST", "Y_STEP"];
        let given: Vec<Option<f64>> = keys
            .iter()
            .map(|k| self.number(path, k))
            .collect::<Result<_>>()?;
        match given[..] {
            [None, None, None, None] => Ok(None),
            [Some(x0), Some(dx), Some(y0), Some(dy)] => {
                if dx == 0.0 || dy == 0.0 || !(x0.is_finite() && y0.is_finite()) {
                    return Err(Error::format(
                        path,
                        format!("MintPy geocoding X_STEP {dx}, Y_STEP {dy} at ({x0}, {y0}); expected finite, non-zero steps"),
                    ));
                }
                let degrees = ["X_UNIT", "Y_UNIT"].iter().all(|k| {
                    self.get(k)
                        .is_none_or(|u| u.to_ascii_lowercase().starts_with("deg"))
                });
                Ok(Some(Geocoding {
                    x_first: x0,
                    x_step: dx,
                    y_first: y0,
                    y_step: dy,
                    degrees,
                }))
            }
            _ => {
                let missing: Vec<&str> = keys
                    .iter()
                    .zip(&given)
                    .filter(|(_, v)| v.is_none())
                    .map(|(k, _)| *k)
                    .collect();
                Err(Error::format(
                    path,
                    format!("MintPy geocoding is incomplete: {} missing (X_FIRST, Y_FIRST, X_STEP and Y_STEP go together)", missing.join(", ")),
                ))
            }
        }
    }

    /// The `date` list as days since 1970-01-01 with its time axis, when the file has one.
    fn dates(&self, path: &Path) -> Result<Option<(Vec<f64>, TimeUnits)>> {
        if !hdf5::list_datasets(path)?.iter().any(|a| a.name == "/date") {
            return Ok(None);
        }
        let time = TimeUnits::parse("days since 1970-01-01", None)?;
        let values = hdf5::read_strings(path, "date")?
            .iter()
            .map(|d| {
                let iso = match (d.len(), d.bytes().all(|b| b.is_ascii_digit())) {
                    (8, true) => format!("{}-{}-{}", &d[..4], &d[4..6], &d[6..]),
                    _ => String::new(),
                };
                time.value(&iso).map_err(|_| {
                    Error::format(path, format!("MintPy date '{d}' is not a date YYYYMMDD"))
                })
            })
            .collect::<Result<Vec<f64>>>()?;
        Ok((!values.is_empty()).then_some((values, time)))
    }
}

/// MintPy's geocoding: the outer corner of the first pixel, the pixel steps (degrees unless
/// `X_UNIT`/`Y_UNIT` say otherwise).
struct Geocoding {
    x_first: f64,
    x_step: f64,
    y_first: f64,
    y_step: f64,
    degrees: bool,
}

/// The dataset read by default: the one named like the file type (`velocity`, `timeseries`),
/// else the first of the product's size.
fn default_dataset(path: &Path, product: &Product) -> Result<String> {
    let size = product.size(path)?;
    let listed = hdf5::list_datasets(path)?;
    let own = format!("/{}", product.file_type());
    listed
        .iter()
        .find(|a| a.name == own)
        .or_else(|| {
            listed
                .iter()
                .find(|a| a.shape.ends_with(&size) && a.dtype != "other")
        })
        .map(|a| a.name.trim_start_matches('/').to_string())
        .ok_or_else(|| {
            Error::format(
                path,
                format!(
                    "MintPy {} file has no dataset of its size {size:?} (LENGTH, WIDTH)",
                    product.file_type()
                ),
            )
        })
}

/// The dataset `var` names (else the product's main one) and its shape; an unknown name is the
/// one-line error listing the file's datasets.
fn named_dataset(
    path: &Path,
    product: &Product,
    var: Option<&str>,
) -> Result<(String, Vec<usize>)> {
    let name = match var {
        Some(v) => v.trim_start_matches('/').to_string(),
        None => default_dataset(path, product)?,
    };
    let listed = hdf5::list_datasets(path)?;
    let full = format!("/{name}");
    let shape = listed
        .iter()
        .find(|a| a.name == full)
        .map(|a| a.shape.clone())
        .ok_or_else(|| crate::datasets::missing_array(path, &full, &listed))?;
    Ok((name, shape))
}

/// The dataset `var` (else the default one) with the step `sel` chooses on a time series'
/// `time` axis. Without a step, a time series is refused when `refuse_time` (a grid is being
/// read) and read whole otherwise (`hdrvis info`).
pub(crate) fn read_array(
    path: &Path,
    product: &Product,
    var: Option<&str>,
    sel: &Selection,
    refuse_time: bool,
) -> Result<ArrayData> {
    let (name, shape) = named_dataset(path, product, var)?;
    let dates = if shape.len() == 3 {
        product.dates(path)?
    } else {
        None
    };
    let timed = dates.as_ref().filter(|(d, _)| d.len() == shape[0]);
    if let Some(dim) = sel.dims().find(|d| timed.is_none() || *d != TIME) {
        let dims = if timed.is_some() {
            "time, y, x"
        } else {
            "y, x"
        };
        return Err(Error::format(
            path,
            format!("variable '{name}' has no dimension '{dim}'; its dimensions are {dims}"),
        ));
    }
    let step = match timed {
        Some((values, time)) => select::time_step(path, &name, TIME, values, time, sel)?,
        None => None,
    };
    if let (Some((values, time)), None, true) = (timed, &step, refuse_time) {
        let span = format!(
            ", {} to {} ({} calendar)",
            time.date(values[0]),
            time.date(values[values.len() - 1]),
            time.calendar.name()
        );
        return Err(select::time_is_not_space(
            path,
            &name,
            TIME,
            values.len(),
            &span,
        ));
    }
    let mut array = hdf5::read_plane(path, &name, step.as_ref().map(|(i, _)| *i))?;
    array.dims = match array.shape.len() {
        3 if timed.is_some() => vec![TIME.into(), "y".into(), "x".into()],
        2 => vec!["y".into(), "x".into()],
        n => (0..n).map(|a| format!("dim{a}")).collect(),
    };
    array.notes = step.map(|(_, note)| vec![note]).unwrap_or_default();
    if array.units.is_none() {
        array.units = product.get("UNIT").map(str::to_string);
    }
    Ok(array)
}

/// The x and y axes (pixel centres, as stored) of a `[rows, columns]` grid of the product, or
/// `None` for radar coordinates.
pub(crate) fn axes(
    path: &Path,
    product: &Product,
    [ny, nx]: [usize; 2],
) -> Result<Option<(GridAxis, GridAxis)>> {
    let Some(Geocoding {
        x_first: x0,
        x_step: dx,
        y_first: y0,
        y_step: dy,
        degrees,
    }) = product.geocoding(path)?
    else {
        return Ok(None);
    };
    let axis = |name: &str, units: &str, first: f64, step: f64, n: usize, kind| GridAxis {
        name: name.to_string(),
        units: Some(units.to_string()),
        values: (0..n).map(|i| first + (i as f64 + 0.5) * step).collect(),
        kind,
        edges: None,
    };
    Ok(Some(if degrees {
        (
            axis("lon", "degrees_east", x0, dx, nx, CoordKind::Longitude),
            axis("lat", "degrees_north", y0, dy, ny, CoordKind::Latitude),
        )
    } else {
        let units = product.get("X_UNIT").unwrap_or("").to_string();
        (
            axis("x", &units, x0, dx, nx, CoordKind::Plain),
            axis(
                "y",
                product.get("Y_UNIT").unwrap_or(&units),
                y0,
                dy,
                ny,
                CoordKind::Plain,
            ),
        )
    }))
}

/// The dates of the time series `var` (else the file's), in ISO 8601: what `times(path)` gives.
pub(crate) fn time_steps(path: &Path, product: &Product, var: Option<&str>) -> Result<Vec<String>> {
    let (name, shape) = named_dataset(path, product, var)?;
    match product.dates(path)? {
        Some((values, time)) if shape.len() == 3 && shape[0] == values.len() => {
            Ok(values.iter().map(|&v| time.date(v)).collect())
        }
        _ => Err(Error::format(
            path,
            format!("variable '{name}' has no time axis (a MintPy time series has a `date` list as long as its first dimension)"),
        )),
    }
}

/// What `hdrvis info` adds for a MintPy product: its type, geography, units, wavelength,
/// reference point and dates.
pub(crate) fn describe(path: &Path, product: &Product) -> Result<Vec<String>> {
    let mut lines = vec![format!("MintPy product: FILE_TYPE {}", product.file_type())];
    lines.push(match axes(path, product, product.size(path)?)? {
        Some((x, y)) => format!(
            "geography: {} {} to {} {}, {} {} to {} {} (pixel centres; X_FIRST/Y_FIRST are the first pixel's corner); drawn north up",
            x.name,
            x.values[0],
            x.values[x.values.len() - 1],
            x.units.as_deref().unwrap_or(""),
            y.name,
            y.values[0],
            y.values[y.values.len() - 1],
            y.units.as_deref().unwrap_or(""),
        ),
        None => "geography: none (radar coordinates: no X_FIRST/Y_FIRST); grids keep storage order, row 0 drawn at the bottom".to_string(),
    });
    if let Some(u) = product.get("UNIT") {
        lines.push(format!("UNIT: {u}"));
    }
    if let Some(w) = product.wavelength(path)? {
        lines.push(format!(
            "WAVELENGTH: {w} m (one fringe of interferometric phase, 2π, is λ/2 = {} m of line-of-sight motion)",
            w / 2.0
        ));
    }
    if let (Some(lat), Some(lon)) = (product.get("REF_LAT"), product.get("REF_LON")) {
        lines.push(format!("reference point: REF_LAT {lat}, REF_LON {lon}"));
    }
    if let (Some(y), Some(x)) = (product.get("REF_Y"), product.get("REF_X")) {
        lines.push(format!("reference pixel: REF_Y {y}, REF_X {x}"));
    }
    if let Some((values, time)) = product.dates(path)? {
        lines.push(format!(
            "time: {} dates, {} to {} (the `date` list; choose one with --index time=I or --at time=DATE)",
            values.len(),
            time.date(values[0]),
            time.date(values[values.len() - 1])
        ));
    }
    Ok(lines)
}

/// The HDF5 format's reader, here above both plain datasets and MintPy's layout: datasets by
/// path, and MintPy's products (a raster, or a time series whose
/// dates select like a time axis) on their geocoding.
pub(crate) struct Hdf5Reader;

impl super::Reader for Hdf5Reader {
    fn list(&self, path: &Path) -> Result<Vec<ArrayListing>> {
        super::hdf5::list_datasets(path)
    }

    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        rank: Option<usize>,
        sel: &crate::datasets::select::Selection,
    ) -> Result<ArrayData> {
        match open(path)? {
            Some(product) => read_array(path, &product, var, sel, rank.is_some()),
            None => super::hdf5::read_dataset(path, var),
        }
    }

    fn selects(&self, path: &Path) -> Result<bool> {
        Ok(open(path)?.is_some())
    }

    fn holds_many(&self) -> bool {
        true
    }

    fn volume(
        &self,
        path: &Path,
        opts: &crate::datasets::LoadOptions,
    ) -> Result<crate::model::Volume> {
        if open(path)?.is_some() {
            return Err(Error::format(
                path,
                "is a MintPy product, a 2-D raster (a time series: one per date); load it with load_grid (index or at choose a date)",
            ));
        }
        let array = crate::datasets::read_array(path, opts.variable.as_deref(), Some(3))?;
        crate::datasets::volume_from_array(path, array, [None, None, None])
    }

    fn grid_axes(&self, path: &Path, array: &ArrayData) -> Result<super::GridAxes> {
        let Some(product) = open(path)? else {
            return Ok(super::GridAxes::default());
        };
        let (x, y) = axes(path, &product, [array.shape[0], array.shape[1]])?
            .map_or((None, None), |(x, y)| (Some(x), Some(y)));
        Ok(super::GridAxes {
            x,
            y,
            wavelength: product.wavelength(path)?,
            ..super::GridAxes::default()
        })
    }

    fn time_steps(&self, path: &Path, var: Option<&str>) -> Result<Vec<String>> {
        match open(path)? {
            Some(product) => time_steps(path, &product, var),
            None => Err(Error::format(
                path,
                "has no time axis (only MintPy time series among HDF5 files have one)",
            )),
        }
    }
}
