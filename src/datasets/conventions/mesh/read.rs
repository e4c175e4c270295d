//! Finding a variable's mesh by the conventions models write, in their order of precedence:
//! UGRID 1.0 (the variable's `mesh` and `location`; the topology's node coordinates and
//! `face_node_connectivity` with its `start_index` and fill values), MPAS (`verticesOnCell`,
//! `nEdgesOnCell`, `latVertex`/`lonVertex`, radians), SCRIP (`grid_corner_lat`/`_lon`), CF cell
//! bounds on 1-D longitude and latitude (ICON's `clon`/`clat` with `clon_vertices`, radians, and
//! what CDO writes for unstructured grids) and coastal models' triangle lists (FVCOM's `nv`,
//! ADCIRC's `element`, 0- or 1-based) with node longitudes and latitudes. The geometry comes from
//! the variable's own file or from `grid` (ICON and MPAS keep it apart); a grid whose cell count
//! matches none of the variable's dimensions is refused.

use std::path::Path;

use crate::datasets::conventions::cf::{attr_number, attr_text};
use crate::datasets::readers::variables::{self, Dims, NcAttribute, NcVariable};
use crate::error::{Error, Result};
use crate::model::mesh::{Location, Mesh};

type Attributes = Vec<(String, NcAttribute)>;

/// The file a mesh's geometry is read from, with its variables listed once.
struct Source<'a> {
    path: &'a Path,
    listed: Vec<(String, Dims)>,
}

impl<'a> Source<'a> {
    fn open(path: &'a Path) -> Result<Source<'a>> {
        Ok(Source {
            path,
            listed: variables::list_variables(path)?,
        })
    }

    fn has(&self, name: &str) -> bool {
        self.listed.iter().any(|(n, _)| n == name)
    }

    fn dims(&self, name: &str) -> Dims {
        variables::dims_in(&self.listed, name)
    }

    fn read(&self, name: &str) -> Result<NcVariable> {
        variables::read_variable(self.path, name)
    }

    fn attributes(&self, name: &str) -> Result<Attributes> {
        variables::variable_attributes(self.path, name)
    }

    /// Variable `name` as degrees: radians converted, by its `units` (or `fallback` when it has
    /// none); any other unit is refused.
    fn degrees(&self, name: &str, fallback: &str) -> Result<Vec<f64>> {
        let v = self.read(name)?;
        let units = v.units.clone().unwrap_or_else(|| fallback.to_string());
        let u = units.trim().to_ascii_lowercase();
        let scale = if u.starts_with("radian") || u == "rad" {
            180.0 / std::f64::consts::PI
        } else if u.starts_with("degree") || u == "deg" {
            1.0
        } else {
            return Err(Error::format(
                self.path,
                format!("mesh coordinate '{name}' in unknown units '{units}'; expected degrees or radians"),
            ));
        };
        Ok(v.data.iter().map(|x| x * scale).collect())
    }
}

/// The mesh variable `name` (dimensions `dims`) of `path` lies on, if any.
pub(crate) fn mesh_of(
    path: &Path,
    name: &str,
    dims: &Dims,
    grid: Option<&Path>,
) -> Result<Option<Mesh>> {
    let attrs = variables::variable_attributes(path, name)?;
    let src = Source::open(grid.unwrap_or(path))?;
    let found = if let Some(topology) = attr_text(&attrs, "mesh") {
        // The topology in the grid file, else beside the variable.
        let own;
        let from = match grid {
            Some(_) if !src.has(topology) => {
                own = Source::open(path)?;
                &own
            }
            _ => &src,
        };
        Some(ugrid(from, topology, attr_text(&attrs, "location"))?)
    } else if let Some((topology, location)) = ugrid_by_dimension(&src, dims)? {
        Some(ugrid(&src, &topology, Some(location))?)
    } else if src.has("verticesOnCell") && src.has("nEdgesOnCell") {
        Some(mpas(&src, dims)?)
    } else if src.has("grid_corner_lat") && src.has("grid_corner_lon") {
        Some(scrip(&src)?)
    } else if let Some(m) = bounded(&src, &attrs)? {
        Some(m)
    } else if let Some(m) = triangles(&src, dims)? {
        Some(m)
    } else {
        columns(&src, &attrs, dims)?
    };
    let Some(mut mesh) = found else {
        return Ok(None);
    };
    if mesh.lon.len() != mesh.lat.len() {
        return Err(Error::format(
            src.path,
            format!(
                "{} mesh with {} node longitudes but {} latitudes",
                mesh.kind,
                mesh.lon.len(),
                mesh.lat.len()
            ),
        ));
    }
    // The variable's dimension that runs over the mesh: by name, else (from a grid file) by length.
    let want = mesh.values();
    let on = dims
        .iter()
        .rev()
        .find(|(d, n)| *d == mesh.dim && *n == want)
        .or_else(|| grid.and_then(|_| dims.iter().rev().find(|(_, n)| *n == want)));
    match on {
        Some((d, _)) => {
            if let Some(g) = grid {
                mesh.pairing = pairing(path, g, *d != mesh.dim, want)?;
            }
            mesh.dim = d.clone();
            Ok(Some(mesh))
        }
        None if grid.is_some() => Err(Error::format(
            path,
            format!(
                "'{name}' has dimensions [{}], none of the {want} {} of the {} in {}",
                dims.iter()
                    .map(|(d, n)| format!("{d}={n}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                if mesh.location == Location::Faces {
                    "cells"
                } else {
                    "nodes"
                },
                mesh.describe(),
                src.path.display()
            ),
        )),
        None => Ok(None),
    }
}

/// Whether the values of `data` lie on `grid`'s cells, as far as the files can tell: both name
/// their grid's `uuidOfHGrid` (as ICON writes it) and these differ: refused; they agree: paired.
/// Otherwise, when only the count of `n` cells or nodes ties them (the values name a grid the
/// grid file does not, or the dimensions' names differ: `by_length`), the pairing says so, since
/// two grids of one size may number their cells differently.
fn pairing(data: &Path, grid: &Path, by_length: bool, n: usize) -> Result<Option<String>> {
    let uuid = |p: &Path| -> Result<Option<String>> {
        Ok(attr_text(&variables::global_attributes(p)?, "uuidOfHGrid").map(str::to_string))
    };
    let name = grid.file_name().map_or_else(
        || grid.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    match (uuid(data)?, uuid(grid)?) {
        (Some(a), Some(b)) if a != b => Err(Error::format(
            data,
            format!(
                "its values are on the grid uuidOfHGrid {a}, but the grid file {} is {b}",
                grid.display()
            ),
        )),
        (Some(_), Some(_)) => Ok(None),
        (Some(a), None) => Ok(Some(format!(
            "paired with {name} by its {n} count alone: the values name the grid uuidOfHGrid {a}, which {name} does not carry"
        ))),
        _ if by_length => Ok(Some(format!(
            "paired with {name} by its {n} count alone: neither dimension names nor uuidOfHGrid tie them"
        ))),
        _ => Ok(None),
    }
}

/// Cells from rows of node indices (`rows` of `width`), `base`-based, ending early at a fill
/// (NaN or negative): each checked against the `nodes` the mesh has.
fn cells<T: Copy + Into<f64>>(
    src: &Source,
    what: &str,
    rows: impl Iterator<Item = impl AsRef<[T]>>,
    base: f64,
    nodes: usize,
) -> Result<(Vec<usize>, Vec<usize>)> {
    let mut offsets = Vec::with_capacity(rows.size_hint().0 + 1);
    offsets.push(0);
    let mut flat = Vec::with_capacity(rows.size_hint().0 * 3);
    for (f, row) in rows.enumerate() {
        let start = flat.len();
        for &v in row.as_ref() {
            let v: f64 = v.into();
            if !v.is_finite() || v < base {
                break;
            }
            let n = v - base;
            // A whole node number below the count (the cast, not fract(): a library call per
            // node on baseline x86-64, and meshes have tens of millions of them).
            if n >= nodes as f64 || (n as usize) as f64 != n {
                return Err(Error::format(
                    src.path,
                    format!("'{what}' cell {f} names node {v} (base {base}); the mesh has {nodes} nodes"),
                ));
            }
            flat.push(n as usize);
        }
        if flat.len() - start < 3 {
            return Err(Error::format(
                src.path,
                format!(
                    "'{what}' cell {f} has {} nodes; expected at least 3",
                    flat.len() - start
                ),
            ));
        }
        offsets.push(flat.len());
    }
    Ok((offsets, flat))
}

/// The rows of a 2-D variable, transposed when its cells run along its second dimension.
fn rows_of(v: &NcVariable, cells_first: bool) -> Vec<Vec<f64>> {
    let (a, b) = (v.dims[0].1, v.dims[1].1);
    if cells_first {
        v.data.chunks(b.max(1)).map(<[f64]>::to_vec).collect()
    } else {
        (0..b)
            .map(|j| (0..a).map(|i| v.data[i * b + j]).collect())
            .collect()
    }
}

fn ugrid(src: &Source, topology: &str, location: Option<&str>) -> Result<Mesh> {
    let t = src.attributes(topology)?;
    let bad = |why: String| Error::format(src.path, format!("UGRID mesh '{topology}': {why}"));
    let coords =
        attr_text(&t, "node_coordinates").ok_or_else(|| bad("no node_coordinates".into()))?;
    let names: Vec<&str> = coords.split_whitespace().collect();
    let [x, y] = names[..] else {
        return Err(bad(format!(
            "node_coordinates '{coords}'; expected two variables"
        )));
    };
    // CF orders them x then y; standard names or units say which is the latitude when not.
    let is_lat = |n: &str| -> bool {
        src.attributes(n).is_ok_and(|a| {
            attr_text(&a, "standard_name") == Some("latitude")
                || attr_text(&a, "units").is_some_and(|u| u.contains("north"))
        })
    };
    let (lon_name, lat_name) = if is_lat(x) { (y, x) } else { (x, y) };
    let (lon, lat) = (
        src.degrees(lon_name, "degrees")?,
        src.degrees(lat_name, "degrees")?,
    );
    let conn_name = attr_text(&t, "face_node_connectivity")
        .ok_or_else(|| bad("no face_node_connectivity".into()))?;
    let conn = src.read(conn_name)?;
    if conn.dims.len() != 2 {
        return Err(bad(format!("'{conn_name}' is not 2-D")));
    }
    let face_dim = ugrid_face_dim(src, &t, &conn.dims).map_err(bad)?;
    let base = attr_number(&src.attributes(conn_name)?, "start_index").unwrap_or(0.0);
    let (offsets, nodes) = cells(
        src,
        conn_name,
        rows_of(&conn, conn.dims[0].0 == face_dim).into_iter(),
        base,
        lon.len(),
    )?;
    let (location, dim) = match location {
        Some("face") | None => (Location::Faces, face_dim),
        Some("node") => match src.dims(lon_name).first() {
            Some(d) => (Location::Nodes, d.0.clone()),
            None => return Err(bad(format!("node coordinate '{lon_name}' is not 1-D"))),
        },
        Some(other) => {
            return Err(bad(format!(
                "values on '{other}' are not drawn (faces and nodes are)"
            )))
        }
    };
    Ok(Mesh {
        kind: "UGRID".into(),
        lon,
        lat,
        offsets,
        nodes,
        location,
        dim,
        pairing: None,
    })
}

/// The dimension of a UGRID topology's faces: its `face_dimension`, else that of its
/// `face_coordinates` (UGRID 0.9 files store the connectivity (nodes, faces) and say so only
/// there), else the connectivity's first, as UGRID 1.0 defaults. It must be one of the
/// connectivity's two dimensions.
fn ugrid_face_dim(
    src: &Source,
    topology: &Attributes,
    conn: &Dims,
) -> std::result::Result<String, String> {
    let of_coordinates = || {
        let first = attr_text(topology, "face_coordinates")?
            .split_whitespace()
            .next()?;
        match &src.dims(first)[..] {
            [(d, _)] => Some(d.clone()),
            _ => None,
        }
    };
    let dim = attr_text(topology, "face_dimension")
        .map(str::to_string)
        .or_else(of_coordinates)
        .or_else(|| conn.first().map(|d| d.0.clone()))
        .unwrap_or_default();
    if conn.iter().any(|(d, _)| *d == dim) {
        Ok(dim)
    } else {
        Err(format!(
            "face dimension '{dim}' is not one of the connectivity's [{}]",
            conn.iter()
                .map(|(d, _)| d.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    }
}

/// The UGRID topology of `src` whose faces or nodes a variable without a `mesh` attribute runs
/// along (UGRID 0.9 files name the mesh only on some of their variables), and where its values
/// lie.
fn ugrid_by_dimension(src: &Source, dims: &Dims) -> Result<Option<(String, &'static str)>> {
    for (name, _) in src.listed.iter().filter(|(_, d)| d.is_empty()) {
        let t = src.attributes(name)?;
        let Some(conn) = attr_text(&t, "face_node_connectivity") else {
            continue;
        };
        let faces = ugrid_face_dim(src, &t, &src.dims(conn)).ok();
        let nodes = attr_text(&t, "node_coordinates")
            .and_then(|c| c.split_whitespace().next())
            .and_then(|x| src.dims(x).first().map(|d| d.0.clone()));
        for (d, _) in dims.iter().rev() {
            if Some(d) == faces.as_ref() {
                return Ok(Some((name.clone(), "face")));
            }
            if Some(d) == nodes.as_ref() {
                return Ok(Some((name.clone(), "node")));
            }
        }
    }
    Ok(None)
}

/// MPAS's rows of `width` vertex numbers: each cell's first `counts` entries, up to a missing one.
fn edge_rows<'a, T>(
    values: &'a [T],
    width: usize,
    counts: &'a [f64],
    missing: impl Fn(&T) -> bool + 'a,
) -> impl Iterator<Item = &'a [T]> + 'a {
    values.chunks(width).zip(counts).map(move |(row, &n)| {
        let row = &row[..(n.max(0.0) as usize).min(row.len())];
        &row[..row.iter().position(&missing).unwrap_or(row.len())]
    })
}

fn mpas(src: &Source, dims: &Dims) -> Result<Mesh> {
    let lon = src.degrees("lonVertex", "radians")?;
    let lat = src.degrees("latVertex", "radians")?;
    let counts = src.read("nEdgesOnCell")?.data;
    let width = src.dims("verticesOnCell").get(1).map_or(0, |d| d.1).max(1);
    // Each row's first nEdgesOnCell entries, up to a missing one (the decoded read's NaN).
    let (offsets, nodes) = match variables::read_integers(src.path, "verticesOnCell")? {
        Some(ints) => {
            let rows = edge_rows(&ints.values, width, &counts, |v| ints.missing.contains(v));
            cells(src, "verticesOnCell", rows, 1.0, lon.len())?
        }
        None => {
            let v = src.read("verticesOnCell")?;
            let rows = edge_rows(&v.data, width, &counts, |v| v.is_nan());
            cells(src, "verticesOnCell", rows, 1.0, lon.len())?
        }
    };
    let on_nodes =
        dims.iter().any(|(d, _)| d == "nVertices") && !dims.iter().any(|(d, _)| d == "nCells");
    Ok(Mesh {
        kind: "MPAS".into(),
        lon,
        lat,
        offsets,
        nodes,
        location: if on_nodes {
            Location::Nodes
        } else {
            Location::Faces
        },
        dim: if on_nodes { "nVertices" } else { "nCells" }.into(),
        pairing: None,
    })
}

/// Cells whose corners are stored with each cell: `(cells, corners)` longitudes and latitudes,
/// each corner its own node.
fn corner_cells(src: &Source, kind: &str, lon: &str, lat: &str, fallback: &str) -> Result<Mesh> {
    let (x, y) = (src.degrees(lon, fallback)?, src.degrees(lat, fallback)?);
    let v = src.dims(lon);
    if v.len() != 2 || src.dims(lat) != v {
        return Err(Error::format(
            src.path,
            format!("'{lon}' and '{lat}' must share two dimensions (cells, corners)"),
        ));
    }
    let (count, corners) = (v[0].1, v[1].1);
    // A repeated last corner (SCRIP pads triangles so) is dropped; cells keep at least three.
    let mut offsets = vec![0];
    let mut nodes = Vec::with_capacity(x.len());
    for c in 0..count {
        let start = nodes.len();
        for k in 0..corners {
            let n = c * corners + k;
            let same = nodes.len() > start && {
                let p = nodes[nodes.len() - 1];
                x[p] == x[n] && y[p] == y[n]
            };
            if x[n].is_finite() && y[n].is_finite() && !same {
                nodes.push(n);
            }
        }
        if nodes.len() - start < 3 {
            return Err(Error::format(
                src.path,
                format!(
                    "'{lon}' cell {c} has {} distinct corners; expected at least 3",
                    nodes.len() - start
                ),
            ));
        }
        offsets.push(nodes.len());
    }
    Ok(Mesh {
        kind: kind.into(),
        lon: x,
        lat: y,
        offsets,
        nodes,
        location: Location::Faces,
        dim: v[0].0.clone(),
        pairing: None,
    })
}

fn scrip(src: &Source) -> Result<Mesh> {
    if attr_text(&src.attributes("grid_corner_lat")?, "units").is_none() {
        return Err(Error::format(
            src.path,
            "SCRIP 'grid_corner_lat' has no units; expected degrees or radians",
        ));
    }
    corner_cells(
        src,
        "SCRIP",
        "grid_corner_lon",
        "grid_corner_lat",
        "degrees",
    )
}

/// 1-D longitude and latitude with CF `bounds` of shape (cells, vertices): among the variable's
/// `coordinates`, else ICON's `clon`/`clat`.
fn bounded(src: &Source, attrs: &Attributes) -> Result<Option<Mesh>> {
    let mut candidates: Vec<String> = attr_text(attrs, "coordinates")
        .map(|c| c.split_whitespace().map(str::to_string).collect())
        .unwrap_or_default();
    candidates.extend(["clon", "clat", "lon", "lat", "longitude", "latitude"].map(String::from));
    let mut lon: Option<(String, String, Dims)> = None;
    let mut lat: Option<(String, String, Dims)> = None;
    for c in candidates
        .iter()
        .filter(|c| src.has(c) && src.dims(c).len() == 1)
    {
        let a = src.attributes(c)?;
        // Cells of at least three corners (a regular axis's bounds have two).
        let Some(b) = attr_text(&a, "bounds")
            .filter(|b| src.has(b) && src.dims(b).len() == 2 && src.dims(b)[1].1 >= 3)
        else {
            continue;
        };
        let units = attr_text(&a, "units").unwrap_or_default();
        let standard = attr_text(&a, "standard_name").unwrap_or_default();
        let latitude = standard == "latitude" || units.contains("north") || c.contains("lat");
        let slot = if latitude { &mut lat } else { &mut lon };
        slot.get_or_insert((b.to_string(), units.to_string(), src.dims(c)));
    }
    // Both on the one dimension of the cells.
    let (Some((lon_b, lon_units, on)), Some((lat_b, _, also))) = (lon, lat) else {
        return Ok(None);
    };
    if on != also {
        return Ok(None);
    }
    // ICON keeps the units on the centres; its bounds may have none.
    let fallback = if lon_units.is_empty() {
        "degrees".to_string()
    } else {
        lon_units
    };
    let kind = if lon_b.starts_with("clon") {
        "ICON"
    } else {
        "CF cell bounds"
    };
    corner_cells(src, kind, &lon_b, &lat_b, &fallback).map(Some)
}

/// Names coastal models give their triangle lists.
const TRIANGLE_LISTS: [&str; 6] = ["nv", "element", "ele", "elements", "face_nodes", "tri"];

fn triangles(src: &Source, dims: &Dims) -> Result<Option<Mesh>> {
    let Some(list) = TRIANGLE_LISTS
        .iter()
        .find(|n| src.has(n) && src.dims(n).len() == 2)
    else {
        return Ok(None);
    };
    let ld = src.dims(list);
    let cells_first = matches!(ld[1].1, 3 | 4);
    if !cells_first && !matches!(ld[0].1, 3 | 4) {
        return Ok(None);
    }
    let (lon_name, lat_name) = [("lon", "lat"), ("x", "y"), ("longitude", "latitude")]
        .into_iter()
        .find(|(a, b)| src.has(a) && src.has(b) && src.dims(a).len() == 1)
        .ok_or_else(|| {
            Error::format(
                src.path,
                format!(
                    "triangle list '{list}' without node longitudes and latitudes (lon/lat or x/y)"
                ),
            )
        })?;
    let (lon, lat) = (
        src.degrees(lon_name, "degrees")?,
        src.degrees(lat_name, "degrees")?,
    );
    let v = src.read(list)?;
    let finite = v.data.iter().filter(|x| x.is_finite());
    let lowest = finite.clone().fold(f64::INFINITY, |a, &b| a.min(b));
    let highest = finite.fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let base = match attr_number(&src.attributes(list)?, "start_index") {
        Some(b) => b,
        // FVCOM and ADCIRC count from 1: a list that never names node 0 and names node N is.
        None if lowest >= 1.0 && highest == lon.len() as f64 => 1.0,
        None => 0.0,
    };
    let (offsets, nodes) = cells(
        src,
        list,
        rows_of(&v, cells_first).into_iter(),
        base,
        lon.len(),
    )?;
    let node_dim = src.dims(lon_name)[0].clone();
    let face_dim = if cells_first {
        ld[0].clone()
    } else {
        ld[1].clone()
    };
    let on_nodes = dims.contains(&node_dim) || !dims.contains(&face_dim);
    let kind = match *list {
        "nv" => "FVCOM",
        "element" => "ADCIRC",
        _ => "triangle list",
    };
    Ok(Some(Mesh {
        kind: kind.into(),
        lon,
        lat,
        offsets,
        nodes,
        location: if on_nodes {
            Location::Nodes
        } else {
            Location::Faces
        },
        dim: if on_nodes { node_dim.0 } else { face_dim.0 },
        pairing: None,
    }))
}

/// Whether points along `dim` are a path in time rather than columns: `dim` is a time axis (a
/// ship's or an aircraft's track, a station's series), or the file is one of CF's discrete
/// sampling geometries other than points (`featureType` trajectory, timeSeries, profile, ...).
fn is_a_path(src: &Source, dim: &str) -> Result<bool> {
    if src.has(dim)
        && attr_text(&src.attributes(dim)?, "units").is_some_and(|u| u.contains(" since "))
    {
        return Ok(true);
    }
    let globals = variables::global_attributes(src.path)?;
    Ok(attr_text(&globals, "featureType").is_some_and(|f| !f.eq_ignore_ascii_case("point")))
}

/// Columns with only their centres: 1-D latitude and longitude on one dimension that is not
/// their own (CAM-SE's `lat(ncol)`, `lon(ncol)`), which the variable has; their cells are the
/// spherical Delaunay triangles of the centres ([`super::delaunay`]), the values on the nodes.
fn columns(src: &Source, attrs: &Attributes, dims: &Dims) -> Result<Option<Mesh>> {
    let mut names: Vec<String> = attr_text(attrs, "coordinates")
        .map(|c| c.split_whitespace().map(str::to_string).collect())
        .unwrap_or_default();
    names.extend(["lon", "lat", "longitude", "latitude", "clon", "clat"].map(String::from));
    let one_d = |n: &String| {
        let d = src.dims(n);
        (src.has(n) && d.len() == 1 && d[0].0 != *n).then(|| d[0].clone())
    };
    let pick = |latitude: bool| -> Result<Option<(String, (String, usize))>> {
        for n in &names {
            let Some(d) = one_d(n) else { continue };
            let a = src.attributes(n)?;
            let units = attr_text(&a, "units").unwrap_or_default();
            let is_lat = attr_text(&a, "standard_name") == Some("latitude")
                || units.contains("north")
                || n.contains("lat");
            if is_lat == latitude {
                return Ok(Some((n.clone(), d)));
            }
        }
        Ok(None)
    };
    let (Some((lon_name, on)), Some((lat_name, also))) = (pick(false)?, pick(true)?) else {
        return Ok(None);
    };
    if on != also || on.1 < 3 || !dims.iter().any(|(_, n)| *n == on.1) {
        return Ok(None);
    }
    if is_a_path(src, &on.0)? {
        return Ok(None);
    }
    let (lon, lat) = (
        src.degrees(&lon_name, "degrees")?,
        src.degrees(&lat_name, "degrees")?,
    );
    // Points along one great circle (a section's path) are a line, not columns.
    if super::delaunay::on_one_great_circle(&lon, &lat) {
        return Ok(None);
    }
    let tris = super::delaunay::triangulate(&lon, &lat).map_err(|why| {
        Error::format(
            src.path,
            format!("columns '{lon_name}', '{lat_name}': {why}"),
        )
    })?;
    let offsets = (0..=tris.len()).map(|k| 3 * k).collect();
    Ok(Some(Mesh {
        kind: "columns (spherical Delaunay of their centres)".into(),
        lon,
        lat,
        offsets,
        nodes: tris.into_iter().flatten().collect(),
        location: Location::Nodes,
        dim: on.0,
        pairing: None,
    }))
}
