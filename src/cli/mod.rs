//! Command-line definitions (clap). Parsing only: every command calls into the library, through
//! its handler in [`run`], [`animate`], [`bench`], [`cache`], [`datasets`], [`slurm`] or
//! [`tonemap`].

pub mod animate;
pub mod bench;
pub mod cache;
pub mod cluster;
pub mod datasets;
pub mod run;
pub mod slurm;
pub mod tonemap;

use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{CommandFactory, Parser, Subcommand};
use std::path::PathBuf;

/// Parses the command line; on a misspelt command or option that clap finds no near match for
/// (letters swapped: `rnu`), adds the closest one as its tip, then exits as clap does.
pub fn parse() -> Cli {
    let args: Vec<String> = std::env::args().collect();
    Cli::try_parse_from(&args).unwrap_or_else(|e| with_suggestion(e, &args).exit())
}

/// Adds "a similar subcommand/argument exists" to an unknown-command or unknown-option error
/// that has no suggestion yet.
fn with_suggestion(mut e: clap::Error, args: &[String]) -> clap::Error {
    let cmd = Cli::command();
    let (wanted, suggestion_kind, candidates) = match e.kind() {
        ErrorKind::InvalidSubcommand => (
            e.get(ContextKind::InvalidSubcommand),
            ContextKind::SuggestedSubcommand,
            cmd.get_subcommands()
                .map(|c| c.get_name().to_string())
                .collect::<Vec<_>>(),
        ),
        ErrorKind::UnknownArgument => {
            // The options of the subcommand named on the line, and the global ones.
            let sub = args
                .iter()
                .skip(1)
                .find_map(|a| cmd.get_subcommands().find(|c| c.get_name() == a));
            let longs = sub
                .into_iter()
                .flat_map(|c| c.get_arguments())
                .chain(cmd.get_arguments())
                .flat_map(|a| a.get_long_and_visible_aliases().unwrap_or_default())
                .map(|l| format!("--{l}"))
                .collect::<Vec<_>>();
            (
                e.get(ContextKind::InvalidArg),
                ContextKind::SuggestedArg,
                longs,
            )
        }
        _ => return e,
    };
    let Some(ContextValue::String(wanted)) = wanted.cloned() else {
        return e;
    };
    if e.get(suggestion_kind).is_none() {
        if let Some(best) =
            hdrvis::error::closest_name(&wanted, candidates.iter().map(String::as_str))
        {
            e.insert(suggestion_kind, ContextValue::String(best.to_string()));
        }
    }
    e
}

#[derive(Parser, Debug)]
#[command(name = "hdrvis", version, about = "Headless HDR visualisation of geoscience data", long_about = None)]
pub struct Cli {
    /// GPU backend: auto (Vulkan, then GL), vulkan or gl. Default from HDRVIS_BACKEND, else auto.
    #[arg(long, global = true)]
    pub backend: Option<String>,
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a Rhai script: `hdrvis run SCRIPT.rhai [--out DIR] [--set KEY=VALUE]...`
    Run(RunArgs),
    /// Print the GPU adapter, backend, driver and capabilities, and the cache folder.
    Doctor,
    /// The cache of generated datasets and compiled pipelines: `hdrvis cache du|clean`.
    #[command(subcommand)]
    Cache(cache::CacheCommand),
    /// Print the script API reference (Markdown).
    Api,
    /// Benchmarks.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Generate a dataset (into the cache unless -o is given) and print its path.
    #[command(subcommand)]
    Gen(datasets::GenCommand),
    /// Describe a data file: shape, range, dynamic range, histogram.
    Info(datasets::InfoArgs),
    /// Tone-map an HDR OpenEXR into a display PNG or EXR: `hdrvis tonemap IN.exr -o OUT.png --op reinhard`
    Tonemap(tonemap::ToneMapArgs),
    /// Frames as a movie: `hdrvis animate 'out/orbit/*.png' -o orbit.mp4` (.mp4/.webm through
    /// ffmpeg, .gif, .png animated PNG).
    Animate(animate::AnimateArgs),
    /// Interactive terminal viewer: `hdrvis tui SCRIPT.rhai` (the script's scene and params) or
    /// `hdrvis tui IMAGE.exr` (exposure, operator, false colour, channels). `?` lists the keys.
    Tui(TuiArgs),
    /// A script as a Slurm job: `hdrvis slurm SCRIPT.rhai [--array N] [--ranks R] [--submit]`
    /// writes the job script (a job array sharing out a sweep, MPI ranks rendering together);
    /// `--submit` hands it to sbatch.
    Slurm(slurm::SlurmArgs),
    /// The outputs a sweep writes that are missing, found without rendering:
    /// `hdrvis sweep-status --out DIR SCRIPT.rhai [--array N]`.
    SweepStatus(slurm::SweepStatusArgs),
    /// Run the built-in demo scene (also what `hdrvis` does with no command).
    Demo {
        /// Output folder.
        #[arg(long, visible_alias = "output", default_value = "out/demo")]
        out: PathBuf,
    },
}

#[derive(clap::Args, Debug)]
pub struct RunArgs {
    pub script: PathBuf,
    /// Output folder: every file the script writes goes here.
    #[arg(long, short, visible_alias = "output", default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub inputs: ScriptInputArgs,
    /// Skip outputs that already exist (resume an interrupted sweep).
    #[arg(long)]
    pub resume: bool,
    /// Run task I of N (0 <= I < N) of a shared sweep: `shard(list)` returns its share.
    /// Default: from the Slurm job array or srun task variables, else the whole list.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// GPU memory budget of every render in MiB (the scripts' `memory_budget` default): larger
    /// volumes stream through a brick cache of this size.
    #[arg(long = "gpu-memory", value_name = "MIB")]
    pub gpu_memory: Option<f64>,
    /// Print one line per pass: `pass NAME ran MS` or `pass NAME cached`.
    #[arg(long)]
    pub stats: bool,
    /// Wall-clock limit of the run in seconds: past it the script stops with an error
    /// (no limit by default).
    #[arg(long, value_name = "SECONDS")]
    pub timeout: Option<f64>,
    /// Memory budget of the result cache in MiB (default from HDRVIS_CACHE_MIB, else 2048):
    /// results of unchanged stages are reused within a run, least recently used evicted first.
    #[arg(long, value_name = "MIB")]
    pub cache_mib: Option<u64>,
    /// After the run, print the result images inline once (the images passed to preview(),
    /// else the last one rendered): kitty, iTerm2, sixel or half blocks.
    #[arg(long)]
    pub preview: bool,
    /// Inline image protocol for --preview: auto, kitty, sixel, iterm2, halfblocks
    /// (default from HDRVIS_TUI_PROTOCOL, else auto).
    #[arg(long)]
    pub protocol: Option<String>,
}

/// The flags of every command that runs a script: its parameters and the folders it may read.
#[derive(clap::Args, Debug)]
pub struct ScriptInputArgs {
    /// Script parameter read by `param(name, default)`; repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Extra folder the script may read; repeatable.
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_paths: Vec<PathBuf>,
}

impl ScriptInputArgs {
    /// The `--set` pairs, each split at its first `=`.
    pub fn parsed_sets(&self) -> hdrvis::Result<Vec<(String, String)>> {
        self.sets
            .iter()
            .map(|s| match s.split_once('=') {
                Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
                _ => Err(hdrvis::Error::invalid(
                    "--set",
                    format!("expected KEY=VALUE, got {s:?}"),
                )),
            })
            .collect()
    }
}

#[derive(clap::Args, Debug)]
pub struct TuiArgs {
    /// A .rhai script or an OpenEXR image.
    pub input: PathBuf,
    /// Output folder: saved views (s) and the script's own outputs.
    #[arg(long, short, visible_alias = "output", default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub inputs: ScriptInputArgs,
    /// Image protocol: auto (ask the terminal), kitty, sixel, iterm2, halfblocks
    /// (default from HDRVIS_TUI_PROTOCOL, else auto).
    #[arg(long)]
    pub protocol: Option<String>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkippingViewArg {
    Orbit,
    Axis,
}

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Volume ray casting, one sample per voxel, on the HDR blobs and the mantle (Fig. 5 TF):
    /// 256^3 (257^3) -> 512^2 and 513^3 -> 1024^2.
    Volume {
        /// Timed runs per size (after one warm-up).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Only the small size (quick check).
        #[arg(long)]
        quick: bool,
        /// Which scenes: `ours` (the HDR blobs and the mantle), `peer` (scenes that are not
        /// ours: linear emission-absorption, an opaque isosurface-like wall, sparse blobs and
        /// dense fractal noise, under piecewise-linear transfer functions as VTK's), `all`, or
        /// names separated by commas.
        #[arg(long, default_value = "ours")]
        scenes: String,
        /// Run a peer on the same data side by side: `vtk` (pip's vtk: its GPU ray caster on the
        /// same llvmpipe, and its fixed-point CPU ray caster on two threads); then compare at
        /// equal error: each peer's image and every hdrvis setting (precision, step,
        /// pre-integration) scored against the f64 integral of the peer's optical model, and the
        /// fastest setting at least as accurate as each peer.
        #[arg(long)]
        peer: Option<String>,
        /// With --peer: rounds of timing, hdrvis's runs then each peer's, back to back; a peer's
        /// ratio is the median of the rounds' ratios.
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// Also time each stage of the per-sample work (march, volume sample, scale, table
        /// index, table loads) to show where a frame's time goes.
        #[arg(long)]
        breakdown: bool,
    },
    /// What accuracy costs: every compositing precision (u8, f16, f32, f32c, f64) timed and
    /// compared with the f64 reference on the mantle and HDR-blob scenes, the naive and
    /// range-reduced interference phase on the tsunami and fault surfaces, and the mantle's
    /// shell rendered natively against its resampled 128^3, 256^3 and 513^3 boxes.
    Accuracy {
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Image side in pixels.
        #[arg(long, default_value_t = 256)]
        size: u32,
        /// Volume side in voxels.
        #[arg(long, default_value_t = 128)]
        n: usize,
        /// Folder for accuracy.csv, accuracy.json and the chart accuracy.png.
        #[arg(long, default_value = "out/bench-accuracy")]
        out: PathBuf,
        /// Nodes per side of the tsunami and fault grids.
        #[arg(long, default_value_t = 256)]
        grid: usize,
        /// Only this scene (mantle, blobs, band, tsunami, fault, shell); all by default.
        #[arg(long)]
        scene: Option<String>,
        /// Resample the shell onto 32^3 and 64^3 boxes only (quick check).
        #[arg(long)]
        quick: bool,
    },
    /// One spherical sample against one Cartesian sample: the mantle's native shell and its
    /// resampled N^3 box, the same view and step in the world, no skipping and no early exit,
    /// runs alternating; samples counted along each ray.
    Spherical {
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Side of the box (and the spherical grid fine enough for it).
        #[arg(long, default_value_t = 256)]
        n: usize,
        /// Image side in pixels.
        #[arg(long, default_value_t = 512)]
        size: u32,
    },
    /// Empty-space skipping, off against on in one run: the in-core ray caster on the mantle
    /// under its Fig. 5 transfer function (257^3 and 513^3 -> 512^2 and 1024^2) and the HDR
    /// blobs (nothing to skip); the mapped one on the mantle's native shell and a
    /// tomography-like shell showing its slabs (128 levels -> 512^2).
    Skipping {
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Only the 257^3 mantle, the 256^3 blobs and shells of 64 levels -> 256^2.
        #[arg(long)]
        quick: bool,
        /// `orbit` (rays at every angle to the grid) or `axis` (bench volume's view, along z).
        #[arg(long, value_enum, default_value_t = SkippingViewArg::Orbit)]
        view: SkippingViewArg,
    },
    /// Empty-space skipping: the mantle's temperature fluctuation N^3 -> SIZE^2 with the plain
    /// ray caster and the bricked one, each without and with skipping (Fig. 5 TF and hot plumes
    /// only).
    Bricks {
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Volume side in voxels.
        #[arg(long, default_value_t = 513)]
        n: usize,
        /// Image side in pixels.
        #[arg(long, default_value_t = 1024)]
        size: u32,
        /// Brick edge in voxels (8, 16, 32, 64, 128).
        #[arg(long, default_value_t = 32)]
        brick: usize,
    },
    /// Out-of-core rendering: an N^3 f32 volume written to the dataset cache as .npy (once),
    /// read in place, rendered with a GPU memory budget; reports time and peak memory.
    Large {
        #[arg(long, default_value_t = 1)]
        runs: usize,
        /// Volume side in voxels (1024: 4.3 GB).
        #[arg(long, default_value_t = 1024)]
        n: usize,
        /// Image side in pixels.
        #[arg(long, default_value_t = 1024)]
        size: u32,
        /// GPU memory budget in MiB.
        #[arg(long = "gpu-memory", default_value_t = 1024.0)]
        gpu_memory: f64,
        /// Brick edge in voxels.
        #[arg(long, default_value_t = 32)]
        brick: usize,
    },
    /// Dataset generators: okada 1001^2, mantle 513^3, tsunami 1000^2 for 2 simulated hours.
    Datasets {
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Small sizes (quick check).
        #[arg(long)]
        quick: bool,
    },
    /// Tone mapping: every operator on 1024^2, 2048^2 and 4096^2 synthetic HDR images (in bands
    /// of rows beyond one storage binding), median ms.
    Tonemap {
        /// Timed runs per operator and size (after one warm-up).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Only the 1024^2 size (quick check).
        #[arg(long)]
        quick: bool,
        /// Whole processes side by side with a peer: `pfstools` (Debian's pfstools: pfsin |
        /// pfstmo_… | pfsout) for every operator both have, at 1024^2 and 4096^2 (--quick:
        /// 1024^2), end to end: read, tone map, write.
        #[arg(long)]
        peer: Option<String>,
        /// With --peer: alternating rounds of one run of each tool (after one untimed run).
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// With --peer: the output format both tools write, exr or png.
        #[arg(long, default_value = "exr")]
        format: String,
        /// With --peer: where hdrvis maps (`hdrvis tonemap --mapper`): auto, cpu or gpu.
        #[arg(long, default_value = "auto")]
        mapper: String,
    },
    /// TUI responsiveness: key press to updated preview (exposure, operator, ν, camera) on a
    /// 256^3 volume and a 513^2 surface at preview size, medians.
    Tui {
        /// Timed runs per case (after one warm-up).
        #[arg(long, default_value_t = 9)]
        runs: usize,
        /// Volume side in voxels (the surface grid is 2n+1 nodes per side).
        #[arg(long, default_value_t = 256)]
        n: usize,
    },
    /// What each effect costs: a ray cast plain, with shading, with jitter; and a ten-image
    /// exposure sweep from one render against ten full renders.
    Effects {
        /// Timed runs per case (after one warm-up).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Volume side in voxels.
        #[arg(long, default_value_t = 256)]
        n: usize,
        /// Image side in pixels.
        #[arg(long, default_value_t = 512)]
        size: u32,
    },
    /// Distributed rendering (`--features mpi`): strong scaling of the mantle N^3 -> SIZE^2 over
    /// MPI ranks on this machine (`mpirun --oversubscribe -n R` of this binary for each R of
    /// --ranks), compositing time per image side and scheme, each rank's peak memory, and the
    /// cost model's prediction from the measured link. Started by mpirun or srun itself, it
    /// measures the world it is in.
    Distributed {
        /// Timed runs per case (after one warm-up).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Volume side in voxels.
        #[arg(long, default_value_t = 257)]
        n: usize,
        /// Image side in pixels.
        #[arg(long, default_value_t = 512)]
        size: u32,
        /// Rank counts, comma-separated.
        #[arg(long, default_value = "1,2,4")]
        ranks: String,
        /// Image sides of the compositing cases, comma-separated.
        #[arg(long, default_value = "256,512,1024,2048")]
        sides: String,
        /// Where a rank count's run writes its report for the run that started it.
        #[arg(long, hide = true)]
        report: Option<PathBuf>,
    },
    /// Unstructured meshes at model sizes: MPAS-like Voronoi meshes of the icosahedron (level 9:
    /// MPAS's 15 km mesh's 2 621 442 cells) written as MPAS writes them, then load_grid (read,
    /// mesh, sample onto lat/lon) and a map render timed, with peak memory; `--peer geovista`
    /// draws the same file with GeoVista in the same run
    Meshes {
        /// Timed runs per mesh (after one warm-up).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Icosahedral levels (7: 163 842 cells, 8: 655 362, 9: 2 621 442).
        #[arg(long, value_delimiter = ',', default_values_t = vec![7u32, 9])]
        levels: Vec<u32>,
        /// Width of the map in pixels (its height is half).
        #[arg(long, default_value_t = 1024)]
        width: u32,
        /// A peer drawing the same mesh file: geovista.
        #[arg(long)]
        peer: Option<String>,
        /// Instead: a (depth, cells) volume on each level's ICON triangles, loaded at
        /// --resolution and rendered width x width, against locating every sample of that frame
        /// on the mesh (what a native march through the prisms does each frame).
        #[arg(long)]
        volume: bool,
        /// With --volume: load_volume's resolution in degrees.
        #[arg(long, default_value_t = 0.5)]
        resolution: f64,
    },
    /// Interference surfaces on an N^2 grid in map view: a ν change (step 2 only) and a full
    /// two-step render, medians.
    Surface {
        /// Timed runs per case (after one warm-up).
        #[arg(long, default_value_t = 9)]
        runs: usize,
        /// Grid nodes per side.
        #[arg(long, default_value_t = 1024)]
        n: usize,
    },
}
