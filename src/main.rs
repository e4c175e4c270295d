//! The `hdrvis` binary: parse arguments, call the library, print errors as one line and exit
//! non-zero. With no command it runs the built-in demo.

mod cli;

use clap::Parser;
use cli::{BenchCommand, Cli, Command};
use hdrvis::gpu::{BackendChoice, GpuContext};
use hdrvis::script::{run_script_file, run_script_source, ScriptOptions};
use hdrvis::{Error, Result};
use std::path::{Path, PathBuf};

const DEMO_SCRIPT: &str = include_str!("../scripts/demo.rhai");

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    let backend = BackendChoice::resolve(cli.backend.as_deref())?;
    match cli.command {
        None => demo(Path::new("out/demo"), backend),
        Some(Command::Demo { out }) => demo(&out, backend),
        Some(Command::Run(args)) => {
            let mut opts = ScriptOptions::new(&args.out);
            opts.backend = backend;
            opts.allowed_paths = args.allow_paths.clone();
            opts.sets = parse_sets(&args.sets)?;
            let report = run_script_file(&args.script, &opts)?;
            for p in report.written {
                println!("wrote {}", p.display());
            }
            Ok(())
        }
        Some(Command::Gen(cmd)) => {
            cli::datasets::run_gen(&cmd).map(|p| println!("{}", p.display()))
        }
        Some(Command::Info(args)) => cli::datasets::run_info(&args).map(|r| print!("{r}")),
        Some(Command::Doctor) => {
            let ctx = GpuContext::new(backend)?;
            println!("{}", ctx.report());
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Surface { runs, n })) => {
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let rows = hdrvis::render::surface_bench::bench_surface(ctx, n, runs, &mut |m| {
                eprintln!("{m}")
            })?;
            print!(
                "{}",
                hdrvis::render::surface_bench::format_surface_table(&adapter, &rows)
            );
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Volume { runs, quick, peer })) => {
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let peer_script = match peer.as_deref() {
                None => None,
                Some("vtk") => Some(hdrvis::bench::vtk_peer_script()?),
                Some(other) => {
                    return Err(Error::invalid(
                        "--peer",
                        format!("unknown peer {other:?}; known: vtk"),
                    ))
                }
            };
            let sizes: &[(usize, u32)] = if quick {
                &[(256, 512)]
            } else {
                &[(256, 512), (513, 1024)]
            };
            let rows = hdrvis::bench::bench_volume_render(
                ctx,
                sizes,
                runs,
                peer_script.as_deref(),
                &mut |m| eprintln!("{m}"),
            )?;
            print!("{}", hdrvis::bench::format_volume_table(&adapter, &rows));
            Ok(())
        }
    }
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
fn demo(out: &Path, backend: BackendChoice) -> Result<()> {
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
