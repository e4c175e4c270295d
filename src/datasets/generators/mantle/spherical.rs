//! The temperature on the spherical (r, theta, phi) grid and its trilinear interpolation in
//! (r, theta, phi), with the node radii and the quadrature weights of a sphere's rows.

use std::f64::consts::{PI, TAU};

use super::options::{MantleField, SphericalResolution};
use super::{INNER_RADIUS, OUTER_RADIUS};

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

    pub(super) fn derive(&self, field: MantleField, temperature: f64, radial_mean: f64) -> f64 {
        match field {
            MantleField::Temperature => temperature,
            MantleField::Fluctuation => temperature - radial_mean,
            MantleField::Viscosity => ((0.5 - temperature) * self.viscosity_contrast.ln()).exp(),
        }
    }

    pub(super) fn phi_cell(&self, phi: f64) -> PhiCell {
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
    pub(super) fn interpolate(&self, rho: f64, z: f64, phi: &PhiCell) -> Option<(f64, f64)> {
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

pub(super) struct PhiCell {
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

pub(super) fn node_radius(res: &SphericalResolution, ir: usize) -> f64 {
    if ir + 1 == res.radial {
        OUTER_RADIUS
    } else {
        INNER_RADIUS + ir as f64 * res.radial_step()
    }
}

pub(super) fn row_weights(res: &SphericalResolution) -> Vec<f64> {
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
