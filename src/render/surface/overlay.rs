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

use super::marks::{Contours, Vectors};
use super::options::{CoastlineStyle, SurfaceOptions, SurfaceView};
use super::projected::ProjectedMap;
use super::projector::{Projector, ShellSurface};
use crate::datasets::coastlines::{coastlines, CoastResolution};
use crate::error::{Error, Result};
use crate::model::geometry::segment_distance;
use crate::model::map_frame::MapAxes;
use crate::model::mesh::ring::{ring_into, Ring};
use crate::model::mesh::MeshField;
use crate::model::text::{draw_text, format_number, Type};
use crate::model::{Camera, Cut, DepthRings, Grid, HdrImage, Volume};
use std::borrow::Cow;
use std::sync::Arc;

/// The graticule's colour (linear mid grey) and width in pixels.
const GRATICULE_COLOUR: [f64; 3] = [0.2; 3];
const GRATICULE_WIDTH: f64 = 1.0;
/// The depth rings' width in pixels (black).
const RING_WIDTH: f64 = 1.5;
/// Widest line, in pixels.
pub(crate) const MAX_LINE_WIDTH: f64 = 64.0;

/// Clear pixels either side of a contour label's text.
const LABEL_PAD: f64 = 2.0;

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
    /// Lines are longitudes and latitudes (repeated a turn either way on a map, and not drawn
    /// across the dateline), rather than a plain grid's coordinates.
    geographic: bool,
    contours: Option<Contours>,
    vectors: Option<Vectors>,
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
            geographic: true,
            contours: None,
            vectors: None,
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
            rings: depths,
            ..Overlay::on(Projector::Map(axes), false)
        })
    }

    /// The overlay `opts` asks for on `grid`, or `None`; an error naming the option when the
    /// grid or view cannot carry one (lines need longitude and latitude in a map or globe view).
    pub(crate) fn plan(grid: &Grid, opts: &SurfaceOptions) -> Result<Option<Overlay>> {
        Self::plan_on(grid, Some(grid), opts, None)
    }

    /// As [`Self::plan`] for a picture whose pixels lie on the axes of `frame` (or on the
    /// projected map `projected` when one is given), with contours and vectors from `data` (the
    /// rendered grid; `None` for a mesh).
    pub(crate) fn plan_on(
        frame: &Grid,
        data: Option<&Grid>,
        opts: &SurfaceOptions,
        projected: Option<Arc<ProjectedMap>>,
    ) -> Result<Option<Overlay>> {
        let lines = match (&opts.coastlines, opts.graticule, &opts.cell_edges) {
            (None, None, None) => None,
            (Some(_), _, _) => Some("coastlines"),
            (None, Some(_), _) => Some("graticule"),
            (None, None, Some(_)) => Some("cell_edges"),
        };
        let marks = match (&opts.contours, &opts.vectors) {
            (None, None) => None,
            (Some(_), _) => Some("contours"),
            (None, Some(_)) => Some("vectors"),
        };
        let mut overlay = match (lines, &opts.depth_rings, marks) {
            (Some(field), _, _) => Self::geographic(frame, opts, projected, field)?,
            (None, Some(r), _) => Self::section_rings(frame, r, &opts.view)?,
            (None, None, Some(field)) => Self::plain(frame, opts, projected, field)?,
            (None, None, None) => return Ok(None),
        };
        let shown = opts
            .properties
            .first()
            .map(String::as_str)
            .or_else(|| data.map(|g| g.property_at(0).0));
        overlay.contours = opts
            .contours
            .as_ref()
            .map(|c| Contours::plan(c, data, shown))
            .transpose()?;
        overlay.vectors = opts
            .vectors
            .as_ref()
            .map(|v| Vectors::plan(v, data))
            .transpose()?;
        Ok(Some(overlay))
    }

    /// Coastlines, graticule or cell edges (`field` names the first asked for): a map or globe of
    /// a longitude/latitude grid.
    fn geographic(
        grid: &Grid,
        opts: &SurfaceOptions,
        projected: Option<Arc<ProjectedMap>>,
        field: &str,
    ) -> Result<Overlay> {
        let axes = MapAxes::of_grid(grid).filter(|_| grid.is_geographic());
        let projector = match (&opts.view, axes, projected) {
            (SurfaceView::Map, _, Some(map)) => Projector::Projected(map),
            (SurfaceView::Map, Some(axes), None) => Projector::Map(axes),
            (SurfaceView::Globe(c), _, _) => Projector::Globe(*c),
            _ => {
                return Err(Error::invalid(
                    field,
                    format!(
                        "lines are drawn on map and globe views of longitude/latitude grids; grid {:?} in {} has none",
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
        Ok(Overlay {
            coast,
            graticule: opts.graticule,
            rotation,
            ..Overlay::on(projector, true)
        })
    }

    /// Contours or vectors alone (`field` names the first asked for): a map of any grid with
    /// evenly spaced axes (its own or the frame its pixels are placed on), a projected map or the
    /// globe.
    fn plain(
        grid: &Grid,
        opts: &SurfaceOptions,
        projected: Option<Arc<ProjectedMap>>,
        field: &str,
    ) -> Result<Overlay> {
        let (projector, geographic) = match (&opts.view, projected, MapAxes::of_grid(grid)) {
            (SurfaceView::Map, Some(map), _) => (Projector::Projected(map), true),
            (SurfaceView::Map, None, Some(axes)) => (Projector::Map(axes), grid.is_geographic()),
            (SurfaceView::Globe(c), _, _) => (Projector::Globe(*c), true),
            _ => {
                return Err(Error::invalid(
                    field,
                    format!(
                        "{field} are drawn on map and globe views; grid {:?} is drawn in {}",
                        grid.name(),
                        opts.view.describe()
                    ),
                ))
            }
        };
        Ok(Overlay::on(projector, geographic))
    }

    /// An overlay drawing nothing yet through `projector`.
    fn on(projector: Projector, geographic: bool) -> Overlay {
        Overlay {
            projector,
            coast: None,
            graticule: None,
            rings: Vec::new(),
            rotation: None,
            edges: None,
            geographic,
            contours: None,
            vectors: None,
        }
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
        if let Some(c) = &self.contours {
            let labels = if c.style.labels {
                self.contour_labels(c, img.width, img.height)
            } else {
                Vec::new()
            };
            let holes: Vec<[f64; 4]> = labels.iter().map(|l| l.0).collect();
            let lines = c.lines.iter().map(|l| Cow::Borrowed(l.points.as_slice()));
            self.draw_lines(img, lines, c.style.linear, c.style.width, &holes);
            let ty = Type::for_figure(img.width, img.height);
            let colour = c.style.linear.map(|v| v as f32);
            for (b, text) in &labels {
                let at = (b[0] + LABEL_PAD) as i64;
                draw_text(
                    img,
                    at,
                    b[1] as i64,
                    text,
                    ty,
                    [colour[0], colour[1], colour[2], 1.0],
                );
            }
            let mut levels: Vec<f64> = c.lines.iter().map(|l| l.level).collect();
            levels.dedup();
            let list: Vec<String> = levels.iter().map(|v| format!("{v}")).collect();
            img.set_meta(
                "contours",
                format!(
                    "{} lines at {}, {}, {} px",
                    c.lines.len(),
                    list.join(" "),
                    c.style.colour,
                    c.style.width
                ),
            );
        }
        if let Some(v) = &self.vectors {
            self.draw_vectors(img, v);
        }
    }

    /// Where contour labels go: on each line long enough to carry one (twice its label),
    /// a box about its middle point in which the line is not drawn, and the text; boxes that
    /// would leave the picture or meet another are left out.
    fn contour_labels(&self, c: &Contours, w: u32, h: u32) -> Vec<([f64; 4], String)> {
        let ty = Type::for_figure(w, h);
        let mut out: Vec<([f64; 4], String)> = Vec::new();
        for line in &c.lines {
            let px: Vec<[f64; 2]> = line
                .points
                .iter()
                .filter_map(|&p| self.line_pixel(p, w, h))
                .collect();
            let length: f64 = px
                .windows(2)
                .map(|s| (s[1][0] - s[0][0]).hypot(s[1][1] - s[0][1]))
                // A jump across half the picture is a projection's seam, not line.
                .filter(|d| *d < 0.5 * w.max(h) as f64)
                .sum();
            let text = format_number(line.level);
            let tw = ty.width(&text) as f64 + 2.0 * LABEL_PAD;
            if px.is_empty() || length < 2.0 * tw {
                continue;
            }
            let mid = px[px.len() / 2];
            let lh = ty.line() as f64;
            let b = [
                mid[0] - 0.5 * tw,
                mid[1] - 0.5 * lh,
                mid[0] + 0.5 * tw,
                mid[1] + 0.5 * lh,
            ];
            let inside = b[0] >= 0.0 && b[1] >= 0.0 && b[2] <= w as f64 && b[3] <= h as f64;
            let meets = |o: &[f64; 4]| b[0] < o[2] && o[0] < b[2] && b[1] < o[3] && o[1] < b[3];
            if inside && !out.iter().any(|(o, _)| meets(o)) {
                out.push((b, text));
            }
        }
        out
    }

    /// The pixel position of a line's point (longitude and latitude on the true sphere, moved
    /// onto a rotated-pole map's sphere), or `None`.
    fn line_pixel(&self, p: [f64; 2], w: u32, h: u32) -> Option<[f64; 2]> {
        let p = match &self.rotation {
            Some(r) => {
                let (lat, lon) = r.to_rotated(p[1], p[0]);
                [lon, lat]
            }
            None => p,
        };
        self.projector.pixel_at(p, w, h)
    }

    /// The arrows of `v` (the field's, then the reference arrow on its box), and their
    /// description in the metadata.
    fn draw_vectors(&self, img: &mut HdrImage, v: &Vectors) {
        let (w, h) = (img.width, img.height);
        let step = match (&self.projector, v.geographic()) {
            (Projector::Map(a), false) => {
                1e-4 * (a.x.hi - a.x.lo).abs().max((a.y.hi - a.y.lo).abs())
            }
            _ => 0.01,
        };
        let arrows = v.arrows(
            (w, h),
            |px| self.projector.point_at(px, w, h),
            |q| self.projector.pixel_at(q, w, h),
            step,
        );
        let stroke_all = |img: &mut HdrImage, segments: &[[[f64; 2]; 2]], linear: [f64; 3]| {
            let mut cover = vec![0f32; (w as usize) * (h as usize)];
            for &[a, b] in segments {
                stroke(&mut cover, w, h, a, b, v.style.width);
            }
            self.composite(img, &cover, linear);
        };
        stroke_all(img, &arrows.segments, v.style.linear);
        // The reference arrow is black, like its label, on its white box.
        let reference = v.reference_segments(&arrows, img);
        stroke_all(img, &reference, [0.0; 3]);
        img.set_meta("vectors", v.describe(&arrows));
    }

    fn draw_layer(&self, img: &mut HdrImage, layer: &Layer) {
        let lines = layer
            .lines
            .iter()
            .copied()
            .chain(layer.owned.iter().map(Vec::as_slice))
            .map(Cow::Borrowed);
        self.draw_lines(img, lines, layer.linear, layer.width, &[]);
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
        self.draw_lines(img, lines, style.linear, style.width, &[]);
    }

    /// Strokes `lines` (longitude, latitude) `width` pixels wide in the linear colour `linear`.
    /// Pixels inside any of `holes` ([x0, y0, x1, y1], a contour label's box) stay clear.
    fn draw_lines<'a>(
        &self,
        img: &mut HdrImage,
        lines: impl Iterator<Item = Cow<'a, [[f64; 2]]>>,
        linear: [f64; 3],
        width: f64,
        holes: &[[f64; 4]],
    ) {
        let (w, h) = (img.width, img.height);
        let mut cover = vec![0f32; (w as usize) * (h as usize)];
        // Longitudes jump by a turn at the dateline; a plain grid's coordinates do not wrap.
        let wraps = self.geographic;
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
                for [a, b] in self.projector.segment([seg[0], seg[1]], (w, h), wraps) {
                    stroke(&mut cover, w, h, a, b, width);
                }
            }
        }
        for b in holes {
            let (x0, x1) = (b[0].max(0.0) as u32, (b[2].ceil() as u32).min(w));
            let (y0, y1) = (b[1].max(0.0) as u32, (b[3].ceil() as u32).min(h));
            for y in y0..y1 {
                cover[(y * w + x0) as usize..(y * w + x1) as usize].fill(0.0);
            }
        }
        self.composite(img, &cover, linear);
    }

    /// Lays the colour `linear` over `img` at each pixel's coverage in `cover`.
    fn composite(&self, img: &mut HdrImage, cover: &[f32], linear: [f64; 3]) {
        let c = linear.map(|v| v as f32);
        if matches!(self.projector, Projector::Shell(_)) {
            // A volume render's colour is premultiplied (over its background): the line goes
            // over it.
            for (p, &a) in img.pixels.iter_mut().zip(cover) {
                if a > 0.0 {
                    for k in 0..3 {
                        p[k] = c[k] * a + p[k] * (1.0 - a);
                    }
                    p[3] = a + p[3] * (1.0 - a);
                }
            }
            return;
        }
        for (p, &a) in img.pixels.iter_mut().zip(cover) {
            if a > 0.0 {
                let alpha = a + p[3] * (1.0 - a);
                for k in 0..3 {
                    p[k] = (c[k] * a + p[k] * p[3] * (1.0 - a)) / alpha;
                }
                p[3] = alpha;
            }
        }
    }
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
            coast: Some((CoastlineStyle::default(), res)),
            ..Overlay::on(projector, true)
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
            geographic: true,
            contours: None,
            vectors: None,
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
            graticule: Some(30.0),
            ..Overlay::on(map, true)
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
        let axes = MapAxes {
            x: axis(0.0, 8.0),
            y: axis(0.0, 8.0),
            y_down: false,
            rotated: false,
        };
        let overlay = Overlay {
            graticule: Some(4.0),
            ..Overlay::on(Projector::Map(axes), true)
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

    /// A uniform flow (u east, v north, 3 and 4) on a 2° world grid.
    fn flow() -> super::super::marks::Vectors {
        let lon: Vec<f64> = (0..180).map(|i| -179.0 + 2.0 * i as f64).collect();
        let lat: Vec<f64> = (0..90).map(|j| -89.0 + 2.0 * j as f64).collect();
        let n = lon.len() * lat.len();
        let g = Grid::from_lon_lat(
            "flow",
            lon,
            lat,
            vec![("u".into(), vec![3.0; n]), ("v".into(), vec![4.0; n])],
        )
        .unwrap();
        let style = super::super::marks::VectorStyle::new("u", "v");
        super::super::marks::Vectors::plan(&style, Some(&g)).unwrap()
    }

    /// Each shaft's unit direction and its midpoint, from the arrows' segments (shaft, head, head).
    fn shafts(segments: &[[[f64; 2]; 2]]) -> Vec<([f64; 2], [f64; 2])> {
        segments
            .chunks(3)
            .map(|a| {
                let [p, q] = a[0];
                let d = [q[0] - p[0], q[1] - p[1]];
                let n = d[0].hypot(d[1]);
                (
                    [d[0] / n, d[1] / n],
                    [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])],
                )
            })
            .collect()
    }

    #[test]
    fn arrows_on_a_map_point_as_the_map_stretches_east_and_north() {
        // 60°W–60°E, 0–60°N on 400 × 300 px: 400/120 px per degree east, 300/60 north. A
        // vector (3, 4) m/s at latitude φ turns 3/(R cos φ) rad east and 4/R north: on the map
        // (3/cos φ · 400/120, −4 · 300/60), normalised.
        let axes = MapAxes {
            x: axis(-60.0, 60.0),
            y: axis(0.0, 60.0),
            y_down: false,
            rotated: false,
        };
        let overlay = Overlay::on(Projector::Map(axes), true);
        let (w, h) = (400u32, 300u32);
        let v = flow();
        let arrows = v.arrows(
            (w, h),
            |px| overlay.projector.point_at(px, w, h),
            |q| overlay.projector.pixel_at(q, w, h),
            0.01,
        );
        assert_eq!(arrows.count, 12 * 9);
        for (d, mid) in shafts(&arrows.segments) {
            let lat = 60.0 - mid[1] / 300.0 * 60.0;
            let want = [
                3.0 / lat.to_radians().cos() * 400.0 / 120.0,
                -4.0 * 300.0 / 60.0,
            ];
            let n = want[0].hypot(want[1]);
            let angle = (d[0] * want[1] / n - d[1] * want[0] / n).asin().abs();
            assert!(angle < 1e-5, "at {lat}°: {d:?} vs {want:?}");
        }
    }

    #[test]
    fn arrows_on_the_globe_point_along_the_projected_tangent() {
        // The perspective image of the tangent t = 3·east + 4·north at p: the derivative of
        // (v·right, v·up)/(v·forward), v = p − eye, along t.
        let cam = Camera::geo([0.0; 3], 20.0, 10.0, 3.0, 35.0).unwrap();
        let overlay = Overlay::on(Projector::Globe(cam), true);
        let (w, h) = (256u32, 256u32);
        let v = flow();
        let arrows = v.arrows(
            (w, h),
            |px| overlay.projector.point_at(px, w, h),
            |q| overlay.projector.pixel_at(q, w, h),
            0.01,
        );
        assert!(arrows.count > 20, "{}", arrows.count);
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut checked = 0;
        for (d, mid) in shafts(&arrows.segments) {
            // The arrow's point is the lattice point its shaft is centred on.
            let Some([lon, lat]) = overlay.projector.point_at(mid, w, h) else {
                continue;
            };
            let (lo, la) = (lon.to_radians(), lat.to_radians());
            let p = [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()];
            let east = [-lo.sin(), lo.cos(), 0.0];
            let north = [-la.sin() * lo.cos(), -la.sin() * lo.sin(), la.cos()];
            let t = [0, 1, 2].map(|k| 3.0 * east[k] + 4.0 * north[k]);
            let vv = [0, 1, 2].map(|k| p[k] - cam.eye[k]);
            let (vf, tf) = (dot(vv, cam.forward), dot(t, cam.forward));
            let want = [
                dot(t, cam.right) * vf - dot(vv, cam.right) * tf,
                -(dot(t, cam.up) * vf - dot(vv, cam.up) * tf),
            ];
            let n = want[0].hypot(want[1]);
            let angle = (d[0] * want[1] / n - d[1] * want[0] / n).asin().abs();
            assert!(angle < 1e-3, "({lon}, {lat}): {d:?} vs {want:?}");
            checked += 1;
        }
        assert!(checked > 20);
    }
}
