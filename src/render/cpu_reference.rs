//! The f64 CPU reference of the volume ray caster: the same rays, segments, trilinear sampling,
//! transfer function and emission–absorption integral as `shaders/volume.wgsl`, in double
//! precision, point-sampled or pre-integrated. Tests compare the GPU with it and with closed
//! forms; the accuracy report uses it as ground truth. It is not a user path.

use super::{jitter_fraction, TfSampling, VolumeRenderOptions};
use crate::error::Result;
use crate::model::camera::sub;
use crate::model::{Aabb, HdrImage, Volume};
use rayon::prelude::*;

/// (1 - exp(-x)) / x, computed without cancellation; 1 at x = 0.
fn escape_fraction(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        -(-x).exp_m1() / x
    }
}

/// Renders `volume` in f64. Pixels are returned as f32 only at the very end.
pub fn render_volume_cpu(volume: &Volume, opts: &VolumeRenderOptions) -> Result<HdrImage> {
    let img = render_volume_f64(volume, opts)?;
    let pixels = img.into_iter().map(|p| p.map(|v| v as f32)).collect();
    Ok(HdrImage::from_pixels(opts.width, opts.height, pixels))
}

/// The reference in full precision, row-major RGBA.
pub fn render_volume_f64(volume: &Volume, opts: &VolumeRenderOptions) -> Result<Vec<[f64; 4]>> {
    opts.validate()?;
    let tf = opts.tf.resolve(&volume.stats())?;
    let bounds = volume.bounds();
    let local = Aabb {
        lo: [0.0; 3],
        hi: bounds.size(),
    };
    let voxel = volume.voxel_length();
    let ds = opts.step * voxel;
    let stop_tau = opts.stop_optical_depth();
    let preintegrated = opts.tf_sampling == TfSampling::PreIntegrated;
    let integral = if preintegrated {
        tf.table_integral()
    } else {
        Vec::new()
    };
    let (w, h) = (opts.width, opts.height);
    let pixels = (0..h)
        .into_par_iter()
        .flat_map_iter(|py| {
            let (tf, integral) = (&tf, &integral);
            (0..w).map(move |px| {
                let (o, d) = opts.camera.ray(px, py, w, h);
                let o = sub(o, bounds.lo);
                let mut tau = 0.0f64;
                let mut color = [0.0f64; 3];
                if let Some((t0, t1)) = local.intersect(o, d) {
                    let t_enter = t0.max(0.0);
                    if t1 > t_enter {
                        let first = if opts.jitter {
                            ds * (1.0 - jitter_fraction(px, py, w, h, opts.seed))
                        } else {
                            ds
                        };
                        let span = t1 - t_enter;
                        let n = if span > first {
                            ((span - first) / ds).ceil() as u64 + 1
                        } else {
                            1
                        };
                        let at = |t: f64| {
                            [
                                bounds.lo[0] + o[0] + d[0] * t,
                                bounds.lo[1] + o[1] + d[1] * t,
                                bounds.lo[2] + o[2] + d[2] * t,
                            ]
                        };
                        let mut ta = t_enter;
                        // Pre-integration reads the value at segment ends, the front one carried.
                        let mut front = if preintegrated {
                            volume.sample_trilinear(at(t_enter))
                        } else {
                            f64::NAN
                        };
                        for k in 0..n {
                            let tb = (t_enter + first + k as f64 * ds).min(t1);
                            let mid = 0.5 * (ta + tb);
                            let mut len = (tb - ta) / voxel;
                            ta = tb;
                            let p = at(mid);
                            let (mut e, a) = if preintegrated {
                                let back = volume.sample_trilinear(at(tb));
                                let pair = (front, back);
                                front = back;
                                match (pair.0.is_finite(), pair.1.is_finite()) {
                                    (true, true) => tf.segment_mean(integral, pair.0, pair.1),
                                    (false, false) => continue,
                                    // The edge of missing data taken at the middle: the half
                                    // next to the finite end carries its value.
                                    (true, false) | (false, true) => {
                                        len *= 0.5;
                                        tf.eval(if pair.0.is_finite() { pair.0 } else { pair.1 })
                                    }
                                }
                            } else {
                                let v = volume.sample_trilinear(p);
                                if !v.is_finite() {
                                    continue;
                                }
                                tf.eval(v)
                            };
                            if let Some(sh) = &opts.shading {
                                if e.iter().any(|&c| c > 0.0) {
                                    let f = sh.factor(volume.gradient(p), d);
                                    e = e.map(|c| c * f);
                                }
                            }
                            let x = a * len;
                            let weight = (-tau).exp() * len * escape_fraction(x);
                            for c in 0..3 {
                                color[c] += weight * e[c];
                            }
                            tau += x;
                            if tau > stop_tau {
                                break;
                            }
                        }
                    }
                }
                let t = (-tau).exp();
                [
                    color[0] + t * opts.background[0],
                    color[1] + t * opts.background[1],
                    color[2] + t * opts.background[2],
                    -(-tau).exp_m1(),
                ]
            })
        })
        .collect();
    Ok(pixels)
}
