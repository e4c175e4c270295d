//! `hdrvis bench distributed`: strong scaling of a distributed render over the ranks of one
//! world (MPI ranks with `--features mpi`, or threads joined by channels in the tests). Every
//! rank runs [`bench_world`] in step, since each render and each compositing is a collective
//! call: the mantle's fluctuation (a `.npy` read in place, so each rank reads only its slab)
//! rendered along z, then the compositing schemes alone on synthetic partial images of several
//! sizes, then a ping-pong between ranks 0 and 1 that measures the transport's latency and
//! bandwidth for the cost model of docs/performance.md. Rank 0 gets the [`WorldReport`]; the
//! reports of several worlds (1, 2, 4 ranks) make the scaling table.

use super::{mantle_fig5_tf, mantle_fluctuation, median, peak_memory_mib, timing_session};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Axis, Camera, TransferFunction};
use crate::render::distributed::composite::{composite, Partial, Scheme};
use crate::render::distributed::exchange::{barrier, gather_u64, Exchange};
use crate::render::{VolumeRenderOptions, VolumeSource};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// What one world measures: the mantle `n`³ rendered at `size`², compositing at each of
/// `sides`², `runs` timed runs each after one warm-up.
#[derive(Clone, Debug)]
pub struct DistributedBench {
    pub n: usize,
    pub size: u32,
    pub runs: usize,
    pub sides: Vec<u32>,
}

/// One compositing case: scheme, image side, ms of each run on rank 0.
#[derive(Clone, Debug, PartialEq)]
pub struct CompositeRow {
    pub scheme: Scheme,
    pub side: u32,
    pub ms: Vec<f64>,
}

/// The measurements of one world, on rank 0.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldReport {
    pub ranks: usize,
    pub transport: String,
    pub n: usize,
    pub size: u32,
    /// Wall-clock ms of each timed render on rank 0 (slab ray cast, compositing, hand-out).
    pub render_ms: Vec<f64>,
    /// Each rank's peak resident memory (VmHWM) after the renders, MiB.
    pub peak_mib: Vec<f64>,
    pub composite: Vec<CompositeRow>,
    /// One-way latency (s) and bandwidth (bytes/s) between ranks 0 and 1; `None` on one rank.
    pub link: Option<(f64, f64)>,
}

/// The benchmark volume: the mantle's fluctuation `n`³ as `.npy`, an entry of the dataset cache
/// (made once under its lock, checked when used).
pub fn bench_volume_file(n: usize) -> Result<PathBuf> {
    crate::datasets::cache::cached("bench-distributed-mantle", &n.to_string(), "npy", |tmp| {
        let v = mantle_fluctuation(n, 7)?;
        crate::datasets::npy::write_npy_f32(tmp, &v.dims, &v.data)
    })
}

/// Runs the benchmark as one rank of `world`; every rank must call it with the same `bench`.
/// Rank 0 returns the report, the others `None`.
pub fn bench_world(
    ctx: Arc<GpuContext>,
    world: Arc<dyn Exchange>,
    bench: &DistributedBench,
    log: &mut dyn FnMut(&str),
) -> Result<Option<WorldReport>> {
    let (rank, ranks) = (world.rank(), world.size());
    let root = rank == 0;
    // Rank 0 writes the volume when it is missing; the others wait for it.
    if root {
        bench_volume_file(bench.n)?;
    }
    barrier(world.as_ref())?;
    let path = bench_volume_file(bench.n)?;
    let volume = crate::datasets::bricked::open_bricked(&path, None, 32)?;
    let mut opts = VolumeRenderOptions::new(
        Camera::axis(Axis::Z, &volume.bounds()),
        TransferFunction::Lut(mantle_fig5_tf()),
    );
    (opts.width, opts.height, opts.step) = (bench.size, bench.size, 1.0);
    let source = VolumeSource::Bricked(Arc::new(volume));
    let session = timing_session(ctx).with_cluster(world.clone());
    // A fixed count, never a timed warm-up: every rank must make the same collective calls.
    let mut render_ms = Vec::new();
    for run in 0..=bench.runs.max(1) {
        let r = session.render_volume_detailed(&source, &opts)?;
        if run > 0 {
            render_ms.push(r.seconds * 1e3);
        }
    }
    if root {
        log(&format!(
            "{ranks} ranks: render median {:.1} ms",
            median(&render_ms)
        ));
    }
    let peak_kib = (peak_memory_mib().unwrap_or(0.0) * 1024.0) as u64;
    let peak_mib = gather_u64(world.as_ref(), peak_kib)?
        .iter()
        .map(|&k| k as f64 / 1024.0)
        .collect();
    let composite = time_compositing(world.as_ref(), bench)?;
    let link = if ranks > 1 {
        Some(measure_link(world.as_ref())?)
    } else {
        None
    };
    Ok(root.then(|| WorldReport {
        ranks,
        transport: world.transport().to_string(),
        n: bench.n,
        size: bench.size,
        render_ms,
        peak_mib,
        composite,
        link,
    }))
}

/// The schemes a world of `ranks` can composite with: binary-swap needs a power of two.
fn schemes(ranks: usize) -> Vec<Scheme> {
    match ranks {
        1 => Vec::new(),
        n if n.is_power_of_two() => vec![Scheme::BinarySwap, Scheme::DirectSend],
        _ => vec![Scheme::DirectSend],
    }
}

/// Each scheme at each side², synthetic partials (the joins' arithmetic does not depend on
/// the values), every run started together after a barrier and timed on rank 0.
fn time_compositing(world: &dyn Exchange, bench: &DistributedBench) -> Result<Vec<CompositeRow>> {
    let mut rows = Vec::new();
    for &side in &bench.sides {
        let pixels = side as usize * side as usize;
        let level = 0.1 * (world.rank() + 1) as f32;
        let partial: Vec<Partial> = vec![[level, level, level, 0.05]; pixels];
        for scheme in schemes(world.size()) {
            let mut ms = Vec::new();
            for run in 0..=bench.runs.max(1) {
                let mine = partial.clone();
                barrier(world)?;
                let t = Instant::now();
                composite(world, mine, scheme)?;
                if run > 0 {
                    ms.push(t.elapsed().as_secs_f64() * 1e3);
                }
            }
            rows.push(CompositeRow { scheme, side, ms });
        }
    }
    Ok(rows)
}

/// Latency (half the median round trip of one byte) and bandwidth (16 MiB over half its
/// median round trip, latency taken off) between ranks 0 and 1; the other ranks wait.
fn measure_link(world: &dyn Exchange) -> Result<(f64, f64)> {
    let round_trip = |bytes: usize, runs: usize| -> Result<f64> {
        let data = vec![1u8; bytes];
        let mut times = Vec::new();
        for _ in 0..runs {
            let t = Instant::now();
            match world.rank() {
                0 => {
                    world.send(1, &data)?;
                    world.recv(1)?;
                }
                1 => {
                    let got = world.recv(0)?;
                    world.send(0, &got)?;
                }
                _ => {}
            }
            times.push(t.elapsed().as_secs_f64());
        }
        Ok(median(&times))
    };
    barrier(world)?;
    let latency = round_trip(1, 21)? / 2.0;
    let big = 16 << 20;
    let bandwidth = big as f64 / (round_trip(big, 5)? / 2.0 - latency).max(1e-9);
    barrier(world)?;
    Ok((latency, bandwidth))
}

/// The cost model of docs/performance.md for an image of `side`² RGBA f32 pixels over `ranks`:
/// binary-swap α·log₂N + (S/β)(1 − 1/N) and the gather onto rank 0 (N − 1)·α + (S/β)(1 − 1/N),
/// in seconds, for latency `alpha` (s) and bandwidth `beta` (bytes/s).
pub(crate) fn model_seconds(side: u32, ranks: usize, alpha: f64, beta: f64) -> (f64, f64) {
    let bytes = 16.0 * f64::from(side) * f64::from(side);
    let n = ranks as f64;
    let moved = bytes / beta * (1.0 - 1.0 / n);
    (alpha * n.log2() + moved, (n - 1.0) * alpha + moved)
}

/// A world's report as lines `hdrvis bench distributed` reads back from its per-rank-count
/// runs ([`parse_world_report`]).
pub fn format_world_report(r: &WorldReport) -> String {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    let mut s = format!(
        "world {} {} {} {}\nrender {}\npeak {}\n",
        r.ranks,
        r.n,
        r.size,
        r.transport,
        list(&r.render_ms),
        list(&r.peak_mib)
    );
    for c in &r.composite {
        s.push_str(&format!(
            "composite {} {} {}\n",
            c.scheme.name(),
            c.side,
            list(&c.ms)
        ));
    }
    if let Some((alpha, beta)) = r.link {
        s.push_str(&format!("link {alpha} {beta}\n"));
    }
    s
}

/// The report [`format_world_report`] wrote; `what` names its source in errors.
pub fn parse_world_report(text: &str, what: &str) -> Result<WorldReport> {
    let bad = |line: &str| {
        Error::invalid(
            what,
            format!("expected a report of hdrvis bench distributed, got the line {line:?}"),
        )
    };
    let numbers = |line: &str, field: &str| -> Result<Vec<f64>> {
        field
            .split(',')
            .filter(|t| !t.is_empty())
            .map(|t| t.parse::<f64>().map_err(|_| bad(line)))
            .collect()
    };
    let mut report: Option<WorldReport> = None;
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let words: Vec<&str> = line.split_whitespace().collect();
        if let ["world", ranks, n, size, transport] = words[..] {
            report = Some(WorldReport {
                ranks: ranks.parse().map_err(|_| bad(line))?,
                n: n.parse().map_err(|_| bad(line))?,
                size: size.parse().map_err(|_| bad(line))?,
                transport: transport.to_string(),
                render_ms: Vec::new(),
                peak_mib: Vec::new(),
                composite: Vec::new(),
                link: None,
            });
            continue;
        }
        let r = report.as_mut().ok_or_else(|| bad(line))?;
        match words[..] {
            ["render", ms] => r.render_ms = numbers(line, ms)?,
            ["peak", mib] => r.peak_mib = numbers(line, mib)?,
            ["composite", scheme, side, ms] => r.composite.push(CompositeRow {
                scheme: Scheme::parse(scheme)?,
                side: side.parse().map_err(|_| bad(line))?,
                ms: numbers(line, ms)?,
            }),
            ["link", alpha, beta] => {
                r.link = Some((
                    alpha.parse().map_err(|_| bad(line))?,
                    beta.parse().map_err(|_| bad(line))?,
                ));
            }
            _ => return Err(bad(line)),
        }
    }
    report.ok_or_else(|| bad(""))
}

/// The scaling table of several worlds' reports (ascending rank counts): render medians with
/// speed-up and efficiency against the fewest ranks, each rank's peak memory, and compositing
/// medians beside the cost model's prediction from the measured link.
pub fn format_scaling_table(machine: &str, reports: &[WorldReport]) -> String {
    let Some(base) = reports.first() else {
        return String::new();
    };
    let base_ms = median(&base.render_ms);
    let mut s = format!(
        "machine: {machine}\ndistributed benchmark: mantle fluctuation {n}^3 (.npy read in place) -> {size}^2, axis view along the slabs, Fig. 5 TF, median of {runs} runs after one warm-up; rank 0's wall clock\n\n\
         | ranks | render ms | speed-up | efficiency | peak memory per rank (VmHWM, MiB) |\n|---|---|---|---|---|\n",
        n = base.n,
        size = base.size,
        runs = base.render_ms.len(),
    );
    for r in reports {
        let ms = median(&r.render_ms);
        let speedup = base_ms / ms;
        let peaks: Vec<String> = r.peak_mib.iter().map(|p| format!("{p:.0}")).collect();
        s.push_str(&format!(
            "| {} | {ms:.1} | {speedup:.2} | {:.0} % | {} |\n",
            r.ranks,
            100.0 * speedup * base.ranks as f64 / r.ranks as f64,
            peaks.join(", ")
        ));
    }
    s.push_str("\n| image | ranks | scheme | composite ms | model ms (swap + gather) | link (α, β) |\n|---|---|---|---|---|---|\n");
    for r in reports {
        for c in &r.composite {
            let model = r.link.map_or("-".to_string(), |(alpha, beta)| {
                let (swap, gather) = model_seconds(c.side, r.ranks, alpha, beta);
                format!("{:.2} + {:.2}", swap * 1e3, gather * 1e3)
            });
            let link = r.link.map_or("-".to_string(), |(alpha, beta)| {
                format!("{:.1} µs, {:.2} GB/s", alpha * 1e6, beta / 1e9)
            });
            s.push_str(&format!(
                "| {side}² | {} | {} | {:.2} | {model} | {link} |\n",
                r.ranks,
                c.scheme.name(),
                median(&c.ms),
                side = c.side,
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::distributed::ChannelExchange;

    #[test]
    fn the_model_gives_the_published_table_of_performance_md() {
        // 1024² over 64 nodes at 2 µs and 10 GB/s: 1.7 + 1.8 ms; 8192² over 1024: 107.3 + 109.3.
        let (swap, gather) = model_seconds(1024, 64, 2e-6, 10e9);
        assert_eq!(
            (format!("{:.1}", swap * 1e3), format!("{:.1}", gather * 1e3)),
            ("1.7".into(), "1.8".into())
        );
        let (swap, gather) = model_seconds(8192, 1024, 2e-6, 10e9);
        assert_eq!(
            (format!("{:.1}", swap * 1e3), format!("{:.1}", gather * 1e3)),
            ("107.3".into(), "109.3".into())
        );
        // One rank moves nothing.
        assert_eq!(model_seconds(512, 1, 2e-6, 10e9), (0.0, 0.0));
    }

    #[test]
    fn a_report_reads_back_as_written() {
        let r = WorldReport {
            ranks: 4,
            transport: "MPI".into(),
            n: 65,
            size: 128,
            render_ms: vec![12.5, 11.25, 13.0],
            peak_mib: vec![100.5, 90.0, 90.25, 91.0],
            composite: vec![
                CompositeRow {
                    scheme: Scheme::BinarySwap,
                    side: 256,
                    ms: vec![1.5, 1.25],
                },
                CompositeRow {
                    scheme: Scheme::DirectSend,
                    side: 256,
                    ms: vec![2.0, 2.5],
                },
            ],
            link: Some((1.5e-6, 3.25e9)),
        };
        let text = format_world_report(&r);
        assert_eq!(parse_world_report(&text, "report").unwrap(), r);
        let e = parse_world_report("render 1,2\n", "rank log")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("rank log: expected a report"), "{e}");
        assert!(parse_world_report("world 2 65 x MPI\n", "r").is_err());
    }

    #[test]
    fn compositing_is_timed_for_each_scheme_and_side_on_every_rank_in_step() {
        let bench = DistributedBench {
            n: 8,
            size: 8,
            runs: 2,
            sides: vec![4, 8],
        };
        let group = ChannelExchange::group(4);
        let rows: Vec<Vec<CompositeRow>> = std::thread::scope(|scope| {
            let handles: Vec<_> = group
                .iter()
                .map(|ex| scope.spawn(|| time_compositing(ex, &bench).unwrap()))
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for per_rank in &rows {
            let cases: Vec<(Scheme, u32, usize)> = per_rank
                .iter()
                .map(|c| (c.scheme, c.side, c.ms.len()))
                .collect();
            assert_eq!(
                cases,
                [
                    (Scheme::BinarySwap, 4, 2),
                    (Scheme::DirectSend, 4, 2),
                    (Scheme::BinarySwap, 8, 2),
                    (Scheme::DirectSend, 8, 2),
                ]
            );
        }
        assert_eq!(schemes(3), [Scheme::DirectSend]);
        assert!(schemes(1).is_empty());
    }
}
