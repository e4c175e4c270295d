//! The temperature model on the spherical grid: the conductive profile, the error-function
//! boundary layers of a convecting shell, and the seeded plumes and slabs laid over them.

use std::f64::consts::PI;

use super::options::{MantleOptions, SphericalResolution};
use super::SHELL_THICKNESS;
use super::{CRITICAL_RAYLEIGH, FEATURE_RAYLEIGH_WITHOUT_CONVECTION, INNER_RADIUS, OUTER_RADIUS};
use crate::model::numeric::{erf, erfc, normalized_legendre, SplitMix64};
use crate::model::vec3::{cross, dot, norm};

/// The conductive temperature of the shell with T(r_b) = 1 and T(r_t) = 0 (Zhong et al. 2008):
/// T_c(r) = r_b (r - r_t) / (r (r_b - r_t)).
pub(crate) fn conductive_temperature(r: f64) -> f64 {
    INNER_RADIUS * (r - OUTER_RADIUS) / (r * (INNER_RADIUS - OUTER_RADIUS))
}

/// Radial structure of a convecting shell heated from below: an isothermal interior between two
/// error-function boundary layers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BoundaryLayers {
    /// Interior temperature T_i.
    pub interior: f64,
    /// Length scale of the top layer: T = T_i erf((r_t - r) / top) near the surface.
    pub top: f64,
    /// Length scale of the bottom layer: T = T_i + (1 - T_i) erfc((r - r_b) / bottom).
    pub bottom: f64,
}

impl BoundaryLayers {
    /// Each layer is as thick as marginal stability allows: its local Rayleigh number
    /// Ra dT (delta/d)^3 equals `CRITICAL_RAYLEIGH`. Heat flux through a layer then scales as
    /// dT^(4/3) per unit area; with no internal heating the flux through the surface equals
    /// that through the core-mantle boundary, r_t^2 T_i^(4/3) = r_b^2 (1 - T_i)^(4/3), which
    /// gives T_i = q / (1 + q) with q = (r_b / r_t)^(3/2) = 0.408, T_i = 0.290: the cool interior
    /// typical of spherical shells with a small core.
    pub(crate) fn for_rayleigh(rayleigh: f64) -> Self {
        let ratio = (INNER_RADIUS / OUTER_RADIUS).powf(1.5);
        let interior = ratio / (1.0 + ratio);
        let thickness =
            |drop: f64| SHELL_THICKNESS * (CRITICAL_RAYLEIGH / (rayleigh * drop)).cbrt();
        BoundaryLayers {
            interior,
            top: thickness(interior),
            bottom: thickness(1.0 - interior),
        }
    }

    /// Temperature at radius r. Each layer is divided by its value across the whole shell so
    /// that T(r_b) = 1 and T(r_t) = 0 exactly even when layers are thick.
    pub(crate) fn temperature(&self, r: f64) -> f64 {
        let top = erf((OUTER_RADIUS - r) / self.top) / erf(SHELL_THICKNESS / self.top);
        let full = erf(SHELL_THICKNESS / self.bottom);
        let bottom = (erfc((r - INNER_RADIUS) / self.bottom) - (1.0 - full)) / full;
        self.interior * top + (1.0 - self.interior) * bottom
    }
}

/// A hot conduit from the core-mantle boundary up to a flattened head.
struct Plume {
    axis: [f64; 3],
    /// Columns farther than this angle from the axis are untouched.
    cos_reach: f64,
    conduit_radius: f64,
    head_radius: f64,
    head_half_height: f64,
    head_centre: f64,
    /// Share of the bottom boundary layer's temperature drop the plume carries.
    excess: f64,
}

/// A cold sheet hanging from a great-circle trench, dipping towards `pole` with depth.
struct Slab {
    pole: [f64; 3],
    centre: [f64; 3],
    along: [f64; 3],
    half_length: f64,
    thickness: f64,
    tan_dip: f64,
    bottom: f64,
    core_temperature: f64,
    /// Columns whose signed angle from the trench plane lies outside this range are untouched.
    lateral_range: (f64, f64),
}

/// Angular taper beyond the ends of a trench.
const TRENCH_END_TAPER: f64 = 0.08;
/// Features reach this many widths before they are cut off: exp(-16) ~ 1e-7, below the f32
/// resolution of the stored temperature.
const FEATURE_REACH: f64 = 4.0;
const NEGLIGIBLE_EXPONENT: f64 = FEATURE_REACH * FEATURE_REACH;

pub(super) struct Features {
    plumes: Vec<Plume>,
    slabs: Vec<Slab>,
}

impl Features {
    pub(super) fn place(opts: &MantleOptions, layers: &BoundaryLayers, finest_width: f64) -> Self {
        let sizes = BoundaryLayers::for_rayleigh(if opts.rayleigh > CRITICAL_RAYLEIGH {
            opts.rayleigh
        } else {
            FEATURE_RAYLEIGH_WITHOUT_CONVECTION
        });
        // Separate streams so that the number of plumes does not move the slabs.
        let mut plume_rng = SplitMix64(opts.seed ^ 0x706C_756D_6573_0001);
        let mut slab_rng = SplitMix64(opts.seed ^ 0x736C_6162_7300_0002);
        let plumes = (0..opts.plumes)
            .map(|_| {
                let axis = plume_rng.direction();
                // A conduit a little wider than the layer that feeds it; never thinner than the
                // grid can carry.
                let conduit_radius = (sizes.bottom * plume_rng.between(1.2, 2.0)).max(finest_width);
                let head_radius = conduit_radius * plume_rng.between(2.0, 3.0);
                let head_half_height = conduit_radius * plume_rng.between(1.0, 1.5);
                let head_centre = plume_rng.between(0.75, 0.95);
                let excess = plume_rng.between(0.35, 0.65);
                let reach = (FEATURE_REACH * head_radius / INNER_RADIUS).min(PI);
                Plume {
                    axis,
                    cos_reach: reach.cos(),
                    conduit_radius,
                    head_radius,
                    head_half_height,
                    head_centre,
                    excess,
                }
            })
            .collect();
        let slabs = (0..opts.slabs)
            .map(|_| {
                let centre = slab_rng.direction();
                let mut pole = slab_rng.direction();
                let along_centre = dot(pole, centre);
                pole = [
                    pole[0] - along_centre * centre[0],
                    pole[1] - along_centre * centre[1],
                    pole[2] - along_centre * centre[2],
                ];
                let length = norm(pole);
                let pole = if length > 1e-6 {
                    [pole[0] / length, pole[1] / length, pole[2] / length]
                } else {
                    // The draw fell on the centre; any perpendicular serves.
                    let helper = if centre[0].abs() < 0.9 {
                        [1.0, 0.0, 0.0]
                    } else {
                        [0.0, 1.0, 0.0]
                    };
                    let p = cross(centre, helper);
                    let l = norm(p);
                    [p[0] / l, p[1] / l, p[2] / l]
                };
                let thickness = (sizes.top * slab_rng.between(0.8, 1.25)).max(finest_width);
                let half_length = slab_rng.between(0.15, 0.5);
                let tan_dip = slab_rng
                    .between(45.0_f64.to_radians(), 85.0_f64.to_radians())
                    .tan();
                let bottom = slab_rng.between(INNER_RADIUS + 0.02, 0.85);
                let core_temperature = layers.interior * slab_rng.between(0.15, 0.4);
                let deepest_shift = (OUTER_RADIUS - bottom) / (tan_dip * bottom);
                let margin = FEATURE_REACH * thickness / INNER_RADIUS;
                Slab {
                    pole,
                    centre,
                    along: cross(pole, centre),
                    half_length,
                    thickness,
                    tan_dip,
                    bottom,
                    core_temperature,
                    lateral_range: (-margin, deepest_shift + 2.0 * margin),
                }
            })
            .collect();
        Features { plumes, slabs }
    }
}

/// A feature that reaches one column of the grid, with the column's angular coordinates
/// relative to it.
#[derive(Clone, Copy)]
enum Nearby {
    /// Plume index and angular distance from its axis.
    Plume(usize, f64),
    /// Slab index, signed angle from the trench plane, and along-trench taper.
    Slab(usize, f64, f64),
}

/// Everything the node loop needs, computed once per grid.
pub(super) struct Model<'a> {
    pub(super) res: SphericalResolution,
    pub(super) radii: Vec<f64>,
    /// Radial temperature profile without lateral structure.
    pub(super) profile: Vec<f64>,
    /// eps sin(pi (r - r_b) / (r_t - r_b)).
    pub(super) bump: Vec<f64>,
    /// cos(m phi) + sin(m phi), and the node's direction cosines.
    pub(super) azimuth: Vec<f64>,
    pub(super) cos_phi: Vec<f64>,
    pub(super) sin_phi: Vec<f64>,
    pub(super) layers: BoundaryLayers,
    pub(super) features: Features,
    pub(super) opts: &'a MantleOptions,
}

impl Model<'_> {
    pub(super) fn fill_row(&self, it: usize, row: &mut [f32]) -> Vec<f64> {
        let res = &self.res;
        let theta = it as f64 * res.theta_step();
        // Exact pole rows keep every longitude of a pole on the same point.
        let (sin_theta, cos_theta) = if it == 0 {
            (0.0, 1.0)
        } else if it + 1 == res.theta {
            (0.0, -1.0)
        } else {
            theta.sin_cos()
        };
        let legendre = normalized_legendre(self.opts.degree, self.opts.order, cos_theta);
        let mut shell_sums = vec![0.0; res.radial];
        let mut nearby = Vec::new();
        for (ip, column) in row.chunks_exact_mut(res.radial).enumerate() {
            let direction = [
                sin_theta * self.cos_phi[ip],
                sin_theta * self.sin_phi[ip],
                cos_theta,
            ];
            self.find_nearby(direction, &mut nearby);
            let harmonic = legendre * self.azimuth[ip];
            for (ir, value) in column.iter_mut().enumerate() {
                let mut t = self.profile[ir] + harmonic * self.bump[ir];
                if !nearby.is_empty() {
                    t = self.apply_features(&nearby, self.radii[ir], t);
                }
                let stored = t as f32;
                *value = stored;
                shell_sums[ir] += stored as f64;
            }
        }
        shell_sums
    }

    fn find_nearby(&self, direction: [f64; 3], nearby: &mut Vec<Nearby>) {
        nearby.clear();
        for (index, plume) in self.features.plumes.iter().enumerate() {
            let cosine = dot(direction, plume.axis);
            if cosine >= plume.cos_reach {
                let angle = norm(cross(direction, plume.axis)).atan2(cosine);
                nearby.push(Nearby::Plume(index, angle));
            }
        }
        for (index, slab) in self.features.slabs.iter().enumerate() {
            let lateral = dot(direction, slab.pole).clamp(-1.0, 1.0).asin();
            if lateral < slab.lateral_range.0 || lateral > slab.lateral_range.1 {
                continue;
            }
            let along = dot(direction, slab.along)
                .atan2(dot(direction, slab.centre))
                .abs();
            let beyond = (along - slab.half_length).max(0.0) / TRENCH_END_TAPER;
            if beyond < FEATURE_REACH {
                nearby.push(Nearby::Slab(index, lateral, (-beyond * beyond).exp()));
            }
        }
    }

    fn apply_features(&self, nearby: &[Nearby], r: f64, mut t: f64) -> f64 {
        let interior = self.layers.interior;
        let height = (r - INNER_RADIUS) / SHELL_THICKNESS;
        for feature in nearby {
            match *feature {
                Nearby::Plume(index, angle) => {
                    let plume = &self.features.plumes[index];
                    let offset = angle * r;
                    let above = ((r - plume.head_centre) / plume.head_half_height).powi(2);
                    let mut exponent = (offset / plume.head_radius).powi(2) + above;
                    let conduit = (offset / plume.conduit_radius).powi(2);
                    exponent = exponent.min(if r <= plume.head_centre {
                        conduit
                    } else {
                        conduit + above
                    });
                    // Most nodes of a nearby column are far from the conduit and the head.
                    if exponent > NEGLIGIBLE_EXPONENT {
                        continue;
                    }
                    // The surface stays at T = 0: the head spreads under it, not through it.
                    let below_surface =
                        -(-((OUTER_RADIUS - r) / plume.conduit_radius).powi(2)).exp_m1();
                    let weight = (-exponent).exp() * below_surface;
                    // The plume loses some of its excess to its surroundings as it rises.
                    let hot = interior + plume.excess * (1.0 - interior) * (1.0 - 0.3 * height);
                    t += weight * (hot - t).max(0.0);
                }
                Nearby::Slab(index, lateral, along_taper) => {
                    let slab = &self.features.slabs[index];
                    let shift = (OUTER_RADIUS - r) / (slab.tan_dip * r);
                    let offset = (lateral - shift) * r / slab.thickness;
                    let below = ((slab.bottom - r).max(0.0) / (2.0 * slab.thickness)).powi(2);
                    let exponent = offset * offset + below;
                    if exponent > NEGLIGIBLE_EXPONENT {
                        continue;
                    }
                    // The core-mantle boundary stays at T = 1: a slab reaching it spreads on it.
                    let above_core = -(-((r - INNER_RADIUS) / slab.thickness).powi(2)).exp_m1();
                    let weight = (-exponent).exp() * along_taper * above_core;
                    // Slabs warm by conduction as they sink: halfway to the interior at the
                    // core-mantle boundary.
                    let cold = slab.core_temperature
                        + 0.5 * (interior - slab.core_temperature) * (1.0 - height);
                    t += weight * (cold - t).min(0.0);
                }
            }
        }
        t
    }
}
