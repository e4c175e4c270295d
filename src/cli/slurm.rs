//! `hdrvis slurm` and `hdrvis sweep-status`: scripts run as Slurm jobs. The first writes a ready
//! job script (a job array with one task per share, each running `hdrvis run --resume` on the
//! script, whose `shard(list)` gives the task its items; and/or MPI ranks started by `srun
//! --mpi=…` that render every volume together) and with `--submit` hands it to sbatch; the second
//! lists the outputs a sweep writes that are missing, from a planning run that renders nothing.

use super::ScriptInputArgs;
use hdrvis::gpu::BackendChoice;
use hdrvis::render::cache::budget_mib;
use hdrvis::script::{check_sweep_script, sweep_status, ScriptOptions, Shard, SlurmJob};
use hdrvis::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct SlurmArgs {
    /// The sweep: a script that loops over `shard(items)`.
    pub script: PathBuf,
    /// Array tasks to share the sweep over: `#SBATCH --array=0-(N-1)` (the script must loop
    /// over `shard(items)`). Without it the job runs the script once.
    #[arg(long, value_name = "N")]
    pub array: Option<u64>,
    /// MPI ranks rendering every volume together, in each task: `#SBATCH --ntasks=R` and
    /// `srun --mpi=TYPE` (needs hdrvis built with `--features mpi`).
    #[arg(long, value_name = "R", default_value_t = 1)]
    pub ranks: u32,
    /// Nodes the ranks of a task spread over: `#SBATCH --nodes=M`.
    #[arg(long, value_name = "M")]
    pub nodes: Option<u32>,
    /// srun's MPI plugin for the ranks (`srun --mpi=list` shows the site's).
    #[arg(long, value_name = "TYPE", default_value = "pmix")]
    pub mpi: String,
    /// Output folder of the sweep; the job script and the tasks' logs go to DIR/slurm/.
    #[arg(long, short, visible_alias = "output", default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub inputs: ScriptInputArgs,
    /// Wall-clock limit of each task (sbatch's formats: MINUTES, HH:MM:SS, D-HH:MM:SS).
    #[arg(long)]
    pub time: Option<String>,
    /// Partition (queue) to run in.
    #[arg(long)]
    pub partition: Option<String>,
    /// Memory of each task (sbatch's format: 4G, 500M).
    #[arg(long)]
    pub mem: Option<String>,
    /// CPU cores of each task.
    #[arg(long, value_name = "C")]
    pub cpus_per_task: Option<u32>,
    /// At most this many tasks at once: `--array=0-(N-1)%K`.
    #[arg(long, value_name = "K")]
    pub max_running: Option<u64>,
    /// Job name (default: the script's name).
    #[arg(long)]
    pub job_name: Option<String>,
    /// Where to write the job script (default DIR/slurm/NAME.sbatch).
    #[arg(long, value_name = "FILE")]
    pub job_file: Option<PathBuf>,
    /// Submit the job script with sbatch and print the job id.
    #[arg(long)]
    pub submit: bool,
    /// Further sbatch options after `--`, each written as an #SBATCH line:
    /// `hdrvis slurm sweep.rhai --array 8 -- --account=geo --qos=long`.
    #[arg(last = true, value_name = "SBATCH OPTIONS")]
    pub sbatch: Vec<String>,
}

#[derive(clap::Args, Debug)]
pub struct SweepStatusArgs {
    /// The sweep's script.
    pub script: PathBuf,
    /// Output folder of the sweep.
    #[arg(long, short, visible_alias = "output", default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub inputs: ScriptInputArgs,
    /// Say which tasks of an array of N have outputs missing (the indices to resubmit).
    #[arg(long, value_name = "N", conflicts_with = "shard")]
    pub array: Option<u64>,
    /// Only the share of task I of N.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
}

/// `hdrvis slurm`: checks the script, writes the job script and, with `--submit`, submits it.
pub fn run_slurm(args: &SlurmArgs) -> Result<()> {
    let job = job(args)?;
    job.check()?;
    let sbatch = if args.submit {
        Some(find_on_path("sbatch").ok_or_else(|| {
            Error::invalid(
                "--submit",
                "sbatch not found on PATH (submit from a Slurm login node, or drop --submit and run sbatch on the written file there)",
            )
        })?)
    } else {
        None
    };
    check_sweep_script(&args.script, &job.sets, args.array.is_some())?;
    let text = job.text()?;
    let cwd = std::env::current_dir().map_err(|e| Error::io(".", e))?;
    let file = match &args.job_file {
        Some(f) => cwd.join(f),
        None => job.log_dir.join(format!("{}.sbatch", job.name)),
    };
    std::fs::create_dir_all(&job.log_dir).map_err(|e| Error::io(&job.log_dir, e))?;
    if let Some(dir) = file.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    hdrvis::io::write_text(&file, &text)?;
    println!("wrote {}", file.display());
    if let Some(sbatch) = sbatch {
        let id = submit(&sbatch, &file)?;
        println!(
            "submitted job {id}: {}, logs in {}",
            job.shape(),
            job.log_dir.display()
        );
    }
    Ok(())
}

/// The job the arguments describe, with absolute paths (a job starts elsewhere).
fn job(args: &SlurmArgs) -> Result<SlurmJob> {
    let cwd = std::env::current_dir().map_err(|e| Error::io(".", e))?;
    let script = std::fs::canonicalize(&args.script).map_err(|e| Error::io(&args.script, e))?;
    let out = cwd.join(&args.out);
    let name = match &args.job_name {
        Some(n) => n.clone(),
        None => script
            .file_stem()
            .map_or("hdrvis".into(), |s| s.to_string_lossy().to_string()),
    };
    Ok(SlurmJob {
        name,
        hdrvis: std::env::current_exe().map_err(|e| Error::io("hdrvis", e))?,
        script,
        log_dir: out.join("slurm"),
        out,
        sets: args.inputs.parsed_sets()?,
        allow_paths: args
            .inputs
            .allow_paths
            .iter()
            .map(|d| cwd.join(d))
            .collect(),
        array: args.array,
        max_running: args.max_running,
        ranks: args.ranks,
        nodes: args.nodes,
        mpi: args.mpi.clone(),
        time: args.time.clone(),
        partition: args.partition.clone(),
        mem: args.mem.clone(),
        cpus_per_task: args.cpus_per_task,
        sbatch: args.sbatch.clone(),
    })
}

/// The first executable file called `name` in a folder of PATH.
pub(super) fn find_on_path(name: &str) -> Option<PathBuf> {
    use std::os::unix::fs::PermissionsExt;
    std::env::split_paths(&std::env::var_os("PATH")?)
        .map(|dir| dir.join(name))
        .find(|p| {
            std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        })
}

/// Runs `sbatch --parsable FILE` and returns the job id it prints.
fn submit(sbatch: &Path, file: &Path) -> Result<String> {
    let out = std::process::Command::new(sbatch)
        .arg("--parsable")
        .arg(file)
        .output()
        .map_err(|e| Error::io(sbatch, e))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    // --parsable prints "JOBID" or "JOBID;CLUSTER".
    let id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if !out.status.success() || id.is_empty() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let why = stderr
            .lines()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no job id printed");
        return Err(Error::invalid(
            "sbatch",
            format!("{} refused {}: {why}", sbatch.display(), file.display()),
        ));
    }
    Ok(id)
}

/// `hdrvis sweep-status`: prints each missing output, the counts, and with `--array` the tasks
/// to resubmit.
pub fn run_sweep_status(args: &SweepStatusArgs, backend: BackendChoice) -> Result<()> {
    let mut opts = ScriptOptions::new(&args.out);
    opts.backend = backend;
    opts.sets = args.inputs.parsed_sets()?;
    opts.allowed_paths = args.inputs.allow_paths.clone();
    opts.cache_mib = budget_mib(None)?;
    if let Some(text) = &args.shard {
        opts.shard = Shard::parse(text)?;
    }
    let status = sweep_status(&args.script, &opts, args.array)?;
    for path in &status.missing {
        println!("missing {}", path.display());
    }
    let total = status.outputs.len();
    println!(
        "{total} outputs: {} done, {} missing",
        total - status.missing.len(),
        status.missing.len()
    );
    if !status.tasks_missing.is_empty() {
        let tasks: Vec<String> = status
            .tasks_missing
            .iter()
            .map(|(t, _)| t.to_string())
            .collect();
        let counts: Vec<String> = status
            .tasks_missing
            .iter()
            .map(|(t, n)| format!("{t} ({n})"))
            .collect();
        println!(
            "tasks with outputs missing: {}; resubmit them with sbatch --array={} JOB_FILE",
            counts.join(", "),
            tasks.join(",")
        );
    }
    for (path, tasks) in &status.shared {
        let tasks: Vec<String> = tasks.iter().map(u64::to_string).collect();
        eprintln!(
            "warning: {} is written by tasks {} (work outside shard() runs in every task)",
            path.display(),
            tasks.join(", ")
        );
    }
    Ok(())
}
