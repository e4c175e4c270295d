//! Map projections for map views (`projection:` on `render_surface`): the equirectangular map
//! the map view draws by default, and Robinson, Mollweide, orthographic, polar stereographic
//! (north and south) and Lambert conformal conic on a sphere of the Earth's mean radius. The
//! projections' formulas are PROJ's, through its pure-Rust port `proj4rs`, and tested against
//! PROJ itself (pyproj) at a table of points. [`MapProjection`] is what a user asks for, with
//! its parameters left to the data's extent where not given; [`Projector`] is one resolved,
//! placing (longitude, latitude) on the projection plane in metres and back, and saying `None`
//! wherever the projection shows no map: the far hemisphere of an orthographic view, the far
//! side of the equator of a polar view, outside a world map's outline.

use super::map_frame::EARTH_RADIUS_KM;
use crate::error::{Error, Result};
use proj4rs::Proj;

/// The projections a map view can take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProjectionKind {
    Equirectangular,
    Robinson,
    Mollweide,
    Orthographic,
    PolarNorth,
    PolarSouth,
    Lambert,
}

impl ProjectionKind {
    pub(crate) const NAMES: &'static [&'static str] = &[
        "equirectangular",
        "robinson",
        "mollweide",
        "orthographic",
        "polar_north",
        "polar_south",
        "lambert",
    ];

    const ALL: [ProjectionKind; 7] = [
        ProjectionKind::Equirectangular,
        ProjectionKind::Robinson,
        ProjectionKind::Mollweide,
        ProjectionKind::Orthographic,
        ProjectionKind::PolarNorth,
        ProjectionKind::PolarSouth,
        ProjectionKind::Lambert,
    ];

    pub fn name(self) -> &'static str {
        Self::NAMES[Self::ALL.iter().position(|&k| k == self).unwrap_or(0)]
    }

    pub fn parse(s: &str) -> Result<ProjectionKind> {
        Self::NAMES
            .iter()
            .position(|&n| n == s)
            .map(|i| Self::ALL[i])
            .ok_or_else(|| {
                Error::invalid(
                    "projection",
                    format!("expected one of {}, got {s:?}", Self::NAMES.join(", ")),
                )
            })
    }
}

/// A map projection with its parameters in degrees; `None` takes the default for the data's
/// extent ([`MapProjection::resolved`]): the central longitude (`lon_0`) is 0° on world maps
/// (Robinson, Mollweide) and on polar views (0° points down from the pole), and the middle of
/// the extent otherwise; the centre latitude (`lat_0`) is the middle of the extent; Lambert's
/// standard parallels (`lat_1`, `lat_2`) lie a sixth of the extent's height inside its edges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapProjection {
    pub kind: ProjectionKind,
    pub lon_0: Option<f64>,
    pub lat_0: Option<f64>,
    pub lat_1: Option<f64>,
    pub lat_2: Option<f64>,
}

/// A longitude–latitude box in degrees: `west` to `east` (east > west, possibly beyond 180°)
/// and `south` to `north`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LonLatBox {
    pub west: f64,
    pub east: f64,
    pub south: f64,
    pub north: f64,
}

impl MapProjection {
    pub fn new(kind: ProjectionKind) -> MapProjection {
        MapProjection {
            kind,
            lon_0: None,
            lat_0: None,
            lat_1: None,
            lat_2: None,
        }
    }

    /// Whether this is the plain equirectangular map (the map view's default).
    pub fn is_equirectangular(&self) -> bool {
        self.kind == ProjectionKind::Equirectangular
    }

    /// The parameters checked: finite, latitudes within ±90°, Lambert's standard parallels on
    /// one side of the equator and not both on it.
    pub fn validate(&self) -> Result<()> {
        let lat = |name: &str, v: Option<f64>| match v {
            Some(v) if !(v.is_finite() && (-90.0..=90.0).contains(&v)) => Err(Error::invalid(
                "projection",
                format!("{name} = {v}: expected a latitude in [-90, 90]"),
            )),
            _ => Ok(()),
        };
        if let Some(v) = self.lon_0.filter(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "projection",
                format!("lon_0 = {v}: expected a finite longitude"),
            ));
        }
        lat("lat_0", self.lat_0)?;
        lat("lat_1", self.lat_1)?;
        lat("lat_2", self.lat_2)?;
        if let (Some(a), Some(b)) = (self.lat_1, self.lat_2) {
            if self.kind == ProjectionKind::Lambert && (a * b < 0.0 || a + b == 0.0) {
                return Err(Error::invalid(
                    "projection",
                    format!("lambert's standard parallels lat_1 = {a} and lat_2 = {b} must lie on one side of the equator"),
                ));
            }
        }
        Ok(())
    }

    /// This projection with every parameter set, the defaults taken from `extent`.
    pub fn resolved(&self, extent: &LonLatBox) -> MapProjection {
        let mid_lon = 0.5 * (extent.west + extent.east);
        let mid_lat = 0.5 * (extent.south + extent.north);
        let world = matches!(
            self.kind,
            ProjectionKind::Robinson
                | ProjectionKind::Mollweide
                | ProjectionKind::PolarNorth
                | ProjectionKind::PolarSouth
        );
        let lon_0 = self
            .lon_0
            .unwrap_or(if world { 0.0 } else { wrap_lon(mid_lon) });
        let sixth = (extent.north - extent.south) / 6.0;
        let (mut lat_1, mut lat_2) = (
            self.lat_1.unwrap_or(extent.south + sixth),
            self.lat_2.unwrap_or(extent.north - sixth),
        );
        if self.kind == ProjectionKind::Lambert && (lat_1 * lat_2 <= 0.0) {
            // A cone needs both parallels on one side of the equator: the side of the extent's
            // middle, at a third and two thirds of its distance from the equator.
            let s = if mid_lat < 0.0 { -1.0 } else { 1.0 };
            let far = extent.north.abs().max(extent.south.abs()).max(3.0);
            (lat_1, lat_2) = (s * far / 3.0, s * 2.0 * far / 3.0);
        }
        MapProjection {
            kind: self.kind,
            lon_0: Some(lon_0),
            lat_0: Some(self.lat_0.unwrap_or(mid_lat)),
            lat_1: Some(lat_1),
            lat_2: Some(lat_2),
        }
    }

    /// The PROJ string of a resolved projection on the sphere of the Earth's mean radius.
    pub fn proj_string(&self) -> String {
        let g = |v: Option<f64>| v.unwrap_or(0.0);
        let sphere = format!("+R={} +units=m +no_defs", EARTH_RADIUS_KM * 1e3);
        let body = match self.kind {
            ProjectionKind::Equirectangular => {
                format!(
                    "+proj=eqc +lat_ts={} +lon_0={}",
                    g(self.lat_0),
                    g(self.lon_0)
                )
            }
            ProjectionKind::Robinson => format!("+proj=robin +lon_0={}", g(self.lon_0)),
            ProjectionKind::Mollweide => format!("+proj=moll +lon_0={}", g(self.lon_0)),
            ProjectionKind::Orthographic => format!(
                "+proj=ortho +lat_0={} +lon_0={}",
                g(self.lat_0),
                g(self.lon_0)
            ),
            ProjectionKind::PolarNorth => {
                format!("+proj=stere +lat_0=90 +lat_ts=90 +lon_0={}", g(self.lon_0))
            }
            ProjectionKind::PolarSouth => {
                format!(
                    "+proj=stere +lat_0=-90 +lat_ts=-90 +lon_0={}",
                    g(self.lon_0)
                )
            }
            ProjectionKind::Lambert => format!(
                "+proj=lcc +lat_0={} +lat_1={} +lat_2={} +lon_0={}",
                g(self.lat_0),
                g(self.lat_1),
                g(self.lat_2),
                g(self.lon_0)
            ),
        };
        format!("{body} {sphere}")
    }

    /// What the image metadata says: the name and the PROJ string.
    pub fn describe(&self) -> String {
        format!("{} ({})", self.kind.name(), self.proj_string())
    }
}

/// A longitude in [−180°, 180°).
pub(crate) fn wrap_lon(lon: f64) -> f64 {
    (lon + 180.0).rem_euclid(360.0) - 180.0
}

/// A resolved projection ready to place points: PROJ's forward and inverse transforms, and the
/// part of the sphere it shows.
pub struct Projector {
    projection: MapProjection,
    geographic: Proj,
    plane: Proj,
}

/// Metres on the plane within which a point unprojected and projected again must land for the
/// plane's point to lie on the map (outside a world map's outline the inverse returns a point
/// that projects elsewhere): 1e-5 of the Earth's radius, 64 m, about 1/500 of a pixel on a
/// 1000-pixel world map (Robinson's inverse, PROJ's iteration, is good to a few metres).
const ROUND_TRIP_M: f64 = EARTH_RADIUS_KM * 1e-2;

impl Projector {
    /// The projector of `projection`, resolved over `extent`.
    pub fn new(projection: &MapProjection, extent: &LonLatBox) -> Result<Projector> {
        projection.validate()?;
        let projection = projection.resolved(extent);
        let proj = |s: &str| {
            Proj::from_proj_string(s).map_err(|e| {
                Error::invalid("projection", format!("PROJ string {s:?} refused: {e}"))
            })
        };
        Ok(Projector {
            geographic: proj(&format!(
                "+proj=latlong +R={} +no_defs",
                EARTH_RADIUS_KM * 1e3
            ))?,
            plane: proj(&projection.proj_string())?,
            projection,
        })
    }

    /// The resolved projection.
    pub fn projection(&self) -> &MapProjection {
        &self.projection
    }

    /// Whether the map shows the point at (`lon`, `lat`) degrees: the near hemisphere of an
    /// orthographic view, the pole's side of the equator in a polar view, the cone's side of
    /// the parallel 45° beyond the equator in a Lambert view, everywhere else.
    pub fn shows(&self, lon: f64, lat: f64) -> bool {
        let p = &self.projection;
        let g = |v: Option<f64>| v.unwrap_or(0.0).to_radians();
        match p.kind {
            ProjectionKind::Orthographic => {
                let (phi, dlam) = (lat.to_radians(), lon.to_radians() - g(p.lon_0));
                let phi0 = g(p.lat_0);
                phi0.sin() * phi.sin() + phi0.cos() * phi.cos() * dlam.cos() >= 0.0
            }
            ProjectionKind::PolarNorth => lat >= 0.0,
            ProjectionKind::PolarSouth => lat <= 0.0,
            ProjectionKind::Lambert => {
                let s = (p.lat_1.unwrap_or(0.0) + p.lat_2.unwrap_or(0.0)).signum();
                s * lat >= -45.0
            }
            _ => lat.abs() <= 90.0,
        }
    }

    /// Whether the way from longitude `a` to `b` (degrees, the short way round) crosses the
    /// meridian where the projection cuts the sphere (opposite its central meridian on world
    /// maps and cones; azimuthal views have no cut).
    pub fn crosses_seam(&self, a: f64, b: f64) -> bool {
        let lon_0 = self.projection.lon_0.unwrap_or(0.0);
        match self.projection.kind {
            ProjectionKind::Orthographic
            | ProjectionKind::PolarNorth
            | ProjectionKind::PolarSouth => false,
            _ => (wrap_lon(a - lon_0) - wrap_lon(b - lon_0)).abs() > 180.0,
        }
    }

    /// The point on the plane (metres) of (`lon`, `lat`) degrees; `None` where the map does not
    /// show it.
    pub fn forward(&self, lon: f64, lat: f64) -> Option<[f64; 2]> {
        if !(lon.is_finite() && lat.is_finite() && self.shows(lon, lat)) {
            return None;
        }
        let mut p = (lon.to_radians(), lat.to_radians(), 0.0);
        proj4rs::transform::transform(&self.geographic, &self.plane, &mut p).ok()?;
        (p.0.is_finite() && p.1.is_finite()).then_some([p.0, p.1])
    }

    /// The (longitude in [−180°, 180°), latitude) degrees at the plane's point `xy` (metres);
    /// `None` off the map.
    pub fn inverse(&self, xy: [f64; 2]) -> Option<[f64; 2]> {
        let mut p = (xy[0], xy[1], 0.0);
        proj4rs::transform::transform(&self.plane, &self.geographic, &mut p).ok()?;
        let (lon, lat) = (wrap_lon(p.0.to_degrees()), p.1.to_degrees());
        let back = self.forward(lon, lat)?;
        ((back[0] - xy[0]).hypot(back[1] - xy[1]) <= ROUND_TRIP_M).then_some([lon, lat])
    }

    /// The plane's box [x_min, x_max, y_min, y_max] (metres) around what the map shows of
    /// `extent`: the projected points of a 0.5° lattice over it, with its edges, and on an
    /// orthographic view the horizon where it crosses the extent. `None` when none shows.
    pub fn bounds(&self, extent: &LonLatBox) -> Option<[f64; 4]> {
        let steps = |lo: f64, hi: f64| ((hi - lo) / 0.5).ceil().max(1.0) as usize;
        let (nx, ny) = (
            steps(extent.west, extent.east),
            steps(extent.south, extent.north),
        );
        let mut b = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut take = |p: Option<[f64; 2]>| {
            if let Some([x, y]) = p {
                b = [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
            }
        };
        for j in 0..=ny {
            let lat = extent.south + (extent.north - extent.south) * j as f64 / ny as f64;
            for i in 0..=nx {
                let lon = extent.west + (extent.east - extent.west) * i as f64 / nx as f64;
                take(self.forward(lon, lat));
            }
        }
        if self.projection.kind == ProjectionKind::Orthographic {
            for k in 0..3600 {
                let [lon, lat] = self.horizon(k as f64 / 10.0);
                if inside(extent, lon, lat) {
                    take(self.forward(lon, lat));
                }
            }
        }
        (b[0] < b[1] && b[2] < b[3]).then_some(b)
    }

    /// The point of an orthographic view's horizon at `bearing` degrees from its centre:
    /// 90° of arc away along that bearing (a hair inside, so it shows).
    fn horizon(&self, bearing: f64) -> [f64; 2] {
        let p = &self.projection;
        let (phi0, lam0) = (
            p.lat_0.unwrap_or(0.0).to_radians(),
            p.lon_0.unwrap_or(0.0).to_radians(),
        );
        let (d, t) = ((90.0f64 - 1e-7).to_radians(), bearing.to_radians());
        let phi = (phi0.sin() * d.cos() + phi0.cos() * d.sin() * t.cos()).asin();
        let lam = lam0 + (t.sin() * d.sin() * phi0.cos()).atan2(d.cos() - phi0.sin() * phi.sin());
        [lam.to_degrees(), phi.to_degrees()]
    }
}

/// Whether (`lon`, `lat`) lies in `extent`, longitudes compared a turn either way.
pub(crate) fn inside(extent: &LonLatBox, lon: f64, lat: f64) -> bool {
    let lon_in = [-360.0, 0.0, 360.0]
        .iter()
        .any(|s| (extent.west..=extent.east).contains(&(lon + s)));
    lon_in && (extent.south..=extent.north).contains(&lat)
}

#[cfg(test)]
mod tests {
    use super::*;

    const WORLD: LonLatBox = LonLatBox {
        west: -180.0,
        east: 180.0,
        south: -90.0,
        north: 90.0,
    };

    #[test]
    fn names_round_trip_and_unknown_names_list_the_known() {
        for &n in ProjectionKind::NAMES {
            assert_eq!(ProjectionKind::parse(n).unwrap().name(), n);
        }
        let e = ProjectionKind::parse("mercator").unwrap_err().to_string();
        assert!(e.contains("robinson") && e.contains("\"mercator\""), "{e}");
    }

    #[test]
    fn every_projection_inverts_its_own_points_and_refuses_what_it_does_not_show() {
        for &kind in &ProjectionKind::ALL {
            let p = Projector::new(&MapProjection::new(kind), &WORLD).unwrap();
            let mut shown = 0;
            for lat in (-80..=80).step_by(20) {
                for lon in (-170..=170).step_by(20) {
                    let (lon, lat) = (lon as f64, lat as f64);
                    let Some(xy) = p.forward(lon, lat) else {
                        assert!(!p.shows(lon, lat), "{kind:?} {lon} {lat}");
                        continue;
                    };
                    shown += 1;
                    let [l, f] = p.inverse(xy).unwrap();
                    // Robinson's inverse (PROJ's iteration) is good to ~2e-5°.
                    assert!(
                        (l - lon).abs() < 1e-4 && (f - lat).abs() < 1e-4,
                        "{kind:?} {lon} {lat} -> {l} {f}"
                    );
                }
            }
            assert!(shown > 20, "{kind:?} shows {shown}");
        }
        // Outside Mollweide's ellipse and beyond an orthographic disc: no point.
        let moll = Projector::new(&MapProjection::new(ProjectionKind::Mollweide), &WORLD).unwrap();
        let [x, _, _, y] = moll.bounds(&WORLD).unwrap().map(|v| v.abs());
        assert!(moll.inverse([0.99 * x, 0.99 * y]).is_none());
        assert!(moll.inverse([0.0, 0.99 * y]).is_some());
        let ortho =
            Projector::new(&MapProjection::new(ProjectionKind::Orthographic), &WORLD).unwrap();
        let r = EARTH_RADIUS_KM * 1e3;
        assert!(ortho.inverse([0.8 * r, 0.8 * r]).is_none());
        assert!(ortho.inverse([0.7 * r, 0.7 * r]).is_some());
        let [x0, x1, y0, y1] = ortho.bounds(&WORLD).unwrap();
        for v in [-x0, x1, -y0, y1] {
            assert!((v / r - 1.0).abs() < 1e-6, "{v}");
        }
    }

    #[test]
    fn defaults_follow_the_extent_and_bad_parameters_are_refused() {
        let conus = LonLatBox {
            west: -125.0,
            east: -65.0,
            south: 20.0,
            north: 56.0,
        };
        let p = MapProjection::new(ProjectionKind::Lambert).resolved(&conus);
        assert_eq!((p.lon_0, p.lat_0), (Some(-95.0), Some(38.0)));
        assert_eq!((p.lat_1, p.lat_2), (Some(26.0), Some(50.0)));
        let r = MapProjection::new(ProjectionKind::Robinson).resolved(&conus);
        assert_eq!(r.lon_0, Some(0.0));
        let mut bad = MapProjection::new(ProjectionKind::Lambert);
        bad.lat_1 = Some(-30.0);
        bad.lat_2 = Some(30.0);
        assert!(bad.validate().unwrap_err().to_string().contains("one side"));
        bad.lat_1 = Some(95.0);
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("lat_1 = 95"));
    }
}
