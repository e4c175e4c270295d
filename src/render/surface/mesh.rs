//! Meshes drawn cell by cell (`render_surface` of a [`MeshField`]). Each pixel is placed on the
//! sphere — on the map by its equirectangular axes over the mesh's extent, on the globe where the
//! camera's ray meets the unit sphere — and located in the mesh through its spatial index; the
//! value there, in f64, becomes the data targets the fringe pass reads, so colours, fringes,
//! colour bars, coastlines and graticules are the grid path's own, and the phase is exact at
//! every pixel. No grid lies between the mesh and the picture: a cell's edge is as sharp as the
//! pixels. With `antialias` each pixel takes the mean of four samples (a 2 × 2 pattern at its
//! quarter points) where at least two of them fall on the mesh, so cell edges and the mesh's
//! outline are smoothed; without it, the value at its centre.

use super::globe::GlobeFrame;
use super::gpu::{DataKey, DataTargets, SurfaceRenderer, SurfaceTiming};
use super::options::{SurfaceOptions, SurfaceView};
use super::overlay::Overlay;
use crate::error::{Error, Result};
use crate::model::colormap::Colormap;
use crate::model::mesh::MeshField;
use crate::model::{CoordKind, Grid, GridCoords, HdrImage, SphericalGrid};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

/// The long side of a mesh's map when neither `width` nor `height` is given, in pixels.
pub(crate) const DEFAULT_MAP_SIDE: u32 = 1024;

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

/// The picture of a mesh for `opts`: its size, and the latitude–longitude grid (values missing)
/// that stands for the map's axes — one node per pixel centre on the map, so coastlines,
/// graticules and frames follow the pixels — or on the globe the mesh's extent at 1°, which
/// places the default camera.
pub(crate) fn mesh_frame(field: &MeshField, opts: &SurfaceOptions) -> Result<(Grid, u32, u32)> {
    let ext = MapExtent::of(field)?;
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
    Ok((extent_grid(field, &ext, nx, ny)?, w, h))
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
    let axis = |name: &str, units: &str, kind, lo: f64, span: f64, n: usize| GridCoords {
        name: name.into(),
        units: units.into(),
        values: (0..n)
            .map(|k| lo + (k as f64 + 0.5) * span / n as f64)
            .collect(),
        kind,
    };
    let x = axis(
        "longitude",
        "degrees_east",
        CoordKind::Longitude,
        ext.west,
        ext.span,
        nx,
    );
    let y = axis(
        "latitude",
        "degrees_north",
        CoordKind::Latitude,
        ext.south,
        ext.height,
        ny,
    );
    let values = vec![f64::NAN; nx * ny];
    let mut grid = Grid::with_coords(
        field.name(),
        x,
        y,
        vec![(field.name().to_string(), values)],
        None,
    )?;
    grid.set_units(field.name(), field.units())?;
    Ok(grid)
}

/// What the pixels of a mesh's picture show: per pixel the value (NaN where missing) and the
/// shading (1 on the map; on the globe the headlight's mean over the samples that meet the
/// sphere, −1 where none does, the background).
pub(crate) struct MeshPixels {
    pub values: Vec<f64>,
    pub shade: Vec<f32>,
}

/// Sample offsets within a pixel: its centre, or the 2 × 2 quarter points.
fn offsets(antialias: bool) -> &'static [[f64; 2]] {
    if antialias {
        &[[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]
    } else {
        &[[0.5, 0.5]]
    }
}

/// The pixels of `field` in a `w × h` picture of `opts.view` over the map axes of `frame`
/// (see [`mesh_frame`]).
pub(crate) fn mesh_pixels(
    field: &MeshField,
    opts: &SurfaceOptions,
    frame: &Grid,
    w: u32,
    h: u32,
) -> Result<MeshPixels> {
    let offsets = offsets(opts.antialias);
    let n = w as usize * h as usize;
    // Each sample's (longitude, latitude), NaN where it misses the sphere; and each pixel's shading.
    let mut points = vec![[f64::NAN; 2]; n * offsets.len()];
    let mut shade = vec![1f32; n];
    match &opts.view {
        SurfaceView::Map => {
            let (xs, ys) = (&frame.x().values, &frame.y().values);
            let step = |v: &[f64]| if v.len() > 1 { v[1] - v[0] } else { 1.0 };
            let (dx, dy) = (step(xs), step(ys));
            let (west, north) = (xs[0] - 0.5 * dx, ys[ys.len() - 1] + 0.5 * dy);
            for j in 0..h as usize {
                for i in 0..w as usize {
                    for (s, o) in offsets.iter().enumerate() {
                        points[(j * w as usize + i) * offsets.len() + s] = [
                            west + (i as f64 + o[0]) * dx,
                            north - (j as f64 + o[1]) * dy,
                        ];
                    }
                }
            }
        }
        SurfaceView::Globe(camera) => {
            let per_row = w as usize * offsets.len();
            points
                .par_chunks_mut(per_row)
                .zip(shade.par_chunks_mut(w as usize))
                .enumerate()
                .for_each(|(j, (row, shades))| {
                    let ray = camera.rays(w, h);
                    for i in 0..w as usize {
                        // Each sample's hit on the sphere; the pixel's shading is their mean
                        // (the centre's without antialiasing), −1 (background) when none hits.
                        let (mut shade, mut hits) = (0.0, 0);
                        for (s, o) in offsets.iter().enumerate() {
                            let (eye, d) = ray([i as f64 + o[0], j as f64 + o[1]]);
                            if let Some((_, p)) = GlobeFrame::hit(eye, d) {
                                let (_, lat, lon) = SphericalGrid::from_world(p);
                                row[i * offsets.len() + s] = [lon, lat];
                                shade += GlobeFrame::shade(p, d);
                                hits += 1;
                            }
                        }
                        shades[i] = if hits > 0 {
                            (shade / hits as f64) as f32
                        } else {
                            -1.0
                        };
                    }
                });
        }
        other => {
            return Err(Error::invalid(
                "view",
                format!(
                    "a mesh is drawn on the map or the globe, not in {}; load_grid samples it onto a grid for 3-D views",
                    other.describe()
                ),
            ))
        }
    }
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
    Ok(MeshPixels { values, shade })
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
        let (frame, width, height) = mesh_frame(field, opts)?;
        self.check_binding(width, height, 0, &field.describe())?;
        let overlay =
            Overlay::plan(&frame, opts)?.map(|o| o.with_mesh(field, opts.cell_edges.as_ref()));
        let key = DataKey {
            grid: field.id(),
            view: opts.view.key(),
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
                let pixels = mesh_pixels(field, opts, &frame, width, height)?;
                let t = self.host_targets(field, &pixels, &frame, opts, [width, height]);
                self.data_passes.fetch_add(1, Ordering::Relaxed);
                self.remember(key, t.clone());
                (t, Some(t0.elapsed().as_secs_f64() * 1e3))
            }
        };
        let (mut images, timing) =
            self.fringe_and_overlay(&data, 1, opts, &colormap, overlay.as_ref(), data_ms)?;
        for img in &mut images {
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

    /// Step 1 for a mesh: the pixels' values (f64, relative to the middle of the field's range)
    /// and shading, computed on the host, as the data targets step 2 reads.
    fn host_targets(
        &self,
        field: &MeshField,
        pixels: &MeshPixels,
        frame: &Grid,
        opts: &SurfaceOptions,
        [width, height]: [u32; 2],
    ) -> Arc<DataTargets> {
        let range = field.range();
        let d_ref = range.map_or(0.0, |(a, b)| 0.5 * (a + b));
        let n = pixels.values.len();
        let (mut hi, mut rest) = (vec![0f32; n], vec![0f32; n]);
        let mut mask = vec![[0f32; 2]; n];
        for k in 0..n {
            let d = pixels.values[k];
            if d.is_finite() {
                let off = d - d_ref;
                hi[k] = off as f32;
                rest[k] = (off - hi[k] as f64) as f32;
            }
            mask[k] = [d.is_finite() as u8 as f32, pixels.shade[k]];
        }
        Arc::new(DataTargets {
            hi: self.input_buffer("mesh pixels hi", bytemuck::cast_slice(&hi)),
            rest: self.input_buffer("mesh pixels rest", bytemuck::cast_slice(&rest)),
            mask: self.input_buffer("mesh pixels mask", bytemuck::cast_slice(&mask)),
            width,
            height,
            props: vec![(
                field.name().to_string(),
                field.units().to_string(),
                d_ref,
                range,
            )],
            view: opts.view.describe(),
            axes: (opts.view == SurfaceView::Map)
                .then(|| crate::model::map_frame::MapAxes::of_grid(frame))
                .flatten(),
            outputs: Mutex::new(None),
            values: Mutex::new(HashMap::new()),
        })
    }
}
