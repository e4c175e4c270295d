//! The dataset generator benchmark (`hdrvis bench datasets`): each generator timed end to end,
//! NetCDF output included, with the process's peak memory after it; and what checking a cache
//! entry costs (its checksum, read in full) beside reading it.

use super::{median, peak_memory_mib};
use crate::datasets::generate::Job;
use crate::error::{Error, Result};

/// One generator timing: name, median seconds of the runs, and the process's peak memory after it.
#[derive(Clone, Debug)]
pub struct GeneratorTiming {
    pub name: String,
    pub runs_s: Vec<f64>,
    pub peak_mib: Option<f64>,
}

/// Times the dataset generators at the sizes, each writing its NetCDF output to a
/// temporary folder: Okada on a 1001² grid (the paper's case II), the 513³ mantle (temperature
/// only), and the linear tsunami on 1000² cells for two simulated hours. Run in that order
/// because peak memory is a high-water mark.
pub fn bench_generators(
    runs: usize,
    quick: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<GeneratorTiming>> {
    let dir = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let jobs = generator_jobs(quick);
    let mut out = Vec::new();
    for (name, job) in jobs {
        let mut runs_s = Vec::new();
        for r in 0..runs.max(1) {
            let path = dir.path().join(format!("{}-{r}.nc", job.kind()));
            let start = std::time::Instant::now();
            job.run(&path, &mut |_| Ok(()))?;
            runs_s.push(start.elapsed().as_secs_f64());
            let _ = std::fs::remove_file(&path);
        }
        log(&format!("{name}: median {:.2} s", median(&runs_s)));
        out.push(GeneratorTiming {
            name,
            runs_s,
            peak_mib: peak_memory_mib(),
        });
    }
    Ok(out)
}

/// The generator jobs with their names, at the sizes or, with `quick`, small ones.
fn generator_jobs(quick: bool) -> [(String, Job); 3] {
    use crate::datasets::generate::{MantleJob, OkadaJob, TsunamiJob};
    use crate::datasets::mantle::{MantleField, MantleFields, MantleOptions};
    let mut tsunami = TsunamiJob::default();
    tsunami.options.duration_s = 7200.0;
    let mut mantle = MantleOptions {
        fields: MantleFields::only(MantleField::Temperature),
        ..Default::default()
    };
    let mut okada = OkadaJob::default();
    if quick {
        okada.n = 201;
        mantle.n = 129;
        tsunami.bathymetry = crate::datasets::generate::BathymetrySource::Synthetic {
            n: 250,
            extent_m: crate::datasets::tsunami::SOUTH_CHINA_SEA_EXTENT_M,
        };
    }
    [
        (
            format!("okada {0}x{0} (paper case II)", okada.n),
            Job::Okada(okada),
        ),
        (
            format!("mantle {0}^3 temperature", mantle.n),
            Job::Mantle(MantleJob {
                options: mantle,
                native: false,
            }),
        ),
        (
            "tsunami synthetic basin, 2 h".to_string(),
            Job::Tsunami(tsunami),
        ),
    ]
}

/// The table `hdrvis bench datasets` prints.
pub fn format_generator_table(rows: &[GeneratorTiming]) -> String {
    let mut s = format!(
        "dataset generators (NetCDF output included), {} threads\n",
        rayon::current_num_threads()
    );
    s.push_str(&format!(
        "{:<34} {:>10} {:>6} {:>16}\n",
        "generator", "median s", "runs", "peak memory MiB"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<34} {:>10.2} {:>6} {:>16}\n",
            r.name,
            median(&r.runs_s),
            r.runs_s.len(),
            r.peak_mib
                .map(|m| format!("{m:.0}"))
                .unwrap_or_else(|| "?".into())
        ));
    }
    s
}

/// What checking a cache entry of `n`³ f32 values costs: the median seconds of its checksum
/// (the file read in full and hashed, as on every first use in a process) and of reading the
/// same file into memory, which any reader of the entry pays anyway.
#[derive(Clone, Debug)]
pub struct ChecksumTiming {
    pub n: usize,
    pub bytes: u64,
    pub checksum_s: Vec<f64>,
    pub read_s: Vec<f64>,
}

/// Times the cache check on files of 256³ and 512³ f32 values (64³ and 128³ with `quick`), the
/// page cache warm (a file just made or just read, as a run finds its entry most often).
pub fn bench_checksum(
    runs: usize,
    quick: bool,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<ChecksumTiming>> {
    use crate::io::checked::Sum;
    let dir = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let sizes: &[usize] = if quick { &[64, 128] } else { &[256, 512] };
    let mut out = Vec::new();
    for &n in sizes {
        let path = dir.path().join(format!("entry-{n}.bin"));
        let values: Vec<f32> = (0..n * n * n).map(|i| (i as f32 * 0.618).sin()).collect();
        std::fs::write(&path, bytemuck::cast_slice(&values)).map_err(|e| Error::io(&path, e))?;
        drop(values);
        let bytes = std::fs::metadata(&path)
            .map_err(|e| Error::io(&path, e))?
            .len();
        let (mut checksum_s, mut read_s) = (Vec::new(), Vec::new());
        for _ in 0..runs.max(1) {
            let start = std::time::Instant::now();
            std::hint::black_box(Sum::of_file(&path)?);
            checksum_s.push(start.elapsed().as_secs_f64());
            let start = std::time::Instant::now();
            std::hint::black_box(std::fs::read(&path).map_err(|e| Error::io(&path, e))?);
            read_s.push(start.elapsed().as_secs_f64());
        }
        log(&format!(
            "checksum {n}^3: median {:.3} s",
            median(&checksum_s)
        ));
        let _ = std::fs::remove_file(&path);
        out.push(ChecksumTiming {
            n,
            bytes,
            checksum_s,
            read_s,
        });
    }
    Ok(out)
}

/// The checksum table `hdrvis bench datasets` prints after the generators.
pub fn format_checksum_table(rows: &[ChecksumTiming]) -> String {
    let mut s = String::from(
        "cache entry check (length + xxh3 of every byte, page cache warm), one thread\n",
    );
    s.push_str(&format!(
        "{:<14} {:>10} {:>12} {:>10} {:>12} {:>14}\n",
        "entry", "MiB", "checksum s", "GiB/s", "plain read s", "check / read"
    ));
    for r in rows {
        let (check, read) = (median(&r.checksum_s), median(&r.read_s));
        s.push_str(&format!(
            "{:<14} {:>10.0} {:>12.3} {:>10.2} {:>12.3} {:>14.2}\n",
            format!("{}^3 f32", r.n),
            r.bytes as f64 / (1u64 << 20) as f64,
            check,
            r.bytes as f64 / check / (1u64 << 30) as f64,
            read,
            check / read
        ));
    }
    s
}
