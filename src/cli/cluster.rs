//! `hdrvis run` as one rank of an MPI launch (`mpirun -n N`, `srun --mpi=…`): every rank runs
//! the script with a session split over the ranks, so each `render_volume` renders one slab per
//! rank and composites onto rank 0; only rank 0 writes files and prints. An error on any rank
//! is printed once and ends every rank (MPI_Abort), so no rank hangs waiting for it.

use super::RunArgs;
use hdrvis::bench::distributed::DistributedBench;
use hdrvis::gpu::BackendChoice;
use hdrvis::{Error, Result};
use std::path::Path;

/// The rank and rank count an MPI launcher gave this process, from the environment it sets
/// (OpenMPI's mpirun, MPICH's hydra and Slurm's PMI2 set these); `None` outside a launch.
fn launched() -> Option<(usize, usize)> {
    let var = |k: &str| std::env::var(k).ok()?.trim().parse::<usize>().ok();
    [
        ("OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"),
        ("PMI_RANK", "PMI_SIZE"),
        ("PMIX_RANK", "SLURM_NTASKS"),
    ]
    .iter()
    .find_map(|(r, n)| Some((var(r)?, var(n)?)))
}

/// `hdrvis run`: as a rank when an MPI launcher started several, else as one process.
pub fn run_script(args: &RunArgs, backend: BackendChoice) -> Result<()> {
    if run_if_launched(args, backend)? {
        return Ok(());
    }
    super::run::run_script(args, backend)
}

/// `hdrvis bench distributed` without MPI: what to build instead.
#[cfg(not(feature = "mpi"))]
pub fn bench_distributed(
    _backend: BackendChoice,
    _bench: &DistributedBench,
    _ranks: &[usize],
    _report: Option<&Path>,
) -> Result<()> {
    Err(Error::invalid(
        "bench distributed",
        "this hdrvis was built without MPI; build it with `cargo build --release --features mpi` (Debian: apt-get install openmpi-bin libopenmpi-dev libclang-dev)",
    ))
}

/// `hdrvis bench distributed`: started by an MPI launcher, this process is one rank of the
/// world it measures (rank 0 prints its table, or with `report` writes its report there);
/// otherwise it starts that world with `mpirun --oversubscribe -n R` of this binary for each
/// rank count R and prints the scaling table of them all.
#[cfg(feature = "mpi")]
pub fn bench_distributed(
    backend: BackendChoice,
    bench: &DistributedBench,
    ranks: &[usize],
    report: Option<&Path>,
) -> Result<()> {
    use hdrvis::bench::distributed::{format_scaling_table, format_world_report};
    if launched().is_none() {
        return bench_worlds(backend, bench, ranks);
    }
    let world = std::sync::Arc::new(hdrvis::render::distributed::mpi::MpiExchange::init()?);
    let measured = hdrvis::gpu::GpuContext::new(backend).and_then(|ctx| {
        let machine = machine(&ctx);
        let report_of_rank0 =
            hdrvis::bench::distributed::bench_world(ctx, world.clone(), bench, &mut |m| {
                eprintln!("{m}")
            })?;
        match (report_of_rank0, report) {
            (Some(r), Some(path)) => {
                std::fs::write(path, format_world_report(&r)).map_err(|e| Error::io(path, e))
            }
            (Some(r), None) => {
                print!("{}", format_scaling_table(&machine, &[r]));
                Ok(())
            }
            (None, _) => Ok(()),
        }
    });
    if let Err(e) = measured {
        eprintln!("error: {e}");
        world.abort(1);
    }
    Ok(())
}

/// What a table's numbers were measured on: the adapter and the CPU count.
#[cfg(feature = "mpi")]
fn machine(ctx: &hdrvis::gpu::GpuContext) -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{}; {cores} CPU cores", ctx.describe())
}

/// One `mpirun --oversubscribe -n R` world of this binary per rank count, each writing its
/// report to a temporary file; then the scaling table of them all.
#[cfg(feature = "mpi")]
fn bench_worlds(backend: BackendChoice, bench: &DistributedBench, ranks: &[usize]) -> Result<()> {
    use hdrvis::bench::distributed::{bench_volume_file, format_scaling_table, parse_world_report};
    let mpirun = super::slurm::find_on_path("mpirun").ok_or_else(|| {
        Error::invalid(
            "bench distributed",
            "mpirun not found on PATH (Debian: apt-get install openmpi-bin)",
        )
    })?;
    let exe = std::env::current_exe().map_err(|e| Error::io("hdrvis", e))?;
    let machine = machine(&*hdrvis::gpu::GpuContext::new(backend)?);
    // Written here, so no rank's peak memory holds the generated volume.
    eprintln!("preparing the mantle {}^3 ...", bench.n);
    bench_volume_file(bench.n)?;
    let dir = tempfile::tempdir().map_err(|e| Error::io("temporary folder", e))?;
    let mut reports = Vec::new();
    for &r in ranks {
        eprintln!("{r} ranks: mpirun --oversubscribe -n {r} ...");
        let report = dir.path().join(format!("ranks-{r}.txt"));
        let mut cmd = std::process::Command::new(&mpirun);
        cmd.arg("--oversubscribe");
        if is_root() {
            cmd.arg("--allow-run-as-root");
        }
        let sides: Vec<String> = bench.sides.iter().map(u32::to_string).collect();
        cmd.args(["-n", &r.to_string()])
            .arg(&exe)
            .arg(format!("--backend={}", backend.name()))
            .args(["bench", "distributed", "--runs", &bench.runs.to_string()])
            .args([
                "--n",
                &bench.n.to_string(),
                "--size",
                &bench.size.to_string(),
            ])
            .args(["--sides", &sides.join(","), "--report"])
            .arg(&report)
            .stdout(std::process::Stdio::null());
        let status = cmd.status().map_err(|e| Error::io(&mpirun, e))?;
        let text = std::fs::read_to_string(&report).unwrap_or_default();
        if !status.success() || text.is_empty() {
            return Err(Error::invalid(
                "bench distributed",
                format!("mpirun -n {r} failed ({status}); its ranks' errors are above"),
            ));
        }
        reports.push(parse_world_report(
            &text,
            &format!("the report of {r} ranks"),
        )?);
    }
    print!("{}", format_scaling_table(&machine, &reports));
    Ok(())
}

/// Whether this process runs as root, whom mpirun refuses without `--allow-run-as-root`: the
/// owner of /proc/self is the process's effective user.
#[cfg(feature = "mpi")]
fn is_root() -> bool {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").is_ok_and(|m| m.uid() == 0)
}

/// Runs `hdrvis run` as a rank when an MPI launcher started several; `Ok(false)` when this is
/// an ordinary single-process run.
#[cfg(not(feature = "mpi"))]
fn run_if_launched(_args: &RunArgs, _backend: BackendChoice) -> Result<bool> {
    match launched() {
        Some((rank, n)) if n > 1 => {
            // Every rank would otherwise render the whole script and write the same files.
            if rank != 0 {
                std::process::exit(1);
            }
            Err(Error::invalid(
                "mpi",
                format!(
                    "started as {n} MPI ranks, but this hdrvis was built without MPI; build it with `cargo build --release --features mpi` or run one process"
                ),
            ))
        }
        _ => Ok(false),
    }
}

#[cfg(feature = "mpi")]
fn run_if_launched(args: &RunArgs, backend: BackendChoice) -> Result<bool> {
    use hdrvis::render::distributed::mpi::MpiExchange;
    use hdrvis::render::distributed::Exchange;
    use std::sync::Arc;
    if launched().is_none() {
        return Ok(false);
    }
    let world = Arc::new(MpiExchange::init()?);
    if world.size() < 2 {
        return Ok(false);
    }
    if let Err(e) = run_rank(args, backend, world.clone()) {
        if world.rank() != 0 {
            // An error every rank meets (a script error) is printed by rank 0, whose abort
            // ends this rank first; one only this rank meets is printed here after the pause.
            std::thread::sleep(std::time::Duration::from_secs(2));
        }
        eprintln!("error: {e}");
        world.abort(1);
    }
    Ok(true)
}

/// The script run of one rank; rank 0 prints what the run wrote and, with `--stats`, its
/// passes and every rank's peak memory.
#[cfg(feature = "mpi")]
fn run_rank(
    args: &RunArgs,
    backend: BackendChoice,
    world: std::sync::Arc<hdrvis::render::distributed::mpi::MpiExchange>,
) -> Result<()> {
    use hdrvis::render::distributed::Exchange;
    use hdrvis::render::session::RenderSession;
    use std::sync::{Arc, Mutex};
    let root = world.rank() == 0;
    let mut opts = super::run::script_options(args, backend, Some(world.as_ref()))?;
    let session = RenderSession::new(backend, opts.cache_mib << 20).with_cluster(world.clone());
    opts.session = Some(Arc::new(session));
    if root {
        opts.on_written = Some(super::run::print_as_written(Arc::new(Mutex::new(
            Vec::new(),
        ))));
    } else {
        opts.write_outputs = false;
        opts.capture_prints = true;
        opts.progress = false;
    }
    let report = hdrvis::script::run_script_file(&args.script, &opts)?;
    if args.stats {
        let peaks = gather_peaks(world.as_ref())?;
        if root {
            for r in &report.passes {
                println!("{r}");
            }
            for (rank, peak) in peaks.iter().enumerate() {
                println!(
                    "rank {rank} of {}: peak memory {} (VmHWM)",
                    peaks.len(),
                    super::run::mib(*peak)
                );
            }
        }
    }
    Ok(())
}

/// Every rank's peak resident memory, gathered on rank 0 (empty on the others).
#[cfg(feature = "mpi")]
fn gather_peaks(world: &dyn hdrvis::render::distributed::Exchange) -> Result<Vec<u64>> {
    use hdrvis::render::distributed::{exchange::gather_u64, peak_memory_bytes};
    gather_u64(world, peak_memory_bytes().unwrap_or(0))
}
