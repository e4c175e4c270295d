//! `hdrvis slurm` and `hdrvis sweep-status`: scripts run as Slurm jobs. The first writes a ready
//! job script (a job array with one task per share, each running `hdrvis run --resume` on the
//! script, whose `shard(list)` gives the task its items; and/or MPI ranks started by `srun
//! --mpi=…` that render every volume together) and with `--submit` hands it to sbatch; the second
//! lists the outputs a sweep writes that are missing, from a planning run that renders nothing.

use super::ScriptInputArgs;
use hdrvis::gpu::BackendChoice;
use hdrvis::render::cache::budget_mib;
use hdrvis::script::{check_sweep_script, sweep_status, ScriptOptions, Shard};
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
    check_job_shape(args)?;
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
    let sets = args.inputs.parsed_sets()?;
    check_sweep_script(&args.script, &sets, args.array.is_some())?;
    let job = JobScript::new(args)?;
    let text = job.text(args, &sets)?;
    std::fs::create_dir_all(&job.log_dir).map_err(|e| Error::io(&job.log_dir, e))?;
    if let Some(dir) = job.file.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    hdrvis::io::write_text(&job.file, &text)?;
    println!("wrote {}", job.file.display());
    if let Some(sbatch) = sbatch {
        let id = submit(&sbatch, &job.file)?;
        println!(
            "submitted job {id}: {}, logs in {}",
            job_shape(args),
            job.log_dir.display()
        );
    }
    Ok(())
}

/// Refuses counts of zero, a throttle without an array, and ranks this build cannot start.
fn check_job_shape(args: &SlurmArgs) -> Result<()> {
    let counts = [
        ("--array", args.array, "expected at least 1 task, got 0"),
        (
            "--max-running",
            args.max_running,
            "expected at least 1, got 0",
        ),
        (
            "--ranks",
            Some(u64::from(args.ranks)),
            "expected at least 1, got 0",
        ),
        (
            "--nodes",
            args.nodes.map(u64::from),
            "expected at least 1, got 0",
        ),
    ];
    if let Some((field, _, why)) = counts.iter().find(|c| c.1 == Some(0)) {
        return Err(Error::invalid(*field, *why));
    }
    if args.max_running.is_some() && args.array.is_none() {
        return Err(Error::invalid(
            "--max-running",
            "limits the tasks of a job array; give --array N too",
        ));
    }
    if let Some(m) = args.nodes.filter(|&m| m > args.ranks) {
        return Err(Error::invalid(
            "--nodes",
            format!(
                "{m} nodes for {} ranks would leave nodes idle; give at most as many nodes as ranks",
                args.ranks
            ),
        ));
    }
    if args.ranks > 1 && !cfg!(feature = "mpi") {
        return Err(Error::invalid(
            "--ranks",
            format!(
                "this hdrvis was built without MPI, so each of the {} ranks would run the whole script alone; build it with `cargo build --release --features mpi` and run that binary's `hdrvis slurm`",
                args.ranks
            ),
        ));
    }
    directive_value("--mpi", &args.mpi)?;
    Ok(())
}

/// "3 array tasks of 2 MPI ranks", "1 task": what a job runs, for messages and the job script.
fn job_shape(args: &SlurmArgs) -> String {
    let tasks = match args.array {
        Some(n) => format!("{n} array task{}", if n == 1 { "" } else { "s" }),
        None => "1 task".to_string(),
    };
    match args.ranks {
        1 => tasks,
        r => format!("{tasks} of {r} MPI ranks"),
    }
}

/// Where the job script goes and what it runs, as absolute paths (a job starts elsewhere).
struct JobScript {
    file: PathBuf,
    log_dir: PathBuf,
    name: String,
    hdrvis: PathBuf,
    script: PathBuf,
    out: PathBuf,
    allow_paths: Vec<PathBuf>,
}

impl JobScript {
    fn new(args: &SlurmArgs) -> Result<JobScript> {
        let cwd = std::env::current_dir().map_err(|e| Error::io(".", e))?;
        let script = std::fs::canonicalize(&args.script).map_err(|e| Error::io(&args.script, e))?;
        let out = cwd.join(&args.out);
        let log_dir = out.join("slurm");
        let name = match &args.job_name {
            Some(n) => n.clone(),
            None => script
                .file_stem()
                .map_or("hdrvis".into(), |s| s.to_string_lossy().to_string()),
        };
        let file = match &args.job_file {
            Some(f) => cwd.join(f),
            None => log_dir.join(format!("{name}.sbatch")),
        };
        let hdrvis = std::env::current_exe().map_err(|e| Error::io("hdrvis", e))?;
        Ok(JobScript {
            file,
            log_dir,
            name,
            hdrvis,
            script,
            out,
            allow_paths: args
                .inputs
                .allow_paths
                .iter()
                .map(|d| cwd.join(d))
                .collect(),
        })
    }

    /// The job script: a comment saying what it runs, #SBATCH lines, then one `srun hdrvis run
    /// --resume` of the script.
    fn text(&self, args: &SlurmArgs, sets: &[(String, String)]) -> Result<String> {
        let set_args: Vec<String> = sets
            .iter()
            .map(|(k, v)| format!("--set {}", shell_quote(&format!("{k}={v}"))))
            .collect();
        let script = self.script.display();
        let mut text = format!(
            "#!/bin/bash\n# Written by `hdrvis slurm`: runs\n#   {script}\n# as {shape}.\n",
            shape = job_shape(args)
        );
        if let Some(n) = args.array {
            text.push_str(&format!(
                "# Each task renders the items shard() gives it and logs its \"wrote\" lines. Submitting\n\
                 # this file again renders only what is missing (--resume); what that is:\n\
                 #   hdrvis sweep-status --out {out} {script} --array {n}{sets}\n",
                out = self.out.display(),
                sets = set_args.iter().map(|a| format!(" {a}")).collect::<String>(),
            ));
        } else {
            text.push_str(
                "# Submitting this file again writes only the outputs that are missing (--resume).\n",
            );
        }
        if args.ranks > 1 {
            text.push_str(&format!(
                "# The {} ranks of the step render every volume together; rank 0 writes and prints.\n",
                args.ranks
            ));
        }
        for o in self.directives(args)? {
            text.push_str(&format!("#SBATCH {o}\n"));
        }
        text.push_str("set -euo pipefail\n");
        text.push_str(&self.command(args, &set_args).join(" "));
        text.push('\n');
        Ok(text)
    }

    /// The #SBATCH options: name, array, logs, then the resources asked for, then the user's.
    fn directives(&self, args: &SlurmArgs) -> Result<Vec<String>> {
        // %A_%a is an array task's job and task id, %j a plain job's id.
        let id = if args.array.is_some() { "%A_%a" } else { "%j" };
        let log = |ext: &str| -> Result<String> {
            let path = format!("{}/{}-{id}.{ext}", self.log_dir.display(), self.name);
            directive_value("--out", &path).map(str::to_string)
        };
        let mut options = vec![format!(
            "--job-name={}",
            directive_value("--job-name", &self.name)?
        )];
        if let Some(n) = args.array {
            let throttle = args
                .max_running
                .map(|k| format!("%{k}"))
                .unwrap_or_default();
            options.push(format!("--array=0-{}{throttle}", n - 1));
        }
        options.push(format!("--output={}", log("out")?));
        options.push(format!("--error={}", log("err")?));
        if args.ranks > 1 {
            options.push(format!("--ntasks={}", args.ranks));
        }
        if let Some(m) = args.nodes {
            options.push(format!("--nodes={m}"));
        }
        let given = [
            ("time", &args.time),
            ("partition", &args.partition),
            ("mem", &args.mem),
        ];
        for (key, value) in given {
            if let Some(v) = value {
                options.push(format!(
                    "--{key}={}",
                    directive_value(&format!("--{key}"), v)?
                ));
            }
        }
        if let Some(c) = args.cpus_per_task {
            options.push(format!("--cpus-per-task={c}"));
        }
        for extra in &args.sbatch {
            if !extra.starts_with('-') {
                return Err(Error::invalid(
                    "sbatch options",
                    format!("expected options such as --account=geo after --, got {extra:?}"),
                ));
            }
            options.push(directive_value("sbatch options", extra)?.to_string());
        }
        Ok(options)
    }

    /// `srun [--mpi=TYPE] HDRVIS run SCRIPT --out DIR --resume [--set …] [--allow-path …]`.
    fn command(&self, args: &SlurmArgs, set_args: &[String]) -> Vec<String> {
        let mut command = vec!["srun".to_string()];
        if args.ranks > 1 {
            command.push(format!("--mpi={}", shell_quote(&args.mpi)));
        }
        command.extend([
            shell_quote(&self.hdrvis.display().to_string()),
            "run".into(),
            shell_quote(&self.script.display().to_string()),
            "--out".into(),
            shell_quote(&self.out.display().to_string()),
            "--resume".into(),
        ]);
        command.extend(set_args.iter().cloned());
        for dir in &self.allow_paths {
            command.push(format!(
                "--allow-path {}",
                shell_quote(&dir.display().to_string())
            ));
        }
        command
    }
}

/// A value for an #SBATCH line: sbatch reads those up to the first blank, so values with
/// blanks, quotes or control characters are refused rather than cut short.
fn directive_value<'a>(field: &str, value: &'a str) -> Result<&'a str> {
    if value.is_empty()
        || value
            .chars()
            .any(|c| c.is_whitespace() || c.is_control() || c == '"' || c == '\'')
    {
        return Err(Error::invalid(
            field,
            format!("{value:?} cannot go into an #SBATCH line (empty, or holds blanks, quotes or control characters)"),
        ));
    }
    Ok(value)
}

/// `text` as one shell word: as it is when it holds only safe characters, else single-quoted.
fn shell_quote(text: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "/._-=+:,@%".contains(c);
    if !text.is_empty() && text.chars().all(safe) {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
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
