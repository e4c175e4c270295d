//! Where a volume's voxels lie in the world. Most volumes are regular boxes (origin and spacing);
//! a rectilinear volume has its own, possibly non-uniform, coordinate per voxel centre along each
//! axis (stretched ocean levels); a spherical volume is a shell or a wedge of one on (radius,
//! latitude, longitude) axes, in an Earth-centred frame: +x toward (0°N, 0°E), +y toward
//! (0°N, 90°E), +z toward the North Pole, lengths in the vertical axis's unit. Renderers map a
//! world point to fractional voxel indices through these axes and interpolate in index space.

use super::vec3::dot;
use crate::error::{Error, Result};

/// Voxel-centre coordinates along one axis of a volume, strictly monotonic, and the domain they
/// span: from the first to the last centre, or the cell bounds a file gives.
#[derive(Clone, Debug, PartialEq)]
pub struct CoordAxis {
    pub centres: Vec<f64>,
    /// The domain's ends, `lo < hi`.
    pub lo: f64,
    pub hi: f64,
}

impl CoordAxis {
    /// Checks `centres` (finite, strictly increasing or decreasing; one centre needs `bounds`) and
    /// takes the domain from `bounds` or else from the first and last centres. `field` names the
    /// coordinate in errors.
    pub fn new(centres: Vec<f64>, bounds: Option<(f64, f64)>, field: &str) -> Result<CoordAxis> {
        if centres.is_empty() {
            return Err(Error::invalid(field, "expected at least one coordinate"));
        }
        if let Some(i) = centres.iter().position(|c| !c.is_finite()) {
            return Err(Error::invalid(
                field,
                format!("coordinate {i} is {}; expected finite values", centres[i]),
            ));
        }
        let rising = centres.len() < 2 || centres[1] > centres[0];
        for (i, w) in centres.windows(2).enumerate() {
            if (w[1] > w[0]) != rising || w[1] == w[0] {
                let what = if w[1] == w[0] {
                    "duplicate"
                } else {
                    "non-monotonic"
                };
                return Err(Error::invalid(
                    field,
                    format!(
                        "{what} coordinates at {i} and {} ({} then {}); expected strictly increasing or decreasing values",
                        i + 1,
                        w[0],
                        w[1]
                    ),
                ));
            }
        }
        let first = centres[0];
        let last = centres[centres.len() - 1];
        let (lo, hi) = match bounds {
            Some((a, b)) => (a.min(b), a.max(b)),
            None => (first.min(last), first.max(last)),
        };
        if !(lo.is_finite() && hi.is_finite() && hi > lo)
            || lo > first.min(last)
            || hi < first.max(last)
        {
            return Err(Error::invalid(
                field,
                format!(
                    "the domain [{lo}, {hi}] must be non-empty and contain the coordinates [{}, {}]",
                    first.min(last),
                    first.max(last)
                ),
            ));
        }
        Ok(CoordAxis { centres, lo, hi })
    }

    /// An axis of `n` centres `start + (i + 0.5)·step` with the domain of their cells.
    pub fn uniform_cells(start: f64, step: f64, n: usize) -> CoordAxis {
        CoordAxis {
            centres: (0..n).map(|i| start + (i as f64 + 0.5) * step).collect(),
            lo: start,
            hi: start + n as f64 * step,
        }
    }

    pub fn len(&self) -> usize {
        self.centres.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// The step when the centres are equally spaced (to 1e-9 of the step), else `None`.
    pub fn uniform_step(&self) -> Option<f64> {
        let n = self.centres.len();
        if n < 2 {
            return Some(self.hi - self.lo);
        }
        let step = (self.centres[n - 1] - self.centres[0]) / (n - 1) as f64;
        let uniform = self
            .centres
            .windows(2)
            .all(|w| ((w[1] - w[0]) - step).abs() <= 1e-9 * step.abs());
        uniform.then_some(step)
    }

    /// The smallest distance between neighbouring centres (the domain's width for one centre).
    pub(crate) fn min_spacing(&self) -> f64 {
        self.centres.windows(2).map(|w| (w[1] - w[0]).abs()).fold(
            if self.centres.len() < 2 {
                self.hi - self.lo
            } else {
                f64::INFINITY
            },
            f64::min,
        )
    }

    /// The fractional index of coordinate `c`: `i` at centre `i`, linear between centres, and
    /// linear with the end spacing beyond the first and last centres (clamped by the caller).
    pub(crate) fn fractional_index(&self, c: f64) -> f64 {
        let n = self.centres.len();
        if n < 2 {
            return 0.0;
        }
        let rising = self.centres[1] > self.centres[0];
        // The first centre past c in the axis's direction.
        let past = self
            .centres
            .partition_point(|&x| if rising { x <= c } else { x >= c });
        let i = past.clamp(1, n - 1) - 1;
        let (a, b) = (self.centres[i], self.centres[i + 1]);
        i as f64 + (c - a) / (b - a)
    }
}

/// How a volume's voxel indices map to world positions.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Geometry {
    /// Voxel (i, j, k) at `origin + (index + 0.5)·spacing`.
    #[default]
    Regular,
    /// Voxel (i, j, k) at `(x[i], y[j], z[k])`.
    Rectilinear(Box<[CoordAxis; 3]>),
    /// A shell or wedge on (radius, latitude, longitude) axes.
    Spherical(Box<SphericalGrid>),
}

impl Geometry {
    /// `"cartesian"` for regular and rectilinear boxes, `"spherical"` for shells.
    pub fn name(&self) -> &'static str {
        match self {
            Geometry::Spherical(_) => "spherical",
            _ => "cartesian",
        }
    }
}

/// A volume on (radius, latitude, longitude) axes. Depths and heights are stored as radii.
#[derive(Clone, Debug, PartialEq)]
pub struct SphericalGrid {
    /// Which volume axis (0 = x, fastest in memory; 1 = y; 2 = z) holds radius, latitude and
    /// longitude, in that order.
    pub axis_of: [usize; 3],
    /// Radii of the voxel centres, in `length_unit`.
    pub radius: CoordAxis,
    /// Degrees north, within [−90, 90].
    pub latitude: CoordAxis,
    /// Degrees east. When `lon_wraps`, the axis covers the whole circle and the domain is
    /// `[lo, lo + 360]`, the last centre joining the first across the seam.
    pub longitude: CoordAxis,
    pub lon_wraps: bool,
    pub planet_radius: f64,
    pub length_unit: String,
    /// The file's vertical coordinate: `depth`, `radius` or `height`, for reports.
    pub vertical: String,
    /// Latitude and longitude are on a rotated sphere (CF `rotated_latitude_longitude`): the
    /// volume lies in the grid's frame, in which renders are made; cameras given in the true
    /// frame (`camera_geo`, `camera_look_at`) and coastlines are turned into it.
    pub rotated_pole: Option<super::RotatedPole>,
}

impl SphericalGrid {
    /// Checks the axes against each other: latitudes within ±90°, radii positive and at most
    /// the planet's radius when they come from depths, a longitude span of at most 360°.
    pub fn check(&self, field: &str) -> Result<()> {
        if self.latitude.lo < -90.0 - 1e-9 || self.latitude.hi > 90.0 + 1e-9 {
            return Err(Error::invalid(
                field,
                format!(
                    "latitude spans [{}, {}] degrees; expected values within [-90, 90]",
                    self.latitude.lo, self.latitude.hi
                ),
            ));
        }
        if self.radius.lo < 0.0 {
            return Err(Error::invalid(
                field,
                format!(
                    "the vertical axis reaches radius {} {}: deeper than the planet's radius {} {}",
                    self.radius.lo, self.length_unit, self.planet_radius, self.length_unit
                ),
            ));
        }
        if self.longitude.hi - self.longitude.lo > 360.0 + 1e-9 {
            return Err(Error::invalid(
                field,
                format!(
                    "longitude spans {} degrees; expected at most 360",
                    self.longitude.hi - self.longitude.lo
                ),
            ));
        }
        let mut order = self.axis_of;
        order.sort_unstable();
        if order != [0, 1, 2] {
            return Err(Error::invalid(
                field,
                "axes must be a permutation of 0, 1, 2",
            ));
        }
        Ok(())
    }

    /// The outer radius of the domain.
    pub(crate) fn outer_radius(&self) -> f64 {
        self.radius.hi
    }

    /// The length that `step`, emission and extinction count in: the smallest radial spacing.
    pub fn length_scale(&self) -> f64 {
        self.radius.min_spacing()
    }

    /// World position of (radius, latitude°, longitude°).
    pub fn to_world(r: f64, lat_deg: f64, lon_deg: f64) -> [f64; 3] {
        let (sl, cl) = lat_deg.to_radians().sin_cos();
        let (so, co) = lon_deg.to_radians().sin_cos();
        [r * cl * co, r * cl * so, r * sl]
    }

    /// (radius, latitude°, longitude°) of a world position; longitude in (−180, 180].
    pub(crate) fn from_world(p: [f64; 3]) -> (f64, f64, f64) {
        let rho = (p[0] * p[0] + p[1] * p[1]).sqrt();
        let r = (rho * rho + p[2] * p[2]).sqrt();
        (
            r,
            p[2].atan2(rho).to_degrees(),
            p[1].atan2(p[0]).to_degrees(),
        )
    }

    /// Longitude `lon` moved by whole turns into `[lo, lo + 360)`.
    pub(crate) fn wrap_longitude(&self, lon: f64) -> f64 {
        self.longitude.lo + (lon - self.longitude.lo).rem_euclid(360.0)
    }

    /// Whether the world point lies in the domain (shell, latitude band, longitude wedge).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        let (r, lat, lon) = Self::from_world(p);
        let lon = self.wrap_longitude(lon);
        r >= self.radius.lo
            && r <= self.radius.hi
            && lat >= self.latitude.lo
            && lat <= self.latitude.hi
            && (self.lon_wraps || lon <= self.longitude.hi)
    }

    /// The domain's axis-aligned bounding box. The extremes of each coordinate over a wedge lie
    /// at its corner angles, at the cardinal directions it contains, or at the poles.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lats = vec![self.latitude.lo, self.latitude.hi];
        if self.latitude.lo < 0.0 && self.latitude.hi > 0.0 {
            lats.push(0.0);
        }
        let mut lons = vec![self.longitude.lo, self.longitude.hi];
        for k in -4..=8 {
            let cardinal = 90.0 * k as f64;
            if self.lon_wraps || (cardinal > self.longitude.lo && cardinal < self.longitude.hi) {
                lons.push(cardinal);
            }
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &r in &[self.radius.lo, self.radius.hi] {
            for &lat in &lats {
                for &lon in &lons {
                    let p = Self::to_world(r, lat, lon);
                    for a in 0..3 {
                        lo[a] = lo[a].min(p[a]);
                        hi[a] = hi[a].max(p[a]);
                    }
                }
            }
        }
        (lo, hi)
    }

    /// Fractional voxel indices (per volume axis) of a world point inside the domain; the
    /// longitude index is taken modulo the axis length when it wraps.
    pub(crate) fn fractional_indices(&self, p: [f64; 3]) -> [f64; 3] {
        let (r, lat, lon) = Self::from_world(p);
        let lon = self.wrap_longitude(lon);
        let mut lon_index = self.longitude.fractional_index(lon);
        if self.lon_wraps {
            // Between the last centre and the first one a turn later.
            let n = self.longitude.len() as f64;
            let last = self.longitude.centres[self.longitude.len() - 1];
            let first = self.longitude.centres[0];
            let rising = self.longitude.len() < 2 || self.longitude.centres[1] > first;
            let (a, b) = if rising {
                (last, first + 360.0)
            } else {
                (last, first - 360.0)
            };
            let beyond = if rising {
                lon > last || lon < first
            } else {
                lon < last || lon > first
            };
            if beyond {
                let l = if rising && lon < first {
                    lon + 360.0
                } else if !rising && lon > first {
                    lon - 360.0
                } else {
                    lon
                };
                lon_index = (n - 1.0) + (l - a) / (b - a);
            }
        }
        let mut idx = [0.0; 3];
        idx[self.axis_of[0]] = self.radius.fractional_index(r);
        idx[self.axis_of[1]] = self.latitude.fractional_index(lat);
        idx[self.axis_of[2]] = lon_index;
        idx
    }
}

impl SphericalGrid {
    /// The parts of the ray `o + t·d` (t ≥ 0) inside the domain, in order: the outer sphere
    /// clipped by the inner one and by the latitude cones and longitude planes of a wedge. The
    /// ends are the exact crossings; the parts between them are told apart by their midpoints.
    pub fn ray_intervals(&self, o: [f64; 3], d: [f64; 3]) -> Vec<(f64, f64)> {
        self.ray_intervals_cut(o, d, None)
    }
}

/// Squared distance from p to the segment a–b in the plane.
pub(crate) fn segment_distance2(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (p[0] - a[0] - t * dx, p[1] - a[1] - t * dy);
    ex * ex + ey * ey
}

/// Distance from p to the segment a–b in the plane.
pub(crate) fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    segment_distance2(p, a, b).sqrt()
}

pub(crate) fn sphere_hit(o: [f64; 3], d: [f64; 3], r: f64) -> Option<(f64, f64)> {
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - r * r;
    let disc = b * b - a * c;
    if disc <= 0.0 || a == 0.0 {
        return None;
    }
    let q = -(b + b.signum() * disc.sqrt());
    let (x, y) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    Some((x.min(y), x.max(y)))
}

/// Crossings of the ray with the cone (both nappes) of latitude `lat_deg`.
pub(crate) fn cone_hits(o: [f64; 3], d: [f64; 3], lat_deg: f64) -> Vec<f64> {
    let (s, c) = lat_deg.to_radians().sin_cos();
    let (s2, c2) = (s * s, c * c);
    let a = c2 * d[2] * d[2] - s2 * (d[0] * d[0] + d[1] * d[1]);
    let b = c2 * o[2] * d[2] - s2 * (o[0] * d[0] + o[1] * d[1]);
    let cc = c2 * o[2] * o[2] - s2 * (o[0] * o[0] + o[1] * o[1]);
    if a.abs() < 1e-300 {
        return if b != 0.0 {
            vec![-cc / (2.0 * b)]
        } else {
            Vec::new()
        };
    }
    let disc = b * b - a * cc;
    if disc < 0.0 {
        return Vec::new();
    }
    let q = -(b + if b >= 0.0 { 1.0 } else { -1.0 } * disc.sqrt());
    if q == 0.0 {
        return vec![0.0];
    }
    vec![q / a, cc / q]
}

/// The radii and angles a shell spans, for reports.
impl std::fmt::Display for SphericalGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let u = &self.length_unit;
        write!(
            f,
            "radius {}–{} {u} (from {}; planet radius {} {u}), latitude {}° to {}°, ",
            self.radius.lo,
            self.radius.hi,
            self.vertical,
            self.planet_radius,
            self.latitude.lo,
            self.latitude.hi
        )?;
        if self.lon_wraps {
            write!(f, "longitude all round from {}°", self.longitude.lo)?;
        } else {
            write!(
                f,
                "longitude {}° to {}°",
                self.longitude.lo, self.longitude.hi
            )?;
        }
        match &self.rotated_pole {
            Some(p) => write!(f, " (rotated: {})", p.describe()),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_refuse_bad_coordinates() {
        assert!(CoordAxis::new(vec![0.0, 1.0, 1.0], None, "depth").is_err());
        let e = CoordAxis::new(vec![0.0, 2.0, 1.0], None, "depth").unwrap_err();
        assert!(e.to_string().contains("non-monotonic"), "{e}");
        assert!(CoordAxis::new(vec![0.0, f64::NAN], None, "depth").is_err());
        assert!(CoordAxis::new(vec![3.0, 2.0, 0.5], None, "depth").is_ok());
    }

    #[test]
    fn fractional_index_is_piecewise_linear_both_ways() {
        let up = CoordAxis::new(vec![0.0, 1.0, 3.0, 7.0], None, "z").unwrap();
        assert_eq!(up.fractional_index(0.0), 0.0);
        assert_eq!(up.fractional_index(2.0), 1.5);
        assert_eq!(up.fractional_index(7.0), 3.0);
        assert_eq!(up.fractional_index(-1.0), -1.0);
        assert_eq!(up.fractional_index(9.0), 3.5);
        let down = CoordAxis::new(vec![7.0, 3.0, 1.0, 0.0], None, "z").unwrap();
        assert_eq!(down.fractional_index(5.0), 0.5);
        assert_eq!(down.fractional_index(0.5), 2.5);
        assert_eq!(up.uniform_step(), None);
        assert_eq!(
            CoordAxis::uniform_cells(0.0, 2.0, 3).uniform_step(),
            Some(2.0)
        );
        assert_eq!(up.min_spacing(), 1.0);
    }

    fn global(lon0: f64) -> SphericalGrid {
        SphericalGrid {
            axis_of: [2, 1, 0],
            radius: CoordAxis::uniform_cells(1.0, 0.5, 4),
            latitude: CoordAxis::uniform_cells(-90.0, 10.0, 18),
            longitude: CoordAxis {
                centres: (0..36).map(|i| lon0 + 5.0 + 10.0 * i as f64).collect(),
                lo: lon0,
                hi: lon0 + 360.0,
            },
            lon_wraps: true,
            planet_radius: 3.0,
            length_unit: "km".into(),
            vertical: "radius".into(),
            rotated_pole: None,
        }
    }

    #[test]
    fn world_frame_and_round_trip() {
        let p = SphericalGrid::to_world(2.0, 0.0, 90.0);
        assert!((p[1] - 2.0).abs() < 1e-12 && p[0].abs() < 1e-12);
        let (r, lat, lon) = SphericalGrid::from_world(SphericalGrid::to_world(2.5, -30.0, 120.0));
        assert!(
            (r - 2.5).abs() < 1e-12 && (lat + 30.0).abs() < 1e-12 && (lon - 120.0).abs() < 1e-12
        );
        let g = global(-180.0);
        g.check("v").unwrap();
        let (lo, hi) = g.bounds();
        assert_eq!((lo, hi), ([-3.0, -3.0, -3.0], [3.0, 3.0, 3.0]));
    }

    #[test]
    fn ray_intervals_are_the_chords_of_shell_and_wedge() {
        let g = global(0.0);
        // Along x at impact parameter b in the equatorial plane... here along z at (b, 0).
        for b in [0.0, 0.5, 1.2, 2.0, 2.9] {
            let parts = g.ray_intervals([b, 0.0, -10.0], [0.0, 0.0, 1.0]);
            let total: f64 = parts.iter().map(|(a, c)| c - a).sum();
            let chord = |r: f64| {
                if b < r {
                    2.0 * (r * r - b * b).sqrt()
                } else {
                    0.0
                }
            };
            assert!(
                (total - (chord(3.0) - chord(1.0))).abs() < 1e-12,
                "b {b}: {parts:?}"
            );
            assert_eq!(parts.len(), if b < 1.0 { 2 } else { 1 });
        }
        // A wedge: longitudes 0 to 90, latitudes 0 to 90, radius 1 to 3; a ray along z at
        // (1.5, 1.5) crosses it from the equator to the outer sphere.
        let mut w = global(0.0);
        w.lon_wraps = false;
        w.longitude = CoordAxis::new(vec![10.0, 80.0], Some((0.0, 90.0)), "lon").unwrap();
        w.latitude = CoordAxis::new(vec![10.0, 80.0], Some((0.0, 90.0)), "lat").unwrap();
        let parts = w.ray_intervals([1.5, 1.5, -10.0], [0.0, 0.0, 1.0]);
        let top = (9.0f64 - 4.5).sqrt();
        assert_eq!(parts.len(), 1);
        assert!(
            (parts[0].0 - 10.0).abs() < 1e-12 && (parts[0].1 - (10.0 + top)).abs() < 1e-12,
            "{parts:?}"
        );
        assert!(w
            .ray_intervals([-1.5, 1.5, -10.0], [0.0, 0.0, 1.0])
            .is_empty());
    }

    #[test]
    fn longitude_index_wraps_across_the_seam() {
        for lon0 in [-180.0, 0.0] {
            let g = global(lon0);
            // Halfway between the last centre (lon0 + 355) and the first (lon0 + 5).
            let p = SphericalGrid::to_world(2.0, 5.0, lon0);
            let idx = g.fractional_indices(p);
            assert!((idx[0] - 35.5).abs() < 1e-9, "{lon0}: {idx:?}");
            assert!((idx[1] - 9.0).abs() < 1e-9);
            assert!((idx[2] - 1.5).abs() < 1e-9);
        }
    }
}
