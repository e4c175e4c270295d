//! Distributed renders under real MPI: `mpirun --oversubscribe -n 2|3|4` of the hdrvis built
//! with `--features mpi` (its path in HDRVIS_MPI_BIN; .ci/run builds it) against the same
//! script run as one process. Skipped with a printed reason where MPI or that binary is
//! missing, unless HDRVIS_REQUIRE_MPI=1 (CI), which makes a missing piece a failure.

use crate::volume_render::hdr_blobs;
use hdrvis::io::exr::read_exr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The MPI-enabled hdrvis, when it and mpirun are here.
pub(crate) fn mpi_binary() -> Option<PathBuf> {
    let missing = |why: String| crate::common::missing("HDRVIS_REQUIRE_MPI", &why);
    if Command::new("mpirun").arg("--version").output().is_err() {
        return missing(
            "mpirun is not installed (apt-get install openmpi-bin libopenmpi-dev)".into(),
        );
    }
    match std::env::var_os("HDRVIS_MPI_BIN").map(PathBuf::from) {
        Some(p) if p.is_file() => Some(p),
        Some(p) => missing(format!("HDRVIS_MPI_BIN={} is not a file", p.display())),
        None => missing(
            "HDRVIS_MPI_BIN is not set (cargo build --features mpi, then point it at the binary)"
                .into(),
        ),
    }
}

/// `hdrvis run` of `script` on `ranks` MPI ranks (1: a plain process), killed after 5 minutes
/// so a hung rank fails the test instead of stalling it.
fn run(bin: &Path, ranks: usize, script: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut cmd = Command::new("timeout");
    cmd.arg("300");
    if ranks > 1 {
        cmd.args(["mpirun", "--oversubscribe", "--allow-run-as-root", "-n"])
            .arg(ranks.to_string())
            // Containers often forbid the cross-memory attach of OpenMPI's shared-memory
            // transport; plain copies work everywhere.
            .env("OMPI_MCA_btl_vader_single_copy_mechanism", "none");
    }
    cmd.arg(bin)
        .args(["run", "--out"])
        .arg(out)
        .args(extra)
        .arg(script)
        .output()
        .unwrap()
}

const SCENE: &str = r#"
let v = if param("open", 0) == 1 { open_volume("vol.npy") } else { load_volume("vol.npy") };
let tf = if param("tf", "lut") == "lut" {
    tf_lut(#{ scale: "log10", domain: [1e-4, 10.0], colormap: "magma",
              emission: [[0.0, -1.0], [1.0, 1.0]], opacity: [[0.0, -4.0], [0.6, -2.0], [1.0, -0.5]] })
} else {
    tf_emission_absorption(0.4, 0.3)
};
let cam = if param("camera", "orbit") == "orbit" { camera_orbit(35.0, 25.0) } else { camera_axis("z") };
let size = param("size", 48);
let img = render_volume(v, #{ tf: tf, camera: cam, width: size, height: size - 8, step: 0.7,
                              filter: "exact", early_exit: 0.0, jitter: true });
print("rendered");
save_exr(img, "img.exr");
"#;

/// The blobs of `n`³ voxels with a hole of missing values across z = n/2 (a rank boundary of
/// 2 and 4 ranks), written as vol.npy beside the scene script.
fn scene(dir: &Path, n: usize) -> PathBuf {
    let mut v = hdr_blobs(n);
    let mid = n / 2;
    for k in mid.saturating_sub(2)..(mid + 2).min(n) {
        for j in n / 4..n / 2 {
            for i in n / 5..n / 2 {
                let idx = v.index(i, j, k);
                v.data[idx] = f32::NAN;
            }
        }
    }
    hdrvis::datasets::npy::write_npy_f32(&dir.join("vol.npy"), &[n, n, n], &v.data).unwrap();
    let script = dir.join("scene.rhai");
    std::fs::write(&script, SCENE).unwrap();
    script
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Largest channel difference of two EXRs over the second one's peak colour channel.
pub(crate) fn worst_over_peak(a: &Path, b: &Path) -> f64 {
    let (a, b) = (read_exr(a).unwrap(), read_exr(b).unwrap());
    let peak = b
        .pixels
        .iter()
        .flat_map(|p| p[..3].iter())
        .fold(0.0f32, |m, &v| m.max(v));
    assert!(peak > 0.0);
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(x, y)| (0..4).map(move |c| (x[c] - y[c]).abs()))
        .fold(0.0f32, f32::max) as f64
        / peak as f64
}

#[test]
fn mpirun_on_two_three_and_four_ranks_gives_the_single_process_image() {
    let Some(bin) = mpi_binary() else { return };
    let dir = tempfile::tempdir().unwrap();
    let script = scene(dir.path(), 32);
    for (tf, camera) in [("lut", "orbit"), ("ea", "axis")] {
        let sets = [
            "--set",
            &format!("tf={tf}"),
            "--set",
            &format!("camera={camera}"),
        ];
        let single_out = dir.path().join(format!("single-{tf}"));
        let single = run(&bin, 1, &script, &single_out, &sets);
        assert!(single.status.success(), "{}", stderr(&single));
        for ranks in [2, 3, 4] {
            for open in ["0", "1"] {
                let out = dir.path().join(format!("{tf}-{ranks}-{open}"));
                let mut args = sets.to_vec();
                let open_set = format!("open={open}");
                args.extend(["--set", &open_set]);
                let o = run(&bin, ranks, &script, &out, &args);
                assert!(o.status.success(), "{ranks} ranks: {}", stderr(&o));
                // Rank 0 alone prints and writes.
                let text = stdout(&o);
                assert_eq!(text.matches("rendered").count(), 1, "{text}");
                assert_eq!(text.matches("wrote ").count(), 1, "{text}");
                let files: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
                assert_eq!(files.len(), 1);
                let worst = worst_over_peak(&out.join("img.exr"), &single_out.join("img.exr"));
                assert!(
                    worst < 1e-5,
                    "{tf}/{camera}, {ranks} ranks, open {open}: {worst:.2e} of the peak"
                );
            }
        }
    }
}

/// The `rank r of N: peak memory X MiB` lines of a `--stats` run, in MiB.
fn rank_peaks(text: &str) -> Vec<f64> {
    text.lines()
        .filter(|l| l.starts_with("rank ") && l.contains("peak memory"))
        .map(|l| {
            l.split("peak memory ")
                .nth(1)
                .unwrap()
                .split(' ')
                .next()
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect()
}

#[test]
fn each_ranks_peak_memory_falls_with_the_rank_count() {
    let Some(bin) = mpi_binary() else { return };
    let dir = tempfile::tempdir().unwrap();
    // 224³ f32: 45 MiB of voxels, plus as much again for the texture (lavapipe's textures are
    // host memory).
    let script = scene(dir.path(), 224);
    let sets = ["--stats", "--set", "size=64"];
    let single = run(&bin, 1, &script, &dir.path().join("one"), &sets);
    assert!(single.status.success(), "{}", stderr(&single));
    let single_peak: f64 = stdout(&single)
        .lines()
        .find_map(|l| l.strip_prefix("peak memory "))
        .and_then(|l| l.split(' ').next()?.parse().ok())
        .expect("peak memory line");
    let mut args = sets.to_vec();
    args.extend(["--set", "open=1"]);
    let mut worst_by_ranks = Vec::new();
    for ranks in [2, 4] {
        let o = run(
            &bin,
            ranks,
            &script,
            &dir.path().join(format!("r{ranks}")),
            &args,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let peaks = rank_peaks(&stdout(&o));
        assert_eq!(peaks.len(), ranks, "{}", stdout(&o));
        eprintln!("{ranks} ranks: peaks {peaks:?} MiB; one process {single_peak} MiB");
        worst_by_ranks.push(peaks.iter().cloned().fold(0.0, f64::max));
    }
    assert!(worst_by_ranks[1] < worst_by_ranks[0], "{worst_by_ranks:?}");
    assert!(
        worst_by_ranks[1] < 0.75 * single_peak,
        "4 ranks: {worst_by_ranks:?} MiB against {single_peak} MiB in one process"
    );
}

#[test]
fn mpi_errors_end_every_rank_with_one_line() {
    let Some(bin) = mpi_binary() else { return };
    let dir = tempfile::tempdir().unwrap();
    let script = scene(dir.path(), 3);
    // More ranks than the volume's 3 slices.
    let out = dir.path().join("too-many");
    let o = run(&bin, 4, &script, &out, &[]);
    assert!(!o.status.success());
    assert_ne!(o.status.code(), Some(124), "ranks hung: {}", stderr(&o));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error: ")).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("4 ranks cannot share") && lines[0].contains("3 z-slices"),
        "{err}"
    );
    assert!(!out.join("img.exr").exists());
    // A script error every rank meets: printed once.
    let bad = dir.path().join("bad.rhai");
    std::fs::write(&bad, "let v = load_volume(\"missing.npy\");\n").unwrap();
    let o = run(&bin, 3, &bad, &dir.path().join("bad"), &[]);
    assert!(!o.status.success());
    assert_ne!(o.status.code(), Some(124), "ranks hung: {}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error: ")).count(),
        1,
        "{err}"
    );
    assert!(err.contains("missing.npy"), "{err}");
}

/// The hdrvis built with `--features mpi` on a machine without the MPI library: the loader's
/// one line, exit status 127, nothing written. The library is hidden in a mount namespace of
/// its own (`unshare --mount`, root): the system's library folder is replaced there by links
/// to all its files but libmpi.so*.
#[test]
fn a_missing_mpi_library_is_one_line_and_writes_nothing() {
    let Some(bin) = mpi_binary() else { return };
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !root {
        crate::common::missing::<()>(
            "HDRVIS_REQUIRE_MPI",
            "hiding libmpi needs root (unshare --mount)",
        );
        return;
    }
    let lib = Path::new("/usr/lib/x86_64-linux-gnu");
    assert!(
        lib.join("libmpi.so.40").exists(),
        "Debian's libmpi.so.40 is not in {}",
        lib.display()
    );
    let dir = tempfile::tempdir().unwrap();
    let script = scene(dir.path(), 8);
    let (original, links, out) = (
        dir.path().join("original"),
        dir.path().join("links"),
        dir.path().join("out"),
    );
    std::fs::create_dir_all(&original).unwrap();
    std::fs::create_dir_all(&links).unwrap();
    let hide = r#"set -e
mount --bind "$1" "$2"
for p in "$2"/*; do n=${p##*/}; case $n in libmpi.so*) ;; *) ln -s "$p" "$3/$n";; esac; done
mount --bind "$3" "$1"
shift 3
exec "$@""#;
    let o = Command::new("unshare")
        .args(["--mount", "sh", "-c", hide, "hide"])
        .arg(lib)
        .arg(&original)
        .arg(&links)
        .arg(&bin)
        .args(["run", "--out"])
        .arg(&out)
        .arg(&script)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(127), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains(
            "error while loading shared libraries: libmpi.so.40: cannot open shared object file"
        ),
        "{err}"
    );
    assert!(stdout(&o).is_empty());
    assert!(!out.exists(), "wrote {}", out.display());
}
