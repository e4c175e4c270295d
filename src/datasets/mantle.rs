//! Synthetic mantle-convection temperature in a spherical shell, standing in for case III of
//! Yuan et al. (2008), whose 513^3 volume was resampled from a spherical convection code. The
//! field starts from the CitcomS benchmark initial condition of Zhong et al. (2008): the
//! conductive profile of the shell 0.55 <= r <= 1 plus eps (cos m phi + sin m phi) P_lm(cos theta)
//! sin(pi (r - r_b) / (r_t - r_b)). On top come error-function thermal boundary layers whose
//! thickness follows from a Rayleigh number, hot plumes rising from the core-mantle boundary and
//! cold slabs sinking from the surface, placed by a seeded generator. The field is built on a
//! spherical (r, theta, phi) grid and resampled trilinearly in (r, theta, phi) onto an N^3 box
//! [-1, 1]^3, as the paper did. Voxels outside the shell are NaN, the renderer's missing value.
//!
//! Coordinates: x = r sin(theta) cos(phi), y = r sin(theta) sin(phi), z = r cos(theta); theta is
//! colatitude from +z, phi is longitude from +x towards +y.

use rayon::prelude::*;
use std::f64::consts::{PI, TAU};

use crate::error::{Error, Result};
use crate::model::numeric::{erf, erfc, normalized_legendre, SplitMix64};
use crate::model::vec3::{cross, dot, norm};

/// Core-mantle boundary radius of the non-dimensional shell (Zhong et al. 2008).
pub(crate) const INNER_RADIUS: f64 = 0.55;
/// Surface radius of the non-dimensional shell.
pub(crate) const OUTER_RADIUS: f64 = 1.0;
/// Below about this Rayleigh number a shell does not convect, and the local Rayleigh number of a
/// thermal boundary layer stays near it while the layer is stable (Howard 1966); both are of
/// order 10^3, so one constant serves both.
pub(crate) const CRITICAL_RAYLEIGH: f64 = 1.0e3;

const SHELL_THICKNESS: f64 = OUTER_RADIUS - INNER_RADIUS;
pub(crate) const MAX_N: usize = 2048;
const MAX_AXIS_NODES: usize = 16384;
const MAX_DEGREE: usize = 64;
pub(crate) const MAX_FEATURES: usize = 10_000;
const MAX_RAYLEIGH: f64 = 1.0e12;
/// Plumes and slabs need a size even when the shell is conductive; they take the one of this
/// Rayleigh number then.
const FEATURE_RAYLEIGH_WITHOUT_CONVECTION: f64 = 1.0e6;
/// Share of the progress bar given to building the spherical grid; resampling is the rest.
const SPHERICAL_PROGRESS_SHARE: f64 = 0.3;
const PROGRESS_STEPS: usize = 32;

/// One of the fields the generator can produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MantleField {
    /// Non-dimensional temperature, 1 at the core-mantle boundary and 0 at the surface.
    Temperature,
    /// Temperature minus its area-weighted mean over the sphere of the same radius.
    Fluctuation,
    /// Relative viscosity eta = r_mu^(0.5 - T): 1 at T = 0.5, spanning log10(r_mu) decades.
    Viscosity,
}

impl MantleField {
    pub const ALL: [MantleField; 3] = [
        MantleField::Temperature,
        MantleField::Fluctuation,
        MantleField::Viscosity,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MantleField::Temperature => "temperature",
            MantleField::Fluctuation => "fluctuation",
            MantleField::Viscosity => "viscosity",
        }
    }

    pub fn parse(name: &str) -> Result<Self> {
        MantleField::ALL
            .into_iter()
            .find(|field| field.name().eq_ignore_ascii_case(name.trim()))
            .ok_or_else(|| {
                Error::invalid(
                    "field",
                    format!("unknown mantle field '{name}'; expected temperature, fluctuation or viscosity"),
                )
            })
    }
}

/// Which fields `generate` fills; the others stay empty so that nobody pays for what they did
/// not ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MantleFields {
    pub temperature: bool,
    pub fluctuation: bool,
    pub viscosity: bool,
}

impl MantleFields {
    pub const ALL: MantleFields = MantleFields {
        temperature: true,
        fluctuation: true,
        viscosity: true,
    };

    pub fn only(field: MantleField) -> Self {
        let mut fields = MantleFields {
            temperature: false,
            fluctuation: false,
            viscosity: false,
        };
        fields.set(field, true);
        fields
    }

    pub fn contains(self, field: MantleField) -> bool {
        match field {
            MantleField::Temperature => self.temperature,
            MantleField::Fluctuation => self.fluctuation,
            MantleField::Viscosity => self.viscosity,
        }
    }

    pub fn set(&mut self, field: MantleField, wanted: bool) {
        match field {
            MantleField::Temperature => self.temperature = wanted,
            MantleField::Fluctuation => self.fluctuation = wanted,
            MantleField::Viscosity => self.viscosity = wanted,
        }
    }

    fn count(self) -> usize {
        MantleField::ALL
            .iter()
            .filter(|&&f| self.contains(f))
            .count()
    }
}

/// Node counts of the spherical grid. Radii are `radial` nodes from `INNER_RADIUS` to
/// `OUTER_RADIUS` inclusive; colatitudes are `theta` nodes from 0 to pi inclusive (both poles are
/// rows of the grid); longitudes are `phi` nodes at 2 pi k / phi, periodic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SphericalResolution {
    pub radial: usize,
    pub theta: usize,
    pub phi: usize,
}

impl SphericalResolution {
    /// The grid that resolves a Cartesian box of n cells per axis everywhere in the shell: node
    /// spacing at most the voxel size 2/n radially and along both angles at the surface (where
    /// the angular spacing is coarsest). The radial count has an odd number of nodes so that
    /// mid-shell is a node; theta - 1 is a multiple of 4 and phi of 8 so that the equator, the
    /// 45-degree colatitudes and the eight compass longitudes are nodes. For n = 513 this is
    /// 117 x 809 x 1616 nodes (153 million, 612 MB of f32).
    pub(crate) fn for_cartesian(n: usize) -> Self {
        let voxel = 2.0 / n.max(1) as f64;
        let radial_cells = round_up((SHELL_THICKNESS / voxel).ceil() as usize, 2).max(2);
        let theta_cells = round_up((PI * OUTER_RADIUS / voxel).ceil() as usize, 4).max(4);
        let phi_nodes = round_up((TAU * OUTER_RADIUS / voxel).ceil() as usize, 8).max(8);
        SphericalResolution {
            radial: radial_cells + 1,
            theta: theta_cells + 1,
            phi: phi_nodes,
        }
    }

    pub fn nodes(&self) -> usize {
        self.radial * self.theta * self.phi
    }

    fn validate(&self) -> Result<()> {
        let check = |name: &str, value: usize, min: usize| {
            if value < min || value > MAX_AXIS_NODES {
                Err(Error::invalid(
                    format!("resolution.{name}"),
                    format!("{value} nodes; expected {min}..={MAX_AXIS_NODES}"),
                ))
            } else {
                Ok(())
            }
        };
        check("radial", self.radial, 2)?;
        check("theta", self.theta, 3)?;
        check("phi", self.phi, 4)
    }

    fn radial_step(&self) -> f64 {
        SHELL_THICKNESS / (self.radial - 1) as f64
    }

    fn theta_step(&self) -> f64 {
        PI / (self.theta - 1) as f64
    }

    fn phi_step(&self) -> f64 {
        TAU / self.phi as f64
    }
}

fn round_up(value: usize, multiple: usize) -> usize {
    value.div_ceil(multiple) * multiple
}

/// Parameters of the generator. `Default` gives the paper's 513^3 box with a convecting shell at
/// Ra = 10^7 and the Zhong et al. (2008) case A perturbation (eps = 0.01, l = 3, m = 2).
#[derive(Clone, Debug, PartialEq)]
pub struct MantleOptions {
    /// Cells per axis of the Cartesian output box (2..=2048).
    pub n: usize,
    /// Seed of the plume and slab positions; equal seeds give bit-identical output.
    pub seed: u64,
    /// Number of hot plumes rising from the core-mantle boundary.
    pub plumes: usize,
    /// Number of cold slabs sinking from the surface.
    pub slabs: usize,
    /// Rayleigh number (0..=1e12); it sets the boundary-layer thickness d (Ra_c / (Ra dT))^(1/3)
    /// (`BoundaryLayers::for_rayleigh`): 0.032 at the top and 0.023 at the bottom for Ra = 1e7,
    /// in units of the surface radius. At or below `CRITICAL_RAYLEIGH` (0 included) the shell is
    /// conductive and has no boundary layers. Plume and slab widths follow the layers.
    pub rayleigh: f64,
    /// Amplitude eps of the spherical-harmonic perturbation.
    pub epsilon: f64,
    /// Spherical-harmonic degree l of the perturbation (0..=64).
    pub degree: usize,
    /// Spherical-harmonic order m of the perturbation (0..=degree).
    pub order: usize,
    /// Viscosity contrast r_mu of eta = r_mu^(0.5 - T) (1..=1e12).
    pub viscosity_contrast: f64,
    /// Fields `generate` fills.
    pub fields: MantleFields,
    /// Spherical grid; `None` picks `SphericalResolution::for_cartesian(n)`.
    pub resolution: Option<SphericalResolution>,
}

impl Default for MantleOptions {
    fn default() -> Self {
        MantleOptions {
            n: 513,
            seed: 1,
            plumes: 12,
            slabs: 8,
            rayleigh: 1.0e7,
            epsilon: 0.01,
            degree: 3,
            order: 2,
            viscosity_contrast: 1.0e5,
            fields: MantleFields::ALL,
            resolution: None,
        }
    }
}

impl MantleOptions {
    pub fn validate(&self) -> Result<()> {
        if !(2..=MAX_N).contains(&self.n) {
            return Err(Error::invalid(
                "n",
                format!("{}; expected 2..={MAX_N} cells per axis", self.n),
            ));
        }
        if self.plumes > MAX_FEATURES {
            return Err(Error::invalid(
                "plumes",
                format!("{}; expected 0..={MAX_FEATURES}", self.plumes),
            ));
        }
        if self.slabs > MAX_FEATURES {
            return Err(Error::invalid(
                "slabs",
                format!("{}; expected 0..={MAX_FEATURES}", self.slabs),
            ));
        }
        if !self.rayleigh.is_finite() || !(0.0..=MAX_RAYLEIGH).contains(&self.rayleigh) {
            return Err(Error::invalid(
                "rayleigh",
                format!("{}; expected a finite number in 0..=1e12", self.rayleigh),
            ));
        }
        if !self.epsilon.is_finite() || self.epsilon.abs() > 1.0 {
            return Err(Error::invalid(
                "epsilon",
                format!("{}; expected a finite number in -1..=1", self.epsilon),
            ));
        }
        if self.degree > MAX_DEGREE {
            return Err(Error::invalid(
                "degree",
                format!("{}; expected 0..={MAX_DEGREE}", self.degree),
            ));
        }
        if self.order > self.degree {
            return Err(Error::invalid(
                "order",
                format!("{}; expected 0..=degree ({})", self.order, self.degree),
            ));
        }
        if !self.viscosity_contrast.is_finite()
            || !(1.0..=1.0e12).contains(&self.viscosity_contrast)
        {
            return Err(Error::invalid(
                "viscosity_contrast",
                format!(
                    "{}; expected a finite number in 1..=1e12",
                    self.viscosity_contrast
                ),
            ));
        }
        if self.fields.count() == 0 {
            return Err(Error::invalid(
                "fields",
                "none requested; ask for at least one of temperature, fluctuation, viscosity",
            ));
        }
        if let Some(resolution) = self.resolution {
            resolution.validate()?;
        }
        Ok(())
    }

    /// The spherical grid these options compute on.
    pub(crate) fn spherical_resolution(&self) -> SphericalResolution {
        self.resolution
            .unwrap_or_else(|| SphericalResolution::for_cartesian(self.n))
    }
}

/// The generated Cartesian volume: n^3 cells over [-1, 1]^3, index (k n + j) n + i with i along
/// x, j along y, k along z, cell centres at -1 + (i + 0.5) 2/n. Cells whose centre lies outside
/// the shell hold NaN. A field not requested in `MantleOptions::fields` is an empty vector.
#[derive(Clone, Debug, PartialEq)]
pub struct MantleVolume {
    pub n: usize,
    pub temperature: Vec<f32>,
    pub fluctuation: Vec<f32>,
    pub viscosity: Vec<f32>,
    /// The spherical grid the volume was resampled from.
    pub spherical: SphericalResolution,
}

impl MantleVolume {
    /// The field's voxels, or `None` when it was not generated.
    pub fn field(&self, field: MantleField) -> Option<&[f32]> {
        let values = match field {
            MantleField::Temperature => &self.temperature,
            MantleField::Fluctuation => &self.fluctuation,
            MantleField::Viscosity => &self.viscosity,
        };
        (!values.is_empty()).then_some(values.as_slice())
    }

    /// Centre of cell `index` along any axis.
    pub(crate) fn cell_centre(n: usize, index: usize) -> f64 {
        -1.0 + (index as f64 + 0.5) * (2.0 / n as f64)
    }
}

/// Temperature on the spherical grid, the source the Cartesian volume is resampled from. Node
/// (ir, it, ip) sits at radius `radius(ir)`, colatitude `colatitude(it)`, longitude
/// `longitude(ip)` and is stored at `index(ir, it, ip)` = (it phi + ip) radial + ir. The other two
/// fields are derived from temperature on demand: the fluctuation subtracts `radial_mean`, and
/// viscosity is a pointwise function of temperature.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SphericalGrid {
    pub resolution: SphericalResolution,
    pub temperature: Vec<f32>,
    /// Area-weighted mean temperature of each radial shell of nodes, weights from
    /// `shell_weights`.
    pub radial_mean: Vec<f64>,
    pub viscosity_contrast: f64,
}

impl SphericalGrid {
    #[cfg(test)]
    pub(crate) fn radius(&self, ir: usize) -> f64 {
        node_radius(&self.resolution, ir)
    }

    #[cfg(test)]
    pub(crate) fn colatitude(&self, it: usize) -> f64 {
        it as f64 * self.resolution.theta_step()
    }

    #[cfg(test)]
    pub(crate) fn longitude(&self, ip: usize) -> f64 {
        ip as f64 * self.resolution.phi_step()
    }

    #[cfg(test)]
    pub(crate) fn index(&self, ir: usize, it: usize, ip: usize) -> usize {
        (it * self.resolution.phi + ip) * self.resolution.radial + ir
    }

    /// Value of a field at a node.
    #[cfg(test)]
    pub(crate) fn node(&self, field: MantleField, ir: usize, it: usize, ip: usize) -> f64 {
        let temperature = self.temperature[self.index(ir, it, ip)] as f64;
        self.derive(field, temperature, self.radial_mean[ir])
    }

    /// Quadrature weight of one node of colatitude row `it` in a mean over a sphere: the area of
    /// the band [theta - dtheta/2, theta + dtheta/2] (clipped at the poles) shared equally by the
    /// row's `phi` nodes, normalised so that the weights of a sphere sum to 1. The band areas
    /// telescope to the whole sphere, so the poles get their cap and nothing is counted twice.
    #[cfg(test)]
    pub(crate) fn shell_weights(&self) -> Vec<f64> {
        row_weights(&self.resolution)
    }

    /// Trilinear interpolation in (r, theta, phi) at a Cartesian point; NaN outside the shell.
    /// This is exactly what `generate` does at every cell centre.
    #[cfg(test)]
    pub(crate) fn sample(&self, field: MantleField, x: f64, y: f64, z: f64) -> f64 {
        let rho = x.hypot(y);
        let phi = self.phi_cell(y.atan2(x));
        match self.interpolate(rho, z, &phi) {
            Some((temperature, mean)) => self.derive(field, temperature, mean),
            None => f64::NAN,
        }
    }

    fn derive(&self, field: MantleField, temperature: f64, radial_mean: f64) -> f64 {
        match field {
            MantleField::Temperature => temperature,
            MantleField::Fluctuation => temperature - radial_mean,
            MantleField::Viscosity => ((0.5 - temperature) * self.viscosity_contrast.ln()).exp(),
        }
    }

    fn phi_cell(&self, phi: f64) -> PhiCell {
        let nodes = self.resolution.phi;
        let position = phi.rem_euclid(TAU) / self.resolution.phi_step();
        let floor = position.floor();
        let lower = (floor as usize) % nodes;
        PhiCell {
            lower,
            upper: (lower + 1) % nodes,
            weight: (position - floor).clamp(0.0, 1.0),
        }
    }

    /// Temperature and radial-mean temperature at the point with cylindrical radius `rho`,
    /// height `z` and longitude cell `phi`, or `None` outside the shell. The interpolated
    /// viscosity is therefore geometric (linear in log eta), and the interpolated fluctuation
    /// equals the interpolated temperature minus the radially interpolated mean because
    /// trilinear weights sum to one.
    fn interpolate(&self, rho: f64, z: f64, phi: &PhiCell) -> Option<(f64, f64)> {
        let r = (rho * rho + z * z).sqrt();
        if !(INNER_RADIUS..=OUTER_RADIUS).contains(&r) {
            return None;
        }
        let res = &self.resolution;
        let (r_lower, r_weight) = cell((r - INNER_RADIUS) / res.radial_step(), res.radial);
        // atan2 of (rho, z) stays accurate at the poles, where acos(z / r) loses digits.
        let (t_lower, t_weight) = cell(rho.atan2(z) / res.theta_step(), res.theta);
        let mut temperature = 0.0;
        for (it, wt) in [(t_lower, 1.0 - t_weight), (t_lower + 1, t_weight)] {
            for (ip, wp) in [(phi.lower, 1.0 - phi.weight), (phi.upper, phi.weight)] {
                let base = (it * res.phi + ip) * res.radial + r_lower;
                let inner = self.temperature[base] as f64;
                let outer = self.temperature[base + 1] as f64;
                temperature += wt * wp * (inner + r_weight * (outer - inner));
            }
        }
        let mean = self.radial_mean[r_lower]
            + r_weight * (self.radial_mean[r_lower + 1] - self.radial_mean[r_lower]);
        Some((temperature, mean))
    }
}

struct PhiCell {
    lower: usize,
    upper: usize,
    weight: f64,
}

/// Lower node and weight of the upper node for a fractional node position on an axis of `nodes`
/// nodes; positions are clamped into the axis so that round-off at its ends does no harm.
fn cell(position: f64, nodes: usize) -> (usize, f64) {
    let last_cell = nodes - 2;
    let clamped = position.clamp(0.0, (nodes - 1) as f64);
    let lower = (clamped.floor() as usize).min(last_cell);
    (lower, clamped - lower as f64)
}

fn node_radius(res: &SphericalResolution, ir: usize) -> f64 {
    if ir + 1 == res.radial {
        OUTER_RADIUS
    } else {
        INNER_RADIUS + ir as f64 * res.radial_step()
    }
}

fn row_weights(res: &SphericalResolution) -> Vec<f64> {
    let step = res.theta_step();
    (0..res.theta)
        .map(|it| {
            let centre = it as f64 * step;
            let north = (centre - 0.5 * step).max(0.0);
            let south = (centre + 0.5 * step).min(PI);
            (north.cos() - south.cos()) / (2.0 * res.phi as f64)
        })
        .collect()
}

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

struct Features {
    plumes: Vec<Plume>,
    slabs: Vec<Slab>,
}

impl Features {
    fn place(opts: &MantleOptions, layers: &BoundaryLayers, finest_width: f64) -> Self {
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
struct Model<'a> {
    res: SphericalResolution,
    radii: Vec<f64>,
    /// Radial temperature profile without lateral structure.
    profile: Vec<f64>,
    /// eps sin(pi (r - r_b) / (r_t - r_b)).
    bump: Vec<f64>,
    /// cos(m phi) + sin(m phi), and the node's direction cosines.
    azimuth: Vec<f64>,
    cos_phi: Vec<f64>,
    sin_phi: Vec<f64>,
    layers: BoundaryLayers,
    features: Features,
    opts: &'a MantleOptions,
}

impl Model<'_> {
    fn fill_row(&self, it: usize, row: &mut [f32]) -> Vec<f64> {
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

/// Builds the temperature and its radial mean on the spherical grid, without the Cartesian
/// resampling; `opts.fields` and `opts.n` (beyond choosing the default resolution) play no part.
#[cfg(test)]
pub(crate) fn spherical_field(opts: &MantleOptions) -> Result<SphericalGrid> {
    opts.validate()?;
    build_spherical(opts, &mut |_| {})
}

fn build_spherical(opts: &MantleOptions, progress: &mut dyn FnMut(f64)) -> Result<SphericalGrid> {
    let res = opts.spherical_resolution();
    let radii: Vec<f64> = (0..res.radial).map(|ir| node_radius(&res, ir)).collect();
    let convecting = opts.rayleigh > CRITICAL_RAYLEIGH;
    let layers = BoundaryLayers::for_rayleigh(if convecting {
        opts.rayleigh
    } else {
        FEATURE_RAYLEIGH_WITHOUT_CONVECTION
    });
    let profile = radii
        .iter()
        .map(|&r| {
            if convecting {
                layers.temperature(r)
            } else {
                conductive_temperature(r)
            }
        })
        .collect();
    let bump = radii
        .iter()
        .enumerate()
        .map(|(ir, &r)| {
            // sin(pi) is 1.2e-16, not 0: keep the boundary values exact.
            if ir == 0 || ir + 1 == res.radial {
                0.0
            } else {
                opts.epsilon * (PI * (r - INNER_RADIUS) / SHELL_THICKNESS).sin()
            }
        })
        .collect();
    let phis: Vec<f64> = (0..res.phi).map(|ip| ip as f64 * res.phi_step()).collect();
    let m = opts.order as f64;
    let finest_width = res
        .radial_step()
        .max(OUTER_RADIUS * res.theta_step())
        .max(OUTER_RADIUS * res.phi_step());
    let model = Model {
        res,
        profile,
        bump,
        azimuth: phis
            .iter()
            .map(|&p| (m * p).cos() + (m * p).sin())
            .collect(),
        cos_phi: phis.iter().map(|p| p.cos()).collect(),
        sin_phi: phis.iter().map(|p| p.sin()).collect(),
        features: Features::place(opts, &layers, finest_width),
        layers,
        radii,
        opts,
    };

    let mut temperature = allocate(res.nodes(), "spherical grid")?;
    let row_len = res.phi * res.radial;
    let weights = row_weights(&res);
    let mut shell_sums = vec![0.0; res.radial];
    let rows_per_step = res.theta.div_ceil(PROGRESS_STEPS).max(1);
    for (step, rows) in temperature.chunks_mut(rows_per_step * row_len).enumerate() {
        let first_row = step * rows_per_step;
        let row_sums: Vec<Vec<f64>> = rows
            .par_chunks_mut(row_len)
            .enumerate()
            .map(|(offset, row)| model.fill_row(first_row + offset, row))
            .collect();
        // Summed in row order so that the mean does not depend on thread scheduling.
        for (offset, sums) in row_sums.iter().enumerate() {
            let weight = weights[first_row + offset];
            for (total, sum) in shell_sums.iter_mut().zip(sums) {
                *total += weight * sum;
            }
        }
        progress(((first_row + row_sums.len()) as f64 / res.theta as f64).min(1.0));
    }
    let weight_total: f64 = weights.iter().sum::<f64>() * res.phi as f64;
    let radial_mean = shell_sums.iter().map(|s| s / weight_total).collect();
    Ok(SphericalGrid {
        resolution: res,
        temperature,
        radial_mean,
        viscosity_contrast: opts.viscosity_contrast,
    })
}

fn allocate(len: usize, what: &str) -> Result<Vec<f32>> {
    let mut values = Vec::new();
    values.try_reserve_exact(len).map_err(|_| {
        Error::invalid(
            "n",
            format!(
                "cannot allocate {:.0} MiB for the {what}; lower n or the resolution",
                len as f64 * 4.0 / (1024.0 * 1024.0)
            ),
        )
    })?;
    values.resize(len, 0.0);
    Ok(values)
}

/// Longitude cell and cylindrical radius of one (i, j) column of the Cartesian box, shared by
/// all its z cells.
struct BoxColumn {
    rho: f64,
    phi: PhiCell,
}

/// Cells per side of the blocks the resampling walks through, and z slices per parallel task.
const TILE: usize = 16;
const SLAB_DEPTH: usize = TILE;

/// `SLAB_DEPTH` consecutive z slices (fewer in the last slab) of each requested output.
struct SlabOutputs<'a> {
    first_k: usize,
    depth: usize,
    temperature: Option<&'a mut [f32]>,
    fluctuation: Option<&'a mut [f32]>,
    viscosity: Option<&'a mut [f32]>,
}

fn slabs(values: &mut [f32], len: usize, wanted: bool, n: usize) -> Vec<Option<&mut [f32]>> {
    if wanted {
        values.chunks_mut(len).map(Some).collect()
    } else {
        (0..n.div_ceil(SLAB_DEPTH)).map(|_| None).collect()
    }
}

/// Builds the spherical grid and resamples the requested fields onto the n^3 box. `progress`
/// receives fractions from 0 to 1 on the calling thread. Memory: 4 bytes per spherical node
/// (`SphericalResolution::nodes`) plus 4 n^3 bytes per requested field; for n = 513 that is
/// 612 MB + 540 MB per field.
pub fn generate(opts: &MantleOptions, progress: &mut dyn FnMut(f64)) -> Result<MantleVolume> {
    opts.validate()?;
    progress(0.0);
    let grid = build_spherical(opts, &mut |f| progress(f * SPHERICAL_PROGRESS_SHARE))?;
    let n = opts.n;
    let cells = n * n * n;
    let fields = opts.fields;
    let mut outputs = [Vec::new(), Vec::new(), Vec::new()];
    for (output, field) in outputs.iter_mut().zip(MantleField::ALL) {
        if fields.contains(field) {
            *output = allocate(cells, field.name())?;
        }
    }
    let [mut temperature, mut fluctuation, mut viscosity] = outputs;

    let columns: Vec<BoxColumn> = (0..n * n)
        .map(|c| {
            let x = MantleVolume::cell_centre(n, c % n);
            let y = MantleVolume::cell_centre(n, c / n);
            BoxColumn {
                rho: x.hypot(y),
                phi: grid.phi_cell(y.atan2(x)),
            }
        })
        .collect();
    let slab_len = SLAB_DEPTH * n * n;
    let mut work: Vec<SlabOutputs> = slabs(&mut temperature, slab_len, fields.temperature, n)
        .into_iter()
        .zip(slabs(&mut fluctuation, slab_len, fields.fluctuation, n))
        .zip(slabs(&mut viscosity, slab_len, fields.viscosity, n))
        .enumerate()
        .map(
            |(slab, ((temperature, fluctuation), viscosity))| SlabOutputs {
                first_k: slab * SLAB_DEPTH,
                depth: SLAB_DEPTH.min(n - slab * SLAB_DEPTH),
                temperature,
                fluctuation,
                viscosity,
            },
        )
        .collect();
    let slab_count = work.len();
    let slabs_per_step = rayon::current_num_threads().max(1);
    let mut done = 0;
    for batch in work.chunks_mut(slabs_per_step) {
        batch
            .par_iter_mut()
            .for_each(|slab| resample_slab(&grid, &columns, n, slab));
        done += batch.len();
        progress(
            SPHERICAL_PROGRESS_SHARE
                + (1.0 - SPHERICAL_PROGRESS_SHARE) * done as f64 / slab_count as f64,
        );
    }
    drop(work);
    Ok(MantleVolume {
        n,
        temperature,
        fluctuation,
        viscosity,
        spherical: grid.resolution,
    })
}

/// The mantle on its own spherical grid, as a convection code would write it: node radii in km
/// (the surface at Earth's radius, the core-mantle boundary at 0.55 of it), latitudes from the
/// South Pole to the North Pole inclusive, longitudes all round; and the requested fields on
/// that grid, longitude fastest, then latitude, then radius (the C order of a NetCDF variable on
/// (radius, latitude, longitude)).
#[derive(Clone, Debug)]
pub struct NativeMantle {
    pub geometry: crate::model::SphericalGrid,
    /// Voxel counts (longitudes, latitudes, radii).
    pub dims: [usize; 3],
    pub fields: Vec<(MantleField, Vec<f32>)>,
}

impl NativeMantle {
    /// One field as a spherical volume (`None` when it was not generated).
    pub fn volume(&self, field: MantleField, seed: u64) -> Result<Option<crate::model::Volume>> {
        let Some((_, data)) = self.fields.iter().find(|(f, _)| *f == field) else {
            return Ok(None);
        };
        let [nlon, nlat, nr] = self.dims;
        let mut v = crate::model::Volume::new(
            format!(
                "mantle-{} {nr}x{nlat}x{nlon} (r, lat, lon) seed={seed}",
                field.name()
            ),
            self.dims,
            [1.0; 3],
            [0.0; 3],
            data.clone(),
        )?
        .with_geometry(crate::model::Geometry::Spherical(Box::new(
            self.geometry.clone(),
        )))?;
        v.units = "non-dimensional".into();
        Ok(Some(v))
    }
}

/// Builds the spherical grid and returns the requested fields on it, with no Cartesian
/// resampling (`opts.n` only picks the default resolution). Memory: 4 bytes per node for the
/// grid and for each field.
pub fn generate_native(
    opts: &MantleOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<NativeMantle> {
    use crate::model::{CoordAxis, SphericalGrid as Shell};
    opts.validate()?;
    progress(0.0);
    let grid = build_spherical(opts, &mut |f| progress(0.8 * f))?;
    let res = grid.resolution;
    let km = super::cf::EARTH_RADIUS_KM;
    let radii: Vec<f64> = (0..res.radial)
        .map(|ir| km * node_radius(&res, ir))
        .collect();
    // Colatitude row it is latitude 90 - it·dθ; latitudes are stored rising.
    let latitudes: Vec<f64> = (0..res.theta)
        .map(|j| -90.0 + j as f64 * 180.0 / (res.theta - 1) as f64)
        .collect();
    let step = 360.0 / res.phi as f64;
    let longitudes: Vec<f64> = (0..res.phi).map(|ip| ip as f64 * step).collect();
    let geometry = Shell {
        axis_of: [2, 1, 0],
        radius: CoordAxis::new(radii, None, "radius")?,
        latitude: CoordAxis::new(latitudes, None, "latitude")?,
        longitude: CoordAxis {
            centres: longitudes,
            lo: -0.5 * step,
            hi: 360.0 - 0.5 * step,
        },
        lon_wraps: true,
        planet_radius: km,
        length_unit: "km".into(),
        vertical: "radius".into(),
    };
    let layer = res.theta * res.phi;
    let mut fields = Vec::new();
    for field in MantleField::ALL {
        if !opts.fields.contains(field) {
            continue;
        }
        let mut data = allocate(res.nodes(), field.name())?;
        data.par_chunks_mut(layer)
            .enumerate()
            .for_each(|(ir, shell)| {
                let mean = grid.radial_mean[ir];
                for (j, row) in shell.chunks_mut(res.phi).enumerate() {
                    let it = res.theta - 1 - j;
                    for (ip, out) in row.iter_mut().enumerate() {
                        let t = grid.temperature[(it * res.phi + ip) * res.radial + ir] as f64;
                        *out = grid.derive(field, t, mean) as f32;
                    }
                }
            });
        fields.push((field, data));
    }
    progress(1.0);
    Ok(NativeMantle {
        geometry,
        dims: [res.phi, res.theta, res.radial],
        fields,
    })
}

/// Resamples one slab tile by tile: a 16^3 block of cells reads a compact patch of the
/// spherical grid, where a whole slice at a time would stream most of the grid through the
/// cache for every slice.
fn resample_slab(grid: &SphericalGrid, columns: &[BoxColumn], n: usize, out: &mut SlabOutputs) {
    let log_contrast = grid.viscosity_contrast.ln();
    for j0 in (0..n).step_by(TILE) {
        for i0 in (0..n).step_by(TILE) {
            for dk in 0..out.depth {
                let z = MantleVolume::cell_centre(n, out.first_k + dk);
                for j in j0..(j0 + TILE).min(n) {
                    for i in i0..(i0 + TILE).min(n) {
                        let column = &columns[j * n + i];
                        let cell = (dk * n + j) * n + i;
                        let (temperature, fluctuation, viscosity) =
                            match grid.interpolate(column.rho, z, &column.phi) {
                                Some((t, mean)) => (
                                    t as f32,
                                    (t - mean) as f32,
                                    ((0.5 - t) * log_contrast).exp() as f32,
                                ),
                                None => (f32::NAN, f32::NAN, f32::NAN),
                            };
                        if let Some(values) = out.temperature.as_deref_mut() {
                            values[cell] = temperature;
                        }
                        if let Some(values) = out.fluctuation.as_deref_mut() {
                            values[cell] = fluctuation;
                        }
                        if let Some(values) = out.viscosity.as_deref_mut() {
                            values[cell] = viscosity;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quiet() -> impl FnMut(f64) {
        |_| {}
    }

    fn small(n: usize) -> MantleOptions {
        MantleOptions {
            n,
            ..MantleOptions::default()
        }
    }

    #[test]
    fn conductive_profile_has_the_boundary_values() {
        assert!((conductive_temperature(INNER_RADIUS) - 1.0).abs() < 1e-15);
        assert!(conductive_temperature(OUTER_RADIUS).abs() < 1e-15);
        let layers = BoundaryLayers::for_rayleigh(1e7);
        assert!((layers.temperature(INNER_RADIUS) - 1.0).abs() < 1e-12);
        assert!(layers.temperature(OUTER_RADIUS).abs() < 1e-12);
        // Interior from equal heat flow through both layers: q = 0.55^1.5, T_i = q / (1 + q).
        let q = 0.55f64.powf(1.5);
        assert!((layers.interior - q / (1.0 + q)).abs() < 1e-15);
        assert!((layers.interior - 0.2897).abs() < 1e-4);
        let flux_top = OUTER_RADIUS.powi(2) * layers.interior / layers.top;
        let flux_bottom = INNER_RADIUS.powi(2) * (1.0 - layers.interior) / layers.bottom;
        assert!((flux_top / flux_bottom - 1.0).abs() < 1e-12);
        // Mid-shell sits in the isothermal interior.
        assert!((layers.temperature(0.775) - layers.interior).abs() < 1e-6);
    }

    fn conductive_options(n: usize) -> MantleOptions {
        MantleOptions {
            epsilon: 0.0,
            plumes: 0,
            slabs: 0,
            rayleigh: 0.0,
            ..small(n)
        }
    }

    #[test]
    fn conductive_shell_equals_closed_form() {
        let opts = conductive_options(33);
        let grid = spherical_field(&opts).unwrap();
        let res = grid.resolution;
        for ir in 0..res.radial {
            let expected = conductive_temperature(grid.radius(ir));
            for (it, ip) in [(0, 0), (res.theta / 3, 5), (res.theta - 1, res.phi - 1)] {
                let node = grid.node(MantleField::Temperature, ir, it, ip);
                assert!((node - expected).abs() < 1e-7);
            }
        }
        assert!((grid.node(MantleField::Temperature, 0, 2, 3) - 1.0).abs() < 1e-7);
        assert!(
            grid.node(MantleField::Temperature, res.radial - 1, 2, 3)
                .abs()
                < 1e-7
        );

        // Linear interpolation of T_c errs by at most dr^2/8 max|T_c''|, with
        // T_c'' = 2 r_b r_t / ((r_t - r_b) r^3), largest at r_b.
        let volume = generate(&opts, &mut quiet()).unwrap();
        let dr = res.radial_step();
        let bound = dr * dr / 8.0 * 2.0 * INNER_RADIUS * OUTER_RADIUS
            / (SHELL_THICKNESS * INNER_RADIUS.powi(3))
            + 1e-6;
        let n = opts.n;
        let mut inside = 0;
        let mut worst: f64 = 0.0;
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let (x, y, z) = (
                        MantleVolume::cell_centre(n, i),
                        MantleVolume::cell_centre(n, j),
                        MantleVolume::cell_centre(n, k),
                    );
                    let r = (x * x + y * y + z * z).sqrt();
                    let value = volume.temperature[(k * n + j) * n + i];
                    if (INNER_RADIUS..=OUTER_RADIUS).contains(&r) {
                        inside += 1;
                        worst = worst.max((value as f64 - conductive_temperature(r)).abs());
                    } else {
                        assert!(value.is_nan(), "outside the shell at r = {r}");
                    }
                }
            }
        }
        assert!(inside > 10_000);
        assert!(worst <= bound, "worst {worst} bound {bound}");
        assert!(worst > 0.0);
    }

    #[test]
    fn resampled_field_equals_nodes_where_they_coincide() {
        // n = 21 puts cell centres at 2m/21 on the axes; with r_b = 11/20 a radial step of
        // 1/420 (190 nodes) makes r = 2m/21 a radial node for m = 6..10. Theta = 9 and phi = 16
        // nodes put the six axis directions on nodes, the poles included.
        let n = 21;
        let opts = MantleOptions {
            resolution: Some(SphericalResolution {
                radial: 190,
                theta: 9,
                phi: 16,
            }),
            plumes: 40,
            slabs: 20,
            ..small(n)
        };
        let grid = spherical_field(&opts).unwrap();
        let volume = generate(&opts, &mut quiet()).unwrap();
        let centre = n / 2;
        let axes = [
            ([1i64, 0, 0], 4usize, 0usize),
            ([-1, 0, 0], 4, 8),
            ([0, 1, 0], 4, 4),
            ([0, -1, 0], 4, 12),
            ([0, 0, 1], 0, 0),
            ([0, 0, -1], 8, 0),
        ];
        let mut compared = 0;
        for (direction, it, ip) in axes {
            for m in 6..=10i64 {
                let ir = (40 * m - 231) as usize;
                assert!((grid.radius(ir) - 2.0 * m as f64 / 21.0).abs() < 1e-12);
                let cell = |d: i64| (centre as i64 + d * m) as usize;
                let (i, j, k) = (cell(direction[0]), cell(direction[1]), cell(direction[2]));
                let index = (k * n + j) * n + i;
                for field in MantleField::ALL {
                    let node = grid.node(field, ir, it, ip);
                    let voxel = volume.field(field).unwrap()[index] as f64;
                    let tolerance = 1e-6 * node.abs().max(1.0);
                    assert!(
                        (voxel - node).abs() < tolerance,
                        "{field:?} at {direction:?} r={} voxel {voxel} node {node}",
                        grid.radius(ir)
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 6 * 5 * 3);
        // And the volume is the public sampler at every cell centre.
        for index in [0, 4000, 5000, 6000, 9260] {
            let (i, j, k) = (index % n, index / n % n, index / (n * n));
            let sampled = grid.sample(
                MantleField::Fluctuation,
                MantleVolume::cell_centre(n, i),
                MantleVolume::cell_centre(n, j),
                MantleVolume::cell_centre(n, k),
            );
            let voxel = volume.fluctuation[index] as f64;
            assert!((sampled.is_nan() && voxel.is_nan()) || (sampled - voxel).abs() < 1e-7);
        }
    }

    #[test]
    fn harmonic_perturbation_has_degree_three_order_two_pattern() {
        // Mid-shell node where sin(pi (r - r_b) / d) = 1; theta - 1 = 16 and phi = 32 place
        // nodes on every pi/16.
        let opts = MantleOptions {
            epsilon: 0.01,
            resolution: Some(SphericalResolution {
                radial: 9,
                theta: 17,
                phi: 32,
            }),
            ..conductive_options(16)
        };
        let grid = spherical_field(&opts).unwrap();
        let mid = 4;
        let r = grid.radius(mid);
        assert!((r - 0.775).abs() < 1e-15);
        let perturbation = |it: usize, ip: usize| {
            grid.node(MantleField::Temperature, mid, it, ip) - conductive_temperature(r)
        };
        let res = grid.resolution;
        for it in 0..res.theta {
            for ip in 0..res.phi {
                let (theta, phi) = (grid.colatitude(it), grid.longitude(ip));
                let x = theta.cos();
                let closed = 0.01
                    * ((2.0 * phi).cos() + (2.0 * phi).sin())
                    * 15.0
                    * (7.0 / (240.0 * PI)).sqrt()
                    * x
                    * (1.0 - x * x);
                assert!((perturbation(it, ip) - closed).abs() < 1e-7);
            }
        }
        // Along a parallel at theta = pi/4: cos 2phi + sin 2phi = sqrt(2) sin(2 phi + pi/4)
        // changes sign 2m = 4 times, between the nodes around 3pi/8, 7pi/8, 11pi/8, 15pi/8.
        let it = 4;
        let signs: Vec<bool> = (0..res.phi).map(|ip| perturbation(it, ip) > 0.0).collect();
        let changes: Vec<usize> = (0..res.phi)
            .filter(|&ip| signs[ip] != signs[(ip + 1) % res.phi])
            .collect();
        // Zeros at 3pi/8 = node 6 exactly: the sign flips between 5|6 or 6|7 depending on
        // round-off at the zero, so check with the node values around it.
        assert_eq!(changes.len(), 4, "{changes:?}");
        for (change, zero) in changes.iter().zip([6usize, 14, 22, 30]) {
            assert!(change + 1 == zero || *change == zero, "{change} vs {zero}");
        }
        assert!(perturbation(it, 2) > 0.0);
        // Along the meridian phi = pi/8, where cos 2phi + sin 2phi = sqrt(2) is largest:
        // P_32 ~ cos(theta) sin^2(theta) has l - m = 1 interior zero, at the equator, and
        // vanishes at both poles.
        let ip = 2;
        // Zero to the f32 rounding of the stored temperature.
        assert!(perturbation(0, ip).abs() < 1e-7);
        assert!(perturbation(16, ip).abs() < 1e-7);
        assert!(perturbation(8, ip).abs() < 1e-7);
        assert!((1..8).all(|it| perturbation(it, ip) > 0.0));
        assert!((9..16).all(|it| perturbation(it, ip) < 0.0));
    }

    #[test]
    fn seed_determines_the_field() {
        let opts = small(24);
        let first = generate(&opts, &mut quiet()).unwrap();
        let again = generate(&opts, &mut quiet()).unwrap();
        let bits = |v: &MantleVolume| {
            v.temperature
                .iter()
                .map(|t| t.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&first), bits(&again));
        let other = generate(
            &MantleOptions {
                seed: 2,
                ..opts.clone()
            },
            &mut quiet(),
        )
        .unwrap();
        let differing = first
            .temperature
            .iter()
            .zip(&other.temperature)
            .filter(|(a, b)| a.is_finite() && (*a - *b).abs() > 1e-3)
            .count();
        assert!(differing > 100, "{differing}");
    }

    #[test]
    fn fluctuation_has_zero_mean_on_every_shell() {
        let opts = small(48);
        let grid = spherical_field(&opts).unwrap();
        let res = grid.resolution;
        let weights = grid.shell_weights();
        assert!((weights.iter().sum::<f64>() * res.phi as f64 - 1.0).abs() < 1e-12);
        let mut largest_fluctuation: f64 = 0.0;
        for ir in 0..res.radial {
            let mut mean = 0.0;
            for (it, weight) in weights.iter().enumerate() {
                for ip in 0..res.phi {
                    let value = grid.node(MantleField::Fluctuation, ir, it, ip);
                    largest_fluctuation = largest_fluctuation.max(value.abs());
                    mean += weight * value;
                }
            }
            assert!(mean.abs() < 1e-6, "shell {ir}: {mean}");
        }
        // Plumes and slabs make fluctuations of a good fraction of the temperature drop.
        assert!(largest_fluctuation > 0.1, "{largest_fluctuation}");
    }

    #[test]
    fn boundary_temperatures_survive_plumes_and_slabs() {
        let opts = MantleOptions {
            plumes: 60,
            slabs: 40,
            ..small(40)
        };
        let grid = spherical_field(&opts).unwrap();
        let res = grid.resolution;
        for it in 0..res.theta {
            for ip in 0..res.phi {
                let bottom = grid.node(MantleField::Temperature, 0, it, ip);
                let top = grid.node(MantleField::Temperature, res.radial - 1, it, ip);
                assert!(
                    (bottom - 1.0).abs() < 1e-7 && top.abs() < 1e-7,
                    "{bottom} {top}"
                );
            }
        }
    }

    #[test]
    fn viscosity_spans_decades() {
        let volume = generate(&small(32), &mut quiet()).unwrap();
        let finite = volume.viscosity.iter().filter(|v| v.is_finite());
        let (low, high) = finite.fold((f32::MAX, 0.0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(low > 0.0);
        assert!((high / low).log10() > 3.0, "{low} .. {high}");
        // eta = 1e5^(0.5 - T) with 0 <= T <= 1 keeps it within 10^-2.5..10^2.5.
        assert!(low >= 10f32.powf(-2.5) * (1.0 - 1e-5), "{low}");
        assert!(high <= 10f32.powf(2.5) * (1.0 + 1e-5), "{high}");
    }

    #[test]
    fn only_the_requested_field_is_generated() {
        let opts = MantleOptions {
            fields: MantleFields::only(MantleField::Viscosity),
            ..small(16)
        };
        let volume = generate(&opts, &mut quiet()).unwrap();
        assert!(volume.temperature.is_empty() && volume.fluctuation.is_empty());
        assert_eq!(volume.viscosity.len(), 16 * 16 * 16);
        assert!(volume.field(MantleField::Temperature).is_none());
        let all = generate(&small(16), &mut quiet()).unwrap();
        let bits = |values: &[f32]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&all.viscosity), bits(&volume.viscosity));
    }

    #[test]
    fn progress_rises_to_one() {
        let mut seen = Vec::new();
        generate(&small(20), &mut |f| seen.push(f)).unwrap();
        assert_eq!(seen.first(), Some(&0.0));
        assert!((seen.last().unwrap() - 1.0).abs() < 1e-12);
        assert!(seen.windows(2).all(|w| w[1] >= w[0]));
    }

    #[test]
    fn bad_parameters_are_rejected() {
        let cases = [
            MantleOptions { n: 1, ..small(8) },
            MantleOptions {
                n: 4096,
                ..small(8)
            },
            MantleOptions {
                rayleigh: f64::NAN,
                ..small(8)
            },
            MantleOptions {
                rayleigh: -1.0,
                ..small(8)
            },
            MantleOptions {
                epsilon: f64::INFINITY,
                ..small(8)
            },
            MantleOptions {
                viscosity_contrast: 0.5,
                ..small(8)
            },
            MantleOptions {
                degree: 2,
                order: 3,
                ..small(8)
            },
            MantleOptions {
                fields: MantleFields {
                    temperature: false,
                    fluctuation: false,
                    viscosity: false,
                },
                ..small(8)
            },
            MantleOptions {
                resolution: Some(SphericalResolution {
                    radial: 1,
                    theta: 9,
                    phi: 16,
                }),
                ..small(8)
            },
        ];
        for opts in cases {
            let error = generate(&opts, &mut quiet()).unwrap_err();
            assert!(matches!(error, Error::Invalid { .. }), "{error}");
            assert!(!error.to_string().contains('\n'));
        }
        assert!(MantleField::parse("Viscosity").is_ok());
        assert!(MantleField::parse("pressure").is_err());
    }

    #[test]
    fn resolution_for_the_papers_box() {
        let res = SphericalResolution::for_cartesian(513);
        assert_eq!((res.radial, res.theta, res.phi), (117, 809, 1616));
        assert!(res.radial_step() <= 2.0 / 513.0);
        assert!(res.theta_step() <= 2.0 / 513.0 && res.phi_step() <= 2.0 / 513.0);
    }
}
