//! Marks drawn from data over a surface picture: contour lines (`contours`) and vector arrows
//! (`vectors`), from the rendered grid or another on the same axes. Contours are traced by
//! marching squares in the grid's coordinates ([`crate::model::contour`]) and drawn by the
//! overlay like coastlines, so they follow every view's placement (maps on any axes, projected
//! maps, the globe, sections). Arrows sit on a lattice of the picture's pixels; each takes the
//! vector bilinear at its point and points where the vector points on the picture: the
//! picture's image of a short step along it (east by u, north by v on the sphere; along x by u
//! and y by v on other axes), so the direction is the view's own, projection and aspect
//! included. Lengths are `scale` pixels per data unit, the same everywhere, with a reference
//! arrow of a round magnitude drawn in black with its value on a white box in the picture's
//! lower-right corner.

use crate::error::{Error, Result};
use crate::model::contour::{contour_levels, contour_lines, ContourLine};
use crate::model::text::{draw_text, format_number, Type};
use crate::model::{Grid, GridSampler, HdrImage};
use std::sync::Arc;

/// Which levels a contour overlay draws.
#[derive(Clone, Debug, PartialEq)]
pub enum ContourLevels {
    /// About this many round levels inside the property's range.
    Count(usize),
    /// These levels.
    Values(Vec<f64>),
}

/// `contours`: levels, the property (of the rendered grid, or of `grid`), and the lines' style.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourStyle {
    pub levels: ContourLevels,
    pub property: Option<String>,
    pub grid: Option<Arc<Grid>>,
    pub colour: String,
    pub linear: [f64; 3],
    pub width: f64,
    /// Each line's level written beside it.
    pub labels: bool,
}

impl Default for ContourStyle {
    fn default() -> Self {
        ContourStyle {
            levels: ContourLevels::Count(10),
            property: None,
            grid: None,
            colour: "black".into(),
            linear: [0.0; 3],
            width: 1.0,
            labels: false,
        }
    }
}

/// `vectors`: the two components' properties (of the rendered grid, or of `grid`), the
/// lattice's spacing in pixels, the length scale and the arrows' style.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorStyle {
    pub u: String,
    pub v: String,
    pub grid: Option<Arc<Grid>>,
    pub spacing: f64,
    /// Pixels per data unit of magnitude; `None`: the 90th percentile of the arrows' magnitudes
    /// is 0.9 of the spacing.
    pub scale: Option<f64>,
    /// The reference arrow's magnitude; `None`: a round number near the 90th percentile.
    pub reference: Option<f64>,
    pub colour: String,
    pub linear: [f64; 3],
    pub width: f64,
}

impl VectorStyle {
    pub fn new(u: &str, v: &str) -> VectorStyle {
        VectorStyle {
            u: u.into(),
            v: v.into(),
            grid: None,
            spacing: 32.0,
            scale: None,
            reference: None,
            colour: "black".into(),
            linear: [0.0; 3],
            width: 1.0,
        }
    }
}

/// Contour lines ready to draw: in (longitude, latitude) on the true sphere for a geographic
/// grid, else in the grid's coordinates.
pub(crate) struct Contours {
    pub style: ContourStyle,
    pub lines: Vec<ContourLine>,
}

impl Contours {
    /// The lines `style` asks for of `data` (the rendered grid; `None` for a mesh) whose first
    /// rendered property is `shown`.
    pub(crate) fn plan(
        style: &ContourStyle,
        data: Option<&Grid>,
        shown: Option<&str>,
    ) -> Result<Contours> {
        let grid = source(style.grid.as_deref(), data, "contours")?;
        // Another grid's lines are of its own first property unless one is named.
        let name = style
            .property
            .as_deref()
            .or(shown.filter(|_| style.grid.is_none()));
        let index = match name {
            Some(n) => grid
                .property_index(n)
                .map_err(|e| Error::invalid("contours.property", e.to_string()))?,
            None => 0,
        };
        let levels = match &style.levels {
            ContourLevels::Values(v) => v.clone(),
            ContourLevels::Count(n) => grid
                .range(index)
                .map_or(Vec::new(), |r| contour_levels(r, *n)),
        };
        let mut lines = contour_lines(grid, index, &levels);
        if let Some(pole) = grid.rotated_pole() {
            for l in &mut lines {
                for p in &mut l.points {
                    let (lat, lon) = pole.to_true(p[1], p[0]);
                    *p = [lon, lat];
                }
            }
        }
        Ok(Contours {
            style: style.clone(),
            lines,
        })
    }
}

/// The grid a mark is drawn from: its own `grid`, else the rendered one.
fn source<'a>(own: Option<&'a Grid>, data: Option<&'a Grid>, option: &str) -> Result<&'a Grid> {
    own.or(data).ok_or_else(|| {
        Error::invalid(
            option,
            format!("{option} are drawn from a grid: give one as {option}.grid (load_grid samples a mesh onto one)"),
        )
    })
}

/// Vector arrows ready to place: the grid and its two components.
pub(crate) struct Vectors {
    pub style: VectorStyle,
    grid: Arc<Grid>,
    u: usize,
    v: usize,
}

/// The arrows of a picture: their pixel-space segments (shaft and head), the scale in pixels
/// per unit, and the reference arrow's magnitude, segments and label position.
pub(crate) struct Arrows {
    pub segments: Vec<[[f64; 2]; 2]>,
    pub scale: f64,
    pub reference: f64,
    pub count: usize,
}

/// Most arrows' head length as a fraction of the arrow, and its half-angle.
const HEAD: f64 = 0.3;
const HEAD_ANGLE: f64 = 0.45;

impl Vectors {
    pub(crate) fn plan(style: &VectorStyle, data: Option<&Grid>) -> Result<Vectors> {
        let grid = source(style.grid.as_deref(), data, "vectors")?;
        let index = |name: &str, key: &str| {
            grid.property_index(name)
                .map_err(|e| Error::invalid(key, e.to_string()))
        };
        let (u, v) = (index(&style.u, "vectors.u")?, index(&style.v, "vectors.v")?);
        // The two components alone (not every property of the grid), kept until the draw.
        let component = |i: usize| {
            let (name, values) = grid.property_at(i);
            (name.to_string(), values.to_vec(), grid.units(i).to_string())
        };
        let components = if u == v {
            vec![component(u)]
        } else {
            vec![component(u), component(v)]
        };
        Ok(Vectors {
            style: style.clone(),
            u: 0,
            v: usize::from(u != v),
            grid: Arc::new(grid.derived(grid.name(), components)?),
        })
    }

    /// Whether the components are eastward and northward on the sphere (a geographic grid).
    pub(crate) fn geographic(&self) -> bool {
        self.grid.is_geographic()
    }

    /// The arrows on a `w × h` picture: `point` gives the coordinates (longitude, latitude on
    /// the sphere, or the grid's axes) at a pixel position, `pixel` the pixel position of a
    /// point; `step` is a small step in those coordinates.
    pub(crate) fn arrows(
        &self,
        (w, h): (u32, u32),
        point: impl Fn([f64; 2]) -> Option<[f64; 2]>,
        pixel: impl Fn([f64; 2]) -> Option<[f64; 2]>,
        step: f64,
    ) -> Arrows {
        let sampler = GridSampler::new(&self.grid);
        let s = self.style.spacing;
        let geographic = self.geographic();
        // Each lattice point's pixel, unit direction on the picture and magnitude.
        let mut found: Vec<([f64; 2], [f64; 2], f64)> = Vec::new();
        let (nx, ny) = (
            (w as f64 / s).floor() as usize,
            (h as f64 / s).floor() as usize,
        );
        for j in 0..ny {
            for i in 0..nx {
                let at = [
                    (i as f64 + 0.5) * s + 0.5 * (w as f64 - nx as f64 * s),
                    (j as f64 + 0.5) * s + 0.5 * (h as f64 - ny as f64 * s),
                ];
                let Some(p) = point(at) else { continue };
                let (u, v) = (
                    sampler.value_at(self.u, p[0], p[1]),
                    sampler.value_at(self.v, p[0], p[1]),
                );
                let m = u.hypot(v);
                if !(m.is_finite() && m > 0.0) {
                    continue;
                }
                // A short step along the vector, in the coordinates the picture places.
                let q = if geographic {
                    let c = p[1].to_radians().cos().max(1e-9);
                    [p[0] + step * u / (m * c), p[1] + step * v / m]
                } else {
                    [p[0] + step * u / m, p[1] + step * v / m]
                };
                let (Some(a), Some(b)) = (pixel(p), pixel(q)) else {
                    continue;
                };
                let d = [b[0] - a[0], b[1] - a[1]];
                let n = d[0].hypot(d[1]);
                if n > 0.0 && n.is_finite() {
                    found.push((at, [d[0] / n, d[1] / n], m));
                }
            }
        }
        let mut mags: Vec<f64> = found.iter().map(|f| f.2).collect();
        mags.sort_by(f64::total_cmp);
        let q90 = mags
            .get((mags.len() * 9 / 10).min(mags.len().saturating_sub(1)))
            .copied()
            .unwrap_or(1.0);
        let scale = self.style.scale.unwrap_or(0.9 * s / q90);
        let reference = self.style.reference.unwrap_or_else(|| round_number(q90));
        let mut segments = Vec::new();
        for (at, d, m) in &found {
            let len = m * scale;
            // Centred on its lattice point.
            let tail = [at[0] - 0.5 * len * d[0], at[1] - 0.5 * len * d[1]];
            arrow(&mut segments, tail, *d, len);
        }
        Arrows {
            segments,
            scale,
            reference,
            count: found.len(),
        }
    }

    /// The reference arrow and its label in `img`'s lower-right corner, on a white box.
    pub(crate) fn reference_segments(
        &self,
        arrows: &Arrows,
        img: &mut HdrImage,
    ) -> Vec<[[f64; 2]; 2]> {
        let ty = Type::for_figure(img.width, img.height);
        let units = self.grid.units(self.u);
        let label = format!("{} {}", format_number(arrows.reference), units)
            .trim()
            .to_string();
        let len = arrows.reference * arrows.scale;
        let pad = ty.gap() as f64 * 2.0;
        let box_w = len + 3.0 * pad + ty.width(&label) as f64;
        let box_h = ty.line() as f64 + 2.0 * pad;
        let (x0, y0) = (
            img.width as f64 - box_w - pad,
            img.height as f64 - box_h - pad,
        );
        if x0 < 0.0 || y0 < 0.0 {
            return Vec::new();
        }
        for y in y0 as u32..(y0 + box_h) as u32 {
            for x in x0 as u32..(x0 + box_w) as u32 {
                img.pixels[(y * img.width + x) as usize] = [1.0, 1.0, 1.0, 1.0];
            }
        }
        let mid = y0 + 0.5 * box_h;
        let text_x = (x0 + 2.0 * pad + len) as i64;
        draw_text(
            img,
            text_x,
            (mid - 0.5 * ty.line() as f64) as i64,
            &label,
            ty,
            [0.0, 0.0, 0.0, 1.0],
        );
        let mut segments = Vec::new();
        arrow(&mut segments, [x0 + pad, mid], [1.0, 0.0], len);
        segments
    }

    /// What the image metadata records.
    pub(crate) fn describe(&self, arrows: &Arrows) -> String {
        format!(
            "{} arrows of ({}, {}) every {} px, {} px per {}, reference {}",
            arrows.count,
            self.grid.property_at(self.u).0,
            self.grid.property_at(self.v).0,
            self.style.spacing,
            arrows.scale,
            self.grid.units(self.u),
            arrows.reference
        )
    }
}

/// An arrow from `tail` along the unit direction `d`, `len` pixels long: its shaft and the two
/// strokes of its head.
fn arrow(out: &mut Vec<[[f64; 2]; 2]>, tail: [f64; 2], d: [f64; 2], len: f64) {
    let tip = [tail[0] + len * d[0], tail[1] + len * d[1]];
    out.push([tail, tip]);
    let head = (HEAD * len).clamp(2.0, 10.0);
    for side in [-1.0, 1.0] {
        let (c, s) = (HEAD_ANGLE.cos(), side * HEAD_ANGLE.sin());
        let back = [-(d[0] * c - d[1] * s), -(d[0] * s + d[1] * c)];
        out.push([tip, [tip[0] + head * back[0], tip[1] + head * back[1]]]);
    }
}

/// 1, 2 or 5 × 10ⁿ nearest `v` (1 for nothing to go by).
fn round_number(v: f64) -> f64 {
    if !(v.is_finite() && v > 0.0) {
        return 1.0;
    }
    let e = v.log10().floor() as i32;
    let mag = 10f64.powi(e);
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| if e < 0 { m / 10f64.powi(-e) } else { m * mag })
        .min_by(|a, b| (a - v).abs().total_cmp(&(b - v).abs()))
        .unwrap_or(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrows_point_along_the_vector_as_the_picture_places_it() {
        // A plain 21 x 11 grid with a uniform vector (3, 4): on a picture placing x to the right
        // at 10 px per unit and y upward at 5 px per unit, each shaft runs along (30, −20)/|·|.
        let g = Grid::from_fn("g", 21, 11, |_, _| 0.0)
            .unwrap()
            .derived(
                "g",
                vec![
                    ("u".into(), vec![3.0; 231], "m/s".into()),
                    ("v".into(), vec![4.0; 231], "m/s".into()),
                ],
            )
            .unwrap();
        let style = VectorStyle::new("u", "v");
        let vectors = Vectors::plan(&style, Some(&g)).unwrap();
        let (w, h) = (200u32, 50u32);
        let arrows = vectors.arrows(
            (w, h),
            |p| Some([p[0] / 10.0, (h as f64 - p[1]) / 5.0]),
            |q| Some([q[0] * 10.0, h as f64 - q[1] * 5.0]),
            1e-3,
        );
        assert_eq!(arrows.count, 6);
        let want = [30.0 / 36.0555, -20.0 / 36.0555];
        for shaft in arrows.segments.chunks(3).map(|a| a[0]) {
            let d = [shaft[1][0] - shaft[0][0], shaft[1][1] - shaft[0][1]];
            let n = d[0].hypot(d[1]);
            assert!(
                (d[0] / n - want[0]).abs() < 1e-4 && (d[1] / n - want[1]).abs() < 1e-4,
                "{d:?}"
            );
            // Magnitude 5 at the default scale: every arrow 0.9 of the spacing.
            assert!((n - 0.9 * 32.0).abs() < 1e-9, "{n}");
        }
        assert_eq!(arrows.reference, 5.0);
    }

    #[test]
    fn round_numbers() {
        assert_eq!(round_number(7.3), 5.0);
        assert_eq!(round_number(0.017), 0.02);
        assert_eq!(round_number(86.0), 100.0);
    }
}
