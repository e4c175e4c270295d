//! Numerical stability of the compositing variants: hard cases each compared with the f64 CPU
//! reference on Vulkan (lavapipe) and the GL fallback, and the paper's claim that 8-bit
//! compositing loses faint structure that float compositing keeps.

use crate::common::render;
use hdrvis::bench::{lost_detail, relative_rms as rel_rms};
use hdrvis::gpu::BackendChoice;
use hdrvis::model::{Axis, Camera, LutTransfer, Scale, TransferFunction, Volume};
use hdrvis::render::cpu_reference::render_volume_f64;
use hdrvis::render::{FilterMode, Precision, VolumeRenderOptions};

fn gpu(backend: BackendChoice, vol: &Volume, o: &VolumeRenderOptions) -> Vec<[f64; 4]> {
    render(backend, vol, o)
        .pixels
        .iter()
        .map(|p| p.map(|v| v as f64))
        .collect()
}

fn axis(vol: &Volume, tf: TransferFunction, step: f64) -> VolumeRenderOptions {
    let mut o = VolumeRenderOptions::new(Camera::axis(Axis::Z, &vol.bounds()), tf);
    o.width = vol.dims[0] as u32;
    o.height = vol.dims[1] as u32;
    o.step = step;
    o.early_exit = 0.0;
    o.filter = FilterMode::Exact;
    o
}

fn all_finite(p: &[[f64; 4]]) -> bool {
    p.iter().all(|p| p.iter().all(|v| v.is_finite()))
}

#[test]
fn tiny_extinction_over_a_hundred_thousand_steps() {
    let vol = Volume::from_fn("thin", [2, 2, 1000], |_, _, _| 1.0).unwrap();
    let o = axis(
        &vol,
        TransferFunction::emission_absorption(1.0, 1e-9).unwrap(),
        0.01,
    );
    let reference = render_volume_f64(&vol, &o).unwrap();
    for backend in crate::common::backends() {
        for precision in [Precision::F32, Precision::F32c] {
            let mut o = o.clone();
            o.precision = precision;
            let g = gpu(backend, &vol, &o);
            let err = rel_rms(&g, &reference);
            eprintln!("tiny extinction, {backend:?} {precision:?}: rel RMS {err:.2e}");
            // f32 sums blocks of 64 segments before they join the totals (2e-5 here; adding
            // each segment to a sum near 1000 drifts to 7e-4), f32c compensates every sum.
            let limit = if precision == Precision::F32c {
                1e-6
            } else {
                1e-4
            };
            assert!(err < limit, "{backend:?} {precision:?}: rel RMS {err}");
            let alpha_err = (g[0][3] - reference[0][3]).abs() / reference[0][3];
            assert!(
                alpha_err < 1e-2,
                "{backend:?} {precision:?}: alpha {} vs {}",
                g[0][3],
                reference[0][3]
            );
        }
    }
}

#[test]
fn data_spanning_sixty_decades_with_log_scale() {
    let n = 32;
    let vol = Volume::from_fn("decades", [n, n, n], |x, y, z| {
        10f64.powf(-30.0 + 60.0 * (x + 0.3 * y + 0.1 * z) / (1.4 * 32.0))
    })
    .unwrap();
    let tf = TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        domain: Some([1e-30, 1e30]),
        colormap: "viridis".into(),
        emission: vec![[0.0, -2.0], [1.0, 2.0]],
        opacity: vec![[0.0, -6.0], [1.0, -1.0]],
        ..Default::default()
    });
    let o = axis(&vol, tf, 0.5);
    let reference = render_volume_f64(&vol, &o).unwrap();
    for backend in crate::common::backends() {
        let g = gpu(backend, &vol, &o);
        assert!(all_finite(&g));
        let err = rel_rms(&g, &reference);
        assert!(err < 1e-4, "{backend:?}: rel RMS {err}");
    }
}

#[test]
fn constant_zero_and_negative_volumes_under_log_scales() {
    let cases: Vec<(&str, Volume, Scale)> = vec![
        (
            "constant",
            Volume::from_fn("c", [8, 8, 8], |_, _, _| 3.5).unwrap(),
            Scale::Linear,
        ),
        (
            "zeros and negatives in log10",
            Volume::from_fn("z", [8, 8, 8], |x, _, _| if x < 4.0 { 0.0 } else { -x }).unwrap(),
            Scale::Log10,
        ),
        (
            "symlog around zero",
            Volume::from_fn("s", [8, 8, 8], |x, y, _| (x - 4.0) * (y - 4.0)).unwrap(),
            Scale::Symlog { linthresh: 0.0 },
        ),
    ];
    for (name, vol, scale) in cases {
        let tf = TransferFunction::Lut(LutTransfer {
            scale,
            domain: if scale == Scale::Log10 {
                Some([1e-3, 10.0])
            } else {
                None
            },
            ..Default::default()
        });
        let o = axis(&vol, tf, 0.5);
        let reference = render_volume_f64(&vol, &o).unwrap();
        assert!(all_finite(&reference), "{name}");
        for backend in crate::common::backends() {
            let g = gpu(backend, &vol, &o);
            assert!(all_finite(&g), "{name} {backend:?}");
            let err = rel_rms(&g, &reference);
            assert!(err < 1e-5, "{name} {backend:?}: rel RMS {err}");
        }
    }
}

#[test]
fn very_small_and_very_large_steps() {
    let vol = crate::volume_render::hdr_blobs(24);
    for step in [1e-3, 100.0] {
        let tf = TransferFunction::emission_absorption(0.5, 0.3).unwrap();
        let mut o = axis(&vol, tf, step);
        o.width = 12;
        o.height = 12;
        let reference = render_volume_f64(&vol, &o).unwrap();
        for backend in crate::common::backends() {
            let g = gpu(backend, &vol, &o);
            assert!(all_finite(&g));
            let err = rel_rms(&g, &reference);
            assert!(err < 1e-3, "step {step} {backend:?}: rel RMS {err}");
        }
    }
}

/// The paper's argument in numbers: on the mantle, 8-bit compositing loses faint structure that
/// float compositing keeps.
#[test]
fn eight_bit_compositing_loses_the_faint_structure_f32_keeps() {
    use hdrvis::datasets::mantle::{generate, MantleField, MantleFields, MantleOptions};
    let m = generate(
        &MantleOptions {
            n: 48,
            fields: MantleFields::only(MantleField::Fluctuation),
            ..Default::default()
        },
        &mut |_| Ok(()),
    )
    .unwrap();
    let vol = Volume::new(
        "mantle",
        [48; 3],
        [2.0 / 48.0; 3],
        [-1.0; 3],
        m.fluctuation.clone(),
    )
    .unwrap();
    let tf = TransferFunction::Lut(hdrvis::bench::mantle_fig5_tf());
    let mut o =
        VolumeRenderOptions::new(Camera::orbit(&vol.bounds(), 30.0, 20.0, 30.0).unwrap(), tf);
    (o.width, o.height, o.step) = (64, 64, 0.5);
    o.filter = FilterMode::Exact;
    let reference = render_volume_f64(&vol, &o).unwrap();
    let mut results = Vec::new();
    for precision in [
        Precision::U8,
        Precision::F16,
        Precision::F32,
        Precision::F32c,
    ] {
        o.precision = precision;
        let g = gpu(BackendChoice::Vulkan, &vol, &o);
        results.push((
            precision,
            rel_rms(&g, &reference),
            lost_detail(&g, &reference),
        ));
    }
    let get = |p: Precision| *results.iter().find(|r| r.0 == p).unwrap();
    let (_, rms32, lost32) = get(Precision::F32);
    let (_, rms8, lost8) = get(Precision::U8);
    assert!(rms32 < 1e-4, "f32 rel RMS {rms32}");
    assert!(lost32 < 1e-3, "f32 lost detail {lost32}");
    assert!(
        lost8 > 0.2 && rms8 > 100.0 * rms32,
        "u8 should lose detail: {results:?}"
    );
    let (_, rms16, _) = get(Precision::F16);
    assert!(rms16 > rms32 && rms16 < rms8, "{results:?}");
}
