//! Okada's frame: [`OkadaRectangle`] and the kernel that evaluates Okada (1985) at the free
//! surface and Okada (1992, DC3D) at depth, with the papers' rules for their singular cases.

use std::f64::consts::TAU;

use crate::error::{Error, Result};

/// Below this |cos(dip)| a fault is treated as vertical: the general formulas divide by cos(dip)
/// and cos^2(dip) and lose every digit there, while the vertical ones are off by O(cos(dip)).
/// The same threshold as DC3D.
const VERTICAL_COS: f64 = 1e-6;

/// Coordinates closer than this fraction of the fault size to a singular line (xi = 0, eta = 0,
/// q = 0) are moved onto it, so that the papers' limit rules apply instead of a cancellation of
/// huge terms; the error made is of the same relative order.
const SNAP_RELATIVE: f64 = 1e-9;

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
    pub(super) fn check(&self, alpha: f64) -> Result<()> {
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
pub(super) fn dip_sin_cos(dip_deg: f64) -> (f64, f64) {
    let (sin, cos) = dip_deg.to_radians().sin_cos();
    if cos.abs() < VERTICAL_COS {
        (sin.signum(), 0.0)
    } else {
        (sin, cos)
    }
}

/// sin and cos of an angle in degrees, exact at multiples of 90 so that faults striking along an
/// axis or with pure dip-slip rakes keep their exact symmetries.
pub(super) fn sin_cos_deg(angle_deg: f64) -> (f64, f64) {
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
pub(super) struct Kernel {
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
    pub(super) fn new(rect: &OkadaRectangle, alpha: f64) -> Self {
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
    pub(super) fn surface(&self, x: f64, y: f64) -> [f64; 3] {
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
    pub(super) fn internal(&self, x: f64, y: f64, z: f64) -> Result<[f64; 3]> {
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
