//! Faults in project coordinates (x east, y north, z up, metres): [`FaultSegment`] with strike,
//! dip, rake and its depth reference, its placement in Okada's frame, and the elastic medium.

use std::fmt;

use super::kernel::{dip_sin_cos, sin_cos_deg, Kernel, OkadaRectangle};
use crate::error::{Error, Result};

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
    pub(super) fn prepare(&self, elastic: &Elastic) -> PreparedSegment {
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
pub(super) struct PreparedSegment {
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

    pub(super) fn surface(&self, x: f64, y: f64) -> [f64; 3] {
        let (xo, yo) = self.to_okada(x, y);
        self.to_project(self.kernel.surface(xo, yo))
    }

    pub(super) fn internal(&self, x: f64, y: f64, z: f64) -> Result<[f64; 3]> {
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
