//! Unstructured meshes, as climate, ocean and coastal models write them: UGRID 1.0 flexible
//! meshes, ICON's triangles (cell centres with their vertices, CF bounds), MPAS's Voronoi cells,
//! SCRIP grid files, coastal models' triangle lists (FVCOM, ADCIRC) and columns given by their
//! centres alone (CAM-SE), triangulated ([`delaunay`]). A variable whose last
//! dimension runs over a mesh's cells or nodes is found on its mesh here ([`read`]), from its own
//! file or from a separate grid file, and sampled onto a regular latitude–longitude grid
//! ([`sample`]) so that maps, globes and every grid tool draw it.

pub(crate) mod delaunay;
pub(crate) mod read;
pub(crate) mod sample;

use std::path::Path;

use super::select::{self, Selection};
use crate::datasets::readers::variables;
use crate::datasets::{geographic_axis, GridFile};
use crate::error::{Error, Result};
use crate::model::mesh::{Mesh, MeshField};
use crate::model::{CoordKind, Grid, GridCoords};

/// Arrays that describe meshes rather than hold data on them.
const GEOMETRY: [&str; 24] = [
    "clon",
    "clat",
    "clon_vertices",
    "clat_vertices",
    "vlon",
    "vlat",
    "latCell",
    "lonCell",
    "latVertex",
    "lonVertex",
    "verticesOnCell",
    "nEdgesOnCell",
    "grid_center_lat",
    "grid_center_lon",
    "grid_corner_lat",
    "grid_corner_lon",
    "grid_imask",
    "grid_dims",
    "nv",
    "element",
    "lonc",
    "latc",
    "x",
    "y",
];

/// The variable to draw: `var`, else the file's first variable that lies on a mesh.
fn variable_on_mesh(
    path: &Path,
    var: Option<&str>,
    grid: Option<&Path>,
) -> Result<Option<(String, variables::Dims, Mesh)>> {
    let listed = variables::list_variables(path)?;
    // Without a name: the data variables, not coordinates nor the mesh's own arrays.
    let names: Vec<String> = match var {
        Some(v) => vec![v.to_string()],
        None => crate::datasets::arrays::list_arrays(path)?
            .into_iter()
            .filter(|a| !a.is_coordinate && !a.is_auxiliary && !GEOMETRY.contains(&a.name.as_str()))
            .map(|a| a.name)
            .collect(),
    };
    for name in names {
        let dims = variables::dims_in(&listed, &name);
        if dims.is_empty() {
            continue;
        }
        if let Some(mesh) = read::mesh_of(path, &name, &dims, grid)? {
            return Ok(Some((name, dims, mesh)));
        }
    }
    Ok(None)
}

/// A variable on a mesh read under a selection.
struct OnMesh {
    name: String,
    mesh: Mesh,
    /// How each dimension the selection fixed was chosen.
    notes: Vec<String>,
    values: variables::NcVariable,
}

impl OnMesh {
    /// The variable on its mesh (`None`: on none), its values read under `sel`.
    fn read(
        path: &Path,
        var: Option<&str>,
        sel: &Selection,
        grid: Option<&Path>,
    ) -> Result<Option<OnMesh>> {
        let Some((name, dims, mesh)) = variable_on_mesh(path, var, grid)? else {
            return Ok(None);
        };
        let plan = select::plan(path, &name, &dims, sel)?;
        let values = select::read(path, &name, &plan)?;
        Ok(Some(OnMesh {
            name,
            mesh,
            notes: plan.notes,
            values,
        }))
    }

    /// The selection left more (or other) dimensions than `wanted` says: one line naming them.
    fn refused(&self, path: &Path, wanted: &str) -> Error {
        let kept: Vec<String> = self
            .values
            .dims
            .iter()
            .map(|(d, n)| format!("{d}={n}"))
            .collect();
        Error::format(
            path,
            format!(
                "'{}' on the {} keeps [{}] after the selection; {wanted}",
                self.name,
                self.mesh.describe(),
                kept.join(", ")
            ),
        )
    }
}

/// A variable on an unstructured mesh as it lies there (for drawing cell by cell): the selection
/// fixes every dimension but the mesh's. An error naming the file when the variable (or, without
/// one, every variable) is on no mesh.
pub(crate) fn field(
    path: &Path,
    var: Option<&str>,
    sel: &Selection,
    grid: Option<&Path>,
) -> Result<MeshField> {
    let Some(on) = OnMesh::read(path, var, sel, grid)? else {
        let what = var.map_or("no variable".to_string(), |v| format!("'{v}'"));
        return Err(Error::format(
            path,
            format!(
                "{what} lies on no unstructured mesh (UGRID, ICON, MPAS, SCRIP, FVCOM, ADCIRC or columns){}; load_grid reads grids",
                grid.map_or(String::new(), |g| format!(" that {} describes", g.display()))
            ),
        ));
    };
    let v = &on.values;
    if v.dims.len() != 1 || v.dims[0].0 != on.mesh.dim {
        return Err(on.refused(
            path,
            &format!("fix every dimension but '{}' with index or at", on.mesh.dim),
        ));
    }
    let units = v.units.clone().unwrap_or_default();
    let OnMesh {
        name,
        mesh,
        notes,
        values,
    } = on;
    MeshField::new(mesh, values.data, &name, &units, notes)
        .map_err(|e| Error::format(path, e.to_string()))
}

/// `field` sampled onto a regular latitude–longitude grid at its cells' median size (as
/// `load_grid` samples it), made once per field: what its 3-D views draw.
pub(crate) fn sampled_grid(field: &MeshField) -> Result<std::sync::Arc<Grid>> {
    if let Some(g) = field.sampled.get() {
        return Ok(g.clone());
    }
    let r = sample::regrid(field.mesh(), field.values(), None)?;
    let axis = |name: &str, units: &str, values: Vec<f64>, kind| GridCoords {
        name: name.into(),
        units: units.into(),
        values,
        kind,
        edges: None,
    };
    let x = axis("longitude", "degrees_east", r.lon, CoordKind::Longitude);
    let y = axis("latitude", "degrees_north", r.lat, CoordKind::Latitude);
    let name = format!("{} sampled onto {:.6} degrees", field.describe(), r.step);
    let mut grid = Grid::with_coords(&name, x, y, vec![(field.name().to_string(), r.data)], None)?;
    grid.set_units(field.name(), field.units())?;
    let grid = std::sync::Arc::new(grid);
    Ok(field.sampled.get_or_init(|| grid).clone())
}

/// A variable on an unstructured mesh as a grid: the selection fixes every dimension but the
/// mesh's, and the values are sampled onto a regular latitude–longitude grid of `resolution`
/// degrees (default: the cells' median size). `None` when the variable (or, without one, every
/// variable) is on no mesh and no `grid` file is given.
pub(crate) fn grid_file(
    path: &Path,
    var: Option<&str>,
    sel: &Selection,
    resolution: Option<f64>,
    grid: Option<&Path>,
) -> Result<Option<GridFile>> {
    let Some(on) = OnMesh::read(path, var, sel, grid)? else {
        return match grid {
            Some(g) => Err(Error::format(
                path,
                format!(
                    "grid {}: {} lies on no mesh that file describes",
                    g.display(),
                    var.map_or("no variable".to_string(), |v| format!("'{v}'"))
                ),
            )),
            None => Ok(None),
        };
    };
    let (mesh, v) = (&on.mesh, &on.values);
    if v.dims.len() != 1 || v.dims[0].0 != mesh.dim {
        return Err(on.refused(
            path,
            &format!("fix every dimension but '{}' with index or at", mesh.dim),
        ));
    }
    let r = sample::regrid(mesh, &v.data, resolution)
        .map_err(|e| Error::format(path, format!("'{}': {e}", on.name)))?;
    Ok(Some(GridFile {
        name: on.name.clone(),
        selected: on.notes.clone(),
        units: v.units.clone(),
        shape: [r.lat.len(), r.lon.len()],
        data: r.data,
        x: geographic_axis("longitude", r.lon, CoordKind::Longitude),
        y: geographic_axis("latitude", r.lat, CoordKind::Latitude),
        wavelength: None,
        rotated_pole: None,
        regridded: Some(format!(
            "{}, sampled onto {:.6} degrees",
            mesh.describe(),
            r.step
        )),
    }))
}

/// A variable on a mesh with one more dimension (depth or levels: ICON's `S(depth, ncells)`,
/// MPAS's `temperature(nCells, nVertLevels)`) after the selection, each level sampled onto one
/// latitude–longitude grid of `resolution` degrees: the array (level, latitude, longitude) and
/// its dimensions' coordinates (the level's own from the file, latitude and longitude made), for
/// the volume reader to place on the sphere as any CF volume. `None` when the variable is on no
/// mesh.
pub(crate) fn volume_array(
    path: &Path,
    var: Option<&str>,
    sel: &Selection,
    resolution: Option<f64>,
    grid: Option<&Path>,
) -> Result<Option<(crate::datasets::arrays::ArrayData, Vec<super::cf::DimCoord>)>> {
    let Some(read) = OnMesh::read(path, var, sel, grid)? else {
        return Ok(None);
    };
    let (name, mesh, v) = (&read.name, &read.mesh, &read.values);
    let on = v.dims.iter().position(|(d, _)| *d == mesh.dim);
    let (Some(on), 2) = (on, v.dims.len()) else {
        return Err(read.refused(
            path,
            &format!(
                "a volume needs '{}' and one level dimension: fix the others with index or at",
                mesh.dim
            ),
        ));
    };
    let (level_dim, levels) = v.dims[1 - on].clone();
    let count = mesh.values();
    // Each level's values along the mesh, whichever of the two dimensions comes first.
    let level_values = |l: usize| -> Vec<f64> {
        (0..count)
            .map(|c| {
                if on == 1 {
                    v.data[l * count + c]
                } else {
                    v.data[c * levels + l]
                }
            })
            .collect()
    };
    let mut data = Vec::new();
    let mut axes = None;
    for l in 0..levels {
        let r = sample::regrid(mesh, &level_values(l), resolution)
            .map_err(|e| Error::format(path, format!("'{name}': {e}")))?;
        crate::model::volume::check_allocation(
            (levels * r.data.len() * 8) as u64,
            &format!(
                "'{name}' sampled onto {} x {} nodes at {levels} levels",
                r.lat.len(),
                r.lon.len()
            ),
        )?;
        data.extend_from_slice(&r.data);
        axes.get_or_insert((r.lat, r.lon));
    }
    let (lat, lon) = axes.unwrap_or_default();
    let axis = |name: &str, values: Vec<f64>, standard: &str, units: &str| super::cf::DimCoord {
        name: name.to_string(),
        coord: Some(variables::NcVariable {
            name: name.to_string(),
            dims: vec![(name.to_string(), values.len())],
            data: values,
            units: Some(units.to_string()),
            long_name: None,
            attributes: vec![
                (
                    "standard_name".into(),
                    variables::NcAttribute::Text(standard.into()),
                ),
                ("units".into(), variables::NcAttribute::Text(units.into())),
            ],
            stored_nan: 0,
        }),
    };
    let coords = vec![
        super::cf::DimCoord {
            name: level_dim.clone(),
            coord: super::cf::read_coordinate(path, &level_dim)?,
        },
        axis("latitude", lat.clone(), "latitude", "degrees_north"),
        axis("longitude", lon.clone(), "longitude", "degrees_east"),
    ];
    let mut notes = read.notes.clone();
    notes.push(format!(
        "{}, each level sampled onto latitude and longitude",
        mesh.describe()
    ));
    let array = crate::datasets::arrays::ArrayData {
        name: name.clone(),
        dims: vec![level_dim, "latitude".into(), "longitude".into()],
        shape: vec![levels, lat.len(), lon.len()],
        dtype: "float64".into(),
        units: v.units.clone(),
        fill_count: 0,
        attributes: v.attributes.clone(),
        notes,
        data,
    };
    Ok(Some((array, coords)))
}
