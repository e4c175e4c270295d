//! What the mantle generator is asked for: the fields, the spherical grid's resolution and the
//! model's parameters, with their checks.

use std::f64::consts::{PI, TAU};

use super::{
    MAX_AXIS_NODES, MAX_DEGREE, MAX_FEATURES, MAX_N, MAX_RAYLEIGH, OUTER_RADIUS, SHELL_THICKNESS,
};
use crate::error::{Error, Result};

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

    pub(super) fn count(self) -> usize {
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

    pub(super) fn validate(&self) -> Result<()> {
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

    pub(super) fn radial_step(&self) -> f64 {
        SHELL_THICKNESS / (self.radial - 1) as f64
    }

    pub(super) fn theta_step(&self) -> f64 {
        PI / (self.theta - 1) as f64
    }

    pub(super) fn phi_step(&self) -> f64 {
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
