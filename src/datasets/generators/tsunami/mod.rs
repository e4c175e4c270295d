//! Tsunami propagation with the shallow-water equations on a staggered leap-frog Arakawa C grid,
//! in the style of TUNAMI-N1 and COMCOT's linear layer: sea-surface elevation at cell centres,
//! volume fluxes M and N (depth-integrated velocity, m^2/s) on the faces, half a time step
//! apart. Coordinates are Cartesian metres; cells with depth <= 0 are land, kept dry, and act as
//! reflective walls. The equations are linear unless advection and Manning bottom friction are
//! asked for (TUNAMI-N2 style). The module also builds a synthetic South-China-Sea-like basin with
//! a Manila-trench thrust source for demonstrations, and turns real elevation grids into
//! bathymetry.

//!
//! The rooms: `solver` (the leap-frog scheme on the staggered grid), `bathymetry` (still-water
//! depth, from elevation grids and degree spacings), `scenario` (the synthetic basin and its
//! Manila-trench source); this file holds the options and the run.

mod bathymetry;
mod scenario;
mod solver;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
pub(crate) use bathymetry::{bathymetry_from_elevation, grid_spacing_from_lonlat, Bathymetry};
pub(crate) use scenario::{manila_trench_source, scaled_to_extent, synthetic_south_china_sea};
use solver::Model;
/// Standard gravity used by default, m/s^2.
pub(crate) const DEFAULT_GRAVITY: f64 = 9.81;

/// Fraction of the CFL limit used when no time step is given.
pub(crate) const DEFAULT_CFL_FRACTION: f64 = 0.8;

/// Mean Earth radius (IUGG), used by the degree-to-metre conversion.
pub(crate) const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Side of the square domain that `manila_trench_source` positions refer to.
pub const SOUTH_CHINA_SEA_EXTENT_M: f64 = 2_000_000.0;

/// Total water depth below which the nonlinear terms are evaluated with this floor instead; the
/// model has no wetting and drying, so this only keeps a strong drawdown from dividing by zero.
const MIN_TOTAL_DEPTH_M: f64 = 0.01;

/// What happens at the four edges of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Boundary {
    /// Waves leave through the edge: the normal flux is set to the outgoing characteristic,
    /// M = +-sqrt(g h) eta, as TUNAMI does.
    Open,
    /// A vertical wall: no flux through the edge, so total volume is conserved.
    Reflective,
}

#[derive(Debug, Clone, PartialEq)]
pub struct TsunamiOptions {
    /// Simulated time, s.
    pub duration_s: f64,
    /// Time step, s. `None` takes `DEFAULT_CFL_FRACTION` of the CFL limit. Either way the step
    /// is shortened slightly so that a whole number of steps ends exactly at `duration_s`.
    pub dt_s: Option<f64>,
    pub boundary: Boundary,
    /// Adds momentum advection and Manning bottom friction (TUNAMI-N2 style).
    pub nonlinear: bool,
    /// Manning roughness, s/m^(1/3); used only when `nonlinear` is set.
    pub manning_n: f64,
    /// A cell's arrival time is the first time |eta| exceeds this, m.
    pub arrival_threshold_m: f64,
    /// Gravity, m/s^2.
    pub g: f64,
}

impl Default for TsunamiOptions {
    fn default() -> Self {
        TsunamiOptions {
            duration_s: 7200.0,
            dt_s: None,
            boundary: Boundary::Open,
            nonlinear: false,
            manning_n: 0.025,
            arrival_threshold_m: 0.01,
            g: DEFAULT_GRAVITY,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TsunamiResult {
    /// Largest |eta| reached in each cell over the run, the initial state included, m; NaN on
    /// land (depth <= 0).
    pub max_abs_eta: Vec<f64>,
    /// First time |eta| exceeded the arrival threshold, s; NaN where it never did.
    pub arrival_time_s: Vec<f64>,
    /// Sea-surface elevation at the end of the run, m.
    pub final_eta: Vec<f64>,
    pub steps: usize,
    /// The time step actually used, s.
    pub dt_s: f64,
}

/// Propagates the initial sea-surface displacement `eta0` (same layout as the depth grid; the
/// water starts at rest) for `opts.duration_s`. Displacement given on land cells is ignored.
/// `progress` receives the fraction of steps done, at most about a hundred times, ending at 1.
pub(crate) fn simulate(
    bathy: &Bathymetry,
    eta0: &[f64],
    opts: &TsunamiOptions,
    progress: &mut dyn FnMut(f64) -> Result<()>,
) -> Result<TsunamiResult> {
    bathy.validate()?;
    validate_options(opts)?;
    let cells = bathy.nx * bathy.ny;
    if eta0.len() != cells {
        return Err(Error::invalid(
            "eta0",
            format!("expected nx * ny = {cells} values, got {}", eta0.len()),
        ));
    }
    if let Some(index) = eta0.iter().position(|e| !e.is_finite()) {
        return Err(Error::invalid(
            "eta0",
            format!(
                "displacement must be finite, got {} at index {index}",
                eta0[index]
            ),
        ));
    }
    let h_max = bathy.max_depth_m();
    if h_max <= 0.0 {
        return Err(Error::invalid(
            "depth_m",
            "no cell is below sea level (depth > 0), nothing to propagate",
        ));
    }
    // The nonlinear wave speed follows the total depth, so the crest sets the limit.
    let crest = if opts.nonlinear {
        eta0.iter()
            .zip(&bathy.depth_m)
            .filter(|(_, &d)| d > 0.0)
            .fold(0.0_f64, |acc, (&e, _)| acc.max(e))
    } else {
        0.0
    };
    let dt_limit = bathy.dx_m.min(bathy.dy_m) / (2.0 * opts.g * (h_max + crest)).sqrt();
    let dt_wanted = match opts.dt_s {
        Some(dt) if dt > dt_limit => {
            return Err(Error::invalid(
                "dt",
                format!(
                    "{dt} s violates the CFL limit min(dx, dy) / sqrt(2 g h_max) = {dt_limit:.6} s"
                ),
            ))
        }
        Some(dt) => dt,
        None => DEFAULT_CFL_FRACTION * dt_limit,
    };
    let steps_f = (opts.duration_s / dt_wanted * (1.0 - 1e-12))
        .ceil()
        .max(1.0);
    if steps_f > 1e9 {
        return Err(Error::invalid(
            "duration_s",
            format!("{steps_f:.3e} time steps needed; shorten the run or coarsen the grid"),
        ));
    }
    let steps = steps_f as usize;
    let dt = opts.duration_s / steps as f64;

    let mut model = Model::new(bathy, eta0, opts, dt);
    let report_every = steps.div_ceil(100).max(1);
    for step in 0..steps {
        // The water starts at rest at t = 0, so the first flux update spans only half a step
        // to bring the fluxes to t = dt/2; this keeps the start second-order accurate.
        let dt_fraction = if step == 0 { 0.5 } else { 1.0 };
        if opts.nonlinear {
            model.nonlinear_momentum(dt_fraction, opts.manning_n);
        } else {
            model.linear_momentum(dt_fraction);
        }
        model.continuity_and_record((step + 1) as f64 * dt, opts.arrival_threshold_m);
        if (step + 1) % report_every == 0 || step + 1 == steps {
            progress((step + 1) as f64 / steps as f64)?;
        }
    }
    // Land has no sea surface: its maximum is missing (NaN), not a zero wave that would draw as
    // a calm sea (or a dark fringe) in a surface map.
    let max_abs_eta = model
        .max_abs_eta
        .iter()
        .zip(&bathy.depth_m)
        .map(|(&m, &d)| if d > 0.0 { m } else { f64::NAN })
        .collect();
    Ok(TsunamiResult {
        max_abs_eta,
        arrival_time_s: model.arrival_time_s,
        final_eta: model.eta,
        steps,
        dt_s: dt,
    })
}

fn validate_options(opts: &TsunamiOptions) -> Result<()> {
    if !(opts.duration_s.is_finite() && opts.duration_s > 0.0) {
        return Err(Error::invalid(
            "duration_s",
            format!("must be finite and > 0, got {}", opts.duration_s),
        ));
    }
    if let Some(dt) = opts.dt_s {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::invalid(
                "dt",
                format!("must be finite and > 0, got {dt}"),
            ));
        }
    }
    if !(opts.g.is_finite() && opts.g > 0.0) {
        return Err(Error::invalid(
            "g",
            format!("must be finite and > 0, got {}", opts.g),
        ));
    }
    if !(opts.manning_n.is_finite() && opts.manning_n >= 0.0) {
        return Err(Error::invalid(
            "manning_n",
            format!("must be finite and >= 0, got {}", opts.manning_n),
        ));
    }
    if !(opts.arrival_threshold_m.is_finite() && opts.arrival_threshold_m >= 0.0) {
        return Err(Error::invalid(
            "arrival_threshold_m",
            format!("must be finite and >= 0, got {}", opts.arrival_threshold_m),
        ));
    }
    Ok(())
}
