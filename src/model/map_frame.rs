//! Axes and a frame for map-view renders. [`MapAxes`] is what a surface render in map view
//! records in its metadata — each axis's name, units and the coordinates at the image's edges —
//! and [`with_map_frame`] draws a figure from it for `save_png(img, path, #{frame: true})`: the
//! map unscaled inside a white margin with a black outline, ticks and labels at round
//! coordinates along the left and bottom (degrees with N/S/E/W on geographic axes, else numbers
//! with the axis name and units) and the recorded colour bar upright beside the map. The text,
//! the number format and the round tick values are those of [`super::text`].

use super::grid::GridCoords;
use super::text::{draw_text, format_number, nice_ticks, text_width, ColourBar, GLYPH};
use super::HdrImage;

/// Blank space around the figure, in pixels.
pub(crate) const FRAME_PAD: u32 = 6;
/// Length of an axis tick outside the outline.
pub(crate) const FRAME_TICK: u32 = 4;
/// Space between a tick and its label, and between stacked lines of text.
const GAP: u32 = 2;
/// Space between the map's outline and the colour bar, and the bar's width.
pub(crate) const FRAME_BAR_GAP: u32 = 12;
pub(crate) const FRAME_BAR_WIDTH: u32 = 12;
/// Length of a colour-bar tick.
const BAR_TICK: u32 = 3;

const WHITE: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
const BLACK: [f32; 4] = [0.0, 0.0, 0.0, 1.0];

/// One axis of a map image: its name and units and the coordinates at the image's two edges
/// (`lo` at the left or bottom edge, `hi` at the right or top), half a node spacing beyond the
/// first and last nodes, as the map view puts pixel centres on nodes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MapAxis {
    pub name: String,
    pub units: String,
    pub lo: f64,
    pub hi: f64,
}

/// The two axes of a map image: x runs east (left to right), y north (bottom to top).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MapAxes {
    pub x: MapAxis,
    pub y: MapAxis,
}

/// Metadata keys the axes are recorded under (x, then y: name, units, edge coordinates).
const AXIS_KEYS: [[&str; 3]; 2] = [
    ["map_x_axis", "map_x_units", "map_x_extent"],
    ["map_y_axis", "map_y_units", "map_y_extent"],
];

impl MapAxis {
    /// The axis of evenly spaced grid coordinates (within 1e-3 of a spacing); `None` for uneven
    /// ones, which the map view would place at the wrong pixels.
    pub(crate) fn of_coords(coords: &GridCoords) -> Option<MapAxis> {
        let v = &coords.values;
        let step = coords.spacing();
        let even = v
            .iter()
            .enumerate()
            .all(|(i, c)| (c - (v[0] + i as f64 * step)).abs() <= 1e-3 * step.abs());
        let first = *v.first()?;
        (even && step > 0.0).then(|| MapAxis {
            name: coords.name.clone(),
            units: coords.units.clone(),
            lo: first - step / 2.0,
            hi: v[v.len() - 1] + step / 2.0,
        })
    }

    /// Whether the axis is a longitude or latitude: named so, or in units of degrees.
    fn geographic(&self) -> bool {
        matches!(
            self.name.to_ascii_lowercase().as_str(),
            "lon" | "longitude" | "lat" | "latitude"
        ) || self.units.to_ascii_lowercase().starts_with("degree")
    }

    /// A tick label: "120.5°E" on a geographic axis (`hemispheres` = the letters for positive and
    /// negative values), else the number.
    fn label(&self, v: f64, hemispheres: [char; 2]) -> String {
        if !self.geographic() {
            return format_number(v);
        }
        let letter = match v {
            v if v > 0.0 => hemispheres[0].to_string(),
            v if v < 0.0 => hemispheres[1].to_string(),
            _ => String::new(),
        };
        format!("{}°{letter}", format_number(v.abs()))
    }

    /// The axis title: empty on a geographic axis (its labels say it), else "x (m)".
    fn title(&self) -> String {
        match (self.geographic(), self.units.as_str()) {
            (true, _) => String::new(),
            (false, "") => self.name.clone(),
            (false, u) => format!("{} ({u})", self.name),
        }
    }

    /// Round coordinates within the axis with their labels, as many as fit `pixels` with
    /// labels `label_extent(label)` long and a glyph apart.
    fn ticks(
        &self,
        pixels: u32,
        hemispheres: [char; 2],
        label_extent: impl Fn(&str) -> u32,
    ) -> Vec<(f64, String)> {
        for most in (2..=10).rev() {
            let ticks: Vec<(f64, String)> = nice_ticks(self.lo, self.hi, most)
                .into_iter()
                .map(|v| (v, self.label(v, hemispheres)))
                .collect();
            let longest = ticks.iter().map(|(_, l)| label_extent(l)).max();
            let room = pixels as f64 / ticks.len().max(1) as f64;
            if most == 2 || longest.is_some_and(|l| (l + GLYPH) as f64 <= room) {
                return ticks;
            }
        }
        Vec::new()
    }

    /// The pixel (column from the left, or row from the top when `downwards`) that shows `v`
    /// in an image `pixels` long.
    pub(crate) fn pixel(&self, v: f64, pixels: u32, downwards: bool) -> u32 {
        let t = (v - self.lo) / (self.hi - self.lo);
        let t = if downwards { 1.0 - t } else { t };
        ((t * pixels as f64).floor().max(0.0) as u32).min(pixels.saturating_sub(1))
    }
}

impl MapAxes {
    /// The axes of a grid in map view, when both are evenly spaced.
    pub(crate) fn of_grid(grid: &super::Grid) -> Option<MapAxes> {
        Some(MapAxes {
            x: MapAxis::of_coords(grid.x())?,
            y: MapAxis::of_coords(grid.y())?,
        })
    }

    /// Records the axes in `img`'s metadata.
    pub(crate) fn record(&self, img: &mut HdrImage) {
        for (axis, keys) in [&self.x, &self.y].into_iter().zip(AXIS_KEYS) {
            img.set_meta(keys[0], axis.name.as_str());
            img.set_meta(keys[1], axis.units.as_str());
            img.set_meta(keys[2], format!("{} {}", axis.lo, axis.hi));
        }
    }

    /// The axes `img` records, if it records them.
    pub(crate) fn of(img: &HdrImage) -> Option<MapAxes> {
        let axis = |keys: [&str; 3]| -> Option<MapAxis> {
            let mut extent = img.meta(keys[2])?.split_whitespace().map(str::parse::<f64>);
            let (Some(Ok(lo)), Some(Ok(hi))) = (extent.next(), extent.next()) else {
                return None;
            };
            (lo.is_finite() && hi.is_finite() && hi > lo).then(|| MapAxis {
                name: img.meta(keys[0]).unwrap_or("").to_string(),
                units: img.meta(keys[1]).unwrap_or("").to_string(),
                lo,
                hi,
            })
        };
        Some(MapAxes {
            x: axis(AXIS_KEYS[0])?,
            y: axis(AXIS_KEYS[1])?,
        })
    }
}

/// Where things sit in a framed figure.
struct FrameLayout {
    /// Top-left corner of the map.
    left: u32,
    top: u32,
    /// The map's size, and the figure's.
    map_w: u32,
    map_h: u32,
    width: u32,
    height: u32,
    x_ticks: Vec<(f64, String)>,
    y_ticks: Vec<(f64, String)>,
}

impl FrameLayout {
    /// The layout: the left margin holds the widest y label, a tick and the outline; the top one
    /// a line of text (the y title and the bar's caption); the bottom one the x ticks, labels
    /// and title; the right one the colour bar, its ticks, labels and caption.
    fn new(img: &HdrImage, axes: &MapAxes, bar: Option<&ColourBar>) -> FrameLayout {
        let x_ticks = axes.x.ticks(img.width, ['E', 'W'], |l| text_width(l, 1));
        let y_ticks = axes.y.ticks(img.height, ['N', 'S'], |_| GLYPH);
        let widest = y_ticks
            .iter()
            .map(|(_, l)| text_width(l, 1))
            .max()
            .unwrap_or(0);
        let left = FRAME_PAD + widest + GAP + FRAME_TICK + 1;
        let bottom_text = if axes.x.title().is_empty() { 1 } else { 2 };
        let bar_part = bar.map_or(0, |b| {
            let labels = b
                .ticks(bar_most(img.height))
                .iter()
                .map(|(_, l)| text_width(l, 1))
                .max()
                .unwrap_or(0);
            let caption = text_width(&b.caption(240), 1);
            FRAME_BAR_GAP + (FRAME_BAR_WIDTH + BAR_TICK + GAP + labels).max(caption)
        });
        let right = 1 + bar_part + FRAME_PAD;
        let bottom = 1 + FRAME_TICK + bottom_text * (GAP + GLYPH) + FRAME_PAD;
        let top = FRAME_PAD + GLYPH + 2 * GAP + 1;
        FrameLayout {
            left,
            top,
            map_w: img.width,
            map_h: img.height,
            width: left + img.width + right,
            height: top + img.height + bottom,
            x_ticks,
            y_ticks,
        }
    }
}

/// How many colour-bar ticks an upright bar `height` pixels tall gets.
fn bar_most(height: u32) -> usize {
    (height / (GLYPH * 3)).clamp(2, 10) as usize
}

/// `img` (exposed for display) in a figure: see the module notes. The map's pixels are copied
/// unscaled with their top-left corner at (`frame_left`, `frame_top`) of the metadata; `bar` is
/// drawn beside it when given.
pub(crate) fn with_map_frame(
    img: &HdrImage,
    axes: &MapAxes,
    bar: Option<&ColourBar>,
) -> crate::Result<HdrImage> {
    let layout = FrameLayout::new(img, axes, bar);
    let mut out = HdrImage::new(layout.width, layout.height);
    out.metadata = img.metadata.clone();
    out.pixels.fill(WHITE);
    let (w, h) = (img.width, img.height);
    for row in 0..h {
        let dst = ((layout.top + row) * layout.width + layout.left) as usize;
        let src = (row * w) as usize;
        out.pixels[dst..dst + w as usize].copy_from_slice(&img.pixels[src..src + w as usize]);
    }
    draw_axes(&mut out, &layout, axes);
    if let Some(bar) = bar {
        draw_upright_bar(&mut out, &layout, bar)?;
    }
    out.set_meta(
        "frame_map_origin",
        format!("{} {}", layout.left, layout.top),
    );
    Ok(out)
}

/// Paints the rectangle [x0, x1) × [y0, y1) (clipped to the image).
fn fill(img: &mut HdrImage, (x0, x1): (u32, u32), (y0, y1): (u32, u32), colour: [f32; 4]) {
    for y in y0..y1.min(img.height) {
        for x in x0..x1.min(img.width) {
            img.pixels[(y * img.width + x) as usize] = colour;
        }
    }
}

/// The outline one pixel outside the map, the ticks outside it and their labels and titles.
fn draw_axes(out: &mut HdrImage, l: &FrameLayout, axes: &MapAxes) {
    let (w, h) = (l.map_w, l.map_h);
    let (x0, y0, x1, y1) = (l.left - 1, l.top - 1, l.left + w, l.top + h);
    fill(out, (x0, x1 + 1), (y0, y0 + 1), BLACK);
    fill(out, (x0, x1 + 1), (y1, y1 + 1), BLACK);
    fill(out, (x0, x0 + 1), (y0, y1 + 1), BLACK);
    fill(out, (x1, x1 + 1), (y0, y1 + 1), BLACK);
    let label_y = y1 + 1 + FRAME_TICK + GAP;
    let mut free_from = 0i64;
    for (v, label) in &l.x_ticks {
        let x = l.left + axes.x.pixel(*v, w, false);
        fill(out, (x, x + 1), (y1 + 1, y1 + 1 + FRAME_TICK), BLACK);
        let lw = text_width(label, 1) as i64;
        let lx = x as i64 - lw / 2;
        if lx >= free_from {
            draw_text(out, lx, label_y as i64, label, 1, BLACK);
            free_from = lx + lw + GLYPH as i64;
        }
    }
    let title = axes.x.title();
    let tx = l.left as i64 + (w as i64 - text_width(&title, 1) as i64) / 2;
    draw_text(out, tx, (label_y + GLYPH + GAP) as i64, &title, 1, BLACK);
    for (v, label) in &l.y_ticks {
        let y = l.top + axes.y.pixel(*v, h, true);
        fill(out, (x0 - FRAME_TICK, x0), (y, y + 1), BLACK);
        let lx = (x0 - FRAME_TICK - GAP) as i64 - text_width(label, 1) as i64;
        draw_text(out, lx, y as i64 - GLYPH as i64 / 2, label, 1, BLACK);
    }
    draw_text(
        out,
        FRAME_PAD as i64,
        FRAME_PAD as i64,
        &axes.y.title(),
        1,
        BLACK,
    );
}

/// The colour bar upright beside the map, as tall as the map (the high end at the top), with
/// a tick and label at each of [`ColourBar::ticks`] (labels that would overlap the one above
/// are left out) and the bar's caption above it. Records the ticks drawn (`frame_bar_ticks`,
/// "value@row ...").
fn draw_upright_bar(out: &mut HdrImage, l: &FrameLayout, bar: &ColourBar) -> crate::Result<()> {
    let cmap = super::colormap::Colormap::by_name(&bar.colormap)?;
    let bx = l.left + l.map_w + 1 + FRAME_BAR_GAP;
    let h = l.map_h;
    for row in 0..h {
        let t = 1.0 - (row as f64 + 0.5) / h as f64;
        let c = cmap.linear_rgb(t);
        let colour = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
        fill(
            out,
            (bx, bx + FRAME_BAR_WIDTH),
            (l.top + row, l.top + row + 1),
            colour,
        );
    }
    let tick_x = bx + FRAME_BAR_WIDTH;
    let mut drawn = Vec::new();
    let mut free_from = 0i64;
    for (v, label) in bar.ticks(bar_most(h)).into_iter().rev() {
        let row = l.top + ((1.0 - bar.position(v)) * (h - 1) as f64).round() as u32;
        fill(out, (tick_x, tick_x + BAR_TICK), (row, row + 1), BLACK);
        let ly = row as i64 - GLYPH as i64 / 2;
        if ly >= free_from {
            let lx = (tick_x + BAR_TICK + GAP) as i64;
            draw_text(out, lx, ly, &label, 1, BLACK);
            free_from = ly + (GLYPH + GAP) as i64;
            drawn.push(format!("{v}@{row}"));
        }
    }
    let caption = bar.caption(240);
    let cy = l.top as i64 - (GLYPH + 2 * GAP) as i64;
    draw_text(out, bx as i64, cy, &caption, 1, BLACK);
    out.set_meta("frame_bar_ticks", drawn.join(" "));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::text::BarScale;

    fn coords(name: &str, units: &str, values: Vec<f64>) -> GridCoords {
        GridCoords {
            name: name.into(),
            units: units.into(),
            values,
            ..Default::default()
        }
    }

    #[test]
    fn axes_come_from_even_coordinates_and_round_trip_through_metadata() {
        let lon = MapAxis::of_coords(&coords("lon", "degrees_east", vec![-10.0, -9.5, -9.0]));
        let lon = lon.unwrap();
        assert_eq!((lon.lo, lon.hi), (-10.25, -8.75));
        let uneven = coords("depth", "m", vec![0.0, 1.0, 3.0]);
        assert_eq!(MapAxis::of_coords(&uneven), None);
        let y = MapAxis::of_coords(&coords("y", "km", vec![0.0, 2.0])).unwrap();
        let axes = MapAxes { x: lon, y };
        let mut img = HdrImage::new(3, 2);
        assert_eq!(MapAxes::of(&img), None);
        axes.record(&mut img);
        assert_eq!(MapAxes::of(&img), Some(axes.clone()));
        // Pixel centres on nodes: node i of 3 is column i; the top row is the northern node.
        for (i, v) in [-10.0, -9.5, -9.0].into_iter().enumerate() {
            assert_eq!(axes.x.pixel(v, 3, false), i as u32);
        }
        assert_eq!(
            (axes.y.pixel(2.0, 2, true), axes.y.pixel(0.0, 2, true)),
            (0, 1)
        );
    }

    #[test]
    fn labels_name_hemispheres_on_geographic_axes_and_units_elsewhere() {
        let axis = |name: &str, units: &str| MapAxis {
            name: name.into(),
            units: units.into(),
            lo: -1.0,
            hi: 1.0,
        };
        let lon = axis("longitude", "");
        assert_eq!(lon.label(-120.5, ['E', 'W']), "120.5°W");
        assert_eq!(lon.label(0.0, ['E', 'W']), "0°");
        assert_eq!(axis("phi", "degrees_north").label(15.0, ['N', 'S']), "15°N");
        assert_eq!(lon.title(), "");
        assert_eq!(axis("x", "m").label(2.5e6, ['E', 'W']), "2.5e6");
        assert_eq!(axis("x", "m").title(), "x (m)");
        assert_ne!(
            crate::model::text::glyph('°'),
            crate::model::text::glyph('?')
        );
    }

    #[test]
    fn frame_places_the_map_ticks_and_bar_by_the_layout() {
        let axes = MapAxes {
            x: MapAxis::of_coords(&coords("x", "m", (0..40).map(f64::from).collect())).unwrap(),
            y: MapAxis::of_coords(&coords("y", "m", (0..30).map(f64::from).collect())).unwrap(),
        };
        let mut img = HdrImage::new(40, 30);
        img.pixels.fill([0.25, 0.5, 0.75, 1.0]);
        let bar = ColourBar {
            colormap: "viridis".into(),
            scale: BarScale::Linear,
            lo: 0.0,
            hi: 1.0,
            units: "m".into(),
        };
        let out = with_map_frame(&img, &axes, Some(&bar)).unwrap();
        // 40 × 30 px leave room for two labels a side (a label and a glyph per tick): steps of
        // 20, ticks at 0 and 20; the widest y label, "20", is 16 px, so the map starts at
        // 6 + 16 + 2 + 4 + 1.
        let (left, top) = (29u32, 19u32);
        assert_eq!(out.meta("frame_map_origin"), Some("29 19"));
        let at = |x: u32, y: u32| out.pixels[(y * out.width + x) as usize];
        assert_eq!(at(left, top), [0.25, 0.5, 0.75, 1.0]);
        assert_eq!(at(left + 39, top + 29), [0.25, 0.5, 0.75, 1.0]);
        assert_eq!(at(left - 1, top), BLACK);
        // Ticks in the columns of nodes 0 and 20 (x = node index here) and the rows of nodes 0
        // and 20 counted from the north; no tick at node 10.
        for v in [0u32, 20] {
            assert_eq!(at(left + v, top + 30 + 2), BLACK, "x tick {v}");
            assert_eq!(at(left - 3, top + 29 - v), BLACK, "y tick {v}");
        }
        assert_eq!(at(left + 10, top + 30 + 2), WHITE);
        assert_eq!(at(left - 3, top + 19), WHITE);
        // Bar ticks at rows top + round((1 − t) · 29), drawn right of the bar.
        let ticks = out.meta("frame_bar_ticks").unwrap().to_string();
        assert!(ticks.split(' ').count() >= 2, "{ticks}");
        for t in ticks.split(' ') {
            let (v, row) = t.split_once('@').unwrap();
            let (v, row): (f64, u32) = (v.parse().unwrap(), row.parse().unwrap());
            assert_eq!(row, top + ((1.0 - v) * 29.0).round() as u32);
            assert_eq!(
                at(left + 40 + 1 + FRAME_BAR_GAP + FRAME_BAR_WIDTH, row),
                BLACK
            );
        }
    }
}
