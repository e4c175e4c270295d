//! What a surface render is asked for: [`SurfaceOptions`] with its validation, the option
//! enums (view, colour mode, phase method, missing colour) and the image size a render gets.

use super::globe::GlobeFrame;
use super::MAX_PROPERTIES;
use crate::datasets::coastlines::CoastResolution;
use crate::error::{Error, Result};
use crate::model::{Camera, Grid, MapProjection, Projection};

/// How the surface is seen in step 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceView {
    /// Top-down orthographic, north up; by default one pixel per grid node.
    Map,
    /// Perspective orbit around the relief (degrees; azimuth about +z from +x).
    Orbit {
        azimuth: f64,
        elevation: f64,
        fov: f64,
    },
    /// Any camera, in the surface's world space: x = (x − x₀), y = (y − y₀) in coordinate units,
    /// z = (height − min height) × exaggeration.
    Camera(Camera),
    /// A geographic grid draped on the unit sphere (Earth-centred frame: +x toward 0°N 0°E, +y
    /// toward 0°N 90°E, +z north), seen by this camera in that frame; no relief.
    Globe(Camera),
}

impl SurfaceView {
    pub(super) fn key(&self) -> Vec<u64> {
        match self {
            SurfaceView::Map => vec![0],
            SurfaceView::Orbit {
                azimuth,
                elevation,
                fov,
            } => vec![1, azimuth.to_bits(), elevation.to_bits(), fov.to_bits()],
            SurfaceView::Camera(c) | SurfaceView::Globe(c) => {
                let globe = matches!(self, SurfaceView::Globe(_));
                let mut k = vec![2 + globe as u64];
                for v in [c.eye, c.forward, c.right, c.up] {
                    k.extend(v.iter().map(|x| x.to_bits()));
                }
                match c.projection {
                    Projection::Perspective { fov_y_deg } => k.push(fov_y_deg.to_bits()),
                    Projection::Orthographic {
                        half_width,
                        half_height,
                    } => k.extend([half_width.to_bits(), half_height.to_bits()]),
                }
                k
            }
        }
    }

    pub fn describe(&self) -> String {
        match self {
            SurfaceView::Map => "map (top-down orthographic, north up)".into(),
            SurfaceView::Orbit {
                azimuth,
                elevation,
                fov,
            } => format!("orbit azimuth {azimuth} elevation {elevation} fov {fov}"),
            SurfaceView::Camera(c) => c.describe(),
            SurfaceView::Globe(c) => format!("globe (unit sphere), {}", c.describe()),
        }
    }

    /// The globe seen from `distance` sphere radii above the centre of `grid`'s extent, north
    /// up (+y up over a pole), with a `fov`-degree perspective.
    pub(crate) fn globe_above(grid: &Grid, distance: f64, fov: f64) -> Result<SurfaceView> {
        let (lat, lon) = if crate::model::grid_sampler::evenly_spaced(grid) {
            GlobeFrame::of(grid)?.centre()
        } else {
            // Uneven axes (drawn with their nodes placed on the host): the middle of their
            // bounds, on the true sphere.
            GlobeFrame::check_geographic(grid)?;
            let b = crate::model::GridSampler::new(grid).bounds();
            let (lat, lon) = (0.5 * (b[2] + b[3]), 0.5 * (b[0] + b[1]));
            grid.rotated_pole()
                .map_or((lat, lon), |r| r.to_true(lat, lon))
        };
        Ok(SurfaceView::Globe(Camera::geo(
            [0.0; 3], lat, lon, distance, fov,
        )?))
    }

    /// 0: perspective over the relief, 1: map, 2: globe (the data shader's `VIEW`).
    pub(super) fn code(&self) -> u32 {
        match self {
            SurfaceView::Map => 1,
            SurfaceView::Globe(_) => 2,
            _ => 0,
        }
    }
}

/// The three colour modes of the paper's Fig. 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FringeMode {
    /// (a) The wrapped phase frac(ν·d) through a cyclic colour map: one colour cycle per fringe.
    Cyclic,
    /// (b) A colour over the data range (optionally log-scaled), modulated by the fringes.
    Modulated,
    /// (c) A colour map without fringes (the `fringe` channel is still written).
    Direct,
}

impl FringeMode {
    pub(crate) const NAMES: &'static [&'static str] = &["cyclic", "modulated", "direct"];

    pub fn parse(s: &str) -> Result<FringeMode> {
        match s {
            "cyclic" => Ok(FringeMode::Cyclic),
            "modulated" => Ok(FringeMode::Modulated),
            "direct" => Ok(FringeMode::Direct),
            _ => Err(Error::invalid(
                "mode",
                format!("expected \"cyclic\", \"modulated\" or \"direct\", got {s:?}"),
            )),
        }
    }

    /// The mode after this one, cyclic → modulated → direct → cyclic (the TUI's `m`).
    pub(crate) fn next(self) -> FringeMode {
        match self {
            FringeMode::Cyclic => FringeMode::Modulated,
            FringeMode::Modulated => FringeMode::Direct,
            FringeMode::Direct => FringeMode::Cyclic,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            FringeMode::Cyclic => "cyclic",
            FringeMode::Modulated => "modulated",
            FringeMode::Direct => "direct",
        }
    }

    pub(super) fn code(self) -> u32 {
        match self {
            FringeMode::Cyclic => 0,
            FringeMode::Modulated => 1,
            FringeMode::Direct => 2,
        }
    }
}

/// How the fringe pass evaluates the phase 2π·ν·d.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PhaseMethod {
    /// d kept as d_ref + hi + rest, ν split into short parts, fractions taken before the sums
    /// (see the module notes): ~1e-6 of a period for ν·d up to ~1e10.
    #[default]
    Reduced,
    /// What a straightforward implementation does: d as one f32, cos(2π·ν·d) evaluated directly
    /// in f32 with no reference subtraction or range reduction. Kept to measure what the
    /// reduction buys (`hdrvis bench accuracy`).
    Naive,
}

impl PhaseMethod {
    pub(crate) const NAMES: &'static [&'static str] = &["reduced", "naive"];

    pub fn parse(s: &str) -> Result<PhaseMethod> {
        match s {
            "reduced" => Ok(PhaseMethod::Reduced),
            "naive" => Ok(PhaseMethod::Naive),
            _ => Err(Error::invalid(
                "phase",
                format!("expected \"reduced\" or \"naive\", got {s:?}"),
            )),
        }
    }

    /// What the image metadata says about the phase.
    pub fn describe(self) -> &'static str {
        match self {
            PhaseMethod::Reduced => "f64 via d_ref + hi + rest and exact 12-bit partial products",
            PhaseMethod::Naive => "naive: cos(2 pi nu d) in f32 with d as one f32",
        }
    }
}

/// How pixels without data (NaN nodes such as land, or the background of a 3-D view) are drawn.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum MissingColour {
    /// RGBA 0: transparent in a PNG (which then gets an alpha channel) and in the EXR.
    #[default]
    Transparent,
    /// An opaque colour (linear RGB) by name or `#rrggbb`; no fringe is ever drawn in it, as
    /// no fringe is opaque and flat over an area with no data.
    Colour { name: String, linear: [f64; 3] },
}

impl MissingColour {
    /// `"transparent"`, a colour name or `#rrggbb`.
    pub fn parse(name: &str) -> Result<MissingColour> {
        if name.trim().eq_ignore_ascii_case("transparent") {
            return Ok(MissingColour::Transparent);
        }
        let linear = crate::model::colormap::named_colour("missing", name)
            .map_err(|e| Error::invalid("missing", format!("{e} (or \"transparent\")")))?;
        Ok(MissingColour::Colour {
            name: name.trim().to_string(),
            linear,
        })
    }

    /// What the image metadata says: `transparent` or the colour's name.
    pub fn describe(&self) -> &str {
        match self {
            MissingColour::Transparent => "transparent",
            MissingColour::Colour { name, .. } => name,
        }
    }

    /// The colour holes are painted in, linear RGB; `None` for transparent.
    pub(super) fn linear(&self) -> Option<[f32; 3]> {
        match self {
            MissingColour::Transparent => None,
            MissingColour::Colour { linear, .. } => {
                Some([linear[0] as f32, linear[1] as f32, linear[2] as f32])
            }
        }
    }
}

/// Everything a surface render depends on besides the grid.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// Properties to render (1 to 4), all from one data pass; empty means the grid's first.
    pub properties: Vec<String>,
    /// ν per property (one value applies to all).
    pub nu: Vec<f64>,
    pub mode: FringeMode,
    /// Colour map name; `None` picks `sinebow` for cyclic mode and `viridis` otherwise.
    pub colormap: Option<String>,
    /// Modulation depth m in [0, 1]: colour × (1 − m + m·I).
    pub modulation: f64,
    /// Use |d| (for colour; the fringe intensity is symmetric in d).
    pub absolute: bool,
    /// Log-scaled colour over |d| in modulated/direct modes.
    pub log_color: bool,
    pub view: SurfaceView,
    /// Image size; `None` is a figure-sized map ([`default_size`]) or 512 (other views).
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Height for relief in 3-D views: `elevation`, a property name, or `None` (flat).
    pub relief: Option<String>,
    pub exaggeration: f64,
    /// How the fringe pass evaluates the phase (reduced by default).
    pub phase: PhaseMethod,
    /// Colours from the fringe averaged over each pixel's footprint (on by default), so fringes
    /// denser than the pixels fade to their mean instead of aliasing.
    pub antialias: bool,
    /// How pixels without data are drawn (transparent by default).
    pub missing: MissingColour,
    /// The data values the colours span in modulated and direct modes (magnitudes with
    /// `absolute` or `log_color`) instead of the data's range; values outside take the end
    /// colours, so renders with one domain give one value one colour.
    pub domain: Option<(f64, f64)>,
    /// The colour range made symmetric about this value, for diverging maps: about the domain
    /// when one is given, else with half-width max |d − c| over the data.
    pub centre: Option<f64>,
    /// Natural Earth coastlines over a map or globe view of a longitude/latitude grid.
    pub coastlines: Option<CoastlineStyle>,
    /// Meridians and parallels every this many degrees over a map or globe view.
    pub graticule: Option<f64>,
    /// A mesh's cell outlines over its map or globe view (the style's resolution unused).
    pub cell_edges: Option<CoastlineStyle>,
    /// Lines across a section's map at these depths.
    pub depth_rings: Option<crate::model::DepthRings>,
    /// The map view's projection; `None` (or equirectangular) is the equirectangular map.
    pub projection: Option<MapProjection>,
    /// Contour lines over the picture.
    pub contours: Option<super::marks::ContourStyle>,
    /// Vector arrows over the picture.
    pub vectors: Option<super::marks::VectorStyle>,
    /// What the colour bar says it measures; `None`: the property's long name and units.
    pub label: Option<String>,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            properties: Vec::new(),
            nu: vec![1.0],
            mode: FringeMode::Cyclic,
            colormap: None,
            modulation: 1.0,
            absolute: false,
            log_color: false,
            view: SurfaceView::Map,
            width: None,
            height: None,
            relief: None,
            exaggeration: 1.0,
            phase: PhaseMethod::Reduced,
            antialias: true,
            missing: MissingColour::Transparent,
            domain: None,
            centre: None,
            coastlines: None,
            graticule: None,
            cell_edges: None,
            depth_rings: None,
            projection: None,
            contours: None,
            vectors: None,
            label: None,
        }
    }
}

/// ν must be finite and positive.
pub(crate) fn check_nu(nu: f64) -> Result<()> {
    if nu.is_finite() && nu > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            "nu",
            format!("expected a finite frequency > 0 (fringes per data unit), got {nu}"),
        ))
    }
}

impl SurfaceOptions {
    pub fn validate(&self) -> Result<()> {
        if self.properties.len() > MAX_PROPERTIES {
            return Err(Error::invalid(
                "property",
                format!(
                    "at most {MAX_PROPERTIES} properties per data pass, got {}",
                    self.properties.len()
                ),
            ));
        }
        if self.nu.is_empty() {
            return Err(Error::invalid("nu", "expected at least one value"));
        }
        for &nu in &self.nu {
            check_nu(nu)?;
        }
        let n = self.properties.len().max(1);
        if self.nu.len() != 1 && self.nu.len() != n {
            return Err(Error::invalid(
                "nu",
                format!(
                    "expected one ν or one per property ({n}), got {}",
                    self.nu.len()
                ),
            ));
        }
        if !(self.modulation.is_finite() && (0.0..=1.0).contains(&self.modulation)) {
            return Err(Error::invalid(
                "modulation",
                format!("expected a depth in [0, 1], got {}", self.modulation),
            ));
        }
        if !(self.exaggeration.is_finite() && self.exaggeration >= 0.0) {
            return Err(Error::invalid(
                "exaggeration",
                format!("expected a finite factor >= 0, got {}", self.exaggeration),
            ));
        }
        self.validate_colour_range()?;
        if let Some(p) = &self.projection {
            p.validate()?;
            if self.view != SurfaceView::Map && !p.is_equirectangular() {
                return Err(Error::invalid(
                    "projection",
                    format!(
                        "a projection applies to the map view, not to {}",
                        self.view.describe()
                    ),
                ));
            }
        }
        if let Some(c) = &self.coastlines {
            c.validate("coastlines")?;
        }
        if let Some(c) = &self.cell_edges {
            c.validate("cell_edges")?;
        }
        if let Some(step) = self.graticule {
            check_graticule(step)?;
        }
        for (f, v) in [("width", self.width), ("height", self.height)] {
            if let Some(v) = v {
                if v == 0 || v > crate::render::MAX_IMAGE_SIDE {
                    return Err(Error::invalid(
                        f,
                        format!(
                            "expected 1 to {} pixels, got {v}",
                            crate::render::MAX_IMAGE_SIDE
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether `grid` is drawn by placing its pixels on the host (`located`): a map in a
    /// projection other than the equirectangular, and a map or globe of a grid whose axes are
    /// not evenly spaced. (3-D views over a relief draw an uneven grid sampled onto even axes
    /// at its finest spacing instead.)
    pub(crate) fn host_placed(&self, grid: &Grid) -> bool {
        match self.view {
            SurfaceView::Map => {
                self.projected() || !crate::model::grid_sampler::evenly_spaced(grid)
            }
            SurfaceView::Globe(_) => !crate::model::grid_sampler::evenly_spaced(grid),
            _ => false,
        }
    }

    /// Whether the map is drawn in a projection other than the equirectangular.
    pub fn projected(&self) -> bool {
        self.view == SurfaceView::Map && self.projection.is_some_and(|p| !p.is_equirectangular())
    }

    /// What step 1's picture depends on of the view: the view, and a map's projection.
    pub(super) fn view_key(&self) -> Vec<u64> {
        let mut key = self.view.key();
        if let Some(p) = self.projection.filter(|_| self.projected()) {
            key.push(100 + p.kind as u64);
            for v in [p.lon_0, p.lat_0, p.lat_1, p.lat_2] {
                key.push(v.map_or(u64::MAX, f64::to_bits));
            }
        }
        key
    }

    /// `domain` and `centre` alone: finite, a domain increasing (positive under log colour), a
    /// centre inside the domain, and neither in cyclic mode, whose colours follow the phase.
    pub(crate) fn validate_colour_range(&self) -> Result<()> {
        let given = |f: &str| {
            Error::invalid(
                f,
                "cyclic colours follow the fringe phase, not the data; use mode \"modulated\" or \"direct\" for a colour range",
            )
        };
        if self.mode == FringeMode::Cyclic {
            if self.domain.is_some() {
                return Err(given("domain"));
            }
            if self.centre.is_some() {
                return Err(given("centre"));
            }
        }
        if let Some((lo, hi)) = self.domain {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(Error::invalid(
                    "domain",
                    format!("expected [lo, hi] with finite lo < hi, got [{lo}, {hi}]"),
                ));
            }
            if self.log_color && lo <= 0.0 {
                return Err(Error::invalid(
                    "domain",
                    format!("log colour spans magnitudes: expected 0 < lo < hi, got [{lo}, {hi}]"),
                ));
            }
        }
        if let Some(c) = self.centre {
            if !c.is_finite() {
                return Err(Error::invalid(
                    "centre",
                    format!("expected a finite value, got {c}"),
                ));
            }
            if self.log_color {
                return Err(Error::invalid(
                    "centre",
                    "a log colour scale has no centre; drop centre or log_color",
                ));
            }
            if let Some((lo, hi)) = self.domain.filter(|(lo, hi)| c < *lo || c > *hi) {
                return Err(Error::invalid(
                    "centre",
                    format!("{c} lies outside the domain [{lo}, {hi}]"),
                ));
            }
        }
        Ok(())
    }

    /// The data values the colours span for a property whose finite values lie in `data`
    /// (`None`: all missing): the domain, else the data's range, made symmetric about the centre
    /// when one is given. A centre outside the data with no domain is an error naming `property`.
    pub(crate) fn colour_range(
        &self,
        data: Option<(f64, f64)>,
        property: &str,
    ) -> Result<Option<(f64, f64)>> {
        let Some((lo, hi)) = self.domain.or(data) else {
            return Ok(None);
        };
        let Some(c) = self.centre else {
            return Ok(Some((lo, hi)));
        };
        if self.domain.is_none() && (c < lo || c > hi) {
            return Err(Error::invalid(
                "centre",
                format!(
                    "{c} lies outside the data of {property:?} ([{lo}, {hi}]); give a domain to centre beyond the data"
                ),
            ));
        }
        let half = (lo - c).abs().max((hi - c).abs());
        Ok(Some((c - half, c + half)))
    }

    pub(super) fn nu_for(&self, i: usize) -> f64 {
        if self.nu.len() == 1 {
            self.nu[0]
        } else {
            self.nu[i]
        }
    }

    pub(super) fn colormap_name(&self) -> &str {
        match &self.colormap {
            Some(c) => c,
            None if self.mode == FringeMode::Cyclic => "sinebow",
            None => "viridis",
        }
    }
}

/// The image size a render gets: the options' size, else in map view a figure-sized map of the
/// grid's nodes ([`map_size`]) and 512² in other views.
pub(crate) fn default_size(grid: &Grid, opts: &SurfaceOptions) -> (u32, u32) {
    match opts.view {
        SurfaceView::Map => {
            let aspect = grid
                .map_aspect()
                .unwrap_or(grid.nx() as f64 / grid.ny() as f64);
            map_size(grid.nx(), grid.ny(), aspect, opts.width, opts.height)
        }
        _ => (opts.width.unwrap_or(512), opts.height.unwrap_or(512)),
    }
}

/// The map size of `grid` drawn linearly over `bounds` ([x_lo, x_hi, y_lo, y_hi] of its axes)
/// with `nodes` the node counts that resolve its finest spacing: as [`default_size`] gives
/// for a grid with that many evenly spaced nodes over those bounds.
pub(super) fn map_size_of(
    grid: &Grid,
    bounds: [f64; 4],
    (nx, ny): (usize, usize),
    opts: &SurfaceOptions,
) -> (u32, u32) {
    let aspect = if grid.is_geographic() {
        let lat_c = (0.5 * (bounds[2] + bounds[3]))
            .clamp(-90.0, 90.0)
            .to_radians();
        (bounds[1] - bounds[0]) * lat_c.cos().max(1e-6) / (bounds[3] - bounds[2])
    } else {
        nx as f64 / ny as f64
    };
    map_size(nx, ny, aspect, opts.width, opts.height)
}

/// The long side a default map aims at: a figure, not a thumbnail.
pub(crate) const FIGURE_SIDE: f64 = 1000.0;

/// The size of a map `aspect` times as wide as high, of a grid with `nx` × `ny` nodes: both
/// sides as given; one given, the other from the aspect; neither, the smallest image of that
/// aspect with at least one pixel per node along both axes, enlarged by [`figure_factor`] to
/// about [`FIGURE_SIDE`] on its long side (at most 16384 a side).
fn map_size(
    nx: usize,
    ny: usize,
    aspect: f64,
    width: Option<u32>,
    height: Option<u32>,
) -> (u32, u32) {
    let side = |v: f64| v.round().clamp(1.0, 16384.0) as u32;
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, side(w as f64 / aspect)),
        (None, Some(h)) => (side(h as f64 * aspect), h),
        (None, None) => {
            let (w, h) = if nx as f64 >= ny as f64 * aspect {
                (nx as f64, nx as f64 / aspect)
            } else {
                (ny as f64 * aspect, ny as f64)
            };
            let grow = figure_factor(w.max(h)) as f64;
            let shrink = (16384.0 / (grow * w.max(h))).min(1.0);
            (side(w * grow * shrink), side(h * grow * shrink))
        }
    }
}

/// The whole odd factor that brings a map's long side of `long` pixels nearest (in ratio) to
/// [`FIGURE_SIDE`], at least 1. Odd, so that at one pixel per node times the factor a pixel's
/// centre still falls on every node: the nodes' own values are shown, and the pixels between
/// two nodes lie symmetrically about them.
pub(crate) fn figure_factor(long: f64) -> u32 {
    if long >= FIGURE_SIDE {
        return 1;
    }
    let mut k = 1u32;
    while ((long * (k + 2) as f64) / FIGURE_SIDE).ln().abs()
        < ((long * k as f64) / FIGURE_SIDE).ln().abs()
    {
        k += 2;
    }
    k
}

/// Resolves the property list to grid indices (unknown names list the known ones).
pub(super) fn property_indices(grid: &Grid, opts: &SurfaceOptions) -> Result<Vec<usize>> {
    if opts.properties.is_empty() {
        return Ok(vec![0]);
    }
    opts.properties
        .iter()
        .map(|p| grid.property_index(p))
        .collect()
}

/// How coastlines are drawn: colour (linear RGB, with the name it was given), line width in
/// pixels and the Natural Earth scale (`None`: chosen by the map's extent).
#[derive(Clone, Debug, PartialEq)]
pub struct CoastlineStyle {
    pub colour: String,
    pub linear: [f64; 3],
    pub width: f64,
    pub resolution: Option<CoastResolution>,
}

impl Default for CoastlineStyle {
    fn default() -> Self {
        CoastlineStyle {
            colour: "black".into(),
            linear: [0.0; 3],
            width: 1.0,
            resolution: None,
        }
    }
}

/// A graticule step must be a finite number of degrees in (0, 90].
pub(crate) fn check_graticule(step: f64) -> Result<()> {
    if step.is_finite() && step > 0.0 && step <= 90.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            "graticule",
            format!("expected a step in degrees > 0 and at most 90, got {step}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_default_map_is_a_figure_with_a_pixel_on_every_node() {
        // The odd factor nearest in ratio to 1000 pixels on the long side.
        assert_eq!(figure_factor(58.0), 17);
        assert_eq!(figure_factor(90.0), 11);
        assert_eq!(figure_factor(20.0), 51);
        assert_eq!(figure_factor(360.0), 3);
        assert_eq!(figure_factor(512.0), 3);
        assert_eq!(figure_factor(600.0), 1);
        assert_eq!(figure_factor(1000.0), 1);
        assert_eq!(figure_factor(4096.0), 1);
        // A plain 49 × 37 grid: 21 pixels a node; a width alone keeps the nodes' aspect.
        assert_eq!(map_size(49, 37, 49.0 / 37.0, None, None), (1029, 777));
        assert_eq!(map_size(49, 37, 49.0 / 37.0, Some(490), None), (490, 370));
        assert_eq!(map_size(49, 37, 49.0 / 37.0, None, Some(74)), (98, 74));
        // A global 1° grid: three pixels a degree; 16384 caps the largest.
        assert_eq!(map_size(360, 180, 2.0, None, None), (1080, 540));
        assert_eq!(map_size(40000, 20, 2000.0, None, None), (16384, 8));
    }
}
