//! Slurm job scripts for sweeps: what `hdrvis slurm` writes. A [`SlurmJob`] says what to run
//! (this binary, the script, its output folder, `--set` values, readable folders) and how (a job
//! array with one task per share of `shard(items)`, MPI ranks started by `srun --mpi=…`, the
//! resources asked for); [`SlurmJob::text`] makes the job script. sbatch reads an #SBATCH line
//! only up to its first blank, so values that cannot go into one are refused instead of being
//! cut short; the command line is quoted for bash.

use crate::error::{Error, Result};
use std::path::PathBuf;

/// One sweep as a Slurm job. Paths are absolute: a job starts in another folder.
#[derive(Clone, Debug, Default)]
pub struct SlurmJob {
    /// The job's name (`--job-name`, and the log files' stem).
    pub name: String,
    /// The hdrvis binary the tasks run.
    pub hdrvis: PathBuf,
    /// The sweep's script.
    pub script: PathBuf,
    /// The sweep's output folder.
    pub out: PathBuf,
    /// Where the tasks' logs go.
    pub log_dir: PathBuf,
    /// `--set NAME=VALUE` pairs for the script.
    pub sets: Vec<(String, String)>,
    /// Folders the script may read besides its own (`--allow-path`).
    pub allow_paths: Vec<PathBuf>,
    /// Array tasks sharing the sweep; `None` runs the script once.
    pub array: Option<u64>,
    /// At most this many array tasks at once.
    pub max_running: Option<u64>,
    /// MPI ranks rendering every volume together in each task (1: none).
    pub ranks: u32,
    /// Nodes the ranks spread over.
    pub nodes: Option<u32>,
    /// srun's MPI plugin.
    pub mpi: String,
    /// `--time`, `--partition`, `--mem` as sbatch takes them.
    pub time: Option<String>,
    pub partition: Option<String>,
    pub mem: Option<String>,
    pub cpus_per_task: Option<u32>,
    /// Further sbatch options (`--account=geo`), each an #SBATCH line.
    pub sbatch: Vec<String>,
}

impl SlurmJob {
    /// Refuses counts of zero, a throttle without an array, more nodes than ranks, ranks a
    /// build without MPI cannot start, and an MPI plugin that cannot be written.
    pub fn check(&self) -> Result<()> {
        let counts = [
            ("--array", self.array),
            ("--max-running", self.max_running),
            ("--ranks", Some(u64::from(self.ranks))),
            ("--nodes", self.nodes.map(u64::from)),
        ];
        if let Some((field, _)) = counts.iter().find(|c| c.1 == Some(0)) {
            return Err(Error::invalid(*field, "expected at least 1, got 0"));
        }
        if self.max_running.is_some() && self.array.is_none() {
            return Err(Error::invalid(
                "--max-running",
                "limits the tasks of a job array; give --array N too",
            ));
        }
        if let Some(m) = self.nodes.filter(|&m| m > self.ranks) {
            return Err(Error::invalid(
                "--nodes",
                format!(
                    "{m} nodes for {} ranks would leave nodes idle; give at most as many nodes as ranks",
                    self.ranks
                ),
            ));
        }
        if self.ranks > 1 && !cfg!(feature = "mpi") {
            return Err(Error::invalid(
                "--ranks",
                format!(
                    "this hdrvis was built without MPI, so each of the {} ranks would run the whole script alone; build it with `cargo build --release --features mpi` and run that binary's `hdrvis slurm`",
                    self.ranks
                ),
            ));
        }
        directive_value("--mpi", &self.mpi)?;
        Ok(())
    }

    /// "3 array tasks of 2 MPI ranks", "1 task": what the job runs, for messages.
    pub fn shape(&self) -> String {
        let tasks = match self.array {
            Some(n) => format!("{n} array task{}", if n == 1 { "" } else { "s" }),
            None => "1 task".to_string(),
        };
        match self.ranks {
            0 | 1 => tasks,
            r => format!("{tasks} of {r} MPI ranks"),
        }
    }

    /// The job script: a comment saying what it runs, #SBATCH lines, then one `srun hdrvis run
    /// --resume` of the script.
    pub fn text(&self) -> Result<String> {
        let set_args: Vec<String> = self
            .sets
            .iter()
            .map(|(k, v)| format!("--set {}", shell_quote(&format!("{k}={v}"))))
            .collect();
        let script = self.script.display();
        let mut text = format!(
            "#!/bin/bash\n# Written by `hdrvis slurm`: runs\n#   {script}\n# as {}.\n",
            self.shape()
        );
        if let Some(n) = self.array {
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
        if self.ranks > 1 {
            text.push_str(&format!(
                "# The {} ranks of the step render every volume together; rank 0 writes and prints.\n",
                self.ranks
            ));
        }
        for o in self.directives()? {
            text.push_str(&format!("#SBATCH {o}\n"));
        }
        text.push_str("set -euo pipefail\n");
        text.push_str(&self.command(&set_args).join(" "));
        text.push('\n');
        Ok(text)
    }

    /// The #SBATCH options: name, array, logs, then the resources asked for, then the user's.
    fn directives(&self) -> Result<Vec<String>> {
        // %A_%a is an array task's job and task id, %j a plain job's id.
        let id = if self.array.is_some() { "%A_%a" } else { "%j" };
        let log = |ext: &str| -> Result<String> {
            let path = format!("{}/{}-{id}.{ext}", self.log_dir.display(), self.name);
            directive_value("--out", &path).map(str::to_string)
        };
        let mut options = vec![format!(
            "--job-name={}",
            directive_value("--job-name", &self.name)?
        )];
        if let Some(n) = self.array {
            let throttle = self
                .max_running
                .map(|k| format!("%{k}"))
                .unwrap_or_default();
            options.push(format!("--array=0-{}{throttle}", n.saturating_sub(1)));
        }
        options.push(format!("--output={}", log("out")?));
        options.push(format!("--error={}", log("err")?));
        if self.ranks > 1 {
            options.push(format!("--ntasks={}", self.ranks));
        }
        if let Some(m) = self.nodes {
            options.push(format!("--nodes={m}"));
        }
        let given = [
            ("time", &self.time),
            ("partition", &self.partition),
            ("mem", &self.mem),
        ];
        for (key, value) in given {
            if let Some(v) = value {
                let field = format!("--{key}");
                options.push(format!("{field}={}", directive_value(&field, v)?));
            }
        }
        if let Some(c) = self.cpus_per_task {
            options.push(format!("--cpus-per-task={c}"));
        }
        for extra in &self.sbatch {
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
    fn command(&self, set_args: &[String]) -> Vec<String> {
        let mut command = vec!["srun".to_string()];
        if self.ranks > 1 {
            command.push(format!("--mpi={}", shell_quote(&self.mpi)));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn job() -> SlurmJob {
        SlurmJob {
            name: "sweep".into(),
            hdrvis: "/opt/hd rvis/bin/hdrvis".into(),
            script: "/home/u/it's/sweep.rhai".into(),
            out: "/scratch/out".into(),
            log_dir: "/scratch/out/slurm".into(),
            sets: vec![
                ("title".into(), "a $b `c` \"d\" \\ e".into()),
                ("n".into(), "64".into()),
            ],
            allow_paths: vec!["/data/model run".into()],
            array: Some(8),
            max_running: Some(3),
            ranks: 1,
            mpi: "pmix".into(),
            time: Some("01:30:00".into()),
            mem: Some("4G".into()),
            sbatch: vec!["--account=geo".into()],
            ..SlurmJob::default()
        }
    }

    /// What bash makes of each quoted word is the word itself, whatever it holds.
    #[test]
    fn quoted_words_reach_the_program_unchanged() {
        let words = [
            "plain",
            "",
            "two words",
            "it's",
            "$HOME",
            "`id`",
            "a\"b",
            "back\\slash",
            "tab\there",
            "new\nline",
            "*?[]",
            "ν = 0.25 m",
            "'",
            "''",
        ];
        let line = words
            .iter()
            .map(|w| shell_quote(w))
            .collect::<Vec<_>>()
            .join(" ");
        let out = std::process::Command::new("bash")
            .args(["-c", &format!("printf '%s\\0' {line}")])
            .output()
            .expect("bash runs");
        let got: Vec<String> = String::from_utf8(out.stdout)
            .unwrap()
            .split_terminator('\0')
            .map(str::to_string)
            .collect();
        assert_eq!(got, words);
        assert_eq!(shell_quote("/a/b-c_d.rhai"), "/a/b-c_d.rhai");
    }

    /// The job script holds the directives in order and a command bash splits into the
    /// intended arguments.
    #[test]
    fn the_job_script_runs_the_sweep_with_its_settings() {
        let job = job();
        let text = job.text().unwrap();
        let directives: Vec<&str> = text
            .lines()
            .filter_map(|l| l.strip_prefix("#SBATCH "))
            .collect();
        assert_eq!(
            directives,
            [
                "--job-name=sweep",
                "--array=0-7%3",
                "--output=/scratch/out/slurm/sweep-%A_%a.out",
                "--error=/scratch/out/slurm/sweep-%A_%a.err",
                "--time=01:30:00",
                "--mem=4G",
                "--account=geo",
            ]
        );
        assert!(text.starts_with("#!/bin/bash\n"));
        assert!(text.contains("as 8 array tasks."));
        let command = text.lines().last().unwrap();
        let args = std::process::Command::new("bash")
            .args([
                "-c",
                &format!("printf '%s\\0' {}", command.strip_prefix("srun ").unwrap()),
            ])
            .output()
            .unwrap();
        let args: Vec<String> = String::from_utf8(args.stdout)
            .unwrap()
            .split_terminator('\0')
            .map(str::to_string)
            .collect();
        assert_eq!(
            args,
            [
                "/opt/hd rvis/bin/hdrvis",
                "run",
                "/home/u/it's/sweep.rhai",
                "--out",
                "/scratch/out",
                "--resume",
                "--set",
                "title=a $b `c` \"d\" \\ e",
                "--set",
                "n=64",
                "--allow-path",
                "/data/model run",
            ]
        );
    }

    #[test]
    fn a_plain_job_logs_by_job_id_and_ranks_start_through_srun_mpi() {
        let mut job = job();
        job.array = None;
        job.max_running = None;
        let text = job.text().unwrap();
        assert!(text.contains("#SBATCH --output=/scratch/out/slurm/sweep-%j.out\n"));
        assert!(!text.contains("--array"));
        assert_eq!(job.shape(), "1 task");
        job.ranks = 4;
        job.nodes = Some(2);
        let text = job.text().unwrap();
        assert!(text.contains("#SBATCH --ntasks=4\n#SBATCH --nodes=2\n"));
        assert!(text
            .lines()
            .last()
            .unwrap()
            .starts_with("srun --mpi=pmix '/opt/hd rvis/bin/hdrvis' run"));
        assert_eq!(job.shape(), "1 task of 4 MPI ranks");
    }

    #[test]
    fn values_an_sbatch_line_would_cut_short_and_bad_counts_are_refused() {
        type Change = fn(&mut SlurmJob);
        let cases: [(Change, &str); 7] = [
            (|j| j.time = Some("1 day".into()), "--time"),
            (|j| j.name = "my sweep".into(), "--job-name"),
            (|j| j.sbatch = vec!["account=geo".into()], "sbatch options"),
            (
                |j| j.sbatch = vec!["--comment=\"x\"".into()],
                "sbatch options",
            ),
            (|j| j.array = Some(0), "--array"),
            (|j| j.nodes = Some(2), "--nodes"),
            (
                |j| {
                    j.array = None;
                },
                "--max-running",
            ),
        ];
        for (change, field) in cases {
            let mut job = job();
            change(&mut job);
            let err = job
                .check()
                .and_then(|()| job.text())
                .unwrap_err()
                .to_string();
            assert!(err.contains(field), "{field}: {err}");
            assert!(!err.contains('\n'), "{err}");
        }
    }
}
