//! The `hdrvis` binary: parse arguments, call the library, print errors as one line and exit
//! non-zero. With no command it runs the built-in demo. Each command's handling is in [`cli`].

mod cli;

use cli::{Cli, Command};
use hdrvis::gpu::{BackendChoice, GpuContext};
use hdrvis::Result;
use std::path::Path;

fn main() {
    quiet_wayland_probe();
    let cli = cli::parse();
    let result = run(cli);
    // Entries made for this run only, when the cache folder could not take them.
    hdrvis::datasets::cache::remove_private_dir();
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// Hands the command to its handler.
fn run(cli: Cli) -> Result<()> {
    let backend = BackendChoice::resolve(cli.backend.as_deref())?;
    match cli.command {
        None => cli::run::run_demo(Path::new("out/demo"), backend),
        Some(Command::Demo { out }) => cli::run::run_demo(&out, backend),
        Some(Command::Run(args)) => cli::cluster::run_script(&args, backend),
        Some(Command::Tui(args)) => cli::run::run_tui(&args, backend),
        Some(Command::Bench(cmd)) => cli::bench::run_bench(cmd, backend),
        Some(Command::Gen(cmd)) => {
            cli::datasets::run_gen(&cmd).map(|p| println!("{}", p.display()))
        }
        Some(Command::Info(args)) => cli::datasets::run_info(&args).map(|r| print!("{r}")),
        Some(Command::Api) => {
            print!("{}", hdrvis::script::api_reference());
            Ok(())
        }
        Some(Command::Tonemap(args)) => cli::tonemap::run_tonemap(&args, backend),
        Some(Command::Doctor) => {
            println!("{}", cli::cache::cache_line());
            GpuContext::new(backend).map(|ctx| println!("{}", ctx.report()))
        }
        Some(Command::Animate(args)) => cli::animate::run_animate(&args)
            .map(|n| println!("wrote {} ({n} frames)", args.output.display())),
        Some(Command::Slurm(args)) => cli::slurm::run_slurm(&args),
        Some(Command::SweepStatus(args)) => cli::slurm::run_sweep_status(&args, backend),
        Some(Command::Cache(cmd)) => {
            let (report, passed) = cli::cache::run_cache(&cmd)?;
            print!("{report}");
            if !passed {
                hdrvis::datasets::cache::remove_private_dir();
                std::process::exit(1);
            }
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
