//! Writing CF-1.8 classic NetCDF grids: coordinate axes with their CF attributes, auxiliary
//! coordinates, data variables with a NaN `_FillValue`, all through `netcdf-writer` into a
//! temporary file renamed into place ([`crate::io::write_atomically`]): a failed write leaves
//! nothing.

use std::path::Path;

use netcdf_reader::NcAttrValue;
use netcdf_writer::{NcFileBuilder, NcWriteOptions};

use super::check_monotonic;
use crate::error::{Error, Result};

/// Sample types `write_grid` stores as they are (NC_FLOAT or NC_DOUBLE).
pub trait GridValue: netcdf_writer::NcFillValueType + sealed::Sealed {
    /// NaN of this type, declared as `_FillValue` so NaN cells read back as missing everywhere.
    const NAN: Self;
}
impl GridValue for f32 {
    const NAN: Self = f32::NAN;
}
impl GridValue for f64 {
    const NAN: Self = f64::NAN;
}
mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A data variable to write: `(name, values in C order, units, long_name)`.
pub(crate) type GridVar<'a, T> = (&'a str, &'a [T], &'a str, &'a str);
/// A coordinate axis to write: `(dimension name, coordinate values, units)`.
pub(crate) type GridCoord<'a> = (&'a str, &'a [f64], &'a str);
/// An auxiliary coordinate along one dimension, not necessarily monotonic (the latitudes of a
/// section's columns): `(name, index of its dimension in the coordinates, values, units)`.
pub(crate) type AuxCoord<'a> = (&'a str, usize, &'a [f64], &'a str);

/// Writes a CF-1.8 classic NetCDF file (64-bit offset, or CDF-5 when a variable is too large for
/// it). `coords` name the dimensions, slowest first (e.g. `lat`, `lon`, or `z`, `y`, `x`); every
/// variable in `vars` spans all of them, in C order. NaN values are declared missing through a
/// NaN `_FillValue`, which is what xarray writes too.
pub fn write_grid<T: GridValue>(
    path: impl AsRef<Path>,
    coords: &[GridCoord<'_>],
    vars: &[GridVar<'_, T>],
    global_attrs: &[(&str, &str)],
) -> Result<()> {
    let no_aux = GridAux {
        aux: &[],
        coord_attrs: &[],
    };
    write_grid_with_aux(path.as_ref(), coords, &no_aux, vars, global_attrs)
}

/// What a grid file carries besides its axes and data: auxiliary coordinates, and further
/// attributes of the axes' coordinate variables as `(dimension name, key, value)` (a depth
/// axis's `positive: "down"`).
pub(crate) struct GridAux<'a> {
    pub aux: &'a [AuxCoord<'a>],
    pub coord_attrs: &'a [(&'a str, &'a str, &'a str)],
}

/// [`write_grid`] with auxiliary coordinates, each a 1-D variable on one of the dimensions that
/// every data variable names in its CF `coordinates` attribute (so xarray reads them as
/// coordinates), and further attributes of the coordinate variables.
pub(crate) fn write_grid_with_aux<T: GridValue>(
    path: &Path,
    coords: &[GridCoord<'_>],
    extra: &GridAux<'_>,
    vars: &[GridVar<'_, T>],
    global_attrs: &[(&str, &str)],
) -> Result<()> {
    let aux = extra.aux;
    if coords.is_empty() {
        return Err(Error::invalid(
            "coords",
            "at least one coordinate axis is required",
        ));
    }
    let mut builder = NcFileBuilder::new();
    let mut dim_ids = Vec::with_capacity(coords.len());
    for &(name, values, units) in coords {
        check_name("coords", name)?;
        if values.is_empty() {
            // A zero length would declare the classic format's unlimited dimension.
            return Err(Error::invalid(
                format!("coords.{name}"),
                "needs at least one value",
            ));
        }
        check_monotonic(values)
            .map_err(|msg| Error::invalid(format!("coords.{name}"), format!("coordinate {msg}")))?;
        let dim = builder
            .add_dimension(name, values.len() as u64)
            .map_err(|e| Error::invalid(format!("coords.{name}"), e.to_string()))?;
        let var = builder
            .add_variable::<f64>(name, &[dim])
            .map_err(|e| Error::invalid(format!("coords.{name}"), e.to_string()))?;
        for (key, value) in coordinate_attributes(name, units) {
            add_text_attr(&mut builder, var, key, &value)?;
        }
        for (_, key, value) in extra.coord_attrs.iter().filter(|a| a.0 == name) {
            add_text_attr(&mut builder, var, key, value)?;
        }
        builder
            .write_variable(var, values)
            .map_err(|e| Error::invalid(format!("coords.{name}"), e.to_string()))?;
        dim_ids.push(dim);
    }
    add_aux_coords(&mut builder, coords, aux, &dim_ids)?;
    let aux_names: Vec<&str> = aux.iter().map(|a| a.0).collect();
    let cells = coords
        .iter()
        .try_fold(1usize, |acc, c| acc.checked_mul(c.1.len()))
        .ok_or_else(|| {
            Error::invalid("coords", "the grid has more cells than memory can address")
        })?;
    for &(name, values, units, long_name) in vars {
        check_name("vars", name)?;
        if values.len() != cells {
            return Err(Error::invalid(
                format!("vars.{name}"),
                format!("has {} values; the coordinates need {cells}", values.len()),
            ));
        }
        let var = builder
            .add_variable::<T>(name, &dim_ids)
            .map_err(|e| Error::invalid(format!("vars.{name}"), e.to_string()))?;
        builder
            .set_variable_fill_value(var, T::NAN)
            .map_err(|e| Error::invalid(format!("vars.{name}"), e.to_string()))?;
        if !units.is_empty() {
            add_text_attr(&mut builder, var, "units", units)?;
        }
        if !long_name.is_empty() {
            add_text_attr(&mut builder, var, "long_name", long_name)?;
        }
        if !aux_names.is_empty() {
            add_text_attr(&mut builder, var, "coordinates", &aux_names.join(" "))?;
        }
        builder
            .write_variable(var, values)
            .map_err(|e| Error::invalid(format!("vars.{name}"), e.to_string()))?;
    }
    let mut has_conventions = false;
    for &(key, value) in global_attrs {
        has_conventions |= key == "Conventions";
        builder
            .add_attribute(key, NcAttrValue::Chars(value.to_string()))
            .map_err(|e| Error::invalid(format!("global_attrs.{key}"), e.to_string()))?;
    }
    if !has_conventions {
        builder
            .add_attribute("Conventions", NcAttrValue::Chars("CF-1.8".into()))
            .map_err(|e| Error::invalid("global_attrs.Conventions", e.to_string()))?;
    }
    write_built(path, &builder)
}

/// Writes the file `builder` describes to `path` atomically: all of it or, on an error, nothing.
pub(crate) fn write_built(path: &Path, builder: &NcFileBuilder) -> Result<()> {
    crate::io::write_atomically(path, |out| {
        builder
            .write(out, NcWriteOptions::default())
            .map(|_| ())
            .map_err(|e| match e {
                netcdf_writer::Error::Io(io) => io,
                other => std::io::Error::other(other.to_string()),
            })
    })
}

/// The auxiliary coordinates `aux` as 1-D variables on their dimensions (`dim_ids`, in the order
/// of `coords`), with the CF attributes of their names less the axis, which the dimension's own
/// coordinate carries.
fn add_aux_coords(
    builder: &mut NcFileBuilder,
    coords: &[GridCoord<'_>],
    aux: &[AuxCoord<'_>],
    dim_ids: &[netcdf_writer::DimensionId],
) -> Result<()> {
    for &(name, dim, values, units) in aux {
        check_name("aux", name)?;
        let field = format!("aux.{name}");
        if coords.get(dim).map(|c| c.1.len()) != Some(values.len()) {
            return Err(Error::invalid(
                field,
                "needs one value per node of its dimension",
            ));
        }
        let var = builder
            .add_variable::<f64>(name, &[dim_ids[dim]])
            .map_err(|e| Error::invalid(field.clone(), e.to_string()))?;
        for (key, value) in coordinate_attributes(name, units) {
            if key != "axis" {
                add_text_attr(builder, var, key, &value)?;
            }
        }
        builder
            .write_variable(var, values)
            .map_err(|e| Error::invalid(field, e.to_string()))?;
    }
    Ok(())
}

/// Writes a cell-centred volume of `dims = [nx, ny, nz]` cells as one variable on dimensions
/// (z, y, x), `data` x fastest. The coordinates are the cell centres
/// `origin + (i + 0.5) * spacing`, so `origin` is the volume's minimum corner, as in `vti`.
#[allow(clippy::too_many_arguments)]
pub fn write_volume(
    path: impl AsRef<Path>,
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    length_units: &str,
    var: GridVar<'_, f32>,
    global_attrs: &[(&str, &str)],
) -> Result<()> {
    crate::datasets::check_volume_geometry(dims, spacing, origin)?;
    let centres = |a: usize| -> Vec<f64> {
        (0..dims[a])
            .map(|i| origin[a] + (i as f64 + 0.5) * spacing[a])
            .collect()
    };
    let (x, y, z) = (centres(0), centres(1), centres(2));
    let coords = [
        ("z", &z[..], length_units),
        ("y", &y[..], length_units),
        ("x", &x[..], length_units),
    ];
    write_grid(path, &coords, &[var], global_attrs)
}

fn check_name(field: &str, name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            format!("{field}.{name}"),
            "names must start with a letter or '_' and use only letters, digits, '_', '-', '.'",
        ))
    }
}

fn coordinate_attributes(name: &str, units: &str) -> Vec<(&'static str, String)> {
    let mut attrs = Vec::new();
    if !units.is_empty() {
        attrs.push(("units", units.to_string()));
    }
    let (standard_name, axis) = match name {
        "lat" | "latitude" => (Some("latitude"), Some("Y")),
        "lon" | "longitude" => (Some("longitude"), Some("X")),
        "x" => (None, Some("X")),
        "y" => (None, Some("Y")),
        "z" | "depth" | "height" | "radius" => (None, Some("Z")),
        "time" => (Some("time"), Some("T")),
        _ => (None, None),
    };
    if let Some(s) = standard_name {
        attrs.push(("standard_name", s.to_string()));
    }
    if let Some(a) = axis {
        attrs.push(("axis", a.to_string()));
    }
    attrs
}

fn add_text_attr(
    builder: &mut NcFileBuilder,
    var: netcdf_writer::VariableId,
    key: &str,
    value: &str,
) -> Result<()> {
    builder
        .add_variable_attribute(var, key, NcAttrValue::Chars(value.to_string()))
        .map_err(|e| Error::invalid(format!("attribute {key}"), e.to_string()))
}
