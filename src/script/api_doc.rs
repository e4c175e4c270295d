//! The script API reference. Each registered function has an entry here (area, signature,
//! description); a test checks that the entries and the engine's registered functions are the
//! same set, and `hdrvis api` prints the reference that `docs/api.md` holds.

#[cfg(test)]
use std::collections::BTreeSet;

pub(crate) struct ApiEntry {
    pub area: &'static str,
    pub name: &'static str,
    /// Parameter names with types, as shown to users.
    pub params: &'static [&'static str],
    pub returns: &'static str,
    pub doc: &'static str,
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
    }
}

/// Areas in the order the reference lists them.
pub(crate) const AREAS: &[&str] = &[
    "datasets",
    "transfer functions",
    "cameras",
    "rendering",
    "surfaces",
    "exposure and tone mapping",
    "output",
    "parameters and sweeps",
];

pub(crate) const API: &[ApiEntry] = &[
    e("datasets", "load_volume", &["path: string"], "Volume", "Reads .npy (nz, ny, nx), .npz, .nhdr/.nrrd, .nc (a 3-D variable on z, y, x), .vti, legacy .vtk or an HDF5 dataset, relative to the script's folder; \"box.nc:T\" picks the variable T of a file with several, \"volume.h5:/group/name\" an HDF5 dataset."),
    e("datasets", "load_volume", &["path: string", "options: map"], "Volume", "As above with #{variable: \"T\"}: the array or variable to read (an unknown one lists the file's); geometry: \"auto\" (CF latitude, longitude and depth/radius/height make a spherical volume) or \"cartesian\" (coordinates as box lengths); planet_radius: in the vertical axis's unit (default the file's, else 6371 km)."),
    e("datasets", "open_volume", &["path: string"], "BrickedVolume", "Opens a volume as 32³ bricks without loading it: .npy memory-mapped, .nc read by hyperslabs (other formats are loaded, then bricked); for volumes larger than memory."),
    e("datasets", "open_volume", &["path: string", "options: map"], "BrickedVolume", "As above with #{variable, brick: 8|16|32|64|128}; \"box.nc:T\" also picks the variable."),
    e("datasets", "generate_mantle", &["options: map"], "Volume", "Synthetic mantle shell on [-1, 1]^3: #{n, seed, field: \"temperature\"|\"fluctuation\"|\"viscosity\", plumes, slabs}; outside the shell is missing (NaN)."),
    e("datasets", "generate", &["kind: string", "options: map"], "string", "Path of a cached NetCDF dataset, generated on a miss: \"okada\" #{strike, dip, rake, slip, length, width, depth, depth_ref, extent, n} (ux, uy, uz), \"tsunami\" #{n, extent, duration, boundary} (max_abs_eta, arrival_time, depth), \"mantle\" #{n, seed, field, plumes, slabs, native} (native: true keeps the spherical grid, CF on radius in km, latitude, longitude; loads as a spherical volume)."),
    e("datasets", "volume_log10", &["volume: Volume"], "Volume", "log10 of every voxel; zeros and negatives become missing (NaN)."),
    e("datasets", "volume_abs", &["volume: Volume"], "Volume", "|v| of every voxel."),
    e("datasets", "volume_magnitude", &["components: array"], "Volume", "sqrt(sum of squares) of same-shape volumes, e.g. [vx, vy, vz]."),
    e("datasets", "volume_subset", &["volume: Volume", "lo: array", "hi: array"], "Volume", "The voxels [lo, hi) as a new volume at the same world position."),
    e("datasets", "get$geometry", &["volume: Volume"], "string", "volume.geometry: \"spherical\" for a shell or wedge on (radius, latitude, longitude), \"cartesian\" for a box (regular or rectilinear)."),
    e("datasets", "to_string", &["volume: Volume"], "string", "One line: name, geometry, shape, units, value range, missing count and extent (radii and angles of a shell); print(volume) shows it."),
    e("datasets", "to_debug", &["volume: Volume"], "string", "The same line as to_string (debug printing)."),
    e("datasets", "resample", &["volume: Volume", "options: map"], "Volume", "#{n}: the volume on a regular Cartesian box over its bounding box, n cubic voxels along the longest side, trilinear in the source's index space at voxel centres; missing (NaN) outside a shell or wedge. The paper's way of rendering spherical data; emission and extinction then count per box voxel."),
    e("datasets", "volume_stats", &["volume: Volume"], "map", "#{min, max, min_positive, finite, missing} over the finite voxels."),
    e("datasets", "get$name", &["volume: Volume"], "string", "volume.name (grids have .name too)"),
    e("datasets", "get$dims", &["volume: Volume"], "array", "volume.dims: [nx, ny, nz]"),
    e("transfer functions", "tf_emission_absorption", &["e: number", "a: number"], "TransferFunction", "Grey emission e·v and extinction a·v per voxel length."),
    e("transfer functions", "tf_lut", &["options: map"], "TransferFunction", "HDR table: #{scale: \"linear\"|\"log10\"|\"symlog\" (case ignored; aliases lin, log, logarithmic, symmetric-log), linthresh, domain: [lo, hi], lens: #{lo, hi, factor}, colormap, emission: [[t, log10 e], ...], opacity: [[t, log10 sigma], ...], transparent_below}."),
    e("transfer functions", "tf_preset", &["name: string"], "TransferFunction", "A ready-made HDR transfer function: log-inferno, log-viridis, symlog-diverging, linear-grey."),
    e("cameras", "camera_axis", &["axis: string"], "Camera", "Orthographic view along \"x\", \"y\" or \"z\" framing the volume exactly."),
    e("cameras", "camera_orbit", &["azimuth: number", "elevation: number"], "Camera", "Perspective camera orbiting the volume's centre (degrees; fov 35)."),
    e("cameras", "camera_orbit", &["azimuth: number", "elevation: number", "fov: number"], "Camera", "As above with a vertical field of view in degrees."),
    e("cameras", "camera_geo", &["lat: number", "lon: number", "distance: number"], "Camera", "Perspective camera above latitude, longitude (degrees) at distance times the shell's outer radius from the planet's centre (a box: times half its diagonal from its centre), looking at the centre with north up (fov 35)."),
    e("cameras", "camera_geo", &["lat: number", "lon: number", "distance: number", "fov: number"], "Camera", "As above with a vertical field of view in degrees."),
    e("cameras", "camera_look_at", &["eye: array", "target: array", "up: array", "fov: number"], "Camera", "Free perspective camera."),
    e("rendering", "render_volume", &["volume: Volume", "options: map"], "Image", "HDR ray cast: #{tf, camera, width, height, step (voxels), jitter, seed, early_exit, background: [r, g, b], filter: \"auto\"|\"hardware\"|\"exact\", precision: \"u8\"|\"f16\"|\"f32\"|\"f32c\"|\"f64\" (f64 on the GPU where the adapter has shader f64, else the CPU), shading: true|false|#{ambient, diffuse, specular, shininess} (Blinn–Phong headlight on the data gradient; absent = no shading code; not on the bricked path), tf_sampling: \"point\"|\"preintegrated\" (the transfer function's mean between the values at each segment's ends; not on the bricked path), empty_space_skipping (default true: jump over space the transfer function leaves empty — missing data, transparent values — with the same image), memory_budget (MiB of GPU memory; larger volumes stream through a brick cache), brick (edge in voxels: render bricked), level (0 full, 1 half, ... 4: quick look)}. Results of the plain path are cached: an identical call returns the earlier image without a ray cast."),
    e("rendering", "render_volume", &["volume: BrickedVolume", "options: map"], "Image", "As above for an opened volume: always bricked, skipping empty bricks unless empty_space_skipping: false, out of core beyond memory_budget."),
    e("rendering", "get$width", &["image: Image"], "int", "image.width"),
    e("rendering", "get$height", &["image: Image"], "int", "image.height"),
    e("surfaces", "load_grid", &["path: string"], "Grid", "A 2-D field from .npy, .npz or .nc; every same-shape array becomes a property (elevation-like names become the relief); \"f.nc:eta\" keeps only that variable, as below."),
    e("surfaces", "load_grid", &["path: string", "name: string"], "Grid", "As above, keeping only the named array as the property."),
    e("surfaces", "grid_stats", &["grid: Grid", "property: string"], "map", "#{min, max, min_positive, finite, missing} of one property."),
    e("surfaces", "grid_derive", &["grid: Grid", "property: string", "op: string", "name: string"], "Grid", "A copy with a derived property: op \"log10\" (zeros and negatives missing) or \"abs\"."),
    e("surfaces", "grid_magnitude", &["grid: Grid", "properties: array", "name: string"], "Grid", "A copy with the magnitude of the named components, e.g. [\"ux\", \"uy\", \"uz\"]."),
    e("surfaces", "grid_subset", &["grid: Grid", "lo: array", "hi: array"], "Grid", "Nodes [lo, hi) as a new grid, coordinates kept."),
    e("surfaces", "get$nx", &["grid: Grid"], "int", "grid.nx"),
    e("surfaces", "get$ny", &["grid: Grid"], "int", "grid.ny"),
    e("surfaces", "get$properties", &["grid: Grid"], "array", "grid.properties: the property names"),
    e("surfaces", "render_surface", &["grid: Grid", "options: map"], "Image or array", "Interference rendering, I = (1 + cos 2 pi nu d)/2: #{nu (number or one per property), mode: \"cyclic\"|\"modulated\"|\"direct\", colormap, property (name, or an array of up to four rendered from one data pass, returning an array), view: \"map\" (a geographic grid keeps the cos-latitude aspect), \"perspective\", \"globe\" (a lon/lat grid draped on the unit sphere, seen from 3 radii above its centre) or a Camera, globe: true (the Camera looks at the sphere in the Earth-centred frame), width, height, modulation, absolute, log_color, exaggeration, relief, phase: \"reduced\" (default: f64-exact phase) or \"naive\" (cos(2 pi nu d) in f32, for comparison), antialias (default true: colours from the fringe averaged over the pixel footprint), missing: \"transparent\" (default) or a colour name / #rrggbb}. The EXR gets the data value, `fringe` and `fringe_filtered` channels."),
    e("surfaces", "render_surface", &["grid: Grid"], "Image", "An error naming the options render_surface needs."),
    e("surfaces", "surface_colorbar", &["grid: Grid", "options: map"], "Image", "Colour bar for the same options (plus width, height), with the resolution 1/nu in its metadata."),
    e("surfaces", "surface_legend", &["grid: Grid", "options: map"], "Image", "Legend for the same options (plus width, default 384): the colour bar with its domain, \"1 fringe = 1/nu units\", nu and the mode drawn as text."),
    e("exposure and tone mapping", "load_image", &["path: string"], "Image", "Reads an RGB(A) OpenEXR (float or half, from any producer) as an HDR image."),
    e("exposure and tone mapping", "exposure", &["image: Image", "ev: number"], "Image", "The HDR image times 2^ev (no re-render)."),
    e("exposure and tone mapping", "bracket", &["image: Image", "evs: array"], "array", "One exposed HDR image per EV, all from the same render."),
    e("exposure and tone mapping", "tonemap", &["image: Image", "options: map"], "Image", "Display-referred image in [0, 1]: #{op: \"linear\"|\"drago\"|\"reinhard\"|\"ward\"|\"aces\"|\"reinhard-local\"|\"durand\", exposure, key, white, bias, saturation, gamma, offset, gamut: \"scale\" (default: keeps hue) or \"clip\", ...} (GPU, with an f64 CPU reference)."),
    e("exposure and tone mapping", "tonemap", &["image: Image", "op: string"], "Image", "As above with the operator's defaults."),
    e("exposure and tone mapping", "false_colour", &["image: Image"], "Image", "False-colour view of log10 luminance with a decade legend."),
    e("output", "preview", &["image: Image"], "()", "Shows the image inline when stdout is a terminal (kitty, iTerm2, sixel or half blocks); a no-op otherwise. Under `hdrvis tui` the last previewed image is what the TUI shows; under `hdrvis run --preview` previews are printed once after the run."),
    e("output", "save_exr", &["image: Image", "path: string"], "()", "Linear OpenEXR (float R, G, B, A plus extra channels and provenance), under the output folder."),
    e("output", "save_png", &["image: Image", "path: string"], "()", "8-bit sRGB view of the image at 0 EV, under the output folder."),
    e("output", "save_png", &["image: Image", "path: string", "exposure: number"], "()", "8-bit sRGB view at the given exposure in stops."),
    e("output", "save_png", &["image: Image", "path: string", "options: map"], "()", "As above with #{exposure, legend: true} (the colour bar the render recorded drawn beneath, with labelled decades and units) or frame: true (a map-view surface with lat/lon or x/y axes and the colour bar beside it)."),
    e("output", "save_animation", &["frames: array", "path: string"], "()", "A movie of the frames (Images, or paths of PNGs under the output folder) at 12 frames/s: .mp4 (H.264) and .webm (VP9) through the system's ffmpeg, .gif and .png (animated PNG) without it. Under the output folder; frames are converted one at a time."),
    e("output", "save_animation", &["frames: array", "path: string", "options: map"], "()", "As above with #{fps, exposure} (exposure in stops, for HDR images)."),
    e("parameters and sweeps", "already_done", &["path: string"], "bool", "True when `--resume` is on and this output already exists: skip its work."),
    e("parameters and sweeps", "progress", &["done: int", "total: int"], "()", "Progress bar with ETA on stderr (when it is a terminal)."),
    e("parameters and sweeps", "progress", &["done: int", "total: int", "label: string"], "()", "As above, with a label."),
    e("parameters and sweeps", "shard", &["items: array or range"], "array", "The items this task owns when a sweep is shared out: all of them when run alone; with `hdrvis run --shard I/N`, in a Slurm job array (SLURM_ARRAY_TASK_ID) or in srun tasks (SLURM_PROCID of SLURM_NTASKS), task I of N gets the contiguous block from floor(I·len/N) to floor((I+1)·len/N), so the tasks' shares are disjoint and cover the list. `for az in shard([0, 45, 90])`, `for i in shard(0..frames)`."),
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

/// The reference as Markdown (what `hdrvis api` prints and docs/api.md holds).
pub(crate) fn reference_markdown() -> String {
    let mut s = String::from(
        "# hdrvis script API\n\nGenerated by `hdrvis api` from the functions the engine registers; a test keeps this file current.\nPaths read resolve against the script's folder; outputs go under `--out`. Options maps reject unknown keys.\n",
    );
    for area in AREAS {
        s.push_str(&format!("\n## {area}\n\n"));
        for e in API.iter().filter(|e| e.area == *area) {
            s.push_str(&format!("- `{}` — {}\n", signature(e), e.doc));
        }
    }
    s
}
