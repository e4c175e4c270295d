//! `hdrvis bench …`: each subcommand is one benchmark of `hdrvis::bench`, its progress on stderr
//! and its table on stdout (the accuracy benchmark also writes its files and, on a terminal,
//! shows its chart inline).

use super::{BenchCommand, SkippingViewArg};
use hdrvis::bench::{
    accuracy, bricks, datasets, effects, mesh_volume, meshes, skipping, spherical, surface,
    tonemap, tui, volume,
};
use hdrvis::gpu::{BackendChoice, GpuContext};
use hdrvis::{Error, Result};
use std::path::Path;
use std::sync::Arc;

impl From<SkippingViewArg> for skipping::SkippingView {
    fn from(view: SkippingViewArg) -> Self {
        match view {
            SkippingViewArg::Orbit => skipping::SkippingView::Orbit,
            SkippingViewArg::Axis => skipping::SkippingView::Axis,
        }
    }
}

/// Runs the benchmark `cmd` names and prints its report.
pub fn run_bench(cmd: BenchCommand, backend: BackendChoice) -> Result<()> {
    match cmd {
        cmd @ BenchCommand::Volume { .. } => bench_volume(backend, cmd),
        BenchCommand::Accuracy {
            runs,
            size,
            n,
            grid,
            out,
            scene,
            quick,
        } => bench_accuracy(
            backend,
            runs,
            (size, n, grid),
            &out,
            scene.as_deref(),
            &accuracy::shell_boxes(quick),
        ),
        BenchCommand::Spherical { runs, n, size } => {
            let (ctx, adapter) = gpu(backend)?;
            let rows = spherical::bench_spherical(ctx, n, size, runs, &mut progress)?;
            print!(
                "{}",
                spherical::format_spherical_table(&adapter, n, size, &rows)
            );
            Ok(())
        }
        BenchCommand::Bricks {
            runs,
            n,
            size,
            brick,
        } => {
            let (ctx, adapter) = gpu(backend)?;
            let rows = bricks::bench_skipping(ctx, n, size, brick, runs, &mut progress)?;
            print!(
                "{}",
                bricks::format_skipping_table(&adapter, n, size, &rows)
            );
            Ok(())
        }
        BenchCommand::Skipping { runs, quick, view } => {
            let view = view.into();
            let (ctx, adapter) = gpu(backend)?;
            let rows = skipping::bench_skipping(ctx, runs, quick, view, &mut progress)?;
            print!("{}", skipping::format_skipping_table(&adapter, view, &rows));
            Ok(())
        }
        BenchCommand::Large {
            runs,
            n,
            size,
            gpu_memory,
            brick,
        } => {
            let (ctx, adapter) = gpu(backend)?;
            let report = bricks::bench_large(ctx, n, size, gpu_memory, brick, runs, &mut progress)?;
            print!("{}", bricks::format_large_report(&adapter, &report));
            Ok(())
        }
        BenchCommand::Datasets { runs, quick } => {
            let rows = datasets::bench_generators(runs, quick, &mut progress)?;
            print!("{}", datasets::format_generator_table(&rows));
            let rows = datasets::bench_checksum(runs.max(3), quick, &mut progress)?;
            print!("\n{}", datasets::format_checksum_table(&rows));
            Ok(())
        }
        cmd @ BenchCommand::Tonemap { .. } => bench_tonemap_command(cmd, backend, &mut progress),
        BenchCommand::Tui { runs, n } => {
            let (adapter, rows) = tui::bench_tui(backend, n, runs, &mut progress)?;
            print!("{}", tui::format_tui_table(&adapter, &rows));
            Ok(())
        }
        BenchCommand::Effects { runs, n, size } => {
            let (ctx, adapter) = gpu(backend)?;
            let rows = effects::bench_effects(ctx, n, size, runs, &mut progress)?;
            print!(
                "{}",
                effects::format_effects_table(&adapter, n, size, &rows)
            );
            Ok(())
        }
        cmd @ BenchCommand::Distributed { .. } => bench_distributed(backend, cmd),
        cmd @ BenchCommand::Meshes { .. } => bench_meshes_command(cmd, backend, &mut progress),
        BenchCommand::Surface { runs, n } => {
            let (ctx, adapter) = gpu(backend)?;
            let rows = surface::bench_surface(ctx, n, runs, &mut progress)?;
            print!("{}", surface::format_surface_table(&adapter, &rows));
            Ok(())
        }
    }
}

/// `hdrvis bench meshes`: the levels checked, then each mesh timed (and its peer run).
fn bench_meshes_command(
    cmd: BenchCommand,
    backend: BackendChoice,
    progress: &mut dyn FnMut(&str),
) -> Result<()> {
    let BenchCommand::Meshes {
        runs,
        levels,
        width,
        peer,
        volume,
        resolution,
    } = cmd
    else {
        unreachable!("called for bench meshes only")
    };
    if let Some(&l) = levels.iter().find(|&&l| l > 10) {
        return Err(Error::invalid(
            "levels",
            format!("{l}; expected 0 to 10 (10: 10 485 762 cells)"),
        ));
    }
    let (ctx, adapter) = gpu(backend)?;
    if volume {
        let mut rows = Vec::new();
        for &level in &levels {
            let size = (width, resolution);
            rows.push(mesh_volume::bench_mesh_volume(
                ctx.clone(),
                level,
                size,
                runs,
                progress,
            )?);
        }
        print!(
            "adapter: {adapter}\n{}",
            mesh_volume::format_mesh_volume_table(width, &rows)
        );
        return Ok(());
    }
    let rows = meshes::bench_meshes(ctx, &levels, width, runs, peer.as_deref(), progress)?;
    print!("{}", meshes::format_meshes_table(&adapter, width, &rows));
    Ok(())
}

/// `hdrvis bench tonemap`: the GPU tone mapper on its own, or with `--peer` whole processes.
fn bench_tonemap_command(
    cmd: BenchCommand,
    backend: BackendChoice,
    progress: &mut dyn FnMut(&str),
) -> Result<()> {
    let BenchCommand::Tonemap {
        runs,
        quick,
        peer,
        rounds,
        format,
        mapper,
    } = cmd
    else {
        unreachable!("called for bench tonemap only")
    };
    match peer {
        Some(peer) => {
            let how = (format.as_str(), mapper.as_str());
            bench_tonemap_peer((&peer, backend), quick, rounds.max(1), how, progress)
        }
        None => {
            let (ctx, adapter) = gpu(backend)?;
            let rows = tonemap::bench_tonemap(ctx, tonemap::sizes(quick), runs, progress)?;
            print!("{}", tonemap::format_tonemap_table(&adapter, &rows));
            Ok(())
        }
    }
}

/// `hdrvis bench tonemap --peer pfstools`: this binary as a whole process against pfstools,
/// with the `--backend` this run was given.
fn bench_tonemap_peer(
    (peer, backend): (&str, BackendChoice),
    quick: bool,
    rounds: usize,
    (format, mapper): (&str, &str),
    progress: &mut dyn FnMut(&str),
) -> Result<()> {
    use hdrvis::bench::tonemap_peer;
    super::tonemap::mapper_flag(mapper)?;
    if peer != "pfstools" {
        return Err(Error::invalid(
            "--peer",
            format!("unknown peer {peer:?}; known: pfstools"),
        ));
    }
    let hdrvis = std::env::current_exe().map_err(|e| Error::io("hdrvis", e))?;
    let setup = tonemap_peer::PeerToneMapSetup {
        hdrvis: &hdrvis,
        backend: backend.name(),
        format,
        mapper,
        rounds,
    };
    let sizes: &[u32] = if quick { &[1024] } else { &[1024, 4096] };
    let rows = tonemap_peer::bench_tonemap_peer(&setup, sizes, progress)?;
    print!("{}", tonemap_peer::format_tonemap_peer_table(&setup, &rows));
    Ok(())
}

/// `hdrvis bench distributed`, its lists as typed.
fn bench_distributed(backend: BackendChoice, cmd: BenchCommand) -> Result<()> {
    let BenchCommand::Distributed {
        runs,
        n,
        size,
        ranks,
        sides,
        report,
    } = cmd
    else {
        unreachable!("run_bench hands over bench distributed only")
    };
    let bench = hdrvis::bench::distributed::DistributedBench {
        n,
        size,
        runs,
        sides: whole_numbers("--sides", &sides)?,
    };
    let ranks = whole_numbers("--ranks", &ranks)?;
    super::cluster::bench_distributed(backend, &bench, &ranks, report.as_deref())
}

/// A comma-separated list of whole numbers >= 1, as `--ranks` and `--sides` take them.
fn whole_numbers<T: std::str::FromStr + From<u8> + PartialOrd>(
    flag: &str,
    text: &str,
) -> Result<Vec<T>> {
    text.split(',')
        .map(|t| match t.trim().parse::<T>() {
            Ok(v) if v >= T::from(1) => Ok(v),
            _ => Err(hdrvis::Error::invalid(
                flag,
                format!("expected whole numbers >= 1 separated by commas, got {text:?}"),
            )),
        })
        .collect()
}

/// A benchmark's progress line, on stderr.
fn progress(message: &str) {
    eprintln!("{message}");
}

/// The GPU context of `backend` and the description of its adapter that heads every table.
fn gpu(backend: BackendChoice) -> Result<(Arc<GpuContext>, String)> {
    let ctx = GpuContext::new(backend)?;
    let adapter = ctx.describe();
    Ok((ctx, adapter))
}

/// `hdrvis bench volume` (`cmd` is its [`BenchCommand::Volume`]).
fn bench_volume(backend: BackendChoice, cmd: BenchCommand) -> Result<()> {
    let BenchCommand::Volume {
        runs,
        quick,
        scenes,
        peer,
        rounds,
        breakdown,
    } = cmd
    else {
        unreachable!("run_bench passes bench volume's command")
    };
    let (runs, peer) = ((runs, rounds), peer.as_deref());
    let scenes = volume::volume_scenes(quick, &scenes)?;
    let (ctx, adapter) = gpu(backend)?;
    let peer_script = volume::peer_script(peer)?;
    let rows = volume::bench_volume_render(
        ctx,
        &scenes,
        runs,
        peer_script.as_deref(),
        breakdown,
        &mut progress,
    )?;
    print!("{}", volume::format_volume_table(&adapter, &rows));
    print!("{}", volume::format_breakdown_table(&rows));
    let compared: Vec<_> = rows
        .iter()
        .filter_map(|r| Some((r.name.clone(), r.equal_error.as_ref()?)))
        .collect();
    print!(
        "{}",
        hdrvis::bench::equal_error::format_equal_error(&compared)
    );
    Ok(())
}

/// `(size, n, grid)`: image side, volume side and surface grid side of the scenes.
fn bench_accuracy(
    backend: BackendChoice,
    runs: usize,
    (size, n, grid): (u32, usize, usize),
    out: &Path,
    scene: Option<&str>,
    boxes: &[usize],
) -> Result<()> {
    let (ctx, adapter) = gpu(backend)?;
    let scenes = accuracy::accuracy_scenes(size, n, grid, scene, boxes)?;
    let rows = accuracy::bench_accuracy(ctx, &scenes, runs, &mut progress)?;
    print!("{}", accuracy::format_accuracy_table(&adapter, &rows));
    let (csv, json) = accuracy::write_accuracy_files(out, &rows)?;
    let chart = accuracy::write_accuracy_chart(out, &adapter, &rows)?;
    println!(
        "wrote {}, {} and {}",
        csv.display(),
        json.display(),
        chart.display()
    );
    // A terminal that cannot show images still has the file.
    let _ = hdrvis::io::terminal::print_file_inline(
        &chart,
        hdrvis::io::terminal::ProtocolChoice::Auto,
        80,
        "accuracy chart",
    );
    Ok(())
}
