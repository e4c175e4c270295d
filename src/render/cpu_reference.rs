//! The f64 CPU reference of the volume ray caster: the same rays, segments, trilinear sampling,
//! transfer function and emission–absorption integral as `shaders/volume.wgsl`, in double
//! precision, point-sampled or pre-integrated. Tests compare the GPU with it and with closed
//! forms; the accuracy report uses it as ground truth. It is not a user path.

use super::{jitter_fraction, TfSampling, VolumeRenderOptions};
use crate::error::Result;
use crate::model::cut::FACE_PROBE;
use crate::model::transfer::ResolvedTransfer;
use crate::model::vec3::sub;
use crate::model::{Aabb, Geometry, HdrImage, Volume};
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
pub(crate) fn render_volume_cpu(volume: &Volume, opts: &VolumeRenderOptions) -> Result<HdrImage> {
    let img = render_volume_f64(volume, opts)?;
    let pixels = img.into_iter().map(|p| p.map(|v| v as f32)).collect();
    Ok(HdrImage::from_pixels(opts.width, opts.height, pixels))
}

/// The reference in full precision, row-major RGBA.
pub fn render_volume_f64(volume: &Volume, opts: &VolumeRenderOptions) -> Result<Vec<[f64; 4]>> {
    opts.validate()?;
    let tf = opts.tf.resolve(&volume.stats())?;
    let bounds = volume.bounds();
    let preintegrated = opts.tf_sampling == TfSampling::PreIntegrated;
    let rings = match &opts.cut_faces {
        Some(f) => f.rings(volume, &opts.camera, opts.height)?,
        None => (Vec::new(), 0.0),
    };
    let tracer = Tracer {
        rings,
        volume,
        opts,
        integral: if preintegrated {
            tf.table_integral()
        } else {
            Vec::new()
        },
        tf,
        local: Aabb {
            lo: [0.0; 3],
            hi: bounds.size(),
        },
        bounds,
        voxel: volume.voxel_length(),
        ds: opts.step * volume.voxel_length(),
        stop_tau: opts.stop_optical_depth(),
        preintegrated,
    };
    let (w, h) = (opts.width, opts.height);
    Ok((0..h)
        .into_par_iter()
        .flat_map_iter(|py| {
            let tracer = &tracer;
            (0..w).map(move |px| tracer.pixel(px, py))
        })
        .collect())
}

/// What every ray of one reference render shares.
struct Tracer<'a> {
    volume: &'a Volume,
    opts: &'a VolumeRenderOptions,
    tf: ResolvedTransfer,
    /// The table's running integral (pre-integration only).
    integral: Vec<[f64; 4]>,
    bounds: Aabb,
    /// The volume's box with its corner at the origin.
    local: Aabb,
    voxel: f64,
    ds: f64,
    stop_tau: f64,
    preintegrated: bool,
    /// The radii of the depth rings on cut faces and the half width of their lines.
    rings: (Vec<f64>, f64),
}

impl Tracer<'_> {
    /// The composited pixel: premultiplied colour over the background, and alpha.
    fn pixel(&self, px: u32, py: u32) -> [f64; 4] {
        let (w, h) = (self.opts.width, self.opts.height);
        let (o, d) = self.opts.camera.ray(px, py, w, h);
        let (color, tau) = match &self.volume.geometry {
            Geometry::Regular => {
                // In the box's frame, as the shader marches (the cut is in world coordinates,
                // the ray's parameter the same in both).
                let local = sub(o, self.bounds.lo);
                match self.local.intersect(local, d) {
                    Some((t0, t1)) if t1 > t0.max(0.0) => {
                        self.march_box(px, py, (o, local), d, (t0.max(0.0), t1))
                    }
                    _ => ([0.0; 3], 0.0),
                }
            }
            Geometry::Rectilinear(_) => match self.bounds.intersect(o, d) {
                Some((t0, t1)) if t1 > t0.max(0.0) => {
                    self.march_box(px, py, (o, o), d, (t0.max(0.0), t1))
                }
                _ => ([0.0; 3], 0.0),
            },
            Geometry::Spherical(g) => match g.ray_intervals_cut(o, d, self.opts.cut.as_ref()) {
                parts if parts.is_empty() => ([0.0; 3], 0.0),
                parts => self.march_to_face(px, py, (o, o), d, &parts),
            },
        };
        let t = (-tau).exp();
        let bg = self.opts.background;
        [
            color[0] + t * bg[0],
            color[1] + t * bg[1],
            color[2] + t * bg[2],
            -(-tau).exp_m1(),
        ]
    }

    /// [`Self::march`] over a box's piece `[t0, t1]` of the ray, less the cut's box if there is
    /// one; `o` is the ray's origin in world coordinates (the cut's) and in the march's frame.
    fn march_box(
        &self,
        px: u32,
        py: u32,
        (world, o): ([f64; 3], [f64; 3]),
        d: [f64; 3],
        piece: (f64, f64),
    ) -> ([f64; 3], f64) {
        let parts = match &self.opts.cut {
            Some(c) => c.clip_box(world, d, piece),
            None => vec![piece],
        };
        if parts.is_empty() {
            return ([0.0; 3], 0.0);
        }
        self.march_to_face(px, py, (world, o), d, &parts)
    }

    /// [`Self::march`] over `parts` up to the first face of the cut that is drawn
    /// ([`crate::model::CutFaces`]), which then closes the ray: a part starts on a face where the point just
    /// before it lies in the domain and in the removed region. `o` as for [`Self::march_box`].
    fn march_to_face(
        &self,
        px: u32,
        py: u32,
        (world, o): ([f64; 3], [f64; 3]),
        d: [f64; 3],
        parts: &[(f64, f64)],
    ) -> ([f64; 3], f64) {
        let face = self
            .opts
            .cut_faces
            .as_ref()
            .zip(self.opts.cut.as_ref())
            .and_then(|(faces, cut)| {
                let at = |t: f64| [0, 1, 2].map(|a| world[a] + d[a] * t);
                parts.iter().enumerate().find_map(|(i, &(u, _))| {
                    let before = at(u - FACE_PROBE * self.voxel);
                    let removed = match &self.volume.geometry {
                        Geometry::Spherical(g) => {
                            g.contains(before) && cut.removes(g.planet_radius, before)
                        }
                        _ => self.bounds.contains(before) && cut.removes_box(before),
                    };
                    if !removed {
                        return None;
                    }
                    let v = self.volume.sample_world_with(at(u), self.opts.missing);
                    let (e, a) = if v.is_finite() {
                        self.tf.eval(v)
                    } else {
                        ([0.0; 3], 0.0)
                    };
                    // The face's distance from the planet's centre, against the rings.
                    let p = at(u);
                    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    let (radii, half) = &self.rings;
                    let on_ring = radii.iter().any(|ring| (r - ring).abs() < *half);
                    faces
                        .radiance(v, e, a)
                        .map(|c| (i, if on_ring { [0.0; 3] } else { c }))
                })
            });
        let drawn = face.map_or(parts.len(), |(i, _)| i);
        let (mut color, mut tau) = if drawn > 0 {
            self.march(px, py, o, d, &parts[..drawn])
        } else {
            ([0.0; 3], 0.0)
        };
        if let Some((_, radiance)) = face.filter(|_| tau <= self.stop_tau) {
            let t = (-tau).exp();
            for c in 0..3 {
                color[c] += t * radiance[c];
            }
            tau = f64::INFINITY;
        }
        (color, tau)
    }

    /// Colour and optical depth along the ray through the parts `parts` of it inside the
    /// domain (in order). The segments are those of the whole ray from the first part's start:
    /// the first one (jittered), then steps of ds; each is cut to the parts it overlaps, and a
    /// cut piece is sampled at its own middle.
    fn march(
        &self,
        px: u32,
        py: u32,
        o: [f64; 3],
        d: [f64; 3],
        parts: &[(f64, f64)],
    ) -> ([f64; 3], f64) {
        let (opts, ds, voxel) = (self.opts, self.ds, self.voxel);
        let first = if opts.jitter {
            ds * (1.0 - jitter_fraction(px, py, opts.width, opts.height, opts.seed))
        } else {
            ds
        };
        let t_enter = parts[0].0;
        let seg_end = |k: u64| t_enter + first + k as f64 * ds;
        let seg_start = |k: u64| if k == 0 { t_enter } else { seg_end(k - 1) };
        let offset = if self.volume.is_regular() {
            self.bounds.lo
        } else {
            [0.0; 3]
        };
        let at = |t: f64| [0, 1, 2].map(|a| offset[a] + o[a] + d[a] * t);
        let mut tau = 0.0f64;
        let mut color = [0.0f64; 3];
        for &(u, v) in parts {
            // The segment before the one holding u, in case rounding put u past its start
            // (an empty piece is passed over).
            let mut k = if u <= seg_end(0) {
                0
            } else {
                ((u - t_enter - first) / ds).floor().max(0.0) as u64
            };
            // Pre-integration reads the value at segment ends, the front one carried.
            let mut front = if self.preintegrated {
                self.volume.sample_world_with(at(u), opts.missing)
            } else {
                f64::NAN
            };
            while seg_start(k) < v {
                let ta = seg_start(k).max(u);
                let tb = seg_end(k).min(v);
                k += 1;
                if tb <= ta {
                    continue;
                }
                let mid = 0.5 * (ta + tb);
                let mut len = (tb - ta) / voxel;
                let p = at(mid);
                let sample = if self.preintegrated {
                    let back = self.volume.sample_world_with(at(tb), opts.missing);
                    let pair = (front, back);
                    front = back;
                    self.segment(pair, &mut len)
                } else {
                    let v = self.volume.sample_world_with(p, opts.missing);
                    v.is_finite().then(|| self.tf.eval(v))
                };
                let Some((mut e, a)) = sample else {
                    continue;
                };
                if let Some(sh) = &opts.shading {
                    if e.iter().any(|&c| c > 0.0) {
                        let f = sh.factor(self.volume.gradient_world(p), d);
                        e = e.map(|c| c * f);
                    }
                }
                let x = a * len;
                let weight = (-tau).exp() * len * escape_fraction(x);
                for c in 0..3 {
                    color[c] += weight * e[c];
                }
                tau += x;
                if tau > self.stop_tau {
                    return (color, tau);
                }
            }
        }
        (color, tau)
    }

    /// The pre-integrated emission and extinction of a segment with end values `pair`; `None`
    /// where both are missing. The edge of missing data is taken at the middle: the half next
    /// to the finite end carries its value (`len` halves).
    fn segment(&self, pair: (f64, f64), len: &mut f64) -> Option<([f64; 3], f64)> {
        match (pair.0.is_finite(), pair.1.is_finite()) {
            (true, true) => Some(self.tf.segment_mean(&self.integral, pair.0, pair.1)),
            (false, false) => None,
            (true, false) | (false, true) => {
                *len *= 0.5;
                Some(
                    self.tf
                        .eval(if pair.0.is_finite() { pair.0 } else { pair.1 }),
                )
            }
        }
    }
}
