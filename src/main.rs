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
    quiet_wayland_probe();
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
            opts.resume = args.resume;
            if let Some(m) = args.gpu_memory.filter(|m| !(m.is_finite() && *m > 0.0)) {
                return Err(Error::invalid(
                    "--gpu-memory",
                    format!("expected MiB > 0, got {m}"),
                ));
            }
            opts.gpu_memory_mib = args.gpu_memory;
            opts.progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
            opts.cache_mib = hdrvis::render::cache::budget_mib(args.cache_mib)?;
            opts.capture_previews = args.preview;
            let protocol =
                hdrvis::tui::protocol::ProtocolChoice::resolve(args.protocol.as_deref())?;
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
                for (i, img) in images.iter().enumerate() {
                    let title = format!("{} image {}", args.script.display(), i + 1);
                    if !hdrvis::tui::preview::print_inline(img, &title, protocol, 60)? {
                        eprintln!("--preview: stdout is not a terminal; no inline images");
                        break;
                    }
                }
            }
            Ok(())
        }
        Some(Command::Tui(args)) => {
            let opts = hdrvis::tui::TuiOptions {
                input: args.input.clone(),
                out_dir: args.out.clone(),
                sets: parse_sets(&args.sets)?,
                allowed_paths: args.allow_paths.clone(),
                backend,
                protocol: hdrvis::tui::protocol::ProtocolChoice::resolve(args.protocol.as_deref())?,
                cache_mib: hdrvis::render::cache::budget_mib(None)?,
            };
            hdrvis::tui::run_tui(&opts)
        }
        Some(Command::Bench(BenchCommand::Tui { runs, n })) => {
            let (adapter, rows) =
                hdrvis::bench::tui::bench_tui(backend, n, runs, &mut |m| eprintln!("{m}"))?;
            print!("{}", hdrvis::bench::tui::format_tui_table(&adapter, &rows));
            Ok(())
        }
        Some(Command::Gen(cmd)) => {
            cli::datasets::run_gen(&cmd).map(|p| println!("{}", p.display()))
        }
        Some(Command::Info(args)) => cli::datasets::run_info(&args).map(|r| print!("{r}")),
        Some(Command::Api) => {
            print!("{}", hdrvis::script::api_reference());
            Ok(())
        }
        Some(Command::Tonemap(args)) => cli::tonemap::run_tonemap(&args, backend),
        Some(Command::Bench(BenchCommand::Tonemap { runs, quick })) => {
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let sizes: &[u32] = if quick { &[1024] } else { &[1024, 2048, 4096] };
            let rows =
                hdrvis::bench::tonemap::bench_tonemap(ctx, sizes, runs, &mut |m| eprintln!("{m}"))?;
            print!(
                "{}",
                hdrvis::bench::tonemap::format_tonemap_table(&adapter, &rows)
            );
            Ok(())
        }
        Some(Command::Doctor) => {
            let ctx = GpuContext::new(backend)?;
            println!("{}", ctx.report());
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Accuracy {
            runs,
            size,
            n,
            grid,
            out,
            scene,
        })) => {
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            use hdrvis::bench::accuracy;
            let scenes = accuracy::accuracy_scenes(size, n, grid, scene.as_deref())?;
            let rows = accuracy::bench_accuracy(ctx, &scenes, runs, &mut |m| eprintln!("{m}"))?;
            print!("{}", accuracy::format_accuracy_table(&adapter, &rows));
            let (csv, json) = accuracy::write_accuracy_files(&out, &rows)?;
            let chart = accuracy::write_accuracy_chart(&out, &adapter, &rows)?;
            println!(
                "wrote {}, {} and {}",
                csv.display(),
                json.display(),
                chart.display()
            );
            if std::io::IsTerminal::is_terminal(&std::io::stdout()) {
                let config = viuer::Config {
                    absolute_offset: false,
                    width: Some(80),
                    ..Default::default()
                };
                // A terminal that cannot show images still has the file.
                if let Ok(img) = image::open(&chart) {
                    let _ = viuer::print(&img, &config);
                }
            }
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Bricks {
            runs,
            n,
            size,
            brick,
        })) => {
            use hdrvis::bench::bricks::{bench_skipping, format_skipping_table};
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let rows = bench_skipping(ctx, n, size, brick, runs, &mut |m| eprintln!("{m}"))?;
            print!("{}", format_skipping_table(&adapter, n, size, &rows));
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Large {
            runs,
            n,
            size,
            gpu_memory,
            brick,
        })) => {
            use hdrvis::bench::bricks::{bench_large, format_large_report};
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let report = bench_large(ctx, n, size, gpu_memory, brick, runs, &mut |m| {
                eprintln!("{m}")
            })?;
            print!("{}", format_large_report(&adapter, &report));
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Datasets { runs, quick })) => {
            let rows = hdrvis::bench::bench_generators(runs, quick, &mut |m| eprintln!("{m}"))?;
            print!("{}", hdrvis::bench::format_generator_table(&rows));
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Effects { runs, n, size })) => {
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let rows = hdrvis::bench::effects::bench_effects(ctx, n, size, runs, &mut |m| {
                eprintln!("{m}")
            })?;
            print!(
                "{}",
                hdrvis::bench::effects::format_effects_table(&adapter, n, size, &rows)
            );
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Surface { runs, n })) => {
            let ctx = GpuContext::new(backend)?;
            let adapter = ctx.describe();
            let rows =
                hdrvis::bench::surface::bench_surface(ctx, n, runs, &mut |m| eprintln!("{m}"))?;
            print!(
                "{}",
                hdrvis::bench::surface::format_surface_table(&adapter, &rows)
            );
            Ok(())
        }
        Some(Command::Bench(BenchCommand::Volume {
            runs,
            quick,
            peer,
            breakdown,
        })) => {
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
                breakdown,
                &mut |m| eprintln!("{m}"),
            )?;
            print!("{}", hdrvis::bench::format_volume_table(&adapter, &rows));
            print!("{}", hdrvis::bench::format_breakdown_table(&rows));
            Ok(())
        }
    }
}

/// The Vulkan loader's Wayland probe prints "XDG_RUNTIME_DIR is invalid or not set" on headless
/// nodes, where no Wayland session exists; pointing it at the temp folder makes the probe fail
/// quietly. Runs before any thread starts, and only when no Wayland session is configured.
fn quiet_wayland_probe() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
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
