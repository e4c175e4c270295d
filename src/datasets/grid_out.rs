//! Grids out: any [`Grid`] (a loaded field, a section, a slice, a subset) written as CF NetCDF
//! that xarray, netCDF4 and `load_grid` read back. The grid's y axis is the slower dimension and
//! x the faster, each a coordinate variable with the axis's name and units (degrees_north and
//! degrees_east on a geographic grid); every property is a data variable with its units, the
//! elevation one named `elevation`. A section's per-column `latitude` and `longitude` (properties
//! constant down each column) become 1-D auxiliary coordinates on the x dimension instead, named
//! in every data variable's `coordinates` attribute; [`column_properties`] turns them back into
//! properties when the file is loaded. A depth axis carries `positive: "down"`. The file is
//! written atomically.

use super::netcdf::{self, AuxCoord, GridCoord, GridVar};
use crate::error::{Error, Result};
use crate::model::{CoordKind, Grid, GridCoords};
use std::path::Path;

/// Properties a section keeps per column, written as auxiliary coordinates.
const COLUMN_COORDINATES: [(&str, &str); 2] =
    [("latitude", "degrees_north"), ("longitude", "degrees_east")];

/// Writes `grid` to `path` as CF-1.8 NetCDF (see the module's description).
pub fn save_grid(grid: &Grid, path: &Path) -> Result<()> {
    let (nx, ny) = (grid.nx(), grid.ny());
    let units = |c: &GridCoords| match c.kind {
        CoordKind::Longitude => "degrees_east".to_string(),
        CoordKind::Latitude => "degrees_north".to_string(),
        CoordKind::Plain | CoordKind::Depth => c.units.clone(),
    };
    let (ux, uy) = (units(grid.x()), units(grid.y()));
    if grid.x().name == grid.y().name {
        return Err(Error::invalid(
            "save_grid",
            format!(
                "both axes of grid {:?} are named {:?}; NetCDF needs two dimension names",
                grid.name(),
                grid.x().name
            ),
        ));
    }
    let coords: [GridCoord<'_>; 2] = [
        (&grid.y().name, &grid.y().values, &uy),
        (&grid.x().name, &grid.x().values, &ux),
    ];
    let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
    let mut vars: Vec<(String, &[f64], String)> = Vec::new();
    for i in 0..grid.property_names().len() {
        let (name, values) = grid.property_at(i);
        let per_column = !grid.is_geographic()
            && COLUMN_COORDINATES.iter().any(|(n, _)| *n == name)
            && values.chunks(nx).all(|row| row == &values[..nx]);
        if per_column {
            columns.push((name.to_string(), values[..nx].to_vec()));
        } else {
            vars.push((name.to_string(), values, grid.units(i).to_string()));
        }
    }
    if let Some(e) = grid.elevation() {
        if !vars.iter().any(|v| v.0 == "elevation") {
            vars.push(("elevation".into(), e, String::new()));
        }
    }
    let aux: Vec<AuxCoord<'_>> = columns
        .iter()
        .map(|(name, values)| {
            let unit = COLUMN_COORDINATES
                .iter()
                .find(|(n, _)| n == name)
                .map_or("", |(_, u)| u);
            (name.as_str(), 1, values.as_slice(), unit)
        })
        .collect();
    let data: Vec<GridVar<'_, f64>> = vars
        .iter()
        .map(|(name, values, units)| (name.as_str(), *values, units.as_str(), ""))
        .collect();
    debug_assert!(data.iter().all(|v| v.1.len() == nx * ny));
    // A depth axis says it grows downward, so CF readers (and load_grid) draw it that way.
    let positive: Vec<(&str, &str, &str)> = [grid.x(), grid.y()]
        .into_iter()
        .filter(|c| c.kind == CoordKind::Depth)
        .map(|c| (c.name.as_str(), "positive", "down"))
        .collect();
    let extra = netcdf::GridAux {
        aux: &aux,
        coord_attrs: &positive,
    };
    netcdf::write_grid_with_aux(
        path,
        &coords,
        &extra,
        &data,
        &[("title", grid.name()), ("source", "hdrvis save_grid")],
    )
}

/// The per-column auxiliary coordinates (`latitude`, `longitude`) of a grid file whose x
/// dimension is `x_dim` (`nx` long), each repeated down the `ny` rows as a property
/// `(name, values, units)`, as a section holds them.
pub(crate) fn column_properties(
    path: &Path,
    x_dim: &str,
    [ny, nx]: [usize; 2],
) -> Result<Vec<(String, Vec<f64>, String)>> {
    let mut out = Vec::new();
    for (name, dims) in netcdf::list_variables(path)? {
        let on_x = dims.len() == 1 && dims[0].0 == x_dim && dims[0].1 == nx;
        if !on_x || name == x_dim || !COLUMN_COORDINATES.iter().any(|(n, _)| *n == name) {
            continue;
        }
        let column = super::read_array(path, Some(&name), Some(1))?;
        let values = (0..ny).flat_map(|_| column.data.iter().copied()).collect();
        out.push((name, values, column.units.unwrap_or_default()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_geographic_grid_round_trips_through_load_grid() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nc");
        let v: Vec<f64> = (0..12).map(|i| i as f64 * 0.5 - 2.0).collect();
        let mut g = Grid::from_lon_lat(
            "g",
            vec![10.0, 20.0, 30.0, 40.0],
            vec![-5.0, 0.0, 5.0],
            vec![("uz".into(), v.clone())],
        )
        .unwrap();
        g.set_units("uz", "m").unwrap();
        save_grid(&g, &path).unwrap();
        let back = crate::datasets::load_grid(&path, None).unwrap();
        assert!(back.is_geographic());
        assert_eq!(back.x().values, g.x().values);
        assert_eq!(back.y().values, g.y().values);
        assert_eq!(back.property("uz").unwrap(), &v[..]);
        assert_eq!(back.units(0), "m");
    }
}
