//! Datasets: the files geoscientists have, read through one registry of readers chosen by
//! content (`readers`), given their meaning by the CF conventions (`conventions`), and the
//! generators of the paper's case studies (`generators`); here, the volumes and grids built from
//! what the readers read (`load_volume`, `load_grid`) and the arrays by name across formats.

pub(crate) mod access;
mod arrays;
pub mod bricked;
pub mod cache;
pub mod coastlines;
pub mod conventions;
pub mod describe;
pub mod generators;
pub(crate) mod grid_out;
pub mod info;
pub mod readers;
pub mod series;
mod slabs;
mod stats;

use crate::error::{Error, Result};
use crate::model::{CoordAxis, CoordKind, Geometry, Grid, GridCoords, Volume};
pub use arrays::read_values;
pub(crate) use arrays::{
    fits_rank, missing_array, no_array, plain_array, rank_name, read_netcdf_array, volume_array,
};
pub(crate) use arrays::{list_arrays, read_array, read_array_sel, ArrayData, ArrayListing};
pub use conventions::select;
pub(crate) use conventions::{cf, cf_time, curvilinear};
pub use generators::{generate, mantle, okada, tsunami};
pub(crate) use readers::{geotiff, mintpy, scalar};
pub use readers::{netcdf, npy, Format};
use std::path::Path;

/// That a cell-centred volume's `dims` are at least 1, its `spacing` finite and positive and its
/// `origin` finite (the netCDF and VTK volume writers' shared check).
pub(crate) fn check_volume_geometry(
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
) -> Result<()> {
    for (axis, (&n, &d)) in ["x", "y", "z"].iter().zip(dims.iter().zip(&spacing)) {
        if n == 0 {
            return Err(Error::invalid(format!("dims.{axis}"), "must be at least 1"));
        }
        if !(d.is_finite() && d > 0.0) {
            return Err(Error::invalid(
                format!("spacing.{axis}"),
                format!("is {d}; must be finite and > 0"),
            ));
        }
    }
    if let Some(o) = origin.iter().find(|o| !o.is_finite()) {
        return Err(Error::invalid("origin", format!("has {o}; must be finite")));
    }
    Ok(())
}

/// Loads a scalar volume by the file's reader; see [`load_volume_with`].
pub fn load_volume(path: &Path) -> Result<Volume> {
    load_volume_with(path, &LoadOptions::default())
}

/// [`load_volume_with`] of the variable `var` (else the file's first 3-D data variable).
pub fn load_volume_var(path: &Path, var: Option<&str>) -> Result<Volume> {
    let opts = LoadOptions {
        variable: var.map(str::to_string),
        ..LoadOptions::default()
    };
    load_volume_with(path, &opts)
}

/// How [`load_volume_with`] reads a file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// The array or variable to read.
    pub variable: Option<String>,
    /// Treat geographic coordinates as Cartesian lengths (the box of the coordinate values)
    /// instead of placing the volume on the sphere.
    pub cartesian: bool,
    /// The planet's radius in the vertical axis's unit, over the file's (default 6371 km).
    pub planet_radius: Option<f64>,
    /// Dimensions fixed by position or coordinate value (NetCDF, a MintPy time series' time):
    /// the variable read has the others.
    pub select: select::Selection,
    /// The band of a multi-band GeoTIFF, counted from 1 as GDAL does.
    pub band: Option<usize>,
    /// A NetCDF variable on one of the volume's dimensions, in units of length, to place it by
    /// instead of that dimension's coordinate (a model level's height, say).
    pub vertical: Option<String>,
    /// The step in degrees of the regular grid a curvilinear grid is regridded onto, or an
    /// unstructured mesh sampled onto (default: its median cell edge); refused for other grids.
    pub resolution: Option<f64>,
    /// The file holding the mesh of a variable on an unstructured mesh, when its own file has
    /// only the values (ICON and MPAS keep the grid apart).
    pub grid: Option<std::path::PathBuf>,
    /// A grid reduced over the steps of one of the variable's dimensions (a climatology, a
    /// time mean): [`load_grid_with`] reads each step and combines them node by node.
    pub reduce: Option<ReduceOver>,
}

/// A reduction over the steps `steps` (first and last index, inclusive; all by default) of the
/// dimension `dim`.
#[derive(Clone, Debug, PartialEq)]
pub struct ReduceOver {
    pub dim: String,
    pub how: crate::model::arithmetic::Reduction,
    pub steps: Option<(usize, usize)>,
}

/// Loads a scalar volume by the reader the file's content names ([`Format::of`]): `.npy` (shape (nz, ny, nx)),
/// `.npz` (the array `var`, else the largest 3-D one), `.nc` (the variable `var`, else the first
/// 3-D data variable; dimensions (z, y, x), leading length-1 dimensions such as a single time
/// step are dropped), `.vti`, `.nhdr`/`.nrrd`. For NetCDF, a variable on CF latitude, longitude
/// and a vertical length axis becomes a spherical volume (see [`cf`]) unless
/// `opts.cartesian`. Otherwise an axis whose coordinate variable is evenly spaced (within 1e-5 of
/// its mean step) gets that spacing and the origin `first centre - spacing / 2`, since values
/// are cell centred, and a decreasing coordinate is flipped so that the volume runs in
/// increasing coordinate; an axis without a coordinate variable is indexed (spacing 1, origin
/// 0); when a coordinate is unevenly spaced the volume is rectilinear. Units come from the
/// variable's `units` attribute.
pub fn load_volume_with(path: &Path, opts: &LoadOptions) -> Result<Volume> {
    if let Some(r) = &opts.reduce {
        return Err(Error::invalid(
            r.how.name(),
            "reductions over a dimension make grids (load_grid); a volume keeps its dimensions",
        ));
    }
    let reader = Format::of(path)?.reader();
    if !opts.select.is_empty() && !reader.selects(path)? {
        return Err(Error::format(
            path,
            "selecting by dimension (index, at) needs a NetCDF file",
        ));
    }
    reader.volume(path, opts)
}

/// The one array of a file that holds a volume with its own geometry (VTK ImageData, NRRD,
/// legacy VTK), refused when `var` names another.
pub(crate) fn named_volume(path: &Path, volume: Volume, var: Option<&str>) -> Result<Volume> {
    match var.filter(|w| *w != volume.name) {
        Some(wanted) => Err(Error::format(
            path,
            format!("no array '{wanted}'; the file has: {}", volume.name),
        )),
        None => Ok(volume),
    }
}

pub(crate) fn volume_from_npy(path: &Path) -> Result<Volume> {
    let arr = npy::read_npy::<f32>(path)?;
    if arr.shape.len() != 3 {
        return Err(Error::format(
            path,
            format!(
                "expected a 3-D array of shape (nz, ny, nx), got shape {:?}",
                arr.shape
            ),
        ));
    }
    let dims = [arr.shape[2], arr.shape[1], arr.shape[0]];
    crate::model::volume::check_dims(&dims, &format!("{}: shape", path.display()))?;
    let name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("volume");
    Volume::new(name, dims, [1.0; 3], [0.0; 3], arr.data)
        .map_err(|e| Error::format(path, e.to_string()))
}

/// [`read_grid`] as bare arrays: `(shape [ny, nx], values in C order (x fastest), coordinates
/// (x, y) when the file has them)`.
#[allow(clippy::type_complexity)]
#[cfg(test)]
pub(crate) fn load_grid_arrays(
    path: &Path,
    var: Option<&str>,
) -> Result<(Vec<usize>, Vec<f64>, Option<(Vec<f64>, Vec<f64>)>)> {
    let grid = read_grid(path, var)?;
    let coords = match (grid.x, grid.y) {
        (Some(x), Some(y)) => Some((x.values, y.values)),
        _ => None,
    };
    Ok((grid.shape.to_vec(), grid.data, coords))
}

/// The dates of the time axis of variable `var` (else of the file's first data variable that
/// has one), in ISO 8601: a NetCDF file's CF time axis or a MintPy time series' `date` list.
/// What `times(path)` returns.
pub fn time_steps(path: &Path, var: Option<&str>) -> Result<Vec<String>> {
    Format::of(path)?.reader().time_steps(path, var)
}

/// One coordinate axis of a grid file.
#[derive(Clone, Debug, PartialEq)]
pub struct GridAxis {
    pub name: String,
    pub units: Option<String>,
    pub values: Vec<f64>,
    /// Longitude or latitude as CF marks it (NetCDF), else plain.
    pub kind: CoordKind,
    /// The outer cell edges from the coordinate's CF `bounds`, when it names them.
    pub edges: Option<(f64, f64)>,
}

/// A 2-D field with its metadata, as [`read_grid`] reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct GridFile {
    pub name: String,
    /// How the selection was made, one description per fixed dimension.
    pub selected: Vec<String>,
    pub units: Option<String>,
    /// `[ny, nx]`, x fastest.
    pub shape: [usize; 2],
    pub data: Vec<f64>,
    pub x: Option<GridAxis>,
    pub y: Option<GridAxis>,
    /// The radar wavelength (m) of an InSAR product (MintPy's `WAVELENGTH`).
    pub wavelength: Option<f64>,
    /// The rotated pole of a CF `rotated_latitude_longitude` grid, whose x and y are then its
    /// rotated longitudes and latitudes.
    pub rotated_pole: Option<crate::model::RotatedPole>,
    /// How a curvilinear grid was regridded onto x and y ([`curvilinear`]).
    pub regridded: Option<String>,
}

/// A 2-D field for the surface renderer, with the names and units of the variable and its
/// coordinates. `.npy`: the array; `.npz`: the array `var`, else the largest 2-D one, with
/// coordinates from arrays named `x`/`lon`/`longitude` and `y`/`lat`/`latitude` of matching
/// lengths; `.nc`: the variable `var`, else the first 2-D data variable, with its dimensions'
/// coordinate variables; a MintPy `.h5`: its main dataset on the pixel centres of its
/// geocoding; a GeoTIFF: its one band on its pixel centres. Leading length-1 dimensions are dropped. Coordinates are returned as
/// stored (they may decrease). NaN marks missing values.
pub fn read_grid(path: &Path, var: Option<&str>) -> Result<GridFile> {
    read_grid_with(path, var, &select::Selection::default())
}

/// [`read_grid`] of the variable with the dimensions `sel` fixes (NetCDF, a MintPy time
/// series).
pub fn read_grid_with(path: &Path, var: Option<&str>, sel: &select::Selection) -> Result<GridFile> {
    read_grid_file(path, var, sel, None, None, None)
}

/// [`read_grid_with`] with the band of a GeoTIFF, by the file's reader; a variable on an
/// unstructured mesh (in its file, or in `mesh_grid`) is sampled onto latitude and longitude.
fn read_grid_file(
    path: &Path,
    var: Option<&str>,
    sel: &select::Selection,
    band: Option<usize>,
    resolution: Option<f64>,
    mesh_grid: Option<&Path>,
) -> Result<GridFile> {
    let reader = Format::of(path)?.reader();
    if reader.variables().is_some() || mesh_grid.is_some() {
        if let Some(file) = conventions::mesh::grid_file(path, var, sel, resolution, mesh_grid)? {
            return Ok(file);
        }
    }
    reader.grid(path, var, sel, band, resolution)
}

/// [`Reader::grid`]'s default: the 2-D array `reader` reads, on the axes it gives, a curvilinear
/// grid regridded onto latitude and longitude.
pub(crate) fn grid_of_array<R: readers::Reader + ?Sized>(
    reader: &R,
    path: &Path,
    var: Option<&str>,
    sel: &select::Selection,
    band: Option<usize>,
    resolution: Option<f64>,
) -> Result<GridFile> {
    if let Some(b) = band.filter(|&b| b != 1) {
        return Err(Error::format(
            path,
            format!("band {b}: only GeoTIFF files (.tif, .tiff) have several bands"),
        ));
    }
    let array = read_array_sel(path, var, Some(2), sel)?;
    let [ny, nx] = [array.shape[0], array.shape[1]];
    let axes = reader.grid_axes(path, &array)?;
    let mut file = GridFile {
        name: array.name,
        selected: array.notes,
        units: array.units,
        shape: [ny, nx],
        data: array.data,
        x: axes.x,
        y: axes.y,
        wavelength: axes.wavelength,
        rotated_pole: axes.rotated_pole,
        regridded: None,
    };
    match axes.curvilinear {
        Some((lat, lon)) => {
            regrid_curvilinear(path, &mut file, &array.dims, (lat, lon), resolution)?
        }
        None => no_resolution(path, resolution)?,
    }
    Ok(file)
}

/// A NetCDF grid variable's axes: its dimensions' coordinate variables with their CF kinds, the
/// rotated pole of a rotated-pole grid (whose axes are then longitude and latitude), and the 2-D
/// latitude and longitude of a curvilinear grid (when its axes are not geographic).
pub(crate) fn netcdf_grid_axes(path: &Path, array: &ArrayData) -> Result<readers::GridAxes> {
    let axis = |dim: &str| -> Result<Option<GridAxis>> {
        let Some(var) = cf::read_coordinate(path, dim)? else {
            return Ok(None);
        };
        // Bounds that cannot be read (named but absent) leave the half spacings, as xarray
        // opens such files without them.
        let edges = cf::cf_bounds(path, &var).unwrap_or(None);
        Ok(Some({
            // Longitude, latitude and depth (drawn downward) matter to a grid; a
            // vertical axis's unit check is the volume reader's concern, so its error is
            // not raised here.
            let kind = match cf::axis_role(path, &var) {
                Ok(cf::AxisRole::Longitude) => CoordKind::Longitude,
                Ok(cf::AxisRole::Latitude) => CoordKind::Latitude,
                Ok(cf::AxisRole::Vertical {
                    kind: cf::Vertical::Depth,
                    ..
                }) => CoordKind::Depth,
                _ => CoordKind::Plain,
            };
            GridAxis {
                name: dim.to_string(),
                units: var.units,
                values: var.data,
                kind,
                edges,
            }
        }))
    };
    let (mut x, mut y) = (axis(&array.dims[1])?, axis(&array.dims[0])?);
    // A pressure axis is no length: rows at the standard atmosphere's heights, surface at the
    // bottom, as in a volume.
    for a in [&mut x, &mut y].into_iter().flatten() {
        let heights = a
            .units
            .as_deref()
            .and_then(|u| conventions::atmosphere::heights_km(&a.values, u));
        if let Some(heights) = heights {
            a.values = heights;
            // Bounds in pressure are not edges in height.
            a.edges = None;
            a.name = format!("{} (standard-atmosphere height of its pressure)", a.name);
            a.units = Some("km".into());
        }
    }
    let rotated_pole = cf::rotated_pole(path, &array.name)?;
    if rotated_pole.is_some() {
        // Rotated longitudes and latitudes (CF grid_longitude, grid_latitude).
        for (a, kind) in [
            (&mut x, CoordKind::Longitude),
            (&mut y, CoordKind::Latitude),
        ] {
            if let Some(a) = a {
                a.kind = kind;
            }
        }
    }
    let curvilinear = cf::curvilinear_coords(path, &array.name, &array.attributes, &array.dims)?;
    Ok(readers::GridAxes {
        x,
        y,
        rotated_pole,
        curvilinear,
        wavelength: None,
    })
}

/// A longitude or latitude axis in CF's degrees east or north.
pub(crate) fn geographic_axis(name: &str, values: Vec<f64>, kind: CoordKind) -> Option<GridAxis> {
    let units = match kind {
        CoordKind::Latitude => "degrees_north",
        _ => "degrees_east",
    };
    Some(GridAxis {
        name: name.to_string(),
        units: Some(units.to_string()),
        values,
        kind,
        edges: None,
    })
}

/// A resolution is for curvilinear grids: refused for any other.
pub(crate) fn no_resolution(path: &Path, resolution: Option<f64>) -> Result<()> {
    match resolution {
        Some(r) => Err(Error::format(
            path,
            format!("resolution {r}: only curvilinear grids (2-D latitude and longitude named in a variable's coordinates) and unstructured meshes are regridded; this grid has its own axes"),
        )),
        None => Ok(()),
    }
}

/// `file` (read on its curvilinear dimensions) regridded onto a regular latitude–longitude grid
/// of `resolution` degrees ([`curvilinear`]).
fn regrid_curvilinear(
    path: &Path,
    file: &mut GridFile,
    dims: &[String],
    (lat, lon): (netcdf::NcVariable, netcdf::NcVariable),
    resolution: Option<f64>,
) -> Result<()> {
    let grid = curvilinear::Curvilinear {
        shape: file.shape,
        lat: &lat.data,
        lon: &lon.data,
    };
    let r = curvilinear::regrid(&grid, &file.data, resolution).map_err(|e| {
        Error::format(
            path,
            format!(
                "variable {:?} on {} and {}: {e}",
                file.name, lat.name, lon.name
            ),
        )
    })?;
    let [y, x] = [&dims[dims.len() - 2], &dims[dims.len() - 1]];
    file.regridded = Some(format!(
        "curvilinear {}({y}, {x}) and {}({y}, {x}), {} x {} nodes, regridded onto {:.6} degrees",
        lat.name, lon.name, file.shape[0], file.shape[1], r.step
    ));
    file.shape = [r.lat.len(), r.lon.len()];
    file.x = geographic_axis(&lon.name, r.lon, CoordKind::Longitude);
    file.y = geographic_axis(&lat.name, r.lat, CoordKind::Latitude);
    file.data = r.data;
    Ok(())
}

/// Names an array may have that make it the elevation of a grid rather than a property.
const ELEVATION_NAMES: [&str; 5] = ["elevation", "topo", "topography", "height", "z"];

/// Loads a 2-D field as a [`Grid`]: `.npy` (one property named after the file), `.npz` and
/// NetCDF (every non-coordinate array of the chosen or default array's 2-D shape becomes a
/// property, sorted by name; `x`/`lon` and `y`/`lat` arrays are coordinates; an array named
/// `elevation`, `topo`, `topography`, `height` or `z` of that shape is the elevation). `var` picks
/// one array; with it only that array is a property (plus the elevation).
pub fn load_grid(path: &Path, var: Option<&str>) -> Result<Grid> {
    let opts = LoadOptions {
        variable: var.map(str::to_string),
        ..LoadOptions::default()
    };
    load_grid_with(path, &opts)
}

/// A variable on an unstructured mesh as it lies there, for drawing cell by cell: `opts.variable`
/// (else the file's first variable on a mesh) with the dimensions `opts.select` fixes, its mesh
/// from its file or from `opts.grid`. `resolution` and `band` belong to grids and are refused.
pub fn load_mesh(path: &Path, opts: &LoadOptions) -> Result<crate::model::mesh::MeshField> {
    if opts.resolution.is_some() {
        return Err(Error::invalid(
            "resolution",
            "a mesh is drawn cell by cell; resolution samples it onto a grid with load_grid",
        ));
    }
    if opts.band.is_some() {
        return Err(Error::invalid("band", "bands belong to GeoTIFF grids"));
    }
    if let Some(r) = &opts.reduce {
        return Err(Error::invalid(
            r.how.name(),
            "reductions over a dimension are load_grid's; sample the mesh onto a grid there",
        ));
    }
    conventions::mesh::field(
        path,
        opts.variable.as_deref(),
        &opts.select,
        opts.grid.as_deref(),
    )
}

/// [`load_grid`] of `opts.variable` with the dimensions `opts.select` fixes; the grid's name
/// then says how each was chosen ("… at time 2011-03-11T06:00:00 (index 5)"), and further
/// properties are only those of the same selection's shape that have the selected dimensions.
pub fn load_grid_with(path: &Path, opts: &LoadOptions) -> Result<Grid> {
    if let Some(r) = &opts.reduce {
        return load_grid_reduced(path, opts, r);
    }
    let var = opts.variable.as_deref();
    let file = read_grid_file(
        path,
        var,
        &opts.select,
        opts.band,
        opts.resolution,
        opts.grid.as_deref(),
    )?;
    let [ny, nx] = file.shape;
    let x = grid_coords(file.x, "x", nx);
    let y = grid_coords(file.y, "y", ny);
    let mut props = vec![(file.name.clone(), file.data, file.units.unwrap_or_default())];
    // With a selection, only the named variable: others may lack the selected dimensions; a
    // regridded one stands alone too (the others are on the curvilinear nodes).
    let ask = readers::ExtrasAsked {
        main: &file.name,
        coord_names: [x.name.as_str(), y.name.as_str()],
        shape: [ny, nx],
        only_elevation: var.is_some() || !opts.select.is_empty() || file.regridded.is_some(),
        x_is_longitude: x.kind == CoordKind::Longitude,
    };
    let found = Format::of(path)?.reader().grid_extras(path, &ask)?;
    let elevation = found.elevation;
    if !found.properties.is_empty() {
        props.extend(found.properties);
        props.sort_by(|a, b| a.0.cmp(&b.0));
    }
    let mut name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("grid")
        .to_string();
    if !file.selected.is_empty() {
        name = format!("{name} at {}", file.selected.join(", "));
    }
    let units: Vec<(String, String)> = props.iter().map(|p| (p.0.clone(), p.2.clone())).collect();
    let props = props.into_iter().map(|(n, v, _)| (n, v)).collect();
    let mut grid = Grid::with_coords(&name, x, y, props, elevation)
        .map_err(|e| Error::format(path, format!("{} (variable {:?})", e, file.name)))?;
    for (property, units) in &units {
        grid.set_units(property, units)?;
    }
    // Long names from the data model, where the format has one (NetCDF, HDF5, GRIB, Zarr).
    if Format::of(path)?.reader().variables().is_some() {
        for (property, _) in &units {
            let attributes =
                readers::variables::variable_attributes(path, property).unwrap_or_default();
            if let Some((_, readers::variables::NcAttribute::Text(t))) =
                attributes.iter().find(|(k, _)| k == "long_name")
            {
                grid.set_long_name(property, t)?;
            }
        }
    }
    grid.set_wavelength(file.wavelength);
    grid.set_rotated_pole(file.rotated_pole);
    Ok(grid)
}

/// [`load_grid_with`] reduced over `r.dim`: each step read as a grid with the dimension fixed
/// there (with the options' other selections) and the steps combined node by node
/// ([`crate::model::arithmetic::reduce_grids`]: missing values skipped, as xarray's skipna).
fn load_grid_reduced(path: &Path, opts: &LoadOptions, r: &ReduceOver) -> Result<Grid> {
    let field = r.how.name();
    if opts.select.dims().any(|d| d == r.dim) {
        return Err(Error::invalid(
            field,
            format!("{:?} is both reduced over and fixed by index or at", r.dim),
        ));
    }
    let listed = readers::variables::list_variables(path)?;
    let variable = match &opts.variable {
        Some(v) => v.clone(),
        None => listed
            .iter()
            .find(|(n, dims)| {
                dims.len() > 2
                    && dims.iter().any(|(d, _)| d == &r.dim)
                    && !dims.iter().any(|(d, _)| d == n)
            })
            .map(|(n, _)| n.clone())
            .ok_or_else(|| {
                Error::format(
                    path,
                    format!("no variable has the dimension {:?} to reduce over", r.dim),
                )
            })?,
    };
    let dims = readers::variables::dims_in(&listed, &variable);
    let Some(&(_, n)) = dims.iter().find(|(d, _)| d == &r.dim) else {
        let names: Vec<&str> = dims.iter().map(|(d, _)| d.as_str()).collect();
        return Err(Error::format(
            path,
            format!(
                "{field}: {variable:?} has no dimension {:?}; it has {}",
                r.dim,
                names.join(", ")
            ),
        ));
    };
    let (first, last) = r.steps.unwrap_or((0, n.saturating_sub(1)));
    if n == 0 || first > last || last >= n {
        return Err(Error::invalid(
            field,
            format!(
                "steps {first} to {last} of {:?}, which has {n} (0 to {})",
                r.dim,
                n.saturating_sub(1)
            ),
        ));
    }
    let grids = (first..=last)
        .map(|k| {
            let mut step = opts.clone();
            step.reduce = None;
            step.variable = Some(variable.clone());
            step.select.index.push((r.dim.clone(), k as i64));
            load_grid_with(path, &step)
        })
        .collect::<Result<Vec<Grid>>>()?;
    let refs: Vec<&Grid> = grids.iter().collect();
    let mut grid = crate::model::arithmetic::reduce_grids(&refs, r.how)?;
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("grid");
    grid.set_name(&format!(
        "{stem} {variable}, {field} over {} steps {first} to {last}",
        r.dim
    ));
    for i in 0..grids[0].property_names().len() {
        let (name, long) = (
            grids[0].property_at(i).0.to_string(),
            grids[0].long_name(i).to_string(),
        );
        if !long.is_empty() && grid.property_index(&name).is_ok() {
            grid.set_long_name(&name, &format!("{field} of {long}"))?;
        }
    }
    Ok(grid)
}

/// A grid axis from a file's coordinate array, or node indices when the file has none.
fn grid_coords(axis: Option<GridAxis>, name: &str, n: usize) -> GridCoords {
    match axis {
        Some(a) => GridCoords {
            name: a.name,
            units: a.units.unwrap_or_default(),
            values: a.values,
            kind: a.kind,
            edges: a.edges,
        },
        None => GridCoords::index(name, n),
    }
}

/// The other arrays of `path` with the 2-D shape `[ny, nx]` (after dropping length-1
/// dimensions): elevation-named ones become the elevation, the rest further properties unless
/// `only_elevation`. The array `main`, coordinate variables and arrays named like coordinates
/// (`coord_names`, `x`, `y`, `lon`, `lat`, `longitude`, `latitude`) are skipped.
pub(crate) fn same_shape_arrays(
    path: &Path,
    ask: &readers::ExtrasAsked,
) -> Result<readers::GridExtras> {
    const COORDINATE_NAMES: [&str; 6] = ["x", "y", "lon", "lat", "longitude", "latitude"];
    let (main, coord_names, [ny, nx]) = (ask.main, &ask.coord_names, ask.shape);
    let only_elevation = ask.only_elevation;
    let mut extras = readers::GridExtras::default();
    for a in list_arrays(path)? {
        let name = a.name.as_str();
        if name == main
            || !a.is_data()
            || coord_names.contains(&name)
            || COORDINATE_NAMES.contains(&name)
        {
            continue;
        }
        let is_elevation = ELEVATION_NAMES.contains(&name);
        let squeezed: Vec<usize> = a.shape.iter().cloned().filter(|&s| s != 1).collect();
        if squeezed != [ny, nx] || (only_elevation && !is_elevation) {
            continue;
        }
        let arr = read_array(path, Some(name), Some(2))?;
        if is_elevation {
            extras.elevation = Some(arr.data);
        } else {
            extras
                .properties
                .push((a.name, arr.data, arr.units.unwrap_or_default()));
        }
    }
    Ok(extras)
}

pub(crate) fn volume_from_netcdf(path: &Path, opts: &LoadOptions) -> Result<Volume> {
    if let Some((array, coords)) = conventions::mesh::volume_array(
        path,
        opts.variable.as_deref(),
        &opts.select,
        opts.resolution,
        opts.grid.as_deref(),
    )? {
        return volume_from_mesh(path, array, coords, opts);
    }
    if let Some(r) = opts.resolution {
        return Err(Error::format(
            path,
            format!("resolution {r}: only a variable on an unstructured mesh is sampled into a volume; this one has its own axes"),
        ));
    }
    let array = read_array_sel(path, opts.variable.as_deref(), Some(3), &opts.select)?;
    // The volume's name says how a selection was made ("temp at time 2000-01-16T00:00:00 (index 2)").
    let name = if array.notes.is_empty() {
        array.name.clone()
    } else {
        format!("{} at {}", array.name, array.notes.join(", "))
    };
    let (mut volume, level_note) = volume_from_netcdf_array(path, array, opts)?;
    volume.name = match level_note {
        Some(note) => format!("{name} ({note})"),
        None => name,
    };
    Ok(volume)
}

/// A variable on a mesh, its levels sampled onto latitude and longitude
/// ([`conventions::mesh::volume_array`]): a spherical volume when its level dimension is a
/// depth, radius or height (unless `opts.cartesian`), else a box of longitude, latitude and
/// level index.
fn volume_from_mesh(
    path: &Path,
    array: ArrayData,
    coords: Vec<cf::DimCoord>,
    opts: &LoadOptions,
) -> Result<Volume> {
    let name = format!("{} at {}", array.name, array.notes.join(", "));
    let grid = if opts.cartesian {
        None
    } else {
        spherical_grid_of(path, &array, &coords, opts)?
    };
    let axes = [
        coords[2].coord.as_ref().map(|c| c.data.clone()),
        coords[1].coord.as_ref().map(|c| c.data.clone()),
        None,
    ];
    let mut volume = match grid {
        Some(g) => volume_from_array(path, array, [None, None, None])?
            .with_geometry(Geometry::Spherical(Box::new(g)))
            .map_err(|e| Error::format(path, e.to_string()))?,
        None => volume_from_array(path, array, axes)?,
    };
    volume.name = name;
    Ok(volume)
}

/// [`volume_from_netcdf`] of the array read, and a note when a vertical axis in levels (not a
/// length) was placed by index.
fn volume_from_netcdf_array(
    path: &Path,
    array: ArrayData,
    opts: &LoadOptions,
) -> Result<(Volume, Option<String>)> {
    // The volume's three dimensions: the last three (leading length-1 ones were squeezed).
    let dims: Vec<(String, usize)> = array.dims[array.dims.len() - 3..]
        .iter()
        .cloned()
        .zip(array.shape.iter().copied())
        .collect();
    let mut coords = cf::dim_coords(path, &dims)?;
    let mut placed = None;
    match &opts.vertical {
        Some(name) => cf::use_vertical(path, name, &mut coords)?,
        // Pressure levels at the standard atmosphere's heights, not by index.
        None => placed = conventions::vertical::pressure_as_height(&mut coords),
    }
    if !opts.cartesian {
        refuse_curvilinear(path, &array, &coords)?;
        if let Some(grid) = spherical_grid_of(path, &array, &coords, opts)? {
            let volume = volume_from_array(path, array, [None, None, None])?;
            return volume
                .with_geometry(Geometry::Spherical(Box::new(grid)))
                .map(|v| (v, placed))
                .map_err(|e| Error::format(path, e.to_string()));
        }
    }
    // Volume axes are x, y, z; the array's dimensions run z, y, x. Levels that are not lengths
    // (model levels; pressure was turned into heights above) are placed by index, as an axis
    // without coordinates.
    let mut note = placed;
    let mut axes: [Option<Vec<f64>>; 3] = [None, None, None];
    for (a, d) in coords.iter().rev().enumerate() {
        let Some(c) = &d.coord else { continue };
        if matches!(cf::axis_role(path, c)?, cf::AxisRole::Levels) {
            let units = c.units.as_deref().unwrap_or("");
            note = Some(format!(
                "{} in '{units}' placed by index: name a length coordinate with vertical",
                d.name
            ));
        } else {
            axes[a] = Some(c.data.clone());
        }
    }
    volume_from_array(path, array, axes).map(|v| (v, note))
}

/// A volume on a curvilinear grid (2-D latitude and longitude) has no place on the sphere the
/// renderer knows: refused, naming the way to a level as a regridded surface or the volume in
/// index space.
fn refuse_curvilinear(path: &Path, array: &ArrayData, coords: &[cf::DimCoord]) -> Result<()> {
    let Some((lat, lon)) =
        cf::curvilinear_coords(path, &array.name, &array.attributes, &array.dims)?
    else {
        return Ok(());
    };
    let level = coords.first().map_or("level", |d| d.name.as_str());
    Err(Error::format(
        path,
        format!(
            "variable {:?} is on a curvilinear grid ({} and {} are 2-D); volumes need 1-D latitude and longitude axes: load one {level} as a surface with load_grid(path, #{{ index: #{{ {level}: 0 }} }}) (regridded), or the volume in index space with geometry: \"cartesian\"",
            array.name, lat.name, lon.name
        ),
    ))
}

/// The spherical grid of a NetCDF variable whose last three dimensions CF marks as latitude,
/// longitude and a vertical length axis, else `None`.
fn spherical_grid_of(
    path: &Path,
    array: &ArrayData,
    coords: &[cf::DimCoord],
    opts: &LoadOptions,
) -> Result<Option<crate::model::SphericalGrid>> {
    let sphere = cf::SphereOptions {
        planet_radius: opts.planet_radius,
    };
    let declared = cf::declared_radius(path, &array.attributes)?;
    cf::spherical_grid(path, &array.name, coords, declared, &sphere)
}

/// `hdrvis info`'s line on where a NetCDF volume lies: on the sphere, with its radii and
/// angles, or in a Cartesian box. Dimensions of length 1 (a 2 m `height`, a single level) are
/// labels of the field and a time axis is never space, so both are left out.
pub(crate) fn netcdf_geometry(path: &Path, array: &ArrayData) -> Result<String> {
    let mut spatial: Vec<(String, usize)> = Vec::new();
    for (dim, &len) in array.dims.iter().zip(&array.shape) {
        let time = readers::variables::coordinate_variable(path, dim)?
            .is_some_and(|c| matches!(cf::axis_role(path, &c), Ok(cf::AxisRole::Time)));
        if len > 1 && !time {
            spatial.push((dim.clone(), len));
        }
    }
    let n = spatial.len();
    if n < 3 {
        return Ok("cartesian (not a volume)".into());
    }
    let dims = spatial[n - 3..].to_vec();
    let mut coords = cf::dim_coords(path, &dims)?;
    // As `load_volume` places them: pressure levels at standard-atmosphere heights.
    conventions::vertical::pressure_as_height(&mut coords);
    Ok(
        match spherical_grid_of(path, array, &coords, &LoadOptions::default())? {
            Some(g) => format!("spherical: {g}"),
            None => "cartesian".into(),
        },
    )
}

/// Builds a volume from a 3-D array (z, y, x) and optional cell-centre coordinates per volume
/// axis (x, y, z).
pub(crate) fn volume_from_array(
    path: &Path,
    array: ArrayData,
    axes: [Option<Vec<f64>>; 3],
) -> Result<Volume> {
    let dims = [array.shape[2], array.shape[1], array.shape[0]];
    crate::model::volume::check_dims(&dims, &format!("{}: shape", path.display()))?;
    let mut data: Vec<f32> = array.data.iter().map(|&v| v as f32).collect();
    let mut spacing = [1.0; 3];
    let mut origin = [0.0; 3];
    let uneven = axes
        .iter()
        .flatten()
        .any(|values| even_step(values).is_none());
    if uneven {
        let mut volume = Volume::new(array.name, dims, spacing, origin, data)
            .map_err(|e| Error::format(path, e.to_string()))?;
        volume.units = array.units.unwrap_or_default();
        let rectilinear = rectilinear_axes(path, &axes, dims)?;
        return volume
            .with_geometry(Geometry::Rectilinear(Box::new(rectilinear)))
            .map_err(|e| Error::format(path, e.to_string()));
    }
    for (a, coord) in axes.iter().enumerate() {
        let Some(values) = coord.as_deref() else {
            continue;
        };
        match values {
            [single] => origin[a] = single - 0.5,
            [first, .., last] => {
                let step = (last - first) / (values.len() - 1) as f64;
                spacing[a] = step.abs();
                origin[a] = first.min(*last) - 0.5 * step.abs();
                if step < 0.0 {
                    flip_axis(&mut data, dims, a);
                }
            }
            [] => {}
        }
    }
    let mut volume = Volume::new(array.name, dims, spacing, origin, data)
        .map_err(|e| Error::format(path, e.to_string()))?;
    volume.units = array.units.unwrap_or_default();
    Ok(volume)
}

/// The mean step of coordinates that are evenly spaced within 1e-5 of it, else `None`.
fn even_step(values: &[f64]) -> Option<f64> {
    let [first, .., last] = values else {
        return Some(1.0);
    };
    let step = (last - first) / (values.len() - 1) as f64;
    values
        .windows(2)
        .all(|w| ((w[1] - w[0]) - step).abs() <= 1e-5 * step.abs())
        .then_some(step)
}

/// Coordinate axes of a rectilinear volume: cell-centred, each domain reaching half the end
/// spacing beyond the first and last centres (as a regular axis's cells do); an axis without
/// coordinates is indexed.
fn rectilinear_axes(
    path: &Path,
    axes: &[Option<Vec<f64>>; 3],
    dims: [usize; 3],
) -> Result<[CoordAxis; 3]> {
    let names = ["x", "y", "z"];
    let mut out = Vec::new();
    for a in 0..3 {
        let axis = match &axes[a] {
            None => CoordAxis::uniform_cells(0.0, 1.0, dims[a]),
            Some(values) if values.len() < 2 => CoordAxis::uniform_cells(values[0] - 0.5, 1.0, 1),
            Some(values) => {
                let n = values.len();
                let half_first = 0.5 * (values[1] - values[0]).abs();
                let half_last = 0.5 * (values[n - 1] - values[n - 2]).abs();
                let (lo, hi) = if values[n - 1] > values[0] {
                    (values[0] - half_first, values[n - 1] + half_last)
                } else {
                    (values[n - 1] - half_last, values[0] + half_first)
                };
                CoordAxis::new(
                    values.clone(),
                    Some((lo, hi)),
                    &format!("{}: coordinate of axis {}", path.display(), names[a]),
                )?
            }
        };
        out.push(axis);
    }
    Ok([out[0].clone(), out[1].clone(), out[2].clone()])
}

/// Reverses the order of the voxels along volume axis `axis` (0 = x, 1 = y, 2 = z).
pub(crate) fn flip_axis(data: &mut [f32], dims: [usize; 3], axis: usize) {
    let [nx, ny, nz] = dims;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (ti, tj, tk) = match axis {
                    0 => (nx - 1 - i, j, k),
                    1 => (i, ny - 1 - j, k),
                    _ => (i, j, nz - 1 - k),
                };
                let (a, b) = ((k * ny + j) * nx + i, (tk * ny + tj) * nx + ti);
                if a < b {
                    data.swap(a, b);
                }
            }
        }
    }
}

#[cfg(test)]
mod load_tests {
    use super::*;

    #[test]
    fn netcdf_volume_round_trips_dims_spacing_origin_and_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.nc");
        let data: Vec<f32> = (0..4 * 3 * 2).map(|i| i as f32 * 0.5 - 3.0).collect();
        netcdf::write_volume(
            &path,
            [4, 3, 2],
            [0.5, 2.0, 10.0],
            [-1.0, 4.0, -20.0],
            "km",
            ("rho", &data, "kg m-3", "density"),
            &[],
        )
        .unwrap();
        let v = load_volume(&path).unwrap();
        assert_eq!((v.name.as_str(), v.units.as_str()), ("rho", "kg m-3"));
        assert_eq!(v.dims, [4, 3, 2]);
        for a in 0..3 {
            assert!((v.spacing[a] - [0.5, 2.0, 10.0][a]).abs() < 1e-12);
            assert!((v.origin[a] - [-1.0, 4.0, -20.0][a]).abs() < 1e-12);
        }
        assert_eq!(v.data, data);
        let err = load_volume_var(&path, Some("t")).unwrap_err().to_string();
        assert!(
            err.contains("no variable 't'") && err.contains("rho"),
            "{err}"
        );
    }

    /// A 4 x 3 x 2 volume over six decades, both signs, and its x axis, written to `dir/name`.
    fn write_npz_volume(path: &Path, compressed: bool) -> (Vec<f64>, [f64; 4]) {
        let rho: Vec<f64> = (0..24)
            .map(|i| (i as f64 - 11.5) * 10f64.powi(i % 6 - 3))
            .collect();
        let x = [0.5, 1.5, 2.5, 3.5];
        let zeros = vec![0.0; 4096];
        npy::write_npz(
            path,
            &[
                ("x", &[4], &x),
                ("rho", &[2, 3, 4], &rho),
                ("zeros", &[4096], &zeros),
            ],
            compressed,
        )
        .unwrap();
        (rho, x)
    }

    #[test]
    fn npz_round_trips_stored_and_deflated_members() {
        let dir = tempfile::tempdir().unwrap();
        let mut sizes = Vec::new();
        for compressed in [false, true] {
            let path = dir.path().join(format!("v{compressed}.npz"));
            let (rho, x) = write_npz_volume(&path, compressed);
            let listed = list_arrays(&path).unwrap();
            let shapes: Vec<(&str, &[usize], &str)> = listed
                .iter()
                .map(|a| (a.name.as_str(), a.shape.as_slice(), a.dtype.as_str()))
                .collect();
            assert_eq!(
                shapes,
                [
                    ("x", &[4][..], "<f8"),
                    ("rho", &[2, 3, 4], "<f8"),
                    ("zeros", &[4096], "<f8")
                ]
            );
            // The only 3-D array is the volume; f64 values arrive rounded to f32.
            let v = load_volume(&path).unwrap();
            assert_eq!((v.name.as_str(), v.dims), ("rho", [4, 3, 2]));
            let expect: Vec<f32> = rho.iter().map(|&r| r as f32).collect();
            assert_eq!(v.data, expect);
            assert_eq!(read_array(&path, Some("x"), Some(1)).unwrap().data, x);
            sizes.push(std::fs::metadata(&path).unwrap().len());
        }
        // Stored: at least the 4096 zeros' 32768 bytes; deflated, they shrink to a few dozen.
        assert!(sizes[0] > 32_768 && sizes[1] < 2_000, "{sizes:?}");
    }

    #[test]
    fn unreadable_npz_is_a_one_line_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("good.npz");
        let (rho, _) = write_npz_volume(&good, false);
        let bytes = std::fs::read(&good).unwrap();
        // A byte of rho's first value flipped: the archive stays well-formed, but the member's
        // CRC-32 no longer matches.
        let first = rho[0].to_le_bytes();
        let at = bytes.windows(8).position(|w| w == first).unwrap();
        let mut flipped = bytes.clone();
        flipped[at + 3] ^= 0x40;
        let cases: [(&str, Vec<u8>, &str); 3] = [
            (
                "text.npz",
                b"x,y\n1,2\n".to_vec(),
                "not a readable .npz archive",
            ),
            (
                "half.npz",
                bytes[..bytes.len() / 2].to_vec(),
                "not a readable .npz archive",
            ),
            ("flipped.npz", flipped, "array 'rho'"),
        ];
        for (name, contents, needle) in cases {
            let path = dir.path().join(name);
            std::fs::write(&path, contents).unwrap();
            let err = load_volume(&path).unwrap_err().to_string();
            assert!(err.contains(name) && err.contains(needle), "{err}");
            assert_eq!(err.lines().count(), 1, "{err}");
        }
    }

    #[test]
    fn decreasing_coordinates_are_flipped_and_2d_grids_load() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.nc");
        let (z, y, x) = ([1.0], [30.0, 20.0], [0.0, 1.0, 2.0]);
        let values: Vec<f64> = (0..6).map(f64::from).collect();
        netcdf::write_grid::<f64>(
            &path,
            &[("z", &z, "m"), ("y", &y, "m"), ("x", &x, "m")],
            &[("h", &values, "m", "height")],
            &[],
        )
        .unwrap();
        // A single z level still makes a volume; y runs 30 -> 20 on disk, 20 -> 30 in memory.
        let v = load_volume(&path).unwrap();
        assert_eq!((v.dims, v.spacing[1], v.origin[1]), ([3, 2, 1], 10.0, 15.0));
        assert_eq!(v.data, [3.0, 4.0, 5.0, 0.0, 1.0, 2.0]);
        let (shape, data, coords) = load_grid_arrays(&path, None).unwrap();
        assert_eq!((shape, data), (vec![2, 3], values));
        assert_eq!(coords, Some((x.to_vec(), y.to_vec())));
    }
}
