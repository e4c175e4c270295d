//! `hdrvis run`, `hdrvis demo` (also what `hdrvis` does with no command) and `hdrvis tui`: the
//! commands that run a Rhai script, turning their flags into the library's options and printing
//! what the run wrote.

use super::{RunArgs, TuiArgs};
use hdrvis::gpu::BackendChoice;
use hdrvis::io::terminal::ProtocolChoice;
use hdrvis::model::HdrImage;
use hdrvis::render::cache::budget_mib;
use hdrvis::script::{run_script_file, run_script_source, ScriptOptions};
use hdrvis::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const DEMO_SCRIPT: &str = include_str!("../../scripts/demo.rhai");

/// `hdrvis run SCRIPT.rhai`: runs the script, prints the files it wrote, with `--stats` one
/// line per pass, and with `--preview` its images inline.
pub fn run_script(args: &RunArgs, backend: BackendChoice) -> Result<()> {
    let opts = script_options(args, backend)?;
    let protocol = ProtocolChoice::resolve(args.protocol.as_deref())?;
    let report = run_script_file(&args.script, &opts)?;
    for p in &report.written {
        println!("wrote {}", p.display());
    }
    if args.stats {
        for r in &report.passes {
            println!("{r}");
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

/// The script options `hdrvis run`'s flags ask for.
fn script_options(args: &RunArgs, backend: BackendChoice) -> Result<ScriptOptions> {
    let mut opts = ScriptOptions::new(&args.out);
    opts.backend = backend;
    opts.allowed_paths = args.allow_paths.clone();
    opts.sets = parse_sets(&args.sets)?;
    opts.resume = args.resume;
    if let Some(m) = args.gpu_memory.filter(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(Error::invalid(
            "--gpu-memory",
            format!("expected MiB > 0, got {m}"),
        ));
    }
    opts.gpu_memory_mib = args.gpu_memory;
    opts.timeout = match args.timeout {
        Some(s) if s.is_finite() && s > 0.0 => Some(std::time::Duration::from_secs_f64(s)),
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
        sets: parse_sets(&args.sets)?,
        allowed_paths: args.allow_paths.clone(),
        backend,
        protocol: ProtocolChoice::resolve(args.protocol.as_deref())?,
        cache_mib: budget_mib(None)?,
    };
    hdrvis::tui::run_tui(&opts)
}

fn parse_sets(sets: &[String]) -> Result<Vec<(String, String)>> {
    sets.iter()
        .map(|s| match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
            _ => Err(Error::invalid(
                "--set",
                format!("expected KEY=VALUE, got {s:?}"),
            )),
        })
        .collect()
}

/// The built-in demo: a generated mantle-like volume rendered with an HDR transfer function.
pub fn run_demo(out: &Path, backend: BackendChoice) -> Result<()> {
    let mut opts = ScriptOptions::new(out);
    opts.backend = backend;
    let dir: PathBuf = std::env::current_dir().map_err(|e| Error::io(".", e))?;
    eprintln!(
        "hdrvis demo: rendering a generated mantle volume into {}",
        out.display()
    );
    let report = run_script_source(DEMO_SCRIPT, "scripts/demo.rhai", &dir, &opts)?;
    for p in report.written {
        println!("wrote {}", p.display());
    }
    Ok(())
}
