//! Still-water depth on a regular grid ([`Bathymetry`]) with its checks and CFL limit, depth from
//! elevation grids, and longitude/latitude spacings in metres.

use super::EARTH_RADIUS_M;
use crate::error::{Error, Result};

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
