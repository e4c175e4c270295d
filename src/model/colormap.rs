//! Named colour maps, taken from the `colorgrad` crate rather than hand-typed tables. Maps are
//! defined in display (sRGB-encoded) colour; `Colormap::linear_rgb` converts to linear light,
//! which is what an HDR image holds, so a map shows its intended colours after the sRGB curve.
//! That curve lives here, once for the whole crate: `linear_to_srgb` / [`srgb_to_linear`],
//! and the 8- and 16-bit quantisers every display image (PNG, terminal) goes through.

use crate::error::{Error, Result};
use colorgrad::Gradient;

/// Every colour-map name hdrvis accepts, each also reversed with the suffix `_r` (`rd_bu_r` runs
/// blue to red). `sinebow` and `rainbow` are cyclic (for wrapped data).
pub(crate) const COLORMAP_NAMES: &[&str] = &[
    "viridis",
    "magma",
    "inferno",
    "plasma",
    "cividis",
    "turbo",
    "cubehelix",
    "warm",
    "cool",
    "spectral",
    "rd_bu",
    "rd_yl_bu",
    "br_bg",
    "blues",
    "greens",
    "greys",
    "oranges",
    "reds",
    "yl_or_rd",
    "sinebow",
    "rainbow",
    "white",
];

pub(crate) struct Colormap {
    name: String,
    gradient: Option<Box<dyn Gradient + Send + Sync>>,
    /// `_r`: t runs from 1 to 0.
    reversed: bool,
}

impl std::fmt::Debug for Colormap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Colormap({})", self.name)
    }
}

impl Colormap {
    pub(crate) fn by_name(name: &str) -> Result<Colormap> {
        use colorgrad::preset as p;
        let (base, reversed) = match name.strip_suffix("_r") {
            Some(base) => (base, true),
            None => (name, false),
        };
        let gradient: Option<Box<dyn Gradient + Send + Sync>> = match base {
            "viridis" => Some(Box::new(p::viridis())),
            "magma" => Some(Box::new(p::magma())),
            "inferno" => Some(Box::new(p::inferno())),
            "plasma" => Some(Box::new(p::plasma())),
            "cividis" => Some(Box::new(p::cividis())),
            "turbo" => Some(Box::new(p::turbo())),
            "cubehelix" => Some(Box::new(p::cubehelix_default())),
            "warm" => Some(Box::new(p::warm())),
            "cool" => Some(Box::new(p::cool())),
            "spectral" => Some(Box::new(p::spectral())),
            "rd_bu" => Some(Box::new(p::rd_bu())),
            "rd_yl_bu" => Some(Box::new(p::rd_yl_bu())),
            "br_bg" => Some(Box::new(p::br_bg())),
            "blues" => Some(Box::new(p::blues())),
            "greens" => Some(Box::new(p::greens())),
            "greys" => Some(Box::new(p::greys())),
            "oranges" => Some(Box::new(p::oranges())),
            "reds" => Some(Box::new(p::reds())),
            "yl_or_rd" => Some(Box::new(p::yl_or_rd())),
            "sinebow" => Some(Box::new(p::sinebow())),
            "rainbow" => Some(Box::new(p::rainbow())),
            "white" => None,
            _ => {
                return Err(Error::invalid(
                    "colormap",
                    format!(
                        "unknown colour map {name:?}; known: {} (each also reversed with the suffix _r)",
                        COLORMAP_NAMES.join(", ")
                    ),
                ))
            }
        };
        Ok(Colormap {
            name: name.to_string(),
            gradient,
            reversed,
        })
    }

    pub(crate) fn name(&self) -> &str {
        &self.name
    }

    /// Display-encoded colour at t in [0, 1] (clamped).
    pub(crate) fn srgb(&self, t: f64) -> [f64; 3] {
        match &self.gradient {
            None => [1.0; 3],
            Some(g) => {
                let t = t.clamp(0.0, 1.0);
                let c = g.at(if self.reversed { 1.0 - t } else { t } as f32);
                [c.r as f64, c.g as f64, c.b as f64].map(|v| v.clamp(0.0, 1.0))
            }
        }
    }

    /// Linear-light colour at t in [0, 1] (clamped).
    pub(crate) fn linear_rgb(&self, t: f64) -> [f64; 3] {
        self.srgb(t).map(srgb_to_linear)
    }
}

/// Colour names accepted where a single colour is asked for (a background, the colour of missing
/// data), besides `#rrggbb`.
pub(crate) const COLOUR_NAMES: &[(&str, [u8; 3])] = &[
    ("black", [0, 0, 0]),
    ("white", [255, 255, 255]),
    ("grey", [128, 128, 128]),
    ("gray", [128, 128, 128]),
    ("lightgrey", [211, 211, 211]),
    ("darkgrey", [64, 64, 64]),
    ("tan", [210, 180, 140]),
    ("beige", [245, 245, 220]),
    ("sand", [194, 178, 128]),
];

/// The linear RGB of a named colour (`COLOUR_NAMES`, case-insensitive) or of `#rrggbb` (sRGB).
pub(crate) fn named_colour(field: &str, name: &str) -> Result<[f64; 3]> {
    let lower = name.trim().to_ascii_lowercase();
    let srgb = if let Some(hex) = lower.strip_prefix('#') {
        let byte = |i: usize| {
            hex.get(i..i + 2)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        };
        match (hex.len(), byte(0), byte(2), byte(4)) {
            (6, Some(r), Some(g), Some(b)) => Some([r, g, b]),
            _ => None,
        }
    } else {
        COLOUR_NAMES
            .iter()
            .find(|(n, _)| *n == lower)
            .map(|(_, c)| *c)
    };
    let names: Vec<&str> = COLOUR_NAMES.iter().map(|(n, _)| *n).collect();
    srgb.map(|c| c.map(|v| srgb_to_linear(v as f64 / 255.0)))
        .ok_or_else(|| {
            Error::invalid(
                field,
                format!(
                    "unknown colour {name:?}; expected #rrggbb or one of {}",
                    names.join(", ")
                ),
            )
        })
}

/// The IEC 61966-2-1 sRGB decoding curve (exact piecewise form): an encoded value, clamped to
/// [0, 1], to linear light.
pub fn srgb_to_linear(encoded: f64) -> f64 {
    let v = encoded.clamp(0.0, 1.0);
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// `srgb_to_linear(v) as f32`. An 8-bit code k / 255 (what colorgrad's turbo gives) is decoded
/// from a table of the 256, computed once by the same formula: the false-colour view decodes
/// three per pixel, a million per terminal preview, and a power each cost more than the rest
/// of its work. Any other value is decoded directly.
pub(crate) fn decode_srgb_f32(v: f32) -> f32 {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    let code = (v * 255.0).round();
    if (0.0..=255.0).contains(&code) && code as u8 as f32 / 255.0 == v {
        let table = TABLE.get_or_init(|| {
            std::array::from_fn(|k| srgb_to_linear((k as f32 / 255.0) as f64) as f32)
        });
        return table[code as usize];
    }
    srgb_to_linear(v as f64) as f32
}

/// The IEC 61966-2-1 sRGB encoding curve (exact piecewise form): linear light, clamped to
/// [0, 1] (NaN as 0), to the encoded value.
pub(crate) fn linear_to_srgb(linear: f64) -> f64 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Display-referred linear light (clamped to [0, 1]) as 8-bit sRGB, rounded to nearest.
/// Non-finite values (missing data) show as 0, so +inf is black too. The code is counted among
/// the 255 linear values where it steps ([`srgb8_steps`]) instead of computed through a power
/// per value: a table gives the count at the start of the value's 1/4096-wide bucket, and at
/// most a few steps lie inside a bucket. The same codes as [`srgb8_by_formula`] for every
/// input, several times faster (a terminal preview encodes a million pixels a key).
pub fn encode_srgb8(linear: f64) -> u8 {
    if !linear.is_finite() || linear <= 0.0 {
        return 0;
    }
    if linear >= 1.0 {
        return 255;
    }
    let steps = srgb8_steps();
    // linear * 4096 is exact, so the bucket starts at or below `linear`.
    let mut code = usize::from(srgb8_bucket_codes()[(linear * SRGB8_BUCKETS as f64) as usize]);
    while code < steps.len() && steps[code] <= linear {
        code += 1;
    }
    code as u8
}

/// Buckets of [0, 1) in [`encode_srgb8`]'s table.
const SRGB8_BUCKETS: usize = 4096;

/// `codes[b]`: the 8-bit code of b / 4096, the number of steps at or below it.
fn srgb8_bucket_codes() -> &'static [u8; SRGB8_BUCKETS] {
    static CODES: std::sync::OnceLock<[u8; SRGB8_BUCKETS]> = std::sync::OnceLock::new();
    CODES.get_or_init(|| {
        let steps = srgb8_steps();
        std::array::from_fn(|b| {
            let start = b as f64 / SRGB8_BUCKETS as f64;
            steps.partition_point(|&step| step <= start) as u8
        })
    })
}

/// The sRGB curve and rounding that define [`encode_srgb8`].
fn srgb8_by_formula(linear: f64) -> u8 {
    (linear_to_srgb(linear) * 255.0 + 0.5).floor() as u8
}

/// `steps[k]`: the least f64 whose 8-bit code by [`srgb8_by_formula`] exceeds k, found by
/// bisection on the ordered bit patterns of positive doubles (the formula is monotonic), once.
fn srgb8_steps() -> &'static [f64; 255] {
    static STEPS: std::sync::OnceLock<[f64; 255]> = std::sync::OnceLock::new();
    STEPS.get_or_init(|| {
        std::array::from_fn(|k| {
            let (mut lo, mut hi) = (0u64, 1f64.to_bits());
            // Invariant: code(lo) <= k < code(hi); positive doubles order as their bits.
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if usize::from(srgb8_by_formula(f64::from_bits(mid))) > k {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            f64::from_bits(hi)
        })
    })
}

/// As [`encode_srgb8`], 16 bits deep (16-bit PNG).
pub(crate) fn encode_srgb16(linear: f64) -> u16 {
    if !linear.is_finite() {
        return 0;
    }
    (linear_to_srgb(linear) * 65535.0 + 0.5).floor() as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tabled sRGB decoding equals the formula for every 8-bit code and between codes.
    #[test]
    fn decode_srgb_f32_equals_the_formula() {
        for k in 0..=255u32 {
            let v = k as f32 / 255.0;
            assert_eq!(
                decode_srgb_f32(v),
                srgb_to_linear(v as f64) as f32,
                "code {k}"
            );
            let between = v + 0.3 / 255.0;
            assert_eq!(
                decode_srgb_f32(between),
                srgb_to_linear(between as f64) as f32
            );
        }
    }

    /// The stepped 8-bit encoder gives the formula's code for every input: at each step and the
    /// doubles either side of it, a million random values in [0, 1], and out-of-range ones.
    #[test]
    fn srgb8_by_steps_equals_the_formula() {
        let mut values = vec![0.0, -0.0, 1.0, -1e-300, 1.0 + 1e-12, 7.5, f64::MIN_POSITIVE];
        for &step in srgb8_steps() {
            let bits = step.to_bits();
            values.extend([step, f64::from_bits(bits - 1), f64::from_bits(bits + 1)]);
        }
        let mut rng = crate::model::numeric::SplitMix64(7);
        values.extend((0..1_000_000).map(|_| (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64));
        for v in values {
            assert_eq!(encode_srgb8(v), srgb8_by_formula(v), "{v:e}");
        }
        assert_eq!(encode_srgb8(f64::NAN), 0);
        assert_eq!(encode_srgb8(f64::INFINITY), 0);
        assert_eq!(
            (encode_srgb8(0.0), encode_srgb8(1.0), encode_srgb8(0.5)),
            (0, 255, 188)
        );
    }

    /// Colour maps that wrap around (the colour at 0 equals the colour at 1).
    const CYCLIC_COLORMAPS: &[&str] = &["sinebow", "rainbow"];

    #[test]
    fn every_listed_name_resolves_and_unknown_lists_names() {
        for n in COLORMAP_NAMES {
            let c = Colormap::by_name(n).unwrap();
            let rgb = c.linear_rgb(0.3);
            assert!(rgb.iter().all(|v| (0.0..=1.0).contains(v)), "{n}");
        }
        let e = Colormap::by_name("jet").unwrap_err().to_string();
        assert!(e.contains("viridis") && e.contains("jet"), "{e}");
    }

    #[test]
    fn reversed_maps_run_backwards() {
        let (a, r) = (
            Colormap::by_name("rd_bu").unwrap(),
            Colormap::by_name("rd_bu_r").unwrap(),
        );
        for t in [0.0, 0.2, 0.5, 0.9, 1.0] {
            assert_eq!(a.srgb(t), r.srgb(1.0 - t));
        }
        // rd_bu_r: blue at the low end, red at the high end.
        let (low, high) = (r.srgb(0.0), r.srgb(1.0));
        assert!(low[2] > low[0] && high[0] > high[2]);
        assert!(Colormap::by_name("nope_r").is_err());
    }

    #[test]
    fn named_colours_and_hex_decode_to_linear_light() {
        assert_eq!(named_colour("missing", "black").unwrap(), [0.0; 3]);
        let tan = named_colour("missing", "Tan").unwrap();
        assert!((tan[0] - srgb_to_linear(210.0 / 255.0)).abs() < 1e-12);
        let hex = named_colour("missing", "#D2B48C").unwrap();
        assert_eq!(hex, tan);
        let e = named_colour("missing", "#12345").unwrap_err().to_string();
        assert!(e.starts_with("missing:") && e.contains("tan"), "{e}");
        assert!(named_colour("missing", "mauve").is_err());
    }

    #[test]
    fn viridis_endpoints_match_the_published_map() {
        // matplotlib's viridis starts at #440154 and ends at #fde725 (the preset ends at #fee825).
        let c = Colormap::by_name("viridis").unwrap();
        let a = c.srgb(0.0);
        assert!(
            (a[0] - 0x44 as f64 / 255.0).abs() < 2e-3 && (a[2] - 0x54 as f64 / 255.0).abs() < 2e-3
        );
        let b = c.srgb(1.0);
        assert!((b[0] - 0xfe as f64 / 255.0).abs() < 5e-3);
    }

    #[test]
    fn cyclic_maps_wrap() {
        for n in CYCLIC_COLORMAPS {
            let c = Colormap::by_name(n).unwrap();
            let (a, b) = (c.srgb(0.0), c.srgb(1.0));
            assert!(
                (0..3).all(|i| (a[i] - b[i]).abs() < 2e-2),
                "{n}: {a:?} vs {b:?}"
            );
        }
    }

    #[test]
    fn srgb_curve_matches_iec_61966_2_1() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-12);
        // The two pieces meet at 0.0031308 -> 0.04045 (to 4 decimals).
        assert!((linear_to_srgb(0.0031308) - 0.040449936).abs() < 1e-8);
        assert!((linear_to_srgb(0.18) - 0.461356).abs() < 1e-6);
        // Out of range clamps; NaN encodes as 0 (decoding keeps NaN: missing stays missing).
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert_eq!(linear_to_srgb(5.0), linear_to_srgb(1.0));
        assert_eq!(linear_to_srgb(f64::NAN), 0.0);
        assert_eq!(srgb_to_linear(2.0), 1.0);
        assert!(srgb_to_linear(f64::NAN).is_nan());
        for i in 0..=100 {
            let v = i as f64 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-12);
            assert!((srgb_to_linear(linear_to_srgb(v)) - v).abs() < 1e-12);
        }
    }

    #[test]
    fn srgb_quantisation_endpoints_and_midtones() {
        assert_eq!(encode_srgb8(0.0), 0);
        assert_eq!(encode_srgb8(1.0), 255);
        assert_eq!(encode_srgb8(5.0), 255);
        assert_eq!(encode_srgb8(-5.0), 0);
        // Missing values are black, whatever their sign.
        assert_eq!(encode_srgb8(f64::NAN), 0);
        assert_eq!(encode_srgb8(f64::INFINITY), 0);
        // 18 % grey encodes to 118 in sRGB, 50 % to 188.
        assert_eq!(encode_srgb8(0.18), 118);
        assert_eq!(encode_srgb8(0.5), 188);
        assert_eq!(encode_srgb16(1.0), 65535);
        assert_eq!(encode_srgb16(0.5), 48192); // 0.735357 * 65535
        assert_eq!(encode_srgb16(f64::NAN), 0);
    }
}
