//! The accuracy benchmark's report: the table printed to the terminal with its summary lines
//! (what f32 costs, the fastest setting within a bound, the shell against its boxes), the CSV
//! and JSON files and the log–log chart of error against time.

use super::shell::shell_summary;
use super::{AccuracyRow, CONVERGED, PER_NODE, SAME_STEP};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

pub fn format_accuracy_table(adapter: &str, rows: &[AccuracyRow]) -> String {
    let mut s = format!("adapter: {adapter}\naccuracy against f64 CPU references: the same rays, steps and table ({SAME_STEP}), the integral, pre-integrated at 1/8 of the step ({CONVERGED}), the fringe at each node ({PER_NODE})\n");
    s.push_str(&format!(
        "{:<8} {:<26} {:<15} {:>10} {:>11} {:>11} {:>12} {:>12}\n",
        "scene",
        "variant",
        "reference",
        "median ms",
        "rel RMS",
        "max rel",
        "PSNR 8-bit",
        "lost detail"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<8} {:<26} {:<15} {:>10.1} {:>11.2e} {:>11.2e} {:>12} {:>11.2}%\n",
            r.scene,
            r.variant,
            r.reference,
            r.median_ms,
            r.rel_rms,
            r.max_rel,
            if r.psnr_8bit.is_finite() {
                format!("{:.1} dB", r.psnr_8bit)
            } else {
                "exact".into()
            },
            100.0 * r.lost_detail
        ));
    }
    for line in f32_cost_summary(rows)
        .into_iter()
        .chain(shell_summary(rows))
    {
        s.push_str(&line);
        s.push('\n');
    }
    let costs: Vec<&AccuracyRow> = rows.iter().filter(|r| r.memory_mib.is_finite()).collect();
    if !costs.is_empty() {
        s.push_str(&format!(
            "{:<8} {:<17} {:>11} {:>14} {:>10} {:>11}\n",
            "scene", "variant", "memory MiB", "resampling ms", "median ms", "rel RMS"
        ));
        for r in costs {
            s.push_str(&format!(
                "{:<8} {:<17} {:>11.1} {:>14.0} {:>10.1} {:>11.2e}\n",
                r.scene,
                r.variant,
                r.memory_mib,
                if r.prepare_ms.is_finite() {
                    r.prepare_ms
                } else {
                    0.0
                },
                r.median_ms,
                r.rel_rms
            ));
        }
    }
    s
}

/// Per scene: the fastest variant within 1e-3 relative RMS, and f32's time against it.
pub(crate) fn f32_cost_summary(rows: &[AccuracyRow]) -> Vec<String> {
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    scenes
        .into_iter()
        .filter_map(|scene| {
            let of_scene = rows.iter().filter(|r| r.scene == scene);
            if let (Some(naive), Some(reduced)) = (
                of_scene.clone().find(|r| r.variant == "naive f32"),
                of_scene.clone().find(|r| r.variant == "reduced"),
            ) {
                return Some(format!(
                    "{scene}: the reduced phase has rel RMS {:.1e} against {:.1e} for the naive f32 phase, at {:.2}x its time",
                    reduced.rel_rms,
                    naive.rel_rms,
                    reduced.median_ms / naive.median_ms
                ));
            }
            let precisions = of_scene.clone().filter(|r| r.reference == SAME_STEP);
            let fastest = precisions
                .clone()
                .filter(|r| r.rel_rms <= 1e-3 && !r.variant.starts_with("f64"))
                .min_by(|a, b| a.median_ms.total_cmp(&b.median_ms))?;
            let f32 = precisions.clone().find(|r| r.variant == "f32")?;
            let mut line = format!(
                "{scene}: fastest precision within 1e-3 rel RMS is {} ({:.1} ms); f32 has rel RMS {:.1e} at {:.2}x its time",
                fastest.variant,
                fastest.median_ms,
                f32.rel_rms,
                f32.median_ms / fastest.median_ms
            );
            // Against the integral: the cheapest step and sampling that reach 1e-3.
            if let Some(knob) = of_scene
                .clone()
                .filter(|r| {
                    r.reference == CONVERGED && r.rel_rms <= 1e-3 && !r.variant.starts_with("f64")
                })
                .min_by(|a, b| a.median_ms.total_cmp(&b.median_ms))
            {
                line.push_str(&format!(
                    "; against the integral, the cheapest step within 1e-3 is {} ({:.1} ms, {:.1e})",
                    knob.variant, knob.median_ms, knob.rel_rms
                ));
            }
            Some(line)
        })
        .collect()
}

/// The chart of error against time (log–log), one colour per scene, written as `accuracy.png`.
pub fn write_accuracy_chart(dir: &Path, adapter: &str, rows: &[AccuracyRow]) -> Result<PathBuf> {
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    let series: Vec<crate::bench::chart::Series> = scenes
        .iter()
        .map(|scene| crate::bench::chart::Series {
            name: scene.to_string(),
            points: rows
                .iter()
                .filter(|r| r.scene == *scene)
                .map(|r| (r.median_ms, r.rel_rms, r.variant.clone()))
                .collect(),
        })
        .collect();
    let (w, h) = (960, 640);
    // The adapter's name without the driver details, which would not fit.
    let short = adapter.split(" (").next().unwrap_or(adapter);
    let title = format!("What accuracy costs: error against time on {short}");
    let rgb = crate::bench::chart::log_log_chart(
        &title,
        "median time per frame (ms)",
        "relative RMS error against f64",
        &series,
        w,
        h,
    )?;
    let path = dir.join("accuracy.png");
    crate::bench::chart::write_rgb_png(&path, &rgb, w, h)?;
    Ok(path)
}

/// CSV and JSON of the accuracy rows, written atomically into `dir`.
pub fn write_accuracy_files(dir: &Path, rows: &[AccuracyRow]) -> Result<(PathBuf, PathBuf)> {
    use std::io::Write;
    let csv = dir.join("accuracy.csv");
    let json = dir.join("accuracy.json");
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            "null".into()
        }
    };
    crate::io::write_atomic(&csv, |w| {
        writeln!(
            w,
            "scene,variant,reference,median_ms,rel_rms,max_rel,psnr_8bit_db,lost_detail,memory_mib,prepare_ms"
        )
        .map_err(|e| Error::io(&csv, e))?;
        for r in rows {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{},{}",
                r.scene,
                r.variant,
                r.reference,
                r.median_ms,
                r.rel_rms,
                r.max_rel,
                num(r.psnr_8bit),
                r.lost_detail,
                num(r.memory_mib),
                num(r.prepare_ms)
            )
            .map_err(|e| Error::io(&csv, e))?;
        }
        Ok(())
    })?;
    crate::io::write_atomic(&json, |w| {
        let items: Vec<String> = rows
            .iter()
            .map(|r| {
                format!(
                    "{{\"scene\": \"{}\", \"variant\": \"{}\", \"reference\": \"{}\", \"median_ms\": {}, \"rel_rms\": {}, \"max_rel\": {}, \"psnr_8bit_db\": {}, \"lost_detail\": {}, \"memory_mib\": {}, \"prepare_ms\": {}}}",
                    r.scene, r.variant, r.reference, num(r.median_ms), num(r.rel_rms), num(r.max_rel), num(r.psnr_8bit), num(r.lost_detail), num(r.memory_mib), num(r.prepare_ms)
                )
            })
            .collect();
        writeln!(w, "[\n  {}\n]", items.join(",\n  ")).map_err(|e| Error::io(&json, e))
    })?;
    Ok((csv, json))
}
