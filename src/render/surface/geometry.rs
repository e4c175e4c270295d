//! Where the surface sits in world space and how it is seen ([`SurfaceGeometry`]): relief
//! heights, the relief box, the camera of the view, and the light of the 3-D views.

use super::globe::GlobeFrame;
use super::options::{SurfaceOptions, SurfaceView};
use crate::error::{Error, Result};
use crate::model::grid::metres_per_unit;
use crate::model::map_frame::EARTH_RADIUS_KM;
use crate::model::{Aabb, Camera, Grid};

/// Where the surface sits in world space and how it is seen, as both the data pass and its f64
/// CPU reference ([`crate::render::surface_reference`]) use it. World: x = i·sx, y = j·sy from
/// the first node, z = (height − hmin)·exaggeration − z_lo, so that the relief box is
/// [0, box_size] (a flat surface gets a thin box around z = −z_lo). All three in one length
/// unit wherever the units are known ([`WorldUnits`]): a geographic grid's degrees become metres
/// on the sphere, and a relief in m over axes in km is scaled to km, so `exaggeration` is a
/// pure factor.
#[derive(Clone, Debug)]
pub(crate) struct SurfaceGeometry {
    /// Relief height per node before exaggeration (holes at the lowest height; 0 when flat).
    pub heights: Vec<f64>,
    /// Node spacing (sx, sy) in world units.
    pub spacing: [f64; 2],
    /// World z per height unit (1 for a flat surface).
    pub exaggeration: f64,
    /// Lowest relief height.
    pub height_min: f64,
    /// World z of the box's lower corner before the shift to 0 (negative for a flat surface).
    pub z_lo: f64,
    pub box_size: [f64; 3],
    /// The camera with its eye relative to the box's lower corner (in the Earth-centred frame
    /// on the globe); `None` in map view.
    pub camera: Option<Camera>,
    /// How the grid lies on the sphere in the globe view.
    pub globe: Option<GlobeFrame>,
    /// The map view's first row shows the first y node ([`Grid::y_down`]: a depth axis) rather
    /// than the last.
    pub y_down: bool,
}

/// The length unit of a surface's world: its node spacing in that unit, and how many world units
/// one unit of the relief is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct WorldUnits {
    pub spacing: [f64; 2],
    /// World units per relief unit (1 where either unit is unknown: as stored).
    pub relief_scale: f64,
}

impl WorldUnits {
    /// Geographic grids: metres on the sphere, longitude at the cosine of the grid's central
    /// latitude (the map's equirectangular scale). Axes in a length unit: the x axis's unit. Other
    /// axes (node indices, unknown units): coordinates as stored and the relief unscaled. The
    /// elevation is in metres; a relief property in the units it declares.
    pub(crate) fn of(grid: &Grid, relief: Option<&str>) -> WorldUnits {
        let step = |c: &crate::model::GridCoords| c.spacing().abs().max(f64::MIN_POSITIVE);
        let (sx, sy) = (step(grid.x()), step(grid.y()));
        let relief_metres = match relief {
            None | Some("none") | Some("elevation") => Some(1.0),
            Some(name) => grid
                .property_index(name)
                .ok()
                .and_then(|i| metres_per_unit(grid.units(i))),
        };
        if grid.is_geographic() {
            let per_degree = EARTH_RADIUS_KM * 1e3 * std::f64::consts::PI / 180.0;
            let ys = &grid.y().values;
            let lat_c = (0.5 * (ys[0] + ys[ys.len() - 1])).to_radians();
            return WorldUnits {
                spacing: [sx * per_degree * lat_c.cos().max(1e-6), sy * per_degree],
                relief_scale: relief_metres.unwrap_or(1.0),
            };
        }
        let (x_m, y_m) = (
            metres_per_unit(&grid.x().units),
            metres_per_unit(&grid.y().units),
        );
        match (x_m, y_m) {
            (Some(x_m), Some(y_m)) => WorldUnits {
                spacing: [sx, sy * y_m / x_m],
                relief_scale: relief_metres.map_or(1.0, |r| r / x_m),
            },
            _ => WorldUnits {
                spacing: [sx, sy],
                relief_scale: 1.0,
            },
        }
    }
}

impl SurfaceGeometry {
    pub fn new(grid: &Grid, opts: &SurfaceOptions) -> Result<Self> {
        let (nx, ny) = (grid.nx(), grid.ny());
        // Relief heights (world z before exaggeration), holes at the lowest height.
        let globe = match opts.view {
            SurfaceView::Globe(_) => Some(GlobeFrame::of(grid)?),
            _ => None,
        };
        let relief: Option<Vec<f64>> = match (&opts.view, opts.relief.as_deref()) {
            (SurfaceView::Map, _) | (_, None) | (_, Some("none")) => None,
            (SurfaceView::Globe(_), Some(_)) => {
                return Err(Error::invalid(
                    "relief",
                    "the globe view draws the field on the sphere without relief; leave relief out or use \"none\"",
                ))
            }
            (_, Some("elevation")) => Some(
                grid.elevation()
                    .ok_or_else(|| {
                        Error::invalid(
                            "relief",
                            format!(
                                "grid {:?} has no elevation; use a property name or none",
                                grid.name()
                            ),
                        )
                    })?
                    .to_vec(),
            ),
            (_, Some(name)) => Some(grid.property(name)?.to_vec()),
        };
        // Flat surfaces (no relief or no exaggeration) get heights 0 and an effective factor 1.
        let relief = relief.filter(|_| opts.exaggeration > 0.0);
        let exag = if relief.is_some() {
            opts.exaggeration
        } else {
            1.0
        };
        let (hmin, hmax) = relief
            .as_ref()
            .and_then(|r| {
                r.iter()
                    .filter(|v| v.is_finite())
                    .fold(None, |acc: Option<(f64, f64)>, &v| {
                        Some(acc.map_or((v, v), |(a, b)| (a.min(v), b.max(v))))
                    })
            })
            .unwrap_or((0.0, 0.0));
        let heights: Vec<f64> = match &relief {
            Some(r) => r
                .iter()
                .map(|&v| if v.is_finite() { v } else { hmin })
                .collect(),
            None => vec![0.0; nx * ny],
        };
        let units = WorldUnits::of(grid, opts.relief.as_deref());
        let [sx, sy] = units.spacing;
        let exag = exag * units.relief_scale;
        let mut size = [
            (nx.max(2) - 1) as f64 * sx,
            (ny.max(2) - 1) as f64 * sy,
            (hmax - hmin) * exag,
        ];
        // A flat surface still needs a box of some thickness for the ray test.
        let thin = 1e-4 * size[0].max(size[1]);
        let z_lo = if size[2] < thin { -thin } else { 0.0 };
        size[2] = size[2].max(thin) - z_lo;
        let camera = match opts.view {
            SurfaceView::Map => None,
            SurfaceView::Orbit {
                azimuth,
                elevation,
                fov,
            } => {
                let b = Aabb {
                    lo: [0.0, 0.0, z_lo],
                    hi: [size[0], size[1], size[2] + z_lo],
                };
                Some(Camera::orbit(&b, azimuth, elevation, fov)?)
            }
            SurfaceView::Camera(c) => Some(c),
            SurfaceView::Globe(c) => Some(c),
        };
        // Positions relative to the box's lower corner (z = z_lo); the globe's frame is its own.
        let camera = camera.map(|mut c| {
            if globe.is_none() {
                c.eye[2] -= z_lo;
            }
            c
        });
        Ok(SurfaceGeometry {
            heights,
            spacing: [sx, sy],
            exaggeration: exag,
            height_min: hmin,
            z_lo,
            box_size: size,
            camera,
            globe,
            y_down: grid.y_down(),
        })
    }

    /// The height whose world z is 0 (the box floor): hmin + z_lo / exaggeration.
    pub(crate) fn height_at_floor(&self) -> f64 {
        self.height_min + self.z_lo / self.exaggeration
    }

    /// The node row (continuous v along y) that the map view shows at continuous pixel row
    /// `row` (both measured from the first node's end): the top row is the last y node, or the
    /// first when y runs downward. The data shader mirrors it (`counts.z`).
    pub(crate) fn map_v(&self, row: f64, ny: usize) -> f64 {
        if self.y_down {
            row
        } else {
            (ny - 1) as f64 - row
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::grid::{CoordKind, GridCoords};

    /// A 101 × 51 grid whose relief `h` rises to `top` at one node, over the given axes.
    fn grid(x: GridCoords, y: GridCoords, units: &str, top: f64) -> Grid {
        let n = x.values.len() * y.values.len();
        let mut h = vec![0.0; n];
        h[n / 2] = top;
        let mut g = Grid::with_coords("g", x, y, vec![("h".into(), h)], None).unwrap();
        g.set_units("h", units).unwrap();
        g
    }

    fn axis(units: &str, kind: CoordKind, first: f64, step: f64, n: usize) -> GridCoords {
        GridCoords {
            name: "a".into(),
            units: units.into(),
            values: (0..n).map(|i| first + step * i as f64).collect(),
            kind,
            edges: None,
        }
    }

    fn box_of(g: &Grid, exaggeration: f64) -> [f64; 3] {
        let opts = SurfaceOptions {
            view: SurfaceView::Orbit {
                azimuth: 30.0,
                elevation: 40.0,
                fov: 30.0,
            },
            relief: Some("h".into()),
            exaggeration,
            ..Default::default()
        };
        SurfaceGeometry::new(g, &opts).unwrap().box_size
    }

    #[test]
    fn degrees_become_metres_on_the_sphere_so_exaggeration_is_a_pure_factor() {
        // 2° of longitude by 1° of latitude centred on 60° N, a 1000 m summit.
        let g = grid(
            axis("degrees_east", CoordKind::Longitude, 10.0, 0.02, 101),
            axis("degrees_north", CoordKind::Latitude, 59.5, 0.02, 51),
            "m",
            1000.0,
        );
        let per_degree = 6371.0088e3 * std::f64::consts::PI / 180.0;
        let [x, y, z] = box_of(&g, 30.0);
        assert!((x / (2.0 * per_degree * 0.5) - 1.0).abs() < 1e-12, "{x}");
        assert!((y / per_degree - 1.0).abs() < 1e-12, "{y}");
        assert!((z / 30_000.0 - 1.0).abs() < 1e-12, "{z}");
    }

    #[test]
    fn a_relief_in_metres_over_kilometre_axes_is_scaled_to_kilometres() {
        let g = grid(
            axis("km", CoordKind::Plain, 0.0, 0.5, 101),
            axis("kilometres", CoordKind::Plain, 0.0, 0.5, 51),
            "m",
            250.0,
        );
        let [x, y, z] = box_of(&g, 4.0);
        assert_eq!((x, y), (50.0, 25.0));
        assert!((z - 1.0).abs() < 1e-12, "{z}");
        // Axes without a length unit keep the relief as stored.
        let plain = grid(
            axis("node", CoordKind::Plain, 0.0, 1.0, 101),
            axis("node", CoordKind::Plain, 0.0, 1.0, 51),
            "m",
            250.0,
        );
        assert_eq!(box_of(&plain, 4.0), [100.0, 50.0, 1000.0]);
    }
}
