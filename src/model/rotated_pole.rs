//! CF's `rotated_latitude_longitude` grid mapping: latitudes and longitudes on a sphere turned so
//! that its north pole lies at the true point (`grid_north_pole_latitude`,
//! `grid_north_pole_longitude`), as regional climate models (CORDEX, COSMO) store their grids.
//! The rotated origin (0°, 0°) is the true point 90° from that pole on the pole's meridian
//! continued across the true north pole, and `north_pole_grid_longitude` turns the rotated
//! longitudes about the rotated pole — PROJ's `ob_tran` (`o_lat_p`, `lon_0` = pole longitude +
//! 180°, `o_lon_p`), which the tests check against.

use super::vec3::{cross, dot};
use crate::error::{Error, Result};

/// A rotated pole as CF gives it, and the rows of the rotation from true to rotated Cartesian
/// coordinates on the unit sphere (`north_pole_grid_longitude` folded in about the rotated z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotatedPole {
    pub pole_latitude: f64,
    pub pole_longitude: f64,
    pub north_pole_grid_longitude: f64,
    rows: [[f64; 3]; 3],
}

/// The unit vector at latitude `lat`, longitude `lon` (degrees).
fn unit(lat: f64, lon: f64) -> [f64; 3] {
    let (la, lo) = (lat.to_radians(), lon.to_radians());
    [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
}

/// (latitude, longitude) in degrees of a unit vector, longitude in (−180°, 180°].
fn angles(p: [f64; 3]) -> (f64, f64) {
    let lat = p[2].clamp(-1.0, 1.0).asin().to_degrees();
    let lon = p[1].atan2(p[0]).to_degrees();
    (lat, lon)
}

impl RotatedPole {
    /// The mapping of a CF `rotated_latitude_longitude` variable's attributes; an error naming
    /// the attribute when a number is not finite or the pole latitude is outside [−90°, 90°].
    pub fn new(
        pole_latitude: f64,
        pole_longitude: f64,
        north_pole_grid_longitude: f64,
    ) -> Result<RotatedPole> {
        for (name, v) in [
            ("grid_north_pole_latitude", pole_latitude),
            ("grid_north_pole_longitude", pole_longitude),
            ("north_pole_grid_longitude", north_pole_grid_longitude),
        ] {
            if !v.is_finite() {
                return Err(Error::invalid(name, format!("expected a number, got {v}")));
            }
        }
        if !(-90.0..=90.0).contains(&pole_latitude) {
            return Err(Error::invalid(
                "grid_north_pole_latitude",
                format!("expected degrees in [-90, 90], got {pole_latitude}"),
            ));
        }
        // The rotated pole (z), the rotated origin 90° from it across the true north pole (x),
        // then the rotated longitudes turned by north_pole_grid_longitude about z.
        let z = unit(pole_latitude, pole_longitude);
        let x = unit(90.0 - pole_latitude, pole_longitude + 180.0);
        let y = cross(z, x);
        let (s, c) = north_pole_grid_longitude.to_radians().sin_cos();
        let x_turned = [0, 1, 2].map(|k| c * x[k] - s * y[k]);
        let y_turned = [0, 1, 2].map(|k| s * x[k] + c * y[k]);
        Ok(RotatedPole {
            pole_latitude,
            pole_longitude,
            north_pole_grid_longitude,
            rows: [x_turned, y_turned, z],
        })
    }

    /// The true (latitude, longitude) of the rotated point (`rlat`, `rlon`), degrees.
    pub fn to_true(&self, rlat: f64, rlon: f64) -> (f64, f64) {
        let q = unit(rlat, rlon);
        let r = &self.rows;
        angles([0, 1, 2].map(|a| r[0][a] * q[0] + r[1][a] * q[1] + r[2][a] * q[2]))
    }

    /// The rotated (latitude, longitude) of the true point (`lat`, `lon`), degrees; longitude
    /// in (−180°, 180°].
    pub fn to_rotated(&self, lat: f64, lon: f64) -> (f64, f64) {
        angles(self.rows.map(|row| dot(row, unit(lat, lon))))
    }

    /// The true Cartesian vector `v` in the rotated frame.
    pub(crate) fn turn(&self, v: [f64; 3]) -> [f64; 3] {
        self.rows.map(|row| dot(row, v))
    }

    /// The rotation from true to rotated Cartesian coordinates, rows x, y, z, for shaders.
    pub(crate) fn matrix(&self) -> [[f64; 3]; 3] {
        self.rows
    }

    /// One line for metadata and `info`: the pole's true position.
    pub fn describe(&self) -> String {
        let mut s = format!(
            "rotated pole at {}°N {}°E",
            self.pole_latitude, self.pole_longitude
        );
        if self.north_pole_grid_longitude != 0.0 {
            s += &format!(
                ", north pole grid longitude {}°",
                self.north_pole_grid_longitude
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `lon` brought into (−180°, 180°].
    fn wrap180(lon: f64) -> f64 {
        let w = (lon + 180.0).rem_euclid(360.0) - 180.0;
        if w == -180.0 {
            180.0
        } else {
            w
        }
    }

    /// EURO-CORDEX's pole; true positions from pyproj 3 (PROJ's ob_tran, `CRS.from_cf`).
    #[test]
    fn rotated_points_land_where_proj_puts_them() {
        let pole = RotatedPole::new(39.25, -162.0, 0.0).unwrap();
        for ((rlon, rlat), (lon, lat)) in [
            ((0.0, 0.0), (18.0, 50.75)),
            ((10.0, 0.0), (33.572481934530565, 49.69641688106688)),
            ((0.0, 10.0), (18.0, 60.749999999999986)),
            ((-20.0, -15.0), (-5.09506529426498, 32.625072791683216)),
            ((180.0, 39.25), (-162.0, -11.499999999999996)),
        ] {
            let (la, lo) = pole.to_true(rlat, rlon);
            assert!(
                (la - lat).abs() < 1e-9 && (lo - lon).abs() < 1e-9,
                "{rlon} {rlat}"
            );
            let (rla, rlo) = pole.to_rotated(lat, lon);
            assert!((rla - rlat).abs() < 1e-9, "{rla}");
            assert!((wrap180(rlo - rlon)).abs() < 1e-9, "{rlo}");
        }
        // The true north pole sits on the rotated meridian 0 at the pole's latitude.
        let (rla, rlo) = pole.to_rotated(90.0, 0.0);
        assert!((rla - 39.25).abs() < 1e-9 && rlo.abs() < 1e-9);
        // o_lon_p = 30: the rotated origin moves to rotated longitude 30 (pyproj).
        let turned = RotatedPole::new(39.25, -162.0, 30.0).unwrap();
        let (la, lo) = turned.to_true(0.0, 30.0);
        assert!((la - 50.75).abs() < 1e-9 && (lo - 18.0).abs() < 1e-9);
        let (la, lo) = turned.to_true(0.0, 0.0);
        assert!((la - 42.11676550910764).abs() < 1e-9, "{la}");
        assert!((lo + 24.380780138283747).abs() < 1e-9, "{lo}");
    }

    #[test]
    fn the_matrix_rotates_true_vectors_into_the_grid_frame() {
        let pole = RotatedPole::new(39.25, -162.0, 30.0).unwrap();
        let m = pole.matrix();
        for (lat, lon) in [(50.0, 10.0), (-33.9, 18.4), (89.0, -120.0)] {
            let p = unit(lat, lon);
            let (rlat, rlon) = angles(m.map(|row| dot(row, p)));
            let (want_lat, want_lon) = pole.to_rotated(lat, lon);
            assert!((rlat - want_lat).abs() < 1e-9);
            assert!(wrap180(rlon - want_lon).abs() < 1e-9, "{rlon} {want_lon}");
        }
    }

    #[test]
    fn bad_attributes_name_themselves() {
        let e = RotatedPole::new(95.0, 0.0, 0.0).unwrap_err().to_string();
        assert!(e.starts_with("grid_north_pole_latitude: "), "{e}");
        let e = RotatedPole::new(10.0, f64::NAN, 0.0)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("grid_north_pole_longitude: "), "{e}");
    }
}
