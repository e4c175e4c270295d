//! Tsunami propagation with the shallow-water equations on a staggered leap-frog Arakawa C grid,
//! in the style of TUNAMI-N1 and COMCOT's linear layer: sea-surface elevation at cell centres,
//! volume fluxes M and N (depth-integrated velocity, m^2/s) on the faces, half a time step
//! apart. Coordinates are Cartesian metres; cells with depth <= 0 are land, kept dry, and act as
//! reflective walls. The equations are linear unless advection and Manning bottom friction are
//! asked for (TUNAMI-N2 style). The file also builds a synthetic South-China-Sea-like basin with
//! a Manila-trench thrust source for demonstrations, and turns real elevation grids into
//! bathymetry.

use rayon::prelude::*;

use crate::error::{Error, Result};

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

/// Still-water depth on a regular grid.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Bathymetry {
    pub nx: usize,
    pub ny: usize,
    pub dx_m: f64,
    pub dy_m: f64,
    /// Depth in metres, positive below sea level, row-major `j * nx + i` with j running north.
    /// Cells with depth <= 0 are land.
    pub depth_m: Vec<f64>,
}

impl Bathymetry {
    /// Checks the sizes, the spacing and that every depth is finite.
    pub(crate) fn validate(&self) -> Result<()> {
        if self.nx == 0 || self.ny == 0 {
            return Err(Error::invalid(
                "bathymetry",
                format!(
                    "grid must have at least 1 x 1 cells, got {} x {}",
                    self.nx, self.ny
                ),
            ));
        }
        for (field, value) in [("dx_m", self.dx_m), ("dy_m", self.dy_m)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::invalid(
                    field,
                    format!("grid spacing must be finite and > 0, got {value}"),
                ));
            }
        }
        let cells = self.nx.checked_mul(self.ny).ok_or_else(|| {
            Error::invalid(
                "bathymetry",
                format!("{} x {} cells overflow", self.nx, self.ny),
            )
        })?;
        if self.depth_m.len() != cells {
            return Err(Error::invalid(
                "depth_m",
                format!(
                    "expected nx * ny = {cells} values, got {}",
                    self.depth_m.len()
                ),
            ));
        }
        if let Some(index) = self.depth_m.iter().position(|d| !d.is_finite()) {
            return Err(Error::invalid(
                "depth_m",
                format!(
                    "depth must be finite, got {} at cell (i={}, j={})",
                    self.depth_m[index],
                    index % self.nx,
                    index / self.nx
                ),
            ));
        }
        Ok(())
    }

    /// Largest still-water depth, 0 when every cell is land.
    pub(crate) fn max_depth_m(&self) -> f64 {
        self.depth_m.iter().fold(0.0_f64, |acc, &d| acc.max(d))
    }

    /// Largest stable time step of the 2-D leap-frog scheme, min(dx, dy) / sqrt(2 g h_max).
    #[cfg(test)]
    pub(crate) fn cfl_limit_s(&self, g: f64) -> f64 {
        self.dx_m.min(self.dy_m) / (2.0 * g * self.max_depth_m()).sqrt()
    }
}

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
    progress: &mut dyn FnMut(f64),
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
            progress((step + 1) as f64 / steps as f64);
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

/// The state of one run. Faces of x-flux M: `(nx + 1) * ny`, index `j * (nx + 1) + i` for the
/// face between cells i-1 and i. Faces of y-flux N: `nx * (ny + 1)`, index `j * nx + i` for the
/// face between rows j-1 and j.
struct Model {
    nx: usize,
    ny: usize,
    dt: f64,
    dx: f64,
    dy: f64,
    g: f64,
    eta: Vec<f64>,
    flux_x: Vec<f64>,
    flux_y: Vec<f64>,
    /// Still-water depth on each face; 0 on walls (next to land, or a reflective edge). On an
    /// open edge it is the depth of the one cell inside.
    face_depth_x: Vec<f64>,
    face_depth_y: Vec<f64>,
    /// g h dt / dx on interior faces; on open edge faces the radiation speed sqrt(g h) instead.
    coef_x: Vec<f64>,
    coef_y: Vec<f64>,
    /// Spare buffers for the nonlinear update, which reads old fluxes around each face.
    next_x: Vec<f64>,
    next_y: Vec<f64>,
    faces: FaceFields,
    max_abs_eta: Vec<f64>,
    arrival_time_s: Vec<f64>,
}

/// Per-step fields of the nonlinear update: total depth h + eta on every face, and the other
/// direction's flux averaged onto it (0 on edge faces, where it is never read).
#[derive(Default)]
struct FaceFields {
    total_x: Vec<f64>,
    n_at_x: Vec<f64>,
    total_y: Vec<f64>,
    m_at_y: Vec<f64>,
}

impl Model {
    fn new(bathy: &Bathymetry, eta0: &[f64], opts: &TsunamiOptions, dt: f64) -> Self {
        let (nx, ny) = (bathy.nx, bathy.ny);
        let depth = &bathy.depth_m;
        let wet = |j: usize, i: usize| depth[j * nx + i] > 0.0;
        let open = opts.boundary == Boundary::Open;
        let g = opts.g;

        let mut face_depth_x = vec![0.0; (nx + 1) * ny];
        for j in 0..ny {
            for i in 0..=nx {
                face_depth_x[j * (nx + 1) + i] = if i == 0 || i == nx {
                    let inside = if i == 0 { 0 } else { nx - 1 };
                    if open && wet(j, inside) {
                        depth[j * nx + inside]
                    } else {
                        0.0
                    }
                } else if wet(j, i - 1) && wet(j, i) {
                    0.5 * (depth[j * nx + i - 1] + depth[j * nx + i])
                } else {
                    0.0
                };
            }
        }
        let mut face_depth_y = vec![0.0; nx * (ny + 1)];
        for j in 0..=ny {
            for i in 0..nx {
                face_depth_y[j * nx + i] = if j == 0 || j == ny {
                    let inside = if j == 0 { 0 } else { ny - 1 };
                    if open && wet(inside, i) {
                        depth[inside * nx + i]
                    } else {
                        0.0
                    }
                } else if wet(j - 1, i) && wet(j, i) {
                    0.5 * (depth[(j - 1) * nx + i] + depth[j * nx + i])
                } else {
                    0.0
                };
            }
        }
        let coef_x = face_depth_x
            .iter()
            .enumerate()
            .map(|(f, &h)| {
                let i = f % (nx + 1);
                if i == 0 || i == nx {
                    (g * h).sqrt()
                } else {
                    g * h * dt / bathy.dx_m
                }
            })
            .collect();
        let coef_y = face_depth_y
            .iter()
            .enumerate()
            .map(|(f, &h)| {
                let j = f / nx;
                if j == 0 || j == ny {
                    (g * h).sqrt()
                } else {
                    g * h * dt / bathy.dy_m
                }
            })
            .collect();

        let eta: Vec<f64> = eta0
            .iter()
            .zip(depth)
            .map(|(&e, &d)| if d > 0.0 { e } else { 0.0 })
            .collect();
        let max_abs_eta = eta.iter().map(|e| e.abs()).collect();
        let arrival_time_s = eta
            .iter()
            .map(|e| {
                if e.abs() > opts.arrival_threshold_m {
                    0.0
                } else {
                    f64::NAN
                }
            })
            .collect();
        Model {
            nx,
            ny,
            dt,
            dx: bathy.dx_m,
            dy: bathy.dy_m,
            g,
            eta,
            flux_x: vec![0.0; (nx + 1) * ny],
            flux_y: vec![0.0; nx * (ny + 1)],
            face_depth_x,
            face_depth_y,
            coef_x,
            coef_y,
            next_x: Vec::new(),
            next_y: Vec::new(),
            faces: FaceFields::default(),
            max_abs_eta,
            arrival_time_s,
        }
    }

    /// M -= g h dt dEta/dx on every face, one grid row per task.
    fn linear_momentum(&mut self, dt_fraction: f64) {
        let (nx, ny) = (self.nx, self.ny);
        let eta = &self.eta;
        let coef_x = &self.coef_x;
        let coef_y = &self.coef_y;
        self.flux_x
            .par_chunks_mut(nx + 1)
            .zip(self.flux_y[..nx * ny].par_chunks_mut(nx))
            .enumerate()
            .for_each(|(j, (m_row, n_row))| {
                let e = &eta[j * nx..(j + 1) * nx];
                let cx = &coef_x[j * (nx + 1)..(j + 1) * (nx + 1)];
                for (((m, c), e_right), e_left) in m_row[1..nx]
                    .iter_mut()
                    .zip(&cx[1..nx])
                    .zip(&e[1..])
                    .zip(&e[..nx - 1])
                {
                    *m -= dt_fraction * c * (e_right - e_left);
                }
                m_row[0] = -cx[0] * e[0];
                m_row[nx] = cx[nx] * e[nx - 1];

                let cy = &coef_y[j * nx..(j + 1) * nx];
                if j == 0 {
                    for ((n, c), e_here) in n_row.iter_mut().zip(cy).zip(e) {
                        *n = -c * e_here;
                    }
                } else {
                    let e_south = &eta[(j - 1) * nx..j * nx];
                    for (((n, c), e_here), e_below) in n_row.iter_mut().zip(cy).zip(e).zip(e_south)
                    {
                        *n -= dt_fraction * c * (e_here - e_below);
                    }
                }
            });
        let e_top = &self.eta[(ny - 1) * nx..];
        let cy_top = &self.coef_y[ny * nx..];
        for ((n, c), e) in self.flux_y[ny * nx..].iter_mut().zip(cy_top).zip(e_top) {
            *n = c * e;
        }
    }

    /// TUNAMI-N2-style momentum: first-order upwind advection of the fluxes and semi-implicit
    /// Manning friction, with the total depth h + eta in the pressure term.
    fn nonlinear_momentum(&mut self, dt_fraction: f64, manning_n: f64) {
        let (nx, ny) = (self.nx, self.ny);
        let dt = self.dt * dt_fraction;
        let mut next_x = std::mem::take(&mut self.next_x);
        let mut next_y = std::mem::take(&mut self.next_y);
        next_x.resize(self.flux_x.len(), 0.0);
        next_y.resize(self.flux_y.len(), 0.0);
        let mut faces = std::mem::take(&mut self.faces);
        faces.total_x.resize(self.flux_x.len(), 0.0);
        faces.n_at_x.resize(self.flux_x.len(), 0.0);
        faces.total_y.resize(self.flux_y.len(), 0.0);
        faces.m_at_y.resize(self.flux_y.len(), 0.0);
        let this = &*self;
        // Depths and cross fluxes at faces are each read by up to five neighbouring updates,
        // so they are computed once per step.
        faces
            .total_x
            .par_chunks_mut(nx + 1)
            .zip(faces.n_at_x.par_chunks_mut(nx + 1))
            .enumerate()
            .for_each(|(j, (total, cross))| {
                for i in 0..=nx {
                    total[i] = this.total_depth_x(j, i);
                    cross[i] = if i == 0 || i == nx {
                        0.0
                    } else {
                        this.flux_y_at_x_face(j, i)
                    };
                }
            });
        faces
            .total_y
            .par_chunks_mut(nx)
            .zip(faces.m_at_y.par_chunks_mut(nx))
            .enumerate()
            .for_each(|(j, (total, cross))| {
                for i in 0..nx {
                    total[i] = this.total_depth_y(j, i);
                    cross[i] = if j == 0 || j == ny {
                        0.0
                    } else {
                        this.flux_x_at_y_face(j, i)
                    };
                }
            });
        let faces_ref = &faces;
        next_x
            .par_chunks_mut(nx + 1)
            .enumerate()
            .for_each(|(j, row)| {
                for (i, out) in row.iter_mut().enumerate() {
                    *out = this.nonlinear_flux_x(faces_ref, j, i, dt, manning_n);
                }
            });
        next_y.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            for (i, out) in row.iter_mut().enumerate() {
                *out = this.nonlinear_flux_y(faces_ref, j, i, dt, manning_n);
            }
        });
        self.faces = faces;
        self.next_x = std::mem::replace(&mut self.flux_x, next_x);
        self.next_y = std::mem::replace(&mut self.flux_y, next_y);
    }

    fn total_depth_x(&self, j: usize, i: usize) -> f64 {
        let h = self.face_depth_x[j * (self.nx + 1) + i];
        let row = &self.eta[j * self.nx..(j + 1) * self.nx];
        let eta_mean = if i == 0 {
            row[0]
        } else if i == self.nx {
            row[self.nx - 1]
        } else {
            0.5 * (row[i - 1] + row[i])
        };
        (h + eta_mean).max(MIN_TOTAL_DEPTH_M)
    }

    fn total_depth_y(&self, j: usize, i: usize) -> f64 {
        let h = self.face_depth_y[j * self.nx + i];
        let eta_mean = if j == 0 {
            self.eta[i]
        } else if j == self.ny {
            self.eta[(self.ny - 1) * self.nx + i]
        } else {
            0.5 * (self.eta[(j - 1) * self.nx + i] + self.eta[j * self.nx + i])
        };
        (h + eta_mean).max(MIN_TOTAL_DEPTH_M)
    }

    /// N averaged onto an interior x-face from its four neighbours.
    fn flux_y_at_x_face(&self, j: usize, i: usize) -> f64 {
        let nx = self.nx;
        let n = &self.flux_y;
        0.25 * (n[j * nx + i - 1] + n[j * nx + i] + n[(j + 1) * nx + i - 1] + n[(j + 1) * nx + i])
    }

    /// M averaged onto an interior y-face from its four neighbours.
    fn flux_x_at_y_face(&self, j: usize, i: usize) -> f64 {
        let w = self.nx + 1;
        let m = &self.flux_x;
        0.25 * (m[(j - 1) * w + i] + m[(j - 1) * w + i + 1] + m[j * w + i] + m[j * w + i + 1])
    }

    fn nonlinear_flux_x(
        &self,
        faces: &FaceFields,
        j: usize,
        i: usize,
        dt: f64,
        manning_n: f64,
    ) -> f64 {
        let (nx, ny) = (self.nx, self.ny);
        let w = nx + 1;
        let e = &self.eta[j * nx..(j + 1) * nx];
        if i == 0 {
            return -self.coef_x[j * w] * e[0];
        }
        if i == nx {
            return self.coef_x[j * w + nx] * e[nx - 1];
        }
        if self.face_depth_x[j * w + i] <= 0.0 {
            return 0.0;
        }
        let m = self.flux_x[j * w + i];
        let depth = faces.total_x[j * w + i];
        let n_here = faces.n_at_x[j * w + i];

        let m_sq_over_d = |ii: usize| {
            if self.face_depth_x[j * w + ii] <= 0.0 {
                0.0
            } else {
                self.flux_x[j * w + ii].powi(2) / faces.total_x[j * w + ii]
            }
        };
        let advect_x = upwind(m >= 0.0, m_sq_over_d, i) / self.dx;
        let mn_over_d = |jj: usize| {
            if self.face_depth_x[jj * w + i] <= 0.0 {
                0.0
            } else {
                self.flux_x[jj * w + i] * faces.n_at_x[jj * w + i] / faces.total_x[jj * w + i]
            }
        };
        let advect_y = upwind_within(n_here >= 0.0, mn_over_d, j, ny) / self.dy;
        let pressure = self.g * depth * (e[i] - e[i - 1]) / self.dx;
        let friction = manning_friction(dt * self.g * manning_n * manning_n, m, n_here, depth);
        ((1.0 - friction) * m - dt * (advect_x + advect_y + pressure)) / (1.0 + friction)
    }

    fn nonlinear_flux_y(
        &self,
        faces: &FaceFields,
        j: usize,
        i: usize,
        dt: f64,
        manning_n: f64,
    ) -> f64 {
        let (nx, ny) = (self.nx, self.ny);
        let f = j * nx + i;
        if j == 0 {
            return -self.coef_y[f] * self.eta[i];
        }
        if j == ny {
            return self.coef_y[f] * self.eta[(ny - 1) * nx + i];
        }
        if self.face_depth_y[f] <= 0.0 {
            return 0.0;
        }
        let n = self.flux_y[f];
        let depth = faces.total_y[j * nx + i];
        let m_here = faces.m_at_y[j * nx + i];

        let n_sq_over_d = |jj: usize| {
            if self.face_depth_y[jj * nx + i] <= 0.0 {
                0.0
            } else {
                self.flux_y[jj * nx + i].powi(2) / faces.total_y[jj * nx + i]
            }
        };
        let advect_y = upwind(n >= 0.0, n_sq_over_d, j) / self.dy;
        let nm_over_d = |ii: usize| {
            if self.face_depth_y[j * nx + ii] <= 0.0 {
                0.0
            } else {
                self.flux_y[j * nx + ii] * faces.m_at_y[j * nx + ii] / faces.total_y[j * nx + ii]
            }
        };
        let advect_x = upwind_within(m_here >= 0.0, nm_over_d, i, nx) / self.dx;
        let pressure =
            self.g * depth * (self.eta[j * nx + i] - self.eta[(j - 1) * nx + i]) / self.dy;
        let friction = manning_friction(dt * self.g * manning_n * manning_n, n, m_here, depth);
        ((1.0 - friction) * n - dt * (advect_x + advect_y + pressure)) / (1.0 + friction)
    }

    /// eta -= dt div(M, N), then the running maximum and the arrival times at time `t`.
    fn continuity_and_record(&mut self, t: f64, threshold: f64) {
        let nx = self.nx;
        let (rdx, rdy) = (self.dt / self.dx, self.dt / self.dy);
        let flux_x = &self.flux_x;
        let flux_y = &self.flux_y;
        self.eta
            .par_chunks_mut(nx)
            .zip(self.max_abs_eta.par_chunks_mut(nx))
            .zip(self.arrival_time_s.par_chunks_mut(nx))
            .enumerate()
            .for_each(|(j, ((e_row, max_row), arrival_row))| {
                let m = &flux_x[j * (nx + 1)..(j + 1) * (nx + 1)];
                let n_south = &flux_y[j * nx..(j + 1) * nx];
                let n_north = &flux_y[(j + 1) * nx..(j + 2) * nx];
                for (((((e, m_west), m_east), n_s), n_n), max_abs) in e_row
                    .iter_mut()
                    .zip(&m[..nx])
                    .zip(&m[1..])
                    .zip(n_south)
                    .zip(n_north)
                    .zip(max_row.iter_mut())
                {
                    *e -= rdx * (m_east - m_west) + rdy * (n_n - n_s);
                    *max_abs = max_abs.max(e.abs());
                }
                for (e, arrival) in e_row.iter().zip(arrival_row.iter_mut()) {
                    if arrival.is_nan() && e.abs() > threshold {
                        *arrival = t;
                    }
                }
            });
    }
}

/// First-order upwind difference of `q` at face `k`: backward where the flow runs forward.
fn upwind(forward: bool, q: impl Fn(usize) -> f64, k: usize) -> f64 {
    if forward {
        q(k) - q(k - 1)
    } else {
        q(k + 1) - q(k)
    }
}

/// `upwind` across the rows (or columns) of faces, zero where the upwind neighbour would lie
/// outside the `n` of them.
fn upwind_within(forward: bool, q: impl Fn(usize) -> f64, k: usize, n: usize) -> f64 {
    match (forward, k > 0, k + 1 < n) {
        (true, true, _) | (false, _, true) => upwind(forward, q, k),
        _ => 0.0,
    }
}

/// Half the Manning friction factor of the semi-implicit update, dt g n^2 |q| / (2 D^(7/3)),
/// given `scale` = dt g n^2; D^(7/3) is built from a cube root, several times cheaper than powf.
fn manning_friction(scale: f64, along: f64, across: f64, depth: f64) -> f64 {
    if scale == 0.0 {
        return 0.0;
    }
    scale * (along * along + across * across).sqrt() / (2.0 * depth * depth * depth.cbrt())
}

/// Bathymetry from an elevation grid (positive up, as in `topobathy.npz`): depth = -elevation.
/// Rows must run south to north (`j * nx + i`); flip a north-up raster first.
pub(crate) fn bathymetry_from_elevation(
    elevation_m: &[f64],
    nx: usize,
    ny: usize,
    dx_m: f64,
    dy_m: f64,
) -> Result<Bathymetry> {
    if let Some(index) = elevation_m.iter().position(|z| !z.is_finite()) {
        return Err(Error::invalid(
            "elevation_m",
            format!(
                "elevation must be finite, got {} at index {index}",
                elevation_m[index]
            ),
        ));
    }
    let bathy = Bathymetry {
        nx,
        ny,
        dx_m,
        dy_m,
        depth_m: elevation_m.iter().map(|z| -z).collect(),
    };
    bathy.validate()?;
    Ok(bathy)
}

/// Converts a longitude/latitude spacing in degrees into metres (dx east, dy north) on a
/// spherical Earth of radius `EARTH_RADIUS_M`, at latitude `mean_latitude_deg`.
///
/// This is a local equirectangular projection: east-west distances are exact only at the mean
/// latitude and scale with cos(latitude) elsewhere, so over a grid spanning +-1 degree of
/// latitude around 49 N they are off by up to about 2 % at the northern and southern rows; the
/// ellipsoid's flattening adds up to about 0.5 %. Good for tsunami travel times on regional grids.
pub(crate) fn degree_spacing_to_metres(
    dlon_deg: f64,
    dlat_deg: f64,
    mean_latitude_deg: f64,
) -> Result<(f64, f64)> {
    for (field, value) in [("dlon_deg", dlon_deg), ("dlat_deg", dlat_deg)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(Error::invalid(
                field,
                format!("spacing must be finite and > 0, got {value}"),
            ));
        }
    }
    if !(mean_latitude_deg.is_finite() && mean_latitude_deg.abs() < 89.0) {
        return Err(Error::invalid(
            "mean_latitude_deg",
            format!("must lie within (-89, 89) degrees, got {mean_latitude_deg}"),
        ));
    }
    let metres_per_degree = EARTH_RADIUS_M * std::f64::consts::PI / 180.0;
    Ok((
        dlon_deg * metres_per_degree * mean_latitude_deg.to_radians().cos(),
        dlat_deg * metres_per_degree,
    ))
}

/// Grid spacing in metres from a grid's longitude and latitude vectors (degrees, either order),
/// using the mean step and `degree_spacing_to_metres` at the mean latitude. The solver needs a
/// uniform grid, so each step may differ from the mean by at most 5 %: stored grids are often
/// only nearly uniform (the latitude steps of `topobathy.npz` vary by about +-2 %).
pub(crate) fn grid_spacing_from_lonlat(
    longitude_deg: &[f64],
    latitude_deg: &[f64],
) -> Result<(f64, f64)> {
    let spacing = |field: &str, values: &[f64]| -> Result<f64> {
        if values.len() < 2 || values.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                field,
                format!("need at least 2 finite values, got {}", values.len()),
            ));
        }
        let step = (values[values.len() - 1] - values[0]) / (values.len() - 1) as f64;
        let uneven = values
            .windows(2)
            .any(|pair| ((pair[1] - pair[0]) - step).abs() > 0.05 * step.abs());
        if step == 0.0 || uneven {
            return Err(Error::invalid(
                field,
                "values must be monotonic with steps within 5 % of their mean",
            ));
        }
        Ok(step.abs())
    };
    let dlon = spacing("longitude", longitude_deg)?;
    let dlat = spacing("latitude", latitude_deg)?;
    let mean_latitude = 0.5 * (latitude_deg[0] + latitude_deg[latitude_deg.len() - 1]);
    degree_spacing_to_metres(dlon, dlat, mean_latitude)
}

/// A synthetic basin shaped like the South China Sea on an `n x n` grid covering
/// `extent_m x extent_m` (about `SOUTH_CHINA_SEA_EXTENT_M` is realistic): land along the north
/// (China), west (Indochina) and south (Borneo), the Luzon-Palawan arc on the east with the open
/// Luzon Strait north of it, shelves of 20-200 m (widest in the south-west, like the Sunda
/// shelf), a 4000 m abyssal plain with gentle relief, and a trench reaching 5300 m west of Luzon
/// along strike 350 degrees, like the Manila trench. Land cells carry negative depth (elevation).
/// All features scale with `extent_m`.
pub(crate) fn synthetic_south_china_sea(n: usize, extent_m: f64) -> Bathymetry {
    let n = n.max(2);
    let d = extent_m / n as f64;
    let mut depth_m = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            let v = (j as f64 + 0.5) / n as f64;
            depth_m.push(south_china_sea_depth(u, v));
        }
    }
    Bathymetry {
        nx: n,
        ny: n,
        dx_m: d,
        dy_m: d,
        depth_m,
    }
}

/// Depth at fractional position (u east, v north) in the unit square.
fn south_china_sea_depth(u: f64, v: f64) -> f64 {
    use std::f64::consts::TAU;
    let china = 0.86 + 0.03 * (TAU * 1.5 * u).sin() - v;
    let indochina = u - (0.10 + 0.04 * (TAU * 1.2 * v).sin());
    let borneo = v - (0.08 + 0.03 * (TAU * 2.0 * u).sin());
    let luzon_palawan = signed_distance_to_box(u, v, (0.90, 0.15), (1.5, 0.78));
    // Distance from the nearest coast, as a fraction of the extent; negative on land.
    let sea_distance = china.min(indochina).min(borneo).min(luzon_palawan);
    if sea_distance <= 0.0 {
        return -(10.0 + 3000.0 * (-sea_distance).min(0.5));
    }
    let sunda = (-((u - 0.15).powi(2) + (v - 0.10).powi(2)) / 0.03).exp();
    let shelf_width = 0.05 + 0.15 * sunda;
    let slope_width = 0.06;
    let mut depth = if sea_distance < shelf_width {
        20.0 + 180.0 * sea_distance / shelf_width
    } else {
        let s = ((sea_distance - shelf_width) / slope_width).min(1.0);
        let smooth = s * s * (3.0 - 2.0 * s);
        let relief = 150.0 * (TAU * 3.0 * u).sin() * (TAU * 2.5 * v).cos();
        200.0 + (3800.0 + relief - 200.0) * smooth
    };
    let (across, along) = manila_trench_coordinates(u, v);
    let trench = (-(across / 0.0125).powi(2)).exp() * (-(along / 0.2).powi(4)).exp();
    depth += (MANILA_TRENCH_AXIS_DEPTH_M - depth) * trench;
    depth
}

/// Signed distance from (u, v) to an axis-aligned box, negative inside.
fn signed_distance_to_box(u: f64, v: f64, lo: (f64, f64), hi: (f64, f64)) -> f64 {
    let cx = 0.5 * (lo.0 + hi.0);
    let cy = 0.5 * (lo.1 + hi.1);
    let qx = (u - cx).abs() - 0.5 * (hi.0 - lo.0);
    let qy = (v - cy).abs() - 0.5 * (hi.1 - lo.1);
    qx.max(0.0).hypot(qy.max(0.0)) + qx.max(qy).min(0.0)
}

const MANILA_TRENCH_AXIS_DEPTH_M: f64 = 5300.0;
/// Trench axis midpoint in the unit square and its strike, degrees clockwise from north.
const MANILA_TRENCH_AXIS_UV: (f64, f64) = (0.80, 0.55);
const MANILA_TRENCH_STRIKE_DEG: f64 = 350.0;

/// (distance across the trench towards the dip direction, distance along strike), unit square.
fn manila_trench_coordinates(u: f64, v: f64) -> (f64, f64) {
    let strike = MANILA_TRENCH_STRIKE_DEG.to_radians();
    let (du, dv) = (u - MANILA_TRENCH_AXIS_UV.0, v - MANILA_TRENCH_AXIS_UV.1);
    let along = du * strike.sin() + dv * strike.cos();
    let across = du * strike.cos() - dv * strike.sin();
    (across, along)
}

/// A rectangular thrust fault for Okada's solution, in the Aki-Richards convention (dip to the
/// right of strike, rake +90 = pure thrust). Positions are metres in the synthetic basin's frame
/// (origin at its south-west corner, x east, y north).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FaultSource {
    /// Degrees clockwise from north.
    pub strike_deg: f64,
    pub dip_deg: f64,
    pub rake_deg: f64,
    pub slip_m: f64,
    /// Along strike.
    pub length_m: f64,
    /// Down dip.
    pub width_m: f64,
    /// Depth of the fault plane's centre below the sea floor.
    pub depth_m: f64,
    /// Surface projection of the fault plane's centre.
    pub x_m: f64,
    pub y_m: f64,
}

impl FaultSource {
    /// Depth of the up-dip (top) edge.
    #[cfg(test)]
    pub(crate) fn top_edge_depth_m(&self) -> f64 {
        self.depth_m - 0.5 * self.width_m * self.dip_deg.to_radians().sin()
    }

    /// The same fault placed in a synthetic basin of side `extent_m` instead of
    /// `SOUTH_CHINA_SEA_EXTENT_M`: the position scales, the fault's size does not.
    pub(crate) fn scaled_to_extent(self, extent_m: f64) -> FaultSource {
        let scale = extent_m / SOUTH_CHINA_SEA_EXTENT_M;
        FaultSource {
            x_m: self.x_m * scale,
            y_m: self.y_m * scale,
            ..self
        }
    }
}

/// A Manila-trench megathrust for the synthetic basin of side `SOUTH_CHINA_SEA_EXTENT_M`:
/// strike 350, dip 20, rake 90 degrees, 8 m of slip on a 200 km x 80 km plane whose top edge
/// lies 5 km below the sea floor under the trench axis (so the centre is at 18.68 km depth),
/// dipping east under Luzon. Magnitude about Mw 8.4 for a rigidity of 40 GPa.
pub(crate) fn manila_trench_source() -> FaultSource {
    let (strike_deg, dip_deg) = (MANILA_TRENCH_STRIKE_DEG, 20.0_f64);
    let (width_m, top_depth_m) = (80_000.0, 5_000.0);
    let dip = dip_deg.to_radians();
    // From the trench axis to the plane's centre, half the width down dip, horizontally
    // along the dip direction (strike + 90 degrees).
    let dip_azimuth = (strike_deg + 90.0).to_radians();
    let offset = 0.5 * width_m * dip.cos();
    let (axis_u, axis_v) = MANILA_TRENCH_AXIS_UV;
    FaultSource {
        strike_deg,
        dip_deg,
        rake_deg: 90.0,
        slip_m: 8.0,
        length_m: 200_000.0,
        width_m,
        depth_m: top_depth_m + 0.5 * width_m * dip.sin(),
        x_m: axis_u * SOUTH_CHINA_SEA_EXTENT_M + offset * dip_azimuth.sin(),
        y_m: axis_v * SOUTH_CHINA_SEA_EXTENT_M + offset * dip_azimuth.cos(),
    }
}

#[cfg(test)]
mod tests {
    //! Reference values come from `/work/shared/reference/validation.md` ("Linear shallow-water
    //! (tsunami) analytic cases"), which quotes closed forms: c = sqrt(g h), the Hankel-transform
    //! solution for a 2-D Gaussian, Lamb's step transmission T = 2 c1 / (c1 + c2), Green's law
    //! and Merian's seiche periods.

    use super::*;

    const G: f64 = 9.81;

    fn flat(nx: usize, ny: usize, spacing_m: f64, depth_m: f64) -> Bathymetry {
        Bathymetry {
            nx,
            ny,
            dx_m: spacing_m,
            dy_m: spacing_m,
            depth_m: vec![depth_m; nx * ny],
        }
    }

    fn options(duration_s: f64, boundary: Boundary) -> TsunamiOptions {
        TsunamiOptions {
            duration_s,
            boundary,
            ..TsunamiOptions::default()
        }
    }

    fn run(bathy: &Bathymetry, eta0: &[f64], opts: &TsunamiOptions) -> TsunamiResult {
        simulate(bathy, eta0, opts, &mut |_| {}).expect("valid run")
    }

    /// Gaussian hump of amplitude `amplitude`, replicated over every row, centred at `centre_m`.
    fn hump_1d(bathy: &Bathymetry, centre_m: f64, sigma_m: f64, amplitude: f64) -> Vec<f64> {
        (0..bathy.nx * bathy.ny)
            .map(|k| {
                let x = ((k % bathy.nx) as f64 + 0.5) * bathy.dx_m;
                amplitude * (-(x - centre_m).powi(2) / (2.0 * sigma_m * sigma_m)).exp()
            })
            .collect()
    }

    /// Position of the largest value of `row` within cells `range`, refined by a parabola
    /// through the maximum and its two neighbours.
    fn peak_position_m(row: &[f64], range: std::ops::Range<usize>, dx: f64) -> f64 {
        let k = range
            .clone()
            .max_by(|&a, &b| row[a].total_cmp(&row[b]))
            .unwrap();
        let (left, mid, right) = (row[k - 1], row[k], row[k + 1]);
        let shift = 0.5 * (left - right) / (left - 2.0 * mid + right);
        (k as f64 + 0.5 + shift) * dx
    }

    #[test]
    fn hump_splits_into_halves_travelling_at_the_long_wave_speed() {
        // validation.md case 1: c = sqrt(g h) = 198.091 m/s for h = 4000 m.
        let c = (G * 4000.0_f64).sqrt();
        assert!((c - 198.091).abs() < 1e-3);
        let dx = 2000.0;
        let bathy = flat(500, 3, dx, 4000.0);
        let centre = 500_000.0;
        let eta0 = hump_1d(&bathy, centre, 20_000.0, 1.0);
        let positions = [600.0, 1500.0].map(|t| {
            let result = run(&bathy, &eta0, &options(t, Boundary::Reflective));
            let row = &result.final_eta[bathy.nx..2 * bathy.nx];
            let right = peak_position_m(row, 251..499, dx) - centre;
            let left = centre - peak_position_m(row, 1..249, dx);
            // Each half carries half the initial amplitude.
            assert!((row.iter().cloned().fold(0.0, f64::max) - 0.5).abs() < 0.01);
            (right, left)
        });
        let speed_right = (positions[1].0 - positions[0].0) / 900.0;
        let speed_left = (positions[1].1 - positions[0].1) / 900.0;
        for speed in [speed_right, speed_left] {
            assert!((speed / c - 1.0).abs() < 0.01, "speed {speed} m/s vs {c}");
        }
    }

    #[test]
    fn arrival_times_advance_at_the_long_wave_speed() {
        let c = (G * 4000.0_f64).sqrt();
        let dx = 1000.0;
        let bathy = flat(800, 1, dx, 4000.0);
        let eta0 = hump_1d(&bathy, 100_000.0, 20_000.0, 1.0);
        let result = run(&bathy, &eta0, &options(1800.0, Boundary::Reflective));
        let near = result.arrival_time_s[300];
        let far = result.arrival_time_s[500];
        let expected = 200_000.0 / c;
        assert!(((far - near) / expected - 1.0).abs() < 0.01, "{near} {far}");
        // Cells the wave has not reached report NaN; the hump itself arrives at t = 0.
        assert!(result.arrival_time_s[799].is_nan());
        assert_eq!(result.arrival_time_s[100], 0.0);
    }

    /// eta at the centre and 200 km east of it for the 2-D Gaussian on a grid of spacing `dx`.
    fn gaussian_2d(dx: f64, time_s: f64, offset_cells: usize) -> f64 {
        let half_width = 280_000.0;
        let half = (half_width / dx).round() as usize;
        let n = 2 * half + 1;
        let bathy = flat(n, n, dx, 4000.0);
        let sigma = 20_000.0;
        let eta0: Vec<f64> = (0..n * n)
            .map(|k| {
                let x = (k % n) as f64 - half as f64;
                let y = (k / n) as f64 - half as f64;
                let r2 = (x * x + y * y) * dx * dx;
                (-r2 / (2.0 * sigma * sigma)).exp()
            })
            .collect();
        let result = run(&bathy, &eta0, &options(time_s, Boundary::Open));
        let centre = half * n + half;
        let e = &result.final_eta;
        let k = offset_cells;
        0.25 * (e[centre + k] + e[centre - k] + e[centre + k * n] + e[centre - k * n])
    }

    #[test]
    fn radial_gaussian_matches_the_hankel_solution_with_second_order_convergence() {
        // validation.md case 2: A = 1 m, sigma = 20 km, h = 4000 m.
        let at_centre = -0.183693;
        let at_200_km = 0.089639;
        let t_front = 200_000.0 / (G * 4000.0_f64).sqrt();
        assert!((t_front - 1009.64).abs() < 0.01);
        let spacings = [4000.0, 2000.0, 1000.0];
        let errors: Vec<f64> = spacings
            .iter()
            .map(|&dx| {
                let centre = gaussian_2d(dx, 300.0, 0);
                let ring = gaussian_2d(dx, t_front, (200_000.0 / dx) as usize);
                eprintln!("dx {dx}: eta(0, 300 s) = {centre:.6}, eta(200 km, front) = {ring:.6}");
                if dx <= 2000.0 {
                    assert!((centre / at_centre - 1.0).abs() < 0.02, "{centre}");
                    assert!((ring / at_200_km - 1.0).abs() < 0.02, "{ring}");
                }
                (centre - at_centre).abs() + (ring - at_200_km).abs()
            })
            .collect();
        for pair in errors.windows(2) {
            let order = (pair[0] / pair[1]).log2();
            eprintln!("errors {pair:?}: observed order {order:.3}");
            assert!(order > 1.6, "observed order {order}");
        }
    }

    fn uneven_basin() -> (Bathymetry, Vec<f64>) {
        let (nx, ny) = (60, 40);
        let mut bathy = flat(nx, ny, 5000.0, 0.0);
        for j in 0..ny {
            for i in 0..nx {
                let (u, v) = (i as f64 / nx as f64, j as f64 / ny as f64);
                let island = (u - 0.6).powi(2) + (v - 0.5).powi(2) < 0.01;
                bathy.depth_m[j * nx + i] = if island {
                    -30.0
                } else {
                    50.0 + 3000.0 * u * (1.0 + (6.0 * v).sin()).max(0.1)
                };
            }
        }
        let eta0 = (0..nx * ny)
            .map(|k| {
                let (i, j) = ((k % nx) as f64, (k / nx) as f64);
                2.0 * (-((i - 20.0).powi(2) + (j - 15.0).powi(2)) / 18.0).exp()
            })
            .collect();
        (bathy, eta0)
    }

    #[test]
    fn reflective_basin_conserves_volume_to_rounding() {
        // validation.md case 1: the flux form conserves mass exactly.
        let (bathy, eta0) = uneven_basin();
        let volume = |eta: &[f64]| {
            eta.iter()
                .zip(&bathy.depth_m)
                .filter(|(_, &d)| d > 0.0)
                .map(|(e, _)| e * bathy.dx_m * bathy.dy_m)
                .sum::<f64>()
        };
        let initial = volume(&eta0);
        for nonlinear in [false, true] {
            let opts = TsunamiOptions {
                nonlinear,
                ..options(3000.0, Boundary::Reflective)
            };
            let result = run(&bathy, &eta0, &opts);
            assert!(result.steps > 200);
            let drift = (volume(&result.final_eta) - initial).abs() / initial;
            assert!(
                drift < 1e-12,
                "nonlinear {nonlinear}: relative drift {drift:e}"
            );
            // The wave has actually moved.
            assert!(result.final_eta[15 * 60 + 20] < 1.0);
        }
    }

    #[test]
    fn open_edges_let_the_wave_leave() {
        let n = 101;
        let bathy = flat(n, n, 2000.0, 4000.0);
        let eta0: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64 - 50.0, (k / n) as f64 - 50.0);
                (-(x * x + y * y) * 4.0e6 / (2.0 * 4.0e8)).exp()
            })
            .collect();
        let left_over = |boundary| {
            let result = run(&bathy, &eta0, &options(2000.0, boundary));
            result.final_eta.iter().fold(0.0_f64, |m, e| m.max(e.abs()))
        };
        let open = left_over(Boundary::Open);
        let closed = left_over(Boundary::Reflective);
        eprintln!("largest |eta| left after 2000 s: open {open}, reflective {closed}");
        assert!(open < 0.03, "{open}");
        assert!(closed > 0.1, "{closed}");
    }

    #[test]
    fn step_shelf_transmits_lambs_amplitude() {
        // validation.md case 3: T = 2 c1 / (c1 + c2) = 1.63451 for 4000 m -> 200 m.
        let (c1, c2) = ((G * 4000.0_f64).sqrt(), (G * 200.0_f64).sqrt());
        let transmission = 2.0 * c1 / (c1 + c2);
        assert!((transmission - 1.63451).abs() < 1e-5);
        let dx = 500.0;
        let nx = 1100;
        let step = 800; // cells, 400 km
        let mut bathy = flat(nx, 1, dx, 4000.0);
        bathy.depth_m[step..].fill(200.0);
        // The right-going half of the split hump (amplitude 0.5) is the incident wave.
        let eta0 = hump_1d(&bathy, 200_000.0, 20_000.0, 1.0);
        let result = run(&bathy, &eta0, &options(2000.0, Boundary::Reflective));
        let on_shelf = result.final_eta[step + 20..]
            .iter()
            .fold(0.0_f64, |m, &e| m.max(e));
        let measured = on_shelf / 0.5;
        eprintln!("step shelf transmission {measured:.5} vs {transmission:.5}");
        assert!((measured / transmission - 1.0).abs() < 0.02);
    }

    #[test]
    fn gentle_slope_follows_greens_law() {
        // validation.md case 4: A2 / A1 = (h1 / h2)^(1/4) = 2.11474 for 4000 m -> 200 m.
        let greens = (4000.0_f64 / 200.0).powf(0.25);
        assert!((greens - 2.11474).abs() < 1e-5);
        let dx = 250.0;
        let (deep_end, slope_end, nx) = (1200, 2800, 3200); // 300 km, 700 km, 800 km
        let mut bathy = flat(nx, 1, dx, 4000.0);
        for i in deep_end..nx {
            let s = ((i - deep_end) as f64 / (slope_end - deep_end) as f64).min(1.0);
            bathy.depth_m[i] = 4000.0 + (200.0 - 4000.0) * s;
        }
        let eta0 = hump_1d(&bathy, 150_000.0, 10_000.0, 1.0);
        let c_deep = (G * 4000.0_f64).sqrt();
        // Travel time to the foot of the slope: flat part, then integral of dx / sqrt(g h) on
        // the linear slope, 2 L / (sqrt(g) (sqrt(h1) + sqrt(h2))).
        let slope_length = (slope_end - deep_end) as f64 * dx;
        let t_slope = 2.0 * slope_length / (G.sqrt() * (4000.0_f64.sqrt() + 200.0_f64.sqrt()));
        let duration = 150_000.0 / c_deep + t_slope + 200.0;
        let result = run(&bathy, &eta0, &options(duration, Boundary::Reflective));
        let at_foot = result.max_abs_eta[slope_end - 4..slope_end + 4]
            .iter()
            .fold(0.0_f64, |m, &e| m.max(e));
        let measured = at_foot / 0.5;
        eprintln!("Green's law ratio {measured:.5} vs {greens:.5}");
        assert!((measured / greens - 1.0).abs() < 0.05);
    }

    #[test]
    fn closed_basin_seiches_with_merians_period() {
        // validation.md case 5: T_n = 2 L / (n sqrt(g h)).
        let (nx, dx, h) = (100, 1000.0, 50.0);
        let length = nx as f64 * dx;
        let bathy = flat(nx, 1, dx, h);
        for mode in [1.0, 2.0] {
            let period = 2.0 * length / (mode * (G * h).sqrt());
            let eta0: Vec<f64> = (0..nx)
                .map(|i| (mode * std::f64::consts::PI * (i as f64 + 0.5) / nx as f64).cos())
                .collect();
            let half = run(&bathy, &eta0, &options(0.5 * period, Boundary::Reflective));
            let full = run(&bathy, &eta0, &options(period, Boundary::Reflective));
            for ((e0, e_half), e_full) in eta0.iter().zip(&half.final_eta).zip(&full.final_eta) {
                assert!(
                    (e_half + e0).abs() < 0.005,
                    "mode {mode}: {e_half} vs {}",
                    -e0
                );
                assert!((e_full - e0).abs() < 0.005, "mode {mode}: {e_full} vs {e0}");
            }
        }
    }

    #[test]
    fn nonlinear_terms_vanish_for_small_waves_and_friction_damps() {
        let bathy = flat(400, 1, 1000.0, 50.0);
        let eta0 = hump_1d(&bathy, 100_000.0, 10_000.0, 0.01);
        let linear = run(&bathy, &eta0, &options(2000.0, Boundary::Reflective));
        let smooth = TsunamiOptions {
            nonlinear: true,
            manning_n: 0.0,
            ..options(2000.0, Boundary::Reflective)
        };
        let nonlinear = run(&bathy, &eta0, &smooth);
        let largest_difference = linear
            .final_eta
            .iter()
            .zip(&nonlinear.final_eta)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(largest_difference < 1e-3 * 0.01, "{largest_difference}");

        // Manning friction decelerates by g n^2 u^2 / h^(4/3): here (u ~ 0.25 m/s, h = 10 m)
        // that removes some 20 % of the speed within 2000 s.
        let shallow = flat(200, 1, 500.0, 10.0);
        let big = hump_1d(&shallow, 50_000.0, 5_000.0, 1.0);
        let rough = TsunamiOptions {
            manning_n: 0.03,
            ..smooth.clone()
        };
        let peak = |opts: &TsunamiOptions| {
            run(&shallow, &big, opts)
                .final_eta
                .iter()
                .fold(0.0_f64, |m, &e| m.max(e))
        };
        let (frictionless, damped) = (peak(&smooth), peak(&rough));
        assert!(
            frictionless > 0.4 && damped < 0.9 * frictionless,
            "{frictionless} {damped}"
        );
    }

    #[test]
    fn bad_input_is_rejected_with_the_field_named() {
        let bathy = flat(20, 10, 1000.0, 4000.0);
        let eta0 = vec![0.0; 200];
        let limit = bathy.cfl_limit_s(G);
        assert!((limit - 1000.0 / (2.0 * G * 4000.0_f64).sqrt()).abs() < 1e-12);
        let field = |result: Result<TsunamiResult>| match result {
            Err(Error::Invalid { field, msg }) => (field, msg),
            other => panic!("expected an invalid-parameter error, got {other:?}"),
        };
        let too_long = TsunamiOptions {
            dt_s: Some(1.01 * limit),
            ..options(100.0, Boundary::Open)
        };
        let (name, msg) = field(simulate(&bathy, &eta0, &too_long, &mut |_| {}));
        assert_eq!(name, "dt");
        assert!(msg.contains(&format!("{limit:.6}")), "{msg}");
        let at_limit = TsunamiOptions {
            dt_s: Some(limit),
            ..too_long.clone()
        };
        assert!(simulate(&bathy, &eta0, &at_limit, &mut |_| {}).is_ok());

        let short = vec![0.0; 199];
        let opts = options(100.0, Boundary::Open);
        assert_eq!(
            field(simulate(&bathy, &short, &opts, &mut |_| {})).0,
            "eta0"
        );
        let mut nan_eta = eta0.clone();
        nan_eta[3] = f64::INFINITY;
        assert_eq!(
            field(simulate(&bathy, &nan_eta, &opts, &mut |_| {})).0,
            "eta0"
        );
        let mut holed = bathy.clone();
        holed.depth_m[7] = f64::NAN;
        assert_eq!(
            field(simulate(&holed, &eta0, &opts, &mut |_| {})).0,
            "depth_m"
        );
        let mut short_depth = bathy.clone();
        short_depth.depth_m.pop();
        assert_eq!(
            field(simulate(&short_depth, &eta0, &opts, &mut |_| {})).0,
            "depth_m"
        );
        let dry = flat(20, 10, 1000.0, -5.0);
        assert_eq!(
            field(simulate(&dry, &eta0, &opts, &mut |_| {})).0,
            "depth_m"
        );
        for (name, bad) in [
            ("duration_s", options(0.0, Boundary::Open)),
            ("duration_s", options(f64::NAN, Boundary::Open)),
            (
                "g",
                TsunamiOptions {
                    g: -1.0,
                    ..opts.clone()
                },
            ),
            (
                "manning_n",
                TsunamiOptions {
                    manning_n: -0.1,
                    ..opts.clone()
                },
            ),
            (
                "dt",
                TsunamiOptions {
                    dt_s: Some(0.0),
                    ..opts.clone()
                },
            ),
        ] {
            assert_eq!(field(simulate(&bathy, &eta0, &bad, &mut |_| {})).0, name);
        }
    }

    #[test]
    fn progress_reaches_one_and_the_step_ends_on_the_duration() {
        let bathy = flat(10, 10, 1000.0, 100.0);
        let mut reports = Vec::new();
        let opts = TsunamiOptions {
            dt_s: Some(7.0),
            ..options(100.0, Boundary::Open)
        };
        let result = simulate(&bathy, &[0.0; 100], &opts, &mut |f| reports.push(f)).unwrap();
        assert_eq!(result.steps, 15);
        assert!((result.dt_s * 15.0 - 100.0).abs() < 1e-12);
        assert_eq!(reports.last(), Some(&1.0));
        assert!(reports.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn elevation_grids_become_depths_and_degrees_become_metres() {
        let bathy =
            bathymetry_from_elevation(&[120.0, -35.0, 0.0, -4000.0], 2, 2, 10.0, 20.0).unwrap();
        assert_eq!(bathy.depth_m, vec![-120.0, 35.0, -0.0, 4000.0]);
        assert!(bathymetry_from_elevation(&[1.0, f64::NAN], 2, 1, 1.0, 1.0).is_err());
        assert!(bathymetry_from_elevation(&[1.0, 2.0], 3, 1, 1.0, 1.0).is_err());

        // One degree of a great circle on a 6371 km sphere is 111.19493 km.
        let (dx, dy) = degree_spacing_to_metres(1.0, 1.0, 60.0).unwrap();
        assert!((dy - 111_194.93).abs() < 0.01, "{dy}");
        assert!((dx - 0.5 * 111_194.93).abs() < 0.01, "{dx}");
        assert!(degree_spacing_to_metres(1.0, 1.0, 90.0).is_err());

        let longitude: Vec<f64> = (0..5).map(|k| -126.0 + 0.5 * k as f64).collect();
        let latitude: Vec<f64> = (0..3).map(|k| 50.0 - 1.0 * k as f64).collect();
        let (dx, dy) = grid_spacing_from_lonlat(&longitude, &latitude).unwrap();
        assert!((dy - 111_194.93).abs() < 0.01);
        assert!((dx - 0.5 * 111_194.93 * 49.0_f64.to_radians().cos()).abs() < 0.01);
        assert!(grid_spacing_from_lonlat(&[1.0, 2.0, 4.0], &latitude).is_err());
    }

    #[test]
    fn synthetic_basin_has_shelves_plain_trench_and_a_source_over_the_trench() {
        let n = 200;
        let bathy = synthetic_south_china_sea(n, SOUTH_CHINA_SEA_EXTENT_M);
        bathy.validate().unwrap();
        let count = |pred: &dyn Fn(f64) -> bool| bathy.depth_m.iter().filter(|&&d| pred(d)).count();
        let cells = (n * n) as f64;
        let land = count(&|d| d <= 0.0) as f64 / cells;
        let shelf = count(&|d| d > 0.0 && d <= 200.0) as f64 / cells;
        let plain = count(&|d| (3700.0..=4300.0).contains(&d)) as f64 / cells;
        assert!((0.1..0.5).contains(&land), "land {land}");
        assert!(shelf > 0.05, "shelf {shelf}");
        assert!(plain > 0.2, "plain {plain}");
        assert!(bathy.max_depth_m() > 5000.0);

        let source = manila_trench_source();
        assert_eq!(
            (source.strike_deg, source.dip_deg, source.rake_deg),
            (350.0, 20.0, 90.0)
        );
        assert!((source.top_edge_depth_m() - 5000.0).abs() < 1e-9);
        let cell = |x: f64, y: f64| {
            let d = SOUTH_CHINA_SEA_EXTENT_M / n as f64;
            bathy.depth_m[(y / d) as usize * n + (x / d) as usize]
        };
        // The trench axis lies up dip of the plane's centre, deeper than the plain.
        let back = 0.5 * source.width_m * source.dip_deg.to_radians().cos();
        let azimuth = (source.strike_deg + 90.0).to_radians();
        let axis = (
            source.x_m - back * azimuth.sin(),
            source.y_m - back * azimuth.cos(),
        );
        assert!(cell(axis.0, axis.1) > 5000.0, "{}", cell(axis.0, axis.1));
        // The centre lies under the forearc slope, still well offshore.
        assert!(cell(source.x_m, source.y_m) > 1000.0);

        // A short run from an uplift over the source stays finite and spreads.
        let small = synthetic_south_china_sea(100, SOUTH_CHINA_SEA_EXTENT_M);
        let d = small.dx_m;
        let eta0: Vec<f64> = (0..100 * 100)
            .map(|k| {
                let x = ((k % 100) as f64 + 0.5) * d - source.x_m;
                let y = ((k / 100) as f64 + 0.5) * d - source.y_m;
                (-(x * x + y * y) / (2.0 * 4.0e4_f64.powi(2))).exp()
            })
            .collect();
        let result = run(&small, &eta0, &options(1200.0, Boundary::Open));
        assert!(result.final_eta.iter().all(|e| e.is_finite()));
        let reached = result
            .arrival_time_s
            .iter()
            .filter(|t| t.is_finite())
            .count();
        assert!(reached > 200, "{reached}");
        assert!(result
            .final_eta
            .iter()
            .zip(&small.depth_m)
            .all(|(&e, &h)| h > 0.0 || e == 0.0));
    }
}
