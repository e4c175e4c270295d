//! The script API reference. Each registered function has an entry here (area, signature,
//! description); a test checks that the entries and the engine's registered functions are the
//! same set, and `hdrvis api` prints the reference that `docs/api.md` holds.

use super::api_bricks::OPEN_VOLUME;
use super::api_datasets::{
    GENERATE_MANTLE, GENERATE_MANTLE_FILE, GENERATE_OKADA, GENERATE_TSUNAMI, SERIES_RANGE,
};
use super::api_fields::RESAMPLE;
use super::api_output::{SAVE_ANIMATION, SAVE_EXR, SAVE_PNG};
use super::api_post::{FALSE_COLOUR, TONEMAP};
use super::api_render::{
    CUT, CUT_FACES, CUT_PLANE, LENS, LOAD_VOLUME, RENDER_VOLUME, SHADING, TF_LUT,
};
use super::api_sections::{SECTION, SLICE, SLICE_PLANE};
use super::api_surface::{LOAD_GRID, LOAD_MESH, RENDER_SURFACE, SURFACE_COLORBAR, SURFACE_LEGEND};
use super::lines::{CELL_EDGES, COASTLINES, CONTOURS, VECTORS};
use super::options::OptionTable;
#[cfg(test)]
use std::collections::BTreeSet;

pub(crate) struct ApiEntry {
    pub area: &'static str,
    pub name: &'static str,
    /// Parameter names with types, as shown to users.
    pub params: &'static [&'static str],
    pub returns: &'static str,
    pub doc: &'static str,
    /// The option tables of the function's `options` map (and of maps nested in it).
    pub options: &'static [&'static OptionTable],
}

const fn e(
    area: &'static str,
    name: &'static str,
    params: &'static [&'static str],
    returns: &'static str,
    doc: &'static str,
) -> ApiEntry {
    ApiEntry {
        area,
        name,
        params,
        returns,
        doc,
        options: &[],
    }
}

/// An entry whose options map is described by `options`.
const fn with(entry: ApiEntry, options: &'static [&'static OptionTable]) -> ApiEntry {
    ApiEntry { options, ..entry }
}

/// Areas in the order the reference lists them.
pub(crate) const AREAS: &[&str] = &[
    "datasets",
    "transfer functions",
    "cameras",
    "rendering",
    "surfaces",
    "sections and slices",
    "arithmetic",
    "exposure and tone mapping",
    "output",
    "parameters and sweeps",
];

pub(crate) const API: &[ApiEntry] = &[
    e("datasets", "load_volume", &["path: string"], "Volume", "Reads .npy (nz, ny, nx), .npz, .nhdr/.nrrd, .nc (a 3-D variable on z, y, x), .vti, legacy .vtk or an HDF5 dataset, relative to the script's folder; \"box.nc:T\" picks the variable T of a file with several, \"volume.h5:/group/name\" an HDF5 dataset."),
    with(e("datasets", "load_volume", &["path: string", "options: map"], "Volume", "As above with options (a NetCDF variable of more dimensions is read with index/at fixing the rest; a CF time axis is never read as space):"), &[&LOAD_VOLUME]),
    e("datasets", "open_volume", &["path: string"], "BrickedVolume", "Opens a volume as 32³ bricks without loading it: .npy read where needed, .nc read by hyperslabs (other formats are loaded, then bricked); for volumes larger than memory."),
    with(e("datasets", "open_volume", &["path: string", "options: map"], "BrickedVolume", "As above with options (\"box.nc:T\" also picks the variable):"), &[&OPEN_VOLUME]),
    e("datasets", "times", &["path: string"], "array", "The steps of a NetCDF file's CF time axis (of its first data variable that has one), or of a MintPy time series' date list, as [#{ index, date }], dates in ISO 8601 in the file's calendar; for sweeps over index: #{ time: i }."),
    e("datasets", "times", &["path: string", "variable: string"], "array", "As above for the named variable."),
    e("datasets", "series_range", &["path: string"], "array", "[lo, hi]: the range of a NetCDF variable over every step of its CF time axis (or of a MintPy time series over its dates), read a step at a time, missing values left out: one colour range (domain) for every frame of a movie."),
    with(e("datasets", "series_range", &["path: string", "options: map"], "array", "As above with options:"), &[&SERIES_RANGE]),
    with(e("datasets", "generate_mantle", &["options: map"], "Volume", "Synthetic mantle shell on [-1, 1]^3; outside the shell is missing (NaN). Options:"), &[&GENERATE_MANTLE]),
    with(e("datasets", "generate", &["kind: string", "options: map"], "string", "Path of a cached NetCDF dataset, generated on a miss: \"okada\" (ux, uy, uz), \"tsunami\" (max_abs_eta, arrival_time, depth) or \"mantle\" (the field). Options of each kind:"), &[&GENERATE_OKADA, &GENERATE_TSUNAMI, &GENERATE_MANTLE_FILE]),
    e("datasets", "volume_log10", &["volume: Volume"], "Volume", "log10 of every voxel; zeros and negatives become missing (NaN)."),
    e("datasets", "volume_abs", &["volume: Volume"], "Volume", "|v| of every voxel."),
    e("datasets", "volume_magnitude", &["components: array"], "Volume", "sqrt(sum of squares) of same-shape volumes, e.g. [vx, vy, vz]."),
    e("datasets", "volume_subset", &["volume: Volume", "lo: array", "hi: array"], "Volume", "The voxels [lo, hi) as a new volume at the same world position."),
    e("datasets", "get$geometry", &["volume: Volume"], "string", "volume.geometry: \"spherical\" for a shell or wedge on (radius, latitude, longitude), \"cartesian\" for a box (regular or rectilinear)."),
    e("datasets", "to_string", &["volume: Volume"], "string", "One line: name, geometry, shape, units, value range, missing count and extent (radii and angles of a shell); print(volume) shows it."),
    e("datasets", "to_debug", &["volume: Volume"], "string", "The same line as to_string (debug printing)."),
    with(e("datasets", "resample", &["volume: Volume", "options: map"], "Volume", "The volume on a regular Cartesian box over its bounding box, n cubic voxels along the longest side, trilinear in the source's index space at voxel centres; missing (NaN) outside a shell or wedge. The paper's way of rendering spherical data; emission and extinction then count per box voxel. Options:"), &[&RESAMPLE]),
    e("datasets", "volume_stats", &["volume: Volume"], "map", "#{min, max, min_positive, finite, missing} over the finite voxels."),
    e("datasets", "get$name", &["volume: Volume"], "string", "volume.name (grids have .name too)"),
    e("datasets", "get$dims", &["volume: Volume"], "array", "volume.dims: [nx, ny, nz]"),
    e("transfer functions", "tf_emission_absorption", &["e: number", "a: number"], "TransferFunction", "Grey emission e·v and extinction a·v per voxel length."),
    with(e("transfer functions", "tf_lut", &["options: map"], "TransferFunction", "HDR table from a scale, a colour map and log10 emission and extinction curves over t in [0, 1]. Options:"), &[&TF_LUT, &LENS]),
    e("transfer functions", "tf_preset", &["name: string"], "TransferFunction", "A ready-made HDR transfer function: log-inferno, log-viridis, symlog-diverging, linear-grey."),
    e("cameras", "camera_axis", &["axis: string"], "Camera", "Orthographic view along \"x\", \"y\" or \"z\" framing the volume exactly."),
    e("cameras", "camera_orbit", &["azimuth: number", "elevation: number"], "Camera", "Perspective camera orbiting the scene's centre (degrees; fov 35), far enough that what is drawn fills the frame: the box's bounding sphere, or a spherical volume's or globe's sphere where that is smaller."),
    e("cameras", "camera_orbit", &["azimuth: number", "elevation: number", "fov: number"], "Camera", "As above with a vertical field of view in degrees."),
    e("cameras", "camera_geo", &["lat: number", "lon: number", "distance: number"], "Camera", "Perspective camera above latitude, longitude (degrees) at distance times the shell's outer radius from the planet's centre (a box: times half its diagonal from its centre), looking at the centre with north up (fov 35)."),
    e("cameras", "camera_geo", &["lat: number", "lon: number", "distance: number", "fov: number"], "Camera", "As above with a vertical field of view in degrees."),
    e("cameras", "camera_look_at", &["eye: array", "target: array", "up: array", "fov: number"], "Camera", "Free perspective camera."),
    with(e("rendering", "render_volume", &["volume: Volume", "options: map"], "Image", "HDR ray cast. Results of the plain path are cached: an identical call returns the earlier image without a ray cast. Options:"), &[&RENDER_VOLUME, &SHADING, &CUT, &CUT_PLANE, &CUT_FACES]),
    with(e("rendering", "render_volume", &["volume: BrickedVolume", "options: map"], "Image", "As above for an opened volume: always bricked, skipping empty bricks unless empty_space_skipping: false, out of core beyond memory_budget; the same options."), &[&RENDER_VOLUME, &SHADING, &CUT, &CUT_PLANE, &CUT_FACES]),
    e("rendering", "get$width", &["image: Image"], "int", "image.width"),
    e("rendering", "get$height", &["image: Image"], "int", "image.height"),
    e("rendering", "meta", &["image: Image", "key: string"], "string or ()", "The image's metadata entry `key` (what the EXR header carries: the view, ν, colour domain, a map's projection as `map_projection`, ...); () when absent."),
    e("surfaces", "load_grid", &["path: string"], "Grid", "A 2-D field from .npy, .npz, .nc, .h5 (MintPy products placed by X_FIRST/Y_FIRST), GRIB (editions 1 and 2; index: #{ message: k } picks a message) or a GeoTIFF (.tif, EPSG:4326), north up where the file is georeferenced; every same-shape array becomes a property (elevation-like names become the relief); \"f.nc:eta\" keeps only that variable, as below."),
    e("surfaces", "load_grid", &["path: string", "name: string"], "Grid", "As above, keeping only the named array as the property."),
    with(e("surfaces", "load_grid", &["path: string", "options: map"], "Grid", "A 2-D field of a variable of any rank, the other dimensions fixed by index or at (a depth slice of a (depth, lat, lon) volume is a (lat, lon) grid with its geography); the grid's name says how each was chosen. Options:"), &[&LOAD_GRID]),
    e("surfaces", "grid_stats", &["grid: Grid", "property: string"], "map", "#{min, max, min_positive, finite, missing} of one property."),
    e("surfaces", "grid_derive", &["grid: Grid", "property: string", "op: string", "name: string"], "Grid", "A copy with a derived property: op \"log10\" (zeros and negatives missing) or \"abs\"."),
    e("surfaces", "grid_magnitude", &["grid: Grid", "properties: array", "name: string"], "Grid", "A copy with the magnitude of the named components, e.g. [\"ux\", \"uy\", \"uz\"]."),
    e("surfaces", "grid_subset", &["grid: Grid", "lo: array", "hi: array"], "Grid", "Nodes [lo, hi) as a new grid, coordinates kept."),
    e("surfaces", "get$nx", &["grid: Grid"], "int", "grid.nx"),
    e("surfaces", "get$ny", &["grid: Grid"], "int", "grid.ny"),
    e("surfaces", "get$properties", &["grid: Grid"], "array", "grid.properties: the property names"),
    e("surfaces", "get$wavelength", &["grid: Grid"], "float or ()", "grid.wavelength: the radar wavelength in m of a MintPy product (WAVELENGTH), else (); nu: 2.0 / g.wavelength on a displacement in m draws one fringe per λ/2, which the legend then says (\"1 fringe = 0.02773 m = λ/2\")"),
    with(e("surfaces", "render_surface", &["grid: Grid", "options: map"], "Image or array", "Interference rendering, I = (1 + cos 2 pi nu d)/2. The EXR gets the data value, `fringe` and `fringe_filtered` channels. Options:"), &[&RENDER_SURFACE, &COASTLINES, &CONTOURS, &VECTORS]),
    e("surfaces", "render_surface", &["grid: Grid"], "Image", "An error naming the options render_surface needs."),
    e("surfaces", "load_mesh", &["path: string"], "Mesh", "A variable on an unstructured mesh as it lies there, one value per cell or node (UGRID, ICON, MPAS, SCRIP, FVCOM, ADCIRC, or columns with centres only, triangulated); \"f.nc:T850\" picks the variable. render_surface draws it cell by cell; load_grid samples it onto latitude and longitude instead."),
    with(e("surfaces", "load_mesh", &["path: string", "options: map"], "Mesh", "As above with the other dimensions fixed by index or at, and the mesh from a grid file. Options:"), &[&LOAD_MESH]),
    e("surfaces", "get$cells", &["mesh: Mesh"], "int", "mesh.cells: how many cells"),
    e("surfaces", "get$nodes", &["mesh: Mesh"], "int", "mesh.nodes: how many nodes"),
    e("surfaces", "get$kind", &["mesh: Mesh"], "string", "mesh.kind: the convention it was read by (UGRID, ICON, MPAS, SCRIP, FVCOM, ADCIRC, columns)"),
    e("surfaces", "get$name", &["mesh: Mesh"], "string", "mesh.name: the variable"),
    e("surfaces", "get$units", &["mesh: Mesh"], "string", "mesh.units: the variable's units"),
    e("surfaces", "describe", &["mesh: Mesh"], "string", "One line: the variable, how its other dimensions were chosen, the mesh's convention, cells, nodes and where the values sit."),
    with(e("surfaces", "render_surface", &["mesh: Mesh", "options: map"], "Image", "A mesh drawn cell by cell on the map (over the mesh's extent, 1024 px on the long side by default) or the globe: each pixel located in the mesh through its spatial index, cell data flat over each cell, node data linear over its triangles, the value exact in f64 at every pixel; antialias (default) averages 4 samples per pixel. The same options as for a grid; perspective views draw the mesh sampled onto a grid at its cells' median size (as load_grid does); cell_edges draws the cells' outlines on the map and the globe. Options:"), &[&RENDER_SURFACE, &COASTLINES, &CELL_EDGES, &CONTOURS, &VECTORS]),
    with(e("surfaces", "surface_colorbar", &["grid: Grid", "options: map"], "Image", "Colour bar for render_surface's options, with the resolution 1/nu in its metadata. Options:"), &[&SURFACE_COLORBAR]),
    with(e("surfaces", "surface_legend", &["grid: Grid", "options: map"], "Image", "Legend for render_surface's options: the colour bar with its domain, \"1 fringe = 1/nu units\", nu and the mode drawn as text. Options:"), &[&SURFACE_LEGEND]),
    e("arithmetic", "+", &["a: Grid | Volume | number", "b: Grid | Volume | number"], "Grid or Volume", "a + b node by node: two grids on the same axes (properties paired by name, or each grid's only one), two volumes on the same voxels, or a field and a number on either side; computed in f64 (volumes rounded back to f32); a missing value stays missing; the units kept (fields in other units are refused: with_units first)."),
    e("arithmetic", "-", &["a: Grid | Volume | number", "b: Grid | Volume | number"], "Grid or Volume", "a - b, as +: an anomaly is jul - clim, a difference keeps K, and g - 273.15 stays K until with_units(g - 273.15, \"degC\")."),
    e("arithmetic", "*", &["a: Grid | Volume | number", "b: Grid | Volume | number"], "Grid or Volume", "a * b, as +; two fields' units are joined (\"K m\"), a number keeps them."),
    e("arithmetic", "/", &["a: Grid | Volume | number", "b: Grid | Volume | number"], "Grid or Volume", "a / b, as +; two fields' units are divided (\"K/m\", \"1\" for equal units), a field by a number keeps them; division by zero gives inf or NaN (missing)."),
    e("arithmetic", "mean", &["fields: array"], "Grid or Volume", "The mean node by node of an array of grids (on the first's axes) or of volumes (on the first's voxels), skipping missing values as xarray does (missing where all are): for t in 0..12 { gs.push(load_grid(f, #{ variable: \"sst\", index: #{ time: t } })) } then mean(gs) is the climatology."),
    e("arithmetic", "min", &["fields: array"], "Grid or Volume", "The least value node by node, as mean."),
    e("arithmetic", "max", &["fields: array"], "Grid or Volume", "The greatest value node by node, as mean."),
    e("arithmetic", "std", &["fields: array"], "Grid or Volume", "The population standard deviation node by node (ddof 0, numpy's nanstd), as mean."),
    e("arithmetic", "with_units", &["field: Grid | Volume", "units: string"], "Grid or Volume", "A copy in these units (every property of a grid): what colour bars and save_grid then say."),
    with(e("sections and slices", "section", &["volume: Volume", "options: map"], "Grid", "A great-circle section of a spherical volume: columns evenly spaced along the short arc from `from` to `to`, rows evenly spaced in depth, each node trilinear in the volume's (radius, latitude, longitude) grid. x is the distance along the arc at the surface and y the depth, both in the volume's length unit; the properties are the volume's values and each column's `latitude` and `longitude`. Columns outside a wedge are missing. render_surface draws it (fringes, frame: true). Options:"), &[&SECTION]),
    with(e("sections and slices", "slice", &["volume: Volume", "options: map"], "Grid", "The plane of a box volume (regular or rectilinear) at a world coordinate along x, y or z: a grid on the voxel centres of the two other axes, trilinear across the plane. Options:"), &[&SLICE]),
    with(e("sections and slices", "slice_plane", &["volume: Volume", "options: map"], "Grid", "An oblique plane of a box volume: n nodes evenly spaced over the plane's part of the box's bounding box, on in-plane axes u and v measured from origin in world units; nodes outside the box are missing. Options:"), &[&SLICE_PLANE]),
    e("sections and slices", "save_grid", &["grid: Grid", "path: string"], "()", "Writes any grid as CF NetCDF (.nc) under the output folder: the y and x axes as coordinate variables (degrees_north/east on a geographic grid), every property as a variable with its units, a section's per-column latitude and longitude as auxiliary coordinates on its distance axis; xarray and load_grid read it back."),
    e("exposure and tone mapping", "load_image", &["path: string"], "Image", "Reads an RGB(A) OpenEXR (float or half, from any producer) as an HDR image."),
    e("exposure and tone mapping", "exposure", &["image: Image", "ev: number"], "Image", "The HDR image times 2^ev (no re-render)."),
    e("exposure and tone mapping", "bracket", &["image: Image", "evs: array"], "array", "One exposed HDR image per EV, all from the same render."),
    with(e("exposure and tone mapping", "tonemap", &["image: Image", "options: map"], "Image", "Display-referred image in [0, 1] (the f64 operators on a CPU-only machine, else the GPU); each operator takes only its own parameters. Options:"), &[&TONEMAP]),
    e("exposure and tone mapping", "tonemap", &["image: Image", "op: string"], "Image", "As above with the operator's defaults."),
    e("exposure and tone mapping", "false_colour", &["image: Image"], "Image", "False-colour view of log10 luminance with a decade legend."),
    with(e("exposure and tone mapping", "false_colour", &["image: Image", "options: map"], "Image", "As above over a given range of luminance (the same colours for every image of a sweep). Options:"), &[&FALSE_COLOUR]),
    e("output", "preview", &["image: Image"], "()", "Shows the image inline when stdout is a terminal (kitty, iTerm2, sixel or half blocks); a no-op otherwise. Under `hdrvis tui` the last previewed image is what the TUI shows; under `hdrvis run --preview` previews are printed once after the run."),
    e("output", "save_exr", &["image: Image", "path: string"], "()", "Linear OpenEXR (float R, G, B, A plus extra channels and provenance), under the output folder."),
    with(e("output", "save_exr", &["image: Image", "path: string", "options: map"], "()", "As above with options:"), &[&SAVE_EXR]),
    e("output", "save_png", &["image: Image", "path: string"], "()", "8-bit sRGB view of the image at 0 EV, under the output folder."),
    e("output", "save_png", &["image: Image", "path: string", "exposure: number"], "()", "8-bit sRGB view at the given exposure in stops."),
    with(e("output", "save_png", &["image: Image", "path: string", "options: map"], "()", "As above with options:"), &[&SAVE_PNG]),
    e("output", "save_animation", &["frames: array", "path: string"], "()", "A movie of the frames (Images, or paths of PNGs under the output folder) at 12 frames/s: .mp4 (H.264) and .webm (VP9) through the system's ffmpeg, .gif and .png (animated PNG) without it. Under the output folder; frames are converted one at a time. A path written as a string in the call is checked before the script runs, so a missing ffmpeg is said before any frame is rendered."),
    with(e("output", "save_animation", &["frames: array", "path: string", "options: map"], "()", "As above with options:"), &[&SAVE_ANIMATION]),
    e("parameters and sweeps", "already_done", &["path: string"], "bool", "True when `--resume` is on and this output already exists and reads back whole (a damaged one is written again): skip its work."),
    e("parameters and sweeps", "progress", &["done: int", "total: int"], "()", "Progress bar with ETA on stderr (when it is a terminal)."),
    e("parameters and sweeps", "progress", &["done: int", "total: int", "label: string"], "()", "As above, with a label."),
    e("parameters and sweeps", "shard", &["items: array or range"], "array", "The items this task owns when a sweep is shared out: all of them when run alone; with `hdrvis run --shard I/N`, in a Slurm job array (SLURM_ARRAY_TASK_ID) or in srun tasks (SLURM_PROCID of SLURM_NTASKS), task I of N gets the contiguous block from floor(I·len/N) to floor((I+1)·len/N), so the tasks' shares are disjoint and cover the list. `for az in shard([0, 45, 90])`, `for i in shard(0..frames)`."),
    e("parameters and sweeps", "sleep", &["seconds: number"], "()", "Waits; with --timeout a sleep ends at the deadline with the timeout's error, without one a run sleeps at most 1 s in all."),
    e("parameters and sweeps", "param", &["name: string", "default: any"], "any", "The value of `--set name=value`, parsed as the default's type; the default when not set. `hdrvis tui` lists every param and re-runs the script when one changes."),
];

/// (name, arity) of every documented function.
#[cfg(test)]
pub(crate) fn documented() -> BTreeSet<(String, usize)> {
    API.iter()
        .map(|e| (e.name.to_string(), e.params.len()))
        .collect()
}

/// (name, arity) of every function registered in `engine` (standard packages excluded).
#[cfg(test)]
pub(crate) fn registered(engine: &rhai::Engine) -> BTreeSet<(String, usize)> {
    engine
        .gen_fn_signatures(false)
        .into_iter()
        .filter_map(|sig| {
            let (name, rest) = sig.split_once('(')?;
            let params = rest.split_once(')')?.0;
            let arity = if params.trim().is_empty() {
                0
            } else {
                params.matches("_:").count().max(params.split(',').count())
            };
            Some((name.to_string(), arity))
        })
        .collect()
}

/// User-facing signature, e.g. `render_volume(volume: Volume, options: map) -> Image`, with
/// property getters shown as properties.
pub(crate) fn signature(e: &ApiEntry) -> String {
    match e.name.strip_prefix("get$") {
        Some(prop) => format!(
            "{}.{prop} -> {}",
            e.params[0].split(':').next().unwrap_or("x"),
            e.returns
        ),
        None => format!("{}({}) -> {}", e.name, e.params.join(", "), e.returns),
    }
}

/// Signatures of the functions named `name`, for "expected one of" error messages.
pub(crate) fn signatures_named(name: &str) -> Vec<String> {
    API.iter()
        .filter(|e| e.name == name)
        .map(signature)
        .collect()
}

/// The option lists of `e` under its line, each table once: one listed for an earlier entry is
/// referred to.
fn push_options(s: &mut String, e: &ApiEntry, listed: &mut Vec<&'static str>) {
    let nested = e.options.len() > 1;
    for table in e.options {
        if listed.contains(&table.function) {
            s.push_str(&format!(
                "  - {}: the options listed above\n",
                table.function
            ));
            continue;
        }
        listed.push(table.function);
        if nested {
            s.push_str(&format!("  - {}:\n", table.function));
        }
        let indent = if nested { "    " } else { "  " };
        for line in table.reference_lines() {
            s.push_str(&format!("{indent}- {line}\n"));
        }
    }
}

/// The reference as Markdown (what `hdrvis api` prints and docs/api.md holds).
pub(crate) fn reference_markdown() -> String {
    let mut s = String::from(
        "# hdrvis script API\n\nGenerated by `hdrvis api` from the functions the engine registers; a test keeps this file current.\nPaths read resolve against the script's folder; outputs go under `--out`. Options maps reject unknown keys.\n",
    );
    let mut listed = Vec::new();
    for area in AREAS {
        s.push_str(&format!("\n## {area}\n\n"));
        for e in API.iter().filter(|e| e.area == *area) {
            s.push_str(&format!("- `{}` — {}\n", signature(e), e.doc));
            push_options(&mut s, e, &mut listed);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::script::options::Kind;
    use crate::script::{run_script_source, ScriptOptions};

    /// Runs `source` as a planning run (options checked, nothing rendered or written) in a
    /// folder holding `geo.nc`, a small grid `uz` on CF latitude and longitude (the surface
    /// tables' calls load it) and `series.nc`, a time series (series_range's).
    fn plan(source: &str) -> crate::Result<()> {
        let dir = tempfile::tempdir().unwrap();
        plan_fixtures(dir.path());
        let mut opts = ScriptOptions::new(dir.path().join("out"));
        opts.progress = false;
        opts.plan_only = true;
        run_script_source(source, "t.rhai", dir.path(), &opts).map(|_| ())
    }

    /// The files the tables' calls read, written into `dir`.
    fn plan_fixtures(dir: &std::path::Path) {
        let uz: Vec<f64> = (0..12).map(|i| i as f64 * 0.25 - 1.0).collect();
        crate::datasets::netcdf::write_grid(
            dir.join("geo.nc"),
            &[
                ("lat", &[10.0, 20.0, 30.0], "degrees_north"),
                ("lon", &[100.0, 110.0, 120.0, 130.0], "degrees_east"),
            ],
            &[("uz", &uz, "m", "uplift")],
            &[],
        )
        .unwrap();
        // A time series for series_range: the example script's fixture (xarray-written).
        let series = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("datasets/fixtures/tsunami_series.nc");
        std::fs::copy(series, dir.join("series.nc")).unwrap();
        // A coastal triangle mesh for load_mesh (make_meshes.py's FVCOM file).
        let mesh = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("datasets/fixtures/mesh_fvcom.nc");
        std::fs::copy(mesh, dir.join("mesh.nc")).unwrap();
    }

    fn tables() -> Vec<&'static OptionTable> {
        let mut all: Vec<&'static OptionTable> = Vec::new();
        for table in API.iter().flat_map(|e| e.options.iter().copied()) {
            if !all.iter().any(|t| t.function == table.function) {
                all.push(table);
            }
        }
        all
    }

    /// Every table: an unknown key is refused naming the known options, and every option the
    /// table describes is accepted with a value of its kind.
    #[test]
    fn every_option_table_refuses_unknown_keys_and_accepts_each_option() {
        let tables = tables();
        assert!(tables.len() >= 17, "{} tables", tables.len());
        for table in tables {
            let call = table.call.replace("OPTS", "o");
            let unknown = format!("let o = {}; o.no_such_option = 1; {call};", table.base);
            let e = plan(&unknown).unwrap_err().to_string();
            let expected = format!(
                "unknown option no_such_option; known options: {}",
                table.names().join(", ")
            );
            assert!(e.contains(&expected), "{}: {e}", table.function);
            for spec in table.options {
                // An operator parameter needs an operator that takes it, relief a view that
                // has it.
                let base = match operators_taking(spec.name).first() {
                    Some(op) if table.function == "tonemap" => format!("#{{ op: {op:?} }}"),
                    _ if table.function == "render_surface"
                        && ["relief", "exaggeration"].contains(&spec.name) =>
                    {
                        table.base.replace(" }", ", view: \"perspective\" }")
                    }
                    // A seed varies jittered renders.
                    _ if table.function == "render_volume" && spec.name == "seed" => {
                        table.base.replace(" }", ", jitter: true }")
                    }
                    // Faces are a cut's.
                    _ if spec.name == "cut_faces" => {
                        table.base.replace(" }", ", cut: #{ x: [0.0, 0.5] } }")
                    }
                    _ => table.base.to_string(),
                };
                // Lines over a volume need a spherical one, depth rings on a surface a section.
                let call = if table.function == "render_surface" && spec.name == "depth_rings" {
                    call.replace(
                        "load_grid(\"geo.nc\")",
                        "section(load_volume(generate(\"mantle\", #{ n: 4, native: true })), #{ from: [0.0, 0.0], to: [0.0, 90.0] })",
                    )
                } else {
                    call.clone()
                };
                let call = if table.function == "render_volume"
                    && ["coastlines", "graticule"].contains(&spec.name)
                {
                    call.replace(
                        "generate_mantle(#{ n: 4 })",
                        "load_volume(generate(\"mantle\", #{ n: 4, native: true }))",
                    )
                } else {
                    call.clone()
                };
                // Reductions over a dimension read the time series, steps with a reduction.
                let reduces = ["mean", "min", "max", "std", "steps"].contains(&spec.name);
                let (base, call) = if table.function == "load_grid" && reduces {
                    (
                        if spec.name == "steps" {
                            "#{ mean: \"time\" }".to_string()
                        } else {
                            base
                        },
                        call.replace("geo.nc", "series.nc"),
                    )
                } else {
                    (base, call)
                };
                let source = format!(
                    "let o = {base}; o[{:?}] = {}; {call};",
                    spec.name,
                    spec.kind.example(spec.default)
                );
                let result = plan(&source);
                // The fixture's grid is on 1-D axes: its reader refuses a resolution by name,
                // and the sandbox a mesh's grid file that is not there.
                if table.function == "load_grid" && spec.name == "resolution" {
                    let e = result.unwrap_err().to_string();
                    assert!(e.contains("resolution 1: only curvilinear grids"), "{e}");
                    continue;
                }
                // The fixture's volume is on no mesh: a resolution is refused there by name.
                if table.function == "load_volume" && spec.name == "resolution" {
                    let e = result.unwrap_err().to_string();
                    assert!(
                        e.contains("resolution 1: only a variable on an unstructured mesh"),
                        "{e}"
                    );
                    continue;
                }
                if matches!(table.function, "load_grid" | "load_volume" | "load_mesh")
                    && spec.name == "grid"
                {
                    let e = result.unwrap_err().to_string();
                    assert!(e.contains("grid.nc: no such file"), "{e}");
                    continue;
                }
                if let Err(e) = result {
                    panic!(
                        "{}: option {} refused: {e}\n{source}",
                        table.function, spec.name
                    );
                }
            }
        }
    }

    /// Values to try for an option when looking for one that changes the image: the example,
    /// every choice, both switches, and a few points of a range.
    fn candidates(kind: &Kind, default: &str) -> Vec<String> {
        let mut out = vec![kind.example(default)];
        match kind {
            Kind::Choice(names) => out.extend(names.iter().map(|n| format!("{n:?}"))),
            Kind::Bool => out.extend(["false".to_string(), "true".to_string()]),
            Kind::Int(lo, hi) => {
                out.extend([lo + 1, (lo + 3).min(*hi), (*hi).min(64)].map(|v| v.to_string()))
            }
            Kind::Num(lo, hi) | Kind::NumAbove(lo, hi) => {
                let hi = if hi.is_finite() { *hi } else { lo + 8.0 };
                out.extend([0.25, 0.5, 0.9].map(|f| format!("{:?}", lo + f * (hi - lo))));
            }
            Kind::Finite => out.extend(["-1.0", "0.5", "2.0", "7.0"].map(String::from)),
            Kind::Text(_) | Kind::Value(..) => {}
        }
        out
    }

    /// The pixels a real run of `source` saves to `x.exr`, or the run's error.
    fn image_of(dir: &std::path::Path, source: &str) -> Result<Vec<[f32; 4]>, String> {
        let out = dir.join("out");
        let _ = std::fs::remove_dir_all(&out);
        let mut opts = ScriptOptions::new(out.clone());
        opts.progress = false;
        run_script_source(source, "t.rhai", dir, &opts).map_err(|e| e.to_string())?;
        crate::io::exr::read_exr(&out.join("x.exr"))
            .map(|img| img.pixels)
            .map_err(|e| e.to_string())
    }

    /// The options of image-making functions that change nothing in [`audit_options`]'s scenes,
    /// each with why that is not an option ignored.
    const UNCHANGED_FOR_A_REASON: [(&str, &str); 30] = [
        ("render_volume tf", "the base call's own transfer function"),
        ("render_volume background", "the example is the default"),
        (
            "render_volume empty_space_skipping",
            "exact by design: the same image, faster",
        ),
        (
            "render_volume memory_budget",
            "the in-memory volume fits every budget tried",
        ),
        (
            "render_volume early_exit",
            "no ray of the small scene reaches the threshold",
        ),
        (
            "render_volume shading",
            "the small scene's gradients light it as unshaded",
        ),
        ("render_volume shading ambient", "as shading"),
        ("render_volume shading diffuse", "as shading"),
        ("render_volume shading specular", "as shading"),
        ("render_volume shading shininess", "as shading"),
        (
            "render_volume cut lon",
            "the example is the base call's range",
        ),
        (
            "render_volume cut plane point",
            "the example is the base call's point",
        ),
        ("render_surface colormap", "the example is the default"),
        ("render_surface property", "the fixture's only property"),
        (
            "render_surface label",
            "the colour bar's caption, drawn by save_png's frame and legend, not by the render",
        ),
        (
            "render_surface missing",
            "the fixture has no missing values",
        ),
        (
            "render_surface coastlines resolution",
            "no coast differs at 8 x 8 pixels",
        ),
        ("render_surface contours property", "the example is the rendered property"),
        ("render_surface contours grid", "the example is the rendered grid"),
        ("render_surface vectors u", "the example is the base's own"),
        ("render_surface vectors v", "the example is the base's own"),
        ("render_surface vectors grid", "the example is the rendered grid"),
        ("surface_colorbar colormap", "the example is the default"),
        ("surface_colorbar property", "the fixture's only property"),
        (
            "surface_colorbar label",
            "the bar's caption, in its metadata for frames and legends",
        ),
        ("surface_legend colormap", "the example is the default"),
        ("surface_legend property", "the fixture's only property"),
        ("tonemap saturation", "the test image is grey"),
        (
            "tonemap gamut",
            "the test image is grey, within every gamut",
        ),
        (
            "tonemap exposure",
            "the default operator, Reinhard's, divides by the log-average luminance, which exposure scales alike",
        ),
    ];

    /// No option silently ignored: for every table of a function that makes an image, each
    /// option either changes the image for some value or is refused, except the options
    /// [`UNCHANGED_FOR_A_REASON`] names, which must be exactly those that change nothing (so a
    /// newly ignored option, or a stale entry, fails).
    #[test]
    fn audit_options() {
        let dir = tempfile::tempdir().unwrap();
        plan_fixtures(dir.path());
        let makes_image = [
            "render_volume",
            "render_surface",
            "tonemap",
            "false_colour",
            "surface_colorbar",
            "surface_legend",
        ];
        let mut silent = Vec::new();
        for table in tables() {
            if !makes_image.iter().any(|f| table.call.starts_with(f)) {
                continue;
            }
            let mut call = table.call.replace("OPTS", "o");
            // The cut table's base is a shell's cut: its ranges are tried on a spherical volume.
            if table.function == "render_volume cut" {
                call = call.replace(
                    "generate_mantle(#{ n: 4 })",
                    "load_volume(generate(\"mantle\", #{ n: 4, native: true }))",
                );
            }
            let base_source = format!("let o = {}; save_exr({call}, \"x.exr\");", table.base);
            let Ok(base) = image_of(dir.path(), &base_source) else {
                eprintln!("{}: the base call fails", table.function);
                continue;
            };
            for spec in table.options {
                let mut verdicts = Vec::new();
                let (mut changed, mut same) = (false, false);
                for value in candidates(&spec.kind, spec.default) {
                    let source = format!(
                        "let o = {}; o[{:?}] = {value}; save_exr({call}, \"x.exr\");",
                        table.base, spec.name
                    );
                    match image_of(dir.path(), &source) {
                        Err(e) => verdicts.push(format!(
                            "{value}: refused ({})",
                            e.lines().next().unwrap_or("")
                        )),
                        Ok(img) if img != base => changed = true,
                        Ok(_) => {
                            same = true;
                            verdicts.push(format!("{value}: same"));
                        }
                    }
                }
                if same && !changed {
                    silent.push(format!(
                        "{} {}: {}",
                        table.function,
                        spec.name,
                        verdicts.join("; ")
                    ));
                }
            }
        }
        let mut expected: Vec<&str> = UNCHANGED_FOR_A_REASON.iter().map(|e| e.0).collect();
        let mut names: Vec<&str> = silent
            .iter()
            .map(|s| s.split(':').next().unwrap_or(""))
            .collect();
        expected.sort_unstable();
        names.sort_unstable();
        assert_eq!(
            names,
            expected,
            "options that changed nothing and were not refused:\n{}",
            silent.join("\n")
        );
    }

    /// The tone-mapping operators that take the parameter `name`.
    fn operators_taking(name: &str) -> Vec<&'static str> {
        crate::tonemap::Operator::NAMES
            .into_iter()
            .filter(|op| crate::tonemap::Operator::param_names(op).contains(&name))
            .collect()
    }

    /// Each operator parameter of `tonemap` names, in its doc, exactly the operators that take it.
    #[test]
    fn tonemap_parameters_name_their_operators() {
        for spec in TONEMAP.options {
            let ops = operators_taking(spec.name);
            if ops.is_empty() {
                continue;
            }
            let prefix = format!("{}: ", ops.join(", "));
            assert!(spec.doc.starts_with(&prefix), "{}: {}", spec.name, spec.doc);
        }
    }

    /// docs/api.md lists each table's options (with `docs_api_md_is_current`, which holds it to
    /// the generated reference, exactly those; checked line by line so that a missing one is
    /// named).
    #[test]
    fn docs_api_md_lists_every_table_option() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/api.md");
        let doc = std::fs::read_to_string(&path).unwrap();
        for table in tables() {
            for line in table.reference_lines() {
                assert!(
                    doc.contains(&line),
                    "docs/api.md lacks {}: {line}",
                    table.function
                );
            }
        }
    }

    /// Values are refused as the script wrote them, in a real run and in a planning run alike.
    #[test]
    fn out_of_range_options_quote_the_value_as_written() {
        let cases = [
            ("generate_mantle(#{ n: 100000 });", "n: 100000; expected integer 2..=2048"),
            ("generate_mantle(#{ n: -5 });", "n: -5; expected integer 2..=2048"),
            ("generate_mantle(#{ plumes: 4611686018427387904 });", "plumes: 4611686018427387904;"),
            ("render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 100000 });", "width: 100000; expected integer 1..=16384"),
            ("tonemap(exposure(render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4 }), 0.0), #{ op: \"drago\", key: 0.2 });", "drago.key"),
            ("surface_colorbar(load_grid(generate(\"okada\", #{ n: 3 })), #{ width: 100000, height: 100000 });", "width: 100000; expected integer 1..=16384"),
            // A data value where a scaled one belongs: refused, with what it is on the domain.
            ("tf_lut(#{ domain: [-40.0, 60.0], transparent_below: 15.0 });", "transparent_below: 15 is not a scaled value t in [0, 1], as the emission and opacity points are; the data value 15 is t = 0.5500 on the domain [-40, 60]"),
            ("tf_lut(#{ scale: \"log10\", transparent_below: -0.5 });", "transparent_below: -0.5 is not a scaled value t in [0, 1], as the emission and opacity points are"),
        ];
        for (source, needle) in cases {
            let e = plan(source).unwrap_err().to_string();
            assert!(e.contains(needle), "{source}: {e}");
            let dir = tempfile::tempdir().unwrap();
            let mut opts = ScriptOptions::new(dir.path().join("out"));
            opts.progress = false;
            let e = run_script_source(source, "t.rhai", dir.path(), &opts)
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "real run: {source}: {e}");
        }
    }
}
