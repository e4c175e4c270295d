//! Axes and a frame for map-view renders. [`MapAxes`] is what a surface render in map view
//! records in its metadata — each axis's name, units and the coordinates at the image's edges —
//! and [`with_map_frame`] draws a figure from it for `save_png(img, path, #{frame: true})`: the
//! map unscaled inside a white margin with a black outline, ticks and labels at round
//! coordinates along the left and bottom (degrees with N/S/E/W on geographic axes, else numbers
//! with the axis name and units), the recorded colour bar upright beside the map (with its
//! extend triangles), an optional title above, lines of text below (the fringe legend) and, on
//! longitude/latitude axes, a scale bar in km at the map's centre latitude. [`FrameLayout`]
//! places every piece as a rectangle before anything is drawn, sized from the type (labels sit a
//! gap from their ticks, the bar's top label clears its caption), so a test can hold the boxes
//! apart. The text, the number format and the round tick values are those of [`super::text`].

use super::text::{
    draw_extend_triangles, draw_text, extend_length, format_number, nice_ticks, typeset_number,
    ColourBar, Type,
};
use crate::model::grid::GridCoords;
use crate::model::HdrImage;

const WHITE: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
const BLACK: [f32; 4] = [0.0, 0.0, 0.0, 1.0];

/// One axis of a map image: its name and units and the coordinates at the image's two edges
/// (`lo` at the left edge, or the bottom — the top on a downward y axis —, `hi` at the other),
/// half a node spacing beyond the first and last nodes, as the map view puts pixel centres on
/// nodes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MapAxis {
    pub name: String,
    pub units: String,
    pub lo: f64,
    pub hi: f64,
}

/// The two axes of a map image: x runs east (left to right), y north (bottom to top) or, when
/// `y_down` (a depth axis, [`crate::model::Grid::y_down`]), downward (top to bottom).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MapAxes {
    pub x: MapAxis,
    pub y: MapAxis,
    pub y_down: bool,
    /// Longitudes and latitudes of a rotated pole (CF `rotated_latitude_longitude`): labelled
    /// in degrees without hemispheres, titled as rotated.
    pub rotated: bool,
}

/// Metadata keys the axes are recorded under (x, then y: name, units, edge coordinates).
const AXIS_KEYS: [[&str; 3]; 2] = [
    ["map_x_axis", "map_x_units", "map_x_extent"],
    ["map_y_axis", "map_y_units", "map_y_extent"],
];

/// Metadata key of the y axis's direction: "down" or "up".
const Y_DIRECTION_KEY: &str = "map_y_direction";

/// Metadata key present ("yes") on maps of rotated-pole grids.
const ROTATED_KEY: &str = "map_rotated_pole";

/// Tick steps on degree axes: those that divide the circle.
const DEGREE_STEPS: [f64; 16] = [
    0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 2.5, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 90.0, 180.0,
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
    /// negative values; `None`, a rotated pole's axis: "−20°"), else the number.
    fn label(&self, v: f64, hemispheres: Option<[char; 2]>) -> String {
        if !self.geographic() {
            return typeset_number(v);
        }
        let Some(hemispheres) = hemispheres else {
            return format!("{}°", typeset_number(v));
        };
        // Longitudes east of 180° (a 0–360° grid) read as west ones.
        let v = if hemispheres == ['E', 'W'] && v > 180.0 {
            v - 360.0
        } else {
            v
        };
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
    /// labels and the space after them `label_extent(label)` long. Degrees take steps that
    /// divide the circle (1, 2, 5, 10, 15, 20, 30, 45, 60, 90°, …), on the multiples of the
    /// `graticule` step when the map draws one, so the ticks meet its lines.
    fn ticks(
        &self,
        pixels: u32,
        hemispheres: Option<[char; 2]>,
        graticule: Option<f64>,
        label_extent: impl Fn(&str) -> u32,
    ) -> Vec<(f64, String)> {
        let fits = |ticks: &[(f64, String)]| {
            let longest = ticks.iter().map(|(_, l)| label_extent(l)).max();
            let room = pixels as f64 / ticks.len().max(1) as f64;
            longest.is_some_and(|l| l as f64 <= room)
        };
        if self.geographic() && self.hi - self.lo >= 0.5 {
            let steps: Vec<f64> = match graticule {
                Some(g) => [1.0, 2.0, 3.0, 4.0, 6.0, 9.0, 12.0]
                    .iter()
                    .map(|k| k * g)
                    .collect(),
                None => DEGREE_STEPS.to_vec(),
            };
            let mut last = Vec::new();
            for step in steps {
                let k0 = (self.lo / step).ceil() as i64;
                let k1 = (self.hi / step).floor() as i64;
                if k1 - k0 > 12 {
                    continue;
                }
                let ticks: Vec<(f64, String)> = (k0..=k1)
                    .map(|k| k as f64 * step)
                    .map(|v| (v, self.label(v, hemispheres)))
                    .collect();
                if ticks.len() >= 2 && fits(&ticks) {
                    return ticks;
                }
                if !ticks.is_empty() {
                    last = ticks;
                }
            }
            if !last.is_empty() {
                return last;
            }
        }
        for most in (2..=10).rev() {
            let ticks: Vec<(f64, String)> = nice_ticks(self.lo, self.hi, most)
                .into_iter()
                .map(|v| (v, self.label(v, hemispheres)))
                .collect();
            let longest = ticks.iter().map(|(_, l)| label_extent(l)).max();
            let room = pixels as f64 / ticks.len().max(1) as f64;
            if most == 2 || longest.is_some_and(|l| l as f64 <= room) {
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
    /// The axis titles: a rotated pole's "rotated longitude" and "rotated latitude", else each
    /// axis's own ([`MapAxis::title`]).
    fn titles(&self) -> (String, String) {
        if self.rotated {
            ("rotated longitude".into(), "rotated latitude".into())
        } else {
            (self.x.title(), self.y.title())
        }
    }

    /// The axes of a grid in map view, when both are evenly spaced.
    pub(crate) fn of_grid(grid: &crate::model::Grid) -> Option<MapAxes> {
        Some(MapAxes {
            x: MapAxis::of_coords(grid.x())?,
            y: MapAxis::of_coords(grid.y())?,
            y_down: grid.y_down(),
            rotated: grid.rotated_pole().is_some(),
        })
    }

    /// Records the axes in `img`'s metadata.
    pub(crate) fn record(&self, img: &mut HdrImage) {
        for (axis, keys) in [&self.x, &self.y].into_iter().zip(AXIS_KEYS) {
            img.set_meta(keys[0], axis.name.as_str());
            img.set_meta(keys[1], axis.units.as_str());
            img.set_meta(keys[2], format!("{} {}", axis.lo, axis.hi));
        }
        img.set_meta(Y_DIRECTION_KEY, if self.y_down { "down" } else { "up" });
        if self.rotated {
            img.set_meta(ROTATED_KEY, "yes");
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
            y_down: img.meta(Y_DIRECTION_KEY) == Some("down"),
            rotated: img.meta(ROTATED_KEY).is_some(),
        })
    }
}

/// What a framed figure shows besides the map and its axes: the type, a title, the colour bar,
/// lines of text under the map (the fringe legend) and whether to draw a scale bar (geographic
/// axes only).
pub(crate) struct FrameExtras<'a> {
    pub ty: Type,
    pub title: Option<&'a str>,
    pub bar: Option<&'a ColourBar>,
    pub notes: Vec<String>,
    pub scale_bar: bool,
    /// The graticule's step in degrees, when the map draws one: longitude and latitude ticks
    /// fall on its lines.
    pub graticule: Option<f64>,
}

/// A rectangle of the figure, [x, x + w) × [y, y + h).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rect {
    pub x: i64,
    pub y: i64,
    pub w: i64,
    pub h: i64,
}

impl Rect {
    fn new(x: i64, y: i64, w: u32, h: u32) -> Rect {
        Rect {
            x,
            y,
            w: w as i64,
            h: h as i64,
        }
    }

    pub(crate) fn overlaps(&self, o: &Rect) -> bool {
        self.x < o.x + o.w && o.x < self.x + self.w && self.y < o.y + o.h && o.y < self.y + self.h
    }
}

/// One thing a figure draws.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Piece {
    /// The map's pixels, unscaled.
    Map,
    /// The colour bar, upright, with its extend triangles inside the rectangle.
    Bar,
    /// A black rectangle: a tick, the scale bar.
    Ink,
    /// A line of text in the figure's type (`title`: the title's larger type).
    Text { text: String, title: bool },
}

/// Where everything of a framed figure sits: the pieces with their rectangles, in drawing order,
/// and the figure's size. Nothing overlaps but ticks and the outline they leave from (the
/// layout test holds every text box apart from every other piece).
pub(crate) struct FrameLayout {
    pub width: u32,
    pub height: u32,
    pub map: Rect,
    pub pieces: Vec<(Piece, Rect)>,
    /// The colour bar's ticks drawn, "value@row ...", and the scale bar, "km@pixels".
    bar_ticks: Vec<String>,
    scale: Option<(f64, u32)>,
}

/// Mean Earth radius (IUGG), in km: a degree of latitude is 111.195 km.
pub(crate) const EARTH_RADIUS_KM: f64 = 6371.0088;

/// Text rows above the map: the title, then the y axis's title at the left and the colour bar's
/// caption over the bar (on two rows when they would meet).
struct Header {
    rows: Vec<(Piece, i64, u32)>,
    bottom: u32,
}

impl FrameLayout {
    /// The layout of `img` framed with `axes` and `extras`; see the module notes.
    /// A map in a projection (no `axes`) gets the title, colour bar and notes without ticks.
    pub(crate) fn new(img: &HdrImage, axes: Option<&MapAxes>, extras: &FrameExtras) -> FrameLayout {
        let ty = extras.ty;
        let (gap, line) = (ty.gap(), ty.line());
        let (tick, pad) = (gap.max(3), 2 * gap);
        let (map_w, map_h) = (img.width, img.height);
        let digit = ty.width("0");
        let (x_ticks, y_ticks) = match axes {
            Some(axes) => {
                let letters = |l: [char; 2]| (!axes.rotated).then_some(l);
                (
                    axes.x
                        .ticks(map_w, letters(['E', 'W']), extras.graticule, |l| {
                            ty.width(l) + digit
                        }),
                    axes.y
                        .ticks(map_h, letters(['N', 'S']), extras.graticule, |_| line + gap),
                )
            }
            None => (Vec::new(), Vec::new()),
        };
        let widest_y = y_ticks.iter().map(|(_, l)| ty.width(l)).max().unwrap_or(0);
        let left = pad + widest_y + gap + tick + 1;
        let bar_x = left + map_w + 1 + line;
        let header = Self::header(axes, extras, (left, map_w, map_h, bar_x), (pad, tick));
        // The top bar and y labels stand half a line above the map's top edge.
        let top = header.bottom + line / 2 + 1;
        let map = Rect::new(left as i64, top as i64, map_w, map_h);
        let mut l = FrameLayout {
            width: 0,
            height: 0,
            map,
            pieces: vec![(Piece::Map, map)],
            bar_ticks: Vec::new(),
            scale: None,
        };
        for (piece, y, x) in header.rows {
            l.text(piece, x as i64, y, ty, extras.ty.times(1.25));
        }
        if let Some(axes) = axes {
            l.x_axis(axes, &x_ticks, ty, tick);
            l.y_axis(axes, &y_ticks, ty, tick);
        }
        let mut bottom = (map.y + map.h) as u32 + 1 + tick + gap + line;
        let (x_title, _) = axes.map(MapAxes::titles).unwrap_or_default();
        if !x_title.is_empty() {
            let title = x_title;
            let x = map.x + (map.w - ty.width(&title) as i64) / 2;
            l.text_at(&title, x, (bottom + gap) as i64, ty);
            bottom += gap + line;
        }
        for note in &extras.notes {
            l.text_at(note, map.x, (bottom + gap) as i64, ty);
            bottom += gap + line;
        }
        if let (true, Some(axes)) = (extras.scale_bar, axes) {
            bottom = l.scale_bar(axes, ty, bottom + gap);
        }
        let mut right = (map.x + map.w) as u32 + 1;
        if let Some(bar) = extras.bar {
            right = right.max(l.colour_bar(bar, bar_x, ty, tick));
        }
        let widest = l.pieces.iter().map(|(_, r)| (r.x + r.w) as u32).max();
        l.width = right.max(widest.unwrap_or(0)) + pad;
        l.height = bottom + pad;
        l
    }

    fn header(
        axes: Option<&MapAxes>,
        extras: &FrameExtras,
        (left, map_w, map_h, bar_x): (u32, u32, u32, u32),
        (pad, tick): (u32, u32),
    ) -> Header {
        let ty = extras.ty;
        let (gap, line) = (ty.gap(), ty.line());
        let mut rows = Vec::new();
        let mut y = pad;
        if let Some(title) = extras.title.filter(|t| !t.is_empty()) {
            let big = ty.times(1.25);
            let map_mid = left as i64 + map_w as i64 / 2;
            let x = (map_mid - big.width(title) as i64 / 2).max(pad as i64);
            let piece = Piece::Text {
                text: title.to_string(),
                title: true,
            };
            rows.push((piece, y as i64, x as u32));
            y += big.line() + gap;
        }
        let (_, y_title) = axes.map(MapAxes::titles).unwrap_or_default();
        let caption = extras
            .bar
            .map(|b| b.caption(1 << 20, ty))
            .unwrap_or_default();
        let text = |t: &str| Piece::Text {
            text: t.to_string(),
            title: false,
        };
        if !y_title.is_empty() {
            rows.push((text(&y_title), y as i64, pad));
        }
        if let (false, Some(bar)) = (caption.is_empty(), extras.bar) {
            // A caption longer than the bar's column ends where the column does and reaches
            // left over the map's top, rather than widening the figure by its length.
            let right = bar_x + Self::bar_column_width(bar, map_h, ty, tick);
            let x = bar_x
                .min(right.saturating_sub(ty.width(&caption)))
                .max(left);
            let meets = !y_title.is_empty() && pad + ty.width(&y_title) + gap > x;
            if meets {
                y += line + gap;
            }
            rows.push((text(&caption), y as i64, x));
        }
        if !y_title.is_empty() || !caption.is_empty() {
            y += line + gap;
        }
        Header { rows, bottom: y }
    }

    /// Places a header row: text in the figure's type or, for the title, in `big`.
    fn text(&mut self, piece: Piece, x: i64, y: i64, ty: Type, big: Type) {
        if let Piece::Text { text, title } = &piece {
            let t = if *title { big } else { ty };
            let r = Rect::new(x, y, t.width(text), t.line());
            self.pieces.push((piece, r));
        }
    }

    /// Places `text` at (x, y) unless it would overlap a text already placed; whether it did.
    fn text_at(&mut self, text: &str, x: i64, y: i64, ty: Type) -> bool {
        let r = Rect::new(x, y, ty.width(text), ty.line());
        let clear = self
            .pieces
            .iter()
            .all(|(p, o)| !matches!(p, Piece::Text { .. }) || !o.overlaps(&r));
        if clear {
            let piece = Piece::Text {
                text: text.to_string(),
                title: false,
            };
            self.pieces.push((piece, r));
        }
        clear
    }

    /// Ticks under the map's bottom edge and their labels a gap below them.
    fn x_axis(&mut self, axes: &MapAxes, ticks: &[(f64, String)], ty: Type, tick: u32) {
        let m = self.map;
        let below = m.y + m.h + 1;
        for (v, label) in ticks {
            let x = m.x + axes.x.pixel(*v, m.w as u32, false) as i64;
            self.pieces.push((Piece::Ink, Rect::new(x, below, 1, tick)));
            let lx = x - ty.width(label) as i64 / 2;
            self.text_at(label, lx, below + (tick + ty.gap()) as i64, ty);
        }
    }

    /// Ticks left of the map's left edge and their labels a gap left of them, centred on the
    /// tick.
    fn y_axis(&mut self, axes: &MapAxes, ticks: &[(f64, String)], ty: Type, tick: u32) {
        let m = self.map;
        let outside = m.x - 1 - tick as i64;
        for (v, label) in ticks {
            let y = m.y + axes.y.pixel(*v, m.h as u32, !axes.y_down) as i64;
            self.pieces
                .push((Piece::Ink, Rect::new(outside, y, tick, 1)));
            let lx = outside - (ty.gap() + ty.width(label)) as i64;
            self.text_at(label, lx, y - ty.line() as i64 / 2, ty);
        }
    }

    /// How many ticks a bar beside a map `map_h` pixels high takes at most.
    fn bar_tick_count(map_h: u32, ty: Type) -> usize {
        (map_h / (3 * ty.line())).clamp(2, 10) as usize
    }

    /// The width of the bar's column: the bar, its ticks and their widest label.
    fn bar_column_width(bar: &ColourBar, map_h: u32, ty: Type, tick: u32) -> u32 {
        let widest = bar
            .ticks(Self::bar_tick_count(map_h, ty))
            .iter()
            .map(|(_, l)| ty.width(l))
            .max()
            .unwrap_or(0);
        ty.line() + tick + ty.gap() + widest
    }

    /// The colour bar upright from the map's top to its bottom at column `bar_x`, a line of
    /// text wide, with ticks on its right and their labels a gap beyond (labels that would
    /// overlap the one above are left out); the rightmost column used.
    fn colour_bar(&mut self, bar: &ColourBar, bar_x: u32, ty: Type, tick: u32) -> u32 {
        let m = self.map;
        let thick = ty.line();
        let r = Rect::new(bar_x as i64, m.y, thick, m.h as u32);
        self.pieces.push((Piece::Bar, r));
        let (r0, r1) = upright_rows(bar, m.h as u32, thick);
        let tick_x = (bar_x + thick) as i64;
        let mut right = bar_x + thick;
        let most = Self::bar_tick_count(m.h as u32, ty);
        for (v, label) in bar.ticks(most).into_iter().rev() {
            let row =
                m.y + r0 as i64 + ((1.0 - bar.position(v)) * (r1 - r0 - 1) as f64).round() as i64;
            let lx = tick_x + (tick + ty.gap()) as i64;
            if self.text_at(&label, lx, row - ty.line() as i64 / 2, ty) {
                self.pieces
                    .push((Piece::Ink, Rect::new(tick_x, row, tick, 1)));
                self.bar_ticks.push(format!("{v}@{row}"));
                right = right.max((lx + ty.width(&label) as i64) as u32);
            }
        }
        right
    }

    /// A scale bar in km at the map's centre latitude under the map's left end, about a quarter
    /// of the map long at a round length, with its label right of it; the row below it. Nothing
    /// for axes that are not longitude and latitude, nor where the map's scale varies by more
    /// than 10 % ([`nearly_constant_scale`]).
    fn scale_bar(&mut self, axes: &MapAxes, ty: Type, y: u32) -> u32 {
        if !(axes.x.geographic() && axes.y.geographic()) {
            return y - ty.gap();
        }
        let m = self.map;
        let lat = 0.5 * (axes.y.lo + axes.y.hi);
        if !nearly_constant_scale(axes.y.lo, axes.y.hi) {
            return y - ty.gap();
        }
        let km_per_degree = EARTH_RADIUS_KM * std::f64::consts::PI / 180.0;
        let km_per_px =
            (axes.x.hi - axes.x.lo) * km_per_degree * lat.to_radians().cos() / m.w as f64;
        let target = km_per_px * m.w as f64 / 4.0;
        if !(target.is_finite() && target > 0.0) {
            return y - ty.gap();
        }
        // The longest 1, 2 or 5 × 10^k km within a quarter of the map.
        let power = 10f64.powf(target.log10().floor());
        let km = [5.0, 2.0, 1.0]
            .into_iter()
            .map(|m| m * power)
            .find(|v| *v <= target)
            .unwrap_or(power);
        let px = (km / km_per_px).round() as u32;
        let (gap, line) = (ty.gap(), ty.line());
        let thick = gap.max(3);
        let bar_y = y as i64 + (line as i64 - thick as i64) / 2;
        self.pieces
            .push((Piece::Ink, Rect::new(m.x, bar_y, px.max(1), thick)));
        let label = format!("{} km", typeset_number(km));
        self.text_at(&label, m.x + (px + gap) as i64, y as i64, ty);
        self.scale = Some((km, px));
        y + line
    }
}

/// Whether an equirectangular map between latitudes `lo` and `hi` has an east–west scale within
/// 10 % of its centre latitude's everywhere (a scale bar then means what it says): the scale
/// goes as cos φ, so its extremes are at the edges and, across the equator, at 0°.
fn nearly_constant_scale(lo: f64, hi: f64) -> bool {
    let (lo, hi) = (lo.clamp(-90.0, 90.0), hi.clamp(-90.0, 90.0));
    let c0 = (0.5 * (lo + hi)).to_radians().cos();
    let mut extremes = vec![lo.to_radians().cos(), hi.to_radians().cos()];
    if lo < 0.0 && hi > 0.0 {
        extremes.push(1.0);
    }
    c0 > 0.0 && extremes.iter().all(|c| (c / c0 - 1.0).abs() <= 0.1)
}

/// The rows [r0, r1) of a map `h` tall over which an upright bar's colours run, short of the
/// extend triangles at the ends that clip (the high end at the top).
fn upright_rows(bar: &ColourBar, h: u32, thick: u32) -> (u32, u32) {
    let (a, b) = bar.extent(h, extend_length(h, thick));
    (h - b, h - a)
}

/// `img` (exposed for display) in a figure: see the module notes. The map's pixels are copied
/// unscaled with their top-left corner at (`frame_map_origin`) of the metadata; the colour bar's
/// ticks drawn are recorded as `frame_bar_ticks` ("value@row ...") and the scale bar as
/// `frame_scale_bar` ("km pixels").
pub(crate) fn with_map_frame(
    img: &HdrImage,
    axes: Option<&MapAxes>,
    extras: &FrameExtras,
) -> crate::Result<HdrImage> {
    let l = FrameLayout::new(img, axes, extras);
    let mut out = HdrImage::new(l.width, l.height);
    out.metadata = img.metadata.clone();
    out.pixels.fill(WHITE);
    let m = l.map;
    let (x0, y0) = (m.x as u32, m.y as u32);
    let (x1, y1) = (x0 + img.width, y0 + img.height);
    fill(&mut out, (x0 - 1, x1 + 1), (y0 - 1, y0), BLACK);
    fill(&mut out, (x0 - 1, x1 + 1), (y1, y1 + 1), BLACK);
    fill(&mut out, (x0 - 1, x0), (y0 - 1, y1 + 1), BLACK);
    fill(&mut out, (x1, x1 + 1), (y0 - 1, y1 + 1), BLACK);
    for (piece, r) in &l.pieces {
        let (rx, ry) = (r.x.max(0) as u32, r.y.max(0) as u32);
        let span = ((rx, rx + r.w as u32), (ry, ry + r.h as u32));
        match piece {
            Piece::Map => {
                for row in 0..img.height {
                    let dst = ((y0 + row) * l.width + x0) as usize;
                    let src = (row * img.width) as usize;
                    out.pixels[dst..dst + img.width as usize]
                        .copy_from_slice(&img.pixels[src..src + img.width as usize]);
                }
            }
            Piece::Ink => fill(&mut out, span.0, span.1, BLACK),
            Piece::Bar => {
                if let Some(bar) = extras.bar {
                    draw_upright_bar(&mut out, bar, span, extras.ty)?;
                }
            }
            Piece::Text { text, title } => {
                let ty = if *title {
                    extras.ty.times(1.25)
                } else {
                    extras.ty
                };
                draw_text(&mut out, r.x, r.y, text, ty, BLACK);
            }
        }
    }
    out.set_meta("frame_map_origin", format!("{x0} {y0}"));
    if extras.bar.is_some() {
        out.set_meta("frame_bar_ticks", l.bar_ticks.join(" "));
    }
    if let Some((km, px)) = l.scale {
        out.set_meta("frame_scale_bar", format!("{km} {px}"));
    }
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

/// The colour bar's colours in the columns [x0, x1) and rows [y0, y1), the high end at the top,
/// with its extend triangles.
fn draw_upright_bar(
    out: &mut HdrImage,
    bar: &ColourBar,
    ((x0, x1), (y0, y1)): ((u32, u32), (u32, u32)),
    ty: Type,
) -> crate::Result<()> {
    let cmap = crate::model::colormap::Colormap::by_name(&bar.colormap)?;
    let (r0, r1) = upright_rows(bar, y1 - y0, ty.line());
    let n = (r1 - r0) as f64;
    for row in r0..r1 {
        let t = 1.0 - ((row - r0) as f64 + 0.5) / n;
        let c = cmap.linear_rgb(t);
        let colour = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
        fill(out, (x0, x1), (y0 + row, y0 + row + 1), colour);
    }
    draw_extend_triangles(out, bar, &cmap, (x0, x1), (y0, y1), true);
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
        let axes = MapAxes {
            x: lon,
            y,
            y_down: false,
            rotated: false,
        };
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
        assert_eq!(lon.label(-120.5, Some(['E', 'W'])), "120.5°W");
        assert_eq!(lon.label(0.0, Some(['E', 'W'])), "0°");
        // A rotated pole's axis: degrees with a sign, no hemisphere.
        assert_eq!(lon.label(-20.0, None), "−20°");
        assert_eq!(
            axis("phi", "degrees_north").label(15.0, Some(['N', 'S'])),
            "15°N"
        );
        assert_eq!(lon.title(), "");
        assert_eq!(axis("x", "m").label(2.5e6, Some(['E', 'W'])), "2.5×10⁶");
        assert_eq!(axis("x", "m").label(-0.5, Some(['E', 'W'])), "−0.5");
        assert_eq!(axis("x", "m").title(), "x (m)");
    }

    fn bar(extend: [bool; 2]) -> ColourBar {
        ColourBar {
            colormap: "viridis".into(),
            scale: BarScale::Linear,
            lo: 0.0,
            hi: 1.0,
            units: "m".into(),
            label: String::new(),
            extend,
        }
    }

    fn extras<'a>(ty: Type, bar: Option<&'a ColourBar>, title: Option<&'a str>) -> FrameExtras<'a> {
        FrameExtras {
            ty,
            title,
            bar,
            notes: vec!["1 fringe = 0.25 m (ν = 4 per m)".into()],
            scale_bar: true,
            graticule: None,
        }
    }

    #[test]
    fn frame_places_the_map_ticks_and_bar_by_the_layout() {
        let axes = MapAxes {
            x: MapAxis::of_coords(&coords("x", "m", (0..40).map(f64::from).collect())).unwrap(),
            y: MapAxis::of_coords(&coords("y", "m", (0..30).map(f64::from).collect())).unwrap(),
            y_down: false,
            rotated: false,
        };
        let mut img = HdrImage::new(40, 30);
        img.pixels.fill([0.25, 0.5, 0.75, 1.0]);
        let b = bar([false; 2]);
        let ty = Type::new(11.0);
        let out = with_map_frame(&img, Some(&axes), &extras(ty, Some(&b), None)).unwrap();
        let layout = FrameLayout::new(&img, Some(&axes), &extras(ty, Some(&b), None));
        let (left, top) = (layout.map.x as u32, layout.map.y as u32);
        assert_eq!(
            out.meta("frame_map_origin"),
            Some(format!("{left} {top}").as_str())
        );
        let at = |x: u32, y: u32| out.pixels[(y * out.width + x) as usize];
        assert_eq!(at(left, top), [0.25, 0.5, 0.75, 1.0]);
        assert_eq!(at(left + 39, top + 29), [0.25, 0.5, 0.75, 1.0]);
        assert_eq!(at(left - 1, top), BLACK);
        // Ticks in the columns of nodes 0 and 20 (x = node index here) and the rows of nodes 0
        // and 20 counted from the north; no tick at node 10. No scale bar on axes in metres.
        for v in [0u32, 20] {
            assert_eq!(at(left + v, top + 30 + 2), BLACK, "x tick {v}");
            assert_eq!(at(left - 3, top + 29 - v), BLACK, "y tick {v}");
        }
        assert_eq!(at(left + 10, top + 30 + 2), WHITE);
        assert_eq!(at(left - 3, top + 19), WHITE);
        assert_eq!(out.meta("frame_scale_bar"), None);
        // Bar ticks at rows top + round((1 − t) · 29), drawn right of the bar.
        let (bar_rect, _) = layout
            .pieces
            .iter()
            .find(|(p, _)| *p == Piece::Bar)
            .map(|(p, r)| (*r, p))
            .unwrap();
        let ticks = out.meta("frame_bar_ticks").unwrap().to_string();
        assert!(ticks.split(' ').count() >= 2, "{ticks}");
        for t in ticks.split(' ') {
            let (v, row) = t.split_once('@').unwrap();
            let (v, row): (f64, u32) = (v.parse().unwrap(), row.parse().unwrap());
            assert_eq!(row, top + ((1.0 - v) * 29.0).round() as u32);
            assert_eq!(at((bar_rect.x + bar_rect.w) as u32, row), BLACK);
        }
        // With both ends clipped the bar's end rows narrow to triangles in the end colours.
        let clipped = bar([true, true]);
        let out = with_map_frame(&img, Some(&axes), &extras(ty, Some(&clipped), None)).unwrap();
        let at = |x: i64, y: i64| out.pixels[(y as u32 * out.width + x as u32) as usize];
        let (x0, mid) = (bar_rect.x, bar_rect.x + bar_rect.w / 2);
        let (top_row, bottom_row) = (bar_rect.y, bar_rect.y + bar_rect.h - 1);
        assert_eq!(at(x0, top_row), WHITE);
        assert_eq!(at(x0, bottom_row), WHITE);
        let cmap = crate::model::colormap::Colormap::by_name("viridis").unwrap();
        let end = |t: f64| cmap.linear_rgb(t).map(|v| v as f32);
        let (hi, lo) = (at(mid, top_row + 1), at(mid, bottom_row - 1));
        assert_eq!([hi[0], hi[1], hi[2]], end(1.0));
        assert_eq!([lo[0], lo[1], lo[2]], end(0.0));
    }

    /// A section's depth axis runs downward: the tick of the shallowest depth is on the map's top
    /// row, deeper ticks lower, the labels increase down the figure and the axis is titled
    /// "depth (km)".
    #[test]
    fn a_downward_depth_axis_puts_depth_labels_increasing_down_the_figure() {
        let axes = MapAxes {
            x: MapAxis::of_coords(&coords("distance", "km", (0..40).map(f64::from).collect()))
                .unwrap(),
            y: MapAxis::of_coords(&coords("depth", "km", (0..30).map(f64::from).collect()))
                .unwrap(),
            y_down: true,
            rotated: false,
        };
        let mut img = HdrImage::new(40, 30);
        axes.record(&mut img);
        assert_eq!(MapAxes::of(&img), Some(axes.clone()));
        let ty = Type::new(11.0);
        let out = with_map_frame(&img, Some(&axes), &extras(ty, None, None)).unwrap();
        let layout = FrameLayout::new(&img, Some(&axes), &extras(ty, None, None));
        let (left, top) = (layout.map.x as u32, layout.map.y as u32);
        let at = |x: u32, y: u32| out.pixels[(y * out.width + x) as usize];
        for v in [0u32, 20] {
            assert_eq!(at(left - 3, top + v), BLACK, "depth tick {v}");
        }
        assert_eq!(at(left - 3, top + 29), WHITE);
        let labels: Vec<(f64, i64)> = layout
            .pieces
            .iter()
            .filter_map(|(p, r)| match p {
                Piece::Text { text, .. } if r.x + r.w < layout.map.x => {
                    text.parse::<f64>().ok().map(|v| (v, r.y))
                }
                _ => None,
            })
            .collect();
        assert!(labels.len() >= 2, "{labels:?}");
        assert!(
            labels
                .windows(2)
                .all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1),
            "{labels:?}"
        );
        let titles = |want: &str| {
            layout
                .pieces
                .iter()
                .any(|(p, _)| matches!(p, Piece::Text { text, .. } if text == want))
        };
        assert!(titles("depth (km)") && titles("distance (km)"));
    }

    /// Every text box of a framed figure — tick labels, axis and bar captions, the title, the
    /// legend line, the scale bar's label — lies inside the figure and overlaps no other piece
    /// (map, bar, ticks, scale bar, other text), at small and large type, with extend triangles
    /// and without; and each tick label keeps at least a gap from its tick.
    #[test]
    fn framed_figure_pieces_never_overlap() {
        let geo = |name: &str, units: &str, from: f64, n: usize, step: f64| {
            MapAxis::of_coords(&coords(
                name,
                units,
                (0..n).map(|i| from + step * i as f64).collect(),
            ))
            .unwrap()
        };
        let cases = [
            (
                geo("lon", "degrees_east", 120.0, 512, 0.02),
                geo("lat", "degrees_north", -10.0, 256, 0.02),
                (512, 256),
            ),
            (
                geo("x", "km", -300.0, 400, 1.5),
                geo("depth", "km", -2900.0, 300, 10.0),
                (400, 300),
            ),
        ];
        for (x, y, (w, h)) in cases {
            let axes = MapAxes {
                x,
                y,
                y_down: false,
                rotated: false,
            };
            let img = HdrImage::new(w, h);
            for ty in [Type::for_figure(img.width, img.height), Type::new(30.0)] {
                for extend in [[false; 2], [true, true]] {
                    let b = bar(extend);
                    let e = extras(ty, Some(&b), Some("Sea-surface height, 2011 Tōhoku"));
                    let l = FrameLayout::new(&img, Some(&axes), &e);
                    let texts: Vec<&Rect> = l
                        .pieces
                        .iter()
                        .filter(|(p, _)| matches!(p, Piece::Text { .. }))
                        .map(|(_, r)| r)
                        .collect();
                    assert!(texts.len() >= 8, "{}", texts.len());
                    for (i, (p, r)) in l.pieces.iter().enumerate() {
                        assert!(
                            r.x >= 0
                                && r.y >= 0
                                && r.x + r.w <= l.width as i64
                                && r.y + r.h <= l.height as i64,
                            "{p:?} {r:?} outside {}×{}",
                            l.width,
                            l.height
                        );
                        for (q, o) in &l.pieces[i + 1..] {
                            let text =
                                matches!(p, Piece::Text { .. }) || matches!(q, Piece::Text { .. });
                            let solid = matches!(p, Piece::Map | Piece::Bar)
                                || matches!(q, Piece::Map | Piece::Bar);
                            if text || solid {
                                assert!(!r.overlaps(o), "{p:?} {r:?} overlaps {q:?} {o:?}");
                            }
                        }
                    }
                    // A gap between each tick and the nearest text box.
                    let g = ty.gap() as i64;
                    for (_, t) in l.pieces.iter().filter(|(p, _)| *p == Piece::Ink) {
                        let grown = Rect {
                            x: t.x - g + 1,
                            y: t.y - g + 1,
                            w: t.w + 2 * g - 2,
                            h: t.h + 2 * g - 2,
                        };
                        assert!(
                            texts.iter().all(|r| !r.overlaps(&grown)),
                            "a label touches the tick at {t:?}"
                        );
                    }
                }
            }
        }
    }

    /// A long caption ends where the bar's column does and reaches left over the map's top: the
    /// figure is as wide as with a short one, and no text overlaps.
    #[test]
    fn a_long_bar_caption_does_not_widen_the_figure() {
        let axis = |name: &str, n: usize| {
            MapAxis::of_coords(&coords(name, "m", (0..n).map(|i| i as f64 * 1e3).collect()))
                .unwrap()
        };
        let axes = MapAxes {
            x: axis("x", 400),
            y: axis("y", 300),
            y_down: false,
            rotated: false,
        };
        let img = HdrImage::new(400, 300);
        let ty = Type::for_figure(img.width, img.height);
        let short = bar([false; 2]);
        let long = ColourBar {
            label: "maximum absolute sea-surface elevation over the run".into(),
            ..bar([false; 2])
        };
        let width = |b: &ColourBar| FrameLayout::new(&img, Some(&axes), &extras(ty, Some(b), None));
        let (a, b) = (width(&short), width(&long));
        assert_eq!(a.width, b.width);
        let caption = b
            .pieces
            .iter()
            .find(|(p, _)| matches!(p, Piece::Text { text, .. } if text.starts_with("maximum")))
            .map(|(_, r)| *r)
            .expect("the caption is drawn");
        assert!(caption.x >= b.map.x && caption.y + caption.h <= b.map.y);
        for (p, r) in b
            .pieces
            .iter()
            .filter(|(p, _)| matches!(p, Piece::Text { .. }))
        {
            assert!(*r == caption || !r.overlaps(&caption), "{p:?} {r:?}");
        }
    }

    /// The scale bar at the map's centre latitude: a round length in km drawn as many pixels as
    /// the map's scale there makes it (edges lon 119.99–130.23°, lat −10.01…−4.89°: 2.2051 km
    /// per pixel).
    #[test]
    fn scale_bar_is_in_km_at_the_centre_latitude() {
        let axes = MapAxes {
            x: MapAxis::of_coords(&coords(
                "lon",
                "degrees_east",
                (0..512).map(|i| 120.0 + 0.02 * i as f64).collect(),
            ))
            .unwrap(),
            y: MapAxis::of_coords(&coords(
                "lat",
                "degrees_north",
                (0..256).map(|i| -10.0 + 0.02 * i as f64).collect(),
            ))
            .unwrap(),
            y_down: false,
            rotated: false,
        };
        let img = HdrImage::new(512, 256);
        let out = with_map_frame(&img, Some(&axes), &extras(Type::new(12.0), None, None)).unwrap();
        let lat = (-10.01f64 + -4.89) / 2.0;
        let km_per_px =
            10.24 * 6371.0088 * std::f64::consts::PI / 180.0 * lat.to_radians().cos() / 512.0;
        assert!((km_per_px - 2.2051).abs() < 1e-3, "{km_per_px}");
        // A quarter of the map is 282 km: the bar is 200 km, 91 pixels.
        let scale = out.meta("frame_scale_bar").unwrap();
        assert_eq!(scale, "200 91");
        assert_eq!((200.0 / km_per_px).round(), 91.0);
    }

    #[test]
    fn the_scale_bar_is_left_out_where_the_scale_varies_and_ticks_take_degree_steps() {
        assert!(nearly_constant_scale(-10.0, 20.0));
        assert!(nearly_constant_scale(35.0, 47.0));
        assert!(!nearly_constant_scale(-80.0, 80.0));
        assert!(!nearly_constant_scale(60.0, 80.0));
        let axis = |lo, hi, name: &str| MapAxis {
            name: name.into(),
            units: "degrees".into(),
            lo,
            hi,
        };
        let values = |t: Vec<(f64, String)>| t.into_iter().map(|(v, _)| v).collect::<Vec<_>>();
        // A world map: 30° steps on 600 px, 45° on 400 (labels 7 px a character and a gap of
        // one), 180° and beyond read west.
        let lon = axis(0.0, 360.0, "lon");
        let extent = |l: &str| 7 * l.chars().count() as u32 + 7;
        let t = lon.ticks(600, Some(['E', 'W']), None, extent);
        assert_eq!(
            values(t.clone()),
            (0..13).map(|k| 30.0 * k as f64).collect::<Vec<_>>()
        );
        assert_eq!(t[8].1, "120°W");
        let t = lon.ticks(400, Some(['E', 'W']), None, extent);
        assert_eq!(
            values(t),
            (0..9).map(|k| 45.0 * k as f64).collect::<Vec<_>>()
        );
        // With a 45° graticule the ticks fall on its lines.
        let t = lon.ticks(600, Some(['E', 'W']), Some(45.0), extent);
        assert!(values(t).iter().all(|v| v % 45.0 == 0.0));
        let lat = axis(-80.0, 80.0, "lat");
        let t = lat.ticks(300, Some(['N', 'S']), None, |_| 40);
        assert_eq!(values(t), vec![-60.0, -30.0, 0.0, 30.0, 60.0]);
    }

    /// The default type grows with the figure: the ink of the x labels is four times as tall
    /// under a map four times as large.
    #[test]
    fn label_height_scales_with_the_figure() {
        let ink_height = |w: u32, h: u32| {
            let axes = MapAxes {
                x: MapAxis::of_coords(&coords(
                    "lon",
                    "degrees_east",
                    (0..w).map(|i| 120.0 + 10.0 * i as f64 / w as f64).collect(),
                ))
                .unwrap(),
                y: MapAxis::of_coords(&coords(
                    "lat",
                    "degrees_north",
                    (0..h).map(|i| 10.0 * i as f64 / h as f64).collect(),
                ))
                .unwrap(),
                y_down: false,
                rotated: false,
            };
            let img = HdrImage::new(w, h);
            let e = FrameExtras {
                ty: Type::for_figure(w, h),
                title: None,
                bar: None,
                notes: Vec::new(),
                scale_bar: false,
                graticule: None,
            };
            let l = FrameLayout::new(&img, Some(&axes), &e);
            let out = with_map_frame(&img, Some(&axes), &e).unwrap();
            let below = l.map.y + l.map.h + 1 + e.ty.gap().max(3) as i64;
            let (_, r) = l
                .pieces
                .iter()
                .find(|(p, r)| matches!(p, Piece::Text { .. }) && r.y > below)
                .unwrap();
            (r.y..r.y + r.h)
                .filter(|y| {
                    (r.x..r.x + r.w)
                        .any(|x| out.pixels[(*y as u32 * out.width + x as u32) as usize][0] < 0.5)
                })
                .count() as f64
        };
        let (small, large) = (ink_height(512, 512), ink_height(2048, 2048));
        assert!(small >= 10.0, "{small}");
        assert!((large / small - 4.0).abs() < 0.4, "{large} / {small}");
    }
}
