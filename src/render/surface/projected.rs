//! Maps in a projection ([`ProjectedMap`]): where the projection's plane lies in the picture —
//! the plane's box around the field's extent, centred, at one scale both ways — so a pixel
//! gives its (longitude, latitude) through the projection's inverse and a point its pixel
//! through the forward projection (overlays, tests).

use super::options::SurfaceOptions;
use crate::error::{Error, Result};
use crate::model::map_projection::{LonLatBox, MapProjection, Projector};
use crate::model::HdrImage;

/// The long side of a host-placed map when neither `width` nor `height` is given, in pixels
/// (more where the field has more nodes along it).
pub(crate) const DEFAULT_MAP_SIDE: u32 = 1024;

/// A map in a projection: the projector and where the plane lies in the picture (the plane's
/// box around the field's extent, centred, at one scale both ways).
pub(crate) struct ProjectedMap {
    pub projector: Projector,
    extent: LonLatBox,
    centre: [f64; 2],
    metres_per_pixel: f64,
    pub width: u32,
    pub height: u32,
}

impl ProjectedMap {
    /// The map of `extent` in `projection` for `opts`' size: both sides given, the plane's box
    /// fitted inside and centred; one given, the other from the box's aspect; neither, the long
    /// side [`DEFAULT_MAP_SIDE`] or `nodes` (the field's nodes along its longer axis), whichever
    /// is more.
    pub(crate) fn new(
        projection: &MapProjection,
        extent: &LonLatBox,
        opts: &SurfaceOptions,
        nodes: usize,
    ) -> Result<ProjectedMap> {
        let projector = Projector::new(projection, extent)?;
        let [x0, x1, y0, y1] = projector.bounds(extent).ok_or_else(|| {
            Error::invalid(
                "projection",
                format!(
                    "{} shows none of the field's extent (longitude {} to {}, latitude {} to {})",
                    projection.kind.name(),
                    extent.west,
                    extent.east,
                    extent.south,
                    extent.north
                ),
            )
        })?;
        let aspect = (x1 - x0) / (y1 - y0);
        let side = |v: f64| v.round().clamp(1.0, crate::render::MAX_IMAGE_SIDE as f64) as u32;
        let long = DEFAULT_MAP_SIDE.max(nodes.min(8192) as u32) as f64;
        let (width, height) = match (opts.width, opts.height) {
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, side(w as f64 / aspect)),
            (None, Some(h)) => (side(h as f64 * aspect), h),
            (None, None) if aspect >= 1.0 => (side(long), side(long / aspect)),
            (None, None) => (side(long * aspect), side(long)),
        };
        let metres_per_pixel = ((x1 - x0) / width as f64).max((y1 - y0) / height as f64);
        Ok(ProjectedMap {
            projector,
            extent: *extent,
            centre: [0.5 * (x0 + x1), 0.5 * (y0 + y1)],
            metres_per_pixel,
            width,
            height,
        })
    }

    /// The (longitude, latitude) at the continuous pixel position `px` (0 at the left and top
    /// edges), or `None` off the map.
    pub(crate) fn lonlat(&self, px: [f64; 2]) -> Option<[f64; 2]> {
        let s = self.metres_per_pixel;
        self.projector.inverse([
            self.centre[0] + (px[0] - 0.5 * self.width as f64) * s,
            self.centre[1] - (px[1] - 0.5 * self.height as f64) * s,
        ])
    }

    /// The continuous pixel position of (`lon`, `lat`), or `None` where the map does not show it.
    pub(crate) fn pixel(&self, lon: f64, lat: f64) -> Option<[f64; 2]> {
        let [x, y] = self.projector.forward(lon, lat)?;
        let s = self.metres_per_pixel;
        Some([
            0.5 * self.width as f64 + (x - self.centre[0]) / s,
            0.5 * self.height as f64 - (y - self.centre[1]) / s,
        ])
    }

    /// The field's extent the map was made for: [west, east, south, north] degrees.
    pub(crate) fn extent(&self) -> [f64; 4] {
        let e = &self.extent;
        [e.west, e.east, e.south, e.north]
    }

    /// What the image metadata records.
    pub(crate) fn record(&self, img: &mut HdrImage) {
        img.set_meta("map_projection", self.projector.projection().describe());
        img.set_meta(
            "map_projection_centre",
            format!("{} {}", self.centre[0], self.centre[1]),
        );
        img.set_meta("map_projection_scale", format!("{}", self.metres_per_pixel));
    }
}
