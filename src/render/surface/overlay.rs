//! Coastlines and graticules over map and globe renders, drawn into the HDR image after the
//! fringe pass, so exposure and tone mapping treat them like the field: lines of a linear RGB
//! colour, antialiased by their coverage of each pixel (a pixel's centre within width/2 of the
//! line is covered, with a one-pixel ramp outside), clipped to the image. On a map the lines
//! follow the map's equirectangular axes (repeated 360° either side, so 0–360° grids get them
//! too); on the globe they are projected by the view's camera and drawn only where the sphere
//! faces the eye, so the far hemisphere stays hidden. Renders of spherical volumes get them too
//! ([`Overlay::for_volume`]): on the volume's outer sphere, hidden on its far side and where the
//! domain has no outer surface (outside a regional wedge, or where a cut removes it), and
//! composited over the render's premultiplied colour. The coastlines are Natural Earth's
//! ([`crate::datasets::coastlines`]).

use super::options::{CoastlineStyle, SurfaceOptions, SurfaceView};
use super::projected::ProjectedMap;
use crate::datasets::coastlines::{coastlines, CoastResolution};
use crate::error::{Error, Result};
use crate::model::geometry::segment_distance;
use crate::model::map_frame::MapAxes;
use crate::model::mesh::ring::{ring_into, Ring};
use crate::model::mesh::MeshField;
use crate::model::{Camera, Cut, DepthRings, Grid, HdrImage, SphericalGrid, Volume};
use std::borrow::Cow;
use std::sync::Arc;

/// The graticule's colour (linear mid grey) and width in pixels.
const GRATICULE_COLOUR: [f64; 3] = [0.2; 3];
const GRATICULE_WIDTH: f64 = 1.0;
/// The depth rings' width in pixels (black).
const RING_WIDTH: f64 = 1.5;
/// Widest line, in pixels.
pub(crate) const MAX_LINE_WIDTH: f64 = 64.0;
/// Longest piece of a line drawn straight on the globe, in degrees.
const GLOBE_STEP: f64 = 0.5;

impl CoastlineStyle {
    /// A colour by name or `#rrggbb`, as the option `option` (`coastlines`, `cell_edges`) gives
    /// it in its `colour`.
    pub(crate) fn with_colour(mut self, option: &str, name: &str) -> Result<Self> {
        self.linear = crate::model::colormap::named_colour(&format!("{option}.colour"), name)?;
        self.colour = name.trim().to_string();
        Ok(self)
    }

    /// That the width suits the option `option`'s lines.
    pub(crate) fn validate(&self, option: &str) -> Result<()> {
        check_width(&format!("{option}.width"), self.width)
    }
}

fn check_width(field: &str, w: f64) -> Result<()> {
    if w.is_finite() && w > 0.0 && w <= MAX_LINE_WIDTH {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("expected a line width > 0 and at most {MAX_LINE_WIDTH} pixels, got {w}"),
        ))
    }
}

/// Where a (longitude, latitude) lands in the image.
enum Projector {
    Map(MapAxes),
    Globe(Camera),
    /// A spherical volume's outer surface.
    Shell(Box<ShellSurface>),
    /// A map in a projection.
    Projected(Arc<ProjectedMap>),
}

/// The outer surface of a spherical volume a render shows: its grid (radius, extent) and cut.
struct ShellSurface {
    camera: Camera,
    grid: SphericalGrid,
    cut: Option<Cut>,
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

/// One layer of lines in (longitude, latitude) degrees, with its colour and width.
struct Layer<'a> {
    lines: Vec<&'a [[f64; 2]]>,
    owned: Vec<Vec<[f64; 2]>>,
    linear: [f64; 3],
    width: f64,
}

/// What a surface render draws over its images: checked against the grid and view before any
/// GPU work, drawn on each image after the fringe pass.
pub(crate) struct Overlay {
    projector: Projector,
    coast: Option<(CoastlineStyle, CoastResolution)>,
    graticule: Option<f64>,
    /// Depths of lines across a section's map (its y axis's unit).
    rings: Vec<f64>,
    /// A map of a rotated-pole grid, or a render of a rotated-pole volume: lines are drawn at
    /// their rotated coordinates.
    rotation: Option<crate::model::RotatedPole>,
    /// A mesh's cell outlines and their style.
    edges: Option<(CoastlineStyle, Arc<MeshField>)>,
}

impl Overlay {
    /// The lines `coastlines` and `graticule` ask for over renders of `volume` by `camera` with
    /// the cut `cut`, or `None`; an error naming the option when the volume is not spherical.
    /// The coastlines' scale is by the domain's extent, as on a map.
    pub(crate) fn for_volume(
        volume: &Volume,
        camera: &Camera,
        cut: Option<&Cut>,
        coastlines: Option<&CoastlineStyle>,
        graticule: Option<f64>,
    ) -> Result<Option<Overlay>> {
        let field = match (coastlines, graticule) {
            (None, None) => return Ok(None),
            (Some(_), _) => "coastlines",
            (None, Some(_)) => "graticule",
        };
        let crate::model::Geometry::Spherical(g) = &volume.geometry else {
            return Err(Error::invalid(
                field,
                format!(
                    "lines are drawn on the outer surface of spherical volumes; {} is a box",
                    volume.name
                ),
            ));
        };
        let extent = if g.lon_wraps {
            360.0
        } else {
            (g.longitude.hi - g.longitude.lo).max(g.latitude.hi - g.latitude.lo)
        };
        let coast = coastlines.map(|style| {
            let res = style
                .resolution
                .unwrap_or(CoastResolution::for_extent(extent));
            (style.clone(), res)
        });
        Ok(Some(Overlay {
            projector: Projector::Shell(Box::new(ShellSurface {
                camera: *camera,
                grid: (**g).clone(),
                cut: cut.cloned(),
            })),
            coast,
            graticule,
            rings: Vec::new(),
            // A rotated-pole volume is drawn in its grid's frame: the lines are moved into it.
            rotation: g.rotated_pole,
            edges: None,
        }))
    }

    /// The depth rings `rings` across the map of the section `grid` (a grid whose y is depth),
    /// in its depth unit: the Earth's within its depths, given ones each inside them.
    fn section_rings(grid: &Grid, rings: &DepthRings, view: &SurfaceView) -> Result<Overlay> {
        let field = "depth_rings";
        let axes = MapAxes::of_grid(grid).filter(|_| grid.y_down());
        let (Some(axes), SurfaceView::Map) = (axes, view) else {
            return Err(Error::invalid(
                field,
                format!(
                    "rings are drawn across map views of sections (a grid on depth); grid {:?} in {} has no depth axis",
                    grid.name(),
                    view.describe()
                ),
            ));
        };
        let (lo, hi) = (axes.y.lo, axes.y.hi);
        let depths = match rings {
            DepthRings::Depths(d) => {
                if let Some(bad) = d.iter().find(|d| !(**d >= lo && **d <= hi)) {
                    return Err(Error::invalid(
                        field,
                        format!("depth {bad} is outside the section's depths {lo} to {hi}"),
                    ));
                }
                d.clone()
            }
            DepthRings::Earth => DepthRings::earth_in(&axes.y.units)
                .ok_or_else(|| {
                    Error::invalid(
                        field,
                        format!(
                            "the Earth's rings need depths in km or m, not {:?}; give the depths",
                            axes.y.units
                        ),
                    )
                })?
                .into_iter()
                .filter(|d| *d >= lo && *d <= hi)
                .collect(),
        };
        Ok(Overlay {
            projector: Projector::Map(axes),
            coast: None,
            graticule: None,
            rings: depths,
            rotation: None,
            edges: None,
        })
    }

    /// The overlay `opts` asks for on `grid`, or `None`; an error naming the option when the
    /// grid or view cannot carry one (lines need longitude and latitude in a map or globe view).
    pub(crate) fn plan(grid: &Grid, opts: &SurfaceOptions) -> Result<Option<Overlay>> {
        Self::plan_on(grid, opts, None)
    }

    /// As [`Self::plan`], on the projected map `projected` when one is given (`grid` then
    /// stands for the field's axes).
    pub(crate) fn plan_on(
        grid: &Grid,
        opts: &SurfaceOptions,
        projected: Option<Arc<ProjectedMap>>,
    ) -> Result<Option<Overlay>> {
        let field = match (&opts.coastlines, opts.graticule, &opts.cell_edges) {
            (None, None, None) => {
                return match &opts.depth_rings {
                    Some(r) => Self::section_rings(grid, r, &opts.view).map(Some),
                    None => Ok(None),
                }
            }
            (Some(_), _, _) => "coastlines",
            (None, Some(_), _) => "graticule",
            (None, None, Some(_)) => "cell_edges",
        };
        let axes = MapAxes::of_grid(grid).filter(|_| grid.is_geographic());
        let projector = match (&opts.view, axes, projected) {
            (SurfaceView::Map, _, Some(map)) => Projector::Projected(map),
            (SurfaceView::Map, Some(axes), None) => Projector::Map(axes),
            (SurfaceView::Globe(c), _, _) => Projector::Globe(*c),
            _ => {
                return Err(Error::invalid(
                    field,
                    format!(
                        "lines are drawn on map and globe views of evenly spaced longitude/latitude grids; grid {:?} in {} has none",
                        grid.name(),
                        opts.view.describe()
                    ),
                ))
            }
        };
        let coast = opts.coastlines.clone().map(|style| {
            let res = style.resolution.unwrap_or(match &projector {
                Projector::Map(a) => {
                    CoastResolution::for_extent((a.x.hi - a.x.lo).max(a.y.hi - a.y.lo))
                }
                Projector::Projected(map) => {
                    let [w, e, s, n] = map.extent();
                    CoastResolution::for_extent((e - w).max(n - s))
                }
                Projector::Globe(_) | Projector::Shell(_) => CoastResolution::Coarse,
            });
            (style, res)
        });
        if opts.depth_rings.is_some() {
            return Err(Error::invalid(
                "depth_rings",
                "rings are drawn across sections, which have no coastlines or graticule",
            ));
        }
        let rotation = match &projector {
            Projector::Map(_) => grid.rotated_pole().copied(),
            _ => None,
        };
        Ok(Some(Overlay {
            projector,
            coast,
            graticule: opts.graticule,
            rings: Vec::new(),
            rotation,
            edges: None,
        }))
    }

    /// This overlay with `field`'s cell outlines when `style` asks for them.
    pub(crate) fn with_mesh(
        mut self,
        field: &Arc<MeshField>,
        style: Option<&CoastlineStyle>,
    ) -> Self {
        self.edges = style.map(|s| (s.clone(), field.clone()));
        self
    }

    /// Draws a mesh's cell edges, the graticule, then the coastlines, then the depth rings into
    /// `img`, and records them in its metadata.
    pub(crate) fn draw(&self, img: &mut HdrImage) {
        if let Some((style, field)) = &self.edges {
            self.draw_edges(img, field, style);
            img.set_meta(
                "cell_edges",
                format!("{}, {} px", style.colour, style.width),
            );
        }
        if let (Projector::Map(axes), false) = (&self.projector, self.rings.is_empty()) {
            let layer = Layer {
                lines: Vec::new(),
                owned: self
                    .rings
                    .iter()
                    .map(|&d| vec![[axes.x.lo, d], [axes.x.hi, d]])
                    .collect(),
                linear: [0.0; 3],
                width: RING_WIDTH,
            };
            self.draw_layer(img, &layer);
            let list: Vec<String> = self.rings.iter().map(|d| format!("{d}")).collect();
            img.set_meta(
                "depth_rings",
                format!("{} {}", list.join(", "), axes.y.units),
            );
        }
        if let Some(step) = self.graticule {
            let layer = Layer {
                lines: Vec::new(),
                owned: graticule_lines(step),
                linear: GRATICULE_COLOUR,
                width: GRATICULE_WIDTH,
            };
            self.draw_layer(img, &layer);
            img.set_meta("graticule", format!("every {step} degrees"));
        }
        if let Some((style, res)) = &self.coast {
            let layer = Layer {
                lines: coastlines(*res).iter().map(Vec::as_slice).collect(),
                owned: Vec::new(),
                linear: style.linear,
                width: style.width,
            };
            self.draw_layer(img, &layer);
            img.set_meta(
                "coastlines",
                format!(
                    "Natural Earth {} (public domain), {}, {} px",
                    res.name(),
                    style.colour,
                    style.width
                ),
            );
        }
    }

    fn draw_layer(&self, img: &mut HdrImage, layer: &Layer) {
        let lines = layer
            .lines
            .iter()
            .copied()
            .chain(layer.owned.iter().map(Vec::as_slice))
            .map(Cow::Borrowed);
        self.draw_lines(img, lines, layer.linear, layer.width);
    }

    /// With `style`, the outline of every cell of `field`'s mesh as its ring runs (a ring round
    /// a pole without its closure along the pole).
    fn draw_edges(&self, img: &mut HdrImage, field: &MeshField, style: &CoastlineStyle) {
        let mesh = field.mesh();
        let mut ring = Ring::default();
        let lines = (0..mesh.faces()).filter_map(move |f| {
            if !ring_into(mesh, f, &mut ring) {
                return None;
            }
            let points = &ring.points;
            let mut line = if ring.cap {
                points[..points.len() - 2].to_vec()
            } else {
                points.clone()
            };
            if !ring.cap {
                line.push(points[0]);
            }
            Some(Cow::Owned(line))
        });
        self.draw_lines(img, lines, style.linear, style.width);
    }

    /// Strokes `lines` (longitude, latitude) `width` pixels wide in the linear colour `linear`.
    fn draw_lines<'a>(
        &self,
        img: &mut HdrImage,
        lines: impl Iterator<Item = Cow<'a, [[f64; 2]]>>,
        linear: [f64; 3],
        width: f64,
    ) {
        let (w, h) = (img.width, img.height);
        let mut cover = vec![0f32; (w as usize) * (h as usize)];
        // Longitudes jump by a turn at the dateline; a section's distance does not wrap.
        let wraps = self.rings.is_empty();
        for line in lines {
            // On a rotated-pole map the true lines are drawn where they lie on the rotated sphere.
            let line: Cow<[[f64; 2]]> = match &self.rotation {
                Some(r) => line
                    .iter()
                    .map(|&[lon, lat]| {
                        let (rlat, rlon) = r.to_rotated(lat, lon);
                        [rlon, rlat]
                    })
                    .collect(),
                None => line,
            };
            for seg in line.windows(2) {
                if wraps && (seg[1][0] - seg[0][0]).abs() > 180.0 {
                    continue;
                }
                for [a, b] in self.segment_pixels(seg[0], seg[1], w, h) {
                    stroke(&mut cover, w, h, a, b, width);
                }
            }
        }
        let c = linear.map(|v| v as f32);
        if matches!(self.projector, Projector::Shell(_)) {
            // A volume render's colour is premultiplied (over its background): the line goes
            // over it.
            for (p, &a) in img.pixels.iter_mut().zip(&cover) {
                if a > 0.0 {
                    for k in 0..3 {
                        p[k] = c[k] * a + p[k] * (1.0 - a);
                    }
                    p[3] = a + p[3] * (1.0 - a);
                }
            }
            return;
        }
        for (p, &a) in img.pixels.iter_mut().zip(&cover) {
            if a > 0.0 {
                let alpha = a + p[3] * (1.0 - a);
                for k in 0..3 {
                    p[k] = (c[k] * a + p[k] * p[3] * (1.0 - a)) / alpha;
                }
                p[3] = alpha;
            }
        }
    }

    /// The pieces, in pixel coordinates, that the segment a–b (degrees) is drawn as: on a map
    /// the straight segment and its copies 360° east and west; on the globe the segment cut
    /// into pieces of at most [`GLOBE_STEP`], each kept when both its ends face the eye.
    fn segment_pixels(&self, a: [f64; 2], b: [f64; 2], w: u32, h: u32) -> Vec<[[f64; 2]; 2]> {
        match &self.projector {
            Projector::Map(axes) => {
                let px = |p: [f64; 2], shift: f64| {
                    let down = if axes.y_down {
                        p[1] - axes.y.lo
                    } else {
                        axes.y.hi - p[1]
                    };
                    [
                        (p[0] + shift - axes.x.lo) / (axes.x.hi - axes.x.lo) * w as f64,
                        down / (axes.y.hi - axes.y.lo) * h as f64,
                    ]
                };
                let shifts: &[f64] = if self.rings.is_empty() {
                    &[-360.0, 0.0, 360.0]
                } else {
                    &[0.0]
                };
                shifts.iter().map(|&s| [px(a, s), px(b, s)]).collect()
            }
            Projector::Projected(map) => {
                // Cut into pieces of at most GLOBE_STEP, each kept when both ends show and it
                // does not jump across the map (a seam, where the projection cuts the sphere).
                let n = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()) / GLOBE_STEP).ceil();
                let n = (n as usize).max(1);
                let point = |k: usize| {
                    let t = k as f64 / n as f64;
                    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
                };
                let jump = 0.25 * (w.max(h) as f64);
                (0..n)
                    .filter_map(|k| {
                        let (p, q) = (point(k), point(k + 1));
                        if map.projector.crosses_seam(p[0], q[0]) {
                            return None;
                        }
                        Some([map.pixel(p[0], p[1])?, map.pixel(q[0], q[1])?])
                    })
                    .filter(|[p, q]| (p[0] - q[0]).abs() < jump && (p[1] - q[1]).abs() < jump)
                    .collect()
            }
            Projector::Globe(_) | Projector::Shell(_) => {
                let n = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()) / GLOBE_STEP).ceil();
                let n = (n as usize).max(1);
                let at = |k: usize| {
                    let t = k as f64 / n as f64;
                    let p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                    match &self.projector {
                        Projector::Shell(shell) => shell.pixel(p, w, h),
                        Projector::Globe(cam) => globe_pixel(cam, p, w, h),
                        Projector::Map(_) | Projector::Projected(_) => None,
                    }
                };
                (0..n).filter_map(|k| Some([at(k)?, at(k + 1)?])).collect()
            }
        }
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

/// Meridians and parallels at the multiples of `step` degrees, as polylines of 1° pieces (so
/// they curve on the globe); parallels stop short of the poles.
fn graticule_lines(step: f64) -> Vec<Vec<[f64; 2]>> {
    let multiples = |lo: f64, hi: f64| {
        let k0 = (lo / step).ceil() as i64;
        let k1 = (hi / step).floor() as i64;
        (k0..=k1).map(|k| k as f64 * step).collect::<Vec<_>>()
    };
    let run = |lo: f64, hi: f64| {
        let n = (hi - lo).ceil() as usize;
        (0..=n).map(move |i| lo + (hi - lo) * i as f64 / n as f64)
    };
    let mut lines = Vec::new();
    for lon in multiples(-180.0, 180.0 - 1e-9) {
        lines.push(run(-90.0, 90.0).map(|lat| [lon, lat]).collect());
    }
    for lat in multiples(-90.0 + 1e-9, 90.0 - 1e-9) {
        lines.push(run(-180.0, 180.0).map(|lon| [lon, lat]).collect());
    }
    lines
}

/// Adds the coverage of the segment a–b (pixel coordinates) of `width` pixels to `cover`: for
/// each pixel centre at distance d, clamp(width/2 + 1/2 − d, 0, 1), the largest over segments,
/// so joints are not covered twice.
fn stroke(cover: &mut [f32], w: u32, h: u32, a: [f64; 2], b: [f64; 2], width: f64) {
    let reach = 0.5 * width + 0.5;
    let lo = |u: f64, v: f64| (u.min(v) - reach).floor().max(0.0);
    let hi = |u: f64, v: f64, n: u32| (u.max(v) + reach).ceil().min(n as f64);
    let (x0, x1) = (lo(a[0], b[0]), hi(a[0], b[0], w));
    let (y0, y1) = (lo(a[1], b[1]), hi(a[1], b[1], h));
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    for j in y0 as usize..y1 as usize {
        for i in x0 as usize..x1 as usize {
            let d = segment_distance([i as f64 + 0.5, j as f64 + 0.5], a, b);
            let c = (reach - d).clamp(0.0, 1.0) as f32;
            let slot = &mut cover[j * w as usize + i];
            *slot = slot.max(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::map_frame::MapAxis;

    fn axis(lo: f64, hi: f64) -> MapAxis {
        MapAxis {
            name: String::new(),
            units: "degrees".into(),
            lo,
            hi,
        }
    }

    fn white(w: u32, h: u32) -> HdrImage {
        HdrImage::from_pixels(w, h, vec![[1.0; 4]; (w * h) as usize])
    }

    fn coast(projector: Projector, res: CoastResolution) -> Overlay {
        Overlay {
            projector,
            coast: Some((CoastlineStyle::default(), res)),
            graticule: None,
            rings: Vec::new(),
            rotation: None,
            edges: None,
        }
    }

    /// Pixels the lines darkened, as (column, row).
    fn lines(img: &HdrImage) -> Vec<(usize, usize)> {
        let w = img.width as usize;
        (0..img.pixels.len())
            .filter(|&k| img.pixels[k][0] < 1.0)
            .map(|k| (k % w, k / w))
            .collect()
    }

    fn near(lines: &[(usize, usize)], x: f64, y: f64, r: f64) -> bool {
        lines
            .iter()
            .any(|&(i, j)| (i as f64 + 0.5 - x).hypot(j as f64 + 0.5 - y) <= r)
    }

    /// A rotated-pole map draws a true meridian where it lies in rotated coordinates: the
    /// graticule's 20°E meridian crosses the EURO-CORDEX map's rotated latitude 5° near rotated
    /// longitude 1.1° (pyproj: 1.13° at 55.5°N), where a plain map has no line.
    #[test]
    fn rotated_maps_draw_true_lines_at_their_rotated_coordinates() {
        let pole = crate::model::RotatedPole::new(39.25, -162.0, 0.0).unwrap();
        // 10 pixels per degree over rotated [-15, 15] x [-10, 10].
        let (w, h) = (300u32, 200u32);
        let mut overlay = Overlay {
            projector: Projector::Map(MapAxes {
                x: axis(-15.0, 15.0),
                y: axis(-10.0, 10.0),
                y_down: false,
                rotated: true,
            }),
            coast: None,
            graticule: Some(10.0),
            rings: Vec::new(),
            rotation: Some(pole),
            edges: None,
        };
        let mut img = white(w, h);
        overlay.draw(&mut img);
        let drawn = lines(&img);
        // Where the true meridian 20°E meets rotated latitude 5°: bisect on latitude.
        let (mut lo, mut hi) = (30.0, 70.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if pole.to_rotated(mid, 20.0).0 > 5.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let (_, rlon) = pole.to_rotated(lo, 20.0);
        assert!((rlon - 1.13).abs() < 0.05, "{rlon}");
        let x = (rlon + 15.0) * 10.0;
        assert!(near(&drawn, x, 50.0, 1.5), "no line near column {x}");
        // Without the rotation the same lines lie elsewhere: nothing at that point.
        overlay.rotation = None;
        let mut plain = white(w, h);
        overlay.draw(&mut plain);
        assert!(!near(&lines(&plain), x, 50.0, 3.0));
    }

    #[test]
    fn map_coast_pixels_lie_on_the_projected_coast_and_miss_land_and_sea() {
        // 2 pixels per degree over the world: lon → (lon + 180)·2, lat → (90 − lat)·2.
        let (w, h) = (720u32, 360u32);
        let map = Projector::Map(MapAxes {
            x: axis(-180.0, 180.0),
            y: axis(-90.0, 90.0),
            y_down: false,
            rotated: false,
        });
        let mut img = white(w, h);
        coast(map, CoastResolution::Coarse).draw(&mut img);
        assert!(img.meta("coastlines").unwrap().contains("110m"));
        let px = |p: &[f64; 2]| [(p[0] + 180.0) * 2.0, (90.0 - p[1]) * 2.0];
        // The coast and its copies 360° either side (a line at −180° is also one at 180°).
        let segs: Vec<[[f64; 2]; 2]> = coastlines(CoastResolution::Coarse)
            .iter()
            .flat_map(|l| l.windows(2).map(|s| [px(&s[0]), px(&s[1])]))
            .flat_map(|[a, b]| {
                [-720.0, 0.0, 720.0].map(|dx| [[a[0] + dx, a[1]], [b[0] + dx, b[1]]])
            })
            .collect();
        let drawn = lines(&img);
        assert!(drawn.len() > 5000, "{}", drawn.len());
        for &(i, j) in &drawn {
            let c = [i as f64 + 0.5, j as f64 + 0.5];
            let d = segs
                .iter()
                .map(|s| segment_distance(c, s[0], s[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 1.0, "pixel ({i}, {j}) is {d} px from the coast");
        }
        // Every vertex's own pixel is drawn.
        for p in coastlines(CoastResolution::Coarse).iter().flatten() {
            let [x, y] = px(p);
            let (i, j) = ((x as u32).min(w - 1), (y as u32).min(h - 1));
            assert!(img.pixels[(j * w + i) as usize][0] < 1.0, "{p:?}");
        }
        // Cape of Good Hope on the line; the Sahara and the mid-Atlantic 10 pixels from any.
        assert!(near(
            &drawn,
            (18.47 + 180.0) * 2.0,
            (90.0 + 34.36) * 2.0,
            1.5
        ));
        assert!(!near(&drawn, 200.0 * 2.0, 67.0 * 2.0, 10.0));
        assert!(!near(&drawn, 150.0 * 2.0, 90.0 * 2.0, 10.0));
    }

    #[test]
    fn regional_maps_take_the_fine_scale_and_a_0_to_360_map_gets_the_lines() {
        assert_eq!(CoastResolution::for_extent(10.0), CoastResolution::Fine);
        assert_eq!(CoastResolution::for_extent(360.0), CoastResolution::Coarse);
        // 16–26°E, 30–40°S at 40 px per degree with the 50m outline: the cape within 2 px.
        let map = Projector::Map(MapAxes {
            x: axis(16.0, 26.0),
            y: axis(-40.0, -30.0),
            y_down: false,
            rotated: false,
        });
        let mut img = white(400, 400);
        coast(map, CoastResolution::Fine).draw(&mut img);
        let drawn = lines(&img);
        assert!(near(&drawn, 2.47 * 40.0, 4.36 * 40.0, 2.0));
        // A 0–360° map draws the Americas (west of 0°) shifted by 360°: 70°W 0°N → 290°E,
        // the coast of Ecuador at 80°W lies at 280°E.
        let map = Projector::Map(MapAxes {
            x: axis(0.0, 360.0),
            y: axis(-90.0, 90.0),
            y_down: false,
            rotated: false,
        });
        let mut img = white(360, 180);
        coast(map, CoastResolution::Coarse).draw(&mut img);
        assert!(near(&lines(&img), 280.0, 90.0, 2.0));
    }

    #[test]
    fn globe_hides_the_far_hemisphere() {
        let cam = Camera::geo([0.0; 3], 0.0, 0.0, 3.0, 35.0).unwrap();
        let (w, h) = (256u32, 256u32);
        let mut img = white(w, h);
        coast(Projector::Globe(cam), CoastResolution::Coarse).draw(&mut img);
        let drawn = lines(&img);
        let unit = |p: &[f64; 2]| {
            let (lo, la) = (p[0].to_radians(), p[1].to_radians());
            [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
        };
        // The eye at (3, 0, 0): a point faces it where 3x > 1.
        let all: Vec<&[f64; 2]> = coastlines(CoastResolution::Coarse)
            .iter()
            .flatten()
            .collect();
        let front: Vec<[f64; 2]> = all
            .iter()
            .filter(|p| 3.0 * unit(p)[0] > 1.0)
            .filter_map(|p| cam.project(unit(p), w, h))
            .collect();
        let mut checked = 0;
        for p in all.iter().filter(|p| 3.0 * unit(p)[0] < 0.9) {
            let [x, y] = cam.project(unit(p), w, h).unwrap();
            if front.iter().all(|f| (f[0] - x).hypot(f[1] - y) > 6.0) {
                checked += 1;
                assert!(
                    !near(&drawn, x, y, 2.0),
                    "far-side {p:?} drawn at ({x}, {y})"
                );
            }
        }
        assert!(checked > 100, "{checked}");
        let cape = cam.project(unit(&[18.47, -34.36]), w, h).unwrap();
        assert!(near(&drawn, cape[0], cape[1], 2.0));
    }

    #[test]
    fn graticule_lines_lie_on_multiples_of_the_step() {
        let map = Projector::Map(MapAxes {
            x: axis(-180.0, 180.0),
            y: axis(-90.0, 90.0),
            y_down: false,
            rotated: false,
        });
        let overlay = Overlay {
            projector: map,
            coast: None,
            graticule: Some(30.0),
            rings: Vec::new(),
            rotation: None,
            edges: None,
        };
        let mut img = white(360, 180);
        overlay.draw(&mut img);
        // One pixel per degree: pixel centres at lon −180 + i + 0.5, lat 90 − j − 0.5.
        let off = |v: f64| (v - 30.0 * (v / 30.0).round()).abs();
        let drawn = lines(&img);
        for &(i, j) in &drawn {
            let (lon, lat) = (-179.5 + i as f64, 89.5 - j as f64);
            assert!(off(lon) <= 1.0 || off(lat) <= 1.0, "({i}, {j})");
        }
        for k in -5..=5 {
            let col = (180 + 30 * k) as usize;
            assert!(drawn.contains(&(col, 100)) && drawn.contains(&(col - 1, 100)));
        }
        // The meridian at 30°E runs along the edge of column 210, whose centre it covers half:
        // 0.5·0.2 + 0.5·1 over white.
        let p = img.pixels[100 * 360 + 210];
        assert!((p[0] - 0.6).abs() < 1e-6 && p[3] == 1.0, "{p:?}");
    }

    #[test]
    fn lines_over_transparent_pixels_take_their_coverage_as_alpha() {
        let mut img = HdrImage::from_pixels(8, 8, vec![[0.0; 4]; 64]);
        let overlay = Overlay {
            projector: Projector::Map(MapAxes {
                x: axis(0.0, 8.0),
                y: axis(0.0, 8.0),
                y_down: false,
                rotated: false,
            }),
            coast: None,
            graticule: Some(4.0),
            rings: Vec::new(),
            rotation: None,
            edges: None,
        };
        overlay.draw(&mut img);
        // The meridian at 4° runs between columns 3 and 4, half covering both: the line's own
        // colour at alpha 0.5.
        let p = img.pixels[2 * 8 + 4];
        assert!((p[0] - 0.2).abs() < 1e-6 && p[3] == 0.5, "{p:?}");
        // Column 2 is 1.5 px away: untouched.
        assert_eq!(img.pixels[2 * 8 + 2], [0.0; 4]);
    }

    #[test]
    fn bad_styles_name_their_option() {
        let e = CoastlineStyle::default()
            .with_colour("coastlines", "mauve")
            .unwrap_err();
        assert!(e.to_string().starts_with("coastlines.colour:"), "{e}");
        for w in [0.0, -1.0, f64::NAN, 65.0] {
            let s = CoastlineStyle {
                width: w,
                ..Default::default()
            };
            assert!(s
                .validate("coastlines")
                .unwrap_err()
                .to_string()
                .starts_with("coastlines.width:"));
        }
        for step in [0.0, -10.0, f64::INFINITY, 91.0] {
            assert!(super::super::options::check_graticule(step)
                .unwrap_err()
                .to_string()
                .starts_with("graticule:"));
        }
    }
}
