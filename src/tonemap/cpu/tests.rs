//! Closed forms, hard images and the local operators' invariants of the f64 CPU references.

use super::*;

fn grey(values: &[f32], width: u32) -> HdrImage {
    let pixels = values.iter().map(|&v| [v, v, v, 1.0]).collect::<Vec<_>>();
    HdrImage::from_pixels(width, values.len() as u32 / width, pixels)
}

fn settings(op: Operator) -> ToneMapSettings {
    ToneMapSettings {
        op,
        ..Default::default()
    }
}

fn out_lum(img: &HdrImage) -> Vec<f64> {
    img.pixels
        .iter()
        .map(|p| REC709[0] * p[0] as f64 + REC709[1] * p[1] as f64 + REC709[2] * p[2] as f64)
        .collect()
}

#[test]
fn reinhard_global_matches_closed_form() {
    // Grey pixels: Rec. 709 weights sum to 1, so L_w is the grey value.
    // Lbar = (0.01 * 0.1 * 1 * 10)^(1/4) = 10^-0.5; L = 0.18 / Lbar * L_w (Reinhard 2002 eq. 2).
    let values = [0.01f32, 0.1, 1.0, 10.0];
    let img = grey(&values, 4);
    let lbar = 10f64.powf(-0.5);
    let l_max = 0.18 / lbar * 10.0;
    for white in [None, Some(2.0)] {
        let out = tonemap_cpu(&img, &settings(Operator::Reinhard { key: 0.18, white })).unwrap();
        let w = white.unwrap_or(l_max);
        for (i, &v) in values.iter().enumerate() {
            let l = 0.18 / lbar * v as f64;
            let expected = (l * (1.0 + l / (w * w)) / (1.0 + l)).min(1.0);
            assert!(
                (out.pixels[i][0] as f64 - expected).abs() < 1e-6,
                "white {white:?} L_w {v}: {} vs {expected}",
                out.pixels[i][0]
            );
        }
    }
    // With L_white = max L the brightest pixel maps to exactly 1.
    let out = tonemap_cpu(&img, &settings(Operator::REINHARD)).unwrap();
    assert!((out.pixels[3][1] - 1.0).abs() < 1e-6);
    // Spot values: L_w = 1 -> L = 0.569, L_d = 0.569 (1 + 0.569 / 5.692^2) / 1.569 = 0.36911.
    assert!(
        (out.pixels[2][0] - 0.369_110).abs() < 1e-5,
        "{}",
        out.pixels[2][0]
    );
}

#[test]
fn drago_matches_closed_form() {
    // L_w = 1 and 100: L_wa = 10, so x = 0.1 and x_max = 10. Drago 2003 eq. 4 with b = 0.85,
    // Ld_max = 100: L_d = 1 / log10(11) * ln(1.1) / ln(2 + 8 * 0.01^(ln 0.85 / ln 0.5))
    // = 0.0589982; the maximum maps to Ld_max / 100 = 1.
    let out = tonemap_cpu(&grey(&[1.0, 100.0], 2), &settings(Operator::DRAGO)).unwrap();
    assert!(
        (out.pixels[0][0] as f64 - 0.058_998_18).abs() < 1e-6,
        "{}",
        out.pixels[0][0]
    );
    assert!((out.pixels[1][0] - 1.0).abs() < 1e-6);
}

#[test]
fn ward_equalises_a_log_uniform_histogram() {
    // Ward 1997: a flat histogram of ln L over 4 decades is under the linear ceiling
    // (T * bin width / ln(100) is twice each count), so P(ln L) is linear and
    // L_d = Ld_min (Ld_max / Ld_min)^P: 10^-2..10^2 -> 1..100 cd/m2, L_w = 1 -> 10 -> 0.1.
    let n = 2001;
    let values: Vec<f32> = (0..n)
        .map(|i| 10f64.powf(-2.0 + 4.0 * i as f64 / (n - 1) as f64) as f32)
        .collect();
    let out = out_lum(&tonemap_cpu(&grey(&values, n as u32), &settings(Operator::WARD)).unwrap());
    for (i, expected) in [(0, 0.01), (500, 10f64.powf(-1.5)), (1000, 0.1), (2000, 1.0)] {
        assert!(
            (out[i] / expected - 1.0).abs() < 0.01,
            "{i}: {} vs {expected}",
            out[i]
        );
    }
}

#[test]
fn ward_ceiling_never_exaggerates_contrast() {
    // 90 % of the pixels crowd into L_w in [1, 1.1]; plain histogram equalisation would
    // stretch that 10 % step over most of the display. The linear ceiling limits
    // dL_d / dL_w to L_d / L_w (Ward 1997 eq. 7), so the step stays at most 1.1 (plus the
    // 2.5 % trimming tolerance and one bin of interpolation).
    let mut values: Vec<f32> = (0..900).map(|i| 1.0 + 0.1 * i as f32 / 899.0).collect();
    values.extend((0..100).map(|i| 10f32.powf(-3.0 + 6.0 * i as f32 / 99.0)));
    let out = out_lum(&tonemap_cpu(&grey(&values, 1000), &settings(Operator::WARD)).unwrap());
    let ratio = out[899] / out[0];
    assert!(
        ratio > 1.0 && ratio < 1.1 * 1.05,
        "display contrast {ratio} for 1.1 in the scene"
    );
}

#[test]
fn one_stop_doubles_linear_values() {
    let values = [0.001f32, 0.01, 0.1, 0.2, 0.45];
    let img = grey(&values, 5);
    let base = tonemap_cpu(&img, &settings(Operator::Linear)).unwrap();
    let brighter = tonemap_cpu(
        &img,
        &ToneMapSettings {
            exposure_ev: 1.0,
            ..settings(Operator::Linear)
        },
    )
    .unwrap();
    for (a, b) in base.pixels.iter().zip(&brighter.pixels) {
        for k in 0..3 {
            assert!((b[k] as f64 - 2.0 * a[k] as f64).abs() < 1e-7 * b[k] as f64);
        }
    }
}

/// `Operator::divides_out_exposure` is what the operators do: at +3.5 EV and -2 EV an image over
/// five decades (with a missing pixel) maps to the same picture within f32 rounding under the
/// operators that say so, and to a clearly different one under the others.
#[test]
fn operators_that_divide_out_exposure_give_one_picture_at_every_exposure() {
    let (w, h) = (48u32, 40u32);
    let mut img = HdrImage::new(w, h);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        let (x, y) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
        let v = 10f64.powf(-2.5 + 5.0 * x / (w - 1) as f64) * (1.0 + 0.3 * (0.7 * y).sin());
        *p = [v as f32, (0.6 * v) as f32, (0.3 * v) as f32, 1.0];
    }
    img.pixels[77] = [f32::NAN; 4];
    for op in Operator::ALL {
        let at = |ev: f64| {
            let s = ToneMapSettings {
                exposure_ev: ev,
                ..settings(op)
            };
            tonemap_cpu(&img, &s).unwrap()
        };
        let base = at(0.0);
        for ev in [3.5, -2.0] {
            let other = at(ev);
            let largest = base
                .pixels
                .iter()
                .zip(&other.pixels)
                .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
                .fold(0.0f32, f32::max);
            if op.divides_out_exposure() {
                assert!(
                    largest <= 2e-6,
                    "{} at {ev} EV moved by {largest}",
                    op.name()
                );
            } else {
                assert!(
                    largest > 0.1,
                    "{} at {ev} EV moved only {largest}",
                    op.name()
                );
            }
        }
    }
}

#[test]
fn global_operators_are_monotonic_over_twelve_decades() {
    let n = 1201;
    let values: Vec<f32> = (0..n)
        .map(|i| 10f64.powf(-6.0 + 12.0 * i as f64 / (n - 1) as f64) as f32)
        .collect();
    let img = grey(&values, n as u32);
    for op in Operator::ALL.iter().filter(|op| !op.is_local()) {
        let out = out_lum(&tonemap_cpu(&img, &settings(*op)).unwrap());
        for i in 1..n {
            assert!(
                out[i] >= out[i - 1] - 1e-7,
                "{} not monotonic at {}: {} < {}",
                op.name(),
                values[i],
                out[i],
                out[i - 1]
            );
        }
        assert!(out[n - 1] > out[0], "{} is flat", op.name());
    }
}

fn hard_images() -> Vec<(&'static str, HdrImage)> {
    let mut outlier = vec![1e-3f32; 64];
    for (i, v) in outlier.iter_mut().enumerate() {
        *v *= 1.0 + (i % 7) as f32 * 0.1;
    }
    outlier[27] = 1e30;
    vec![
        ("all zeros", grey(&[0.0; 48], 8)),
        ("outlier", grey(&outlier, 8)),
        (
            "denormals",
            grey(&[1e-40, 3e-41, 1e-44, 0.0, 2e-39, 1e-42], 3),
        ),
        ("1x1", grey(&[0.5], 1)),
        ("0x0", HdrImage::new(0, 0)),
        ("1xN", grey(&[0.1, 10.0, 1e3, 0.0, 1e-4, 2.0, f32::NAN], 7)),
        (
            "Nx1",
            grey(&[0.1, 10.0, 1e3, 0.0, 1e-4, f32::INFINITY, 2.0], 1),
        ),
    ]
}

#[test]
fn hard_images_stay_finite_and_in_range() {
    for (name, img) in hard_images() {
        for op in Operator::ALL {
            for ev in [0.0, 40.0, -40.0] {
                let s = ToneMapSettings {
                    exposure_ev: ev,
                    ..settings(op)
                };
                let out = tonemap_cpu(&img, &s).unwrap();
                for (p, q) in out.pixels.iter().zip(&img.pixels) {
                    assert!(
                        p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
                        "{name} {} ev {ev}: {p:?}",
                        op.name()
                    );
                    if !q.iter().all(|v| v.is_finite()) {
                        assert_eq!(*p, [0.0; 4], "missing pixel must map to 0, alpha 0");
                    }
                }
            }
        }
    }
    // Among values near 1e-3 the 1e30 pixel maps to white and the rest stay visible.
    let (_, img) = &hard_images()[1];
    for op in [Operator::REINHARD, Operator::DRAGO, Operator::WARD] {
        let out = out_lum(&tonemap_cpu(img, &settings(op)).unwrap());
        assert!(out[27] > 0.99, "{}: {}", op.name(), out[27]);
        assert!(out[0] > 0.005, "{}: {}", op.name(), out[0]);
    }
    // Reinhard: the outlier lifts mean ln L by about (ln 1e30 - ln 1.3e-3) / 64 = 1.18, so
    // a 1e-3 pixel gets L = 0.18 e^-1.18 (1e-3 / 1.3e-3), about 0.04, and L_white is huge.
    let out = out_lum(&tonemap_cpu(img, &settings(Operator::REINHARD)).unwrap());
    let stats = luminance_log_stats(img, 0.0).unwrap();
    let l = 0.18 * ((1e-3f32 as f64).ln() - stats.mean_log).exp();
    assert!(
        (out[0] - l / (1.0 + l)).abs() < 1e-6,
        "{} vs {}",
        out[0],
        l / (1.0 + l)
    );
}

#[test]
fn log_average_of_tiny_values_is_exact() {
    // Alternating 4e-30 and 0.25e-30 (powers of two times f32(1e-30)): the geometric mean
    // is f32(1e-30) exactly. 2^18 pixels exercise the pairwise sum.
    let tiny = 1e-30f32;
    let values: Vec<f32> = (0..1 << 18)
        .map(|i| if i % 2 == 0 { tiny * 4.0 } else { tiny * 0.25 })
        .collect();
    let img = grey(&values, 512);
    let stats = luminance_log_stats(&img, 0.0).unwrap();
    let expected = (tiny as f64).ln();
    assert!(
        (stats.mean_log - expected).abs() < 1e-12 * expected.abs(),
        "{} vs {expected}",
        stats.mean_log
    );
    // The same holds for f32 denormals (1e-42 < f32's smallest normal 1.2e-38).
    let denormal = grey(&[1e-42, 4e-42, 1e-42, 4e-42], 2);
    let stats = luminance_log_stats(&denormal, 0.0).unwrap();
    let expected = ((1e-42f32 as f64) * (4e-42f32 as f64)).sqrt().ln();
    assert!((stats.mean_log - expected).abs() < 1e-12 * expected.abs());
    // And Reinhard is then independent of the data's units.
    let scaled: Vec<f32> = values.iter().map(|v| v * 1e30).collect();
    let a = tonemap_cpu(&img, &settings(Operator::REINHARD)).unwrap();
    let b = tonemap_cpu(&grey(&scaled, 512), &settings(Operator::REINHARD)).unwrap();
    assert!((a.pixels[0][0] - b.pixels[0][0]).abs() < 1e-6);
    assert!((a.pixels[1][0] - b.pixels[1][0]).abs() < 1e-6);
}

#[test]
fn log_statistics_are_the_same_on_any_number_of_threads() {
    // 2^18 + 123 pixels over five decades, a few missing: 17 chunks of the statistics' fixed
    // size, the last one short. One thread and three must give the same bits, and the mean
    // must be that of the logarithms summed exactly (as f64 values, in i128 fixed point).
    let values: Vec<f32> = (0..(1usize << 18) + 123)
        .map(|i| match i % 997 {
            0 => f32::NAN,
            k => 10f32.powf(-3.0 + 5.0 * k as f32 / 997.0),
        })
        .collect();
    let img = grey(&values, 1);
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| luminance_log_stats(&img, 0.0).unwrap())
    };
    let (one, three) = (on(1), on(3));
    assert_eq!(one, three);
    let logs: Vec<f64> = img
        .pixels
        .iter()
        .map(|p| {
            let v = p[0] as f64;
            0.2126 * v + 0.7152 * v + 0.0722 * v
        })
        .filter(|l| l.is_finite())
        .map(f64::ln)
        .collect();
    assert_eq!(one.count, logs.len());
    let fixed: i128 = logs.iter().map(|l| (l * 2f64.powi(80)) as i128).sum();
    let exact = fixed as f64 / 2f64.powi(80) / logs.len() as f64;
    assert!((one.mean_log - exact).abs() < 1e-14 * exact.abs().max(1.0));
    let max = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = logs.iter().copied().fold(f64::INFINITY, f64::min);
    assert_eq!((one.max_log, one.min_log), (max, min));
}

#[test]
fn missing_pixels_do_not_spread_through_local_blurs() {
    let (w, h) = (64usize, 64usize);
    let mut values: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            10f64.powf(2.0 * (x / 7.0).sin() * (y / 9.0).cos()) as f32
        })
        .collect();
    let hole = 3 * w + 3;
    // Without the NaN, the hole holds the others' geometric mean, so Lbar is unchanged.
    let others: Vec<f64> = (0..w * h)
        .filter(|&i| i != hole)
        .map(|i| (values[i] as f64).ln())
        .collect();
    values[hole] = (others.iter().sum::<f64>() / others.len() as f64).exp() as f32;
    let clean = grey(&values, w as u32);
    values[hole] = f32::NAN;
    let holed = grey(&values, w as u32);
    for op in [Operator::REINHARD_LOCAL, Operator::DURAND] {
        let a = tonemap_cpu(&clean, &settings(op)).unwrap();
        let b = tonemap_cpu(&holed, &settings(op)).unwrap();
        assert_eq!(b.pixels[hole], [0.0; 4]);
        for (i, p) in b.pixels.iter().enumerate() {
            assert!(p.iter().all(|v| v.is_finite()), "{} spread NaN", op.name());
            let (x, y) = (i % w, i / w);
            if x > 40 || y > 40 {
                // Reinhard's widest surround: sigma 10.6 px, window 32 px; Durand's 3 px.
                for (got, want) in p.iter().zip(&a.pixels[i]) {
                    assert!(
                        (got - want).abs() < 1e-5,
                        "{} at ({x}, {y}): {got} vs {want}",
                        op.name()
                    );
                }
            }
        }
    }
}

#[test]
fn local_operators_reduce_to_sensible_values() {
    // A uniform image: every surround equals the centre, so Reinhard local selects the
    // largest scale and L_d = L / (1 + L) with L = key = 0.18 -> 0.152542.
    let img = grey(&[3.0; 100], 10);
    let out = tonemap_cpu(&img, &settings(Operator::REINHARD_LOCAL)).unwrap();
    assert!((out.pixels[55][0] as f64 - 0.18 / 1.18).abs() < 1e-6);
    // Durand on a uniform image: base = log10 3, no detail, base max maps to 1.
    let out = tonemap_cpu(&img, &settings(Operator::DURAND)).unwrap();
    assert!((out.pixels[55][0] - 1.0).abs() < 1e-6);
}

#[test]
fn durand_compresses_the_base_to_the_target_contrast() {
    // Two flat halves 10^4 apart: the bilateral base keeps the step (range weight at
    // 4 / 0.4 = 10 sigma is e^-50), so the halves come out log10(5) apart: 1 and 0.2.
    let (w, h) = (40u32, 8u32);
    let values: Vec<f32> = (0..w * h)
        .map(|i| if i % w < w / 2 { 1e-2 } else { 1e2 })
        .collect();
    let out = tonemap_cpu(&grey(&values, w), &settings(Operator::DURAND)).unwrap();
    assert!((out.pixels[(w + w - 1) as usize][0] - 1.0).abs() < 1e-5);
    assert!(
        (out.pixels[w as usize][0] - 0.2).abs() < 1e-5,
        "{}",
        out.pixels[w as usize][0]
    );
}

#[test]
fn saturation_and_colour_ratio() {
    // C_d = (C / L_w)^s L_d: with s = 0 every channel equals L_d.
    let img = HdrImage::from_pixels(1, 1, vec![[0.3, 0.1, 0.05, 1.0]]);
    let lw = 0.2126 * 0.3 + 0.7152 * 0.1 + 0.0722 * 0.05;
    let s = ToneMapSettings {
        saturation: 0.0,
        ..settings(Operator::Linear)
    };
    let out = tonemap_cpu(&img, &s).unwrap();
    for k in 0..3 {
        assert!((out.pixels[0][k] as f64 - lw).abs() < 1e-7);
    }
    let out = tonemap_cpu(&img, &settings(Operator::Linear)).unwrap();
    assert!((out.pixels[0][0] - 0.3).abs() < 1e-7);
    // Offset then gamma on the display side: (0.3 - 0.1)^(1 / 2) = 0.4472136.
    let s = ToneMapSettings {
        offset: -0.1,
        gamma: 2.0,
        ..settings(Operator::Linear)
    };
    let out = tonemap_cpu(&img, &s).unwrap();
    assert!((out.pixels[0][0] - 0.447_213_6).abs() < 1e-6);
    assert_eq!(out.pixels[0][2], 0.0); // 0.05 - 0.1 clamps to 0
}

#[test]
fn auto_exposure_hits_key_and_percentile() {
    let img = grey(&[0.01, 0.1, 1.0, 10.0], 4);
    // Lbar = 10^-0.5 -> EV = log2(0.18 / 10^-0.5).
    let ev = auto_exposure_key(&img, 0.18).unwrap();
    assert!((ev - (0.18f64 / 10f64.powf(-0.5)).log2()).abs() < 1e-6);
    // The 50th percentile by nearest rank is the 2nd of 4 values, 0.1.
    let ev = auto_exposure_percentile(&img, 50.0, 0.5).unwrap();
    assert!((ev - (0.5f64 / 0.1).log2()).abs() < 1e-6);
    assert_eq!(auto_exposure_key(&grey(&[0.0], 1), 0.18).unwrap(), 0.0);
    assert!(auto_exposure_key(&img, 0.0).is_err());
}

#[test]
fn false_colour_maps_decades_and_draws_a_legend() {
    let values: Vec<f32> = (0..32 * 32)
        .map(|i| 10f32.powf(-2.0 + 4.0 * (i % 32) as f32 / 31.0))
        .collect();
    let mut img = grey(&values, 32);
    img.pixels[0] = [f32::NAN; 4];
    let out = false_colour_log10(&img, 0.0, None).unwrap();
    assert_eq!(out.meta("false_colour.log10_min"), Some("-2"));
    assert_eq!(out.meta("false_colour.log10_max"), Some("2"));
    // Its colour bar labels the decades 0.01 to 100.
    let bar = crate::model::text::ColourBar::of(&out).unwrap();
    let labels: Vec<String> = bar.ticks(10).into_iter().map(|(_, l)| l).collect();
    assert_eq!(labels, ["0.01", "0.1", "1", "10", "100"]);
    assert_eq!(
        out.pixels[0],
        [MISSING_GREY, MISSING_GREY, MISSING_GREY, 1.0]
    );
    // Pixel (31, 0) is at 10^2, the top of the map.
    let top = turbo_linear(1.0);
    assert!((0..3).all(|k| (out.pixels[31][k] - top[k]).abs() < 1e-6));
    // The legend's bottom row has white ticks at the 5 decades, including both ends.
    let last = &out.pixels[31 * 32..];
    let ticks = last.iter().filter(|p| p[..3] == [1.0, 1.0, 1.0]).count();
    assert_eq!(ticks, 5);
    assert!(out.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
}

#[test]
fn invalid_parameters_name_the_field_and_range() {
    let err = |r: Result<Operator>| r.unwrap_err().to_string();
    assert!(err(Operator::parse("reinhard", &[("key", 0.0)])).starts_with("reinhard.key:"));
    assert!(err(Operator::parse("reinhard", &[("white", -1.0)])).starts_with("reinhard.white:"));
    assert!(err(Operator::parse("drago", &[("bias", 1.5)])).contains("(0, 1]"));
    assert!(err(Operator::parse("drago", &[("bias", 0.0)])).contains("(0, 1]"));
    let unknown = err(Operator::parse("mantiuk", &[]));
    for name in Operator::NAMES {
        assert!(unknown.contains(name), "{unknown}");
    }
    assert!(err(Operator::parse("ward", &[("key", 1.0)])).contains("ld_min, ld_max, bins"));
    let bad = |s: ToneMapSettings| s.validate().unwrap_err().to_string();
    let ok = ToneMapSettings::default();
    assert!(bad(ToneMapSettings {
        exposure_ev: f64::NAN,
        ..ok
    })
    .starts_with("exposure_ev:"));
    assert!(bad(ToneMapSettings {
        saturation: -0.1,
        ..ok
    })
    .starts_with("saturation:"));
    let img = grey(&[1.0], 1);
    assert!(tonemap_cpu(
        &img,
        &ToneMapSettings {
            exposure_ev: f64::INFINITY,
            ..ok
        }
    )
    .is_err());
    for name in Operator::NAMES {
        assert_eq!(Operator::parse(name, &[]).unwrap().name(), name);
    }
}

#[test]
fn every_tonemap_shader_parses_and_validates() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders/tonemap");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("wgsl") {
            continue;
        }
        // Through the project's loader, which resolves `#include "shared/..."`.
        let name = format!("tonemap/{}", path.file_name().unwrap().to_string_lossy());
        let source = crate::gpu::shader::load(&name, &[]).unwrap();
        let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| {
            panic!(
                "{}",
                e.emit_to_string_with_path(&source, &path.display().to_string())
            )
        });
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
        // The Rust mirrors must keep the WGSL structs' sizes and member counts.
        for ty in module.types.iter().map(|(_, ty)| ty) {
            let expected = match ty.name.as_deref() {
                Some("ToneMapParams") => {
                    Some((size_of::<crate::tonemap::params::ToneMapParams>(), 36))
                }
                Some("LuminanceStats") => {
                    Some((size_of::<crate::tonemap::params::LuminanceStats>(), 4))
                }
                _ => None,
            };
            if let (Some((size, count)), naga::TypeInner::Struct { members, span }) =
                (expected, &ty.inner)
            {
                assert_eq!(
                    (*span as usize, members.len()),
                    (size, count),
                    "{}",
                    path.display()
                );
            }
        }
        checked += 1;
    }
    assert!(checked >= 6, "only {checked} shaders in {}", dir.display());
}

/// Relative errors of `got` against `exact` display luminance (exact values below 1e-3 count
/// as 1e-3): (RMS, largest, fraction above 1 %).
fn relative_errors(got: &[f64], exact: &[f64]) -> (f64, f64, f64) {
    let rel: Vec<f64> = got
        .iter()
        .zip(exact)
        .map(|(g, e)| (g - e).abs() / e.max(1e-3))
        .collect();
    let rms = (rel.iter().map(|r| r * r).sum::<f64>() / rel.len() as f64).sqrt();
    let max = rel.iter().copied().fold(0.0, f64::max);
    let beyond = rel.iter().filter(|r| **r > 0.01).count() as f64 / rel.len() as f64;
    (rms, max, beyond)
}

/// Durand with sigma_s 5 % of a 128-pixel side: 6.4 px, so the grid's cells are 3 pixels and
/// lights of 1 and 2 pixels are smaller than a cell.
const DURAND_ON_CELLS: Operator = Operator::DurandBilateral {
    contrast: 5.0,
    sigma_spatial: 0.05,
    sigma_range: 0.4,
};

#[test]
fn local_operators_stay_near_their_exact_definitions_on_lights_from_one_pixel() {
    use super::exact::lit_scene;
    for n in [1u32, 2, 4, 16] {
        let img = lit_scene(128, n, 0);
        for (op, rms_bound, max_bound) in [
            (DURAND_ON_CELLS, 3e-3, 1e-2),
            (Operator::REINHARD_LOCAL, 1e-3, 1e-2),
        ] {
            let fast = out_lum(&tonemap_cpu(&img, &settings(op)).unwrap());
            let exact = tonemap_cpu_with(&img, &settings(op), Filters::Exact).unwrap();
            let (rms, max, beyond) = relative_errors(&fast, &out_lum(&exact));
            assert!(
                rms < rms_bound && max < max_bound && beyond == 0.0,
                "{} on {n}-pixel lights: relative RMS {rms:.2e}, largest {max:.2e}, \
                 beyond 1 %: {beyond:.2e}",
                op.name()
            );
        }
    }
}

#[test]
fn reinhard_local_scale_choice_stays_near_full_resolution_gaussians_on_noise() {
    // Four decades of white noise put some pixels' activity at epsilon for every scale: the
    // pyramid may flip their choice, on few pixels.
    let img = super::exact::noise_scene(128, 7);
    let op = Operator::REINHARD_LOCAL;
    let fast = out_lum(&tonemap_cpu(&img, &settings(op)).unwrap());
    let exact = out_lum(&tonemap_cpu_with(&img, &settings(op), Filters::Exact).unwrap());
    let (rms, max, beyond) = relative_errors(&fast, &exact);
    assert!(
        rms < 6e-3 && max < 0.2 && beyond < 0.02,
        "rms {rms:.2e}, largest {max:.2e}, beyond 1 % {beyond:.2e}"
    );
}

#[test]
fn a_light_moving_by_one_pixel_leaves_the_background_alone() {
    use super::exact::lit_scene;
    // Background is at most 2, lights 500 and up.
    let is_background = |img: &HdrImage, p: usize| img.pixels[p][0] < 10.0;
    for n in [1u32, 2, 4] {
        for op in [DURAND_ON_CELLS, Operator::REINHARD_LOCAL] {
            let background_mean = |shift: u32| {
                let img = lit_scene(128, n, shift);
                let out = out_lum(&tonemap_cpu(&img, &settings(op)).unwrap());
                let far: Vec<f64> = (0..out.len())
                    .filter(|&p| is_background(&img, p) && p % 128 < 16)
                    .map(|p| out[p])
                    .collect();
                far.iter().sum::<f64>() / far.len() as f64
            };
            let still = background_mean(0);
            for shift in 1..=3 {
                let change = (background_mean(shift) / still - 1.0).abs();
                assert!(
                    change < 1e-3,
                    "{} with {n}-pixel lights moved {shift} px: background changes by {change:.2e}",
                    op.name()
                );
            }
        }
    }
}

#[test]
fn durand_splat_holds_every_level_the_grid_may_have() {
    let source = crate::gpu::shader::load("tonemap/durand_bilateral.wgsl", &[]).unwrap();
    let declared = format!(
        "const MAX_LEVELS: u32 = {}u;",
        crate::tonemap::params::DURAND_MAX_LEVELS
    );
    assert!(source.contains(&declared), "{declared} missing");
}

/// The turbo map's colours are 8-bit codes, so `decode_srgb_f32`'s table serves them.
#[test]
fn turbo_gives_8_bit_codes() {
    use colorgrad::Gradient;
    let map = colorgrad::preset::turbo();
    let on_codes = (0..=1000).all(|i| {
        let c = map.at(i as f32 / 1000.0);
        [c.r, c.g, c.b]
            .iter()
            .all(|&v| (v * 255.0).round() / 255.0 == v)
    });
    assert!(on_codes, "colorgrad's turbo no longer gives 8-bit codes");
}

/// Saturation and gamma of 1 skip the power: the same bits as libm's pow(x, 1) over every
/// binade of the values they see (colour ratios and display values), subnormals and 0 included.
#[test]
fn a_power_of_one_is_the_value_itself() {
    let (one, other) = (power(1.0), power(1.0 / 2.2));
    let normals = (-1022..=1023).flat_map(|e| {
        [1.0, 1.1, 1.5, 1.999_999_9]
            .into_iter()
            .map(move |m| m * 2f64.powi(e))
    });
    let subnormals = [1u64, 12_345, 1 << 51].map(f64::from_bits);
    let values: Vec<f64> = normals.chain(subnormals).chain([0.0]).collect();
    for &x in &values {
        assert_eq!(one(x).to_bits(), x.powf(1.0).to_bits(), "{x:e}");
        assert_eq!(other(x).to_bits(), x.powf(1.0 / 2.2).to_bits(), "{x:e}");
    }
    assert_eq!(values.len(), 4 * 2046 + 4);
}

/// Reinhard's local operator as written: every V_i by brute force (a full-resolution
/// normalised Gaussian, the square window of the separable one), then per pixel the scan from
/// the finest scale that stops at the first activity of epsilon or more.
fn reinhard_local_by_definition(scene: &Scene, mean_log: f64, p: &ReinhardLocal) -> Vec<f64> {
    use crate::tonemap::params::{blur_sigma, gaussian_radius};
    let (w, h) = (scene.width as isize, scene.height as isize);
    let scaled = |i: usize| p.key * (scene.lum[i].ln() - mean_log).exp();
    let v = |scale: u32, x: isize, y: isize| {
        let sigma = blur_sigma(p.alpha1, p.ratio, scale);
        let r = gaussian_radius(sigma) as isize;
        let (mut num, mut den) = (0.0, 0.0);
        for qy in (y - r).max(0)..(y + r + 1).min(h) {
            for qx in (x - r).max(0)..(x + r + 1).min(w) {
                let q = (qy * w + qx) as usize;
                if scene.lum[q].is_nan() {
                    continue;
                }
                let d2 = ((qx - x).pow(2) + (qy - y).pow(2)) as f64;
                let g = (-d2 / (2.0 * sigma * sigma)).exp();
                num += g * scaled(q);
                den += g;
            }
        }
        num / den
    };
    let sharpness = p.phi.exp2() * p.key;
    (0..scene.lum.len())
        .map(|i| {
            if scene.lum[i].is_nan() {
                return f64::NAN;
            }
            let (x, y) = ((i % scene.width) as isize, (i / scene.width) as isize);
            let mut chosen = v(0, x, y);
            for k in 0..p.scales {
                let (v1, v2) = (v(k, x, y), v(k + 1, x, y));
                let s2 = p.ratio.powi(k as i32).powi(2);
                if ((v1 - v2) / (sharpness / s2 + v1)).abs() >= p.epsilon {
                    break;
                }
                chosen = v1;
            }
            scaled(i) / (1.0 + chosen)
        })
        .collect()
}

#[test]
fn reinhard_local_scans_the_scales_as_defined() {
    // Noise over four decades with a missing pixel; epsilon such that nearly every pixel stops
    // at the first scale (the scan ends early), the paper's, and one that never stops.
    let mut img = super::exact::noise_scene(40, 11);
    img.pixels[5 * 40 + 7] = [f32::NAN; 4];
    let scene = Scene::new(&img, 0.0);
    let stats = luminance_log_stats(&img, 0.0).unwrap();
    for epsilon in [1e-9, 0.05, 1e3] {
        let p = ReinhardLocal {
            key: 0.18,
            alpha1: 0.35,
            ratio: 1.6,
            phi: 8.0,
            epsilon,
            scales: 8,
        };
        let got = reinhard_local(&scene, &stats, &p, Filters::Exact);
        let want = reinhard_local_by_definition(&scene, stats.mean_log, &p);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (g.is_nan() && w.is_nan()) || (g - w).abs() <= 1e-12 * w.abs(),
                "epsilon {epsilon}, pixel {i}: {g} against {w}"
            );
        }
    }
}
