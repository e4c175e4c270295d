//! Displacement of an elastic half-space by finite rectangular dislocations: Okada (1985,
//! BSSA 75, 1135-1154) at the free surface and Okada (1992, BSSA 82, 1018-1040, "DC3D") at depth,
//! with the papers' rules for their singular cases. Two layers: `OkadaRectangle` works in
//! Okada's own frame (x along strike, y perpendicular, z up, origin at the bottom-left corner of
//! the fault) and is what the published check lists test; [`FaultSegment`] places faults in
//! project coordinates (x east, y north, z up, metres) with strike, dip and rake, and
//! [`surface_field`] samples the surface displacement of a set of them on a grid for rendering
//! (the paper's case II: Yuan et al. 2008, section 3.2).

use std::f64::consts::TAU;
use std::fmt;
use std::path::Path;

use rayon::prelude::*;

use crate::error::{Error, Result};

/// Below this |cos(dip)| a fault is treated as vertical: the general formulas divide by cos(dip)
/// and cos^2(dip) and lose every digit there, while the vertical ones are off by O(cos(dip)).
/// The same threshold as DC3D.
const VERTICAL_COS: f64 = 1e-6;

/// Coordinates closer than this fraction of the fault size to a singular line (xi = 0, eta = 0,
/// q = 0) are moved onto it, so that the papers' limit rules apply instead of a cancellation of
/// huge terms; the error made is of the same relative order.
const SNAP_RELATIVE: f64 = 1e-9;

/// Largest grid side accepted by [`surface_field`]; 8193^2 nodes already need 1.6 GB for the
/// three components.
pub(crate) const MAX_GRID_SIDE: usize = 8193;

// ---------------------------------------------------------------------------------------------
// Okada's frame
// ---------------------------------------------------------------------------------------------

/// A rectangular dislocation in Okada's frame: x along strike, y horizontal and perpendicular to
/// strike (the fault dips towards -y for a positive dip), z up. The fault occupies
/// xi in [0, length] along strike and eta in [0, width] up-dip from the origin corner, which lies
/// at (0, 0, -depth); with a negative dip eta grows downwards, so the origin is the top edge. Slip is
/// the movement of the hanging wall relative to the foot wall:
/// `strike_slip` (U1, positive left-lateral), `dip_slip` (U2, positive reverse for a positive dip),
/// `tensile` (U3, positive opening). Any consistent length unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct OkadaRectangle {
    pub length: f64,
    pub width: f64,
    /// Depth of the origin corner (Okada's d in 1985, c in 1992), positive downwards.
    pub depth: f64,
    /// Dip in degrees, in [-90, 90].
    pub dip_deg: f64,
    pub strike_slip: f64,
    pub dip_slip: f64,
    pub tensile: f64,
}

impl OkadaRectangle {
    /// Checks that the numbers describe a buried fault in a valid medium; `alpha` is
    /// (lambda + mu) / (lambda + 2 mu), which lies in (1/4, 1] for Poisson ratios in (-1, 1/2].
    #[cfg(test)]
    fn check(&self, alpha: f64) -> Result<()> {
        let named = [
            ("length", self.length),
            ("width", self.width),
            ("depth", self.depth),
            ("dip_deg", self.dip_deg),
            ("strike_slip", self.strike_slip),
            ("dip_slip", self.dip_slip),
            ("tensile", self.tensile),
            ("alpha", alpha),
        ];
        for (field, value) in named {
            if !value.is_finite() {
                return Err(Error::invalid(
                    field,
                    format!("must be finite, got {value}"),
                ));
            }
        }
        if self.length <= 0.0 || self.width <= 0.0 {
            return Err(Error::invalid(
                "length/width",
                format!("must be > 0, got {} x {}", self.length, self.width),
            ));
        }
        if !(-90.0..=90.0).contains(&self.dip_deg) {
            return Err(Error::invalid(
                "dip_deg",
                format!("must lie in [-90, 90], got {}", self.dip_deg),
            ));
        }
        if !(alpha > 0.25 && alpha <= 1.0) {
            return Err(Error::invalid(
                "alpha",
                format!("(lambda+mu)/(lambda+2mu) must lie in (0.25, 1], got {alpha}"),
            ));
        }
        let (sin, _) = dip_sin_cos(self.dip_deg);
        let shallowest = self.depth.min(self.depth - self.width * sin);
        if shallowest <= 0.0 {
            return Err(Error::invalid(
                "depth",
                format!(
                    "the fault reaches depth {shallowest}; it must be buried (every edge deeper than 0)"
                ),
            ));
        }
        Ok(())
    }

    /// Surface displacement (ux, uy, uz) at (x, y, 0) by Okada's (1985) finite-source formulas.
    #[cfg(test)]
    pub(crate) fn surface_displacement(&self, alpha: f64, x: f64, y: f64) -> Result<[f64; 3]> {
        self.check(alpha)?;
        if !(x.is_finite() && y.is_finite()) {
            return Err(Error::invalid("x/y", "observation point must be finite"));
        }
        Ok(Kernel::new(self, alpha).surface(x, y))
    }

    /// Displacement (ux, uy, uz) at (x, y, z), z <= 0, by Okada (1992) DC3D. A point on an edge
    /// of the fault, where the displacement is singular, is an error; a point on the fault's
    /// surface gets the mean of the two sides.
    #[cfg(test)]
    pub(crate) fn displacement(&self, alpha: f64, x: f64, y: f64, z: f64) -> Result<[f64; 3]> {
        self.check(alpha)?;
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err(Error::invalid("x/y/z", "observation point must be finite"));
        }
        if z > 0.0 {
            return Err(Error::invalid(
                "z",
                format!("must be <= 0 (inside the half-space), got {z}"),
            ));
        }
        Kernel::new(self, alpha).internal(x, y, z)
    }
}

/// sin and cos of a dip, with a near-vertical dip made exactly vertical (see [`VERTICAL_COS`]).
fn dip_sin_cos(dip_deg: f64) -> (f64, f64) {
    let (sin, cos) = dip_deg.to_radians().sin_cos();
    if cos.abs() < VERTICAL_COS {
        (sin.signum(), 0.0)
    } else {
        (sin, cos)
    }
}

/// sin and cos of an angle in degrees, exact at multiples of 90 so that faults striking along an
/// axis or with pure dip-slip rakes keep their exact symmetries.
fn sin_cos_deg(angle_deg: f64) -> (f64, f64) {
    let reduced = angle_deg.rem_euclid(360.0);
    match reduced {
        0.0 => (0.0, 1.0),
        90.0 => (1.0, 0.0),
        180.0 => (0.0, -1.0),
        270.0 => (-1.0, 0.0),
        _ => reduced.to_radians().sin_cos(),
    }
}

/// R + s computed without cancellation: for s < 0 it equals (R^2 - s^2) / (R - s), where
/// `others_squared` = R^2 - s^2 is the sum of the other two squared coordinates.
fn r_plus(r: f64, s: f64, others_squared: f64) -> f64 {
    if s >= 0.0 {
        r + s
    } else {
        others_squared / (r - s)
    }
}

/// ln(R + s) and 1/(R + s) with Okada's rule for R + s = 0 (the point lies on the extension of
/// an edge): ln(R + s) -> -ln(R - s) and 1/(R + s) -> 0. The dropped ln of the distance to the
/// edge line is common to both corners of a Chinnery pair and cancels.
fn log_and_inverse(r_plus_s: f64, r: f64, s: f64) -> (f64, f64) {
    if r_plus_s > 0.0 {
        (r_plus_s.ln(), 1.0 / r_plus_s)
    } else {
        (-(r - s).ln(), 0.0)
    }
}

/// One rectangle with its trigonometry and elastic constants ready for many evaluations.
#[derive(Clone, Copy, Debug)]
struct Kernel {
    length: f64,
    width: f64,
    depth: f64,
    sin: f64,
    cos: f64,
    /// U1, U2, U3 divided by 2 pi.
    slip: [f64; 3],
    alpha: f64,
    /// mu / (lambda + mu) = (1 - alpha) / alpha.
    mu_ratio: f64,
    snap: f64,
}

/// The quantities one corner of the Chinnery sum shares between the terms of Okada (1992).
struct Corner {
    xi: f64,
    eta: f64,
    q: f64,
    r: f64,
    y_tilde: f64,
    d_tilde: f64,
    theta: f64,
    ln_r_xi: f64,
    ln_r_eta: f64,
    x11: f64,
    y11: f64,
    x32: f64,
    y32: f64,
}

impl Kernel {
    fn new(rect: &OkadaRectangle, alpha: f64) -> Self {
        let (sin, cos) = dip_sin_cos(rect.dip_deg);
        Kernel {
            length: rect.length,
            width: rect.width,
            depth: rect.depth,
            sin,
            cos,
            slip: [
                rect.strike_slip / TAU,
                rect.dip_slip / TAU,
                rect.tensile / TAU,
            ],
            alpha,
            mu_ratio: (1.0 - alpha) / alpha,
            snap: SNAP_RELATIVE * rect.length.max(rect.width).max(rect.depth.abs()),
        }
    }

    fn snapped(&self, value: f64) -> f64 {
        if value.abs() < self.snap {
            0.0
        } else {
            value
        }
    }

    /// The four corners of Chinnery's notation f(x, p) - f(x, p-W) - f(x-L, p) + f(x-L, p-W),
    /// each with its sign.
    fn chinnery_corners(&self, x: f64, p: f64) -> [(f64, f64, f64); 4] {
        let xi_near = self.snapped(x);
        let xi_far = self.snapped(x - self.length);
        let eta_bottom = self.snapped(p);
        let eta_top = self.snapped(p - self.width);
        [
            (xi_near, eta_bottom, 1.0),
            (xi_near, eta_top, -1.0),
            (xi_far, eta_bottom, -1.0),
            (xi_far, eta_top, 1.0),
        ]
    }

    /// Okada (1985) surface displacement, summed over the Chinnery corners.
    fn surface(&self, x: f64, y: f64) -> [f64; 3] {
        let p = y * self.cos + self.depth * self.sin;
        let q = self.snapped(y * self.sin - self.depth * self.cos);
        let mut u = [0.0; 3];
        for (xi, eta, sign) in self.chinnery_corners(x, p) {
            let f = self.surface_corner(xi, eta, q);
            for (total, term) in u.iter_mut().zip(f) {
                *total += sign * term;
            }
        }
        u
    }

    /// One corner of Okada's (1985) finite-source displacements with their I-terms, all three slip
    /// types at once.
    fn surface_corner(&self, xi: f64, eta: f64, q: f64) -> [f64; 3] {
        let (sin, cos, m) = (self.sin, self.cos, self.mu_ratio);
        let r = (xi * xi + eta * eta + q * q).sqrt();
        let y_tilde = eta * cos + q * sin;
        let d_tilde = eta * sin - q * cos;
        let r_eta = r_plus(r, eta, xi * xi + q * q);
        let r_xi = r_plus(r, xi, eta * eta + q * q);
        let r_d = r_plus(r, d_tilde, xi * xi + y_tilde * y_tilde);
        let (ln_r_eta, inv_r_eta) = log_and_inverse(r_eta, r, eta);
        let inv_r_xi = if r_xi > 0.0 { 1.0 / r_xi } else { 0.0 };
        let y11 = inv_r_eta / r;
        let x11 = inv_r_xi / r;
        let theta = if q == 0.0 {
            0.0
        } else {
            (xi * eta / (q * r)).atan()
        };

        let (i1, i2, i3, i4, i5);
        if cos != 0.0 {
            i5 = if xi == 0.0 {
                0.0
            } else {
                let x = (xi * xi + q * q).sqrt();
                m * 2.0 / cos
                    * ((eta * (x + q * cos) + x * (r + x) * sin) / (xi * (r + x) * cos)).atan()
            };
            i4 = m / cos * (r_d.ln() - sin * ln_r_eta);
            i3 = m * (y_tilde / (cos * r_d) - ln_r_eta) + sin / cos * i4;
            i2 = -m * ln_r_eta - i3;
            i1 = -m * xi / (cos * r_d) - sin / cos * i5;
        } else {
            let r_d2 = r_d * r_d;
            i1 = -0.5 * m * xi * q / r_d2;
            i3 = 0.5 * m * (eta / r_d + y_tilde * q / r_d2 - ln_r_eta);
            i2 = -m * ln_r_eta - i3;
            i4 = -m * q / r_d;
            i5 = -m * xi * sin / r_d;
        }

        let [u1, u2, u3] = self.slip;
        let strike = [
            -(xi * q * y11 + theta + i1 * sin),
            -(y_tilde * q * y11 + q * cos * inv_r_eta + i2 * sin),
            -(d_tilde * q * y11 + q * sin * inv_r_eta + i4 * sin),
        ];
        let dip = [
            -(q / r - i3 * sin * cos),
            -(y_tilde * q * x11 + cos * theta - i1 * sin * cos),
            -(d_tilde * q * x11 + sin * theta - i5 * sin * cos),
        ];
        let opening_bracket = xi * q * y11 - theta;
        let tensile = [
            q * q * y11 - i3 * sin * sin,
            -d_tilde * q * x11 - sin * opening_bracket - i1 * sin * sin,
            y_tilde * q * x11 + cos * opening_bracket - i5 * sin * sin,
        ];
        [0, 1, 2].map(|k| u1 * strike[k] + u2 * dip[k] + u3 * tensile[k])
    }

    fn corner(&self, xi: f64, eta: f64, q: f64) -> Corner {
        let r = (xi * xi + eta * eta + q * q).sqrt();
        let r_eta = r_plus(r, eta, xi * xi + q * q);
        let r_xi = r_plus(r, xi, eta * eta + q * q);
        let (ln_r_eta, inv_r_eta) = log_and_inverse(r_eta, r, eta);
        let (ln_r_xi, inv_r_xi) = log_and_inverse(r_xi, r, xi);
        let x11 = inv_r_xi / r;
        let y11 = inv_r_eta / r;
        Corner {
            xi,
            eta,
            q,
            r,
            y_tilde: eta * self.cos + q * self.sin,
            d_tilde: eta * self.sin - q * self.cos,
            theta: if q == 0.0 {
                0.0
            } else {
                (xi * eta / (q * r)).atan()
            },
            ln_r_xi,
            ln_r_eta,
            x11,
            y11,
            // (2R + xi) / (R^3 (R + xi)^2), written through X11 so that the R + xi = 0 rule
            // carries over.
            x32: (r + r_xi) * x11 * x11 / r,
            y32: (r + r_eta) * y11 * y11 / r,
        }
    }

    /// Weighted sum of the three slip types' terms.
    fn combine(&self, strike: [f64; 3], dip: [f64; 3], tensile: [f64; 3]) -> [f64; 3] {
        let [u1, u2, u3] = self.slip;
        [0, 1, 2].map(|k| u1 * strike[k] + u2 * dip[k] + u3 * tensile[k])
    }

    /// Okada's (1992) finite-source infinite-medium terms u^A.
    fn term_a(&self, c: &Corner) -> [f64; 3] {
        let (a, one_minus_a) = (self.alpha, 1.0 - self.alpha);
        let (xi, eta, q, r) = (c.xi, c.eta, c.q, c.r);
        let strike = [
            0.5 * c.theta + 0.5 * a * xi * q * c.y11,
            0.5 * a * q / r,
            0.5 * one_minus_a * c.ln_r_eta - 0.5 * a * q * q * c.y11,
        ];
        let dip = [
            0.5 * a * q / r,
            0.5 * c.theta + 0.5 * a * eta * q * c.x11,
            0.5 * one_minus_a * c.ln_r_xi - 0.5 * a * q * q * c.x11,
        ];
        let tensile = [
            -0.5 * one_minus_a * c.ln_r_eta - 0.5 * a * q * q * c.y11,
            -0.5 * one_minus_a * c.ln_r_xi - 0.5 * a * q * q * c.x11,
            0.5 * c.theta - 0.5 * a * q * (eta * c.x11 + xi * c.y11),
        ];
        self.combine(strike, dip, tensile)
    }

    /// Okada's (1992) finite-source surface-deformation terms u^B with their I-integrals.
    fn term_b(&self, c: &Corner) -> [f64; 3] {
        let (sin, cos, m) = (self.sin, self.cos, self.mu_ratio);
        let (xi, eta, q, r) = (c.xi, c.eta, c.q, c.r);
        let r_d = r_plus(r, c.d_tilde, xi * xi + c.y_tilde * c.y_tilde);
        let (i3, i4);
        if cos != 0.0 {
            let cos2 = cos * cos;
            let arctan_term = if xi == 0.0 {
                0.0
            } else {
                let x = (xi * xi + q * q).sqrt();
                ((eta * (x + q * cos) + x * (r + x) * sin) / (xi * (r + x) * cos)).atan()
            };
            i3 = c.y_tilde / (cos * r_d) - (c.ln_r_eta - sin * r_d.ln()) / cos2;
            i4 = sin / cos * xi / r_d + 2.0 * arctan_term / cos2;
        } else {
            let r_d2 = r_d * r_d;
            i3 = 0.5 * (eta / r_d + c.y_tilde * q / r_d2 - c.ln_r_eta);
            i4 = 0.5 * xi * c.y_tilde / r_d2;
        }
        let i1 = -xi / r_d * cos - i4 * sin;
        let i2 = r_d.ln() + i3 * sin;
        let strike = [
            -xi * q * c.y11 - c.theta - m * i1 * sin,
            -q / r + m * c.y_tilde / r_d * sin,
            q * q * c.y11 - m * i2 * sin,
        ];
        let dip = [
            -q / r + m * i3 * sin * cos,
            -eta * q * c.x11 - c.theta - m * xi / r_d * sin * cos,
            q * q * c.x11 + m * i4 * sin * cos,
        ];
        let tensile = [
            q * q * c.y11 - m * i3 * sin * sin,
            q * q * c.x11 + m * xi / r_d * sin * sin,
            q * (eta * c.x11 + xi * c.y11) - c.theta - m * i4 * sin * sin,
        ];
        self.combine(strike, dip, tensile)
    }

    /// Okada's (1992) finite-source depth-dependent terms u^C (multiplied by z by the caller).
    fn term_c(&self, c: &Corner, z: f64) -> [f64; 3] {
        let (sin, cos) = (self.sin, self.cos);
        let (a, one_minus_a) = (self.alpha, 1.0 - self.alpha);
        let (xi, eta, q, r) = (c.xi, c.eta, c.q, c.r);
        let c_bar = c.d_tilde + z;
        let h = q * cos - z;
        let r3 = r * r * r;
        let z32 = sin / r3 - h * c.y32;
        let strike = [
            one_minus_a * xi * c.y11 * cos - a * xi * q * z32,
            one_minus_a * (cos / r + 2.0 * q * c.y11 * sin) - a * c_bar * q / r3,
            one_minus_a * q * c.y11 * cos - a * (c_bar * eta / r3 - z * c.y11 + xi * xi * z32),
        ];
        let dip = [
            one_minus_a * cos / r - q * c.y11 * sin - a * c_bar * q / r3,
            one_minus_a * c.y_tilde * c.x11 - a * c_bar * eta * q * c.x32,
            -c.d_tilde * c.x11 - xi * c.y11 * sin - a * c_bar * (c.x11 - q * q * c.x32),
        ];
        let tensile = [
            -one_minus_a * (sin / r + q * c.y11 * cos) - a * (z * c.y11 - q * q * z32),
            one_minus_a * 2.0 * xi * c.y11 * sin + c.d_tilde * c.x11
                - a * c_bar * (c.x11 - q * q * c.x32),
            one_minus_a * (c.y_tilde * c.x11 + xi * c.y11 * cos)
                + a * q * (c_bar * eta * c.x32 + xi * z32),
        ];
        self.combine(strike, dip, tensile)
    }

    /// Okada (1992) finite rectangular source:
    /// u = [u^A(z) - u^A(-z) + u^B(z) + z u^C(z)] summed over the Chinnery corners, where the
    /// u^A(-z) term (the real source, d = c + z) enters with its own p and q.
    fn internal(&self, x: f64, y: f64, z: f64) -> Result<[f64; 3]> {
        if self.sin < 0.0 {
            return self.internal_flipped(x, y, z);
        }
        let (sin, cos) = (self.sin, self.cos);
        let mut u = [0.0; 3];

        let d_real = self.depth + z;
        let p_real = y * cos + d_real * sin;
        let q_real = self.snapped(y * sin - d_real * cos);
        let corners = self.chinnery_corners(x, p_real);
        let on_edge_line = q_real == 0.0 && {
            let (xi_near, eta_bottom, _) = corners[0];
            let (xi_far, eta_top, _) = corners[3];
            let xi_product = xi_near * xi_far;
            let eta_product = eta_bottom * eta_top;
            (xi_product <= 0.0 && eta_product == 0.0) || (eta_product <= 0.0 && xi_product == 0.0)
        };
        if on_edge_line {
            return Err(Error::invalid(
                "x/y/z",
                format!("({x}, {y}, {z}) lies on an edge of the fault, where the displacement is singular"),
            ));
        }
        for (xi, eta, sign) in corners {
            let a = self.term_a(&self.corner(xi, eta, q_real));
            u[0] -= sign * a[0];
            u[1] -= sign * (a[1] * cos - a[2] * sin);
            u[2] -= sign * (a[1] * sin + a[2] * cos);
        }

        let d_image = self.depth - z;
        let p_image = y * cos + d_image * sin;
        let q_image = self.snapped(y * sin - d_image * cos);
        for (xi, eta, sign) in self.chinnery_corners(x, p_image) {
            let corner = self.corner(xi, eta, q_image);
            let a = self.term_a(&corner);
            let b = self.term_b(&corner);
            let c = self.term_c(&corner, z);
            u[0] += sign * (a[0] + b[0] + z * c[0]);
            u[1] += sign * ((a[1] + b[1] + z * c[1]) * cos - (a[2] + b[2] + z * c[2]) * sin);
            u[2] += sign * ((a[1] + b[1] - z * c[1]) * sin + (a[2] + b[2] - z * c[2]) * cos);
        }
        Ok(u)
    }

    /// A negative dip describes the same plane as a positive dip seen from the other end: strike
    /// reversed (x -> L - x, y -> W cos(dip) - y), origin at the opposite corner, strike- and
    /// dip-slip negated. With sin(dip) >= 0 the image terms never meet R + xi = 0 or R + eta = 0
    /// (that needs a point above the surface), so the limit rules act only on the u^A terms,
    /// whose coefficients vanish there; the depth terms u^C, with z Y11 in them, would not.
    fn internal_flipped(&self, x: f64, y: f64, z: f64) -> Result<[f64; 3]> {
        let flipped = Kernel {
            depth: self.depth - self.width * self.sin,
            sin: -self.sin,
            slip: [-self.slip[0], -self.slip[1], self.slip[2]],
            ..*self
        };
        let u = flipped.internal(self.length - x, self.width * self.cos - y, z)?;
        Ok([-u[0], -u[1], u[2]])
    }
}

// ---------------------------------------------------------------------------------------------
// Project coordinates
// ---------------------------------------------------------------------------------------------

/// Which point of a fault `FaultSegment::depth_m` gives the depth of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DepthRef {
    /// The shallowest edge.
    Top,
    /// The centre of the rectangle.
    #[default]
    Centroid,
    /// The deepest edge.
    Bottom,
}

impl DepthRef {
    pub fn name(self) -> &'static str {
        match self {
            DepthRef::Top => "top",
            DepthRef::Centroid => "centroid",
            DepthRef::Bottom => "bottom",
        }
    }

    /// Parses `top`, `centroid` or `bottom` (any case).
    pub fn parse(text: &str) -> Result<Self> {
        match text.to_ascii_lowercase().as_str() {
            "top" => Ok(DepthRef::Top),
            "centroid" | "center" | "centre" => Ok(DepthRef::Centroid),
            "bottom" => Ok(DepthRef::Bottom),
            _ => Err(Error::invalid(
                "depth_ref",
                format!("expected top, centroid or bottom, got '{text}'"),
            )),
        }
    }
}

impl fmt::Display for DepthRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A rectangular fault in project coordinates (x east, y north, z up, metres). Strike is
/// clockwise from north and the fault dips to the right of its strike (Aki & Richards); a
/// negative dip is Okada's continuation, the same plane as strike + 180, |dip|, rake + 180.
/// Rake follows Aki & Richards and Okada: 0 left-lateral, 90 reverse (thrust), -90 normal.
/// `slip_m` is the hanging wall's movement relative to the foot wall, `opening_m` the tensile
/// opening. `(x_m, y_m)` is the surface point above the centroid; `depth_m` is the depth of the
/// point `depth_ref` names.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSegment {
    pub strike_deg: f64,
    pub dip_deg: f64,
    pub rake_deg: f64,
    pub slip_m: f64,
    pub length_m: f64,
    pub width_m: f64,
    pub depth_m: f64,
    pub depth_ref: DepthRef,
    pub opening_m: f64,
    pub x_m: f64,
    pub y_m: f64,
}

impl Default for FaultSegment {
    fn default() -> Self {
        Self::paper_case_ii()
    }
}

impl FaultSegment {
    /// The earthquake of the paper's case II (Yuan et al. 2008, section 3.2): strike 0, dip 6,
    /// rake -90 (normal), slip 10 m, 100 km along strike, 50 km down dip. The paper says "depth
    /// 50 km" without naming the point; it is taken here as the centroid.
    pub fn paper_case_ii() -> Self {
        FaultSegment {
            strike_deg: 0.0,
            dip_deg: 6.0,
            rake_deg: -90.0,
            slip_m: 10.0,
            length_m: 100e3,
            width_m: 50e3,
            depth_m: 50e3,
            depth_ref: DepthRef::Centroid,
            opening_m: 0.0,
            x_m: 0.0,
            y_m: 0.0,
        }
    }

    /// Vertical extent of half the fault's width.
    fn half_height(&self) -> f64 {
        0.5 * self.width_m * dip_sin_cos(self.dip_deg).0.abs()
    }

    /// Depth of the fault's centre, positive downwards.
    pub(crate) fn centroid_depth_m(&self) -> f64 {
        match self.depth_ref {
            DepthRef::Top => self.depth_m + self.half_height(),
            DepthRef::Centroid => self.depth_m,
            DepthRef::Bottom => self.depth_m - self.half_height(),
        }
    }

    /// Depth of the shallowest edge, positive downwards.
    pub(crate) fn top_depth_m(&self) -> f64 {
        self.centroid_depth_m() - self.half_height()
    }

    /// Depth of the deepest edge, positive downwards.
    #[cfg(test)]
    pub(crate) fn bottom_depth_m(&self) -> f64 {
        self.centroid_depth_m() + self.half_height()
    }

    /// Checks every field; faults are buried, so the top edge must lie below the surface.
    pub fn validate(&self) -> Result<()> {
        let named = [
            ("strike_deg", self.strike_deg),
            ("dip_deg", self.dip_deg),
            ("rake_deg", self.rake_deg),
            ("slip_m", self.slip_m),
            ("length_m", self.length_m),
            ("width_m", self.width_m),
            ("depth_m", self.depth_m),
            ("opening_m", self.opening_m),
            ("x_m", self.x_m),
            ("y_m", self.y_m),
        ];
        for (field, value) in named {
            if !value.is_finite() {
                return Err(Error::invalid(
                    field,
                    format!("must be a finite number, got {value}"),
                ));
            }
        }
        if !(-90.0..=90.0).contains(&self.dip_deg) {
            return Err(Error::invalid(
                "dip_deg",
                format!("must lie in [-90, 90] degrees, got {}", self.dip_deg),
            ));
        }
        for (field, value) in [("length_m", self.length_m), ("width_m", self.width_m)] {
            if value <= 0.0 {
                return Err(Error::invalid(field, format!("must be > 0 m, got {value}")));
            }
        }
        let top = self.top_depth_m();
        if top <= 0.0 {
            let least = self.depth_m - top;
            return Err(Error::invalid(
                "depth_m",
                format!(
                    "the top edge would be at depth {top} m, at or above the surface; with depth_ref {}, \
                     width_m {} and dip_deg {} a buried fault needs depth_m > {least} m",
                    self.depth_ref, self.width_m, self.dip_deg
                ),
            ));
        }
        Ok(())
    }

    /// The segment in Okada's frame: the rectangle, and the surface point above its centroid
    /// expressed in that frame's axes.
    fn prepare(&self, elastic: &Elastic) -> PreparedSegment {
        let (mut strike, mut dip, mut rake) = (self.strike_deg, self.dip_deg, self.rake_deg);
        if dip < 0.0 {
            strike += 180.0;
            dip = -dip;
            rake += 180.0;
        }
        let (sin_strike, cos_strike) = sin_cos_deg(strike);
        let (sin_rake, cos_rake) = sin_cos_deg(rake);
        let (sin_dip, cos_dip) = dip_sin_cos(dip);
        let rect = OkadaRectangle {
            length: self.length_m,
            width: self.width_m,
            depth: self.centroid_depth_m() + 0.5 * self.width_m * sin_dip,
            dip_deg: dip,
            strike_slip: self.slip_m * cos_rake,
            dip_slip: self.slip_m * sin_rake,
            tensile: self.opening_m,
        };
        PreparedSegment {
            kernel: Kernel::new(&rect, elastic.alpha()),
            x_m: self.x_m,
            y_m: self.y_m,
            strike_axis: [sin_strike, cos_strike],
            left_axis: [-cos_strike, sin_strike],
            centroid_okada: [0.5 * self.length_m, 0.5 * self.width_m * cos_dip],
        }
    }
}

/// A segment ready for evaluation: Okada's x axis is the strike direction, his y axis points
/// to the left of strike (the side the fault rises towards).
struct PreparedSegment {
    kernel: Kernel,
    x_m: f64,
    y_m: f64,
    /// (east, north) components of Okada's x axis.
    strike_axis: [f64; 2],
    /// (east, north) components of Okada's y axis.
    left_axis: [f64; 2],
    /// Okada coordinates of the surface point above the centroid.
    centroid_okada: [f64; 2],
}

impl PreparedSegment {
    fn to_okada(&self, x: f64, y: f64) -> (f64, f64) {
        let (east, north) = (x - self.x_m, y - self.y_m);
        (
            east * self.strike_axis[0] + north * self.strike_axis[1] + self.centroid_okada[0],
            east * self.left_axis[0] + north * self.left_axis[1] + self.centroid_okada[1],
        )
    }

    fn to_project(&self, u: [f64; 3]) -> [f64; 3] {
        [
            u[0] * self.strike_axis[0] + u[1] * self.left_axis[0],
            u[0] * self.strike_axis[1] + u[1] * self.left_axis[1],
            u[2],
        ]
    }

    fn surface(&self, x: f64, y: f64) -> [f64; 3] {
        let (xo, yo) = self.to_okada(x, y);
        self.to_project(self.kernel.surface(xo, yo))
    }

    fn internal(&self, x: f64, y: f64, z: f64) -> Result<[f64; 3]> {
        let (xo, yo) = self.to_okada(x, y);
        Ok(self.to_project(self.kernel.internal(xo, yo, z)?))
    }
}

/// Elastic constants of the half-space; only the Poisson ratio matters for displacements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    poisson: f64,
}

impl Default for Elastic {
    /// lambda = mu, Poisson ratio 1/4, as in Okada's check lists.
    fn default() -> Self {
        Elastic { poisson: 0.25 }
    }
}

impl Elastic {
    /// A medium with Poisson ratio `poisson` in (-1, 0.5].
    pub fn from_poisson(poisson: f64) -> Result<Self> {
        if !(poisson > -1.0 && poisson <= 0.5) {
            return Err(Error::invalid(
                "poisson",
                format!("must lie in (-1, 0.5], got {poisson}"),
            ));
        }
        Ok(Elastic { poisson })
    }

    /// A medium from Lamé's constants: mu > 0 and a positive bulk modulus (lambda > -2 mu / 3).
    pub fn from_lame(lambda: f64, mu: f64) -> Result<Self> {
        if !(mu.is_finite() && mu > 0.0) {
            return Err(Error::invalid(
                "mu",
                format!("must be finite and > 0, got {mu}"),
            ));
        }
        if !(lambda.is_finite() && lambda > -2.0 * mu / 3.0) {
            return Err(Error::invalid(
                "lambda",
                format!(
                    "must be finite and > -2 mu / 3 = {}, got {lambda}",
                    -2.0 * mu / 3.0
                ),
            ));
        }
        Self::from_poisson(lambda / (2.0 * (lambda + mu)))
    }

    pub fn poisson(&self) -> f64 {
        self.poisson
    }

    /// Okada's alpha = (lambda + mu) / (lambda + 2 mu) = 1 / (2 (1 - nu)).
    pub fn alpha(&self) -> f64 {
        0.5 / (1.0 - self.poisson)
    }
}

/// Validates every segment, naming the segment's index in the error.
fn prepare_all(segments: &[FaultSegment], elastic: &Elastic) -> Result<Vec<PreparedSegment>> {
    segments
        .iter()
        .enumerate()
        .map(|(index, segment)| match segment.validate() {
            Ok(()) => Ok(segment.prepare(elastic)),
            Err(Error::Invalid { field, msg }) => {
                Err(Error::invalid(format!("segment {index} {field}"), msg))
            }
            Err(other) => Err(other),
        })
        .collect()
}

/// Displacement (east, north, up) in metres at (x, y, z), z <= 0, summed over the segments:
/// Okada (1985) at the surface, Okada (1992) below it.
pub(crate) fn displacement_at(
    segments: &[FaultSegment],
    elastic: &Elastic,
    x: f64,
    y: f64,
    z: f64,
) -> Result<[f64; 3]> {
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return Err(Error::invalid(
            "x/y/z",
            format!("observation point must be finite, got ({x}, {y}, {z})"),
        ));
    }
    if z > 0.0 {
        return Err(Error::invalid(
            "z",
            format!("must be <= 0 m (inside the half-space), got {z}"),
        ));
    }
    let prepared = prepare_all(segments, elastic)?;
    let mut total = [0.0; 3];
    for segment in &prepared {
        let u = if z == 0.0 {
            segment.surface(x, y)
        } else {
            segment.internal(x, y, z)?
        };
        for (sum, part) in total.iter_mut().zip(u) {
            *sum += part;
        }
    }
    Ok(total)
}

/// Surface displacement on a regular grid. `x` (east) and `y` (north) hold the node
/// coordinates along each axis; the components are row-major, index `j * nx + i` for node
/// (`x[i]`, `y[j]`).
#[derive(Clone, Debug, PartialEq)]
pub struct OkadaField {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub ux: Vec<f64>,
    pub uy: Vec<f64>,
    pub uz: Vec<f64>,
}

impl OkadaField {
    pub fn nx(&self) -> usize {
        self.x.len()
    }

    pub fn ny(&self) -> usize {
        self.y.len()
    }
}

/// Surface displacement of the segments on a square of side `extent_m` centred on the origin,
/// `n` nodes per side (spacing `extent_m / (n - 1)`), computed in parallel over rows.
pub fn surface_field(
    segments: &[FaultSegment],
    elastic: &Elastic,
    extent_m: f64,
    n: usize,
) -> Result<OkadaField> {
    if !(extent_m.is_finite() && extent_m > 0.0) {
        return Err(Error::invalid(
            "extent_m",
            format!("must be finite and > 0, got {extent_m}"),
        ));
    }
    if !(2..=MAX_GRID_SIDE).contains(&n) {
        return Err(Error::invalid(
            "n",
            format!("nodes per side must lie in [2, {MAX_GRID_SIDE}], got {n}"),
        ));
    }
    let prepared = prepare_all(segments, elastic)?;
    let spacing = extent_m / (n - 1) as f64;
    let axis: Vec<f64> = (0..n)
        .map(|i| -0.5 * extent_m + i as f64 * spacing)
        .collect();
    let mut ux = vec![0.0; n * n];
    let mut uy = vec![0.0; n * n];
    let mut uz = vec![0.0; n * n];
    ux.par_chunks_mut(n)
        .zip(uy.par_chunks_mut(n))
        .zip(uz.par_chunks_mut(n))
        .enumerate()
        .for_each(|(j, ((row_x, row_y), row_z))| {
            let north = axis[j];
            for (i, &east) in axis.iter().enumerate() {
                let mut u = [0.0; 3];
                for segment in &prepared {
                    let part = segment.surface(east, north);
                    u[0] += part[0];
                    u[1] += part[1];
                    u[2] += part[2];
                }
                row_x[i] = u[0];
                row_y[i] = u[1];
                row_z[i] = u[2];
            }
        });
    Ok(OkadaField {
        x: axis.clone(),
        y: axis,
        ux,
        uy,
        uz,
    })
}

// ---------------------------------------------------------------------------------------------
// Segment tables
// ---------------------------------------------------------------------------------------------

/// Columns a segment table must name in its header.
const REQUIRED_COLUMNS: [&str; 9] = [
    "x_m",
    "y_m",
    "depth_m",
    "strike_deg",
    "dip_deg",
    "rake_deg",
    "length_m",
    "width_m",
    "slip_m",
];

/// Columns a segment table may add; missing ones take opening 0 and a centroid depth.
const OPTIONAL_COLUMNS: [&str; 2] = ["opening_m", "depth_ref"];

/// Parses a whitespace-separated table of fault segments. The first line that is not blank
/// or a comment names the columns, in any order: `x_m y_m depth_m strike_deg dip_deg rake_deg
/// length_m width_m slip_m`, optionally `opening_m` and `depth_ref` (top, centroid or bottom;
/// centroid when absent). `#` starts a comment. Every segment is validated; errors name `path`,
/// the line and the column.
pub fn parse_segment_table(text: &str, path: &Path) -> Result<Vec<FaultSegment>> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(index, line)| (index + 1, line.split('#').next().unwrap_or("").trim()))
        .filter(|(_, line)| !line.is_empty());

    let (header_line, header) = lines.next().ok_or_else(|| {
        Error::format(
            path,
            format!(
                "no header line; expected the column names {} [opening_m] [depth_ref]",
                REQUIRED_COLUMNS.join(" ")
            ),
        )
    })?;
    let columns: Vec<&str> = header.split_whitespace().collect();
    check_segment_columns(&columns, header_line, path)?;
    let mut segments = Vec::new();
    for (line_number, line) in lines {
        segments.push(parse_segment_row(line, line_number, &columns, path)?);
    }
    if segments.is_empty() {
        return Err(Error::format(
            path,
            "the table has a header but no fault segments",
        ));
    }
    Ok(segments)
}

/// Refuses a segment-table header with an unknown or repeated column or without a required one.
fn check_segment_columns(columns: &[&str], header_line: usize, path: &Path) -> Result<()> {
    for (index, name) in columns.iter().enumerate() {
        if !REQUIRED_COLUMNS.contains(name) && !OPTIONAL_COLUMNS.contains(name) {
            return Err(Error::format(
                path,
                format!(
                    "line {header_line}, column {}: unknown column '{name}'; known columns are {} {}",
                    index + 1,
                    REQUIRED_COLUMNS.join(" "),
                    OPTIONAL_COLUMNS.join(" ")
                ),
            ));
        }
        if columns[..index].contains(name) {
            return Err(Error::format(
                path,
                format!(
                    "line {header_line}, column {}: column '{name}' appears twice",
                    index + 1
                ),
            ));
        }
    }
    if let Some(missing) = REQUIRED_COLUMNS.iter().find(|name| !columns.contains(name)) {
        return Err(Error::format(
            path,
            format!("line {header_line}: the header lacks the required column '{missing}'"),
        ));
    }
    Ok(())
}

/// One validated fault segment from a table row under the header `columns`.
fn parse_segment_row(
    line: &str,
    line_number: usize,
    columns: &[&str],
    path: &Path,
) -> Result<FaultSegment> {
    let values: Vec<&str> = line.split_whitespace().collect();
    if values.len() != columns.len() {
        return Err(Error::format(
            path,
            format!(
                "line {line_number}: expected {} values (one per header column), found {}",
                columns.len(),
                values.len()
            ),
        ));
    }
    let mut segment = FaultSegment {
        opening_m: 0.0,
        depth_ref: DepthRef::Centroid,
        ..FaultSegment::paper_case_ii()
    };
    for (index, (&name, &token)) in columns.iter().zip(&values).enumerate() {
        let located = |msg: String| {
            Error::format(
                path,
                format!("line {line_number}, column {} ({name}): {msg}", index + 1),
            )
        };
        if name == "depth_ref" {
            segment.depth_ref = DepthRef::parse(token).map_err(|error| match error {
                Error::Invalid { msg, .. } => located(msg),
                other => other,
            })?;
            continue;
        }
        let value: f64 = token
            .parse()
            .map_err(|_| located(format!("expected a number, found '{token}'")))?;
        let slot = match name {
            "x_m" => &mut segment.x_m,
            "y_m" => &mut segment.y_m,
            "depth_m" => &mut segment.depth_m,
            "strike_deg" => &mut segment.strike_deg,
            "dip_deg" => &mut segment.dip_deg,
            "rake_deg" => &mut segment.rake_deg,
            "length_m" => &mut segment.length_m,
            "width_m" => &mut segment.width_m,
            "slip_m" => &mut segment.slip_m,
            _ => &mut segment.opening_m,
        };
        *slot = value;
    }
    segment.validate().map_err(|error| match error {
        Error::Invalid { field, msg } => {
            let place = match columns.iter().position(|name| *name == field) {
                Some(index) => format!("line {line_number}, column {} ({field})", index + 1),
                None => format!("line {line_number} ({field})"),
            };
            Error::format(path, format!("{place}: {msg}"))
        }
        other => other,
    })?;
    Ok(segment)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Okada (1985) Table 2 uses lambda = mu: alpha = 2/3.
    const ALPHA: f64 = 2.0 / 3.0;

    fn rect(depth: f64, dip_deg: f64, slip: [f64; 3]) -> OkadaRectangle {
        OkadaRectangle {
            length: 3.0,
            width: 2.0,
            depth,
            dip_deg,
            strike_slip: slip[0],
            dip_slip: slip[1],
            tensile: slip[2],
        }
    }

    const UNIT_SLIPS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    /// Asserts a value printed to 4 significant digits (half a unit of the last digit), and
    /// exact zeros where the table prints 0.
    fn assert_printed(got: f64, printed: f64, what: &str) {
        if printed == 0.0 {
            assert!(got.abs() <= 1e-15, "{what}: got {got:e}, table prints 0");
        } else {
            let last_digit = 10f64.powf(printed.abs().log10().floor() - 3.0);
            assert!(
                (got - printed).abs() <= 0.5 * last_digit * (1.0 + 1e-9),
                "{what}: got {got:.6e}, table prints {printed:.3e}"
            );
        }
    }

    fn check_table_case(case: &str, x: f64, y: f64, depth: f64, dip: f64, table: [[f64; 3]; 3]) {
        for (slip, printed) in UNIT_SLIPS.iter().zip(table) {
            let u = rect(depth, dip, *slip)
                .surface_displacement(ALPHA, x, y)
                .unwrap();
            for k in 0..3 {
                assert_printed(
                    u[k],
                    printed[k],
                    &format!("{case} slip {slip:?} component {k}"),
                );
            }
        }
    }

    /// Okada (1985) Table 2, case 2; /work/shared/reference/validation.md.
    #[test]
    fn okada85_table2_case2() {
        check_table_case(
            "case 2",
            2.0,
            3.0,
            4.0,
            70.0,
            [
                [-8.689e-3, -4.298e-3, -2.747e-3],
                [-4.682e-3, -3.527e-2, -3.564e-2],
                [-2.660e-4, 1.056e-2, 3.214e-3],
            ],
        );
    }

    /// Okada (1985) Table 2, case 3: the point lies on the extension of the fault's end edge.
    #[test]
    fn okada85_table2_case3() {
        check_table_case(
            "case 3",
            0.0,
            0.0,
            4.0,
            90.0,
            [
                [0.0, 5.253e-3, 0.0],
                [0.0, 0.0, 0.0],
                [1.223e-2, 0.0, -1.606e-2],
            ],
        );
    }

    /// Okada (1985) Table 2, case 4: the vertical fault of case 3 dipping the other way, dip
    /// -90, with R + eta = 0 at two corners. validation.md gives d = 6, the depth of the fault's
    /// bottom edge; with a negative dip Okada's origin corner (eta = 0) is the fault's top, and
    /// eta grows downwards, so `depth` is 6 - W = 4 (the fault spans depths 4 to 6). The same
    /// numbers come from the fault of dip +90 with its origin at depth 6 and the strike- and
    /// dip-slip reversed, which is the plane seen from its other side.
    #[test]
    fn okada85_table2_case4() {
        let table = [
            [0.0, -1.303e-3, 0.0],
            [0.0, 0.0, 0.0],
            [3.507e-3, 0.0, -7.740e-3],
        ];
        check_table_case("case 4", 0.0, 0.0, 4.0, -90.0, table);
        for (slip, printed) in UNIT_SLIPS.iter().zip(table) {
            let other_side = rect(6.0, 90.0, [-slip[0], -slip[1], slip[2]]);
            let u = other_side.surface_displacement(ALPHA, 0.0, 0.0).unwrap();
            for k in 0..3 {
                assert_printed(
                    u[k],
                    printed[k],
                    &format!("case 4 seen from dip +90, {slip:?} {k}"),
                );
            }
        }
    }

    /// Higher-precision values of Table 2 case 2 (validation.md), quoted digit for digit.
    #[test]
    #[allow(clippy::excessive_precision)]
    fn okada85_case2_high_precision() {
        let expected = [
            [
                -8.6891650042561549e-3,
                -4.2975821897415613e-3,
                -2.7474058276388967e-3,
            ],
            [
                -4.6823487628354045e-3,
                -3.5267267968718020e-2,
                -3.5638557673268470e-2,
            ],
            [
                -2.6599600964428191e-4,
                1.0564074876983659e-2,
                3.2141931142207676e-3,
            ],
        ];
        for (slip, want) in UNIT_SLIPS.iter().zip(expected) {
            let got = rect(4.0, 70.0, *slip)
                .surface_displacement(ALPHA, 2.0, 3.0)
                .unwrap();
            for k in 0..3 {
                let relative = ((got[k] - want[k]) / want[k]).abs();
                assert!(
                    relative <= 1e-9,
                    "slip {slip:?} component {k}: {got:?} vs {want:?}"
                );
            }
        }
    }

    /// Observation points spread around and above the fault for the comparisons below.
    fn sample_points() -> Vec<(f64, f64)> {
        let mut points = Vec::new();
        for &x in &[-7.5, -2.0, 0.0, 0.7, 1.5, 3.0, 4.2, 11.0] {
            for &y in &[-9.0, -3.3, -1.0, 0.0, 0.4, 1.2, 2.9, 6.0] {
                points.push((x, y));
            }
        }
        points
    }

    /// Okada (1992) at z = 0 must reproduce Okada (1985) (the 1992 paper's own consistency
    /// requirement), for every slip type, positive, negative and vertical dips.
    #[test]
    fn okada92_at_surface_equals_okada85() {
        let mut compared = 0;
        for &(depth, dip) in &[
            (4.0, 70.0),
            (4.0, 90.0),
            (6.0, -90.0),
            (3.0, 30.0),
            (2.5, 0.0),
            (5.0, -40.0),
            (4.0, 89.9),
        ] {
            for alpha in [ALPHA, 0.55, 0.9] {
                for slip in UNIT_SLIPS {
                    let source = rect(depth, dip, slip);
                    for (x, y) in sample_points() {
                        let surface = source.surface_displacement(alpha, x, y).unwrap();
                        let internal = source.displacement(alpha, x, y, 0.0).unwrap();
                        // Near vertical both forms lose digits to their 1/cos^2(dip) terms,
                        // and differently.
                        let tolerance = if dip == 89.9 { 1e-7 } else { 1e-11 };
                        let scale = surface.iter().fold(1e-3_f64, |m, v| m.max(v.abs()));
                        for k in 0..3 {
                            assert!(
                                (surface[k] - internal[k]).abs() <= tolerance * scale,
                                "dip {dip} alpha {alpha} slip {slip:?} at ({x}, {y}): {surface:?} vs {internal:?}"
                            );
                        }
                        compared += 1;
                    }
                }
            }
        }
        assert_eq!(compared, 7 * 3 * 3 * 64);
    }

    /// Second differences of the 1992 field at depth, for the equilibrium test below.
    #[allow(clippy::needless_range_loop)] // tensor indices read best as indices
    fn navier_residual(source: &OkadaRectangle, alpha: f64, point: [f64; 3], h: f64) -> (f64, f64) {
        let u = |offset: [f64; 3]| {
            source
                .displacement(
                    alpha,
                    point[0] + offset[0],
                    point[1] + offset[1],
                    point[2] + offset[2],
                )
                .unwrap()
        };
        let step = |axis: usize, amount: f64| {
            let mut offset = [0.0; 3];
            offset[axis] = amount;
            offset
        };
        let centre = u([0.0; 3]);
        // second[i][j][k]: d^2 u_k / dx_i dx_j
        let mut second = [[[0.0; 3]; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let value = if i == j {
                    let (plus, minus) = (u(step(i, h)), u(step(i, -h)));
                    [0, 1, 2].map(|k| (plus[k] - 2.0 * centre[k] + minus[k]) / (h * h))
                } else {
                    let corner = |si: f64, sj: f64| {
                        let mut offset = step(i, si * h);
                        offset[j] = sj * h;
                        u(offset)
                    };
                    let (pp, pm, mp, mm) = (
                        corner(1.0, 1.0),
                        corner(1.0, -1.0),
                        corner(-1.0, 1.0),
                        corner(-1.0, -1.0),
                    );
                    [0, 1, 2].map(|k| (pp[k] - pm[k] - mp[k] + mm[k]) / (4.0 * h * h))
                };
                second[i][j] = value;
            }
        }
        let mu_ratio = (1.0 - alpha) / alpha;
        let (mut worst, mut size) = (0.0_f64, 0.0_f64);
        for k in 0..3 {
            let laplacian: f64 = (0..3).map(|i| second[i][i][k]).sum();
            let grad_div: f64 = (0..3).map(|j| second[k][j][j]).sum();
            // mu lap u + (lambda + mu) grad div u = 0, divided by (lambda + mu).
            worst = worst.max((mu_ratio * laplacian + grad_div).abs());
            size = size.max((mu_ratio * laplacian).abs()).max(grad_div.abs());
        }
        (worst, size)
    }

    /// The 1992 field satisfies Navier's equilibrium equation inside the half-space (a check of
    /// every term, including the depth terms u^C that vanish at z = 0).
    #[test]
    fn okada92_satisfies_navier_equation() {
        let points = [
            [1.0, -2.0, -1.5],
            [4.0, 2.5, -3.0],
            [-1.5, 0.5, -6.0],
            [1.5, 3.0, -0.5],
        ];
        for (depth, dip) in [
            (4.0, 70.0),
            (3.0, 30.0),
            (4.0, 90.0),
            (5.0, -40.0),
            (2.5, 0.0),
        ] {
            for alpha in [ALPHA, 0.55] {
                for slip in UNIT_SLIPS {
                    let source = rect(depth, dip, slip);
                    for point in points {
                        let (residual, size) = navier_residual(&source, alpha, point, 2.5e-3);
                        assert!(
                            residual <= 1e-4 * size,
                            "dip {dip} slip {slip:?} at {point:?}: residual {residual:e}, terms {size:e}"
                        );
                    }
                }
            }
        }
    }

    /// The free surface carries no traction: sigma_xz = sigma_yz = sigma_zz = 0 at z = 0,
    /// with z-derivatives from a fourth-order one-sided difference.
    #[test]
    fn okada92_free_surface_is_traction_free() {
        let h = 2.5e-3;
        for (depth, dip) in [(4.0, 70.0), (3.0, 30.0), (4.0, 90.0), (5.0, -40.0)] {
            let alpha = ALPHA;
            let lambda_over_mu = {
                let poisson = 1.0 - 0.5 / alpha;
                2.0 * poisson / (1.0 - 2.0 * poisson)
            };
            for slip in UNIT_SLIPS {
                let source = rect(depth, dip, slip);
                for (x, y) in [(1.0, -2.0), (4.0, 2.5), (-1.5, 0.5), (2.0, 3.0)] {
                    let u = |dx: f64, dy: f64, z: f64| {
                        source.displacement(alpha, x + dx, y + dy, z).unwrap()
                    };
                    let d_dz: [f64; 3] = {
                        let f = [0.0, 1.0, 2.0, 3.0, 4.0].map(|n| u(0.0, 0.0, -n * h));
                        [0, 1, 2].map(|k| {
                            (25.0 * f[0][k] - 48.0 * f[1][k] + 36.0 * f[2][k] - 16.0 * f[3][k]
                                + 3.0 * f[4][k])
                                / (12.0 * h)
                        })
                    };
                    let central = |dx: f64, dy: f64| {
                        let (plus, minus) = (u(dx * h, dy * h, 0.0), u(-dx * h, -dy * h, 0.0));
                        [0, 1, 2].map(|k| (plus[k] - minus[k]) / (2.0 * h))
                    };
                    let (d_dx, d_dy) = (central(1.0, 0.0), central(0.0, 1.0));
                    let divergence = d_dx[0] + d_dy[1] + d_dz[2];
                    let tractions = [
                        d_dz[0] + d_dx[2],
                        d_dz[1] + d_dy[2],
                        lambda_over_mu * divergence + 2.0 * d_dz[2],
                    ];
                    let size = d_dx
                        .iter()
                        .chain(&d_dy)
                        .chain(&d_dz)
                        .fold(0.0_f64, |m, v| m.max(v.abs()));
                    for traction in tractions {
                        assert!(
                            traction.abs() <= 1e-5 * size,
                            "dip {dip} slip {slip:?} at ({x}, {y}): tractions {tractions:?}, gradient {size:e}"
                        );
                    }
                }
            }
        }
    }

    /// Across the fault the displacement jumps by the slip vector: hanging wall (the side the
    /// normal (0, -sin, cos) points to) minus foot wall = U1 strike + U2 up-dip + U3 normal.
    #[test]
    fn okada92_jump_across_fault_is_the_slip() {
        let slip = [0.7, -1.3, 0.4];
        for (depth, dip) in [(4.0, 70.0), (3.0, 30.0), (4.0, 90.0), (5.0, -40.0)] {
            let source = rect(depth, dip, slip);
            let (sin, cos) = dip_sin_cos(dip);
            let up_dip = [0.0, cos, sin];
            let normal = [0.0, -sin, cos];
            let expected = [0, 1, 2].map(|k| {
                slip[1] * up_dip[k] + slip[2] * normal[k] + if k == 0 { slip[0] } else { 0.0 }
            });
            for (along, up) in [(1.5, 1.0), (0.4, 0.3), (2.7, 1.8)] {
                let on_fault = [along, up * cos, -(depth - up * sin)];
                let side = |sign: f64| {
                    let e = sign * 1e-7;
                    source
                        .displacement(
                            ALPHA,
                            on_fault[0],
                            on_fault[1] + e * normal[1],
                            on_fault[2] + e * normal[2],
                        )
                        .unwrap()
                };
                let (hanging, foot) = (side(1.0), side(-1.0));
                for k in 0..3 {
                    assert!(
                        (hanging[k] - foot[k] - expected[k]).abs() <= 1e-6,
                        "dip {dip} at ({along}, {up}): jump {:?}, slip vector {expected:?}",
                        [0, 1, 2].map(|i| hanging[i] - foot[i])
                    );
                }
            }
        }
    }

    /// On the extension of an edge line (R + xi = 0 or R + eta = 0 for the real source) the
    /// limit rules must give the limit of the neighbouring values; an edge itself is an error.
    #[test]
    fn okada92_is_continuous_across_singular_lines() {
        for (depth, dip) in [(4.0, 70.0), (4.0, 90.0), (5.0, -40.0), (3.0, 30.0)] {
            let source = rect(depth, dip, [0.6, 0.8, 0.5]);
            let (sin, cos) = dip_sin_cos(dip);
            // Below the corner along the end edge (eta < 0), and beyond the bottom edge along
            // strike (xi < 0).
            let lines = [
                [0.0, -1.5 * cos, -(depth + 1.5 * sin)],
                [-1.2, 0.0, -depth],
                [4.5, 0.0, -depth],
            ];
            for point in lines {
                let on_line = source
                    .displacement(ALPHA, point[0], point[1], point[2])
                    .unwrap();
                let nearby = source
                    .displacement(ALPHA, point[0] + 1e-5, point[1] + 1e-5, point[2] - 1e-5)
                    .unwrap();
                for k in 0..3 {
                    assert!(
                        (on_line[k] - nearby[k]).abs()
                            <= 1e-4 * on_line.iter().fold(1e-3, |m: f64, v| m.max(v.abs())),
                        "dip {dip} at {point:?}: {on_line:?} vs {nearby:?}"
                    );
                }
            }
            let corner = source.displacement(ALPHA, 0.0, 0.0, -depth);
            assert!(matches!(corner, Err(Error::Invalid { .. })));
            let on_bottom_edge = source.displacement(ALPHA, 1.0, 0.0, -depth);
            assert!(on_bottom_edge.is_err());
        }
    }

    #[test]
    fn okada_frame_rejects_bad_input() {
        let good = rect(4.0, 70.0, [1.0, 0.0, 0.0]);
        assert!(good.surface_displacement(0.2, 1.0, 1.0).is_err());
        assert!(good.displacement(ALPHA, 1.0, 1.0, 0.5).is_err());
        assert!(good.surface_displacement(ALPHA, f64::NAN, 1.0).is_err());
        let breaking = rect(1.0, 70.0, [1.0, 0.0, 0.0]);
        let error = breaking.surface_displacement(ALPHA, 1.0, 1.0).unwrap_err();
        assert!(error.to_string().starts_with("depth:"), "{error}");
        assert!(rect(4.0, 91.0, [1.0, 0.0, 0.0])
            .surface_displacement(ALPHA, 1.0, 1.0)
            .is_err());
    }

    // ---- project coordinates ----

    fn vertical_strike_slip() -> FaultSegment {
        FaultSegment {
            strike_deg: 0.0,
            dip_deg: 90.0,
            rake_deg: 0.0,
            slip_m: 1.0,
            length_m: 20e3,
            width_m: 10e3,
            depth_m: 10e3,
            depth_ref: DepthRef::Centroid,
            opening_m: 0.0,
            x_m: 0.0,
            y_m: 0.0,
        }
    }

    fn at(segments: &[FaultSegment], x: f64, y: f64, z: f64) -> [f64; 3] {
        displacement_at(segments, &Elastic::default(), x, y, z).unwrap()
    }

    /// A vertical left-lateral fault along north: mirroring across the fault plane reverses
    /// the slip, so u_north and u_up are odd and u_east even in x; mirroring across the plane
    /// through its centre perpendicular to strike does the same with y and the roles swapped.
    #[test]
    fn vertical_strike_slip_symmetries() {
        let fault = [vertical_strike_slip()];
        for z in [0.0, -3e3] {
            for (x, y) in [(1e3, 2e3), (7e3, -15e3), (25e3, 4e3), (3e3, 30e3)] {
                let u = at(&fault, x, y, z);
                let mirror_x = at(&fault, -x, y, z);
                let mirror_y = at(&fault, x, -y, z);
                let tolerance = 1e-12 * u.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                assert!(
                    (u[1] + mirror_x[1]).abs() <= tolerance,
                    "u_north odd in x: {u:?} {mirror_x:?}"
                );
                assert!((u[0] - mirror_x[0]).abs() <= tolerance, "u_east even in x");
                assert!((u[2] + mirror_x[2]).abs() <= tolerance, "u_up odd in x");
                assert!((u[1] - mirror_y[1]).abs() <= tolerance, "u_north even in y");
                assert!((u[0] + mirror_y[0]).abs() <= tolerance, "u_east odd in y");
                assert!((u[2] + mirror_y[2]).abs() <= tolerance, "u_up odd in y");
            }
        }
        // Left-lateral: seen from the west side, the east side moves north (to the left).
        let east_side = at(&fault, 1e3, 0.0, 0.0);
        assert!(east_side[1] > 0.0, "{east_side:?}");
    }

    /// Turning the fault and the observation point together by the same angle turns the
    /// displacement with them.
    #[test]
    fn rotation_moves_the_field_with_the_fault() {
        let base = FaultSegment {
            strike_deg: 30.0,
            dip_deg: 50.0,
            rake_deg: 40.0,
            opening_m: 0.3,
            ..vertical_strike_slip()
        };
        let clockwise = |angle: f64, v: [f64; 2]| {
            let (sin, cos) = angle.to_radians().sin_cos();
            [v[0] * cos + v[1] * sin, -v[0] * sin + v[1] * cos]
        };
        for angle in [90.0, 37.0, -120.0] {
            let turned = FaultSegment {
                strike_deg: base.strike_deg + angle,
                ..base
            };
            for (point, z) in [([7e3, -3e3], 0.0), ([-12e3, 5e3], 0.0), ([2e3, 9e3], -4e3)] {
                let u = at(&[base], point[0], point[1], z);
                let p = clockwise(angle, point);
                let v = at(&[turned], p[0], p[1], z);
                let expected = clockwise(angle, [u[0], u[1]]);
                let tolerance = 1e-12 * u.iter().fold(0.0_f64, |m, w| m.max(w.abs()));
                assert!(
                    (v[0] - expected[0]).abs() <= tolerance,
                    "angle {angle}: {v:?} vs {expected:?}"
                );
                assert!(
                    (v[1] - expected[1]).abs() <= tolerance,
                    "angle {angle}: {v:?} vs {expected:?}"
                );
                assert!(
                    (v[2] - u[2]).abs() <= tolerance,
                    "angle {angle}: {v:?} vs {u:?}"
                );
            }
        }
    }

    /// Top, centroid and bottom references describe the same fault when the depths differ by
    /// half and whole the fault's vertical extent; a shift of (x_m, y_m) shifts the field.
    #[test]
    fn depth_reference_and_position_are_consistent() {
        let centroid = FaultSegment {
            strike_deg: 75.0,
            dip_deg: 35.0,
            rake_deg: 120.0,
            depth_m: 12e3,
            ..vertical_strike_slip()
        };
        let half_height = 0.5 * centroid.width_m * 35f64.to_radians().sin();
        let top = FaultSegment {
            depth_ref: DepthRef::Top,
            depth_m: 12e3 - half_height,
            ..centroid
        };
        let bottom = FaultSegment {
            depth_ref: DepthRef::Bottom,
            depth_m: 12e3 + half_height,
            ..centroid
        };
        assert!((top.top_depth_m() - (12e3 - half_height)).abs() < 1e-9);
        assert!((bottom.bottom_depth_m() - (12e3 + half_height)).abs() < 1e-9);
        let shifted = FaultSegment {
            x_m: 4e3,
            y_m: -6e3,
            ..centroid
        };
        for (x, y, z) in [(3e3, 4e3, 0.0), (-8e3, 1e3, 0.0), (5e3, -2e3, -2e3)] {
            let reference = at(&[centroid], x, y, z);
            let tolerance = 1e-12 * reference.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            for other in [top, bottom] {
                let u = at(&[other], x, y, z);
                for k in 0..3 {
                    assert!(
                        (u[k] - reference[k]).abs() <= tolerance,
                        "{:?}: {u:?} vs {reference:?}",
                        other.depth_ref
                    );
                }
            }
            let moved = at(&[shifted], x + 4e3, y - 6e3, z);
            for k in 0..3 {
                assert!((moved[k] - reference[k]).abs() <= tolerance);
            }
        }
        // A deeper reference point with the same number puts the fault deeper.
        let same_number_top = FaultSegment {
            depth_ref: DepthRef::Top,
            ..centroid
        };
        assert!(same_number_top.centroid_depth_m() > centroid.centroid_depth_m());
    }

    /// Two halves laid end to end displace the ground like the whole fault (linearity of the
    /// solution and the Chinnery sum).
    #[test]
    fn segments_superpose() {
        let whole = FaultSegment {
            strike_deg: 30.0,
            dip_deg: 60.0,
            rake_deg: -70.0,
            length_m: 40e3,
            ..vertical_strike_slip()
        };
        let (sin, cos) = 30f64.to_radians().sin_cos();
        let half = |sign: f64| FaultSegment {
            length_m: 20e3,
            x_m: sign * 10e3 * sin,
            y_m: sign * 10e3 * cos,
            ..whole
        };
        let halves = [half(-1.0), half(1.0)];
        for (x, y, z) in [(5e3, 5e3, 0.0), (-30e3, 12e3, 0.0), (8e3, -3e3, -5e3)] {
            let one = at(&[whole], x, y, z);
            let two = at(&halves, x, y, z);
            let tolerance = 1e-10 * one.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            for k in 0..3 {
                assert!((one[k] - two[k]).abs() <= tolerance, "{one:?} vs {two:?}");
            }
        }
    }

    /// A negative dip is the same plane as strike + 180, |dip|, rake + 180.
    #[test]
    fn negative_dip_is_the_reversed_plane() {
        let negative = FaultSegment {
            strike_deg: 20.0,
            dip_deg: -35.0,
            rake_deg: 50.0,
            opening_m: 0.2,
            ..vertical_strike_slip()
        };
        let positive = FaultSegment {
            strike_deg: 200.0,
            dip_deg: 35.0,
            rake_deg: 230.0,
            ..negative
        };
        for (x, y, z) in [(5e3, 5e3, 0.0), (-9e3, 2e3, 0.0), (3e3, -4e3, -6e3)] {
            let a = at(&[negative], x, y, z);
            let b = at(&[positive], x, y, z);
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() <= 1e-12 * b[k].abs().max(1e-3));
            }
        }
    }

    /// A shallow thrust lifts the ground above its hanging wall; the paper's case II, a normal
    /// fault, lets the ground subside above it and stretches it east-west.
    #[test]
    fn thrust_uplifts_and_normal_fault_subsides() {
        let thrust = FaultSegment {
            rake_deg: 90.0,
            dip_deg: 30.0,
            depth_m: 1e3,
            depth_ref: DepthRef::Top,
            ..vertical_strike_slip()
        };
        assert!(at(&[thrust], 0.0, 0.0, 0.0)[2] > 0.0);

        let n = 101;
        let field = surface_field(
            &[FaultSegment::paper_case_ii()],
            &Elastic::default(),
            1000e3,
            n,
        )
        .unwrap();
        let extreme = |values: &[f64], lower: bool| {
            let mut best = 0;
            for (index, &value) in values.iter().enumerate() {
                if (lower && value < values[best]) || (!lower && value > values[best]) {
                    best = index;
                }
            }
            (values[best], field.x[best % n], field.y[best / n])
        };
        let (lowest, lowest_x, lowest_y) = extreme(&field.uz, true);
        let (highest, highest_x, _) = extreme(&field.uz, false);
        // The fault strikes north and dips east: its up-dip edge lies 24.9 km west of the
        // centroid, its down-dip edge 24.9 km east. The hanging wall slides 10 m down-dip,
        // mostly eastwards: it pulls away from the up-dip edge (subsidence there) and pushes
        // into the rock beyond the down-dip edge (uplift there).
        assert!(lowest < -0.5 && lowest > -10.0, "uz minimum {lowest}");
        assert!(
            (-60e3..0.0).contains(&lowest_x) && lowest_y == 0.0,
            "minimum at ({lowest_x}, {lowest_y})"
        );
        assert!(
            highest > 0.0 && highest_x > 0.0,
            "uz maximum {highest} at x {highest_x}"
        );
        let (east_most, _, _) = extreme(&field.ux, false);
        assert!(
            east_most > 0.5 && east_most < 10.0,
            "ux maximum {east_most}"
        );
        // Pure dip slip on a fault centred on y = 0 along north: mirror symmetry in y.
        for j in 0..n {
            for i in 0..n {
                let (here, mirror) = (j * n + i, (n - 1 - j) * n + i);
                let scale = 1e-12 * lowest.abs();
                assert!((field.uz[here] - field.uz[mirror]).abs() <= scale);
                assert!((field.ux[here] - field.ux[mirror]).abs() <= scale);
                assert!((field.uy[here] + field.uy[mirror]).abs() <= scale);
            }
        }
    }

    #[test]
    fn surface_field_matches_pointwise_values() {
        let segments = [
            FaultSegment::paper_case_ii(),
            FaultSegment {
                x_m: 80e3,
                strike_deg: 45.0,
                rake_deg: 30.0,
                ..FaultSegment::paper_case_ii()
            },
        ];
        let field = surface_field(&segments, &Elastic::default(), 400e3, 9).unwrap();
        assert_eq!((field.nx(), field.ny(), field.uz.len()), (9, 9, 81));
        assert_eq!((field.x[0], field.x[8], field.y[4]), (-200e3, 200e3, 0.0));
        for (j, &y) in field.y.iter().enumerate() {
            for (i, &x) in field.x.iter().enumerate() {
                let u = at(&segments, x, y, 0.0);
                let index = j * 9 + i;
                assert_eq!([field.ux[index], field.uy[index], field.uz[index]], u);
            }
        }
        assert!(surface_field(&segments, &Elastic::default(), 0.0, 9).is_err());
        assert!(surface_field(&segments, &Elastic::default(), 1e3, 1).is_err());
    }

    #[test]
    fn elastic_constants() {
        assert_eq!(Elastic::default().alpha(), 2.0 / 3.0);
        let lame = Elastic::from_lame(30e9, 30e9).unwrap();
        assert!((lame.poisson() - 0.25).abs() < 1e-15);
        let soft = Elastic::from_lame(60e9, 30e9).unwrap();
        assert!((soft.poisson() - 1.0 / 3.0).abs() < 1e-15);
        assert!((soft.alpha() - 0.75).abs() < 1e-15);
        assert!(Elastic::from_poisson(0.6).is_err());
        assert!(Elastic::from_lame(1.0, 0.0).is_err());
        assert!(Elastic::from_lame(-1.0, 1.0).is_err());
    }

    #[test]
    fn validate_names_field_and_range() {
        let message = |segment: FaultSegment| segment.validate().unwrap_err().to_string();
        let good = FaultSegment::paper_case_ii();
        assert!(good.validate().is_ok());
        assert!((good.top_depth_m() - (50e3 - 25e3 * 6f64.to_radians().sin())).abs() < 1e-9);
        let steep = message(FaultSegment {
            dip_deg: 95.0,
            ..good
        });
        assert!(
            steep.starts_with("dip_deg:") && steep.contains("[-90, 90]"),
            "{steep}"
        );
        let flat = message(FaultSegment {
            width_m: 0.0,
            ..good
        });
        assert!(
            flat.starts_with("width_m:") && flat.contains("> 0"),
            "{flat}"
        );
        let short = message(FaultSegment {
            length_m: -1.0,
            ..good
        });
        assert!(short.starts_with("length_m:"), "{short}");
        let missing = message(FaultSegment {
            slip_m: f64::NAN,
            ..good
        });
        assert!(
            missing.starts_with("slip_m:") && missing.contains("finite"),
            "{missing}"
        );
        let breaking = message(FaultSegment {
            depth_m: 2e3,
            ..good
        });
        assert!(
            breaking.starts_with("depth_m:") && breaking.contains("2613"),
            "{breaking}"
        );
        let at_surface = FaultSegment {
            depth_m: 0.0,
            depth_ref: DepthRef::Top,
            ..good
        };
        assert!(message(at_surface).starts_with("depth_m:"));
        let error =
            displacement_at(&[good, at_surface], &Elastic::default(), 0.0, 0.0, 0.0).unwrap_err();
        assert!(
            error.to_string().starts_with("segment 1 depth_m:"),
            "{error}"
        );
    }

    #[test]
    fn parses_segment_tables() {
        let path = Path::new("faults.txt");
        let text = "# two segments of a normal fault\n\
                    \n\
                    slip_m strike_deg dip_deg rake_deg length_m width_m depth_m x_m y_m opening_m depth_ref\n\
                    10 0 6 -90 100e3 50e3 50e3 0 0 0 centroid   # case II\n\
                    2.5 45 60 180 20e3 10e3 1e3 -5e3 7e3 0.1 TOP\n";
        let segments = parse_segment_table(text, path).unwrap();
        assert_eq!(segments.len(), 2);
        assert_eq!(segments[0], FaultSegment::paper_case_ii());
        let second = segments[1];
        assert_eq!(
            (
                second.slip_m,
                second.strike_deg,
                second.dip_deg,
                second.rake_deg,
                second.x_m,
                second.y_m
            ),
            (2.5, 45.0, 60.0, 180.0, -5e3, 7e3)
        );
        assert_eq!((second.opening_m, second.depth_ref), (0.1, DepthRef::Top));

        let minimal = "x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m\n0 0 5e3 10 80 0 4e3 2e3 1\n";
        let parsed = parse_segment_table(minimal, path).unwrap();
        assert_eq!(
            (parsed[0].opening_m, parsed[0].depth_ref),
            (0.0, DepthRef::Centroid)
        );
    }

    #[test]
    fn segment_table_errors_name_path_line_and_column() {
        let path = Path::new("dir/faults.txt");
        let header = "x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m\n";
        let error = |text: &str| parse_segment_table(text, path).unwrap_err().to_string();

        let bad_number = error(&format!(
            "{header}# comment\n0 0 5e3 10 eighty 0 4e3 2e3 1\n"
        ));
        assert_eq!(
            bad_number,
            "dir/faults.txt: line 3, column 5 (dip_deg): expected a number, found 'eighty'"
        );
        let out_of_range = error(&format!("{header}0 0 5e3 10 95 0 4e3 2e3 1\n"));
        assert!(
            out_of_range
                .starts_with("dir/faults.txt: line 2, column 5 (dip_deg): must lie in [-90, 90]"),
            "{out_of_range}"
        );
        let too_shallow = error(&format!("{header}0 0 5e2 10 80 0 4e3 2e3 1\n"));
        assert!(
            too_shallow.starts_with("dir/faults.txt: line 2, column 3 (depth_m):"),
            "{too_shallow}"
        );
        let short_row = error(&format!("{header}0 0 5e3 10 80\n"));
        assert!(
            short_row.contains("line 2: expected 9 values"),
            "{short_row}"
        );
        let unknown = error("x_m y_m depth_km\n");
        assert!(
            unknown.contains("line 1, column 3: unknown column 'depth_km'"),
            "{unknown}"
        );
        let missing = error("x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m\n");
        assert!(
            missing.contains("lacks the required column 'slip_m'"),
            "{missing}"
        );
        let twice = error("x_m x_m\n");
        assert!(
            twice.contains("column 2: column 'x_m' appears twice"),
            "{twice}"
        );
        assert!(error("# nothing\n").contains("no header line"));
        assert!(error(header).contains("no fault segments"));
        let bad_ref = error("x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m depth_ref\n0 0 5e3 10 80 0 4e3 2e3 1 middle\n");
        assert!(
            bad_ref.contains("line 2, column 10 (depth_ref): expected top, centroid or bottom"),
            "{bad_ref}"
        );
    }
}
