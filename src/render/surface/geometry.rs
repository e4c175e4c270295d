//! Where the surface sits in world space and how it is seen ([`SurfaceGeometry`]): relief
//! heights, the relief box, the camera of the view, and the light of the 3-D views.

use super::globe::GlobeFrame;
use super::options::{SurfaceOptions, SurfaceView};
use crate::error::{Error, Result};
use crate::model::{Aabb, Camera, Grid};

/// Where the surface sits in world space and how it is seen, as both the data pass and its f64
/// CPU reference ([`crate::render::surface_reference`]) use it. World: x = i·sx, y = j·sy in
/// coordinate units from the first node, z = (height − hmin)·exaggeration − z_lo, so that the
/// relief box is [0, box_size] (a flat surface gets a thin box around z = −z_lo).
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
        let sx = grid.x().spacing().abs().max(f64::MIN_POSITIVE);
        let sy = grid.y().spacing().abs().max(f64::MIN_POSITIVE);
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
