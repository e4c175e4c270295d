//! Interference-based surface rendering (Yuan et al. 2008, section 2.1) in two GPU steps. Step 1,
//! the data pass (`shaders/surface_data.wgsl`), renders a grid in map view or in a lit 3-D
//! perspective view with relief and writes up to four properties per pixel into float targets in
//! one pass. Step 2, the fringe pass (`shaders/surface_fringe.wgsl`), turns one property into
//! I = (1 + cos 2πν·d)/2 with a colour lookup. [`SurfaceRenderer`] caches step-1 targets keyed by
//! (grid identity, view, size, properties, relief), so changing ν, the colour mode or the colour
//! map re-runs only step 2.
//!
//! Phase precision: per node the host computes d − d_ref in f64 (d_ref = the middle of the
//! property's range) and uploads it as hi = f32(d − d_ref) and rest = f32((d − d_ref) − hi). ν is
//! split on the host into ν₁ + ν₂ + ν₃ with 12 significant bits in ν₁ and ν₂; the shader splits hi
//! into h₁ + h₂ of 12 significant bits each by masking mantissa bits. The four products νᵢ·hⱼ
//! (i, j ≤ 2) are then exact in f32, their fractions are taken separately, and the small terms
//! ν₂h₂ + ν₃·hi + ν·rest and frac(ν·d_ref) (computed in f64 on the host) are added before a last
//! fraction; the cosine sees an argument in [−π, π]. This holds to ~1e-6 of a period for ν·d up
//! to ~10¹⁰ at pixels on grid nodes (map view at the default size); between nodes the values are
//! interpolated in f32 relative to d_ref. For comparison, [`PhaseMethod::Naive`] specialises the
//! fringe pass to what a straightforward implementation does (d as one f32, cos 2πν·d in f32);
//! `hdrvis bench accuracy` measures both.
//!
//! Antialiasing: fringes denser than the pixels would alias into moiré, so the fringe pass also
//! writes the fringe averaged over the pixel's footprint — a Gaussian of σ = 0.5 pixel along the
//! data's gradient, (1 + cos 2πν·d · exp(−2π²ν²σ²|∇d|²))/2 for a field linear across it, with ∇d
//! in data units per pixel from central differences of the neighbouring pixels (the screen-space
//! derivative in 3-D views). The colours use it unless `antialias` is off; the point value stays
//! in the `fringe` channel and the filtered one is `fringe_filtered` ([`fringe_filtered_f64`] and
//! [`pixel_gradient`] are the f64 forms).
//!
//! Geographic grids (longitude along x, latitude along y): the map keeps the equirectangular
//! aspect of [`Grid::map_aspect`], and [`SurfaceView::Globe`] drapes the field on the unit sphere
//! of the Earth-centred frame ([`GlobeFrame`]) for any camera.
//!
//! With `HDRVIS_SURFACE_PROFILE` set, each fringe pass prints its stage times to stderr.

use crate::error::{Error, Result};
use crate::gpu::transfer::ReadbackBuffer;
use crate::gpu::{pipeline, shader, GpuContext};
use crate::model::colormap::Colormap;
use crate::model::geometry::sphere_hit;
use crate::model::map_frame::MapAxis;
use crate::model::{Aabb, Camera, Grid, HdrImage, Projection};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Most properties one data pass writes (one RGBA32F target component each).
pub(crate) const MAX_PROPERTIES: usize = 4;
/// Entries in the colour lookup table.
pub const LUT_SIZE: usize = 256;
/// Step-1 results kept per renderer.
const CACHE_ENTRIES: usize = 4;

/// Host mirror of `Params` in shaders/surface_data.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct DataParams {
    eye: [f32; 4],
    forward: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    proj: [f32; 4],
    cell: [f32; 4],
    light: [f32; 4],
    box_size: [f32; 4],
    globe: [f32; 4],
    dims: [u32; 4],
    counts: [u32; 4],
}

/// Host mirror of `Params` in shaders/surface_fringe.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FringeParams {
    nu: [f32; 4],
    refs: [f32; 4],
    shade: [f32; 4],
    mode: [u32; 4],
    dims: [u32; 4],
    footprint: [f32; 4],
}

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
    fn key(&self) -> Vec<u64> {
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
    pub fn globe_above(grid: &Grid, distance: f64, fov: f64) -> Result<SurfaceView> {
        let frame = GlobeFrame::of(grid)?;
        let (lat, lon) = frame.centre();
        Ok(SurfaceView::Globe(Camera::geo(
            [0.0; 3], lat, lon, distance, fov,
        )?))
    }

    /// 0: perspective over the relief, 1: map, 2: globe (the data shader's `VIEW`).
    fn code(&self) -> u32 {
        match self {
            SurfaceView::Map => 1,
            SurfaceView::Globe(_) => 2,
            _ => 0,
        }
    }
}

/// How a geographic grid lies on the globe's unit sphere: its first node and spacing in degrees,
/// its node counts, and whether its longitudes close the circle (nx spacings make 360°), in
/// which case interpolation runs on from the last node to the first. Each node covers the cell
/// half a spacing either side, as in the map; elsewhere the sphere shows no data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GlobeFrame {
    pub lon0: f64,
    pub dlon: f64,
    pub lat0: f64,
    pub dlat: f64,
    pub nx: usize,
    pub ny: usize,
    pub wrap: bool,
}

impl GlobeFrame {
    /// The frame of a geographic grid with evenly spaced coordinates; anything else is an error
    /// saying what the globe needs.
    pub fn of(grid: &Grid) -> Result<GlobeFrame> {
        if !grid.is_geographic() {
            return Err(Error::invalid(
                "view",
                format!(
                    "the globe needs longitude along x and latitude along y (CF units degrees_east and degrees_north); grid {:?} has {:?} ({}) and {:?} ({})",
                    grid.name(),
                    grid.x().name,
                    grid.x().units,
                    grid.y().name,
                    grid.y().units
                ),
            ));
        }
        if MapAxis::of_coords(grid.x()).is_none() || MapAxis::of_coords(grid.y()).is_none() {
            return Err(Error::invalid(
                "view",
                format!(
                    "the globe needs evenly spaced longitudes and latitudes; grid {:?} has uneven ones",
                    grid.name()
                ),
            ));
        }
        let (nx, ny) = (grid.nx(), grid.ny());
        // A single node stands for a 1° cell.
        let step =
            |c: &crate::model::GridCoords| if c.values.len() > 1 { c.spacing() } else { 1.0 };
        let dlon = step(grid.x());
        Ok(GlobeFrame {
            lon0: grid.x().values[0],
            dlon,
            lat0: grid.y().values[0],
            dlat: step(grid.y()),
            nx,
            ny,
            wrap: (nx as f64 * dlon - 360.0).abs() <= 1e-3 * dlon,
        })
    }

    /// (latitude, longitude) of the middle of the grid's extent.
    pub fn centre(&self) -> (f64, f64) {
        (
            self.lat0 + 0.5 * (self.ny - 1) as f64 * self.dlat,
            self.lon0 + 0.5 * (self.nx - 1) as f64 * self.dlon,
        )
    }

    /// Fractional node coordinates (u along x, v along y) of a point at `lat`, `lon` degrees,
    /// or `None` outside the grid's cells. With `wrap`, u lies in [0, nx); otherwise it is
    /// clamped to the nodes.
    pub fn node_coords(&self, lat: f64, lon: f64) -> Option<(f64, f64)> {
        let (nx, ny) = (self.nx as f64, self.ny as f64);
        let v = (lat - self.lat0) / self.dlat;
        if !(-0.5..=ny - 0.5).contains(&v) {
            return None;
        }
        let v = v.clamp(0.0, ny - 1.0);
        let rel = (lon - self.lon0) / self.dlon;
        if self.wrap {
            let u = rel.rem_euclid(nx);
            return Some((if u >= nx { 0.0 } else { u }, v));
        }
        let u = (rel + 0.5).rem_euclid(360.0 / self.dlon) - 0.5;
        (u <= nx - 0.5).then(|| (u.clamp(0.0, nx - 1.0), v))
    }

    /// Where the ray o + t·d (d of unit length) first meets the unit sphere in front of the eye:
    /// (t, point), or `None`.
    pub fn hit(o: [f64; 3], d: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let (t, _) = sphere_hit(o, d, 1.0)?;
        (t >= 0.0).then(|| (t, [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]))
    }

    /// Headlight shading at a sphere point whose outward normal is `p` for a ray along `d`:
    /// ambient + (1 − ambient)·max(p·(−d), 0), so the limb darkens whichever side is seen.
    pub fn shade(p: [f64; 3], d: [f64; 3]) -> f64 {
        let facing = -(p[0] * d[0] + p[1] * d[1] + p[2] * d[2]);
        LIGHT_AMBIENT + (1.0 - LIGHT_AMBIENT) * facing.max(0.0)
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

    pub fn name(self) -> &'static str {
        match self {
            FringeMode::Cyclic => "cyclic",
            FringeMode::Modulated => "modulated",
            FringeMode::Direct => "direct",
        }
    }

    fn code(self) -> u32 {
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

    /// Paints every missing pixel (the fringe channel NaN there) in this colour.
    fn paint(&self, pixels: &mut [[f32; 4]], fringe: &[f32]) {
        if let MissingColour::Colour { linear, .. } = self {
            let c = [linear[0] as f32, linear[1] as f32, linear[2] as f32, 1.0];
            for (p, f) in pixels.iter_mut().zip(fringe) {
                if f.is_nan() {
                    *p = c;
                }
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
    /// Image size; `None` is the grid's node count (map view) or 512 (other views).
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

    fn nu_for(&self, i: usize) -> f64 {
        if self.nu.len() == 1 {
            self.nu[0]
        } else {
            self.nu[i]
        }
    }

    fn colormap_name(&self) -> &str {
        match &self.colormap {
            Some(c) => c,
            None if self.mode == FringeMode::Cyclic => "sinebow",
            None => "viridis",
        }
    }
}

/// ν split into 12 + 12 significant bits and an f32 remainder (see the module notes).
pub(crate) fn split_nu(nu: f64) -> [f32; 3] {
    let lead = |x: f64| f32::from_bits((x as f32).to_bits() & 0xFFFF_F000);
    let a = lead(nu);
    let b = lead(nu - a as f64);
    let c = (nu - a as f64 - b as f64) as f32;
    [a, b, c]
}

/// The f64 reference: (1 + cos 2πν·d)/2 with the phase reduced before the cosine.
pub fn fringe_f64(nu: f64, d: f64) -> f64 {
    let ph = (nu * d).rem_euclid(1.0);
    0.5 + 0.5 * (std::f64::consts::TAU * (ph - ph.round())).cos()
}

/// Width of the pixel footprint the antialiased fringe averages over: a Gaussian of this σ, in
/// pixels, along the data's gradient.
pub const FOOTPRINT_SIGMA: f64 = 0.5;

/// The f64 reference of the antialiased fringe: the point fringe's contrast scaled by
/// exp(−2π²ν²σ²|∇d|²), the average of (1 + cos 2πν·d)/2 over a Gaussian footprint of σ =
/// [`FOOTPRINT_SIGMA`] pixel for a field linear across it; `gradient` is |∇d| in data units per
/// pixel.
pub fn fringe_filtered_f64(nu: f64, d: f64, gradient: f64) -> f64 {
    let s = nu * FOOTPRINT_SIGMA * gradient;
    let contrast = (-2.0 * std::f64::consts::PI.powi(2) * s * s).exp();
    0.5 + (fringe_f64(nu, d) - 0.5) * contrast
}

/// |∇d| at pixel (x, y) of a `width`-wide row-major plane (data units per pixel), as the fringe
/// pass takes it: central differences of the neighbours along each axis, one-sided where one
/// neighbour is missing (NaN) or off the image, 0 along an axis where both are.
pub fn pixel_gradient(values: &[f64], width: usize, x: usize, y: usize) -> f64 {
    let height = values.len() / width;
    let at = |x: usize, y: usize| values[y * width + x];
    let centre = at(x, y);
    let axis = |before: Option<f64>, after: Option<f64>| {
        let (b, a) = (
            before.filter(|v| v.is_finite()),
            after.filter(|v| v.is_finite()),
        );
        match (b, a) {
            (Some(b), Some(a)) => 0.5 * (a - b),
            (None, Some(a)) => a - centre,
            (Some(b), None) => centre - b,
            (None, None) => 0.0,
        }
    };
    let gx = axis(
        (x > 0).then(|| at(x - 1, y)),
        (x + 1 < width).then(|| at(x + 1, y)),
    );
    let gy = axis(
        (y > 0).then(|| at(x, y - 1)),
        (y + 1 < height).then(|| at(x, y + 1)),
    );
    gx.hypot(gy)
}

/// Direction towards the light of the 3-D views (normalised where used) and the ambient share:
/// shade = ambient + (1 − ambient)·max(n·l, 0). Shared by the data pass and its CPU reference.
pub(crate) const LIGHT_DIRECTION: [f64; 3] = [-0.4, -0.5, 0.77];
pub(crate) const LIGHT_AMBIENT: f64 = 0.3;

/// The image size a render gets: the options' size, else the grid's node counts in map view and
/// 512² in other views.
pub(crate) fn default_size(grid: &Grid, opts: &SurfaceOptions) -> (u32, u32) {
    match (&opts.view, grid.map_aspect()) {
        (SurfaceView::Map, Some(aspect)) => {
            geographic_map_size(grid.nx(), grid.ny(), aspect, opts.width, opts.height)
        }
        (SurfaceView::Map, None) => (
            opts.width.unwrap_or(grid.nx() as u32),
            opts.height.unwrap_or(grid.ny() as u32),
        ),
        _ => (opts.width.unwrap_or(512), opts.height.unwrap_or(512)),
    }
}

/// The map size of a geographic grid whose map is `aspect` times as wide as high: both sides
/// as given; one given, the other from the aspect; neither, the smallest image of that aspect
/// with at least one pixel per node along both axes (at most 16384 a side).
fn geographic_map_size(
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
            let shrink = (16384.0 / w.max(h)).min(1.0);
            (side(w * shrink), side(h * shrink))
        }
    }
}

/// Where the surface sits in world space and how it is seen, as both the data pass and its f64
/// CPU reference ([`super::surface_reference`]) use it. World: x = i·sx, y = j·sy in coordinate
/// units from the first node, z = (height − hmin)·exaggeration − z_lo, so that the relief box
/// is [0, box_size] (a flat surface gets a thin box around z = −z_lo).
#[derive(Clone, Debug)]
pub(crate) struct SurfaceGeometry {
    /// Relief height per node before exaggeration (holes at the lowest height; 0 when flat).
    pub heights: Vec<f64>,
    /// Node spacing (sx, sy) in world units.
    pub spacing: [f64; 2],
    /// World z per height unit (1 for a flat surface).
    pub exaggeration: f64,
    /// Lowest relief height.
    pub height_min: f64,
    /// World z of the box's lower corner before the shift to 0 (negative for a flat surface).
    pub z_lo: f64,
    pub box_size: [f64; 3],
    /// The camera with its eye relative to the box's lower corner (in the Earth-centred frame
    /// on the globe); `None` in map view.
    pub camera: Option<Camera>,
    /// How the grid lies on the sphere in the globe view.
    pub globe: Option<GlobeFrame>,
}

impl SurfaceGeometry {
    pub fn new(grid: &Grid, opts: &SurfaceOptions) -> Result<Self> {
        let (nx, ny) = (grid.nx(), grid.ny());
        // Relief heights (world z before exaggeration), holes at the lowest height.
        let globe = match opts.view {
            SurfaceView::Globe(_) => Some(GlobeFrame::of(grid)?),
            _ => None,
        };
        let relief: Option<Vec<f64>> = match (&opts.view, opts.relief.as_deref()) {
            (SurfaceView::Map, _) | (_, None) | (_, Some("none")) => None,
            (SurfaceView::Globe(_), Some(_)) => {
                return Err(Error::invalid(
                    "relief",
                    "the globe view draws the field on the sphere without relief; leave relief out or use \"none\"",
                ))
            }
            (_, Some("elevation")) => Some(
                grid.elevation()
                    .ok_or_else(|| {
                        Error::invalid(
                            "relief",
                            format!(
                                "grid {:?} has no elevation; use a property name or none",
                                grid.name()
                            ),
                        )
                    })?
                    .to_vec(),
            ),
            (_, Some(name)) => Some(grid.property(name)?.to_vec()),
        };
        // Flat surfaces (no relief or no exaggeration) get heights 0 and an effective factor 1.
        let relief = relief.filter(|_| opts.exaggeration > 0.0);
        let exag = if relief.is_some() {
            opts.exaggeration
        } else {
            1.0
        };
        let (hmin, hmax) = relief
            .as_ref()
            .and_then(|r| {
                r.iter()
                    .filter(|v| v.is_finite())
                    .fold(None, |acc: Option<(f64, f64)>, &v| {
                        Some(acc.map_or((v, v), |(a, b)| (a.min(v), b.max(v))))
                    })
            })
            .unwrap_or((0.0, 0.0));
        let heights: Vec<f64> = match &relief {
            Some(r) => r
                .iter()
                .map(|&v| if v.is_finite() { v } else { hmin })
                .collect(),
            None => vec![0.0; nx * ny],
        };
        let sx = grid.x().spacing().abs().max(f64::MIN_POSITIVE);
        let sy = grid.y().spacing().abs().max(f64::MIN_POSITIVE);
        let mut size = [
            (nx.max(2) - 1) as f64 * sx,
            (ny.max(2) - 1) as f64 * sy,
            (hmax - hmin) * exag,
        ];
        // A flat surface still needs a box of some thickness for the ray test.
        let thin = 1e-4 * size[0].max(size[1]);
        let z_lo = if size[2] < thin { -thin } else { 0.0 };
        size[2] = size[2].max(thin) - z_lo;
        let camera = match opts.view {
            SurfaceView::Map => None,
            SurfaceView::Orbit {
                azimuth,
                elevation,
                fov,
            } => {
                let b = Aabb {
                    lo: [0.0, 0.0, z_lo],
                    hi: [size[0], size[1], size[2] + z_lo],
                };
                Some(Camera::orbit(&b, azimuth, elevation, fov)?)
            }
            SurfaceView::Camera(c) => Some(c),
            SurfaceView::Globe(c) => Some(c),
        };
        // Positions relative to the box's lower corner (z = z_lo); the globe's frame is its own.
        let camera = camera.map(|mut c| {
            if globe.is_none() {
                c.eye[2] -= z_lo;
            }
            c
        });
        Ok(SurfaceGeometry {
            heights,
            spacing: [sx, sy],
            exaggeration: exag,
            height_min: hmin,
            z_lo,
            box_size: size,
            camera,
            globe,
        })
    }

    /// The height whose world z is 0 (the box floor): hmin + z_lo / exaggeration.
    pub(crate) fn height_at_floor(&self) -> f64 {
        self.height_min + self.z_lo / self.exaggeration
    }
}

/// Name, units, d_ref and finite range of a rendered property.
type PropMeta = (String, String, f64, Option<(f64, f64)>);

/// Step-1 results on the GPU, with what step 2 needs to know about them.
struct DataTargets {
    hi: wgpu::Buffer,
    rest: wgpu::Buffer,
    mask: wgpu::Buffer,
    width: u32,
    height: u32,
    /// Per rendered property: name, units, d_ref, finite range.
    props: Vec<PropMeta>,
    view: String,
    /// The map's coordinate axes (map view of a grid with evenly spaced coordinates).
    axes: Option<crate::model::map_frame::MapAxes>,
    /// Fringe-pass outputs and their staging copies, reused by every step-2 run on these targets.
    outputs: Mutex<Option<FringeOutputs>>,
    /// Per property slot, the value channel as returned (missing pixels NaN): it depends on the
    /// data pass only, so step 2 reads it back once and a ν or mode change reuses it.
    values: Mutex<HashMap<usize, Vec<f32>>>,
}

/// Step-2 outputs, mapped directly on CPU adapters (no staging copy of the 16 MiB colour
/// buffer at 1024²; see [`crate::gpu::transfer`]).
struct FringeOutputs {
    color: ReadbackBuffer,
    value: ReadbackBuffer,
    filtered: ReadbackBuffer,
}

/// What a fringe pipeline is specialised on (pipeline constants of surface_fringe.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct FringeVariant {
    slot: usize,
    mode: u32,
    absolute: bool,
    log_color: bool,
    write_value: bool,
    naive_phase: bool,
    antialias: bool,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct DataKey {
    grid: u64,
    view: Vec<u64>,
    width: u32,
    height: u32,
    properties: Vec<String>,
    relief: Option<String>,
    exaggeration: u64,
}

/// Counters for tests and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SurfaceCounters {
    pub data_passes: u64,
    pub fringe_passes: u64,
}

/// Wall time of the two steps of one render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct SurfaceTiming {
    /// The data pass, or `None` when its targets came from the cache.
    pub data_ms: Option<f64>,
    pub fringe_ms: f64,
}

/// The two-step surface renderer with its pipelines and step-1 cache; one per GPU context.
pub struct SurfaceRenderer {
    ctx: Arc<GpuContext>,
    data_pipelines: Mutex<HashMap<u32, Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>>>,
    fringe_pipelines:
        Mutex<HashMap<FringeVariant, Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>>>,
    cache: Mutex<Vec<(DataKey, Arc<DataTargets>)>>,
    data_passes: AtomicU64,
    fringe_passes: AtomicU64,
}

impl SurfaceRenderer {
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        SurfaceRenderer {
            ctx,
            data_pipelines: Mutex::new(HashMap::new()),
            fringe_pipelines: Mutex::new(HashMap::new()),
            cache: Mutex::new(Vec::new()),
            data_passes: AtomicU64::new(0),
            fringe_passes: AtomicU64::new(0),
        }
    }

    /// How many data and fringe passes this renderer has run.
    pub fn counters(&self) -> SurfaceCounters {
        SurfaceCounters {
            data_passes: self.data_passes.load(Ordering::Relaxed),
            fringe_passes: self.fringe_passes.load(Ordering::Relaxed),
        }
    }

    fn build(
        &self,
        name: &str,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
        constants: &[(&str, f64)],
    ) -> Result<Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>> {
        // SAFETY: wgpu's injected bounds checks cost a large share of these small kernels on
        // lavapipe, and neither shader needs them: every invocation returns early outside the
        // image, pixel buffers hold exactly width × height entries, node indices are clamped to
        // the grid, and the lookup-table index is clamped to [0, LUT_SIZE − 2].
        let checks = unsafe { pipeline::RuntimeChecks::unchecked() };
        let spec = pipeline::ComputeSpec {
            label,
            what: &format!("{label} pipeline"),
            shader: pipeline::Shader::Wgsl {
                label: name,
                source: shader::load(name, &[])?,
                checks,
            },
            entry: "main",
            constants,
        };
        Ok(Arc::new(pipeline::compute_with_layout(
            &self.ctx, spec, entries,
        )?))
    }

    /// The data pass specialised for a view ([`SurfaceView::code`]).
    fn data_pipeline(
        &self,
        view: u32,
    ) -> Result<Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>> {
        let mut cache = self.data_pipelines.lock().expect("pipeline cache poisoned");
        if let Some(p) = cache.get(&view) {
            return Ok(p.clone());
        }
        let entries = crate::gpu::layout::uniform_then_storage(4, 3);
        let p = self.build(
            "surface_data.wgsl",
            "surface data pass",
            &entries,
            &[("VIEW", view as f64)],
        )?;
        cache.insert(view, p.clone());
        Ok(p)
    }

    fn fringe_pipeline(
        &self,
        variant: FringeVariant,
    ) -> Result<Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>> {
        let mut cache = self
            .fringe_pipelines
            .lock()
            .expect("pipeline cache poisoned");
        if let Some(p) = cache.get(&variant) {
            return Ok(p.clone());
        }
        let entries = crate::gpu::layout::uniform_then_storage(4, 3);
        let p = self.build(
            "surface_fringe.wgsl",
            "surface fringe pass",
            &entries,
            &[
                ("SLOT", variant.slot as f64),
                ("MODE", variant.mode as f64),
                ("ABSOLUTE", variant.absolute as u8 as f64),
                ("LOG_COLOR", variant.log_color as u8 as f64),
                ("WRITE_VALUE", variant.write_value as u8 as f64),
                ("NAIVE_PHASE", variant.naive_phase as u8 as f64),
                ("ANTIALIAS", variant.antialias as u8 as f64),
            ],
        )?;
        cache.insert(variant, p.clone());
        Ok(p)
    }

    fn input_buffer(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
    }

    fn output_buffer(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    fn bind(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        uniform: &wgpu::Buffer,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }];
        for (i, b) in buffers.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: i as u32 + 1,
                resource: b.as_entire_binding(),
            });
        }
        self.ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
    }

    fn resolve_size(&self, grid: &Grid, opts: &SurfaceOptions) -> Result<(u32, u32)> {
        let (w, h) = default_size(grid, opts);
        let limit = self.ctx.caps.max_storage_buffer_binding_size;
        let largest = (w as u64 * h as u64).max((grid.nx() * grid.ny()) as u64) * 16;
        if largest > limit {
            return Err(Error::invalid(
                "width",
                format!(
                    "{w}x{h} pixels on a {}x{} grid need {} MiB buffers; this adapter binds at most {} MiB",
                    grid.nx(),
                    grid.ny(),
                    largest >> 20,
                    limit >> 20
                ),
            ));
        }
        Ok((w, h))
    }

    /// Step 1, cached: the data targets for these options.
    fn data_pass(
        &self,
        grid: &Grid,
        opts: &SurfaceOptions,
        props: &[usize],
    ) -> Result<Arc<DataTargets>> {
        let (width, height) = self.resolve_size(grid, opts)?;
        let key = DataKey::new(grid, opts, props, width, height);
        if let Some(t) = self.cached_targets(&key) {
            return Ok(t);
        }
        let nodes = NodeValues::of(grid, props);
        let geo = SurfaceGeometry::new(grid, opts)?;
        let heights: Vec<f32> = geo.heights.iter().map(|&h| h as f32).collect();
        let t_hi = self.input_buffer("surface nodes hi", bytemuck::cast_slice(&nodes.hi));
        let t_rest = self.input_buffer("surface nodes rest", bytemuck::cast_slice(&nodes.rest));
        let t_valid = self.input_buffer("surface nodes valid", bytemuck::cast_slice(&nodes.valid));
        let t_height = self.input_buffer("surface nodes height", bytemuck::cast_slice(&heights));
        let map = opts.view == SurfaceView::Map;
        let params = data_params(&geo, grid, props.len(), width, height);
        let pipeline = self.data_pipeline(opts.view.code())?;
        let device = &self.ctx.device;
        use wgpu::util::DeviceExt;
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surface data params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let px = width as u64 * height as u64;
        let planes = px * 4 * props.len() as u64;
        let o_hi = self.output_buffer("surface data hi", planes);
        let o_rest = self.output_buffer("surface data rest", planes);
        let o_mask = self.output_buffer("surface data mask", px * 8);
        let bind = self.bind(
            "surface data",
            &pipeline.1,
            &ubuf,
            &[&t_hi, &t_rest, &t_valid, &t_height, &o_hi, &o_rest, &o_mask],
        );
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline.0);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        self.ctx.queue.submit([enc.finish()]);
        self.data_passes.fetch_add(1, Ordering::Relaxed);
        let targets = Arc::new(DataTargets {
            hi: o_hi,
            rest: o_rest,
            mask: o_mask,
            width,
            height,
            props: nodes.meta,
            view: opts.view.describe(),
            axes: map
                .then(|| crate::model::map_frame::MapAxes::of_grid(grid))
                .flatten(),
            outputs: Mutex::new(None),
            values: Mutex::new(HashMap::new()),
        });
        self.remember(key, targets.clone());
        Ok(targets)
    }

    /// The cached step-1 targets for `key`, if any.
    fn cached_targets(&self, key: &DataKey) -> Option<Arc<DataTargets>> {
        let cache = self.cache.lock().expect("surface cache poisoned");
        cache.iter().find(|(k, _)| k == key).map(|(_, t)| t.clone())
    }

    /// Caches `targets` under `key`, dropping the oldest entry when the cache is full.
    fn remember(&self, key: DataKey, targets: Arc<DataTargets>) {
        let mut cache = self.cache.lock().expect("surface cache poisoned");
        cache.retain(|(k, _)| *k != key);
        if cache.len() >= CACHE_ENTRIES {
            cache.remove(0);
        }
        cache.push((key, targets));
    }

    /// Resolves the property list to grid indices (unknown names list the known ones).
    fn property_indices(grid: &Grid, opts: &SurfaceOptions) -> Result<Vec<usize>> {
        if opts.properties.is_empty() {
            return Ok(vec![0]);
        }
        opts.properties
            .iter()
            .map(|p| grid.property_index(p))
            .collect()
    }

    /// Renders every requested property from one (cached) data pass; one image per property.
    pub fn render(&self, grid: &Grid, opts: &SurfaceOptions) -> Result<Vec<HdrImage>> {
        Ok(self.render_timed(grid, opts)?.0)
    }

    /// As [`Self::render`], also saying how long each step took (no data time on a cache hit).
    pub(crate) fn render_timed(
        &self,
        grid: &Grid,
        opts: &SurfaceOptions,
    ) -> Result<(Vec<HdrImage>, SurfaceTiming)> {
        opts.validate()?;
        let props = Self::property_indices(grid, opts)?;
        let colormap = Colormap::by_name(opts.colormap_name())?;
        let t0 = std::time::Instant::now();
        let passes_before = self.data_passes.load(Ordering::Relaxed);
        let data = self.data_pass(grid, opts, &props)?;
        let data_ms = (self.data_passes.load(Ordering::Relaxed) > passes_before)
            .then(|| t0.elapsed().as_secs_f64() * 1e3);
        let t1 = std::time::Instant::now();
        let images = (0..props.len())
            .map(|slot| self.fringe_pass(&data, slot, opts.nu_for(slot), opts, &colormap))
            .collect::<Result<Vec<_>>>()?;
        let timing = SurfaceTiming {
            data_ms,
            fringe_ms: t1.elapsed().as_secs_f64() * 1e3,
        };
        Ok((images, timing))
    }

    /// Step 2 for one property slot of a data pass.
    fn fringe_pass(
        &self,
        data: &DataTargets,
        slot: usize,
        nu: f64,
        opts: &SurfaceOptions,
        colormap: &Colormap,
    ) -> Result<HdrImage> {
        check_nu(nu)?;
        let (name, units, _, range) = data.props[slot].clone();
        let lut = colormap_table(colormap);
        let params = fringe_params(data, slot, nu, opts, &lut);
        let FringeReadback {
            mut pixels,
            values,
            fringe,
            filtered,
        } = self.run_fringe(data, slot, opts, &params, &lut)?;
        opts.missing.paint(&mut pixels, &fringe);
        let mut image = HdrImage::from_pixels(data.width, data.height, pixels);
        let channel = if name.is_empty() {
            "value".to_string()
        } else {
            name.clone()
        };
        let channel = if channel == "fringe" {
            "value".to_string()
        } else {
            channel
        };
        image.extra_channels.push((channel, values));
        image.extra_channels.push(("fringe".to_string(), fringe));
        image
            .extra_channels
            .push(("fringe_filtered".to_string(), filtered));
        let units_for_bar = units.clone();
        let u = if units.is_empty() {
            "data units".to_string()
        } else {
            units
        };
        image.set_meta("property", name);
        image.set_meta("nu", format!("{nu}"));
        image.set_meta("resolution", format!("{} {u} per fringe (1/nu)", 1.0 / nu));
        image.set_meta("mode", opts.mode.name());
        image.set_meta("colormap", colormap.name());
        image.set_meta("modulation", format!("{}", opts.modulation));
        image.set_meta(
            "data_range",
            match range {
                Some((a, b)) => format!("{a} {b}"),
                None => "all missing".to_string(),
            },
        );
        image.set_meta("view", data.view.clone());
        if let Some(axes) = &data.axes {
            axes.record(&mut image);
        }
        image.set_meta("phase", opts.phase.describe());
        image.set_meta(
            "antialias",
            if opts.antialias {
                "colours from the fringe averaged over a Gaussian footprint of sigma 0.5 pixel"
            } else {
                "off: colours from the point fringe"
            },
        );
        image.set_meta("missing", opts.missing.describe());
        surface_colour_bar(opts, &params, nu, colormap.name(), &units_for_bar).record(&mut image);
        image.set_meta("adapter", self.ctx.describe());
        Ok(image)
    }

    /// Runs the fringe pass for `slot` and reads back its colours (alpha 1), the value channel
    /// (missing pixels NaN; read once per slot, then reused) and the fringe taken from alpha.
    fn run_fringe(
        &self,
        data: &DataTargets,
        slot: usize,
        opts: &SurfaceOptions,
        params: &FringeParams,
        lut: &[[f32; 4]],
    ) -> Result<FringeReadback> {
        let cached_values = data
            .values
            .lock()
            .expect("surface values poisoned")
            .get(&slot)
            .cloned();
        let pipeline = self.fringe_pipeline(FringeVariant {
            slot,
            mode: opts.mode.code(),
            absolute: opts.absolute,
            log_color: opts.log_color,
            write_value: cached_values.is_none(),
            naive_phase: opts.phase == PhaseMethod::Naive,
            antialias: opts.antialias,
        })?;
        let n = data.width as u64 * data.height as u64;
        let mut outputs = data.outputs.lock().expect("surface outputs poisoned");
        let none = wgpu::BufferUsages::empty();
        let outs = outputs.get_or_insert_with(|| FringeOutputs {
            color: ReadbackBuffer::new(&self.ctx, "surface image", n * 16, none),
            value: ReadbackBuffer::new(&self.ctx, "surface value", n * 4, none),
            filtered: ReadbackBuffer::new(&self.ctx, "surface fringe filtered", n * 4, none),
        });
        let enc = self.encode_fringe(&pipeline, params, lut, data, outs, cached_values.is_none());
        let profile = FringeProfile::start();
        self.ctx.queue.submit([enc.finish()]);
        if profile.on {
            self.ctx.wait()?;
        }
        profile.mark("fringe compute");
        self.fringe_passes.fetch_add(1, Ordering::Relaxed);
        let mut pixels: Vec<[f32; 4]> = outs.color.read(&self.ctx, n * 16)?;
        let mut filtered: Vec<f32> = outs.filtered.read(&self.ctx, n * 4)?;
        for (f, p) in filtered.iter_mut().zip(&pixels) {
            if p[3] < 0.0 {
                *f = f32::NAN;
            }
        }
        profile.mark("+ rgba readback");
        let values: Vec<f32> = match cached_values {
            Some(v) => v,
            None => {
                let mut v: Vec<f32> = outs.value.read(&self.ctx, n * 4)?;
                for (value, p) in v.iter_mut().zip(&pixels) {
                    if p[3] < 0.0 {
                        *value = f32::NAN;
                    }
                }
                data.values
                    .lock()
                    .expect("surface values poisoned")
                    .insert(slot, v.clone());
                v
            }
        };
        drop(outputs);
        profile.mark("+ value readback");
        let fringe = take_fringe(&mut pixels);
        profile.mark("+ host");
        Ok(FringeReadback {
            pixels,
            values,
            fringe,
            filtered,
        })
    }

    /// Records the fringe pass and the copies of its outputs (the value channel only when it
    /// is written, `write_value`).
    fn encode_fringe(
        &self,
        pipeline: &(wgpu::ComputePipeline, wgpu::BindGroupLayout),
        params: &FringeParams,
        lut: &[[f32; 4]],
        data: &DataTargets,
        outs: &FringeOutputs,
        write_value: bool,
    ) -> wgpu::CommandEncoder {
        let device = &self.ctx.device;
        use wgpu::util::DeviceExt;
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surface fringe params"),
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let lut_buf = self.input_buffer("surface lut", bytemuck::cast_slice(lut));
        let (w, h) = (data.width, data.height);
        let n = w as u64 * h as u64;
        let (out, out_value) = (&outs.color.buffer, &outs.value.buffer);
        let out_filtered = &outs.filtered.buffer;
        let bind = self.bind(
            "surface fringe",
            &pipeline.1,
            &ubuf,
            &[
                &data.hi,
                &data.rest,
                &data.mask,
                &lut_buf,
                out,
                out_value,
                out_filtered,
            ],
        );
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline.0);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        outs.color.record_copy(&mut enc, n * 16);
        outs.filtered.record_copy(&mut enc, n * 4);
        if write_value {
            outs.value.record_copy(&mut enc, n * 4);
        }
        enc
    }
}

impl DataKey {
    /// What step 1's result depends on (the relief and its exaggeration only off the map view).
    fn new(grid: &Grid, opts: &SurfaceOptions, props: &[usize], width: u32, height: u32) -> Self {
        DataKey {
            grid: grid.id(),
            view: opts.view.key(),
            width,
            height,
            properties: props
                .iter()
                .map(|&i| grid.property_at(i).0.to_string())
                .collect(),
            relief: if opts.view == SurfaceView::Map {
                None
            } else {
                opts.relief.clone()
            },
            exaggeration: if opts.view == SurfaceView::Map {
                0
            } else {
                opts.exaggeration.to_bits()
            },
        }
    }
}

/// The node inputs of step 1: per node and property slot, the value less the property's
/// reference d_ref split into an f32 head and the f32 rest (together ~f64 precision), and 1
/// where the value is finite; with what step 2 needs to know of each property.
struct NodeValues {
    hi: Vec<[f32; 4]>,
    rest: Vec<[f32; 4]>,
    valid: Vec<[f32; 4]>,
    meta: Vec<PropMeta>,
}

impl NodeValues {
    fn of(grid: &Grid, props: &[usize]) -> NodeValues {
        let n = grid.nx() * grid.ny();
        let mut hi = vec![[0f32; 4]; n];
        let mut rest = vec![[0f32; 4]; n];
        let mut valid = vec![[0f32; 4]; n];
        let mut meta = Vec::new();
        for (slot, &p) in props.iter().enumerate() {
            let (name, values) = grid.property_at(p);
            let range = grid.range(p);
            let d_ref = range.map(|(a, b)| 0.5 * (a + b)).unwrap_or(0.0);
            for k in 0..n {
                let d = values[k];
                if d.is_finite() {
                    let off = d - d_ref;
                    let h = off as f32;
                    hi[k][slot] = h;
                    rest[k][slot] = (off - h as f64) as f32;
                    valid[k][slot] = 1.0;
                }
            }
            meta.push((name.to_string(), grid.units(p).to_string(), d_ref, range));
        }
        NodeValues {
            hi,
            rest,
            valid,
            meta,
        }
    }
}

/// The data pass's parameters: the camera (left zero for the map view), cell size,
/// exaggeration, light and sizes.
fn data_params(
    geo: &SurfaceGeometry,
    grid: &Grid,
    properties: usize,
    width: u32,
    height: u32,
) -> DataParams {
    let (nx, ny) = (grid.nx(), grid.ny());
    let v4 = |v: [f64; 3], w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
    let mut params = DataParams {
        eye: [0.0; 4],
        forward: [0.0; 4],
        right: [0.0; 4],
        up: [0.0; 4],
        proj: [0.0; 4],
        cell: [
            geo.spacing[0] as f32,
            geo.spacing[1] as f32,
            geo.exaggeration as f32,
            geo.height_at_floor() as f32,
        ],
        light: v4(LIGHT_DIRECTION, LIGHT_AMBIENT),
        box_size: v4(geo.box_size, 0.0),
        globe: [0.0; 4],
        dims: [nx as u32, ny as u32, width, height],
        counts: [properties as u32, 0, 0, 0],
    };
    if let Some(g) = &geo.globe {
        params.globe = [g.lon0 as f32, g.dlon as f32, g.lat0 as f32, g.dlat as f32];
        params.counts[1] = g.wrap as u32;
    }
    if let Some(cam) = &geo.camera {
        params.eye = v4(cam.eye, 0.0);
        params.forward = v4(cam.forward, 0.0);
        params.right = v4(cam.right, 0.0);
        params.up = v4(cam.up, 0.0);
        params.proj = cam.shader_projection(width, height).map(|v| v as f32);
    }
    params
}

/// The fringe pass's parameters for `slot` at `nu`: ν split for exact phases, the reference
/// phase, the colour domain, shading and mode, and the footprint (with the mean of the colour
/// table `lut`, what cyclic colours fade to).
fn fringe_params(
    data: &DataTargets,
    slot: usize,
    nu: f64,
    opts: &SurfaceOptions,
    lut: &[[f32; 4]],
) -> FringeParams {
    // The table's mean by the trapezoid rule (its entries are samples at both ends of [0, 1]).
    let mut mean = [0f32; 3];
    let last = lut.len() - 1;
    for (i, c) in lut.iter().enumerate() {
        let w = if i == 0 || i == last { 0.5 } else { 1.0 } / last as f32;
        for k in 0..3 {
            mean[k] += c[k] * w;
        }
    }
    let (_, _, d_ref, range) = &data.props[slot];
    let d_ref = *d_ref;
    let (c_lo, c_inv, floor) = colour_domain(opts, range.unwrap_or((d_ref, d_ref)), d_ref);
    let [na, nb, nc] = split_nu(nu);
    FringeParams {
        nu: [na, nb, nc, nu as f32],
        refs: [
            (nu * d_ref).rem_euclid(1.0) as f32,
            d_ref as f32,
            c_lo as f32,
            c_inv as f32,
        ],
        shade: [opts.modulation as f32, floor as f32, 0.0, 0.0],
        mode: [
            slot as u32,
            opts.mode.code(),
            opts.absolute as u32,
            opts.log_color as u32,
        ],
        dims: [data.width, data.height, LUT_SIZE as u32, 0],
        footprint: [mean[0], mean[1], mean[2], (nu * FOOTPRINT_SIGMA) as f32],
    }
}

/// Where colour starts, 1 / its span, and the floor of log colour, for data in [lo, hi]:
/// log10 of magnitudes (above a floor) for log colour outside cyclic mode, magnitudes for
/// absolute, else the offset from d_ref over the data range.
fn colour_domain(opts: &SurfaceOptions, (lo, hi): (f64, f64), d_ref: f64) -> (f64, f64, f64) {
    if opts.log_color && opts.mode != FringeMode::Cyclic {
        let amax = lo.abs().max(hi.abs());
        let amin_pos = if lo > 0.0 {
            lo
        } else if hi < 0.0 {
            -hi
        } else {
            0.0
        };
        let floor = if amin_pos > 0.0 {
            amin_pos
        } else {
            amax * 1e-6
        };
        let floor = if floor > 0.0 { floor } else { 1.0 };
        let (a, b) = (floor.log10(), amax.max(floor).log10());
        (a, if b > a { 1.0 / (b - a) } else { 0.0 }, floor)
    } else if opts.absolute {
        let (a, b) = if lo >= 0.0 {
            (lo, hi)
        } else if hi <= 0.0 {
            (-hi, -lo)
        } else {
            (0.0, lo.abs().max(hi.abs()))
        };
        (a, if b > a { 1.0 / (b - a) } else { 0.0 }, 0.0)
    } else {
        (lo - d_ref, if hi > lo { 1.0 / (hi - lo) } else { 0.0 }, 0.0)
    }
}

/// The colour bar of a fringe pass: one fringe period (0 to 1/ν) in cyclic mode, otherwise the
/// colour domain the pass used (log10 of magnitudes for log colour, magnitudes for absolute).
fn surface_colour_bar(
    opts: &SurfaceOptions,
    params: &FringeParams,
    nu: f64,
    colormap: &str,
    units: &str,
) -> crate::model::text::ColourBar {
    use crate::model::text::{BarScale, ColourBar};
    let [_, d_ref, c_lo, c_inv] = params.refs.map(|v| v as f64);
    let span = if c_inv > 0.0 { 1.0 / c_inv } else { 0.0 };
    let (scale, lo, hi) = match opts.mode {
        FringeMode::Cyclic => (BarScale::Linear, 0.0, 1.0 / nu),
        _ if opts.log_color => (BarScale::Log10, 10f64.powf(c_lo), 10f64.powf(c_lo + span)),
        _ if opts.absolute => (BarScale::Linear, c_lo, c_lo + span),
        _ => (BarScale::Linear, c_lo + d_ref, c_lo + d_ref + span),
    };
    ColourBar {
        colormap: colormap.to_string(),
        scale,
        lo,
        hi,
        units: units.to_string(),
    }
}

/// The colour map sampled at LUT_SIZE points, as the fringe shader's table.
fn colormap_table(colormap: &Colormap) -> Vec<[f32; 4]> {
    (0..LUT_SIZE)
        .map(|i| {
            let c = colormap.linear_rgb(i as f64 / (LUT_SIZE - 1) as f64);
            [c[0] as f32, c[1] as f32, c[2] as f32, 1.0]
        })
        .collect()
}

/// Takes the fringe out of alpha, where the pass leaves it: a negative alpha marks a missing
/// pixel, which becomes (0, 0, 0, 0) with fringe NaN; every other alpha becomes 1.
fn take_fringe(pixels: &mut [[f32; 4]]) -> Vec<f32> {
    use rayon::prelude::*;
    pixels
        .par_iter_mut()
        .map(|p| {
            if p[3] < 0.0 {
                *p = [0.0; 4];
                f32::NAN
            } else {
                let f = p[3];
                p[3] = 1.0;
                f
            }
        })
        .collect()
}

/// What the fringe pass of one slot hands back: colours with alpha 1 (missing pixels all 0),
/// the value channel, the fringe and the footprint-filtered fringe (NaN where missing).
struct FringeReadback {
    pixels: Vec<[f32; 4]>,
    values: Vec<f32>,
    fringe: Vec<f32>,
    filtered: Vec<f32>,
}

/// Step-2 stage times on stderr when `HDRVIS_SURFACE_PROFILE` is set, counted from the submit.
struct FringeProfile {
    on: bool,
    start: std::time::Instant,
}

impl FringeProfile {
    fn start() -> FringeProfile {
        FringeProfile {
            on: std::env::var_os("HDRVIS_SURFACE_PROFILE").is_some(),
            start: std::time::Instant::now(),
        }
    }

    fn mark(&self, stage: &str) {
        if self.on {
            eprintln!("{stage} {:.2} ms", self.start.elapsed().as_secs_f64() * 1e3);
        }
    }
}

/// A colour bar for a surface render (a separate image): horizontal, `width × height`, left to
/// right over the colour domain — for cyclic mode one fringe period (0 to 1/ν), otherwise the
/// property's data range — with the fringes of ν drawn in unless the mode is direct. The
/// resolution 1/ν and the domain are recorded in the metadata.
/// The tallest colour bar, in pixels: a bar is a strip, and the limit keeps a mistyped size from
/// allocating gigabytes.
pub(crate) const MAX_COLORBAR_HEIGHT: u32 = 1024;

pub(crate) fn colorbar(
    grid: &Grid,
    opts: &SurfaceOptions,
    width: u32,
    height: u32,
) -> Result<HdrImage> {
    opts.validate()?;
    let side = crate::render::MAX_IMAGE_SIDE;
    for (field, v, max) in [
        ("width", width, side),
        ("height", height, MAX_COLORBAR_HEIGHT),
    ] {
        if v == 0 || v > max {
            return Err(Error::invalid(
                field,
                format!("expected 1 to {max} pixels, got {v}"),
            ));
        }
    }
    let p = SurfaceRenderer::property_indices(grid, opts)?[0];
    let nu = opts.nu_for(0);
    let cmap = Colormap::by_name(opts.colormap_name())?;
    let (lo, hi) = match opts.mode {
        FringeMode::Cyclic => (0.0, 1.0 / nu),
        _ => grid.range(p).unwrap_or((0.0, 1.0)),
    };
    let (lo, hi) = if opts.absolute && opts.mode != FringeMode::Cyclic {
        (
            if lo < 0.0 && hi > 0.0 {
                0.0
            } else {
                lo.abs().min(hi.abs())
            },
            lo.abs().max(hi.abs()),
        )
    } else {
        (lo, hi)
    };
    let mut img = HdrImage::new(width, height);
    for x in 0..width {
        let d = lo + (hi - lo) * (x as f64 + 0.5) / width as f64;
        let t = match opts.mode {
            FringeMode::Cyclic => (nu * d).rem_euclid(1.0),
            _ if opts.log_color => {
                let floor = if lo > 0.0 { lo } else { hi.abs() * 1e-6 };
                let (a, b) = (
                    floor.max(f64::MIN_POSITIVE).log10(),
                    hi.abs().max(floor).log10(),
                );
                if b > a {
                    (d.abs().max(floor).log10() - a) / (b - a)
                } else {
                    0.0
                }
            }
            _ => {
                if hi > lo {
                    (d - lo) / (hi - lo)
                } else {
                    0.0
                }
            }
        };
        let mut c = cmap.linear_rgb(t);
        if opts.mode != FringeMode::Direct {
            let k = (1.0 - opts.modulation) + opts.modulation * fringe_f64(nu, d);
            c = c.map(|v| v * k);
        }
        for y in 0..height {
            img.pixels[(y * width + x) as usize] = [c[0] as f32, c[1] as f32, c[2] as f32, 1.0];
        }
    }
    let (name, _) = grid.property_at(p);
    let units = grid.units(p);
    let u = if units.is_empty() {
        "data units"
    } else {
        units
    };
    img.set_meta("property", name);
    img.set_meta("resolution", format!("{} {u} per fringe (1/nu)", 1.0 / nu));
    img.set_meta("colorbar_domain", format!("{lo} {hi} {u}"));
    img.set_meta("mode", opts.mode.name());
    img.set_meta("colormap", cmap.name());
    Ok(img)
}

/// The legend's statement of the resolution: "1 fringe = 0.125 m" (1/ν in the property's
/// units, "data units" when it has none).
pub fn resolution_label(nu: f64, units: &str) -> String {
    let u = if units.is_empty() {
        "data units"
    } else {
        units
    };
    format!(
        "1 fringe = {} {u}",
        crate::model::text::format_number(1.0 / nu)
    )
}

/// Height in pixels of the colour bar at the top of a [`legend`].
pub const LEGEND_BAR_HEIGHT: u32 = 16;

/// A legend for a surface render, `width` pixels wide: the colour bar of [`colorbar`] on top,
/// then in white text on black the resolution ("1 fringe = 0.125 m"), ν and the mode, and the
/// bar's domain (its ends, left and right). Text is drawn twice as large when it fits.
pub fn legend(grid: &Grid, opts: &SurfaceOptions, width: u32) -> Result<HdrImage> {
    use crate::model::text::{draw_text, format_number, text_width, GLYPH};
    let bar = colorbar(grid, opts, width, LEGEND_BAR_HEIGHT)?;
    let p = SurfaceRenderer::property_indices(grid, opts)?[0];
    let nu = opts.nu_for(0);
    let units = grid.units(p);
    let label = resolution_label(nu, units);
    let detail = format!("ν = {} ({})", format_number(nu), opts.mode.name());
    let domain: Vec<f64> = bar
        .meta("colorbar_domain")
        .unwrap_or("")
        .split_whitespace()
        .take(2)
        .filter_map(|v| v.parse().ok())
        .collect();
    let (left, right) = match domain[..] {
        [lo, hi] => (format_number(lo), format_number(hi)),
        _ => (String::new(), String::new()),
    };
    let widest = [label.as_str(), detail.as_str()]
        .iter()
        .map(|t| text_width(t, 1))
        .max()
        .unwrap_or(0)
        .max(text_width(&left, 1) + text_width(&right, 1) + GLYPH);
    let scale = if 2 * widest + 4 <= width { 2 } else { 1 };
    let line = GLYPH * scale + 4;
    let height = LEGEND_BAR_HEIGHT + 4 + 3 * line;
    let mut img = HdrImage::new(width, height);
    for px in img.pixels.iter_mut() {
        *px = [0.0, 0.0, 0.0, 1.0];
    }
    img.pixels[..bar.pixels.len()].copy_from_slice(&bar.pixels);
    let white = [1.0, 1.0, 1.0, 1.0];
    let top = (LEGEND_BAR_HEIGHT + 4) as i64;
    let right_x = width as i64 - text_width(&right, scale) as i64 - 2;
    draw_text(&mut img, 2, top, &left, scale, white);
    draw_text(&mut img, right_x.max(2), top, &right, scale, white);
    draw_text(&mut img, 2, top + line as i64, &label, scale, white);
    draw_text(&mut img, 2, top + 2 * line as i64, &detail, scale, white);
    img.metadata = bar.metadata.clone();
    img.set_meta("legend", label.as_str());
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nu_split_is_exact_and_short() {
        for nu in [8.0, 1.0 / 3.0, 12345.678901, 1e-7] {
            let [a, b, c] = split_nu(nu);
            assert_eq!(a.to_bits() & 0xFFF, 0);
            assert_eq!(b.to_bits() & 0xFFF, 0);
            let sum = a as f64 + b as f64 + c as f64;
            assert!((sum - nu).abs() <= nu * 1e-14, "{nu}: {sum}");
        }
    }

    #[test]
    fn bad_nu_is_an_error() {
        for nu in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(check_nu(nu).is_err());
        }
    }
}
