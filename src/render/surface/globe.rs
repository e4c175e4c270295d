//! How a geographic grid lies on the globe's unit sphere ([`GlobeFrame`]): node coordinates of
//! a point, the ray's hit on the sphere and the headlight shading there.

use super::LIGHT_AMBIENT;
use crate::error::{Error, Result};
use crate::model::geometry::sphere_hit;
use crate::model::map_frame::MapAxis;
use crate::model::Grid;

/// How a geographic grid lies on the globe's unit sphere: its first node and spacing in degrees,
/// its node counts, and whether its longitudes close the circle (nx spacings make 360°), in
/// which case interpolation runs on from the last node to the first. Each node covers the cell
/// half a spacing either side, as in the map; elsewhere the sphere shows no data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GlobeFrame {
    pub lon0: f64,
    pub dlon: f64,
    pub lat0: f64,
    pub dlat: f64,
    pub nx: usize,
    pub ny: usize,
    pub wrap: bool,
    /// The grid's rotated pole: its longitudes and latitudes are on the rotated sphere.
    pub rotation: Option<crate::model::RotatedPole>,
}

impl GlobeFrame {
    /// The frame of a geographic grid with evenly spaced coordinates; anything else is an error
    /// saying what the globe needs.
    pub fn of(grid: &Grid) -> Result<GlobeFrame> {
        Self::check_geographic(grid)?;
        if MapAxis::of_coords(grid.x()).is_none() || MapAxis::of_coords(grid.y()).is_none() {
            return Err(Error::invalid(
                "view",
                format!(
                    "the globe needs evenly spaced longitudes and latitudes; grid {:?} has uneven ones",
                    grid.name()
                ),
            ));
        }
        let (nx, ny) = (grid.nx(), grid.ny());
        // A single node stands for a 1° cell.
        let step =
            |c: &crate::model::GridCoords| if c.values.len() > 1 { c.spacing() } else { 1.0 };
        let dlon = step(grid.x());
        Ok(GlobeFrame {
            lon0: grid.x().values[0],
            dlon,
            lat0: grid.y().values[0],
            dlat: step(grid.y()),
            nx,
            ny,
            wrap: (nx as f64 * dlon - 360.0).abs() <= 1e-3 * dlon,
            rotation: grid.rotated_pole().copied(),
        })
    }

    /// That `grid` has longitude along x and latitude along y, or an error saying what the globe
    /// needs.
    pub(crate) fn check_geographic(grid: &Grid) -> Result<()> {
        if !grid.is_geographic() {
            return Err(Error::invalid(
                "view",
                format!(
                    "the globe needs longitude along x and latitude along y (CF units degrees_east and degrees_north); grid {:?} has {:?} ({}) and {:?} ({})",
                    grid.name(),
                    grid.x().name,
                    grid.x().units,
                    grid.y().name,
                    grid.y().units
                ),
            ));
        }
        Ok(())
    }

    /// True (latitude, longitude) of the middle of the grid's extent.
    pub fn centre(&self) -> (f64, f64) {
        let (lat, lon) = (
            self.lat0 + 0.5 * (self.ny - 1) as f64 * self.dlat,
            self.lon0 + 0.5 * (self.nx - 1) as f64 * self.dlon,
        );
        match &self.rotation {
            Some(r) => r.to_true(lat, lon),
            None => (lat, lon),
        }
    }

    /// The rows of the rotation from true to the grid's longitude–latitude frame (the identity
    /// for a grid on true coordinates), for the shader.
    pub(crate) fn rotation_rows(&self) -> [[f64; 3]; 3] {
        self.rotation
            .map_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], |r| {
                r.matrix()
            })
    }

    /// Fractional node coordinates (u along x, v along y) of a point at true `lat`, `lon`
    /// degrees, or `None` outside the grid's cells. With `wrap`, u lies in [0, nx); otherwise it
    /// is clamped to the nodes.
    pub(crate) fn node_coords(&self, lat: f64, lon: f64) -> Option<(f64, f64)> {
        let (lat, lon) = match &self.rotation {
            Some(r) => r.to_rotated(lat, lon),
            None => (lat, lon),
        };
        let (nx, ny) = (self.nx as f64, self.ny as f64);
        let v = (lat - self.lat0) / self.dlat;
        if !(-0.5..=ny - 0.5).contains(&v) {
            return None;
        }
        let v = v.clamp(0.0, ny - 1.0);
        let rel = (lon - self.lon0) / self.dlon;
        if self.wrap {
            let u = rel.rem_euclid(nx);
            return Some((if u >= nx { 0.0 } else { u }, v));
        }
        let u = (rel + 0.5).rem_euclid(360.0 / self.dlon) - 0.5;
        (u <= nx - 0.5).then(|| (u.clamp(0.0, nx - 1.0), v))
    }

    /// Where the ray o + t·d (d of unit length) first meets the unit sphere in front of the eye:
    /// (t, point), or `None`.
    pub fn hit(o: [f64; 3], d: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let (t, _) = sphere_hit(o, d, 1.0)?;
        (t >= 0.0).then(|| (t, [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]))
    }

    /// Headlight shading at a sphere point whose outward normal is `p` for a ray along `d`:
    /// ambient + (1 − ambient)·max(p·(−d), 0), so the limb darkens whichever side is seen.
    pub fn shade(p: [f64; 3], d: [f64; 3]) -> f64 {
        let facing = -(p[0] * d[0] + p[1] * d[1] + p[2] * d[2]);
        LIGHT_AMBIENT + (1.0 - LIGHT_AMBIENT) * facing.max(0.0)
    }
}
