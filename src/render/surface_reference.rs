//! The f64 CPU reference of the surface data pass (`shaders/surface_data.wgsl`), map and 3-D
//! views alike: the same pixel-to-node mapping in map view, and in perspective the same ray march
//! over the relief (steps of half a cell along the ray's horizontal run, at most 4096 per ray,
//! the first step below the surface refined by 12 bisections), the same bilinear sampling that
//! weights valid corners only and marks a pixel missing when its nearest node is, and the same
//! Lambert shading on central differences of the relief one node apart; on the globe the same
//! ray–sphere hit, latitude and longitude to nodes ([`GlobeFrame`], interpolation wrapping
//! across closed longitudes) and headlight shading. Only the arithmetic
//! differs (f64 here, f32 on the GPU, and d itself rather than hi + rest around d_ref), so a
//! comparison measures what f32 costs. The fringe of a reference pixel is
//! [`fringe_f64`](super::surface::fringe_f64) of its value, and its antialiased fringe
//! [`fringe_filtered_f64`](super::surface::fringe_filtered_f64) of its value and the
//! [`pixel_gradient`](super::surface::pixel_gradient) of the reference's value plane.

use super::surface::{
    default_size, fringe_f64, fringe_filtered_f64, pixel_gradient, GlobeFrame, SurfaceGeometry,
    SurfaceOptions, SurfaceView, LIGHT_AMBIENT, LIGHT_DIRECTION, MAX_PROPERTIES,
};
use crate::error::{Error, Result};
use crate::model::vec3::normalize;
use crate::model::Grid;
use crate::model::SphericalGrid;

/// Bisection steps refining a ray's first step below the relief (as the shader).
const BISECTIONS: usize = 12;
/// Most march steps per ray across the relief box (as the shader's span / 4096 floor on dt).
const MAX_MARCH_STEPS: f64 = 4096.0;

/// What the data pass computes per pixel, in f64.
#[derive(Clone, Debug)]
pub struct SurfaceReference {
    pub width: u32,
    pub height: u32,
    /// Property names, in slot order.
    pub properties: Vec<String>,
    /// Whether the pixel shows the surface (always true in map view).
    pub hit: Vec<bool>,
    /// Ray parameter of the hit (world units along the unit ray; 0 in map view, NaN on a miss).
    pub distance: Vec<f64>,
    /// Node coordinates (u along x, v along y) the pixel shows (NaN on a miss).
    pub node: Vec<[f64; 2]>,
    /// Per property slot, the value per pixel (NaN where missing or missed).
    pub values: Vec<Vec<f64>>,
    /// Lambert shading per pixel (1 in map view, 0 on a miss).
    pub shade: Vec<f64>,
}

impl SurfaceReference {
    /// (1 + cos 2πν·d)/2 per pixel of property `slot` (NaN where missing).
    pub fn fringe(&self, slot: usize, nu: f64) -> Vec<f64> {
        self.values[slot]
            .iter()
            .map(|&d| {
                if d.is_finite() {
                    fringe_f64(nu, d)
                } else {
                    f64::NAN
                }
            })
            .collect()
    }

    /// The fringe averaged over each pixel's footprint (NaN where missing), as the fringe pass's
    /// `fringe_filtered` channel.
    pub fn fringe_filtered(&self, slot: usize, nu: f64) -> Vec<f64> {
        let values = &self.values[slot];
        let w = self.width as usize;
        values
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                if d.is_finite() {
                    fringe_filtered_f64(nu, d, pixel_gradient(values, w, i % w, i / w))
                } else {
                    f64::NAN
                }
            })
            .collect()
    }
}

/// The relief, the properties and the view of one render, in f64.
struct Scene<'a> {
    geo: SurfaceGeometry,
    nx: usize,
    ny: usize,
    props: Vec<&'a [f64]>,
}

impl Scene<'_> {
    /// Clamped bilinear footing at node coordinates (u, v), as the shader: base node, the next
    /// node (clamped to the grid, or the first after the last where longitudes close the
    /// circle) and the fractions.
    fn footing(&self, u: f64, v: f64) -> ([usize; 2], [usize; 2], [f64; 2]) {
        let wrap = self.geo.globe.is_some_and(|g| g.wrap);
        let umax = if wrap { self.nx } else { self.nx - 1 } as f64;
        let (u, v) = (u.clamp(0.0, umax), v.clamp(0.0, (self.ny - 1) as f64));
        let base = [
            (u.floor() as usize).min(self.nx - 1),
            (v.floor() as usize).min(self.ny - 1),
        ];
        let f = [(u - base[0] as f64).min(1.0), v - base[1] as f64];
        let next = [
            if wrap && base[0] + 1 == self.nx {
                0
            } else {
                (base[0] + 1).min(self.nx - 1)
            },
            (base[1] + 1).min(self.ny - 1),
        ];
        (base, next, f)
    }

    /// What a globe pixel's ray shows: (t, u, v, shade) where it meets the sphere inside the
    /// grid's cells.
    fn globe(&self, frame: &GlobeFrame, o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64, f64, f64)> {
        let (t, p) = GlobeFrame::hit(o, d)?;
        let (_, lat, lon) = SphericalGrid::from_world(p);
        let (u, v) = frame.node_coords(lat, lon)?;
        Some((t, u, v, GlobeFrame::shade(p, d)))
    }

    fn node(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }

    /// World z of the relief at node coordinates (u, v), relative to the box floor.
    fn height_at(&self, u: f64, v: f64) -> f64 {
        let (b, n, f) = self.footing(u, v);
        let h = &self.geo.heights;
        let h00 = h[self.node(b[0], b[1])];
        let h10 = h[self.node(n[0], b[1])];
        let h01 = h[self.node(b[0], n[1])];
        let h11 = h[self.node(n[0], n[1])];
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let z = lerp(lerp(h00, h10, f[0]), lerp(h01, h11, f[0]), f[1]);
        (z - self.geo.height_at_floor()) * self.geo.exaggeration
    }

    /// Property `slot` at (u, v): the node's value on a node, else the bilinear mean over valid
    /// corners; NaN when the nearest node is missing.
    fn sample(&self, slot: usize, u: f64, v: f64) -> f64 {
        let d = self.props[slot];
        let (b, n, f) = self.footing(u, v);
        if f == [0.0, 0.0] {
            return d[self.node(b[0], b[1])];
        }
        let corners = [(b[0], b[1]), (n[0], b[1]), (b[0], n[1]), (n[0], n[1])];
        let weights = [
            (1.0 - f[0]) * (1.0 - f[1]),
            f[0] * (1.0 - f[1]),
            (1.0 - f[0]) * f[1],
            f[0] * f[1],
        ];
        let (mut sum, mut wsum) = (0.0, 0.0);
        for ((i, j), w) in corners.into_iter().zip(weights) {
            let value = d[self.node(i, j)];
            if value.is_finite() {
                sum += w * value;
                wsum += w;
            }
        }
        let near = [
            if f[0] >= 0.5 { n[0] } else { b[0] },
            if f[1] >= 0.5 { n[1] } else { b[1] },
        ];
        if d[self.node(near[0], near[1])].is_finite() && wsum > 0.0 {
            sum / wsum
        } else {
            f64::NAN
        }
    }

    /// Lambert shading from central differences one node apart.
    fn shade(&self, u: f64, v: f64) -> f64 {
        let [sx, sy] = self.geo.spacing;
        let dzdx = (self.height_at(u + 1.0, v) - self.height_at(u - 1.0, v)) / (2.0 * sx);
        let dzdy = (self.height_at(u, v + 1.0) - self.height_at(u, v - 1.0)) / (2.0 * sy);
        let n = normalize([-dzdx, -dzdy, 1.0]);
        let l = normalize(LIGHT_DIRECTION);
        let lambert = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0);
        LIGHT_AMBIENT + (1.0 - LIGHT_AMBIENT) * lambert
    }

    /// The first point of the ray o + t·d below the relief: (t, u, v), or `None`.
    fn march(&self, o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64, f64)> {
        let (t_in, t_out) = box_hit(o, d, self.geo.box_size);
        if t_in >= t_out {
            return None;
        }
        let [sx, sy] = self.geo.spacing;
        let at = |t: f64| [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
        let below = |p: [f64; 3]| p[2] <= self.height_at(p[0] / sx, p[1] / sy);
        let t0 = t_in.max(0.0);
        let horiz = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-6);
        let dt = (0.5 * sx.min(sy) / horiz).max((t_out - t0) / MAX_MARCH_STEPS);
        let steps = ((t_out - t0) / dt).ceil() as u64;
        let mut prev = t0;
        for s in 0..=steps {
            let t = (t0 + s as f64 * dt).min(t_out);
            if below(at(t)) {
                let (mut lo, mut hi) = (prev, t);
                for _ in 0..BISECTIONS {
                    let mid = 0.5 * (lo + hi);
                    if below(at(mid)) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                let q = at(hi);
                return Some((hi, q[0] / sx, q[1] / sy));
            }
            prev = t;
        }
        None
    }
}

/// Entry and exit distances through the box [0, size], as the shader's `box_hit` (components
/// below 1e-30 replaced by 1e-30 so that no 0·∞ appears).
fn box_hit(o: [f64; 3], d: [f64; 3], size: [f64; 3]) -> (f64, f64) {
    let (mut near, mut far) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        let inv = 1.0 / if d[a].abs() < 1e-30 { 1e-30 } else { d[a] };
        let (ta, tb) = (-o[a] * inv, (size[a] - o[a]) * inv);
        near = near.max(ta.min(tb));
        far = far.min(ta.max(tb));
    }
    (near, far)
}

/// The data pass of `opts` on `grid` in f64: per pixel, what it shows and how it is lit.
pub fn surface_reference(grid: &Grid, opts: &SurfaceOptions) -> Result<SurfaceReference> {
    opts.validate()?;
    let slots: Vec<usize> = if opts.properties.is_empty() {
        vec![0]
    } else {
        opts.properties
            .iter()
            .map(|p| grid.property_index(p))
            .collect::<Result<_>>()?
    };
    if slots.len() > MAX_PROPERTIES {
        return Err(Error::invalid("property", "at most four properties"));
    }
    let (width, height) = default_size(grid, opts);
    let scene = Scene {
        geo: SurfaceGeometry::new(grid, opts)?,
        nx: grid.nx(),
        ny: grid.ny(),
        props: slots.iter().map(|&p| grid.property_at(p).1).collect(),
    };
    let n = width as usize * height as usize;
    let mut out = SurfaceReference {
        width,
        height,
        properties: slots
            .iter()
            .map(|&p| grid.property_at(p).0.to_string())
            .collect(),
        hit: vec![false; n],
        distance: vec![f64::NAN; n],
        node: vec![[f64::NAN; 2]; n],
        values: vec![vec![f64::NAN; n]; slots.len()],
        shade: vec![0.0; n],
    };
    for py in 0..height {
        for px in 0..width {
            let k = py as usize * width as usize + px as usize;
            let found = match (&opts.view, &scene.geo.camera) {
                (SurfaceView::Map, _) | (_, None) => {
                    let scale = [
                        scene.nx as f64 / width as f64,
                        scene.ny as f64 / height as f64,
                    ];
                    let u = (px as f64 + 0.5) * scale[0] - 0.5;
                    let row = (py as f64 + 0.5) * scale[1] - 0.5;
                    Some((0.0, u, scene.geo.map_v(row, scene.ny), 1.0))
                }
                (_, Some(camera)) => {
                    let (o, d) = camera.ray(px, py, width, height);
                    match &scene.geo.globe {
                        Some(frame) => scene.globe(frame, o, d),
                        None => scene
                            .march(o, d)
                            .map(|(t, u, v)| (t, u, v, scene.shade(u, v))),
                    }
                }
            };
            if let Some((t, u, v, shade)) = found {
                out.hit[k] = true;
                out.distance[k] = t;
                out.node[k] = [u, v];
                out.shade[k] = shade;
                for slot in 0..slots.len() {
                    out.values[slot][k] = scene.sample(slot, u, v);
                }
            }
        }
    }
    Ok(out)
}
