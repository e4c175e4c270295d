//! The `gen` and `info` subcommands: clap definitions that map onto the library's dataset jobs
//! (`hdrvis::datasets::generate`) and `info_report`. Without `-o`, generated files go to the
//! dataset cache (`$HDRVIS_CACHE` or `datasets/cache`), keyed by every parameter, so a second
//! identical call returns the cached file at once. Long runs draw a progress bar on stderr.

use hdrvis::io::progress::Progress;
use std::path::{Path, PathBuf};

use hdrvis::datasets::generate::{
    BathymetrySource, Job, MantleJob, OkadaJob, OutputFormat, TsunamiJob,
};
use hdrvis::datasets::mantle::{MantleField, MantleFields, MantleOptions};
use hdrvis::datasets::okada::{self, DepthRef, Elastic, FaultSegment};
use hdrvis::datasets::tsunami::{self, Boundary, TsunamiOptions};
use hdrvis::{Error, Result};

#[derive(clap::Subcommand, Debug)]
pub enum GenCommand {
    /// Okada (1985/1992) displacement of rectangular faults in an elastic half-space (defaults:
    /// the paper's case II). x east, y north, z up, origin above the fault's centroid; the
    /// fault dips to the right of its strike.
    Okada(OkadaArgs),
    /// Linear shallow-water tsunami from the Okada uplift of a Manila-trench-like thrust (or
    /// --segments): maximum |eta| and arrival time.
    Tsunami(TsunamiArgs),
    /// Synthetic mantle convection in a spherical shell, resampled to an N^3 box (or, with
    /// --native, on its own spherical grid as CF NetCDF).
    Mantle(MantleArgs),
}

#[derive(clap::Args, Debug)]
pub struct OutputArgs {
    /// Output file (.nc or .npy); default: the dataset cache
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Output format when no -o is given (with -o the extension decides)
    #[arg(long, value_enum)]
    pub format: Option<FormatArg>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatArg {
    Nc,
    Npy,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthRefArg {
    Top,
    Centroid,
    Bottom,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoundaryArg {
    Open,
    Reflective,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldArg {
    Temperature,
    Fluctuation,
    Viscosity,
    All,
}

#[derive(clap::Args, Debug)]
pub struct OkadaArgs {
    /// Strike, degrees clockwise from north
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub strike: f64,
    /// Dip, degrees in [-90, 90]
    #[arg(long, default_value_t = 6.0, allow_negative_numbers = true)]
    pub dip: f64,
    /// Rake, degrees (0 left-lateral, 90 reverse, -90 normal)
    #[arg(long, default_value_t = -90.0, allow_negative_numbers = true)]
    pub rake: f64,
    /// Slip of the hanging wall, metres
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    pub slip: f64,
    /// Tensile opening, metres
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub opening: f64,
    /// Length along strike, metres
    #[arg(long, default_value_t = 100e3, allow_negative_numbers = true)]
    pub length: f64,
    /// Width down dip, metres
    #[arg(long, default_value_t = 50e3, allow_negative_numbers = true)]
    pub width: f64,
    /// Depth of the point --depth-ref names, metres (positive down)
    #[arg(long, default_value_t = 50e3, allow_negative_numbers = true)]
    pub depth: f64,
    /// Which point of the fault --depth refers to
    #[arg(long, value_enum, default_value_t = DepthRefArg::Centroid)]
    pub depth_ref: DepthRefArg,
    /// Poisson ratio of the half-space (default 0.25, i.e. lambda = mu)
    #[arg(long, conflicts_with_all = ["lambda", "mu"], allow_negative_numbers = true)]
    pub poisson: Option<f64>,
    /// Lamé's first parameter (with --mu), any unit
    #[arg(long, requires = "mu", allow_negative_numbers = true)]
    pub lambda: Option<f64>,
    /// Shear modulus (with --lambda), same unit
    #[arg(long, requires = "lambda", allow_negative_numbers = true)]
    pub mu: Option<f64>,
    /// Side of the square domain, metres
    #[arg(long, default_value_t = 1.0e6)]
    pub extent: f64,
    /// Nodes per side
    #[arg(long, default_value_t = 1001)]
    pub n: usize,
    /// Depth of the observation plane, metres (0 = the surface)
    #[arg(long, default_value_t = 0.0)]
    pub observe_depth: f64,
    /// Table of fault segments (replaces the single-fault options); columns
    /// x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m [opening_m] [depth_ref]
    #[arg(long, value_name = "TABLE")]
    pub segments: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutputArgs,
}

#[derive(clap::Args, Debug)]
pub struct TsunamiArgs {
    /// Elevation grid (.npz or .nc, positive up, with lon/lat or x/y coordinates); default: the
    /// built-in synthetic South-China-Sea-like basin
    #[arg(long, value_name = "FILE")]
    pub bathymetry: Option<PathBuf>,
    /// Name of the elevation array in --bathymetry
    #[arg(long = "variable", visible_alias = "var", requires = "bathymetry")]
    pub var: Option<String>,
    /// Cells per side of the synthetic basin
    #[arg(long, default_value_t = 1000)]
    pub n: usize,
    /// Side of the synthetic basin, metres
    #[arg(long, default_value_t = tsunami::SOUTH_CHINA_SEA_EXTENT_M)]
    pub extent: f64,
    /// Simulated time, seconds
    #[arg(long, default_value_t = 7200.0)]
    pub duration: f64,
    /// Time step, seconds (default: 0.8 of the CFL limit)
    #[arg(long)]
    pub dt: Option<f64>,
    #[arg(long, value_enum, default_value_t = BoundaryArg::Open)]
    pub boundary: BoundaryArg,
    /// Add advection and Manning bottom friction
    #[arg(long)]
    pub nonlinear: bool,
    /// Poisson ratio for the Okada source
    #[arg(long, default_value_t = 0.25)]
    pub poisson: f64,
    /// Table of fault segments (positions in metres from the grid's south-west corner)
    #[arg(long, value_name = "TABLE")]
    pub segments: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutputArgs,
}

#[derive(clap::Args, Debug)]
pub struct MantleArgs {
    /// Cells per side of the Cartesian box
    #[arg(long, default_value_t = 513)]
    pub n: usize,
    /// Seed of the plume and slab positions
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[arg(long, value_enum, default_value_t = FieldArg::All)]
    pub field: FieldArg,
    /// Hot plumes rising from the core-mantle boundary
    #[arg(long, default_value_t = 12)]
    pub plumes: usize,
    /// Cold slabs sinking from the surface
    #[arg(long, default_value_t = 8)]
    pub slabs: usize,
    /// Rayleigh number (sets the boundary-layer thickness)
    #[arg(long, default_value_t = 1.0e7)]
    pub rayleigh: f64,
    /// Viscosity contrast r_mu of eta = r_mu^(0.5 - T)
    #[arg(long, default_value_t = 1.0e5)]
    pub viscosity_contrast: f64,
    /// Keep the spherical grid the field is computed on: CF NetCDF on (radius in km, latitude,
    /// longitude), which loads as a spherical volume; N then only sets the grid's resolution
    #[arg(long)]
    pub native: bool,
    #[command(flatten)]
    pub output: OutputArgs,
}

#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// A data file: .nc, .npy, .npz, .vti, .vtk, .nhdr, .nrrd, .h5 (FILE.h5:/group/name; MintPy
    /// products), a GeoTIFF (.tif) or an OpenEXR image (.exr)
    pub file: PathBuf,
    /// The variable or array to describe (default: the first data variable, or the largest
    /// array); for an .exr, one channel (default: all)
    #[arg(long = "variable", visible_alias = "var")]
    pub var: Option<String>,
    /// Fix a dimension at a position, as xarray's isel: `--index time=5` (repeatable; NetCDF,
    /// a MintPy time series)
    #[arg(long = "index", value_name = "DIM=I")]
    pub index: Vec<String>,
    /// Fix a dimension at a coordinate value, as xarray's sel: `--at depth=600`,
    /// `--at time=2011-03-11T06:00` (nearest time; between two levels, linear) (repeatable)
    #[arg(long = "at", value_name = "DIM=VALUE")]
    pub at: Vec<String>,
    /// The band of a multi-band GeoTIFF, counted from 1 as GDAL does
    #[arg(long = "band", value_name = "N")]
    pub band: Option<usize>,
    /// The file holding the unstructured mesh of a variable whose own file has only the values
    /// (ICON and MPAS grid files): the report then names the mesh
    #[arg(long = "grid", value_name = "FILE")]
    pub grid: Option<std::path::PathBuf>,
    /// One JSON object for machines instead of the report: dims, roles, shape, units, the
    /// dimensions' coordinates, decoded times, missing count, min and max (docs/formats.md)
    #[arg(long)]
    pub json: bool,
}

/// Runs a generator and returns the file it wrote (or found in the cache).
pub fn run_gen(cmd: &GenCommand) -> Result<PathBuf> {
    let (job, output) = job_of(cmd)?;
    let mut bar = Progress::default();
    let label = format!("gen {} (%)", job.kind());
    let mut progress = |f: f64| {
        bar.fraction(f, &label);
        Ok(())
    };
    let path = match &output.output {
        Some(path) => {
            let format = OutputFormat::from_path(path)?;
            if let Some(asked) = output.format {
                if format_of(asked) != format {
                    return Err(Error::invalid(
                        "format",
                        format!(
                            "--format {} disagrees with the extension of {}",
                            format_of(asked).extension(),
                            path.display()
                        ),
                    ));
                }
            }
            job.run(path, &mut progress)?;
            path.clone()
        }
        None => {
            let format = output.format.map_or(OutputFormat::NetCdf, format_of);
            let path = job.run_cached(format, &mut progress)?;
            if hdrvis::datasets::cache::is_private(&path) {
                // The user asked for the file: it outlives the run, outside the cache.
                hdrvis::datasets::cache::keep_private_dir();
                hdrvis::io::notice(&format!(
                    "{} stays where it is when hdrvis ends (remove it when done, or give -o FILE)",
                    path.display()
                ));
            }
            path
        }
    };
    bar.clear();
    Ok(path)
}

/// The text `hdrvis info` prints.
pub fn run_info(args: &InfoArgs) -> Result<String> {
    let mut sel = hdrvis::datasets::select::Selection::default();
    for text in &args.index {
        let (dim, i) = split_pair("--index", text)?;
        let i = i
            .parse()
            .map_err(|_| Error::invalid("--index", format!("'{text}': expected DIM=INTEGER")))?;
        sel.index.push((dim, i));
    }
    for text in &args.at {
        let (dim, v) = split_pair("--at", text)?;
        let at = match v.parse::<f64>() {
            Ok(x) if x.is_finite() => hdrvis::datasets::select::At::Value(x),
            _ => hdrvis::datasets::select::At::Date(v),
        };
        sel.at.push((dim, at));
    }
    if args.json {
        if args.band.is_some() {
            return Err(Error::invalid(
                "--json",
                "describes variables; --band is for the report",
            ));
        }
        return hdrvis::datasets::describe::describe_json(&args.file, args.var.as_deref(), &sel);
    }
    let report = hdrvis::datasets::info::InfoRequest {
        sel: &sel,
        band: args.band,
        grid: args.grid.as_deref(),
    };
    hdrvis::datasets::info::info_report_for(&args.file, args.var.as_deref(), &report)
}

/// `DIM=VALUE` as its two sides.
fn split_pair(flag: &str, text: &str) -> Result<(String, String)> {
    match text.split_once('=') {
        Some((d, v)) if !d.trim().is_empty() && !v.trim().is_empty() => {
            Ok((d.trim().to_string(), v.trim().to_string()))
        }
        _ => Err(Error::invalid(
            flag,
            format!("'{text}': expected DIM=VALUE"),
        )),
    }
}

fn format_of(arg: FormatArg) -> OutputFormat {
    match arg {
        FormatArg::Nc => OutputFormat::NetCdf,
        FormatArg::Npy => OutputFormat::Npy,
    }
}

fn read_segments(path: &Path) -> Result<Vec<FaultSegment>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    okada::parse_segment_table(&text, path)
}

/// The library job a command describes, and its output options.
pub fn job_of(cmd: &GenCommand) -> Result<(Job, &OutputArgs)> {
    Ok(match cmd {
        GenCommand::Okada(a) => {
            let segments = match &a.segments {
                Some(table) => read_segments(table)?,
                None => vec![FaultSegment {
                    strike_deg: a.strike,
                    dip_deg: a.dip,
                    rake_deg: a.rake,
                    slip_m: a.slip,
                    length_m: a.length,
                    width_m: a.width,
                    depth_m: a.depth,
                    depth_ref: match a.depth_ref {
                        DepthRefArg::Top => DepthRef::Top,
                        DepthRefArg::Centroid => DepthRef::Centroid,
                        DepthRefArg::Bottom => DepthRef::Bottom,
                    },
                    opening_m: a.opening,
                    x_m: 0.0,
                    y_m: 0.0,
                }],
            };
            let elastic = match (a.poisson, a.lambda, a.mu) {
                (Some(nu), _, _) => Elastic::from_poisson(nu)?,
                (None, Some(lambda), Some(mu)) => Elastic::from_lame(lambda, mu)?,
                _ => Elastic::default(),
            };
            let job = OkadaJob {
                segments,
                elastic,
                extent_m: a.extent,
                n: a.n,
                observation_depth_m: a.observe_depth,
            };
            (Job::Okada(job), &a.output)
        }
        GenCommand::Tsunami(a) => {
            let bathymetry = match &a.bathymetry {
                Some(path) => BathymetrySource::File {
                    path: path.clone(),
                    var: a.var.clone(),
                },
                None => BathymetrySource::Synthetic {
                    n: a.n,
                    extent_m: a.extent,
                },
            };
            let job = TsunamiJob {
                bathymetry,
                segments: a.segments.as_deref().map(read_segments).transpose()?,
                elastic: Elastic::from_poisson(a.poisson)?,
                options: TsunamiOptions {
                    duration_s: a.duration,
                    dt_s: a.dt,
                    boundary: match a.boundary {
                        BoundaryArg::Open => Boundary::Open,
                        BoundaryArg::Reflective => Boundary::Reflective,
                    },
                    nonlinear: a.nonlinear,
                    ..TsunamiOptions::default()
                },
            };
            (Job::Tsunami(job), &a.output)
        }
        GenCommand::Mantle(a) => {
            let fields = match a.field {
                FieldArg::All => MantleFields::ALL,
                FieldArg::Temperature => MantleFields::only(MantleField::Temperature),
                FieldArg::Fluctuation => MantleFields::only(MantleField::Fluctuation),
                FieldArg::Viscosity => MantleFields::only(MantleField::Viscosity),
            };
            let job = MantleJob {
                options: MantleOptions {
                    n: a.n,
                    seed: a.seed,
                    plumes: a.plumes,
                    slabs: a.slabs,
                    rayleigh: a.rayleigh,
                    viscosity_contrast: a.viscosity_contrast,
                    fields,
                    ..MantleOptions::default()
                },
                native: a.native,
            };
            (Job::Mantle(job), &a.output)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(clap::Parser, Debug)]
    struct Cli {
        #[command(subcommand)]
        gen: GenCommand,
    }

    fn parse(args: &[&str]) -> std::result::Result<Cli, clap::Error> {
        Cli::try_parse_from(std::iter::once("gen").chain(args.iter().copied()))
    }

    #[test]
    fn okada_defaults_are_the_papers_case_ii() {
        let cli = parse(&["okada"]).unwrap();
        let (Job::Okada(job), output) = job_of(&cli.gen).unwrap() else {
            panic!("not okada")
        };
        assert_eq!(job.segments, [FaultSegment::paper_case_ii()]);
        assert_eq!(
            (job.extent_m, job.n, output.output.is_none()),
            (1.0e6, 1001, true)
        );
        assert_eq!(job.elastic, Elastic::default());
    }

    #[test]
    fn negative_numbers_and_lame_constants_parse() {
        let cli = parse(&[
            "okada", "--rake", "-45", "--dip", "-30", "--lambda", "2", "--mu", "1",
        ])
        .unwrap();
        let (Job::Okada(job), _) = job_of(&cli.gen).unwrap() else {
            panic!("not okada")
        };
        assert_eq!(
            (job.segments[0].rake_deg, job.segments[0].dip_deg),
            (-45.0, -30.0)
        );
        // nu = lambda / (2 (lambda + mu)) = 1/3.
        assert!((job.elastic.poisson() - 1.0 / 3.0).abs() < 1e-15);
        assert!(parse(&["okada", "--poisson", "0.3", "--mu", "1"]).is_err());
    }

    #[test]
    fn bad_values_are_errors_not_panics() {
        let cli = parse(&[
            "okada",
            "--dip",
            "120",
            "--n",
            "3",
            "-o",
            "/nonexistent/x.nc",
        ])
        .unwrap();
        let err = run_gen(&cli.gen).unwrap_err();
        assert!(err.to_string().contains("[-90, 90]"), "{err}");
        let cli = parse(&["okada", "--n", "3", "--format", "npy", "-o", "x.nc"]).unwrap();
        let err = run_gen(&cli.gen).unwrap_err();
        assert!(err.to_string().starts_with("format:"), "{err}");
        let cli = parse(&["mantle", "--n", "9", "--field", "all", "-o", "m.npy"]).unwrap();
        assert!(run_gen(&cli.gen)
            .unwrap_err()
            .to_string()
            .starts_with("field:"));
    }

    #[test]
    fn writes_to_the_given_output() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.nc");
        let out_text = out.to_str().unwrap();
        let cli = parse(&["tsunami", "--n", "24", "--duration", "300", "-o", out_text]).unwrap();
        assert_eq!(run_gen(&cli.gen).unwrap(), out);
        let report = run_info(&InfoArgs {
            file: out,
            var: None,
            index: Vec::new(),
            at: Vec::new(),
            band: None,
            grid: None,
            json: false,
        })
        .unwrap();
        assert!(report.contains("variable: max_abs_eta"), "{report}");
    }
}
