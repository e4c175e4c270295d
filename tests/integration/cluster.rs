//! Sweeps shared out over several processes: `hdrvis run --shard I/N`, a real Slurm job array
//! submitted by `hdrvis slurm --submit` and `srun` tasks on a one-node cluster that
//! `tests/cluster/slurm-up.sh` starts (munged, slurmctld, slurmd under a temporary folder, torn
//! down when this test binary ends), and `hdrvis sweep-status`. Every split must write the
//! serial run's files, each exactly once, and a cancelled task resubmitted with `--resume` must
//! complete the sweep; an MPI job array through `srun --mpi=pmix` must give the single-process
//! images. The Slurm tests are skipped with a reason when slurmctld is missing or
//! the tests do not run as root, unless HDRVIS_REQUIRE_SLURM=1 (as in CI).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The sweep every test splits: the shipped example at a tiny size.
fn sweep_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/sweep_slurm.rhai")
}

const SMALL: [&str; 6] = ["--set", "n=24", "--set", "size=24", "--set", "frames=7"];

/// `hdrvis ARGS` in `dir` with the dataset cache there, none of the caller's own Slurm task
/// variables (a CI job may itself run under Slurm), and `env` added.
fn hdrvis_in(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    binary_in(Path::new(env!("CARGO_BIN_EXE_hdrvis")), dir, args, env)
}

/// [`hdrvis_in`] with another build of hdrvis (the MPI one).
fn binary_in(bin: &Path, dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(bin);
    cmd.args(args)
        .current_dir(dir)
        .env("HDRVIS_CACHE", dir.join("cache"));
    for (name, _) in std::env::vars().filter(|(n, _)| n.starts_with("SLURM_")) {
        cmd.env_remove(name);
    }
    cmd.envs(env.iter().copied());
    cmd.output().expect("run hdrvis")
}

/// Environment variables a command gets on top of the test's own.
type Env<'a> = &'a [(&'a str, &'a str)];

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The paths of the "wrote PATH" lines of a log.
fn wrote(log: &str) -> Vec<String> {
    log.lines()
        .filter_map(|l| l.strip_prefix("wrote "))
        .map(str::to_string)
        .collect()
}

/// Output names under `dir/sweep_slurm`, sorted; a cancelled task's temporaries
/// (`.hdrvis-*.tmp`, never an output) are left out.
fn frames(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join("sweep_slurm"))
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().to_string())
                .filter(|n| !n.starts_with('.'))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// The serial run of the sweep into `dir/serial`: the reference every split is held to.
fn serial_run(dir: &Path) -> Vec<String> {
    let script = sweep_script();
    let mut args = vec!["run", script.to_str().unwrap(), "--out", "serial"];
    args.extend(SMALL);
    let out = hdrvis_in(dir, &args, &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let names = frames(&dir.join("serial"));
    // Seven frames, a PNG and an EXR each.
    assert_eq!(names.len(), 14, "{names:?}");
    assert_eq!(wrote(&text(&out.stdout)).len(), 14);
    names
}

/// Every file of `split` equals the serial run's: PNGs byte for byte; EXRs pixel for pixel and
/// in every attribute but `passes`, whose timings differ from run to run.
fn assert_same_files(dir: &Path, split: &str, names: &[String]) {
    assert_eq!(frames(&dir.join(split)), names, "{split}");
    for name in names {
        let a = dir.join("serial/sweep_slurm").join(name);
        let b = dir.join(split).join("sweep_slurm").join(name);
        if name.ends_with(".png") {
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{split}/{name} differs from the serial run's"
            );
        } else {
            let (x, y) = (
                hdrvis::io::exr::read_exr(&a).unwrap(),
                hdrvis::io::exr::read_exr(&b).unwrap(),
            );
            assert_eq!(x.pixels, y.pixels, "{split}/{name}");
            let attributes = |img: &hdrvis::model::HdrImage| {
                let mut m: Vec<_> = img
                    .metadata
                    .iter()
                    .filter(|(k, _)| !k.ends_with("passes"))
                    .cloned()
                    .collect();
                m.sort();
                m
            };
            assert_eq!(attributes(&x), attributes(&y), "{split}/{name}");
        }
    }
}

/// The shares of several logs: disjoint, and together the serial run's files.
fn assert_disjoint_cover(logs: &[String], names: &[String]) {
    let mut seen = BTreeSet::new();
    for (task, log) in logs.iter().enumerate() {
        for path in wrote(log) {
            let name = Path::new(&path)
                .file_name()
                .unwrap()
                .to_string_lossy()
                .to_string();
            assert!(
                seen.insert(name.clone()),
                "{name} written twice (again by log {task})"
            );
        }
    }
    assert_eq!(seen.into_iter().collect::<Vec<_>>(), names);
}

#[test]
fn shard_flag_splits_a_sweep_into_disjoint_shares_that_make_the_serial_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let names = serial_run(d);
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let mut logs = Vec::new();
    for shard in ["0/3", "1/3", "2/3"] {
        let mut args = vec!["run", script, "--out", "split", "--shard", shard];
        args.extend(SMALL);
        // The flag wins over the environment.
        let out = hdrvis_in(
            d,
            &args,
            &[
                ("SLURM_ARRAY_TASK_ID", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
            ],
        );
        assert!(out.status.success(), "{}", text(&out.stderr));
        let stderr = text(&out.stderr);
        assert!(
            stderr.contains(&format!("task {} of 3 (--shard)", &shard[..1])),
            "{stderr}"
        );
        logs.push(text(&out.stdout));
    }
    // Seven frames over three tasks: blocks of 2, 2 and 3 frames.
    let counts: Vec<usize> = logs.iter().map(|l| wrote(l).len()).collect();
    assert_eq!(counts, [4, 4, 6]);
    assert_disjoint_cover(&logs, &names);
    assert_same_files(d, "split", &names);

    // The same split from a job array's variables alone (MIN/MAX instead of COUNT).
    let mut logs = Vec::new();
    for id in ["4", "5", "6"] {
        let mut args = vec!["run", script, "--out", "array"];
        args.extend(SMALL);
        let env = [
            ("SLURM_ARRAY_TASK_ID", id),
            ("SLURM_ARRAY_TASK_MIN", "4"),
            ("SLURM_ARRAY_TASK_MAX", "6"),
        ];
        let out = hdrvis_in(d, &args, &env);
        assert!(out.status.success(), "{}", text(&out.stderr));
        logs.push(text(&out.stdout));
    }
    assert_eq!(
        logs.iter().map(|l| wrote(l).len()).collect::<Vec<_>>(),
        [4, 4, 6]
    );
    assert_disjoint_cover(&logs, &names);
    assert_same_files(d, "array", &names);
}

#[test]
fn bad_shards_and_inconsistent_slurm_variables_are_one_line_errors_writing_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let cases: &[(&[&str], Env, &str)] = &[
        (&["--shard", "3/2"], &[], "--shard: expected I/N"),
        (&["--shard", "0/0"], &[], "--shard: expected I/N"),
        (&["--shard", "x/y"], &[], "--shard: expected I/N"),
        (
            &[],
            &[
                ("SLURM_ARRAY_TASK_ID", "5"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ],
            "SLURM_ARRAY_TASK_COUNT:",
        ),
        (
            &[],
            &[
                ("SLURM_ARRAY_TASK_ID", "1"),
                ("SLURM_ARRAY_TASK_MIN", "2"),
                ("SLURM_ARRAY_TASK_MAX", "3"),
            ],
            "SLURM_ARRAY_TASK_MIN:",
        ),
        (
            &[],
            &[
                ("SLURM_STEP_ID", "0"),
                ("SLURM_PROCID", "2"),
                ("SLURM_NTASKS", "2"),
            ],
            "SLURM_PROCID:",
        ),
    ];
    for (i, (flags, env, needle)) in cases.iter().enumerate() {
        let out_dir = format!("out{i}");
        let mut args = vec!["run", script, "--out", &out_dir];
        args.extend(SMALL);
        args.extend(flags.iter());
        let out = hdrvis_in(d, &args, env);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flags:?} {env:?}: {stderr}");
        let line = stderr
            .lines()
            .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
            .collect::<Vec<_>>();
        assert_eq!(line.len(), 1, "{stderr}");
        assert!(line[0].starts_with(&format!("error: {needle}")), "{stderr}");
        assert!(text(&out.stdout).is_empty());
        assert!(
            !d.join(&out_dir).exists(),
            "{flags:?} {env:?} wrote {out_dir}"
        );
    }
}

#[test]
fn sweep_status_lists_exactly_the_outputs_deleted_from_a_real_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let names = serial_run(d);
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let status = |extra: &[&str]| {
        let mut args = vec!["sweep-status", "--out", "serial", script];
        args.extend(SMALL);
        args.extend(extra);
        let out = hdrvis_in(d, &args, &[]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    assert_eq!(status(&[]).trim(), "14 outputs: 14 done, 0 missing");
    // Frames 1 (task 0 of 3) and 5 (task 2): one EXR, one PNG, another EXR.
    let gone = [
        "az51.42857142857143.exr",
        "az257.14285714285717.png",
        "az257.14285714285717.exr",
    ];
    for name in gone {
        assert!(names.contains(&name.to_string()), "{name} not in {names:?}");
        std::fs::remove_file(d.join("serial/sweep_slurm").join(name)).unwrap();
    }
    let report = status(&[]);
    let missing: BTreeSet<String> = report
        .lines()
        .filter_map(|l| l.strip_prefix("missing "))
        .map(|p| {
            Path::new(p)
                .file_name()
                .unwrap()
                .to_string_lossy()
                .to_string()
        })
        .collect();
    assert_eq!(missing, gone.iter().map(|s| s.to_string()).collect());
    assert!(
        report.contains("14 outputs: 11 done, 3 missing"),
        "{report}"
    );
    let by_task = status(&["--array", "3"]);
    assert!(
        by_task.contains(
            "tasks with outputs missing: 0 (1), 2 (2); resubmit them with sbatch --array=0,2"
        ),
        "{by_task}"
    );
    let one_task = status(&["--shard", "1/3"]);
    assert!(
        one_task.contains("4 outputs: 4 done, 0 missing"),
        "{one_task}"
    );
    // A resumed run writes exactly what sweep-status listed, and nothing else.
    let mut args = vec!["run", script, "--out", "serial", "--resume"];
    args.extend(SMALL);
    let out = hdrvis_in(d, &args, &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let rewritten: BTreeSet<String> = wrote(&text(&out.stdout))
        .iter()
        .map(|p| {
            Path::new(p)
                .file_name()
                .unwrap()
                .to_string_lossy()
                .to_string()
        })
        .collect();
    assert_eq!(rewritten, missing);
    assert_eq!(status(&[]).trim(), "14 outputs: 14 done, 0 missing");
}

#[test]
fn resuming_one_task_of_a_shared_folder_leaves_fresh_temporaries_of_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let tmp_dir = d.join("out/sweep_slurm");
    std::fs::create_dir_all(&tmp_dir).unwrap();
    let fresh = tmp_dir.join(".hdrvis-fresh.tmp");
    let stale = tmp_dir.join(".hdrvis-stale.tmp");
    std::fs::write(&fresh, b"another task is writing this").unwrap();
    let old = std::fs::File::create(&stale).unwrap();
    old.set_modified(std::time::SystemTime::now() - Duration::from_secs(3600))
        .unwrap();
    drop(old);
    let run = |extra: &[&str]| {
        let mut args = vec!["run", script, "--out", "out", "--resume"];
        args.extend(SMALL);
        args.extend(extra);
        let out = hdrvis_in(d, &args, &[]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    };
    run(&["--shard", "0/3"]);
    assert!(fresh.exists(), "a task removed another task's temporary");
    assert!(!stale.exists(), "an hour-old temporary was kept");
    // Alone in the folder, a resumed run sweeps every temporary away.
    run(&[]);
    assert!(!fresh.exists());
}

#[test]
fn slurm_writes_a_ready_job_script_and_refuses_what_it_cannot_submit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let mut args = vec![
        "slurm",
        script,
        "--array",
        "4",
        "--out",
        "sweep",
        "--time",
        "0:10:00",
        "--mem",
        "2G",
        "--cpus-per-task",
        "2",
        "--max-running",
        "2",
    ];
    args.extend(SMALL);
    args.extend(["--", "--account=geo", "--qos=normal"]);
    let out = hdrvis_in(d, &args, &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let job_file = d.join("sweep/slurm/sweep_slurm.sbatch");
    assert_eq!(
        text(&out.stdout).trim(),
        format!("wrote {}", job_file.display())
    );
    let job = std::fs::read_to_string(&job_file).unwrap();
    let directives: Vec<&str> = job.lines().filter(|l| l.starts_with("#SBATCH")).collect();
    let logs = d.join("sweep/slurm/sweep_slurm");
    assert_eq!(
        directives,
        [
            "#SBATCH --job-name=sweep_slurm".to_string(),
            "#SBATCH --array=0-3%2".into(),
            format!("#SBATCH --output={}-%A_%a.out", logs.display()),
            format!("#SBATCH --error={}-%A_%a.err", logs.display()),
            "#SBATCH --time=0:10:00".into(),
            "#SBATCH --mem=2G".into(),
            "#SBATCH --cpus-per-task=2".into(),
            "#SBATCH --account=geo".into(),
            "#SBATCH --qos=normal".into(),
        ]
    );
    let last = job.lines().last().unwrap();
    assert_eq!(
        last,
        format!(
            "srun {} run {script} --out {} --resume --set n=24 --set size=24 --set frames=7",
            env!("CARGO_BIN_EXE_hdrvis"),
            d.join("sweep").display()
        )
    );

    // Refusals: one line, exit 1, no job file.
    let orbit = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/orbit.rhai");
    let empty_path = d.join("no-tools");
    std::fs::create_dir_all(&empty_path).unwrap();
    let cases: &[(Vec<&str>, Env, &str)] = &[
        (
            vec!["slurm", script, "--array", "2", "--out", "a", "--submit"],
            &[("PATH", empty_path.to_str().unwrap())],
            "error: --submit: sbatch not found on PATH",
        ),
        (
            vec![
                "slurm",
                orbit.to_str().unwrap(),
                "--array",
                "2",
                "--out",
                "b",
            ],
            &[],
            "never calls shard(...)",
        ),
        (
            vec!["slurm", script, "--array", "0", "--out", "c"],
            &[],
            "error: --array:",
        ),
        (
            vec![
                "slurm", script, "--array", "2", "--out", "f", "--ranks", "2",
            ],
            &[],
            "error: --ranks: this hdrvis was built without MPI",
        ),
        (
            vec![
                "slurm",
                script,
                "--ranks",
                "1",
                "--out",
                "g",
                "--max-running",
                "2",
            ],
            &[],
            "error: --max-running: limits the tasks of a job array",
        ),
        (
            vec![
                "slurm", script, "--array", "2", "--out", "d", "--set", "sise=3",
            ],
            &[],
            "error: --set sise:",
        ),
        (
            vec![
                "slurm",
                script,
                "--array",
                "2",
                "--out",
                "e",
                "--partition",
                "a b",
            ],
            &[],
            "error: --partition:",
        ),
    ];
    for (args, env, needle) in cases {
        let out = hdrvis_in(d, args, env);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        let out_dir = d.join(args[5]);
        assert!(!out_dir.join("slurm").exists(), "{args:?} wrote a job file");
    }

    // Without --array, one job runs the script once: no array, no shard() needed, %j logs.
    let orbit = orbit.to_str().unwrap();
    let out = hdrvis_in(d, &["slurm", orbit, "--out", "once", "--time", "5"], &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let job = std::fs::read_to_string(d.join("once/slurm/orbit.sbatch")).unwrap();
    let directives: Vec<&str> = job.lines().filter(|l| l.starts_with("#SBATCH")).collect();
    let logs = d.join("once/slurm/orbit");
    assert_eq!(
        directives,
        [
            "#SBATCH --job-name=orbit".to_string(),
            format!("#SBATCH --output={}-%j.out", logs.display()),
            format!("#SBATCH --error={}-%j.err", logs.display()),
            "#SBATCH --time=5".into(),
        ]
    );
    assert_eq!(
        job.lines().last().unwrap(),
        format!(
            "srun {} run {orbit} --out {} --resume",
            env!("CARGO_BIN_EXE_hdrvis"),
            d.join("once").display()
        )
    );
}

/// A one-node Slurm cluster started by tests/cluster/slurm-up.sh for this test binary.
struct Cluster {
    /// SLURM_CONF for the clients.
    conf: String,
}

/// The cluster, started on first use; `None` (with the reason printed) where it cannot run,
/// a panic when HDRVIS_REQUIRE_SLURM=1 asks for it.
fn cluster() -> Option<&'static Cluster> {
    static CLUSTER: OnceLock<Option<Cluster>> = OnceLock::new();
    CLUSTER
        .get_or_init(|| match start_cluster() {
            Ok(c) => Some(c),
            Err(why) => crate::common::missing(
                "HDRVIS_REQUIRE_SLURM",
                &format!("the Slurm cluster did not start: {why}"),
            ),
        })
        .as_ref()
}

fn start_cluster() -> Result<Cluster, String> {
    let uid = Command::new("id")
        .arg("-u")
        .output()
        .map_err(|e| format!("cannot run `id -u`: {e}"))?;
    if text(&uid.stdout).trim() != "0" {
        return Err("slurmd needs root".into());
    }
    if !Command::new("sh")
        .args(["-c", "command -v slurmctld"])
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Err("slurmctld is not installed (apt-get install slurm-wlm munge)".into());
    }
    // The folder outlives the OnceLock; the harness's watchdog removes it with the daemons
    // when this process ends.
    let dir = tempfile::Builder::new()
        .prefix("hdrvis-slurm-")
        .tempdir()
        .map_err(|e| e.to_string())?
        .keep();
    let up = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cluster/slurm-up.sh");
    let out = Command::new(&up)
        .arg(&dir)
        .arg(std::process::id().to_string())
        .output()
        .map_err(|e| format!("{}: {e}", up.display()))?;
    let stdout = text(&out.stdout);
    match stdout
        .lines()
        .last()
        .and_then(|l| l.strip_prefix("SLURM_CONF="))
    {
        Some(conf) if out.status.success() => Ok(Cluster {
            conf: conf.to_string(),
        }),
        _ => Err(format!(
            "{} failed: {}",
            up.display(),
            text(&out.stderr).trim()
        )),
    }
}

impl Cluster {
    /// A Slurm client command (sbatch, squeue, scancel, srun) against this cluster.
    fn client(&self, tool: &str, args: &[&str]) -> Output {
        Command::new(tool)
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .output()
            .unwrap_or_else(|e| panic!("{tool}: {e}"))
    }

    /// Waits until no task of job `id` is pending or running.
    fn wait(&self, id: &str) {
        let t0 = Instant::now();
        loop {
            let out = self.client("squeue", &["-h", "-j", id, "-o", "%i %T"]);
            if text(&out.stdout).trim().is_empty() {
                return;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(180),
                "job {id} still queued: {}",
                text(&out.stdout)
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

/// The job id `hdrvis slurm --submit` printed.
fn submitted_id(stdout: &str) -> String {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("submitted job "))
        .and_then(|rest| rest.split(':').next())
        .unwrap_or_else(|| panic!("no job id in {stdout}"))
        .to_string()
}

/// Stdout and stderr logs of array task `task` of job `id`.
fn task_logs(dir: &Path, out: &str, id: &str, task: u64) -> (String, String) {
    let base = dir
        .join(out)
        .join("slurm")
        .join(format!("sweep_slurm-{id}_{task}"));
    let read = |ext: &str| std::fs::read_to_string(base.with_extension(ext)).unwrap_or_default();
    (read("out"), read("err"))
}

#[test]
fn a_real_slurm_job_array_and_srun_tasks_write_the_serial_files_each_once() {
    let Some(slurm) = cluster() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let names = serial_run(d);
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let mut args = vec![
        "slurm", script, "--array", "3", "--out", "array", "--submit",
    ];
    args.extend(SMALL);
    let out = hdrvis_in(d, &args, &[("SLURM_CONF", &slurm.conf)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let id = submitted_id(&text(&out.stdout));
    slurm.wait(&id);
    let mut logs = Vec::new();
    for task in 0..3 {
        let (stdout, stderr) = task_logs(d, "array", &id, task);
        assert!(
            stderr.contains(&format!("task {task} of 3 (Slurm job array)")),
            "task {task}: {stderr}"
        );
        logs.push(stdout);
    }
    assert_eq!(
        logs.iter().map(|l| wrote(l).len()).collect::<Vec<_>>(),
        [4, 4, 6]
    );
    assert_disjoint_cover(&logs, &names);
    assert_same_files(d, "array", &names);

    // Two srun tasks in one step share the sweep by SLURM_PROCID; --label tells their lines apart.
    let hdrvis = env!("CARGO_BIN_EXE_hdrvis");
    let mut args = vec![
        "--ntasks=2",
        "--label",
        hdrvis,
        "run",
        script,
        "--out",
        "steps",
    ];
    args.extend(SMALL);
    let mut srun = Command::new("srun");
    srun.args(&args)
        .current_dir(d)
        .env("SLURM_CONF", &slurm.conf)
        .env("HDRVIS_CACHE", d.join("cache"));
    let out = srun.output().unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let logs: Vec<String> = ["0: ", "1: "]
        .iter()
        .map(|label| {
            stdout
                .lines()
                .filter_map(|l| l.trim_start().strip_prefix(label))
                .collect::<Vec<_>>()
                .join("\n")
        })
        .collect();
    assert_eq!(
        logs.iter().map(|l| wrote(l).len()).collect::<Vec<_>>(),
        [6, 8]
    );
    assert_disjoint_cover(&logs, &names);
    assert_same_files(d, "steps", &names);
}

/// An MPI render through Slurm: `hdrvis slurm --array 2 --ranks 2 --submit` (the binary built
/// with `--features mpi`) writes and submits a two-task job array whose tasks each run one
/// `srun --mpi=pmix` step of two MPI ranks. The array shares the sweep; the two ranks of a step
/// render every frame of their task's share together (the step's SLURM_PROCID must not share it
/// again), and rank 0 alone writes and prints.
#[test]
fn an_mpi_job_array_through_slurm_renders_each_frame_on_two_ranks_once() {
    let Some(slurm) = cluster() else {
        return;
    };
    let Some(bin) = crate::mpi::mpi_binary() else {
        return;
    };
    let mpi_types = slurm.client("srun", &["--mpi=list"]);
    let listed = format!("{}{}", text(&mpi_types.stdout), text(&mpi_types.stderr));
    assert!(
        listed.lines().any(|l| l.trim() == "pmix"),
        "srun --mpi=list offers no pmix (Debian's slurm-wlm has it): {listed}"
    );
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let names = serial_run(d);
    let script = sweep_script();
    let script = script.to_str().unwrap();
    let mut args = vec![
        "slurm", script, "--array", "2", "--ranks", "2", "--out", "mpi", "--submit",
    ];
    args.extend(SMALL);
    // The job inherits the submitting environment (sbatch's default): the cluster and OpenMPI's
    // setting for containers without cross-memory attach.
    let env = [
        ("SLURM_CONF", slurm.conf.as_str()),
        ("OMPI_MCA_btl_vader_single_copy_mechanism", "none"),
    ];
    let out = binary_in(&bin, d, &args, &env);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains(": 2 array tasks of 2 MPI ranks, logs in"),
        "{stdout}"
    );
    let job = std::fs::read_to_string(d.join("mpi/slurm/sweep_slurm.sbatch")).unwrap();
    assert!(job.lines().any(|l| l == "#SBATCH --ntasks=2"), "{job}");
    let srun = format!("srun --mpi=pmix {} run {script} --out ", bin.display());
    assert!(job.lines().last().unwrap().starts_with(&srun), "{job}");
    let id = submitted_id(&stdout);
    slurm.wait(&id);
    let mut logs = Vec::new();
    for task in 0..2 {
        let (stdout, stderr) = task_logs(d, "mpi", &id, task);
        // One array task of two, said once (by rank 0); the step's ranks are not tasks.
        let said: Vec<&str> = stderr
            .lines()
            .filter(|l| l.contains("hdrvis run: task"))
            .collect();
        assert_eq!(
            said,
            [format!(
                "hdrvis run: task {task} of 2 (Slurm job array): shard() gives it its share"
            )],
            "task {task}: {stderr}"
        );
        // Each frame's lines once: a second rank printing would repeat them.
        logs.push(stdout);
    }
    // Seven frames over two array tasks: 3 and 4 frames, a PNG and an EXR each.
    assert_eq!(
        logs.iter().map(|l| wrote(l).len()).collect::<Vec<_>>(),
        [6, 8]
    );
    assert_disjoint_cover(&logs, &names);
    assert_eq!(frames(&d.join("mpi")), names);
    for name in names.iter().filter(|n| n.ends_with(".exr")) {
        let worst = crate::mpi::worst_over_peak(
            &d.join("mpi/sweep_slurm").join(name),
            &d.join("serial/sweep_slurm").join(name),
        );
        assert!(worst < 1e-5, "{name}: {worst:.2e} of the peak");
    }
}

#[test]
fn a_cancelled_array_task_resubmitted_with_resume_completes_the_sweep() {
    let Some(slurm) = cluster() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let names = serial_run(d);
    // The example sweep with a pause after every frame, so a task is still running when the
    // test cancels it after its first frame.
    let source = std::fs::read_to_string(sweep_script()).unwrap().replace(
        "        save_exr(img, `${name}.exr`);\n",
        "        save_exr(img, `${name}.exr`);\n        for pause_step in 0..param(\"pause\", 0) {}\n",
    );
    assert!(
        source.contains("pause"),
        "the example's save_exr line moved"
    );
    std::fs::write(d.join("sweep_slurm.rhai"), source).unwrap();
    let mut args = vec![
        "slurm",
        "sweep_slurm.rhai",
        "--array",
        "2",
        "--out",
        "part",
        "--submit",
    ];
    args.extend(SMALL);
    args.extend(["--set", "pause=3000000"]);
    let out = hdrvis_in(d, &args, &[("SLURM_CONF", &slurm.conf)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let first = submitted_id(&text(&out.stdout));
    // Task 1 owns frames 3 to 6; cancel it once its first frame is on disk.
    let t0 = Instant::now();
    while !task_logs(d, "part", &first, 1).0.contains(".exr") {
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "task 1 wrote nothing"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let cancel = slurm.client("scancel", &[&format!("{first}_1")]);
    assert!(cancel.status.success(), "{}", text(&cancel.stderr));
    slurm.wait(&first);
    let (cut_short, cut_err) = task_logs(d, "part", &first, 1);
    let before = wrote(&cut_short).len();
    assert!(
        before < 8,
        "task 1 finished before it was cancelled: {cut_short}"
    );
    assert!(frames(&d.join("part")).len() < names.len());

    // Resubmit the same job file: only task 1's missing frames are rendered.
    let job_file = d.join("part/slurm/sweep_slurm.sbatch");
    let resubmit = slurm.client("sbatch", &["--parsable", job_file.to_str().unwrap()]);
    assert!(resubmit.status.success(), "{}", text(&resubmit.stderr));
    let second = text(&resubmit.stdout).trim().to_string();
    slurm.wait(&second);
    let (again0, _) = task_logs(d, "part", &second, 0);
    let (again1, _) = task_logs(d, "part", &second, 1);
    assert!(wrote(&again0).is_empty(), "task 0 was complete: {again0}");
    assert_eq!(wrote(&again1).len(), 8 - before, "{cut_err}\n{again1}");
    // Across both submissions every file was written exactly once.
    let logs = [task_logs(d, "part", &first, 0).0, cut_short, again1];
    assert_disjoint_cover(&logs, &names);
    assert_same_files(d, "part", &names);
}
