//! Scenes of the volume benchmark that are not ours: what a user of VTK or ParaView sets up
//! first, with transfer functions made of piecewise-linear ramps in the data value (as theirs
//! are) rather than hdrvis's log-scaled tables. `linear`: a smooth field, every voxel emitting
//! and absorbing in proportion to its value. `opaque`: the same field under a steep opacity step,
//! so rays stop at an isosurface-like wall and the space in front of it is empty. `sparse`: a few
//! small blobs in empty space. `dense`: fractal noise in which every voxel contributes and
//! neighbouring rays share little. All on [0, 1] values, emission per voxel at most 1 (what a
//! peer's display colours can hold), so the peers are given the same optical model exactly.

use crate::error::Result;
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Scale, TransferFunction, Volume};
use std::f64::consts::TAU;
use std::sync::Arc;

/// The smooth field of `linear` and `opaque` at voxel (x, y, z) of an n³ grid: low-frequency
/// waves in [0, 1].
fn smooth(n: usize, x: f64, y: f64, z: f64) -> f64 {
    let f = n as f64;
    let (u, v, w) = (x / f, y / f, z / f);
    let a = (TAU * (2.0 * u + 0.1)).sin() * (TAU * 3.0 * v).cos();
    let b = (TAU * (2.5 * w + u)).sin() * (TAU * (1.5 * v - 0.2 * w)).cos();
    (0.5 + 0.25 * a + 0.25 * b).clamp(0.0, 1.0)
}

/// A deterministic hash of a lattice point to [0, 1).
fn lattice(i: i64, j: i64, k: i64, seed: u64) -> f64 {
    let mut h = seed ^ 0x9e37_79b9_7f4a_7c15;
    for c in [i, j, k] {
        h ^= c as u64;
        h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h ^= h >> 31;
    }
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Value noise: the lattice hashed at integer points, trilinear (smoothstepped) between.
fn value_noise(x: f64, y: f64, z: f64, seed: u64) -> f64 {
    let (i, j, k) = (x.floor(), y.floor(), z.floor());
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (fx, fy, fz) = (s(x - i), s(y - j), s(z - k));
    let (i, j, k) = (i as i64, j as i64, k as i64);
    let mut sum = 0.0;
    for (di, wx) in [(0, 1.0 - fx), (1, fx)] {
        for (dj, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (dk, wz) in [(0, 1.0 - fz), (1, fz)] {
                sum += wx * wy * wz * lattice(i + di, j + dj, k + dk, seed);
            }
        }
    }
    sum
}

/// The `dense` field: four octaves of value noise, the finest with a period of 4 voxels, in
/// [0, 1].
fn fractal(x: f64, y: f64, z: f64) -> f64 {
    let mut total = 0.0;
    for octave in 0..4 {
        let scale = 32.0 / f64::from(1 << octave);
        let weight = 0.5f64.powi(octave);
        total += weight * value_noise(x / scale, y / scale, z / scale, 7 + octave as u64);
    }
    total / 1.875
}

/// The `sparse` field: 24 small Gaussian blobs (σ = n/50) at deterministic places, in [0, 1].
fn blobs(n: usize, x: f64, y: f64, z: f64) -> f64 {
    let f = n as f64;
    let sigma = f / 50.0;
    let mut v: f64 = 0.0;
    for b in 0..24 {
        let c = |axis: i64| (0.1 + 0.8 * lattice(b, axis, 0, 3)) * f;
        let d2 = (x - c(0)).powi(2) + (y - c(1)).powi(2) + (z - c(2)).powi(2);
        if d2 < 25.0 * sigma * sigma {
            v = v.max((-d2 / (2.0 * sigma * sigma)).exp());
        }
    }
    v
}

/// The volume of scene `name` at n³.
pub(crate) fn volume(name: &str, n: usize) -> Result<Volume> {
    let title = format!("{name} {n}^3");
    match name {
        "linear" | "opaque" => Volume::from_fn(&title, [n; 3], |x, y, z| smooth(n, x, y, z)),
        "sparse" => Volume::from_fn(&title, [n; 3], |x, y, z| blobs(n, x, y, z)),
        _ => Volume::from_fn(&title, [n; 3], fractal),
    }
}

/// A linear ramp through the points (value, y), flat beyond the ends.
fn ramp(points: &[(f64, f64)], v: f64) -> f64 {
    let i = points.partition_point(|p| p.0 <= v);
    if i == 0 {
        return points[0].1;
    }
    if i == points.len() {
        return points[i - 1].1;
    }
    let ((a, ya), (b, yb)) = (points[i - 1], points[i]);
    ya + (yb - ya) * (v - a) / (b - a)
}

/// The transfer function of scene `name`: emission (linear RGB) and extinction per voxel as
/// piecewise-linear ramps in the value, baked onto hdrvis's table over [0, 1].
pub(crate) fn transfer(name: &str) -> Result<TransferFunction> {
    let f: Box<dyn Fn(f64) -> ([f64; 3], f64)> = match name {
        // Every voxel emits and absorbs in proportion to its value: an optical depth of about
        // 2.5 across 256 voxels, so rays run through the whole volume.
        "linear" => Box::new(|v| ([0.05 * v, 0.03, 0.05 * (1.0 - v)], 0.02 * v)),
        // Nothing below 0.6, an opaque wall from 0.62 (alpha 1 − e⁻⁸ per voxel).
        "opaque" => Box::new(|v| {
            let s = ramp(&[(0.6, 0.0), (0.62, 8.0)], v);
            ([0.9, 0.8, 0.6].map(|c| c * s.min(1.0)), s)
        }),
        // Nothing below 0.05: the blobs alone.
        "sparse" => Box::new(|v| {
            let s = ramp(&[(0.05, 0.0), (1.0, 0.3)], v);
            ([1.0, 0.6, 0.2].map(|c| c * s.min(1.0)), s)
        }),
        // Every voxel contributes, more where the noise is high.
        _ => Box::new(|v| ([0.2 * v, 0.1, 0.2 * (1.0 - v)], 0.005 + 0.03 * v)),
    };
    let table = ResolvedTransfer::from_functions(Scale::Linear, [0.0, 1.0], f)?;
    Ok(TransferFunction::Table(Arc::new(table)))
}

/// The names of the scenes that are not ours, in the order the benchmark runs them.
pub(crate) const PEER_SCENES: [&str; 4] = ["linear", "opaque", "sparse", "dense"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fields_span_what_their_transfer_functions_read() {
        let n = 48;
        for name in PEER_SCENES {
            let v = volume(name, n).unwrap();
            let (lo, hi) = v
                .data
                .iter()
                .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(lo >= 0.0 && hi <= 1.0, "{name}: [{lo}, {hi}]");
            let tf = transfer(name).unwrap().resolve(&v.stats()).unwrap();
            // Emission a peer's display colours can hold exactly.
            for k in 0..=20 {
                let (e, s) = tf.eval(k as f64 / 20.0);
                assert!(
                    e.iter().all(|c| (0.0..=1.0).contains(c)) && s >= 0.0,
                    "{name}"
                );
            }
            let empty = v
                .data
                .iter()
                .filter(|&&x| tf.eval(x as f64).1 == 0.0)
                .count();
            let share = empty as f64 / v.data.len() as f64;
            match name {
                "sparse" => assert!(share > 0.9, "{name}: {share}"),
                "opaque" => assert!(share > 0.3 && share < 0.9, "{name}: {share}"),
                _ => assert!(share < 0.01, "{name}: {share}"),
            }
        }
        // The opaque wall: alpha 1 − e⁻⁸ per voxel above 0.62.
        let tf = transfer("opaque")
            .unwrap()
            .resolve(&volume("opaque", 8).unwrap().stats());
        assert!((tf.unwrap().eval(0.7).1 - 8.0).abs() < 1e-9);
    }
}
