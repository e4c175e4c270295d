//! The accuracy report's `shell` scene: the mantle rendered natively on its spherical grid
//! against the same shell resampled onto boxes, each scored against the native integral.

use std::sync::Arc;

use super::{reference_row, scored_row, time_volume, volume_references, AccuracyRow, CONVERGED};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::Volume;
use crate::render::{VolumeRenderOptions, VolumeSource};

/// The accuracy report's `shell` scene: the native shell at steps of 0.5, 1 and 2 radial
/// spacings and its resampled boxes of `boxes` voxels a side at 0.5 of their own voxel, in f32
/// on the GPU, each against the native integral (f64, pre-integrated at 1/8 of the step), with
/// the voxels' memory and the resampling's time; and the f64 reference's own time.
pub(crate) fn shell_rows(
    ctx: Arc<GpuContext>,
    name: &str,
    shell: &Volume,
    options: &VolumeRenderOptions,
    boxes: &[usize],
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<AccuracyRow>> {
    use crate::render::Precision;
    let refs = volume_references(name, shell, options, runs, log)?;
    let session = super::super::timing_session(ctx);
    let size = (options.width, options.height);
    let bytes = |v: &Volume| v.voxel_count() as f64 * 4.0 / (1u64 << 20) as f64;
    let mut rows = Vec::new();
    let shared = Arc::new(shell.clone());
    let source = VolumeSource::Memory(shared);
    let mut o = options.clone();
    o.precision = Precision::F32;
    for factor in [1.0, 2.0, 4.0] {
        o.step = options.step * factor;
        let (ms, got) = time_volume(&session, &source, &o, runs)?;
        let variant = format!("native step {}", o.step);
        let mut r = scored_row(name, variant, &ms, &got, &refs.converged, size, CONVERGED)?;
        r.memory_mib = bytes(shell);
        r.prepare_ms = 0.0;
        log(&format!(
            "{name} {}: {:.1} ms, rel RMS {:.2e}",
            r.variant, r.median_ms, r.rel_rms
        ));
        rows.push(r);
    }
    for &n in boxes {
        log(&format!("{name}: resampling onto {n}^3 ..."));
        let t = std::time::Instant::now();
        let boxed = crate::model::resample_to_box(shell, n)?;
        let prepare_ms = t.elapsed().as_secs_f64() * 1e3;
        let step_world = options.step * boxed.voxel_length();
        let ob = super::super::spherical::box_options(&o, &boxed, shell.voxel_length(), step_world);
        let memory = bytes(&boxed);
        let source = VolumeSource::Memory(Arc::new(boxed));
        let (ms, got) = time_volume(&session, &source, &ob, runs)?;
        drop(source);
        let mut r = scored_row(
            name,
            format!("box {n}^3"),
            &ms,
            &got,
            &refs.converged,
            size,
            CONVERGED,
        )?;
        r.memory_mib = memory;
        r.prepare_ms = prepare_ms;
        log(&format!(
            "{name} {}: {:.1} ms (+{:.0} ms resampling), rel RMS {:.2e}",
            r.variant, r.median_ms, prepare_ms, r.rel_rms
        ));
        rows.push(r);
    }
    let mut reference = reference_row(name, &refs.same_step_ms, CONVERGED);
    reference.variant = "native f64 (CPU)".into();
    reference.memory_mib = bytes(shell);
    rows.push(reference);
    Ok(rows)
}

/// Per box of the shell scene: the fastest native render at least as accurate, and its time
/// against the box's.
pub(crate) fn shell_summary(rows: &[AccuracyRow]) -> Vec<String> {
    let native: Vec<&AccuracyRow> = rows
        .iter()
        .filter(|r| r.variant.starts_with("native step"))
        .collect();
    rows.iter()
        .filter(|r| r.variant.starts_with("box "))
        .map(|b| {
            match native
                .iter()
                .filter(|r| r.rel_rms <= b.rel_rms)
                .min_by(|x, y| x.median_ms.total_cmp(&y.median_ms))
            {
                Some(s) => format!(
                    "{}: {} (rel RMS {:.1e}, {:.0} MiB) at least as accurate as the {} (rel RMS {:.1e}, {:.0} MiB + {:.0} ms resampling) in {:.2}x its render time",
                    b.scene, s.variant, s.rel_rms, s.memory_mib, b.variant, b.rel_rms, b.memory_mib, b.prepare_ms, s.median_ms / b.median_ms
                ),
                None => format!(
                    "{}: the {} (rel RMS {:.1e}) is more accurate than every native step",
                    b.scene, b.variant, b.rel_rms
                ),
            }
        })
        .collect()
}
