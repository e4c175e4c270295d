//! `hdrvis run` as one rank of an MPI launch (`mpirun -n N`, `srun --mpi=…`): every rank runs
//! the script with a session split over the ranks, so each `render_volume` renders one slab per
//! rank and composites onto rank 0; only rank 0 writes files and prints. An error on any rank
//! is printed once and ends every rank (MPI_Abort), so no rank hangs waiting for it.

use super::RunArgs;
use hdrvis::gpu::BackendChoice;
use hdrvis::{Error, Result};

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
    let mut opts = super::run::script_options(args, backend)?;
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
    use hdrvis::render::distributed::peak_memory_bytes;
    let mine = peak_memory_bytes().unwrap_or(0);
    if world.rank() != 0 {
        world.send(0, &mine.to_le_bytes())?;
        return Ok(Vec::new());
    }
    let mut peaks = vec![mine];
    for from in 1..world.size() {
        let msg = world.recv(from)?;
        let bytes: [u8; 8] = msg
            .as_slice()
            .try_into()
            .map_err(|_| Error::invalid("mpi", format!("rank {from} sent no peak memory")))?;
        peaks.push(u64::from_le_bytes(bytes));
    }
    Ok(peaks)
}
