//! The generators as jobs: plain parameter structs for the Okada, tsunami and mantle fields,
//! independent of any command-line parser, each with a stable cache key (FNV-1a over a canonical
//! text of every parameter, see `crate::datasets::cache`) and a `run` that writes the result. The output
//! format follows the file's extension: NetCDF (`.nc`, CF-1.8 classic, with units, long names and
//! the parameters as global attributes) or `.npy` (one array; which one is said on each job).
//! Every write goes through a temporary file renamed into place.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::mantle::{self, MantleField, MantleOptions};
use super::okada::{self, Elastic, FaultSegment};
use super::tsunami::{self, TsunamiOptions};
use crate::datasets::{cache, netcdf};
use crate::error::{Error, Result};

/// Bumped whenever a generator's output changes for the same parameters, so old cache entries
/// are not reused.
const GENERATOR_VERSION: u32 = 2;

/// File formats the generators write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    NetCdf,
    Npy,
}

impl OutputFormat {
    /// The format a file name asks for: `.nc` (or `.nc4`, `.cdf`, `.netcdf`) or `.npy`.
    pub fn from_path(path: &Path) -> Result<Self> {
        match crate::datasets::Format::from_extension(path) {
            Some(crate::datasets::Format::NetCdf) => Ok(OutputFormat::NetCdf),
            Some(crate::datasets::Format::Npy) => Ok(OutputFormat::Npy),
            _ => Err(Error::invalid(
                "output",
                format!(
                    "{}: unknown extension {:?}; expected .nc or .npy",
                    path.display(),
                    crate::io::extension(path)
                ),
            )),
        }
    }

    fn format(self) -> crate::datasets::Format {
        match self {
            OutputFormat::NetCdf => crate::datasets::Format::NetCdf,
            OutputFormat::Npy => crate::datasets::Format::Npy,
        }
    }

    pub fn extension(self) -> &'static str {
        self.format().extensions()[0]
    }
}

/// Any of the three jobs, for callers that handle them alike.
#[derive(Clone, Debug, PartialEq)]
pub enum Job {
    Okada(OkadaJob),
    Tsunami(TsunamiJob),
    Mantle(MantleJob),
}

impl Job {
    pub fn kind(&self) -> &'static str {
        match self {
            Job::Okada(_) => "okada",
            Job::Tsunami(_) => "tsunami",
            Job::Mantle(_) => "mantle",
        }
    }

    pub(crate) fn cache_key(&self) -> String {
        match self {
            Job::Okada(job) => job.cache_key(),
            Job::Tsunami(job) => job.cache_key(),
            Job::Mantle(job) => job.cache_key(),
        }
    }

    pub fn run(&self, out: &Path, progress: &mut dyn FnMut(f64) -> Result<()>) -> Result<()> {
        match self {
            Job::Okada(job) => job.run(out, progress),
            Job::Tsunami(job) => job.run(out, progress),
            Job::Mantle(job) => job.run(out, progress),
        }
    }

    /// The job's output in the dataset cache, generated on a miss.
    pub fn run_cached(
        &self,
        format: OutputFormat,
        progress: &mut dyn FnMut(f64) -> Result<()>,
    ) -> Result<PathBuf> {
        cache::cached(self.kind(), &self.cache_key(), format.extension(), |path| {
            self.run(path, progress)
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Okada
// ---------------------------------------------------------------------------------------------

/// Displacement of a half-space by rectangular faults on a square grid of `n` x `n` nodes
/// spanning `extent_m` and centred on the origin (x east, y north), at `observation_depth_m`
/// below the surface (0: the surface, Okada 1985; deeper: Okada 1992). NetCDF output holds `ux`,
/// `uy`, `uz` (metres, f64) on coordinates `y`, `x` (metres); `.npy` output is one f64 array of
/// shape (3, ny, nx) stacking ux, uy, uz in that order.
#[derive(Clone, Debug, PartialEq)]
pub struct OkadaJob {
    pub segments: Vec<FaultSegment>,
    pub elastic: Elastic,
    pub extent_m: f64,
    pub n: usize,
    pub observation_depth_m: f64,
}

/// Most cells per side of a synthetic tsunami basin.
pub(crate) const MAX_TSUNAMI_N: usize = 16384;

impl Default for OkadaJob {
    /// The paper's case II (Yuan et al. 2008, section 3.2) on a 1000 km square, 1001 nodes a side.
    fn default() -> Self {
        OkadaJob {
            segments: vec![FaultSegment::paper_case_ii()],
            elastic: Elastic::default(),
            extent_m: 1.0e6,
            n: 1001,
            observation_depth_m: 0.0,
        }
    }
}

impl OkadaJob {
    fn canonical(&self) -> String {
        format!(
            "okada v{GENERATOR_VERSION}; poisson={:?}; extent_m={:?}; n={}; observation_depth_m={:?}; {}",
            self.elastic.poisson(),
            self.extent_m,
            self.n,
            self.observation_depth_m,
            segments_canonical(&self.segments)
        )
    }

    pub(crate) fn cache_key(&self) -> String {
        cache::key_of(&self.canonical())
    }

    /// Computes the field and writes it to `out` (`.nc` or `.npy`).
    pub fn run(&self, out: &Path, progress: &mut dyn FnMut(f64) -> Result<()>) -> Result<()> {
        let format = OutputFormat::from_path(out)?;
        if !(self.observation_depth_m.is_finite() && self.observation_depth_m >= 0.0) {
            return Err(Error::invalid(
                "observation_depth_m",
                format!(
                    "must be finite and >= 0 m (positive down), got {}",
                    self.observation_depth_m
                ),
            ));
        }
        if self.segments.is_empty() {
            return Err(Error::invalid("segments", "at least one fault is required"));
        }
        progress(0.0)?;
        let at_depth = self.observation_depth_m > 0.0;
        // At depth the surface grid gives the axes only: half the time is reported for it.
        let mut surface_progress = |f: f64| progress(if at_depth { 0.5 * f } else { f });
        let mut field = okada::surface_field(
            &self.segments,
            &self.elastic,
            self.extent_m,
            self.n,
            &mut surface_progress,
        )?;
        if at_depth {
            self.replace_by_depth_field(&mut field, progress)?;
        }
        match format {
            OutputFormat::NetCdf => {
                let poisson = format!("{}", self.elastic.poisson());
                let extent = format!("{}", self.extent_m);
                let depth = format!("{}", self.observation_depth_m);
                let table = segments_table(&self.segments);
                let key = self.cache_key();
                let level = if self.observation_depth_m > 0.0 {
                    "at depth"
                } else {
                    "surface"
                };
                let long = |axis: &str| format!("{axis} {level} displacement");
                let (lx, ly, lz) = (long("eastward"), long("northward"), long("upward"));
                netcdf::write_grid::<f64>(
                    out,
                    &[("y", &field.y, "m"), ("x", &field.x, "m")],
                    &[
                        ("ux", &field.ux, "m", &lx),
                        ("uy", &field.uy, "m", &ly),
                        ("uz", &field.uz, "m", &lz),
                    ],
                    &[
                        ("title", "Okada rectangular-dislocation displacement"),
                        (
                            "source",
                            "hdrvis gen okada: Okada (1985) at the surface, Okada (1992) at depth",
                        ),
                        (
                            "conventions_note",
                            "x east, y north, z up; origin at the surface point above the first \
                             fault's centroid; faults dip to the right of their strike",
                        ),
                        ("poisson_ratio", &poisson),
                        ("extent_m", &extent),
                        ("observation_depth_m", &depth),
                        ("segments", &table),
                        ("hdrvis_cache_key", &key),
                    ],
                )?;
            }
            OutputFormat::Npy => {
                let n = self.n;
                let mut stack = Vec::with_capacity(3 * n * n);
                for component in [&field.ux, &field.uy, &field.uz] {
                    stack.extend_from_slice(component);
                }
                crate::datasets::npy::write_npy::<f64>(out, &[3, n, n], &stack)?;
            }
        }
        progress(1.0)?;
        Ok(())
    }

    /// Replaces the surface displacements of `field` by Okada (1992) at the observation depth,
    /// node by node, in bands of rows with the second half of the progress after each.
    fn replace_by_depth_field(
        &self,
        field: &mut okada::OkadaField,
        progress: &mut dyn FnMut(f64) -> Result<()>,
    ) -> Result<()> {
        let at_depth = okada::displacement_grid(
            &self.segments,
            &self.elastic,
            &field.x,
            &field.y,
            -self.observation_depth_m,
            &mut |f| progress(0.5 + 0.5 * f),
        )?;
        for (k, u) in at_depth.iter().enumerate() {
            field.ux[k] = u[0];
            field.uy[k] = u[1];
            field.uz[k] = u[2];
        }
        Ok(())
    }
}

/// Every field of every segment, in a fixed order and full precision.
fn segments_canonical(segments: &[FaultSegment]) -> String {
    let mut text = String::new();
    for s in segments {
        let _ = write!(
            text,
            "[strike={:?} dip={:?} rake={:?} slip={:?} length={:?} width={:?} depth={:?} ref={} opening={:?} x={:?} y={:?}]",
            s.strike_deg,
            s.dip_deg,
            s.rake_deg,
            s.slip_m,
            s.length_m,
            s.width_m,
            s.depth_m,
            s.depth_ref,
            s.opening_m,
            s.x_m,
            s.y_m
        );
    }
    text
}

/// The segments as a table `parse_segment_table` reads back, for the file's metadata.
fn segments_table(segments: &[FaultSegment]) -> String {
    let mut text = String::from(
        "x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m opening_m depth_ref\n",
    );
    for s in segments {
        let _ = writeln!(
            text,
            "{} {} {} {} {} {} {} {} {} {} {}",
            s.x_m,
            s.y_m,
            s.depth_m,
            s.strike_deg,
            s.dip_deg,
            s.rake_deg,
            s.length_m,
            s.width_m,
            s.slip_m,
            s.opening_m,
            s.depth_ref
        );
    }
    text
}

// ---------------------------------------------------------------------------------------------
// Tsunami
// ---------------------------------------------------------------------------------------------

/// Where the tsunami's still-water depth comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum BathymetrySource {
    /// `tsunami::synthetic_south_china_sea(n, extent_m)`.
    Synthetic { n: usize, extent_m: f64 },
    /// A 2-D elevation grid (positive up, metres) read with `read_grid`: `.npz` or `.nc` with
    /// longitude/latitude (degrees; converted with `grid_spacing_from_lonlat`) or x/y (metres)
    /// coordinates. `var` names the elevation array; without it the largest 2-D array (npz) or
    /// the first 2-D data variable (nc) is used. Rows and columns are reordered to run south to
    /// north and west to east.
    File { path: PathBuf, var: Option<String> },
}

/// A tsunami run: the sea floor moves by the vertical Okada displacement `uz` of `segments`
/// (default: `manila_trench_source`, scaled into the synthetic basin, or centred on a file
/// grid), taken as the initial sea-surface elevation, then `tsunami::simulate` propagates it.
/// Segment positions are metres from the grid's south-west corner. NetCDF output holds
/// `max_abs_eta` (m), `arrival_time` (s, missing where the wave never arrived), `depth` (m,
/// positive down, negative on land) and `initial_eta` (m) on coordinates `y`, `x` (cell centres,
/// metres from the south-west corner); `.npy` output is `max_abs_eta` alone, f64 of shape
/// (ny, nx).
#[derive(Clone, Debug, PartialEq)]
pub struct TsunamiJob {
    pub bathymetry: BathymetrySource,
    pub segments: Option<Vec<FaultSegment>>,
    pub elastic: Elastic,
    pub options: TsunamiOptions,
}

impl Default for TsunamiJob {
    fn default() -> Self {
        TsunamiJob {
            bathymetry: BathymetrySource::Synthetic {
                n: 1000,
                extent_m: tsunami::SOUTH_CHINA_SEA_EXTENT_M,
            },
            segments: None,
            elastic: Elastic::default(),
            options: TsunamiOptions::default(),
        }
    }
}

impl TsunamiJob {
    fn canonical(&self) -> String {
        let bathymetry = match &self.bathymetry {
            BathymetrySource::Synthetic { n, extent_m } => {
                format!("synthetic n={n} extent_m={extent_m:?}")
            }
            // The file's bytes, not its name, identify the grid; an unreadable file gets a key
            // from its name and fails when run.
            BathymetrySource::File { path, var } => match std::fs::read(path) {
                Ok(bytes) => format!("file fnv={:016x} var={var:?}", cache::fnv1a64(&bytes)),
                Err(_) => format!("file path={} var={var:?}", path.display()),
            },
        };
        let o = &self.options;
        format!(
            "tsunami v{GENERATOR_VERSION}; {bathymetry}; source={}; poisson={:?}; duration_s={:?}; dt_s={:?}; boundary={:?}; nonlinear={}; manning_n={:?}; arrival_threshold_m={:?}; g={:?}",
            self.segments
                .as_deref()
                .map(segments_canonical)
                .unwrap_or_else(|| "manila".into()),
            self.elastic.poisson(),
            o.duration_s,
            o.dt_s,
            o.boundary,
            o.nonlinear,
            o.manning_n,
            o.arrival_threshold_m,
            o.g
        )
    }

    pub(crate) fn cache_key(&self) -> String {
        cache::key_of(&self.canonical())
    }

    /// The still-water depth grid the job runs on.
    pub(crate) fn load_bathymetry(&self) -> Result<tsunami::Bathymetry> {
        match &self.bathymetry {
            BathymetrySource::Synthetic { n, extent_m } => {
                if !(2..=MAX_TSUNAMI_N).contains(n) {
                    return Err(Error::invalid(
                        "n",
                        format!("cells per side must lie in [2, {MAX_TSUNAMI_N}], got {n}"),
                    ));
                }
                if !(extent_m.is_finite() && *extent_m > 0.0) {
                    return Err(Error::invalid(
                        "extent_m",
                        format!("must be finite and > 0, got {extent_m}"),
                    ));
                }
                Ok(tsunami::synthetic_south_china_sea(*n, *extent_m))
            }
            BathymetrySource::File { path, var } => bathymetry_from_file(path, var.as_deref()),
        }
    }

    /// The faults that lift the sea floor, in the grid's frame.
    pub(crate) fn source_segments(&self, bathy: &tsunami::Bathymetry) -> Vec<FaultSegment> {
        if let Some(segments) = &self.segments {
            return segments.clone();
        }
        let manila = tsunami::manila_trench_source();
        let (x_m, y_m) = match self.bathymetry {
            BathymetrySource::Synthetic { extent_m, .. } => {
                let scaled = tsunami::scaled_to_extent(manila, extent_m);
                (scaled.x_m, scaled.y_m)
            }
            BathymetrySource::File { .. } => (
                0.5 * bathy.nx as f64 * bathy.dx_m,
                0.5 * bathy.ny as f64 * bathy.dy_m,
            ),
        };
        vec![FaultSegment { x_m, y_m, ..manila }]
    }

    pub fn run(&self, out: &Path, progress: &mut dyn FnMut(f64) -> Result<()>) -> Result<()> {
        let format = OutputFormat::from_path(out)?;
        let bathy = self.load_bathymetry()?;
        let segments = self.source_segments(&bathy);
        let (nx, ny) = (bathy.nx, bathy.ny);
        let x: Vec<f64> = (0..nx).map(|i| (i as f64 + 0.5) * bathy.dx_m).collect();
        let y: Vec<f64> = (0..ny).map(|j| (j as f64 + 0.5) * bathy.dy_m).collect();
        // The sea floor's uplift: the bar stays at 0 while it is computed, the deadline is heard.
        let uplift = okada::displacement_grid(&segments, &self.elastic, &x, &y, 0.0, &mut |_| {
            progress(0.0)
        })?;
        let eta0: Vec<f64> = uplift.iter().map(|u| u[2]).collect();
        let result = tsunami::simulate(&bathy, &eta0, &self.options, progress)?;
        match format {
            OutputFormat::Npy => {
                crate::datasets::npy::write_npy::<f64>(out, &[ny, nx], &result.max_abs_eta)
            }
            OutputFormat::NetCdf => {
                let o = &self.options;
                let bathymetry = match &self.bathymetry {
                    BathymetrySource::Synthetic { n, extent_m } => format!(
                        "synthetic South-China-Sea-like basin, {n} x {n} cells over {extent_m} m"
                    ),
                    BathymetrySource::File { path, var } => format!(
                        "{} (variable {})",
                        path.display(),
                        var.as_deref().unwrap_or("chosen automatically")
                    ),
                };
                let texts = [
                    format!("{}", o.duration_s),
                    format!("{}", result.dt_s),
                    format!("{}", result.steps),
                    format!("{:?}", o.boundary).to_lowercase(),
                    format!("{}", o.nonlinear),
                    format!("{}", o.arrival_threshold_m),
                    format!("{}", self.elastic.poisson()),
                    segments_table(&segments),
                    self.cache_key(),
                ];
                netcdf::write_grid::<f64>(
                    out,
                    &[("y", &y, "m"), ("x", &x, "m")],
                    &[
                        ("max_abs_eta", &result.max_abs_eta, "m", "maximum absolute sea-surface elevation over the run"),
                        ("arrival_time", &result.arrival_time_s, "s", "first time |eta| exceeded the arrival threshold"),
                        ("depth", &bathy.depth_m, "m", "still-water depth, positive down, negative on land"),
                        ("initial_eta", &eta0, "m", "initial sea-surface elevation: Okada sea-floor uplift"),
                    ],
                    &[
                        ("title", "Tsunami maximum wave height and arrival time"),
                        ("source", "hdrvis gen tsunami: linear (or nonlinear) shallow-water equations, staggered leap-frog C grid"),
                        ("bathymetry", &bathymetry),
                        ("duration_s", &texts[0]),
                        ("dt_s", &texts[1]),
                        ("steps", &texts[2]),
                        ("boundary", &texts[3]),
                        ("nonlinear", &texts[4]),
                        ("arrival_threshold_m", &texts[5]),
                        ("poisson_ratio", &texts[6]),
                        ("segments", &texts[7]),
                        ("hdrvis_cache_key", &texts[8]),
                    ],
                )
            }
        }
    }
}

/// Reads an elevation grid (positive up) and turns it into bathymetry on a south-to-north,
/// west-to-east raster.
fn bathymetry_from_file(path: &Path, var: Option<&str>) -> Result<tsunami::Bathymetry> {
    let grid = crate::datasets::read_grid(path, var)?;
    let (Some(x), Some(y)) = (grid.x, grid.y) else {
        return Err(Error::format(
            path,
            format!(
                "'{}' has no coordinates; the bathymetry needs lon/lat (degrees) or x/y (metres) axes",
                grid.name
            ),
        ));
    };
    let [ny, nx] = grid.shape;
    let degrees = |axis: &crate::datasets::GridAxis| {
        matches!(axis.name.as_str(), "lon" | "longitude" | "lat" | "latitude")
            || axis
                .units
                .as_deref()
                .is_some_and(|u| u.starts_with("degree"))
    };
    let (dx, dy) = if degrees(&x) && degrees(&y) {
        tsunami::grid_spacing_from_lonlat(&x.values, &y.values)?
    } else {
        let step = |axis: &crate::datasets::GridAxis| -> Result<f64> {
            let v = &axis.values;
            if v.len() < 2 {
                return Err(Error::format(
                    path,
                    format!("coordinate '{}' needs at least 2 values", axis.name),
                ));
            }
            Ok(((v[v.len() - 1] - v[0]) / (v.len() - 1) as f64).abs())
        };
        (step(&x)?, step(&y)?)
    };
    let flip_x = x.values.len() > 1 && x.values[1] < x.values[0];
    let flip_y = y.values.len() > 1 && y.values[1] < y.values[0];
    let mut elevation = vec![0.0; nx * ny];
    for j in 0..ny {
        let sj = if flip_y { ny - 1 - j } else { j };
        for i in 0..nx {
            let si = if flip_x { nx - 1 - i } else { i };
            elevation[j * nx + i] = grid.data[sj * nx + si];
        }
    }
    tsunami::bathymetry_from_elevation(&elevation, nx, ny, dx, dy).map_err(|e| match e {
        Error::Invalid { field, msg } => Error::format(path, format!("{field}: {msg}")),
        other => other,
    })
}

// ---------------------------------------------------------------------------------------------
// Mantle
// ---------------------------------------------------------------------------------------------

/// The synthetic mantle-convection volume of `mantle::generate`: n^3 cells over [-1, 1]^3 (the
/// surface radius is 1), NaN outside the shell. NetCDF output holds the requested fields
/// (`temperature`, `fluctuation`, `viscosity`; non-dimensional, f32) on coordinates `z`, `y`, `x`
/// (cell centres, units of the surface radius); `.npy` output is one field, f32 of shape
/// (n, n, n), so exactly one must be requested. With `native`, the fields stay on the spherical
/// grid they are computed on and go to CF NetCDF on (radius, latitude, longitude) — radius in km
/// (surface 6371 km), degrees north and east — which loads as a spherical volume.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MantleJob {
    pub options: MantleOptions,
    pub native: bool,
}

impl MantleJob {
    fn canonical(&self) -> String {
        let o = &self.options;
        let fields: Vec<&str> = MantleField::ALL
            .iter()
            .filter(|f| o.fields.contains(**f))
            .map(|f| f.name())
            .collect();
        let resolution = o
            .resolution
            .map(|r| format!("{}x{}x{}", r.radial, r.theta, r.phi))
            .unwrap_or_else(|| "auto".into());
        format!(
            "mantle v{GENERATOR_VERSION}; n={}; seed={}; plumes={}; slabs={}; rayleigh={:?}; epsilon={:?}; degree={}; order={}; viscosity_contrast={:?}; fields={}; resolution={resolution}",
            o.n,
            o.seed,
            o.plumes,
            o.slabs,
            o.rayleigh,
            o.epsilon,
            o.degree,
            o.order,
            o.viscosity_contrast,
            fields.join(",")
        ) + if self.native { "; native" } else { "" }
    }

    pub(crate) fn cache_key(&self) -> String {
        cache::key_of(&self.canonical())
    }

    pub fn run(&self, out: &Path, progress: &mut dyn FnMut(f64) -> Result<()>) -> Result<()> {
        let format = OutputFormat::from_path(out)?;
        let o = &self.options;
        let wanted: Vec<MantleField> = MantleField::ALL
            .into_iter()
            .filter(|f| o.fields.contains(*f))
            .collect();
        if format == OutputFormat::Npy && wanted.len() != 1 {
            return Err(Error::invalid(
                "field",
                format!(
                    "a .npy file holds one array but {} fields were asked for; choose one of \
                     temperature, fluctuation, viscosity, or write .nc",
                    wanted.len()
                ),
            ));
        }
        if self.native {
            return self.run_native(out, format, progress);
        }
        let volume = mantle::generate(o, progress)?;
        let n = volume.n;
        match format {
            OutputFormat::Npy => {
                let data = volume.field(wanted[0]).unwrap_or(&[]);
                crate::datasets::npy::write_npy_f32(out, &[n, n, n], data)
            }
            OutputFormat::NetCdf => {
                let centres: Vec<f64> = (0..n)
                    .map(|i| mantle::MantleVolume::cell_centre(n, i))
                    .collect();
                let vars: Vec<netcdf::GridVar<'_, f32>> = wanted
                    .iter()
                    .map(|&f| {
                        (
                            f.name(),
                            volume.field(f).unwrap_or(&[]),
                            "1",
                            mantle_long_name(f),
                        )
                    })
                    .collect();
                let s = volume.spherical;
                let texts = [
                    format!("{}", o.seed),
                    format!("{}", o.plumes),
                    format!("{}", o.slabs),
                    format!("{}", o.rayleigh),
                    format!("{}", o.epsilon),
                    format!("{}", o.degree),
                    format!("{}", o.order),
                    format!("{}", o.viscosity_contrast),
                    format!("{} x {} x {} (r, theta, phi)", s.radial, s.theta, s.phi),
                    self.cache_key(),
                ];
                netcdf::write_grid::<f32>(
                    out,
                    &[("z", &centres, "1"), ("y", &centres, "1"), ("x", &centres, "1")],
                    &vars,
                    &[
                        ("title", "Synthetic mantle convection in a spherical shell"),
                        ("source", "hdrvis gen mantle: Zhong et al. (2008) initial condition with boundary layers, plumes and slabs, resampled trilinearly from a spherical grid"),
                        ("length_units_note", "coordinates in units of the surface radius; shell 0.55 <= r <= 1; NaN outside"),
                        ("seed", &texts[0]),
                        ("plumes", &texts[1]),
                        ("slabs", &texts[2]),
                        ("rayleigh", &texts[3]),
                        ("epsilon", &texts[4]),
                        ("degree", &texts[5]),
                        ("order", &texts[6]),
                        ("viscosity_contrast", &texts[7]),
                        ("spherical_grid", &texts[8]),
                        ("hdrvis_cache_key", &texts[9]),
                    ],
                )
            }
        }
    }
}

impl MantleJob {
    /// The global attributes of a mantle file: its parameters and the cache key.
    fn parameter_texts(&self) -> Vec<(&'static str, String)> {
        let o = &self.options;
        vec![
            ("seed", format!("{}", o.seed)),
            ("plumes", format!("{}", o.plumes)),
            ("slabs", format!("{}", o.slabs)),
            ("rayleigh", format!("{}", o.rayleigh)),
            ("epsilon", format!("{}", o.epsilon)),
            ("degree", format!("{}", o.degree)),
            ("order", format!("{}", o.order)),
            ("viscosity_contrast", format!("{}", o.viscosity_contrast)),
            ("hdrvis_cache_key", self.cache_key()),
        ]
    }

    /// The fields on their spherical grid as CF NetCDF on (radius, latitude, longitude).
    fn run_native(
        &self,
        out: &Path,
        format: OutputFormat,
        progress: &mut dyn FnMut(f64) -> Result<()>,
    ) -> Result<()> {
        if format != OutputFormat::NetCdf {
            return Err(Error::invalid(
                "native",
                format!(
                    "{}: the spherical grid needs its coordinates; write .nc (CF NetCDF)",
                    out.display()
                ),
            ));
        }
        let native = mantle::generate_native(&self.options, progress)?;
        let g = &native.geometry;
        let vars: Vec<netcdf::GridVar<'_, f32>> = native
            .fields
            .iter()
            .map(|(f, data)| (f.name(), data.as_slice(), "1", mantle_long_name(*f)))
            .collect();
        let texts = self.parameter_texts();
        let mut attrs: Vec<(&str, &str)> = vec![
            ("title", "Synthetic mantle convection in a spherical shell"),
            ("source", "hdrvis gen mantle --native: Zhong et al. (2008) initial condition with boundary layers, plumes and slabs, on its spherical grid"),
            ("length_units_note", "radius in km with the surface at 6371 km and the core-mantle boundary at 0.55 of it; latitude and longitude nodes include both poles"),
        ];
        attrs.extend(texts.iter().map(|(k, v)| (*k, v.as_str())));
        netcdf::write_grid::<f32>(
            out,
            &[
                ("radius", &g.radius.centres, "km"),
                ("latitude", &g.latitude.centres, "degrees_north"),
                ("longitude", &g.longitude.centres, "degrees_east"),
            ],
            &vars,
            &attrs,
        )
    }
}

/// The `long_name` of a mantle field in files.
fn mantle_long_name(f: MantleField) -> &'static str {
    match f {
        MantleField::Temperature => {
            "non-dimensional temperature (1 at the core-mantle boundary, 0 at the surface)"
        }
        MantleField::Fluctuation => "temperature minus its mean over the sphere of the same radius",
        MantleField::Viscosity => "relative viscosity r_mu^(0.5 - T)",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_stable_and_tell_parameters_apart() {
        let base = OkadaJob::default();
        assert_eq!(base.cache_key(), OkadaJob::default().cache_key());
        assert_eq!(base.cache_key().len(), 16);
        let mut deeper = base.clone();
        deeper.segments[0].depth_m += 1.0;
        let mut finer = base.clone();
        finer.n += 1;
        let mut softer = base.clone();
        softer.elastic = Elastic::from_poisson(0.3).unwrap();
        let keys = [&base, &deeper, &finer, &softer].map(|j| j.cache_key());
        for a in 0..keys.len() {
            for b in a + 1..keys.len() {
                assert_ne!(keys[a], keys[b], "jobs {a} and {b}");
            }
        }
        let mut tsunami = TsunamiJob::default();
        let key = tsunami.cache_key();
        tsunami.options.nonlinear = true;
        assert_ne!(key, tsunami.cache_key());
        let mut mantle = MantleJob::default();
        let key = mantle.cache_key();
        mantle.options.seed = 2;
        assert_ne!(key, mantle.cache_key());
    }

    #[test]
    fn okada_netcdf_matches_displacement_at() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("okada.nc");
        let job = OkadaJob {
            n: 21,
            ..OkadaJob::default()
        };
        job.run(&out, &mut |_| Ok(())).unwrap();
        let names: Vec<String> = netcdf::list_variables(&out)
            .unwrap()
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert_eq!(names, ["y", "x", "ux", "uy", "uz"]);
        let x = crate::datasets::cf::read_coordinate(&out, "x")
            .unwrap()
            .unwrap()
            .data;
        let y = crate::datasets::cf::read_coordinate(&out, "y")
            .unwrap()
            .unwrap()
            .data;
        assert_eq!((x[0], x[20], y[10]), (-5.0e5, 5.0e5, 0.0));
        let components = ["ux", "uy", "uz"].map(|c| netcdf::read_variable(&out, c).unwrap());
        assert_eq!(components[2].units.as_deref(), Some("m"));
        assert_eq!(
            components[2].dims,
            [("y".to_string(), 21), ("x".to_string(), 21)]
        );
        for (i, j) in [(10, 10), (3, 17), (12, 9), (0, 0)] {
            let expected =
                okada::displacement_at(&job.segments, &job.elastic, x[i], y[j], 0.0).unwrap();
            for c in 0..3 {
                assert_eq!(
                    components[c].data[j * 21 + i],
                    expected[c],
                    "node ({i}, {j}) c{c}"
                );
            }
        }
        // Normal faulting subsides the surface above the fault.
        assert!(components[2].data[10 * 21 + 10] < 0.0);
    }

    #[test]
    fn okada_npy_is_a_component_stack() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("okada.npy");
        let job = OkadaJob {
            n: 5,
            ..OkadaJob::default()
        };
        job.run(&out, &mut |_| Ok(())).unwrap();
        let arr = crate::datasets::npy::read_npy::<f64>(&out).unwrap();
        assert_eq!(arr.shape, [3, 5, 5]);
        let field =
            okada::surface_field(&job.segments, &job.elastic, 1.0e6, 5, &mut |_| Ok(())).unwrap();
        assert_eq!(&arr.data[50..75], &field.uz[..]);
    }

    #[test]
    fn okada_refuses_bad_output_and_parameters() {
        let dir = tempfile::tempdir().unwrap();
        let job = OkadaJob::default();
        let err = job
            .run(&dir.path().join("a.txt"), &mut |_| Ok(()))
            .unwrap_err();
        assert!(err.to_string().starts_with("output:"), "{err}");
        let mut bad = OkadaJob { n: 5, ..job };
        bad.segments[0].dip_deg = 95.0;
        let err = bad
            .run(&dir.path().join("a.nc"), &mut |_| Ok(()))
            .unwrap_err();
        assert!(err.to_string().contains("[-90, 90]"), "{err}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn tiny_tsunami_runs_and_records_its_fields() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.nc");
        let job = TsunamiJob {
            bathymetry: BathymetrySource::Synthetic {
                n: 32,
                extent_m: tsunami::SOUTH_CHINA_SEA_EXTENT_M,
            },
            options: TsunamiOptions {
                duration_s: 600.0,
                ..TsunamiOptions::default()
            },
            ..TsunamiJob::default()
        };
        let mut last = 0.0;
        job.run(&out, &mut |f| {
            last = f;
            Ok(())
        })
        .unwrap();
        assert_eq!(last, 1.0);
        let max = netcdf::read_variable(&out, "max_abs_eta").unwrap();
        let eta0 = netcdf::read_variable(&out, "initial_eta").unwrap();
        let depth = netcdf::read_variable(&out, "depth").unwrap();
        assert_eq!(max.dims, [("y".to_string(), 32), ("x".to_string(), 32)]);
        // The maximum includes the initial state, on every wet cell.
        for ((m, e), d) in max.data.iter().zip(&eta0.data).zip(&depth.data) {
            if *d > 0.0 {
                assert!(*m >= e.abs() - 1e-12);
            }
        }
        let peak = eta0.data.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        assert!(
            peak > 0.1,
            "an 8 m thrust lifts the sea floor by metres, got {peak}"
        );
    }

    #[test]
    fn tsunami_reads_lonlat_bathymetry_from_npz() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("topo.npz");
        let (nx, ny) = (12, 10);
        // Latitude stored north first, as rasters often are: the reader flips it.
        let lon: Vec<f64> = (0..nx).map(|i| 120.0 + 0.1 * i as f64).collect();
        let lat: Vec<f64> = (0..ny).map(|j| 20.0 - 0.1 * j as f64).collect();
        let topo: Vec<f64> = (0..nx * ny)
            .map(|k| if k < nx { 50.0 } else { -3000.0 })
            .collect();
        crate::datasets::npy::write_npz(
            &path,
            &[
                ("topo", &[ny, nx], &topo),
                ("longitude", &[nx], &lon),
                ("latitude", &[ny], &lat),
            ],
            true,
        )
        .unwrap();
        let job = TsunamiJob {
            bathymetry: BathymetrySource::File {
                path: path.clone(),
                var: None,
            },
            ..TsunamiJob::default()
        };
        let bathy = job.load_bathymetry().unwrap();
        assert_eq!((bathy.nx, bathy.ny), (nx, ny));
        // The first stored row (northernmost, land) becomes the last row.
        assert!(bathy.depth_m[(ny - 1) * nx..].iter().all(|&d| d == -50.0));
        assert_eq!(bathy.depth_m[0], 3000.0);
        // 0.1 degree of latitude on a 6371 km sphere is 11.119 km.
        assert!((bathy.dy_m - 11_119.49).abs() < 0.1, "{}", bathy.dy_m);
    }

    #[test]
    fn tiny_mantle_writes_every_field_and_refuses_npy_of_all() {
        let dir = tempfile::tempdir().unwrap();
        let job = MantleJob {
            options: MantleOptions {
                n: 17,
                ..MantleOptions::default()
            },
            native: false,
        };
        let out = dir.path().join("m.nc");
        job.run(&out, &mut |_| Ok(())).unwrap();
        let t = netcdf::read_variable(&out, "temperature").unwrap();
        assert_eq!(t.dims.iter().map(|d| d.1).collect::<Vec<_>>(), [17, 17, 17]);
        assert!(netcdf::read_variable(&out, "viscosity").is_ok());
        // Corner cells lie outside the shell and are missing.
        assert!(t.data[0].is_nan());
        let err = job
            .run(&dir.path().join("m.npy"), &mut |_| Ok(()))
            .unwrap_err();
        assert!(err.to_string().starts_with("field:"), "{err}");
    }

    #[test]
    fn native_mantle_is_cf_on_its_spherical_grid_and_loads_as_a_shell() {
        use crate::model::Geometry;
        let dir = tempfile::tempdir().unwrap();
        let job = MantleJob {
            options: MantleOptions {
                n: 17,
                fields: mantle::MantleFields::only(MantleField::Temperature),
                ..MantleOptions::default()
            },
            native: true,
        };
        assert_ne!(
            job.cache_key(),
            MantleJob {
                native: false,
                ..job.clone()
            }
            .cache_key()
        );
        let out = dir.path().join("m.nc");
        job.run(&out, &mut |_| Ok(())).unwrap();
        let t = netcdf::read_variable(&out, "temperature").unwrap();
        let names: Vec<&str> = t.dims.iter().map(|d| d.0.as_str()).collect();
        assert_eq!(names, ["radius", "latitude", "longitude"]);
        let v = crate::datasets::load_volume(&out).unwrap();
        let Geometry::Spherical(g) = &v.geometry else {
            panic!("{v}");
        };
        let (nr, nlat, nlon) = (t.dims[0].1, t.dims[1].1, t.dims[2].1);
        assert_eq!(v.dims, [nlon, nlat, nr]);
        // The shell 0.55 <= r <= 1 of a 6371 km planet, poles included, longitudes all round.
        assert!((g.radius.lo - 0.55 * 6371.0).abs() < 1e-6 && (g.radius.hi - 6371.0).abs() < 1e-6);
        assert_eq!((g.latitude.lo, g.latitude.hi), (-90.0, 90.0));
        assert!(g.lon_wraps);
        // Temperature is 1 on the core-mantle boundary and 0 at the surface, at every node.
        let layer = nlat * nlon;
        assert!(v.data[..layer].iter().all(|&x| (x - 1.0).abs() < 1e-6));
        assert!(v.data[(nr - 1) * layer..].iter().all(|&x| x.abs() < 1e-6));
        let err = job
            .run(&dir.path().join("m.npy"), &mut |_| Ok(()))
            .unwrap_err();
        assert!(err.to_string().contains("write .nc"), "{err}");
    }
}
