//! Cut-aways of spherical volumes: the region where every given range of latitude, longitude and
//! depth holds is removed from a render (one range: a hemisphere, a band or a shell; two or
//! three: a wedge). Rays are clipped analytically: the cut's boundaries — latitude cones,
//! longitude half-planes and depth spheres — are more crossings of the ray, and a piece between
//! crossings is drawn when its middle lies in the domain and outside the cut, as
//! [`SphericalGrid::ray_intervals`] does for the domain alone.

use super::geometry::{cone_hits, sphere_hit, SphericalGrid};
use crate::error::{Error, Result};

/// The removed region: the points whose latitude, longitude and depth lie in every given range
/// (absent ranges hold everywhere; at least one is given).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cut {
    /// Degrees north, `lo < hi` within ±90.
    pub lat: Option<[f64; 2]>,
    /// Degrees east, from `lo` eastward to `hi` (`lo < hi`, at most a turn apart).
    pub lon: Option<[f64; 2]>,
    /// Depths below the surface (planet radius − radius), in the volume's length unit, `lo < hi`.
    pub depth: Option<[f64; 2]>,
}

impl Cut {
    /// Checks the ranges on their own and against the shell `g`: a cut that removes the whole
    /// volume is refused.
    pub fn check(&self, g: &SphericalGrid) -> Result<()> {
        let bad = |name: &str, r: [f64; 2], expected: &str| {
            Err(Error::invalid(
                format!("cut {name}"),
                format!("[{}, {}]; expected {expected}", r[0], r[1]),
            ))
        };
        let ordered = |r: [f64; 2]| r[0].is_finite() && r[1].is_finite() && r[0] < r[1];
        if self.lat.is_none() && self.lon.is_none() && self.depth.is_none() {
            return Err(Error::invalid(
                "cut",
                "expected at least one of lat, lon, depth",
            ));
        }
        if let Some(r) = self
            .lat
            .filter(|r| !ordered(*r) || r[0] < -90.0 || r[1] > 90.0)
        {
            return bad("lat", r, "[south, north] within ±90 degrees, south < north");
        }
        if let Some(r) = self.lon.filter(|r| !ordered(*r) || r[1] - r[0] > 360.0) {
            return bad(
                "lon",
                r,
                "[west, east] in degrees, west < east, at most 360 apart",
            );
        }
        if let Some(r) = self.depth.filter(|r| !ordered(*r)) {
            return bad("depth", r, "[top, bottom], top < bottom");
        }
        let covers = |range: Option<[f64; 2]>, lo: f64, hi: f64| {
            range.is_none_or(|r| r[0] <= lo && r[1] >= hi)
        };
        let lon_covers = self.lon.is_none_or(|r| {
            r[1] - r[0] >= 360.0
                || (!g.lon_wraps && {
                    let lo = r[0] + (g.longitude.lo - r[0]).rem_euclid(360.0);
                    lo + (g.longitude.hi - g.longitude.lo) <= r[1]
                })
        });
        let (top, bottom) = (g.planet_radius - g.radius.hi, g.planet_radius - g.radius.lo);
        if covers(self.lat, g.latitude.lo, g.latitude.hi)
            && lon_covers
            && covers(self.depth, top, bottom)
        {
            return Err(Error::invalid(
                "cut",
                format!("removes the whole volume ({g}); expected ranges that leave part of it"),
            ));
        }
        Ok(())
    }

    /// The radii of the depth range, `[inner, outer]`.
    pub(crate) fn radii(&self, planet_radius: f64) -> Option<[f64; 2]> {
        self.depth
            .map(|d| [planet_radius - d[1], planet_radius - d[0]])
    }

    /// Whether the world point `p` lies in the removed region.
    pub(crate) fn removes(&self, planet_radius: f64, p: [f64; 3]) -> bool {
        let (r, lat, lon) = SphericalGrid::from_world(p);
        self.lat.is_none_or(|[a, b]| lat >= a && lat <= b)
            && self
                .lon
                .is_none_or(|[a, b]| (lon - a).rem_euclid(360.0) <= b - a)
            && self
                .radii(planet_radius)
                .is_none_or(|[a, b]| r >= a && r <= b)
    }

    /// Where the ray `o + t·d` crosses the cut's boundaries (both nappes of each cone and both
    /// halves of each longitude plane: extra crossings only split a piece).
    pub(crate) fn crossings(&self, planet_radius: f64, o: [f64; 3], d: [f64; 3]) -> Vec<f64> {
        let mut t = Vec::new();
        for lat in self.lat.into_iter().flatten() {
            if lat == 0.0 {
                // The equator's "cone" is the plane z = 0, whose double root rounding can lose.
                t.push(-o[2] / d[2]);
            } else if lat.abs() < 90.0 {
                t.extend(cone_hits(o, d, lat));
            }
        }
        for lon in self.lon.into_iter().flatten() {
            let (s, c) = lon.to_radians().sin_cos();
            let (no, nd) = (-s * o[0] + c * o[1], -s * d[0] + c * d[1]);
            if nd != 0.0 {
                t.push(-no / nd);
            }
        }
        for r in self.radii(planet_radius).into_iter().flatten() {
            if r > 0.0 {
                if let Some((a, b)) = sphere_hit(o, d, r) {
                    t.extend([a, b]);
                }
            }
        }
        t
    }
}
