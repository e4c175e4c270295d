//! Tone-mapping parameters: the operator choice with its published defaults, the settings shared
//! by every operator (exposure, offset, gamma, saturation), their validation, and the `#[repr(C)]`
//! structs the WGSL shaders in `shaders/tonemap/` read, which must stay in sync with them.

use crate::error::{Error, Result};

/// A tone-mapping operator and its parameters. Defaults follow the papers cited on each variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Operator {
    /// Scene luminance clamped to [0, 1].
    Linear,
    /// Drago, Myszkowski, Annen, Chiba 2003, "Adaptive logarithmic mapping for displaying high
    /// contrast scenes". World luminance is divided by its log-average first, as in the paper.
    Drago {
        /// Bias b in (0, 1]; the paper recommends 0.85.
        bias: f64,
        /// Display maximum luminance Ld_max in cd/m2 (paper: 100); 100 maps the scene maximum to 1.
        ld_max: f64,
    },
    /// Reinhard, Stark, Shirley, Ferwerda 2002, "Photographic tone reproduction", global operator
    /// (their eq. 4): L_d = L (1 + L / L_white^2) / (1 + L), with L = key / Lbar * L_w.
    Reinhard {
        /// Key a (paper: 0.18, "middle grey").
        key: f64,
        /// L_white in units of the scaled luminance L; `None` uses the image's largest L, so that
        /// the brightest pixel maps exactly to 1.
        white: Option<f64>,
    },
    /// Ward Larson, Rushmeier, Piatko 1997, "A visibility matching tone reproduction operator",
    /// histogram adjustment with the linear ceiling (their section 4.3 / eq. 7).
    WardHistogram {
        /// Display minimum luminance in cd/m2 (paper: 1).
        ld_min: f64,
        /// Display maximum luminance in cd/m2 (paper: 100); display value = L_d / ld_max.
        ld_max: f64,
        /// Number of histogram bins over the image's log-luminance range (paper: about 100).
        bins: u32,
    },
    /// Narkowicz 2016 fit of the ACES filmic curve, (x (a x + b)) / (x (c x + d) + e).
    Aces,
    /// Reinhard et al. 2002 local operator (automatic dodging-and-burning, their eqs. 5-9).
    ReinhardLocal {
        /// Key a (paper: 0.18).
        key: f64,
        /// alpha_1 of the centre Gaussian (paper: 1 / (2 sqrt 2) = 0.35).
        alpha1: f64,
        /// Ratio between successive scales and between the surround and centre (paper: 1.6).
        ratio: f64,
        /// Sharpening parameter phi (paper: 8).
        phi: f64,
        /// Threshold epsilon on the centre-surround activity (paper: 0.05).
        epsilon: f64,
        /// Number of scales (paper: 8), the smallest being 1 pixel.
        scales: u32,
    },
    /// Durand, Dorsey 2002, "Fast bilateral filtering for the display of high-dynamic-range
    /// images": bilateral base of log10 luminance compressed to a target contrast, detail kept.
    DurandBilateral {
        /// Target base contrast (paper: 5), i.e. the base's log10 range becomes log10(contrast).
        contrast: f64,
        /// Spatial sigma as a fraction of the larger image side (paper: 2 %).
        sigma_spatial: f64,
        /// Range sigma on log10 luminance (paper: 0.4).
        sigma_range: f64,
    },
}

impl Operator {
    /// Names accepted by [`Operator::parse`], in the order of the variants.
    pub(crate) const NAMES: [&'static str; 7] = [
        "linear",
        "drago",
        "reinhard",
        "ward",
        "aces",
        "reinhard-local",
        "durand",
    ];

    /// Every operator with its published defaults, in [`Operator::NAMES`] order.
    pub(crate) const ALL: [Operator; 7] = [
        Operator::Linear,
        Operator::DRAGO,
        Operator::REINHARD,
        Operator::WARD,
        Operator::Aces,
        Operator::REINHARD_LOCAL,
        Operator::DURAND,
    ];

    pub const DRAGO: Operator = Operator::Drago {
        bias: 0.85,
        ld_max: 100.0,
    };
    pub const REINHARD: Operator = Operator::Reinhard {
        key: 0.18,
        white: None,
    };
    pub const WARD: Operator = Operator::WardHistogram {
        ld_min: 1.0,
        ld_max: 100.0,
        bins: 100,
    };
    pub const REINHARD_LOCAL: Operator = Operator::ReinhardLocal {
        key: 0.18,
        alpha1: 0.35,
        ratio: 1.6,
        phi: 8.0,
        epsilon: 0.05,
        scales: 8,
    };
    pub const DURAND: Operator = Operator::DurandBilateral {
        contrast: 5.0,
        sigma_spatial: 0.02,
        sigma_range: 0.4,
    };

    /// The operator's name as accepted by [`Operator::parse`].
    pub fn name(&self) -> &'static str {
        Self::NAMES[self.code() as usize]
    }

    /// Whether the operator's picture is the same at every exposure: those that divide the
    /// scene by its log-average (Reinhard, Drago, Reinhard local) or map log luminance relative
    /// to the image's own range (Ward's histogram, Durand's base) scale exposure out, up to
    /// rounding. Linear and ACES map the exposed values as they are.
    pub fn divides_out_exposure(&self) -> bool {
        match self {
            Operator::Linear | Operator::Aces => false,
            Operator::Drago { .. }
            | Operator::Reinhard { .. }
            | Operator::WardHistogram { .. }
            | Operator::ReinhardLocal { .. }
            | Operator::DurandBilateral { .. } => true,
        }
    }

    /// The operator's number in the shaders' `op` field (the index into `Operator::NAMES`).
    pub fn code(&self) -> u32 {
        match self {
            Operator::Linear => 0,
            Operator::Drago { .. } => 1,
            Operator::Reinhard { .. } => 2,
            Operator::WardHistogram { .. } => 3,
            Operator::Aces => 4,
            Operator::ReinhardLocal { .. } => 5,
            Operator::DurandBilateral { .. } => 6,
        }
    }

    /// Whether the operator's output at a pixel depends on its neighbourhood.
    pub(crate) fn is_local(&self) -> bool {
        matches!(
            self,
            Operator::ReinhardLocal { .. } | Operator::DurandBilateral { .. }
        )
    }

    /// Builds an operator from its name and `(parameter, value)` pairs over the defaults, then
    /// validates it. Parameter names are the field names above; Reinhard's `white` <= 0 is not
    /// allowed, leave it out for "largest luminance".
    pub fn parse(name: &str, params: &[(&str, f64)]) -> Result<Operator> {
        let mut op = match name.to_ascii_lowercase().as_str() {
            "linear" => Operator::Linear,
            "drago" => Self::DRAGO,
            "reinhard" => Self::REINHARD,
            "ward" => Self::WARD,
            "aces" => Operator::Aces,
            "reinhard-local" => Self::REINHARD_LOCAL,
            "durand" => Self::DURAND,
            _ => {
                return Err(Error::invalid(
                    "operator",
                    format!(
                        "unknown operator '{name}'; known: {}",
                        Self::NAMES.join(", ")
                    ),
                ))
            }
        };
        for &(param, value) in params {
            op.set(param, value)?;
        }
        op.validate()?;
        Ok(op)
    }

    /// The value of the parameter `param` (as [`Operator::parse`] names it); `None` when the
    /// operator has no such parameter, or for Reinhard's `white` left to the image.
    pub(crate) fn param(&self, param: &str) -> Option<f64> {
        Some(match (*self, param) {
            (Operator::Drago { bias, .. }, "bias") => bias,
            (Operator::Drago { ld_max, .. }, "ld_max") => ld_max,
            (Operator::Reinhard { key, .. }, "key") => key,
            (Operator::Reinhard { white, .. }, "white") => return white,
            (Operator::WardHistogram { ld_min, .. }, "ld_min") => ld_min,
            (Operator::WardHistogram { ld_max, .. }, "ld_max") => ld_max,
            (Operator::WardHistogram { bins, .. }, "bins") => bins as f64,
            (Operator::ReinhardLocal { key, .. }, "key") => key,
            (Operator::ReinhardLocal { alpha1, .. }, "alpha1") => alpha1,
            (Operator::ReinhardLocal { ratio, .. }, "ratio") => ratio,
            (Operator::ReinhardLocal { phi, .. }, "phi") => phi,
            (Operator::ReinhardLocal { epsilon, .. }, "epsilon") => epsilon,
            (Operator::ReinhardLocal { scales, .. }, "scales") => scales as f64,
            (Operator::DurandBilateral { contrast, .. }, "contrast") => contrast,
            (Operator::DurandBilateral { sigma_spatial, .. }, "sigma_spatial") => sigma_spatial,
            (Operator::DurandBilateral { sigma_range, .. }, "sigma_range") => sigma_range,
            _ => return None,
        })
    }

    fn set(&mut self, param: &str, value: f64) -> Result<()> {
        let name = self.name();
        let slot: Option<&mut f64> = match (self, param) {
            (Operator::Drago { bias, .. }, "bias") => Some(bias),
            (Operator::Drago { ld_max, .. }, "ld_max") => Some(ld_max),
            (Operator::Reinhard { key, .. }, "key") => Some(key),
            (Operator::Reinhard { white, .. }, "white") => {
                *white = Some(value);
                return Ok(());
            }
            (Operator::WardHistogram { ld_min, .. }, "ld_min") => Some(ld_min),
            (Operator::WardHistogram { ld_max, .. }, "ld_max") => Some(ld_max),
            (Operator::WardHistogram { bins, .. }, "bins") => {
                *bins = as_count("ward.bins", value, 2, 256)?;
                return Ok(());
            }
            (Operator::ReinhardLocal { key, .. }, "key") => Some(key),
            (Operator::ReinhardLocal { alpha1, .. }, "alpha1") => Some(alpha1),
            (Operator::ReinhardLocal { ratio, .. }, "ratio") => Some(ratio),
            (Operator::ReinhardLocal { phi, .. }, "phi") => Some(phi),
            (Operator::ReinhardLocal { epsilon, .. }, "epsilon") => Some(epsilon),
            (Operator::ReinhardLocal { scales, .. }, "scales") => {
                *scales = as_count("reinhard-local.scales", value, 1, 16)?;
                return Ok(());
            }
            (Operator::DurandBilateral { contrast, .. }, "contrast") => Some(contrast),
            (Operator::DurandBilateral { sigma_spatial, .. }, "sigma_spatial") => {
                Some(sigma_spatial)
            }
            (Operator::DurandBilateral { sigma_range, .. }, "sigma_range") => Some(sigma_range),
            _ => None,
        };
        match slot {
            Some(slot) => {
                *slot = value;
                Ok(())
            }
            None => Err(Error::invalid(
                format!("{name}.{param}"),
                format!(
                    "unknown parameter; '{name}' takes: {}",
                    Self::param_names(name).join(", ")
                ),
            )),
        }
    }

    /// Parameter names each operator accepts in [`Operator::parse`].
    pub(crate) fn param_names(name: &str) -> &'static [&'static str] {
        match name {
            "drago" => &["bias", "ld_max"],
            "reinhard" => &["key", "white"],
            "ward" => &["ld_min", "ld_max", "bins"],
            "reinhard-local" => &["key", "alpha1", "ratio", "phi", "epsilon", "scales"],
            "durand" => &["contrast", "sigma_spatial", "sigma_range"],
            _ => &[],
        }
    }

    /// Whether some operator takes a parameter named `name`.
    pub(crate) fn is_param(name: &str) -> bool {
        Self::NAMES
            .iter()
            .any(|op| Self::param_names(op).contains(&name))
    }

    /// Checks every parameter against its allowed range.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Operator::Linear | Operator::Aces => Ok(()),
            Operator::Drago { bias, ld_max } => {
                if !(bias > 0.0 && bias <= 1.0) {
                    return Err(Error::invalid(
                        "drago.bias",
                        format!("{bias} is outside (0, 1]; the paper uses 0.85"),
                    ));
                }
                positive("drago.ld_max", ld_max)
            }
            Operator::Reinhard { key, white } => {
                positive("reinhard.key", key)?;
                match white {
                    Some(w) => positive("reinhard.white", w),
                    None => Ok(()),
                }
            }
            Operator::WardHistogram {
                ld_min,
                ld_max,
                bins,
            } => {
                positive("ward.ld_min", ld_min)?;
                positive("ward.ld_max", ld_max)?;
                if ld_max <= ld_min {
                    return Err(Error::invalid(
                        "ward.ld_max",
                        format!("{ld_max} must be greater than ld_min = {ld_min}"),
                    ));
                }
                as_count("ward.bins", bins as f64, 2, 256).map(|_| ())
            }
            Operator::ReinhardLocal {
                key,
                alpha1,
                ratio,
                phi,
                epsilon,
                scales,
            } => {
                positive("reinhard-local.key", key)?;
                positive("reinhard-local.alpha1", alpha1)?;
                if !(ratio > 1.0 && ratio.is_finite()) {
                    return Err(Error::invalid(
                        "reinhard-local.ratio",
                        format!("{ratio} must be a finite number > 1 (paper: 1.6)"),
                    ));
                }
                if !(phi.is_finite() && (0.0..=64.0).contains(&phi)) {
                    return Err(Error::invalid(
                        "reinhard-local.phi",
                        format!("{phi} is outside [0, 64] (paper: 8)"),
                    ));
                }
                positive("reinhard-local.epsilon", epsilon)?;
                as_count("reinhard-local.scales", scales as f64, 1, 16)?;
                let largest_sigma = blur_sigma(alpha1, ratio, scales);
                if largest_sigma > 256.0 {
                    return Err(Error::invalid(
                        "reinhard-local.scales",
                        format!(
                            "largest surround sigma {largest_sigma:.1} px exceeds 256 px; lower scales, ratio or alpha1"
                        ),
                    ));
                }
                Ok(())
            }
            Operator::DurandBilateral {
                contrast,
                sigma_spatial,
                sigma_range,
            } => {
                if !(contrast > 1.0 && contrast.is_finite()) {
                    return Err(Error::invalid(
                        "durand.contrast",
                        format!("{contrast} must be a finite number > 1 (paper: 5)"),
                    ));
                }
                if !(sigma_spatial > 0.0 && sigma_spatial <= 0.25) {
                    return Err(Error::invalid(
                        "durand.sigma_spatial",
                        format!(
                            "{sigma_spatial} is outside (0, 0.25] of the image size (paper: 0.02)"
                        ),
                    ));
                }
                positive("durand.sigma_range", sigma_range)
            }
        }
    }
}

/// Standard deviation in pixels of Reinhard's Gaussian number `index` (0-based): the profile
/// exp(-r^2 / (alpha1 s)^2) with s = ratio^index is a Gaussian of sigma = alpha1 s / sqrt 2.
/// Index `scales` is the surround of the largest centre.
pub fn blur_sigma(alpha1: f64, ratio: f64, index: u32) -> f64 {
    alpha1 * ratio.powi(index as i32) / std::f64::consts::SQRT_2
}

/// Durand's spatial sigma in pixels for an image of the given size.
pub(crate) fn durand_sigma_pixels(sigma_spatial: f64, width: u32, height: u32) -> f64 {
    (sigma_spatial * width.max(height) as f64).max(0.5)
}

/// Half-width of the truncated Gaussian window (3 sigma) used by both CPU and GPU blurs.
pub(crate) fn gaussian_radius(sigma: f64) -> u32 {
    (3.0 * sigma).ceil().max(1.0) as u32
}

/// Standard deviation, in cells, of a Gaussian of `sigma_px` pixels computed on a grid of
/// `cell`-pixel cells that was filled by box averaging and is read back by bilinear
/// interpolation: box and tent add about cell^2 / 4 of variance between them, which is taken off
/// so that the whole chain blurs by about `sigma_px`. A grid of one-pixel cells is the image
/// itself (nothing to take off).
pub(crate) fn grid_sigma(sigma_px: f64, cell: u32) -> f64 {
    if cell <= 1 {
        return sigma_px;
    }
    let z = cell as f64;
    (sigma_px * sigma_px / (z * z) - 0.25).max(0.25).sqrt()
}

/// Reinhard's blurs at reduced resolution: scale `index` is blurred on pyramid level
/// [`reinhard_level`] (level k halves the image k times by 2x2 averaging of the (L m, m) pairs),
/// where its sigma still spans at least this many cells.
pub(crate) const REINHARD_MIN_LEVEL_SIGMA: f64 = 1.6;

/// Deepest pyramid level of Reinhard's blurs.
pub(crate) const REINHARD_MAX_LEVEL: u32 = 6;

/// The pyramid level on which Reinhard's Gaussian of `sigma_px` pixels is computed: the
/// coarsest whose cells of 2^k pixels leave sigma_px / 2^k >= `REINHARD_MIN_LEVEL_SIGMA`.
pub fn reinhard_level(sigma_px: f64) -> u32 {
    let mut k = 0;
    while k < REINHARD_MAX_LEVEL
        && sigma_px / f64::from(1u32 << (k + 1)) >= REINHARD_MIN_LEVEL_SIGMA
    {
        k += 1;
    }
    k
}

/// Most intensity levels of Durand's piecewise-linear bilateral filter.
pub(crate) const DURAND_MAX_LEVELS: u32 = 64;
/// Largest side, in cells, of Durand's downsampled grid (bounds its memory: 256^2 cells x
/// [`DURAND_MAX_LEVELS`] levels x 8 bytes = 32 MiB).
pub(crate) const DURAND_MAX_GRID_SIDE: u32 = 256;
/// Smallest range weight of Durand's filter, e^-80: far levels still weigh (very little) so
/// that a normalisation never divides 0 by 0, in f32 as in f64.
pub(crate) const DURAND_MIN_LOG_WEIGHT: f64 = -80.0;

/// Durand & Dorsey's own acceleration (their section 5.1): the bilateral filter of log10
/// luminance as a piecewise-linear function of intensity. Levels i_j = first + j step span the
/// image's log10 luminance at most sigma_r apart; the image is box-averaged onto a grid of
/// `cell`-pixel cells; per level, the range weights w = count exp(-(mean - i_j)^2 / 2 sigma_r^2)
/// and w mean are blurred by a Gaussian of `sigma_cells` (`grid_sigma`) within `radius`
/// cells (2 sigma); each pixel interpolates the two levels around its own l, each read
/// bilinearly from the grid as (sum w mean) / (sum w).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DurandGrid {
    pub cell: u32,
    pub grid_width: u32,
    pub grid_height: u32,
    pub sigma_cells: f64,
    pub radius: u32,
    pub levels: u32,
    pub first_level: f64,
    pub level_step: f64,
}

impl DurandGrid {
    /// The grid for an image of `width` x `height` whose positive luminance spans
    /// [`log10_min`, `log10_max`] (log10 units).
    pub fn new(
        width: u32,
        height: u32,
        sigma_spatial: f64,
        sigma_range: f64,
        log10_min: f64,
        log10_max: f64,
    ) -> DurandGrid {
        let sigma_px = durand_sigma_pixels(sigma_spatial, width, height);
        let by_sigma = (sigma_px / 2.0).floor().max(1.0) as u32;
        let by_memory = width.max(height).div_ceil(DURAND_MAX_GRID_SIDE);
        let cell = by_sigma.max(by_memory).max(1);
        let sigma_cells = grid_sigma(sigma_px, cell);
        let range = (log10_max - log10_min).max(0.0);
        let levels = if range > 0.0 {
            ((range / sigma_range).ceil() as u32 + 1).clamp(2, DURAND_MAX_LEVELS)
        } else {
            2
        };
        let level_step = if range > 0.0 {
            range / (levels - 1) as f64
        } else {
            sigma_range
        };
        DurandGrid {
            cell,
            grid_width: width.div_ceil(cell),
            grid_height: height.div_ceil(cell),
            sigma_cells,
            radius: (2.0 * sigma_cells).ceil().max(1.0) as u32,
            levels,
            first_level: if log10_min.is_finite() {
                log10_min
            } else {
                0.0
            },
            level_step,
        }
    }

    pub fn cells(&self) -> u32 {
        self.grid_width * self.grid_height
    }

    /// The two levels around log10 luminance `l` and the weight of the upper one.
    pub fn bracket(&self, l: f64) -> (u32, f64) {
        let t = (l - self.first_level) / self.level_step;
        let j = t.floor().clamp(0.0, (self.levels - 2) as f64);
        (j as u32, (t - j).clamp(0.0, 1.0))
    }
}

fn positive(field: &str, value: f64) -> Result<()> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("{value} must be a finite number > 0"),
        ))
    }
}

fn as_count(field: &str, value: f64, min: u32, max: u32) -> Result<u32> {
    if value.fract() == 0.0 && value >= min as f64 && value <= max as f64 {
        Ok(value as u32)
    } else {
        Err(Error::invalid(
            field,
            format!("{value} must be a whole number in [{min}, {max}]"),
        ))
    }
}

/// How a display colour with a channel above 1 is brought into [0, 1] after the operator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Gamut {
    /// Scale the whole colour by 1 / its largest channel: hue and saturation are kept (a bright
    /// colour never turns into another hue, so the colour bar still reads the data).
    #[default]
    Scale,
    /// Clip each channel to 1 on its own (changes the hue of bright saturated colours).
    Clip,
}

impl Gamut {
    /// The gamut names `parse` accepts.
    pub(crate) const NAMES: &'static [&'static str] = &["scale", "clip"];

    pub fn parse(name: &str) -> Result<Gamut> {
        match name.to_ascii_lowercase().as_str() {
            "scale" => Ok(Gamut::Scale),
            "clip" => Ok(Gamut::Clip),
            _ => Err(Error::invalid(
                "gamut",
                format!("expected \"scale\" or \"clip\", got {name:?}"),
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Gamut::Scale => "scale",
            Gamut::Clip => "clip",
        }
    }
}

/// Everything a tone-mapping pass needs. The pipeline per pixel is: scene colour x 2^EV ->
/// operator on Rec. 709 luminance -> colour (C / L_w)^saturation * L_d -> + offset -> gamut
/// (a colour whose largest channel exceeds 1 scaled by 1 / max, or clipped per channel) -> clamp
/// to [0, 1] -> ^(1 / gamma). The result is display-referred linear; the sRGB curve comes after.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMapSettings {
    /// Exposure in stops: scene values are multiplied by 2^EV before the operator.
    pub exposure_ev: f64,
    /// Added to display-referred values before clamping, in [-1, 1] (a black-level lift or cut).
    pub offset: f64,
    /// Display gamma applied as v^(1 / gamma) after the offset, in [0.1, 10]; 1 leaves values.
    pub gamma: f64,
    /// Colour saturation s >= 0 in C_d = (C / L_w)^s L_d; 1 keeps the scene's chromaticity.
    pub saturation: f64,
    /// How colours above 1 come into [0, 1] (scaled, keeping their hue, by default).
    pub gamut: Gamut,
    pub op: Operator,
}

impl Default for ToneMapSettings {
    fn default() -> Self {
        ToneMapSettings {
            exposure_ev: 0.0,
            offset: 0.0,
            gamma: 1.0,
            saturation: 1.0,
            gamut: Gamut::Scale,
            op: Operator::REINHARD,
        }
    }
}

impl ToneMapSettings {
    pub fn validate(&self) -> Result<()> {
        if !self.exposure_ev.is_finite() || self.exposure_ev.abs() > 200.0 {
            return Err(Error::invalid(
                "exposure_ev",
                format!(
                    "{} must be a finite number of stops in [-200, 200]",
                    self.exposure_ev
                ),
            ));
        }
        if !(self.offset.is_finite() && (-1.0..=1.0).contains(&self.offset)) {
            return Err(Error::invalid(
                "offset",
                format!("{} is outside [-1, 1]", self.offset),
            ));
        }
        if !(self.gamma.is_finite() && (0.1..=10.0).contains(&self.gamma)) {
            return Err(Error::invalid(
                "gamma",
                format!("{} is outside [0.1, 10]", self.gamma),
            ));
        }
        if !(self.saturation.is_finite() && (0.0..=10.0).contains(&self.saturation)) {
            return Err(Error::invalid(
                "saturation",
                format!("{} is outside [0, 10]", self.saturation),
            ));
        }
        self.op.validate()
    }
}

/// The uniform block every shader in `shaders/tonemap/` declares as `ToneMapParams`.
/// Keep in sync with the WGSL struct `ToneMapParams` (same field order, all 4-byte scalars,
/// 144 bytes). Pass-specific fields (`sigma`, `radius`, the grid and band fields) vary between
/// dispatches of one operator: write one uniform per dispatch or use dynamic offsets.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ToneMapParams {
    pub width: u32,
    pub height: u32,
    /// [`Operator::code`].
    pub op: u32,
    /// Ward histogram bins (<= 256).
    pub bins: u32,
    pub exposure_ev: f32,
    pub offset: f32,
    pub inv_gamma: f32,
    pub saturation: f32,
    /// Reinhard (global and local) key.
    pub key: f32,
    /// Reinhard L_white; <= 0 means "largest scaled luminance".
    pub white: f32,
    /// Drago bias.
    pub bias: f32,
    /// Drago or Ward display maximum (cd/m2); false colour: high decade (log10).
    pub ld_max: f32,
    /// Ward display minimum (cd/m2); false colour: low decade (log10).
    pub ld_min: f32,
    /// Durand: log10 of the target contrast.
    pub contrast_log10: f32,
    /// Durand spatial sigma in pixels.
    pub sigma_spatial_px: f32,
    /// Durand range sigma (log10 units).
    pub sigma_range: f32,
    /// Reinhard local: 2^phi * key.
    pub sharpness: f32,
    /// Reinhard local: epsilon.
    pub epsilon: f32,
    /// Reinhard local: elements per row of a pass's output (`prepare`: level 0's padded pitch;
    /// `blur_x`: the level's width; `fine_x`: every fine plane of a row; `blur_y`: the coarse
    /// buffer's pitch).
    pub out_stride: u32,
    /// Reinhard local `downsample`: cells per stored row of the level above.
    pub in_stride: u32,
    /// Reinhard local `apply`: how many scales are blurred on pyramid level 0 (full
    /// resolution); they come first, since levels grow with the scale.
    pub fine_scales: u32,
    /// Durand: the grid blur's Gaussian sigma in cells (Reinhard's blurs read the host's taps).
    pub sigma: f32,
    /// Window half-width: [`gaussian_radius`] for a Reinhard blur pass, the grid blur's radius
    /// in cells for Durand, the legend strip height for the false-colour view.
    pub radius: u32,
    pub _pad4: u32,
    /// Durand: grid cell side in pixels; Reinhard local: cell side of the pass's pyramid
    /// level (2^k).
    pub cell: u32,
    /// Durand: grid size in cells; Reinhard local: size of the pass's pyramid level.
    pub grid_width: u32,
    pub grid_height: u32,
    /// Durand: number of intensity levels; Reinhard local: number of blurred scales.
    pub levels: u32,
    /// Durand: log10 luminance of level 0 (of the uploaded image, before exposure).
    pub first_level: f32,
    /// Durand: log10 luminance between levels.
    pub level_step: f32,
    /// First row (of pixels, or of cells of the pass's grid) of the band of items this dispatch
    /// covers: images larger than one storage binding are processed in bands of rows, each
    /// binding a window of the large buffers (see `bands.rs` and docs/tonemapping.md).
    pub band_first: u32,
    /// Offset (in elements) of the current pass's destination in a shared buffer.
    pub dst_offset: u32,
    /// Rows in this dispatch's band.
    pub band_rows: u32,
    /// First row of the window bound for a pass's input when it is not the band itself (the
    /// band plus a halo, or the rows a downsample reads).
    pub window_first: u32,
    /// 1 for [`Gamut::Clip`] (read on the host as a pipeline constant, `GAMUT_CLIP`).
    pub gamut_clip: u32,
    /// Uniform structs are a multiple of 16 bytes.
    pub _pad: u32,
}

impl ToneMapParams {
    /// The operator-wide fields for an image; pass fields start at zero.
    pub(crate) fn new(settings: &ToneMapSettings, width: u32, height: u32) -> Self {
        let mut p = ToneMapParams {
            width,
            height,
            op: settings.op.code(),
            exposure_ev: settings.exposure_ev as f32,
            offset: settings.offset as f32,
            inv_gamma: (1.0 / settings.gamma) as f32,
            saturation: settings.saturation as f32,
            gamut_clip: (settings.gamut == Gamut::Clip) as u32,
            band_rows: height,
            ..Default::default()
        };
        match settings.op {
            Operator::Linear | Operator::Aces => {}
            Operator::Drago { bias, ld_max } => {
                p.bias = bias as f32;
                p.ld_max = ld_max as f32;
            }
            Operator::Reinhard { key, white } => {
                p.key = key as f32;
                p.white = white.unwrap_or(0.0) as f32;
            }
            Operator::WardHistogram {
                ld_min,
                ld_max,
                bins,
            } => {
                p.ld_min = ld_min as f32;
                p.ld_max = ld_max as f32;
                p.bins = bins;
            }
            Operator::ReinhardLocal {
                key, phi, epsilon, ..
            } => {
                p.key = key as f32;
                p.sharpness = (2f64.powf(phi) * key) as f32;
                p.epsilon = epsilon as f32;
            }
            Operator::DurandBilateral {
                contrast,
                sigma_spatial,
                sigma_range,
            } => {
                let sigma_px = durand_sigma_pixels(sigma_spatial, width, height);
                p.contrast_log10 = contrast.log10() as f32;
                p.sigma_spatial_px = sigma_px as f32;
                p.sigma_range = sigma_range as f32;
            }
        }
        p
    }
}

/// Result of `shaders/tonemap/luminance_stats.wgsl` (`finish_stats`), over pixels whose exposed
/// luminance is finite and > 0. Keep in sync with the WGSL struct `LuminanceStats` (16 bytes).
/// Means and extremes are kept as natural logs so that images near 1e-30 or 1e30 stay in range.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LuminanceStats {
    /// mean of ln(L_w): ln of the log-average luminance Lbar.
    pub mean_log: f32,
    pub max_log: f32,
    pub min_log: f32,
    /// Number of pixels that entered the statistics; 0 means "nothing to map" (output black).
    pub count: u32,
}
