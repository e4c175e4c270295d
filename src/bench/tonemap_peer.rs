//! `hdrvis bench tonemap --peer pfstools`: whole processes, end to end, side by side with
//! pfstools (Debian's `pfstools`): `hdrvis tonemap IN.exr -o OUT` against
//! `pfsin IN.exr | pfstmo_… | pfsout OUT` for each operator both tools have, on the synthetic
//! HDR image written as hdrvis writes a render (32-bit float RGBA, ZIP). Each tool runs with
//! its own defaults. Rounds alternate the two tools so the machine's drift lands on both; a
//! ratio is the median of the rounds' ratios (pfstools' time over hdrvis's).

use super::median;
use crate::error::{Error, Result};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

/// hdrvis's operator and the pfstools command that implements the same paper.
pub(crate) const PFSTOOLS_OPERATORS: [(&str, &str); 4] = [
    ("reinhard", "pfstmo_reinhard02"),
    ("drago", "pfstmo_drago03"),
    ("durand", "pfstmo_durand02"),
    ("reinhard-local", "pfstmo_reinhard02 --scales"),
];

/// One operator at one size: both tools' whole-process times, per round.
#[derive(Clone, Debug)]
pub struct PeerToneMapRow {
    pub op: &'static str,
    pub peer: &'static str,
    pub size: u32,
    pub hdrvis_ms: Vec<f64>,
    pub peer_ms: Vec<f64>,
}

impl PeerToneMapRow {
    /// Each round's ratio, pfstools' time over hdrvis's (> 1: hdrvis faster).
    pub(crate) fn ratios(&self) -> Vec<f64> {
        self.peer_ms
            .iter()
            .zip(&self.hdrvis_ms)
            .map(|(p, h)| p / h)
            .collect()
    }

    /// The median of the rounds' ratios.
    pub(crate) fn ratio(&self) -> f64 {
        median(&self.ratios())
    }
}

/// Where the runs write, and in what format.
pub struct PeerToneMapSetup<'a> {
    /// The hdrvis binary to time (the running one).
    pub hdrvis: &'a Path,
    /// `--backend` for hdrvis's runs: the bench's own, resolved.
    pub backend: &'a str,
    /// Output extension: `exr` (both tools' defaults: hdrvis half ZIP, pfsoutexr half PIZ) or
    /// `png` (hdrvis's own encoder; pfsout through ImageMagick).
    pub format: &'a str,
    /// `--mapper` for hdrvis's runs: auto, cpu or gpu.
    pub mapper: &'a str,
    pub rounds: usize,
}

/// Checks that pfstools and its operators (Debian's pfstmo, which pfstools only recommends) are
/// installed, with what to do if not.
pub fn pfstools_present() -> Result<()> {
    for tool in ["pfsin", "pfstmo_reinhard02"] {
        let found = Command::new(tool)
            .arg("--help")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok();
        if !found {
            return Err(Error::invalid(
                "--peer pfstools",
                format!("{tool} not found on PATH; install Debian's pfstools and pfstmo (apt install pfstools pfstmo)"),
            ));
        }
    }
    Ok(())
}

/// Times every operator pair on each size: `rounds` rounds of one hdrvis run then one
/// pfstools run, after one untimed run of each (caches, the pipeline cache of the GPU driver).
pub fn bench_tonemap_peer(
    setup: &PeerToneMapSetup<'_>,
    sizes: &[u32],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<PeerToneMapRow>> {
    pfstools_present()?;
    if !matches!(setup.format, "exr" | "png") {
        return Err(Error::invalid(
            "--format",
            format!("expected exr or png, got {:?}", setup.format),
        ));
    }
    let dir = tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?;
    let mut rows = Vec::new();
    for &size in sizes {
        progress(&format!("writing a {size}x{size} HDR image"));
        let input = dir.path().join(format!("in{size}.exr"));
        crate::io::exr::write_exr(&super::tonemap::synthetic_hdr(size, size), &input)?;
        for (op, tmo) in PFSTOOLS_OPERATORS {
            let ours = dir.path().join(format!("hdrvis.{}", setup.format));
            let theirs = dir.path().join(format!("pfs.{}", setup.format));
            let mut row = PeerToneMapRow {
                op,
                peer: tmo,
                size,
                hdrvis_ms: Vec::new(),
                peer_ms: Vec::new(),
            };
            for round in 0..=setup.rounds {
                let h = time_hdrvis(setup, op, &input, &ours)?;
                let p = time_pfstools(tmo, &input, &theirs)?;
                if round > 0 {
                    row.hdrvis_ms.push(h);
                    row.peer_ms.push(p);
                }
            }
            progress(&format!(
                "{op:15} {size}x{size}: hdrvis {:.0} ms, {tmo} {:.0} ms",
                median(&row.hdrvis_ms),
                median(&row.peer_ms)
            ));
            rows.push(row);
        }
    }
    Ok(rows)
}

fn time_hdrvis(setup: &PeerToneMapSetup<'_>, op: &str, input: &Path, out: &Path) -> Result<f64> {
    let mut cmd = Command::new(setup.hdrvis);
    cmd.args(["--backend", setup.backend]);
    cmd.arg("tonemap").arg(input).arg("-o").arg(out);
    cmd.args(["--op", op, "--mapper", setup.mapper]);
    timed(&mut cmd, &format!("hdrvis tonemap --op {op}"))
}

fn time_pfstools(tmo: &str, input: &Path, out: &Path) -> Result<f64> {
    let line = format!("pfsin {} | {tmo} | pfsout {}", quoted(input), quoted(out));
    timed(Command::new("sh").args(["-c", &line]), &line)
}

/// A path for `sh -c`, in single quotes.
fn quoted(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', r"'\''"))
}

/// Runs `cmd` to the end, its output discarded; the wall time in ms.
fn timed(cmd: &mut Command, what: &str) -> Result<f64> {
    let t = Instant::now();
    let out = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| Error::io(cmd.get_program(), e))?;
    let ms = t.elapsed().as_secs_f64() * 1e3;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("").trim();
        return Err(Error::invalid(
            "bench tonemap",
            format!("{what} failed: {last}"),
        ));
    }
    Ok(ms)
}

/// The side-by-side table.
pub fn format_tonemap_peer_table(setup: &PeerToneMapSetup<'_>, rows: &[PeerToneMapRow]) -> String {
    let mut s = format!(
        "whole processes, read + tone map + write .{}, hdrvis --mapper {}, median of {} \
         alternating rounds; × = pfstools' time / hdrvis's (median of the rounds' ratios)\n",
        setup.format, setup.mapper, setup.rounds
    );
    s += &format!(
        "{:15} {:>11} {:>11} {:28} {:>11} {:>7} {:>13}\n",
        "operator", "image", "hdrvis ms", "pfstools", "pfs ms", "×", "rounds ×"
    );
    for r in rows {
        let ratios = r.ratios();
        let lo = ratios.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().cloned().fold(0.0, f64::max);
        s += &format!(
            "{:15} {:>11} {:>11.0} {:28} {:>11.0} {:>6.2}× {:>5.2}–{:.2}×\n",
            r.op,
            format!("{}x{}", r.size, r.size),
            median(&r.hdrvis_ms),
            r.peer,
            median(&r.peer_ms),
            r.ratio(),
            lo,
            hi
        );
    }
    s
}
