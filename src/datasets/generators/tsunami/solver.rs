//! The shallow-water solver: the state of one run on the staggered Arakawa C grid and its
//! leap-frog steps (linear or nonlinear momentum with Manning friction, then continuity).

use rayon::prelude::*;

use super::bathymetry::Bathymetry;
use super::{Boundary, TsunamiOptions, MIN_TOTAL_DEPTH_M};

/// The state of one run. Faces of x-flux M: `(nx + 1) * ny`, index `j * (nx + 1) + i` for the
/// face between cells i-1 and i. Faces of y-flux N: `nx * (ny + 1)`, index `j * nx + i` for the
/// face between rows j-1 and j.
pub(super) struct Model {
    nx: usize,
    ny: usize,
    dt: f64,
    dx: f64,
    dy: f64,
    g: f64,
    pub(super) eta: Vec<f64>,
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
    pub(super) max_abs_eta: Vec<f64>,
    pub(super) arrival_time_s: Vec<f64>,
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
    pub(super) fn new(bathy: &Bathymetry, eta0: &[f64], opts: &TsunamiOptions, dt: f64) -> Self {
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
    pub(super) fn linear_momentum(&mut self, dt_fraction: f64) {
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
    pub(super) fn nonlinear_momentum(&mut self, dt_fraction: f64, manning_n: f64) {
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
    pub(super) fn continuity_and_record(&mut self, t: f64, threshold: f64) {
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
