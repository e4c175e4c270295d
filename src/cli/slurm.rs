//! `hdrvis slurm` and `hdrvis sweep-status`: a sweep shared out over a Slurm job array. The
//! first writes a ready job script (one array task per share, each running `hdrvis run
//! --resume` on the script, whose `shard(list)` gives the task its items) and with `--submit`
//! hands it to sbatch; the second lists the outputs a sweep writes that are missing, from a
//! planning run of the script that renders nothing.

use super::run::parse_sets;
use hdrvis::gpu::BackendChoice;
use hdrvis::render::cache::budget_mib;
use hdrvis::script::{check_sweep_script, sweep_status, ScriptOptions, Shard};
use hdrvis::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct SlurmArgs {
    /// The sweep: a script that loops over `shard(items)`.
    pub script: PathBuf,
    /// Array tasks to share the sweep over: `#SBATCH --array=0-(N-1)`.
    #[arg(long, value_name = "N")]
    pub array: u64,
    /// Output folder of the sweep; the job script and the tasks' logs go to DIR/slurm/.
    #[arg(long, short, visible_alias = "output", default_value = "out")]
    pub out: PathBuf,
    /// Script parameter read by `param(name, default)`; repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Extra folder the script may read; repeatable.
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_paths: Vec<PathBuf>,
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
    /// Script parameter read by `param(name, default)`; repeatable (as the sweep ran).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Extra folder the script may read; repeatable.
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_paths: Vec<PathBuf>,
    /// Say which tasks of an array of N have outputs missing (the indices to resubmit).
    #[arg(long, value_name = "N", conflicts_with = "shard")]
    pub array: Option<u64>,
    /// Only the share of task I of N.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
}

/// `hdrvis slurm`: checks the script, writes the job script and, with `--submit`, submits it.
pub fn run_slurm(args: &SlurmArgs) -> Result<()> {
    if args.array == 0 {
        return Err(Error::invalid("--array", "expected at least 1 task, got 0"));
    }
    if args.max_running == Some(0) {
        return Err(Error::invalid(
            "--max-running",
            "expected at least 1, got 0",
        ));
    }
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
    let sets = parse_sets(&args.sets)?;
    check_sweep_script(&args.script, &sets)?;
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
            "submitted job {id}: {} tasks, logs in {}",
            args.array,
            job.log_dir.display()
        );
    }
    Ok(())
}

/// Where the job script goes and what it runs, as absolute paths (a job starts elsewhere).
struct JobScript {
    file: PathBuf,
    log_dir: PathBuf,
    name: String,
    hdrvis: PathBuf,
    script: PathBuf,
    out: PathBuf,
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
        })
    }

    /// The job script: #SBATCH lines, then one `srun hdrvis run --resume` of the sweep.
    fn text(&self, args: &SlurmArgs, sets: &[(String, String)]) -> Result<String> {
        let last = args.array - 1;
        let throttle = args
            .max_running
            .map(|k| format!("%{k}"))
            .unwrap_or_default();
        let log = |ext: &str| -> Result<String> {
            let path = format!("{}/{}-%A_%a.{ext}", self.log_dir.display(), self.name);
            directive_value("--out", &path).map(str::to_string)
        };
        let mut options = vec![
            format!("--job-name={}", directive_value("--job-name", &self.name)?),
            format!("--array=0-{last}{throttle}"),
            format!("--output={}", log("out")?),
            format!("--error={}", log("err")?),
        ];
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
        let mut command = vec![
            "srun".to_string(),
            shell_quote(&self.hdrvis.display().to_string()),
            "run".into(),
            shell_quote(&self.script.display().to_string()),
            "--out".into(),
            shell_quote(&self.out.display().to_string()),
            "--resume".into(),
        ];
        let set_args: Vec<String> = sets
            .iter()
            .map(|(k, v)| format!("--set {}", shell_quote(&format!("{k}={v}"))))
            .collect();
        command.extend(set_args.iter().cloned());
        for dir in &args.allow_paths {
            let abs = std::env::current_dir()
                .map_err(|e| Error::io(".", e))?
                .join(dir);
            command.push(format!(
                "--allow-path {}",
                shell_quote(&abs.display().to_string())
            ));
        }
        let mut text = format!(
            "#!/bin/bash\n\
             # Written by `hdrvis slurm`: {n} array tasks share the sweep\n\
             #   {script}\n\
             # each rendering the items shard() gives it and logging its \"wrote\" lines. Submitting\n\
             # this file again renders only what is missing (--resume); what that is:\n\
             #   hdrvis sweep-status --out {out} {script} --array {n}{sets}\n",
            n = args.array,
            script = self.script.display(),
            out = self.out.display(),
            sets = set_args.iter().map(|a| format!(" {a}")).collect::<String>(),
        );
        for o in options {
            text.push_str(&format!("#SBATCH {o}\n"));
        }
        text.push_str("set -euo pipefail\n");
        text.push_str(&command.join(" "));
        text.push('\n');
        Ok(text)
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
    opts.sets = parse_sets(&args.sets)?;
    opts.allowed_paths = args.allow_paths.clone();
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
