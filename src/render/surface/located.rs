//! Pictures whose pixels are placed on the host: meshes (located cell by cell), grids on uneven
//! axes (nodes at their coordinates, not their indices) and maps in a projection. Each pixel's
//! sample points are placed where they lie — on a projected map through the projection's
//! inverse ([`ProjectedMap`]), on any other map linearly over the map's axes (the frame grid,
//! one node per pixel centre), on the globe where the camera's ray meets the unit sphere — and
//! the field gives its values there in f64: a mesh through its spatial index, a grid bilinear
//! in its coordinates ([`GridSampler`]). The values become the data targets the fringe pass
//! reads, so colours, fringes, colour bars and overlays are the GPU route's own and the phase
//! is exact at every pixel. Which grids take this route is decided by
//! [`SurfaceOptions::host_placed`] alone.

use super::gpu::{DataKey, DataTargets, SurfaceRenderer, SurfaceTiming};
use super::options::{SurfaceOptions, SurfaceView};
use super::overlay::Overlay;
use super::params::PropMeta;
use super::projected::ProjectedMap;
use super::GlobeFrame;
use crate::error::{Error, Result};
use crate::model::colormap::Colormap;
use crate::model::grid_sampler::GridSampler;
use crate::model::map_projection::LonLatBox;
use crate::model::{Grid, GridCoords, HdrImage, SphericalGrid};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

/// Where a host-placed picture's pixels lie: on a map in a projection, on a map linearly over
/// the axes of `frame` (one node per pixel centre), or on the globe (`frame` then stands for
/// the field's extent and places the default camera).
pub(crate) struct Placement {
    pub frame: Grid,
    pub projected: Option<Arc<ProjectedMap>>,
    pub width: u32,
    pub height: u32,
}

impl Placement {
    /// The frame whose axes a linear map records (for frames and overlays); `None` on a
    /// projected map, which has no straight axes.
    pub(crate) fn axes_frame(&self) -> Option<&Grid> {
        self.projected.is_none().then_some(&self.frame)
    }
}

/// Sample offsets within a pixel: its centre, or the 2 × 2 quarter points.
pub(crate) fn offsets(four: bool) -> &'static [[f64; 2]] {
    if four {
        &[[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]
    } else {
        &[[0.5, 0.5]]
    }
}

/// Each sample point of a `placement` picture in `view` — (longitude, latitude), or the map's
/// axis coordinates, NaN where it misses the map or the sphere — `offsets.len()` per pixel in
/// row-major order, and each pixel's shading (1 on maps; on the globe the headlight's mean over
/// the samples that meet the sphere, −1 where none does, the background).
pub(crate) fn sample_points(
    view: &SurfaceView,
    placement: &Placement,
    offsets: &[[f64; 2]],
    what: &str,
) -> Result<(Vec<[f64; 2]>, Vec<f32>)> {
    let (w, h) = (placement.width as usize, placement.height as usize);
    let per_row = w * offsets.len();
    let mut points = vec![[f64::NAN; 2]; h * per_row];
    let mut shade = vec![1f32; w * h];
    let rows = points.par_chunks_mut(per_row).zip(shade.par_chunks_mut(w));
    match (view, &placement.projected) {
        (SurfaceView::Map, Some(map)) => rows.enumerate().for_each(|(j, (row, _))| {
            for (k, p) in row.iter_mut().enumerate() {
                let (i, o) = (k / offsets.len(), offsets[k % offsets.len()]);
                if let Some(ll) = map.lonlat([i as f64 + o[0], j as f64 + o[1]]) {
                    *p = ll;
                }
            }
        }),
        (SurfaceView::Map, None) => {
            let (xs, ys) = (&placement.frame.x().values, &placement.frame.y().values);
            let step = |v: &[f64]| if v.len() > 1 { v[1] - v[0] } else { 1.0 };
            let (dx, dy) = (step(xs), step(ys));
            let y_down = placement.frame.y_down();
            let (west, top) = if y_down {
                (xs[0] - 0.5 * dx, ys[0] - 0.5 * dy)
            } else {
                (xs[0] - 0.5 * dx, ys[ys.len() - 1] + 0.5 * dy)
            };
            let dy = if y_down { dy } else { -dy };
            rows.enumerate().for_each(|(j, (row, _))| {
                for (k, p) in row.iter_mut().enumerate() {
                    let (i, o) = (k / offsets.len(), offsets[k % offsets.len()]);
                    *p = [west + (i as f64 + o[0]) * dx, top + (j as f64 + o[1]) * dy];
                }
            })
        }
        (SurfaceView::Globe(camera), _) => {
            rows.enumerate().for_each(|(j, (row, shades))| {
                let ray = camera.rays(w as u32, h as u32);
                for i in 0..w {
                    // Each sample's hit on the sphere; the pixel's shading is their mean (the
                    // centre's without antialiasing), −1 (background) when none hits.
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
            })
        }
        (other, _) => {
            return Err(Error::invalid(
                "view",
                format!(
                    "{what} is drawn on the map or the globe here, not in {}",
                    other.describe()
                ),
            ))
        }
    }
    Ok((points, shade))
}

/// The frame of a map over `bounds` ([x_lo, x_hi, y_lo, y_hi] of the axes `x`, `y`) with
/// `nx × ny` nodes at the centres of equal cells, holding `name` (missing, in `units`): the
/// axes the map's pixels, overlays and frames follow.
pub(crate) fn frame_grid(
    (x, y): (&GridCoords, &GridCoords),
    bounds: [f64; 4],
    (nx, ny): (usize, usize),
    (name, units): (&str, &str),
) -> Result<Grid> {
    let axis = |c: &GridCoords, lo: f64, hi: f64, n: usize| GridCoords {
        values: (0..n)
            .map(|k| lo + (k as f64 + 0.5) * (hi - lo) / n as f64)
            .collect(),
        ..c.clone()
    };
    let mut grid = Grid::with_coords(
        name,
        axis(x, bounds[0], bounds[1], nx),
        axis(y, bounds[2], bounds[3], ny),
        vec![(name.to_string(), vec![f64::NAN; nx * ny])],
        None,
    )?;
    grid.set_units(name, units)?;
    Ok(grid)
}

/// The pixels' values `planes` (f64, one plane per property, NaN where missing) with their
/// properties' `meta` and the pixels' `shade`, as the data targets step 2 reads: each value
/// less its property's d_ref, split into an f32 head and the f32 rest.
pub(crate) struct HostPixels {
    pub planes: Vec<Vec<f64>>,
    pub meta: Vec<PropMeta>,
    pub shade: Vec<f32>,
}

impl SurfaceRenderer {
    /// Step 1 on the host: `pixels` as data targets of a `width × height` picture in `opts`'
    /// view, with the map axes of `frame` on linear maps.
    pub(super) fn host_targets(
        &self,
        pixels: &HostPixels,
        frame: Option<&Grid>,
        opts: &SurfaceOptions,
        [width, height]: [u32; 2],
    ) -> Arc<DataTargets> {
        let n = pixels.shade.len();
        let (mut hi, mut rest) = (
            vec![0f32; n * pixels.planes.len()],
            vec![0f32; n * pixels.planes.len()],
        );
        let mut bits = vec![0u32; n];
        for (slot, (plane, meta)) in pixels.planes.iter().zip(&pixels.meta).enumerate() {
            let d_ref = meta.2;
            for (k, &d) in plane.iter().enumerate() {
                if d.is_finite() {
                    let off = d - d_ref;
                    let head = off as f32;
                    hi[slot * n + k] = head;
                    rest[slot * n + k] = (off - head as f64) as f32;
                    bits[k] |= 1 << slot;
                }
            }
        }
        let mask: Vec<[f32; 2]> = bits
            .iter()
            .zip(&pixels.shade)
            .map(|(&b, &s)| [b as f32, s])
            .collect();
        Arc::new(DataTargets {
            hi: self.input_buffer("host pixels hi", bytemuck::cast_slice(&hi)),
            rest: self.input_buffer("host pixels rest", bytemuck::cast_slice(&rest)),
            mask: self.input_buffer("host pixels mask", bytemuck::cast_slice(&mask)),
            width,
            height,
            props: pixels.meta.clone(),
            view: opts.view.describe(),
            axes: frame
                .filter(|_| opts.view == SurfaceView::Map)
                .and_then(crate::model::map_frame::MapAxes::of_grid),
            outputs: Mutex::new(None),
            values: Mutex::new(HashMap::new()),
        })
    }

    /// A grid drawn by placing its pixels on the host ([`SurfaceOptions::host_placed`]): its nodes at their
    /// coordinates on the map, the globe or a projected map.
    pub(super) fn render_placed(
        &self,
        grid: &Grid,
        opts: &SurfaceOptions,
        props: &[usize],
    ) -> Result<(Vec<HdrImage>, SurfaceTiming)> {
        let colormap = Colormap::by_name(opts.colormap_name())?;
        let placement = grid_placement(grid, opts)?;
        let (width, height) = (placement.width, placement.height);
        self.check_binding(width, height, 0, &format!("grid {:?}", grid.name()))?;
        let overlay = Overlay::plan_on(
            &placement.frame,
            Some(grid),
            opts,
            placement.projected.clone(),
        )?;
        let key = DataKey {
            grid: grid.id(),
            view: opts.view_key(),
            width,
            height,
            properties: props
                .iter()
                .map(|&p| grid.property_at(p).0.to_string())
                .collect(),
            relief: None,
            exaggeration: 0,
            samples: 1,
        };
        let t0 = std::time::Instant::now();
        let (data, data_ms) = match self.cached_targets(&key) {
            Some(t) => (t, None),
            None => {
                let pixels = grid_pixels(grid, opts, &placement, props)?;
                let t = self.host_targets(&pixels, placement.axes_frame(), opts, [width, height]);
                self.data_passes.fetch_add(1, Ordering::Relaxed);
                self.remember(key, t.clone());
                (t, Some(t0.elapsed().as_secs_f64() * 1e3))
            }
        };
        let (mut images, timing) = self.fringe_and_overlay(
            &data,
            props.len(),
            opts,
            &colormap,
            overlay.as_ref(),
            data_ms,
        )?;
        for img in &mut images {
            img.set_meta(
                "grid_placement",
                "nodes at their coordinates, bilinear between them (placed on the host)",
            );
            if let Some(map) = &placement.projected {
                map.record(img);
            }
        }
        Ok((images, timing))
    }
}

/// Where a host-placed grid's pixels lie for `opts` (see [`Placement`]).
fn grid_placement(grid: &Grid, opts: &SurfaceOptions) -> Result<Placement> {
    if matches!(opts.view, SurfaceView::Globe(_)) {
        GlobeFrame::check_geographic(grid)?;
    }
    let sampler = GridSampler::new(grid);
    let bounds = sampler.bounds();
    let (nx, ny) = sampler.resolving_counts(super::MAX_EVEN_NODES);
    let name = (grid.name(), "");
    if opts.projected() {
        let extent = true_extent(grid, bounds)?;
        let projection = opts.projection.expect("projected() says it is set");
        let map = ProjectedMap::new(&projection, &extent, opts, nx.max(ny))?;
        let frame = frame_grid((grid.x(), grid.y()), bounds, (2, 2), name)?;
        return Ok(Placement {
            frame,
            width: map.width,
            height: map.height,
            projected: Some(Arc::new(map)),
        });
    }
    let (width, height) = match opts.view {
        SurfaceView::Map => super::options::map_size_of(grid, bounds, (nx, ny), opts),
        _ => (opts.width.unwrap_or(512), opts.height.unwrap_or(512)),
    };
    let nodes = match opts.view {
        SurfaceView::Map => (width as usize, height as usize),
        _ => (nx.min(720), ny.min(360)),
    };
    let mut frame = frame_grid((grid.x(), grid.y()), bounds, nodes, name)?;
    frame.keep_placement_of(grid);
    Ok(Placement {
        frame,
        projected: None,
        width,
        height,
    })
}

/// The true longitude–latitude box of a geographic grid's `bounds` (its rotated box's corners
/// and edges turned to true coordinates on a rotated-pole grid); an error naming the grid when
/// its axes are not longitude and latitude.
fn true_extent(grid: &Grid, b: [f64; 4]) -> Result<LonLatBox> {
    if !grid.is_geographic() {
        return Err(Error::invalid(
            "projection",
            format!(
                "a projection places longitudes and latitudes; grid {:?} has {:?} ({}) and {:?} ({})",
                grid.name(),
                grid.x().name,
                grid.x().units,
                grid.y().name,
                grid.y().units
            ),
        ));
    }
    let Some(pole) = grid.rotated_pole() else {
        return Ok(LonLatBox {
            west: b[0],
            east: b[1],
            south: b[2],
            north: b[3],
        });
    };
    // The rotated box's edges in true coordinates: their latitude range, and the longitudes
    // unwrapped about the first corner's.
    let mut e = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut first = None;
    for k in 0..=400 {
        let t = k as f64 / 400.0;
        for (x, y) in [
            (b[0] + t * (b[1] - b[0]), b[2]),
            (b[0] + t * (b[1] - b[0]), b[3]),
            (b[0], b[2] + t * (b[3] - b[2])),
            (b[1], b[2] + t * (b[3] - b[2])),
        ] {
            let (lat, lon) = pole.to_true(y, x);
            let lon0 = *first.get_or_insert(lon);
            let lon = lon0 + (lon - lon0 + 180.0).rem_euclid(360.0) - 180.0;
            e = [e[0].min(lon), e[1].max(lon), e[2].min(lat), e[3].max(lat)];
        }
    }
    Ok(LonLatBox {
        west: e[0],
        east: e[1],
        south: e[2],
        north: e[3],
    })
}

/// The pixels of `grid`'s properties `props` in a `placement` picture: each pixel's centre
/// placed, and the grid's value there bilinear in its coordinates (true longitudes and
/// latitudes turned to a rotated grid's own on projected maps and the globe).
fn grid_pixels(
    grid: &Grid,
    opts: &SurfaceOptions,
    placement: &Placement,
    props: &[usize],
) -> Result<HostPixels> {
    let what = format!("grid {:?}", grid.name());
    let (mut points, shade) = sample_points(&opts.view, placement, offsets(false), &what)?;
    let true_coords = placement.projected.is_some() || matches!(opts.view, SurfaceView::Globe(_));
    if let (Some(pole), true) = (grid.rotated_pole(), true_coords) {
        points.par_iter_mut().for_each(|p| {
            if p[0].is_finite() {
                let (lat, lon) = pole.to_rotated(p[1], p[0]);
                *p = [lon, lat];
            }
        });
    }
    let sampler = GridSampler::new(grid);
    let planes = props
        .iter()
        .map(|&p| {
            points
                .par_iter()
                .map(|&[x, y]| {
                    if x.is_finite() {
                        sampler.value_at(p, x, y)
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        })
        .collect();
    let meta = props
        .iter()
        .map(|&p| {
            let range = grid.range(p);
            let d_ref = range.map_or(0.0, |(a, b)| 0.5 * (a + b));
            (
                grid.property_at(p).0.to_string(),
                grid.units(p).to_string(),
                d_ref,
                range,
                grid.long_name(p).to_string(),
            )
        })
        .collect();
    Ok(HostPixels {
        planes,
        meta,
        shade,
    })
}
