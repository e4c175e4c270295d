//! Where a point lands in a picture ([`Projector`]): a map's axes, a projected map, the globe
//! seen by a camera, or the outer surface of a spherical volume; and back, from a pixel to the
//! point it shows. The overlay draws its lines and marks through it.

use super::projected::ProjectedMap;
use super::GlobeFrame;
use crate::model::map_frame::MapAxes;
use crate::model::{Camera, Cut, SphericalGrid};
use std::sync::Arc;

/// Longest piece of a line drawn straight on the globe or a projected map, in degrees.
pub(super) const GLOBE_STEP: f64 = 0.5;

/// Where a (longitude, latitude) lands in the image.
pub(super) enum Projector {
    Map(MapAxes),
    Globe(Camera),
    /// A spherical volume's outer surface.
    Shell(Box<ShellSurface>),
    /// A map in a projection.
    Projected(Arc<ProjectedMap>),
}

/// The outer surface of a spherical volume a render shows: its grid (radius, extent) and cut.
pub(super) struct ShellSurface {
    pub camera: Camera,
    pub grid: SphericalGrid,
    pub cut: Option<Cut>,
}

impl ShellSurface {
    /// The pixel of (longitude, latitude) on the outer sphere, where the sphere there faces the
    /// eye and the domain has its outer surface (just inside it is in the domain and kept).
    fn pixel(&self, lonlat: [f64; 2], w: u32, h: u32) -> Option<[f64; 2]> {
        let r = self.grid.radius.hi;
        let inside = SphericalGrid::to_world(r * (1.0 - 1e-9), lonlat[1], lonlat[0]);
        let kept = self.grid.contains(inside)
            && !self
                .cut
                .as_ref()
                .is_some_and(|c| c.removes(self.grid.planet_radius, inside));
        if !kept {
            return None;
        }
        sphere_pixel(&self.camera, r, lonlat, w, h)
    }
}

impl Projector {
    /// The coordinates (longitude and latitude, or a plain map's axes) at the pixel position
    /// `px` of a `w × h` picture; `None` off the map or the sphere.
    pub(super) fn point_at(&self, px: [f64; 2], w: u32, h: u32) -> Option<[f64; 2]> {
        match self {
            Projector::Map(a) => {
                let (fx, fy) = (px[0] / w as f64, px[1] / h as f64);
                let y = if a.y_down {
                    a.y.lo + fy * (a.y.hi - a.y.lo)
                } else {
                    a.y.hi - fy * (a.y.hi - a.y.lo)
                };
                Some([a.x.lo + fx * (a.x.hi - a.x.lo), y])
            }
            Projector::Projected(map) => map.lonlat(px),
            Projector::Globe(cam) => {
                let (eye, d) = cam.ray_at(px, w, h);
                let (_, p) = GlobeFrame::hit(eye, d)?;
                let (_, lat, lon) = SphericalGrid::from_world(p);
                Some([lon, lat])
            }
            Projector::Shell(_) => None,
        }
    }

    /// The pixel position of the point `q` (as [`Self::point_at`] gives them), or `None`.
    pub(super) fn pixel_at(&self, q: [f64; 2], w: u32, h: u32) -> Option<[f64; 2]> {
        match self {
            Projector::Map(a) => {
                let down = if a.y_down {
                    q[1] - a.y.lo
                } else {
                    a.y.hi - q[1]
                };
                Some([
                    (q[0] - a.x.lo) / (a.x.hi - a.x.lo) * w as f64,
                    down / (a.y.hi - a.y.lo) * h as f64,
                ])
            }
            Projector::Projected(map) => map.pixel(q[0], q[1]),
            Projector::Globe(cam) => globe_pixel(cam, q, w, h),
            Projector::Shell(_) => None,
        }
    }

    /// The pieces, in pixel coordinates, that the segment a–b (degrees) is drawn as: on a map
    /// the straight segment, and with `turns` its copies 360° east and west (longitudes); on a
    /// projected map or the globe the segment cut into pieces of at most [`GLOBE_STEP`], each
    /// kept when both its ends show (and, projected, when it does not cross the seam).
    pub(super) fn segment(
        &self,
        [a, b]: [[f64; 2]; 2],
        (w, h): (u32, u32),
        turns: bool,
    ) -> Vec<[[f64; 2]; 2]> {
        if let Projector::Map(_) = self {
            let shifts: &[f64] = if turns { &[-360.0, 0.0, 360.0] } else { &[0.0] };
            return shifts
                .iter()
                .filter_map(|&s| {
                    let at = |p: [f64; 2]| self.pixel_at([p[0] + s, p[1]], w, h);
                    Some([at(a)?, at(b)?])
                })
                .collect();
        }
        let n = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()) / GLOBE_STEP).ceil();
        let n = (n as usize).max(1);
        let point = |k: usize| {
            let t = k as f64 / n as f64;
            [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
        };
        let piece = |k: usize| -> Option<[[f64; 2]; 2]> {
            let (p, q) = (point(k), point(k + 1));
            let at = |p: [f64; 2]| match self {
                Projector::Shell(shell) => shell.pixel(p, w, h),
                other => other.pixel_at(p, w, h),
            };
            if let Projector::Projected(map) = self {
                if map.projector.crosses_seam(p[0], q[0]) {
                    return None;
                }
            }
            Some([at(p)?, at(q)?])
        };
        // A projected piece that jumps across the map crosses a cut the seam test missed.
        let jump = 0.25 * (w.max(h) as f64);
        (0..n)
            .filter_map(piece)
            .filter(|[p, q]| {
                !matches!(self, Projector::Projected(_))
                    || ((p[0] - q[0]).abs() < jump && (p[1] - q[1]).abs() < jump)
            })
            .collect()
    }
}

/// Where a point on the unit sphere at (longitude, latitude) degrees shows in a globe image,
/// or `None` when the sphere there faces away from the eye (the far hemisphere).
pub(crate) fn globe_pixel(cam: &Camera, lonlat: [f64; 2], w: u32, h: u32) -> Option<[f64; 2]> {
    sphere_pixel(cam, 1.0, lonlat, w, h)
}

/// [`globe_pixel`] on the sphere of radius `r` about the origin.
fn sphere_pixel(cam: &Camera, r: f64, lonlat: [f64; 2], w: u32, h: u32) -> Option<[f64; 2]> {
    let p = SphericalGrid::to_world(r, lonlat[1], lonlat[0]);
    let towards_eye = match cam.projection {
        crate::model::Projection::Orthographic { .. } => cam.forward.map(|v| -v),
        crate::model::Projection::Perspective { .. } => {
            [cam.eye[0] - p[0], cam.eye[1] - p[1], cam.eye[2] - p[2]]
        }
    };
    let facing = p[0] * towards_eye[0] + p[1] * towards_eye[1] + p[2] * towards_eye[2];
    if facing <= 0.0 {
        return None;
    }
    cam.project(p, w, h)
}
