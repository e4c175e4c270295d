//! Meshes drawn cell by cell (`render_surface` of a [`MeshField`]). Each pixel is placed on the
//! sphere ([`super::located`]) — on the map by its equirectangular axes over the mesh's extent or
//! through a projection, on the globe where the camera's ray meets the unit sphere — and located in the mesh through its spatial index; the
//! value there, in f64, becomes the data targets the fringe pass reads, so colours, fringes,
//! colour bars, coastlines and graticules are the grid path's own, and the phase is exact at
//! every pixel. No grid lies between the mesh and the picture: a cell's edge is as sharp as the
//! pixels. With `antialias` each pixel takes the mean of four samples (a 2 × 2 pattern at its
//! quarter points) where at least two of them fall on the mesh, so cell edges and the mesh's
//! outline are smoothed; without it, the value at its centre.

use super::gpu::{DataKey, SurfaceRenderer, SurfaceTiming};
use super::located::{frame_grid, offsets, sample_points, HostPixels, Placement};
use super::options::{SurfaceOptions, SurfaceView};
use super::overlay::Overlay;
use super::projected::{ProjectedMap, DEFAULT_MAP_SIDE};
use crate::error::{Error, Result};
use crate::model::colormap::Colormap;
use crate::model::map_projection::LonLatBox;
use crate::model::mesh::MeshField;
use crate::model::{CoordKind, Grid, GridCoords, HdrImage};
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// Where a mesh's map lies: its longitudes (west edge, span) and latitudes (south edge, span),
/// the mesh's extent in the convention that keeps it in one piece, all round when it reaches a
/// pole or spans more than half a turn.
#[derive(Clone, Copy, Debug)]
struct MapExtent {
    west: f64,
    span: f64,
    south: f64,
    height: f64,
}

impl MapExtent {
    fn of(field: &MeshField) -> Result<MapExtent> {
        let e = field.extent();
        let (west, span) = if e.polar || e.lon.1 - e.lon.0 > 180.0 {
            (-180.0, 360.0)
        } else {
            (e.lon.0, e.lon.1 - e.lon.0)
        };
        let (south, height) = if e.polar {
            (-90.0, 180.0)
        } else {
            (e.south, e.north - e.south)
        };
        if !(span > 0.0 && height > 0.0) {
            return Err(Error::invalid(
                "mesh",
                format!("{} covers no area to draw", field.describe()),
            ));
        }
        Ok(MapExtent {
            west,
            span,
            south,
            height,
        })
    }

    /// Map width over height: longitudes shrunk by the cosine of the middle latitude, as the
    /// grid path's equirectangular maps.
    fn aspect(&self) -> f64 {
        let mid = (self.south + 0.5 * self.height).to_radians();
        self.span * mid.cos().max(1e-6) / self.height
    }
}

impl MapExtent {
    fn lonlat_box(&self) -> LonLatBox {
        LonLatBox {
            west: self.west,
            east: self.west + self.span,
            south: self.south,
            north: self.south + self.height,
        }
    }
}

/// Where the pixels of a mesh's picture for `opts` lie: on a projected map, on the
/// equirectangular map over the mesh's extent (the frame's nodes at the pixel centres, so
/// coastlines, graticules and frames follow the pixels), or on the globe (the frame then the
/// mesh's extent at 1°, which places the default camera).
pub(crate) fn mesh_frame(field: &MeshField, opts: &SurfaceOptions) -> Result<Placement> {
    let ext = MapExtent::of(field)?;
    if let (true, Some(projection)) = (opts.projected(), opts.projection) {
        let map = ProjectedMap::new(&projection, &ext.lonlat_box(), opts, 0)?;
        return Ok(Placement {
            frame: extent_grid(field, &ext, 2, 2)?,
            width: map.width,
            height: map.height,
            projected: Some(Arc::new(map)),
        });
    }
    let side = |v: f64| v.round().clamp(1.0, crate::render::MAX_IMAGE_SIDE as f64) as u32;
    let (w, h) = match opts.view {
        SurfaceView::Map => {
            let aspect = ext.aspect();
            match (opts.width, opts.height) {
                (Some(w), Some(h)) => (w, h),
                (Some(w), None) => (w, side(w as f64 / aspect)),
                (None, Some(h)) => (side(h as f64 * aspect), h),
                (None, None) if aspect >= 1.0 => {
                    (DEFAULT_MAP_SIDE, side(DEFAULT_MAP_SIDE as f64 / aspect))
                }
                (None, None) => (side(DEFAULT_MAP_SIDE as f64 * aspect), DEFAULT_MAP_SIDE),
            }
        }
        _ => (opts.width.unwrap_or(512), opts.height.unwrap_or(512)),
    };
    let (nx, ny) = match opts.view {
        SurfaceView::Map => (w as usize, h as usize),
        _ => (
            (ext.span.ceil() as usize).max(2),
            (ext.height.ceil() as usize).max(2),
        ),
    };
    Ok(Placement {
        frame: extent_grid(field, &ext, nx, ny)?,
        projected: None,
        width: w,
        height: h,
    })
}

/// The mesh's extent as a latitude–longitude grid of about 1° (values missing): what places a
/// globe's default camera over it.
pub(crate) fn mesh_extent_grid(field: &MeshField) -> Result<Grid> {
    let ext = MapExtent::of(field)?;
    let n = |span: f64| (span.ceil() as usize).max(2);
    extent_grid(field, &ext, n(ext.span), n(ext.height))
}

/// `nx × ny` nodes at the centres of equal cells over `ext`, the field's one property missing.
fn extent_grid(field: &MeshField, ext: &MapExtent, nx: usize, ny: usize) -> Result<Grid> {
    let axis = |name: &str, units: &str, kind| GridCoords {
        name: name.into(),
        units: units.into(),
        values: Vec::new(),
        kind,
        edges: None,
    };
    frame_grid(
        (
            &axis("longitude", "degrees_east", CoordKind::Longitude),
            &axis("latitude", "degrees_north", CoordKind::Latitude),
        ),
        [
            ext.west,
            ext.west + ext.span,
            ext.south,
            ext.south + ext.height,
        ],
        (nx, ny),
        (field.name(), field.units()),
    )
}

/// The pixels of `field` in a `placement` picture of `opts.view`: with `antialias` the mean
/// of the four quarter points where at least two fall on the mesh, else the centre's value.
fn mesh_pixels(
    field: &MeshField,
    opts: &SurfaceOptions,
    placement: &Placement,
) -> Result<HostPixels> {
    let offsets = offsets(opts.antialias);
    let (points, shade) = sample_points(&opts.view, placement, offsets, "a mesh")
        .map_err(|_| {
            Error::invalid(
                "view",
                format!(
                    "a mesh is drawn on the map or the globe, not in {}; load_grid samples it onto a grid for 3-D views",
                    opts.view.describe()
                ),
            )
        })?;
    let located = field.values_at(&points);
    let values = located
        .chunks(offsets.len())
        .map(|s| {
            let (sum, count) = s
                .iter()
                .filter(|v| v.is_finite())
                .fold((0.0, 0usize), |(a, c), v| (a + v, c + 1));
            if count > 0 && 2 * count >= s.len() {
                sum / count as f64
            } else {
                f64::NAN
            }
        })
        .collect();
    let range = field.range();
    let d_ref = range.map_or(0.0, |(a, b)| 0.5 * (a + b));
    Ok(HostPixels {
        planes: vec![values],
        meta: vec![(
            field.name().to_string(),
            field.units().to_string(),
            d_ref,
            range,
            String::new(),
        )],
        shade,
    })
}

impl SurfaceRenderer {
    /// Draws a field on an unstructured mesh cell by cell on the map or the globe
    /// ([`super::mesh`]): one image, as [`Self::render`] gives for a grid.
    pub fn render_mesh(
        &self,
        field: &Arc<MeshField>,
        opts: &SurfaceOptions,
    ) -> Result<Vec<HdrImage>> {
        Ok(self.render_mesh_timed(field, opts)?.0)
    }

    /// As [`Self::render_mesh`], also saying how long each step took.
    pub(crate) fn render_mesh_timed(
        &self,
        field: &Arc<MeshField>,
        opts: &SurfaceOptions,
    ) -> Result<(Vec<HdrImage>, SurfaceTiming)> {
        opts.validate()?;
        if opts.properties.len() > 1 || opts.properties.iter().any(|p| p != field.name()) {
            return Err(Error::invalid(
                "property",
                format!(
                    "{:?}: a mesh field has one property, {:?}",
                    opts.properties,
                    field.name()
                ),
            ));
        }
        if !matches!(opts.view, SurfaceView::Map | SurfaceView::Globe(_)) {
            return self.render_mesh_sampled(field, opts);
        }
        let colormap = Colormap::by_name(opts.colormap_name())?;
        let placement = mesh_frame(field, opts)?;
        let (width, height) = (placement.width, placement.height);
        self.check_binding(width, height, 0, &field.describe())?;
        let overlay = Overlay::plan_on(&placement.frame, None, opts, placement.projected.clone())?
            .map(|o| o.with_mesh(field, opts.cell_edges.as_ref()));
        let key = DataKey {
            grid: field.id(),
            view: opts.view_key(),
            width,
            height,
            properties: vec![field.name().to_string()],
            relief: None,
            exaggeration: 0,
            samples: if opts.antialias { 4 } else { 1 },
        };
        let t0 = std::time::Instant::now();
        let (data, data_ms) = match self.cached_targets(&key) {
            Some(t) => (t, None),
            None => {
                let pixels = mesh_pixels(field, opts, &placement)?;
                let t = self.host_targets(&pixels, placement.axes_frame(), opts, [width, height]);
                self.data_passes.fetch_add(1, Ordering::Relaxed);
                self.remember(key, t.clone());
                (t, Some(t0.elapsed().as_secs_f64() * 1e3))
            }
        };
        let (mut images, timing) =
            self.fringe_and_overlay(&data, 1, opts, &colormap, overlay.as_ref(), data_ms)?;
        for img in &mut images {
            if let Some(map) = &placement.projected {
                map.record(img);
            }
            img.set_meta("mesh", field.describe());
            img.set_meta(
                "mesh_samples",
                if opts.antialias {
                    "mean of 4 points per pixel (2 x 2), where at least 2 fall on the mesh"
                } else {
                    "the pixel's centre"
                },
            );
        }
        Ok((images, timing))
    }

    /// A 3-D view of a mesh, over a relief: through the grid the mesh samples onto at its cells'
    /// median size (a relief needs heights at nodes), drawn as any grid.
    fn render_mesh_sampled(
        &self,
        field: &Arc<MeshField>,
        opts: &SurfaceOptions,
    ) -> Result<(Vec<HdrImage>, SurfaceTiming)> {
        if opts.cell_edges.is_some() {
            return Err(Error::invalid(
                "cell_edges",
                format!(
                    "cell edges are drawn on the map and the globe; {} draws the mesh sampled onto a grid",
                    opts.view.describe()
                ),
            ));
        }
        let grid = crate::datasets::conventions::mesh::sampled_grid(field)?;
        let (mut images, timing) = self.render_timed(&grid, opts)?;
        for img in &mut images {
            img.set_meta("mesh", field.describe());
            img.set_meta(
                "mesh_samples",
                format!(
                    "sampled onto a {}x{} latitude-longitude grid at the cells' median size",
                    grid.nx(),
                    grid.ny()
                ),
            );
        }
        Ok((images, timing))
    }
}
