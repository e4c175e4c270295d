//! The mesh benchmark (`hdrvis bench meshes`): MPAS-like Voronoi meshes of the icosahedron (the
//! meshes MPAS's quasi-uniform grids are: level 9 has MPAS's 15 km mesh's 2 621 442 cells),
//! written as MPAS writes them (radians, `verticesOnCell` 1-based), then timed as a user meets
//! them: `load_grid` (read, mesh, sample onto latitude and longitude at the cells' median size,
//! then at the picture's pixel) and a map render of the result, and `load_mesh` (read, mesh,
//! spatial index) with a map drawn cell by cell, with the process's peak memory. With `--peer geovista`,
//! GeoVista (on PyVista and VTK) reads the same file and draws it to the same size in the same
//! run (tests/python/bench_meshes_peer.py).

use super::{median, peak_memory_mib};
use crate::datasets::LoadOptions;
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::vec3::{dot, normalize, tangent_basis};
use crate::render::surface::{FringeMode, SurfaceOptions, SurfaceRenderer, SurfaceView};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

type V3 = [f64; 3];

/// The icosahedron subdivided `level` times, its vertices pushed out to the unit sphere: nodes
/// and counter-clockwise triangles (seen from outside).
pub(crate) fn icosphere(level: u32) -> (Vec<V3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut nodes: Vec<V3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(normalize)
    .to_vec();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3 / 2);
        let mut split = |a: u32, b: u32, nodes: &mut Vec<V3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (nodes[a as usize], nodes[b as usize]);
                nodes.push(normalize([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                (nodes.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for &[a, b, c] in &tris {
            let (ab, bc, ca) = (
                split(a, b, &mut nodes),
                split(b, c, &mut nodes),
                split(c, a, &mut nodes),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    (nodes, tris)
}

/// The Voronoi mesh of an icosphere, as MPAS stores it: a cell per node, the cells' vertices at
/// the triangles' centres, each cell's vertices counter-clockwise.
pub(crate) struct Voronoi {
    pub cells: Vec<V3>,
    pub vertices: Vec<V3>,
    /// Per cell, its vertices (5 or 6).
    pub rings: Vec<Vec<u32>>,
}

pub(crate) fn voronoi(level: u32) -> Voronoi {
    let (nodes, tris) = icosphere(level);
    let vertices: Vec<V3> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| nodes[i as usize]);
            normalize([a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2]])
        })
        .collect();
    let mut rings: Vec<Vec<u32>> = vec![Vec::with_capacity(6); nodes.len()];
    for (k, t) in tris.iter().enumerate() {
        for &n in t {
            rings[n as usize].push(k as u32);
        }
    }
    for (n, ring) in rings.iter_mut().enumerate() {
        // Counter-clockwise about the outward normal: by angle in the tangent plane.
        let (e1, e2) = tangent_basis(nodes[n]);
        let angle = |k: &u32| {
            let v = vertices[*k as usize];
            dot(v, e2).atan2(dot(v, e1))
        };
        ring.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
    }
    Voronoi {
        cells: nodes,
        vertices,
        rings,
    }
}

fn lat_lon(v: &[V3]) -> (Vec<f64>, Vec<f64>) {
    v.iter()
        .map(|p| {
            (
                p[2].clamp(-1.0, 1.0).asin(),
                p[1].atan2(p[0]).rem_euclid(std::f64::consts::TAU),
            )
        })
        .unzip()
}

/// Writes the mesh of `level` as an MPAS file at `path`, with a cell field `temperature` of
/// fine structure (so the sampled map is not flat).
pub(crate) fn write_mpas(path: &Path, level: u32) -> Result<usize> {
    use netcdf_reader::NcAttrValue;
    use netcdf_writer::NcFileBuilder;
    let mesh = voronoi(level);
    let (lat_cell, lon_cell) = lat_lon(&mesh.cells);
    let (lat_vertex, lon_vertex) = lat_lon(&mesh.vertices);
    let n = mesh.cells.len();
    let edges: Vec<i32> = mesh.rings.iter().map(|r| r.len() as i32).collect();
    let mut on_cell = vec![0i32; n * 6];
    for (c, ring) in mesh.rings.iter().enumerate() {
        for (k, &v) in ring.iter().enumerate() {
            on_cell[c * 6 + k] = v as i32 + 1;
        }
    }
    let temperature: Vec<f64> = lat_cell
        .iter()
        .zip(&lon_cell)
        .map(|(la, lo)| 280.0 + 25.0 * la.cos() + 4.0 * (9.0 * lo).sin() * (7.0 * la).cos())
        .collect();
    let bad = |e: netcdf_writer::Error| Error::invalid("bench meshes", e.to_string());
    let mut b = NcFileBuilder::new();
    let cells = b.add_dimension("nCells", n as u64).map_err(bad)?;
    let verts = b
        .add_dimension("nVertices", mesh.vertices.len() as u64)
        .map_err(bad)?;
    let max_edges = b.add_dimension("maxEdges", 6).map_err(bad)?;
    for (name, dim, values) in [
        ("latCell", cells, &lat_cell),
        ("lonCell", cells, &lon_cell),
        ("latVertex", verts, &lat_vertex),
        ("lonVertex", verts, &lon_vertex),
    ] {
        let v = b.add_variable::<f64>(name, &[dim]).map_err(bad)?;
        b.add_variable_attribute(v, "units", NcAttrValue::Chars("radians".into()))
            .map_err(bad)?;
        b.write_variable(v, values).map_err(bad)?;
    }
    let v = b
        .add_variable::<i32>("nEdgesOnCell", &[cells])
        .map_err(bad)?;
    b.write_variable(v, &edges).map_err(bad)?;
    let v = b
        .add_variable::<i32>("verticesOnCell", &[cells, max_edges])
        .map_err(bad)?;
    b.write_variable(v, &on_cell).map_err(bad)?;
    let v = b
        .add_variable::<f64>("temperature", &[cells])
        .map_err(bad)?;
    b.add_variable_attribute(v, "units", NcAttrValue::Chars("K".into()))
        .map_err(bad)?;
    b.write_variable(v, &temperature).map_err(bad)?;
    b.add_attribute("on_a_sphere", NcAttrValue::Chars("YES".into()))
        .map_err(bad)?;
    crate::datasets::readers::netcdf::write_built(path, &b)?;
    Ok(n)
}

/// How a mesh reaches the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Route {
    /// `load_grid` at this step (`None`: the cells' size), then the grid's map.
    Sampled(Option<f64>),
    /// `load_mesh`, then the map drawn cell by cell.
    Cells,
    /// `load_mesh`, then a square globe drawn cell by cell.
    CellsGlobe,
}

/// One mesh's timings.
#[derive(Clone, Debug)]
pub struct MeshBenchRow {
    pub level: u32,
    pub cells: usize,
    /// How it was drawn: "grid 0.1234 deg 2942x1471" or "cells".
    pub route: String,
    pub load_ms: Vec<f64>,
    pub draw_ms: Vec<f64>,
    pub peak_mib: Option<f64>,
    /// The peer's line (its JSON), when one ran.
    pub peer: Option<serde_json::Value>,
}

/// Times each level's mesh as a user meets it — sampled onto a grid at the cells' size and at
/// the picture's pixel, and drawn cell by cell — with a `width`-pixel map, `runs` times each
/// after one warm-up; with `peer`, runs it on the same file.
pub fn bench_meshes(
    ctx: Arc<GpuContext>,
    levels: &[u32],
    width: u32,
    runs: usize,
    peer: Option<&str>,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<MeshBenchRow>> {
    let dir = tempfile::tempdir().map_err(|e| Error::invalid("bench meshes", e.to_string()))?;
    let renderer = SurfaceRenderer::new(ctx);
    let mut rows = Vec::new();
    for &level in levels {
        let path = dir.path().join(format!("mpas_level{level}.nc"));
        progress(&format!("meshes: writing level {level}"));
        let cells = write_mpas(&path, level)?;
        let routes = [
            Route::Sampled(None),
            Route::Sampled(Some(360.0 / width as f64)),
            Route::Cells,
            Route::CellsGlobe,
        ];
        for route in routes {
            let mesh = MeshRun {
                path: &path,
                level,
                cells,
            };
            rows.push(time_mesh(&renderer, &mesh, route, width, runs, progress)?);
        }
        if let Some(p) = peer {
            let line = match p {
                "geovista" => run_geovista(&path, width, runs)?,
                other => {
                    return Err(Error::invalid(
                        "peer",
                        format!("{other:?}; expected geovista"),
                    ))
                }
            };
            let n = rows.len();
            rows[n - routes.len()..]
                .iter_mut()
                .for_each(|r| r.peer = Some(line.clone()));
        }
    }
    Ok(rows)
}

/// The mesh file a row times.
struct MeshRun<'a> {
    path: &'a Path,
    level: u32,
    cells: usize,
}

/// One mesh's load and a `width`-pixel map of it by `route`, `runs` times each after one
/// warm-up.
fn time_mesh(
    renderer: &SurfaceRenderer,
    mesh: &MeshRun,
    route: Route,
    width: u32,
    runs: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<MeshBenchRow> {
    let opts = LoadOptions {
        variable: Some("temperature".into()),
        resolution: match route {
            Route::Sampled(r) => r,
            Route::Cells | Route::CellsGlobe => None,
        },
        ..LoadOptions::default()
    };
    let surface = SurfaceOptions {
        mode: FringeMode::Direct,
        view: SurfaceView::Map,
        width: Some(width),
        height: Some(width / 2),
        ..SurfaceOptions::default()
    };
    // Loads, then draws: the times of each, and how it went.
    let once = || -> Result<(f64, f64, String)> {
        let t = Instant::now();
        let (drawn, how) = match route {
            Route::Sampled(_) => {
                let grid = crate::datasets::load_grid_with(mesh.path, &opts)?;
                let load = t.elapsed().as_secs_f64() * 1e3;
                let t = Instant::now();
                std::hint::black_box(renderer.render(&grid, &surface)?);
                let how = format!(
                    "grid {:.4} deg {}x{}",
                    grid.x().spacing(),
                    grid.nx(),
                    grid.ny()
                );
                ((load, t.elapsed().as_secs_f64() * 1e3), how)
            }
            Route::Cells | Route::CellsGlobe => {
                let field = Arc::new(crate::datasets::load_mesh(mesh.path, &opts)?);
                let load = t.elapsed().as_secs_f64() * 1e3;
                let t = Instant::now();
                let (view, how) = if route == Route::Cells {
                    (surface.clone(), "cells, 4 samples/px".to_string())
                } else {
                    let camera = crate::model::Camera::geo([0.0; 3], 30.0, -40.0, 3.2, 40.0)?;
                    let globe = SurfaceOptions {
                        view: SurfaceView::Globe(camera),
                        height: Some(width),
                        ..surface.clone()
                    };
                    (globe, format!("cells, globe {width}x{width}"))
                };
                std::hint::black_box(renderer.render_mesh(&field, &view)?);
                ((load, t.elapsed().as_secs_f64() * 1e3), how)
            }
        };
        Ok((drawn.0, drawn.1, how))
    };
    let (_, _, route_name) = once()?;
    let (mut load_ms, mut draw_ms) = (Vec::new(), Vec::new());
    for r in 0..runs.max(1) {
        progress(&format!(
            "meshes: level {}, {route_name}, run {}",
            mesh.level,
            r + 1
        ));
        let (load, draw, _) = once()?;
        load_ms.push(load);
        draw_ms.push(draw);
    }
    Ok(MeshBenchRow {
        level: mesh.level,
        cells: mesh.cells,
        route: route_name,
        load_ms,
        draw_ms,
        peak_mib: peak_memory_mib(),
        peer: None,
    })
}

/// GeoVista on the same file and image size: its JSON line.
fn run_geovista(path: &Path, width: u32, runs: usize) -> Result<serde_json::Value> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/bench_meshes_peer.py");
    let png = path.with_extension("geovista.png");
    let out = std::process::Command::new("python3")
        .arg(&script)
        .arg(path)
        .args([
            width.to_string(),
            (width / 2).to_string(),
            runs.max(1).to_string(),
        ])
        .arg(&png)
        .output()
        .map_err(|e| Error::invalid("peer", format!("python3: {e}")))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().rev().find(|l| l.starts_with('{'));
    match (out.status.success(), line) {
        (true, Some(l)) => {
            serde_json::from_str(l).map_err(|e| Error::invalid("peer", e.to_string()))
        }
        _ => Err(Error::invalid(
            "peer",
            format!(
                "geovista failed: {}",
                String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .last()
                    .unwrap_or("no output")
            ),
        )),
    }
}

/// The `hdrvis bench meshes` table.
pub fn format_meshes_table(adapter: &str, width: u32, rows: &[MeshBenchRow]) -> String {
    let mut s = format!(
        "adapter: {adapter}\nMPAS-like Voronoi meshes of the icosahedron; load = load_grid (read, mesh, sample onto a lat/lon grid: at the cells' median size, then at the picture's pixel) or load_mesh (read, mesh, spatial index); draw = map render {width}x{} to host memory (the grid's, or cell by cell), or a globe; medians; peak MiB: the process's so far\n",
        width / 2
    );
    s.push_str(&format!(
        "{:>5} {:>10} {:>27} {:>9} {:>9} {:>9} {:>10} {:>10} {:>9}\n",
        "level",
        "cells",
        "route",
        "load ms",
        "draw ms",
        "peak MiB",
        "peer load",
        "peer draw",
        "x (total)"
    ));
    for r in rows {
        let (load, draw) = (median(&r.load_ms), median(&r.draw_ms));
        let peer = r.peer.as_ref().map(|p| {
            let load = 1e3
                * (p["load_s"].as_f64().unwrap_or(f64::NAN) + p["mesh_s"].as_f64().unwrap_or(0.0));
            let draw = 1e3 * p["first_draw_s"].as_f64().unwrap_or(f64::NAN);
            (load, draw)
        });
        s.push_str(&format!(
            "{:>5} {:>10} {:>27} {:>9.0} {:>9.0} {:>9} {:>10} {:>10} {:>9}\n",
            r.level,
            r.cells,
            r.route,
            load,
            draw,
            r.peak_mib.map_or("-".into(), |m| format!("{m:.0}")),
            peer.map_or("-".into(), |p| format!("{:.0}", p.0)),
            peer.map_or("-".into(), |p| format!("{:.0}", p.1)),
            peer.map_or("-".into(), |p| format!(
                "{:.2}",
                (p.0 + p.1) / (load + draw)
            )),
        ));
    }
    if let Some(p) = rows.iter().find_map(|r| r.peer.as_ref()) {
        s.push_str(&format!(
            "peer: {} (pyvista {}, vtk {}), renderer {}; its load: netCDF4 read + GeoVista mesh; its draw: first add_mesh + render + screenshot\n",
            p["tool"].as_str().unwrap_or("?"),
            p["pyvista"].as_str().unwrap_or("?"),
            p["vtk"].as_str().unwrap_or("?"),
            p["renderer"].as_str().unwrap_or("?")
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_voronoi_mesh_has_mpas_counts() {
        // 10·4^L + 2 cells, 12 of them pentagons, the rest hexagons; 20·4^L vertices.
        let m = voronoi(2);
        assert_eq!(m.cells.len(), 162);
        assert_eq!(m.vertices.len(), 320);
        assert_eq!(m.rings.iter().filter(|r| r.len() == 5).count(), 12);
        assert!(m.rings.iter().all(|r| r.len() == 5 || r.len() == 6));
    }
}
