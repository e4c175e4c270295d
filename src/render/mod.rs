//! Renderers: the GPU volume ray caster and its f64 CPU reference, sharing one set of options so
//! they trace the same rays through the same optical model.

pub mod bricked;
pub mod cache;
pub mod cpu_reference;
pub mod distributed;
pub(crate) mod mapped;
pub(crate) mod mapped_skipping;
pub mod passes;
pub(crate) mod route;
pub mod session;
pub(crate) mod skipping;
pub mod surface;
pub mod surface_reference;
pub mod volume;
pub mod volume_f64;

use crate::error::{Error, Result};
use crate::model::{Camera, Cut, CutFaces, Missing, TransferFunction};
pub use route::{Bricking, RenderPath, VolumeRender, VolumeSource};

/// How the volume is interpolated between voxel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterMode {
    /// Hardware trilinear where the adapter filters float32 textures, exact otherwise.
    Auto,
    /// The texture unit's trilinear filter (on many GPUs its weights have only 8 fractional bits).
    Hardware,
    /// Eight texel loads and f32 weights in the shader: the same numbers as the CPU reference.
    Exact,
}

impl FilterMode {
    pub(crate) const NAMES: &'static [&'static str] = &["auto", "hardware", "exact"];

    pub fn parse(s: &str) -> Result<FilterMode> {
        match s {
            "auto" => Ok(FilterMode::Auto),
            "hardware" => Ok(FilterMode::Hardware),
            "exact" => Ok(FilterMode::Exact),
            _ => Err(Error::invalid(
                "filter",
                format!("expected auto, hardware or exact, got {s:?}"),
            )),
        }
    }
}

/// Everything a volume render depends on besides the volume.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeRenderOptions {
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub tf: TransferFunction,
    /// Distance between samples in voxels (the smallest spacing is one voxel).
    pub step: f64,
    /// Offset each ray's first sample by a per-pixel random fraction of a step.
    pub jitter: bool,
    pub seed: u32,
    /// Rays stop once their transmittance falls below this (0 never stops early).
    pub early_exit: f64,
    /// Linear RGB seen through the volume.
    pub background: [f64; 3],
    pub filter: FilterMode,
    /// Arithmetic of the compositing loop.
    pub precision: Precision,
    /// Gradient-based Blinn–Phong shading of the emission; `None` compiles no shading code.
    pub shading: Option<Shading>,
    /// Point-sampled or pre-integrated transfer function.
    pub tf_sampling: TfSampling,
    /// Jump over space the transfer function leaves empty (missing data, transparent values);
    /// the image is the same either way.
    pub empty_space_skipping: bool,
    /// Whether and how the volume may be cut into bricks (bricked and out-of-core paths).
    pub bricking: Bricking,
    /// How a sample with missing voxels among its eight neighbours is taken; renormalised
    /// sampling runs on the f64 CPU reference only.
    pub missing: Missing,
    /// The region removed from a spherical volume (mapped ray caster and f64 CPU reference).
    pub cut: Option<Cut>,
    /// The cut's faces drawn as opaque surfaces of the field (with `cut` only).
    pub cut_faces: Option<CutFaces>,
    /// Natural Earth coastlines on a spherical volume's outer surface.
    pub coastlines: Option<surface::CoastlineStyle>,
    /// Meridians and parallels every this many degrees on a spherical volume's outer surface.
    pub graticule: Option<f64>,
}

/// How each ray segment reads the transfer function.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TfSampling {
    /// The transfer function of the value at the segment's middle.
    #[default]
    Point,
    /// The mean of the transfer function over the segment, the value running linearly between
    /// samples at its ends (pre-integration): transfer-function features narrower than a step
    /// survive.
    PreIntegrated,
}

impl TfSampling {
    pub(crate) const NAMES: &'static [&'static str] = &["point", "preintegrated"];

    pub fn parse(s: &str) -> Result<TfSampling> {
        match s {
            "point" => Ok(TfSampling::Point),
            "preintegrated" => Ok(TfSampling::PreIntegrated),
            _ => Err(Error::invalid(
                "tf_sampling",
                format!("expected point or preintegrated, got {s:?}"),
            )),
        }
    }

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

/// Blinn–Phong shading of each sample's emission under a headlight: the emission is multiplied
/// by ambient + diffuse·|n·l| + specular·|n·l|^shininess, where n is the unit gradient of the
/// data (central differences one voxel apart) and l the ray direction (light at the eye, so the
/// half vector is l). Two-sided, because an iso-surface of a scalar field has no outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading {
    pub ambient: f64,
    pub diffuse: f64,
    pub specular: f64,
    pub shininess: f64,
}

impl Default for Shading {
    fn default() -> Self {
        Shading {
            ambient: 0.3,
            diffuse: 0.7,
            specular: 0.3,
            shininess: 32.0,
        }
    }
}

impl Shading {
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("shading.ambient", self.ambient),
            ("shading.diffuse", self.diffuse),
            ("shading.specular", self.specular),
        ] {
            if !(v.is_finite() && (0.0..=100.0).contains(&v)) {
                return Err(Error::invalid(
                    name,
                    format!("expected a finite coefficient in [0, 100], got {v}"),
                ));
            }
        }
        if !(self.shininess.is_finite() && (1.0..=10_000.0).contains(&self.shininess)) {
            return Err(Error::invalid(
                "shading.shininess",
                format!("expected an exponent in [1, 10000], got {}", self.shininess),
            ));
        }
        Ok(())
    }

    /// The factor for a gradient `g` (any length) and unit ray direction `d`; 1 where the
    /// gradient vanishes or is not finite.
    pub fn factor(&self, g: [f64; 3], d: [f64; 3]) -> f64 {
        let len2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if !(len2 > 0.0 && len2.is_finite()) {
            return 1.0;
        }
        let c = (g[0] * d[0] + g[1] * d[1] + g[2] * d[2]).abs() / len2.sqrt();
        self.ambient + self.diffuse * c + self.specular * c.powf(self.shininess)
    }
}

/// How the compositing loop accumulates colour and optical depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Precision {
    /// 8-bit framebuffer emulation: colour and alpha clamped to [0, 1] and quantised to 8 bits
    /// after every step (the paper's baseline).
    U8,
    /// Colour, transmittance and optical depth rounded to binary16 after every step (emulated
    /// with pack2x16float, so the same on every adapter).
    F16,
    /// f32 throughout (the default).
    F32,
    /// f32 with Kahan-compensated sums of colour and optical depth, transmittance recomputed
    /// from the compensated optical depth.
    F32c,
    /// f64, on the CPU reference path.
    F64,
}

impl Precision {
    pub(crate) const NAMES: &'static [&'static str] = &["u8", "f16", "f32", "f32c", "f64"];

    pub fn parse(s: &str) -> Result<Precision> {
        match s {
            "u8" => Ok(Precision::U8),
            "f16" => Ok(Precision::F16),
            "f32" => Ok(Precision::F32),
            "f32c" => Ok(Precision::F32c),
            "f64" => Ok(Precision::F64),
            _ => Err(Error::invalid(
                "precision",
                format!(
                    "unknown precision {s:?}; known: {}",
                    Precision::NAMES.join(", ")
                ),
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Precision::U8 => "u8",
            Precision::F16 => "f16",
            Precision::F32 => "f32",
            Precision::F32c => "f32c",
            Precision::F64 => "f64",
        }
    }

    /// The shader's PRECISION override constant (f64 does not run in the shader).
    pub(crate) fn shader_code(self) -> u32 {
        match self {
            Precision::F32 | Precision::F64 => 0,
            Precision::U8 => 1,
            Precision::F16 => 2,
            Precision::F32c => 3,
        }
    }
}

/// Default early-ray-termination threshold on transmittance: what is left behind it can change
/// a pixel by at most this fraction of the saturated emission.
pub(crate) const DEFAULT_EARLY_EXIT: f64 = 1e-5;

impl VolumeRenderOptions {
    pub fn new(camera: Camera, tf: TransferFunction) -> Self {
        VolumeRenderOptions {
            width: 512,
            height: 512,
            camera,
            tf,
            step: 1.0,
            jitter: false,
            seed: 0,
            early_exit: DEFAULT_EARLY_EXIT,
            background: [0.0; 3],
            filter: FilterMode::Auto,
            precision: Precision::F32,
            shading: None,
            tf_sampling: TfSampling::Point,
            empty_space_skipping: true,
            bricking: Bricking::default(),
            missing: Missing::Strict,
            cut: None,
            cut_faces: None,
            coastlines: None,
            graticule: None,
        }
    }

    pub fn validate(&self) -> Result<()> {
        for (f, v) in [("width", self.width), ("height", self.height)] {
            if v == 0 || v > MAX_IMAGE_SIDE {
                return Err(Error::invalid(
                    f,
                    format!("expected 1 to {MAX_IMAGE_SIDE} pixels, got {v}"),
                ));
            }
        }
        if !(self.step.is_finite() && self.step >= 1e-4 && self.step <= 1e4) {
            return Err(Error::invalid(
                "step",
                format!(
                    "expected a step in voxels within [1e-4, 1e4], got {}",
                    self.step
                ),
            ));
        }
        if !(self.early_exit.is_finite() && (0.0..1.0).contains(&self.early_exit)) {
            return Err(Error::invalid(
                "early_exit",
                format!(
                    "expected a transmittance in [0, 1), got {}",
                    self.early_exit
                ),
            ));
        }
        if let Some(s) = &self.shading {
            s.validate()?;
        }
        if let Some(c) = &self.coastlines {
            c.validate("coastlines")?;
        }
        if let Some(step) = self.graticule {
            surface::check_graticule(step)?;
        }
        if self.cut_faces.is_some() && self.cut.is_none() {
            return Err(Error::invalid(
                "cut_faces",
                "draws the faces a cut-away opens; give cut too",
            ));
        }
        if let Some(nu) = self.cut_faces.as_ref().and_then(|f| f.nu) {
            if !(nu.is_finite() && nu > 0.0) {
                return Err(Error::invalid(
                    "cut_faces nu",
                    format!("expected fringes per unit of the value > 0, got {nu}"),
                ));
            }
        }
        if self.background.iter().any(|c| !c.is_finite()) {
            return Err(Error::invalid(
                "background",
                "expected three finite numbers",
            ));
        }
        Ok(())
    }

    /// Optical depth at which rays stop.
    pub(crate) fn stop_optical_depth(&self) -> f64 {
        if self.early_exit > 0.0 {
            -self.early_exit.ln()
        } else {
            f64::INFINITY
        }
    }
}

/// The largest side of a rendered image, in pixels.
pub(crate) const MAX_IMAGE_SIDE: u32 = 16384;

/// Refuses, before any GPU work, an RGBA f32 image the adapter cannot hold: a side beyond its
/// largest 2-D texture, or more bytes (rows padded to wgpu's copy alignment) than its largest
/// buffer, which the read back needs. The message names the limit and the largest square that fits.
pub(crate) fn check_output_fits(
    caps: &crate::gpu::Capabilities,
    width: u32,
    height: u32,
) -> Result<()> {
    let side = caps.max_texture_2d;
    if width > side || height > side {
        return Err(Error::invalid(
            "width, height",
            format!("{width} x {height} pixels: this adapter's 2-D images are at most {side} px per side (max_texture_dimension_2d)"),
        ));
    }
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64;
    let row = (width as u64 * 16).div_ceil(align) * align;
    let bytes = row * height as u64;
    if bytes > caps.max_buffer_size {
        let square = ((caps.max_buffer_size / 16) as f64).sqrt() as u64;
        return Err(Error::invalid(
            "width, height",
            format!(
                "{width} x {height} pixels of RGBA f32 need {} MiB, above this adapter's largest buffer of {} MiB (max_buffer_size); at most about {square} x {square} pixels",
                bytes >> 20,
                caps.max_buffer_size >> 20
            ),
        ));
    }
    Ok(())
}

/// Per-pixel jitter fraction in [0, 1), identical to the shader's `hash_u32`.
pub(crate) fn jitter_fraction(px: u32, py: u32, width: u32, height: u32, seed: u32) -> f64 {
    let x = px.wrapping_add(width.wrapping_mul(py.wrapping_add(height.wrapping_mul(seed))));
    let state = x.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    let r = (word >> 22) ^ word;
    (r >> 8) as f64 / 16777216.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transfer_function_sampling_names_round_trip_and_unknown_ones_are_refused() {
        for name in TfSampling::NAMES {
            assert_eq!(TfSampling::parse(name).unwrap().name(), *name);
        }
        let err = TfSampling::parse("linear").unwrap_err().to_string();
        assert_eq!(
            err,
            "tf_sampling: expected point or preintegrated, got \"linear\""
        );
    }
}
