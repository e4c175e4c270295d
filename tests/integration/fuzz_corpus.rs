//! The fuzz corpus: every reader (`.npy`, `.npz`, NRRD, NetCDF classic and NetCDF-4, HDF5, `.vti`,
//! legacy `.vtk`, OpenEXR, GeoTIFF, GRIB editions 1 and 2) is fed deterministic mutants of a small valid file
//! (tests/fuzz/seeds/, written by tests/python/write_fuzz_seeds.py): bit flips, truncations,
//! inserted bytes, boundary numbers written over binary fields and over the numbers of text
//! headers. Each read runs in-process under `catch_unwind` and must end in a value or a one-line
//! error, never a panic. The loop runs in a child of the test binary with a 4 GiB address-space
//! limit, which the readers' memory check sees, so a mutant declaring gigabytes must be refused
//! before it is allocated: an abort fails the test. Mutants that once failed are kept in
//! tests/fuzz/regressions/ and replayed first.

use hdrvis::datasets::info::info_report;
use hdrvis::datasets::{load_grid, load_volume_var};
use hdrvis::io::exr::read_exr;
use hdrvis::model::numeric::SplitMix64;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Mutants per seed: about 4 s per seed on a CI runner, under a minute for the corpus.
const MUTANTS_PER_SEED: usize = 5000;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz")
}

/// The dataset to name in a file of this name (HDF5 files have no default one).
fn variable(path: &Path) -> Option<&'static str> {
    (hdrvis::io::extension(path) == "h5").then_some("/v")
}

/// Every way the library reads a file of this kind, each ending in a value or an error; the
/// failures: a panic, or an error message that is empty or more than one line.
fn read_every_way(path: &Path) -> Vec<String> {
    let var = variable(path);
    let ext = hdrvis::io::extension(path);
    type Read<'a> = (&'static str, Box<dyn Fn() -> Option<String> + 'a>);
    let mut reads: Vec<Read> = vec![(
        "info",
        Box::new(|| info_report(path, var).err().map(|e| e.to_string())),
    )];
    match ext.as_str() {
        "exr" => reads.push((
            "read_exr",
            Box::new(|| read_exr(path).err().map(|e| e.to_string())),
        )),
        "tif" | "grib1" | "grib2" => reads.push((
            "load_grid",
            Box::new(|| load_grid(path, None).err().map(|e| e.to_string())),
        )),
        _ => reads.push((
            "load_volume",
            Box::new(|| load_volume_var(path, var).err().map(|e| e.to_string())),
        )),
    }
    let mut failures = Vec::new();
    for (what, read) in reads {
        match catch_unwind(AssertUnwindSafe(read)) {
            Err(panic) => {
                let text = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                failures.push(format!("{what}: panicked: {text}"));
            }
            Ok(Some(message)) if message.trim().is_empty() || message.contains('\n') => {
                failures.push(format!("{what}: error not one line: {message:?}"));
            }
            Ok(_) => {}
        }
    }
    failures
}

/// Numbers at the edges of the integer types, written over binary fields.
const BOUNDARY: [u64; 9] = [
    0,
    1,
    0x7f,
    0xff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0x7fff_ffff_ffff_ffff,
    u64::MAX,
];

/// Numbers written over a number of a text header (NRRD sizes, VTK dimensions, XML offsets).
const TEXT_NUMBERS: [&str; 7] = [
    "0",
    "-1",
    "3000000000",
    "4294967297",
    "99999999999999999999",
    "1e308",
    "nan",
];

/// One to three mutations of `seed`.
fn mutate(seed: &[u8], rng: &mut SplitMix64) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    let below = |n: usize, rng: &mut SplitMix64| (rng.next_u64() % n.max(1) as u64) as usize;
    for _ in 0..1 + below(3, rng) {
        let at = below(bytes.len(), rng);
        match below(6, rng) {
            0 => {
                for _ in 0..1 + below(8, rng) {
                    let i = below(bytes.len(), rng);
                    if let Some(b) = bytes.get_mut(i) {
                        *b ^= 1 << below(8, rng);
                    }
                }
            }
            1 => bytes.truncate(at),
            2 => {
                let inserted: Vec<u8> = (0..1 + below(16, rng))
                    .map(|_| rng.next_u64() as u8)
                    .collect();
                bytes.splice(at..at, inserted);
            }
            3 => {
                let value = BOUNDARY[below(BOUNDARY.len(), rng)];
                let width = [1, 2, 4, 8][below(4, rng)];
                let big = rng.next_u64() & 1 == 0;
                let all = if big {
                    value.to_be_bytes()
                } else {
                    value.to_le_bytes()
                };
                let field = if big {
                    &all[8 - width..]
                } else {
                    &all[..width]
                };
                for (k, &b) in field.iter().enumerate() {
                    if let Some(slot) = bytes.get_mut(at + k) {
                        *slot = b;
                    }
                }
            }
            4 => {
                // A run of ASCII digits: a number of a text header.
                let starts: Vec<usize> = (0..bytes.len())
                    .filter(|&i| {
                        bytes[i].is_ascii_digit() && (i == 0 || !bytes[i - 1].is_ascii_digit())
                    })
                    .collect();
                if let Some(&start) = starts.get(below(starts.len(), rng)) {
                    let end = (start..bytes.len())
                        .find(|&i| !bytes[i].is_ascii_digit())
                        .unwrap_or(bytes.len());
                    let number = TEXT_NUMBERS[below(TEXT_NUMBERS.len(), rng)];
                    bytes.splice(start..end, number.bytes());
                }
            }
            _ => {
                // A stretch copied over another: repeated headers, offsets pointing elsewhere.
                let len = 1 + below(64, rng);
                let from = below(bytes.len(), rng);
                let piece: Vec<u8> = bytes[from..(from + len).min(bytes.len())].to_vec();
                for (k, b) in piece.into_iter().enumerate() {
                    if let Some(slot) = bytes.get_mut(at + k) {
                        *slot = b;
                    }
                }
            }
        }
    }
    bytes
}

/// Every seed's mutants and every kept regression read every way, in a child process with a
/// 4 GiB address-space limit (two rayon threads and two malloc arenas keep the test binary's own
/// reservations small under it).
#[test]
fn mutants_of_every_reader_end_cleanly() {
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 4000000; exec \"$0\" --exact fuzz_corpus::mutant_loop --ignored --nocapture --test-threads 1")
        .arg(&exe)
        .env("RAYON_NUM_THREADS", "2")
        .env("MALLOC_ARENA_MAX", "2")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "fuzz loop failed ({:?}):\n{stdout}\n{}",
        out.status,
        &stderr[stderr.len().saturating_sub(8000)..]
    );
}

#[test]
#[ignore = "run by mutants_of_every_reader_end_cleanly, under a memory limit"]
fn mutant_loop() {
    let kept = std::env::temp_dir().join("hdrvis-fuzz-failures");
    std::fs::create_dir_all(&kept).unwrap();
    let mut failures = Vec::new();
    let mut regressions: Vec<PathBuf> = std::fs::read_dir(fuzz_dir().join("regressions"))
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    regressions.sort();
    for path in &regressions {
        for f in read_every_way(path) {
            failures.push(format!("{}: {f}", path.display()));
        }
    }
    let mut seeds: Vec<PathBuf> = std::fs::read_dir(fuzz_dir().join("seeds"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    seeds.sort();
    assert_eq!(seeds.len(), 14, "{seeds:?}");
    for (k, seed_path) in seeds.iter().enumerate() {
        let seed = std::fs::read(seed_path).unwrap();
        let name = seed_path.file_name().unwrap().to_str().unwrap();
        assert!(read_every_way(seed_path).is_empty(), "{name} itself fails");
        let mut rng = SplitMix64(0x6675_7a7a ^ k as u64);
        let start = std::time::Instant::now();
        for i in 0..MUTANTS_PER_SEED {
            let mutant = mutate(&seed, &mut rng);
            // Written where it is kept before it is read, so that an abort leaves it behind.
            let path = kept.join(format!("{i}-{name}"));
            std::fs::write(&path, &mutant).unwrap();
            let found = read_every_way(&path);
            if found.is_empty() {
                std::fs::remove_file(&path).unwrap();
            }
            for f in found {
                failures.push(format!("{} (mutant {i} of {name}): {f}", path.display()));
            }
        }
        println!(
            "{name}: {MUTANTS_PER_SEED} mutants in {:.2} s",
            start.elapsed().as_secs_f64()
        );
    }
    assert!(
        failures.is_empty(),
        "{} failures (copy the mutants into tests/fuzz/regressions/ once fixed):\n{}",
        failures.len(),
        failures.join("\n")
    );
}
