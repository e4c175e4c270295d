//! `hdrvis run`, `hdrvis demo` (also what `hdrvis` does with no command) and `hdrvis tui`: the
//! commands that run a Rhai script, turning their flags into the library's options and printing
//! what the run wrote.

use super::{RunArgs, TuiArgs};
use hdrvis::gpu::BackendChoice;
use hdrvis::io::terminal::ProtocolChoice;
use hdrvis::model::HdrImage;
use hdrvis::render::cache::budget_mib;
use hdrvis::render::distributed::Exchange;
use hdrvis::script::{run_script_file, run_script_source, ScriptOptions, Shard, WrittenObserver};
use hdrvis::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

const DEMO_SCRIPT: &str = include_str!("../../scripts/demo.rhai");

/// `hdrvis run SCRIPT.rhai`: runs the script, printing each file as it is written, with
/// `--stats` one line per pass, and with `--preview` its images inline. A run stopped by an
/// error or by SIGINT/SIGTERM says so and how many files it wrote.
pub fn run_script(args: &RunArgs, backend: BackendChoice) -> Result<()> {
    let mut opts = script_options(args, backend, None)?;
    let protocol = ProtocolChoice::resolve(args.protocol.as_deref())?;
    let written = Arc::new(Mutex::new(Vec::new()));
    opts.on_written = Some(print_as_written(written.clone()));
    stop_on_signals(written.clone())?;
    let report = run_script_file(&args.script, &opts).map_err(|e| {
        let list = written.lock().expect("written poisoned");
        if list.is_empty() {
            e
        } else {
            Error::Script(format!("{e}\n{}", stop_line("an error", &list)))
        }
    })?;
    if args.stats {
        for r in &report.passes {
            println!("{r}");
        }
        if let Some(peak) = hdrvis::render::distributed::peak_memory_bytes() {
            println!("peak memory {} (VmHWM)", mib(peak));
        }
    }
    if args.preview {
        let images: Vec<_> = if report.previews.is_empty() {
            report.last_image.into_iter().collect()
        } else {
            report.previews
        };
        print_previews(&args.script, &images, protocol)?;
    }
    Ok(())
}

/// Bytes as MiB with one decimal, for the `--stats` memory lines.
pub(super) fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64)
}

/// Prints "wrote PATH" the moment a file is complete and remembers it for [`stop_line`].
pub(super) fn print_as_written(written: Arc<Mutex<Vec<PathBuf>>>) -> WrittenObserver {
    WrittenObserver(Arc::new(move |path: &Path| {
        // The list's lock also orders these lines against the signal handler's summary.
        let mut list = written.lock().expect("written poisoned");
        println!("wrote {}", path.display());
        list.push(path.to_path_buf());
    }))
}

/// `stopped by WHY after writing N files: a, b` (the "wrote" lines above name them too).
fn stop_line(why: &str, written: &[PathBuf]) -> String {
    let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    match names.len() {
        0 => format!("stopped by {why} before writing any file"),
        n => format!(
            "stopped by {why} after writing {n} file{}: {}",
            if n == 1 { "" } else { "s" },
            names.join(", ")
        ),
    }
}

/// On SIGINT or SIGTERM: prints what the run wrote and that it stopped, then dies of the same
/// signal, so the exit status is what it would have been without the handler. Outputs are
/// written atomically, so nothing half-written is left under its final name, and every output
/// under its final name is in the list (see `hdrvis::io::hold_outputs`).
fn stop_on_signals(written: Arc<Mutex<Vec<PathBuf>>>) -> Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
        .map_err(|e| Error::invalid("signals", e.to_string()))?;
    std::thread::Builder::new()
        .name("hdrvis-stop".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
                // No output takes its final name from here on, and one that just did is in
                // the list: the list and the folder agree.
                let _outputs = hdrvis::io::hold_outputs();
                // A panic elsewhere may have poisoned the lock; the list is still whole.
                let list = written.lock().unwrap_or_else(|p| p.into_inner());
                eprintln!("{}", stop_line(name, &list));
                hdrvis::datasets::cache::remove_private_dir();
                let _ = std::io::Write::flush(&mut std::io::stdout());
                let _ = signal_hook::low_level::emulate_default_handler(sig);
                std::process::exit(128 + sig);
            }
        })
        .map_err(|e| Error::invalid("signals", e.to_string()))?;
    Ok(())
}

/// The script options `hdrvis run`'s flags ask for, for a process alone or (`world`) one rank
/// of an MPI world, whose ranks all own the same share of a sweep.
pub(super) fn script_options(
    args: &RunArgs,
    backend: BackendChoice,
    world: Option<&dyn Exchange>,
) -> Result<ScriptOptions> {
    let mut opts = ScriptOptions::new(&args.out);
    opts.backend = backend;
    opts.allowed_paths = args.inputs.allow_paths.clone();
    opts.sets = args.inputs.parsed_sets()?;
    opts.resume = args.resume;
    let ranks = world.map_or(1, |w| w.size());
    let (shard, source) = Shard::resolve(
        args.shard.as_deref(),
        |name| std::env::var(name).ok(),
        ranks,
    )?;
    opts.shard = shard;
    if shard.count > 1 && world.is_none_or(|w| w.rank() == 0) {
        // The task's log says which share it rendered; its "wrote" lines say what that was.
        eprintln!(
            "hdrvis run: task {} of {} ({source}): shard() gives it its share",
            shard.index, shard.count
        );
    }
    if let Some(m) = args.gpu_memory.filter(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(Error::invalid(
            "--gpu-memory",
            format!("expected MiB > 0, got {m}"),
        ));
    }
    opts.gpu_memory_mib = args.gpu_memory;
    opts.timeout = match args.timeout {
        // try_from refuses what a Duration cannot hold (beyond 2^64 s) instead of panicking.
        Some(s) if s > 0.0 => match std::time::Duration::try_from_secs_f64(s) {
            Ok(d) => Some(d),
            Err(_) => {
                return Err(Error::invalid(
                    "--timeout",
                    format!("expected seconds > 0 and below 1.8e19, got {s}"),
                ))
            }
        },
        Some(s) => {
            return Err(Error::invalid(
                "--timeout",
                format!("expected seconds > 0, got {s}"),
            ))
        }
        None => None,
    };
    opts.progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    opts.cache_mib = budget_mib(args.cache_mib)?;
    opts.capture_previews = args.preview;
    Ok(opts)
}

/// `--preview`: each image inline, titled after the script, until stdout proves not to be a
/// terminal.
fn print_previews(script: &Path, images: &[Arc<HdrImage>], protocol: ProtocolChoice) -> Result<()> {
    for (i, img) in images.iter().enumerate() {
        let title = format!("{} image {}", script.display(), i + 1);
        if !hdrvis::io::terminal::print_inline(img, &title, protocol, 60)? {
            eprintln!("--preview: stdout is not a terminal; no inline images");
            break;
        }
    }
    Ok(())
}

/// `hdrvis tui SCRIPT.rhai | IMAGE.exr`.
pub fn run_tui(args: &TuiArgs, backend: BackendChoice) -> Result<()> {
    let opts = hdrvis::tui::TuiOptions {
        input: args.input.clone(),
        out_dir: args.out.clone(),
        sets: args.inputs.parsed_sets()?,
        allowed_paths: args.inputs.allow_paths.clone(),
        backend,
        protocol: ProtocolChoice::resolve(args.protocol.as_deref())?,
        cache_mib: budget_mib(None)?,
    };
    hdrvis::tui::run_tui(&opts)
}

/// The built-in demo: a generated mantle-like volume rendered with an HDR transfer function.
pub fn run_demo(out: &Path, backend: BackendChoice) -> Result<()> {
    let mut opts = ScriptOptions::new(out);
    opts.backend = backend;
    opts.on_written = Some(print_as_written(Arc::new(Mutex::new(Vec::new()))));
    let dir: PathBuf = std::env::current_dir().map_err(|e| Error::io(".", e))?;
    eprintln!(
        "hdrvis demo: rendering a generated mantle volume into {}",
        out.display()
    );
    run_script_source(DEMO_SCRIPT, "scripts/demo.rhai", &dir, &opts).map(|_| ())
}
