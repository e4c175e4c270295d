//! HDR transfer functions, as the paper describes them: a data scale (linear, log10, symlog) with
//! an optional magnification lens that widens a chosen sub-range, then colour from a named colour
//! map, emission that may exceed 1 and extinction set in decades, all baked into a float lookup
//! table indexed in the scaled space. Beside it, the physical emission–absorption function
//! (emission e·v and extinction a·v per voxel length, grey) that tests compare with closed forms.
//!
//! A [`TransferFunction`] is what users write; [`ResolvedTransfer`] fixes the domain against a
//! volume's statistics and holds the exact numbers both the GPU and the CPU reference evaluate.

use super::colormap::Colormap;
use super::volume::VolumeStats;
use crate::error::{Error, Result};

/// Number of entries of the baked lookup table.
pub const LUT_SIZE: usize = 4096;

/// Smallest positive normal f32: the floor applied before a logarithm, on the GPU and the CPU alike.
pub(crate) const LOG_FLOOR: f64 = 1.175_494_4e-38;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    Linear,
    Log10,
    /// sign(v)·log10(1 + |v|/linthresh): logarithmic for large magnitudes, linear near zero.
    Symlog {
        linthresh: f64,
    },
}

impl Scale {
    /// Every name [`Scale::parse`] accepts, case ignored: the scale's own name first, then its
    /// aliases.
    pub(crate) const NAMES: &'static [&'static [&'static str]] = &[
        &["linear", "lin"],
        &["log10", "log", "logarithmic"],
        &["symlog", "symmetric-log"],
    ];

    /// The scale named `name` (case ignored; aliases in [`Scale::NAMES`]).
    pub fn parse(name: &str, linthresh: Option<f64>) -> Result<Scale> {
        let lower = name.trim().to_ascii_lowercase();
        match Scale::NAMES
            .iter()
            .position(|aliases| aliases.contains(&lower.as_str()))
        {
            Some(0) => Ok(Scale::Linear),
            Some(1) => Ok(Scale::Log10),
            Some(_) => Ok(Scale::Symlog {
                linthresh: linthresh.unwrap_or(0.0),
            }),
            None => {
                let all = Scale::NAMES.iter().flat_map(|a| a.iter().copied());
                let hint = crate::error::closest_name(&lower, all)
                    .map(|c| format!("did you mean {c}? "))
                    .unwrap_or_default();
                Err(Error::invalid(
                    "scale",
                    format!("unknown scale {name:?}; {hint}known: linear (lin), log10 (log, logarithmic), symlog (symmetric-log)"),
                ))
            }
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Scale::Linear => "linear",
            Scale::Log10 => "log10",
            Scale::Symlog { .. } => "symlog",
        }
    }

    /// The scaled value before normalisation to the domain.
    pub(crate) fn apply(&self, v: f64) -> f64 {
        match *self {
            Scale::Linear => v,
            Scale::Log10 => v.max(LOG_FLOOR).log10(),
            Scale::Symlog { linthresh } => {
                v.signum() * (v.abs() / linthresh).ln_1p() / std::f64::consts::LN_10
            }
        }
    }

    /// The data value whose scaled value is `s`: the inverse of [`Scale::apply`] (above the
    /// log floor for log10).
    pub(crate) fn invert(&self, s: f64) -> f64 {
        match *self {
            Scale::Linear => s,
            Scale::Log10 => 10f64.powf(s),
            Scale::Symlog { linthresh } => {
                s.signum() * linthresh * (s.abs() * std::f64::consts::LN_10).exp_m1()
            }
        }
    }

    fn code(&self) -> u32 {
        match self {
            Scale::Linear => 0,
            Scale::Log10 => 1,
            Scale::Symlog { .. } => 2,
        }
    }
}

/// Non-linear magnification of the data sub-range [lo, hi]: that range takes `factor` times the
/// share of the colour/opacity table it would otherwise get (at most all of it but a sliver).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub lo: f64,
    pub hi: f64,
    pub factor: f64,
}

/// A colour-map transfer function with log-scaled emission and opacity.
#[derive(Clone, Debug, PartialEq)]
pub struct LutTransfer {
    pub scale: Scale,
    /// Data range mapped onto [0, 1]; `None` takes it from the volume (finite min/max, or the
    /// smallest positive value for log10).
    pub domain: Option<[f64; 2]>,
    pub lens: Option<Lens>,
    pub colormap: String,
    /// Control points (t, log10 emission) over the scaled value t in [0, 1], piecewise linear.
    pub emission: Vec<[f64; 2]>,
    /// Control points (t, log10 extinction per voxel length), piecewise linear: decades of opacity.
    pub opacity: Vec<[f64; 2]>,
    /// Scaled values below this are fully transparent and dark.
    pub transparent_below: f64,
}

impl Default for LutTransfer {
    fn default() -> Self {
        LutTransfer {
            scale: Scale::Linear,
            domain: None,
            lens: None,
            colormap: "viridis".into(),
            emission: vec![[0.0, 0.0], [1.0, 0.0]],
            opacity: vec![[0.0, -3.0], [1.0, 0.0]],
            transparent_below: 0.0,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum TransferFunction {
    /// Grey emission e·v and extinction a·v per voxel length (v clamped at 0 from below).
    EmissionAbsorption {
        emission: f64,
        absorption: f64,
    },
    Lut(LutTransfer),
    /// A baked table used as it is: another tool's transfer functions resampled onto hdrvis's
    /// table (built by [`ResolvedTransfer::from_functions`]), whatever the volume's range.
    Table(std::sync::Arc<ResolvedTransfer>),
}

/// Numbers as a reader writes them, for metadata: `[0.001, 3]`.
pub(crate) fn plain_list(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(f64::to_string).collect();
    format!("[{}]", items.join(", "))
}

/// Control points as plain text: `[[0, -3], [1, 0]]`.
fn plain_points(points: &[[f64; 2]]) -> String {
    let items: Vec<String> = points.iter().map(|p| plain_list(p)).collect();
    format!("[{}]", items.join(", "))
}

impl TransferFunction {
    pub fn emission_absorption(emission: f64, absorption: f64) -> Result<TransferFunction> {
        for (f, v) in [("tf.emission", emission), ("tf.absorption", absorption)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(
                    f,
                    format!("expected a finite value >= 0, got {v}"),
                ));
            }
        }
        Ok(TransferFunction::EmissionAbsorption {
            emission,
            absorption,
        })
    }

    pub fn describe(&self) -> String {
        match self {
            TransferFunction::EmissionAbsorption {
                emission,
                absorption,
            } => format!("emission-absorption e={emission} a={absorption}"),
            TransferFunction::Lut(l) => format!(
                "lut scale={} domain={} lens={} colormap={} emission={} opacity={} transparent_below={}",
                l.scale.name(),
                l.domain.map_or("auto".to_string(), |d| plain_list(&d)),
                l.lens.map_or("none".to_string(), |z| format!(
                    "{} factor {}",
                    plain_list(&[z.lo, z.hi]),
                    z.factor
                )),
                l.colormap,
                plain_points(&l.emission),
                plain_points(&l.opacity),
                l.transparent_below
            ),
            TransferFunction::Table(t) => format!(
                "table scale={} of {} entries",
                t.mapping.scale.name(),
                t.lut.len()
            ),
        }
    }

    /// The colour bar of a lookup-table transfer function on a volume with `stats` (its colour
    /// map over the resolved domain on its scale, lens not drawn); `None` for emission-absorption
    /// or a domain that does not resolve.
    pub(crate) fn colour_bar(
        &self,
        stats: &VolumeStats,
        units: &str,
    ) -> Option<crate::model::text::ColourBar> {
        use crate::model::text::{BarScale, ColourBar};
        let TransferFunction::Lut(l) = self else {
            return None;
        };
        let [lo, hi] = l.domain_bounds(stats).ok()?;
        let scale = match l.scale_mapping(lo, hi).scale {
            Scale::Linear => BarScale::Linear,
            Scale::Log10 => BarScale::Log10,
            Scale::Symlog { linthresh } => BarScale::Symlog { linthresh },
        };
        Some(ColourBar {
            colormap: l.colormap.clone(),
            scale,
            lo,
            hi,
            units: units.to_string(),
            label: String::new(),
            extend: [false; 2],
        })
    }

    /// Fixes the domain against the volume's statistics and bakes the table.
    pub fn resolve(&self, stats: &VolumeStats) -> Result<ResolvedTransfer> {
        match self {
            TransferFunction::EmissionAbsorption {
                emission,
                absorption,
            } => Ok(ResolvedTransfer {
                kind: TfKind::EmissionAbsorption {
                    emission: *emission,
                    absorption: *absorption,
                },
                mapping: ScaleMapping::identity(),
                lut: Vec::new(),
            }),
            TransferFunction::Lut(l) => l.resolve(stats),
            TransferFunction::Table(t) => Ok((**t).clone()),
        }
    }

    /// The same function with emission per length times `emission` and extinction per length
    /// times `extinction` (both > 0).
    pub(crate) fn with_factors(&self, emission: f64, extinction: f64) -> TransferFunction {
        match self {
            TransferFunction::EmissionAbsorption {
                emission: e,
                absorption: a,
            } => TransferFunction::EmissionAbsorption {
                emission: e * emission,
                absorption: a * extinction,
            },
            TransferFunction::Lut(l) => {
                let mut l = l.clone();
                let (de, ds) = (emission.log10(), extinction.log10());
                for p in &mut l.emission {
                    p[1] = (p[1] + de).clamp(-30.0, 30.0);
                }
                for p in &mut l.opacity {
                    p[1] = (p[1] + ds).clamp(-30.0, 30.0);
                }
                TransferFunction::Lut(l)
            }
            TransferFunction::Table(t) => {
                let mut t = (**t).clone();
                for e in &mut t.lut {
                    *e = [
                        e[0] * emission,
                        e[1] * emission,
                        e[2] * emission,
                        e[3] * extinction,
                    ];
                }
                TransferFunction::Table(std::sync::Arc::new(t))
            }
        }
    }
}

impl LutTransfer {
    fn resolve(&self, stats: &VolumeStats) -> Result<ResolvedTransfer> {
        let [lo, hi] = self.domain_bounds(stats)?;
        let mut mapping = self.scale_mapping(lo, hi);
        if let Some(lens) = self.lens {
            mapping.lens = lens_placement(&mapping, lens)?;
        }
        self.check_control_points()?;
        self.check_transparent_below()?;
        let cmap = Colormap::by_name(&self.colormap)?;
        Ok(ResolvedTransfer {
            kind: TfKind::Lut,
            mapping,
            lut: self.bake_table(&cmap),
        })
    }

    /// The data range [lo, hi] the table spans: the given domain, or the volume's (finite) range,
    /// starting at the smallest positive value for log10.
    fn domain_bounds(&self, stats: &VolumeStats) -> Result<[f64; 2]> {
        let [lo, hi] = match (self.domain, self.scale) {
            (Some(d), _) => d,
            (None, Scale::Log10) => [
                stats.min_positive.ok_or_else(|| {
                    Error::invalid("tf.scale", "log10 needs positive data values, and this volume has none; use symlog or give a domain")
                })?,
                stats.max,
            ],
            (None, _) => [stats.min, stats.max],
        };
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(Error::invalid(
                "tf.domain",
                "expected finite bounds (the volume has no finite values?)",
            ));
        }
        if let Scale::Log10 = self.scale {
            if lo <= 0.0 {
                return Err(Error::invalid(
                    "tf.domain",
                    format!("log10 needs a domain above 0, got [{lo}, {hi}]"),
                ));
            }
        }
        Ok([lo, hi])
    }

    /// The lens-free map of [lo, hi] onto [0, 1] in the scaled space (a symlog threshold left
    /// unset or invalid becomes a thousandth of the largest magnitude).
    fn scale_mapping(&self, lo: f64, hi: f64) -> ScaleMapping {
        let scale = match self.scale {
            Scale::Symlog { linthresh } if linthresh <= 0.0 || !linthresh.is_finite() => {
                Scale::Symlog {
                    linthresh: (1e-3 * lo.abs().max(hi.abs())).max(f64::MIN_POSITIVE),
                }
            }
            s => s,
        };
        let (s_lo, s_hi) = (scale.apply(lo), scale.apply(hi));
        // A constant volume gives a zero-width domain; every voxel then maps to t = 0.
        let inv_range = if s_hi > s_lo {
            1.0 / (s_hi - s_lo)
        } else {
            0.0
        };
        ScaleMapping {
            scale,
            s_lo,
            inv_range,
            lens: None,
        }
    }

    /// That `transparent_below` is a scaled value t in [0, 1], as the control points are; a
    /// number outside (most likely a data value) is refused, saying what it is in t on a given
    /// linear domain.
    pub(crate) fn check_transparent_below(&self) -> Result<()> {
        let t = self.transparent_below;
        if (0.0..=1.0).contains(&t) {
            return Ok(());
        }
        let hint = match self.domain {
            Some([lo, hi]) if self.scale == Scale::Linear && hi > lo && (lo..=hi).contains(&t) => {
                format!(
                    "; the data value {t} is t = {:.4} on the domain [{lo}, {hi}]",
                    (t - lo) / (hi - lo)
                )
            }
            _ => String::new(),
        };
        Err(Error::invalid(
            "transparent_below",
            format!(
                "{t} is not a scaled value t in [0, 1], as the emission and opacity points are{hint}"
            ),
        ))
    }

    /// Rejects empty, non-finite, unsorted or out-of-range emission and opacity control points.
    fn check_control_points(&self) -> Result<()> {
        for (field, pts) in [
            ("tf.emission", &self.emission),
            ("tf.opacity", &self.opacity),
        ] {
            if pts.is_empty() || pts.iter().any(|p| !p[0].is_finite() || !p[1].is_finite()) {
                return Err(Error::invalid(
                    field,
                    "expected at least one [t, log10 value] point with finite numbers",
                ));
            }
            if pts.windows(2).any(|w| w[1][0] < w[0][0]) {
                return Err(Error::invalid(field, "control points must be sorted by t"));
            }
            if pts.iter().any(|p| p[1] > 30.0 || p[1] < -30.0) {
                return Err(Error::invalid(field, "log10 values must lie in [-30, 30]"));
            }
        }
        Ok(())
    }

    /// The LUT_SIZE table entries (r·e, g·e, b·e, extinction) over t in [0, 1].
    fn bake_table(&self, cmap: &Colormap) -> Vec<[f64; 4]> {
        (0..LUT_SIZE)
            .map(|i| {
                let t = i as f64 / (LUT_SIZE - 1) as f64;
                if t < self.transparent_below {
                    return [0.0; 4];
                }
                let e = 10f64.powf(piecewise(&self.emission, t));
                let s = 10f64.powf(piecewise(&self.opacity, t));
                let c = cmap.linear_rgb(t);
                [c[0] * e, c[1] * e, c[2] * e, s]
            })
            .collect()
    }
}

/// Where a lens puts its range on the table, as (ta, tb, out_a, out_b) for `ScaleMapping::lens`;
/// `None` when the range is empty in the base coordinate.
fn lens_placement(mapping: &ScaleMapping, lens: Lens) -> Result<Option<[f64; 4]>> {
    if !(lens.factor.is_finite() && lens.factor >= 1.0) {
        return Err(Error::invalid(
            "tf.lens.factor",
            format!("expected a finite value >= 1, got {}", lens.factor),
        ));
    }
    if lens.lo.partial_cmp(&lens.hi) != Some(std::cmp::Ordering::Less) {
        return Err(Error::invalid(
            "tf.lens",
            format!("expected lo < hi, got [{}, {}]", lens.lo, lens.hi),
        ));
    }
    let ta = mapping.base(lens.lo);
    let tb = mapping.base(lens.hi);
    if tb > ta {
        let width = (lens.factor * (tb - ta)).min(0.98_f64.max(tb - ta));
        let k = if tb - ta < 1.0 {
            (1.0 - width) / (1.0 - (tb - ta))
        } else {
            1.0
        };
        Ok(Some([ta, tb, ta * k, ta * k + width]))
    } else {
        Ok(None)
    }
}

/// Segments whose table coordinates differ by less than this (in entries) take the table at their
/// middle: below it the integral's difference quotient would lose more to f32 rounding on the
/// GPU than the middle value differs from the mean.
pub(crate) const PREINTEGRATION_MIN_SPAN: f64 = 1e-3;

/// The table entry i whose linear piece [i, i + 1] holds coordinate x.
fn table_cell(x: f64) -> usize {
    (x.max(0.0).floor() as usize).min(LUT_SIZE - 2)
}

/// The mean of max(v, 0) as v runs linearly from a to b.
pub(crate) fn mean_positive_part(a: f64, b: f64) -> f64 {
    if a >= 0.0 && b >= 0.0 {
        0.5 * (a + b)
    } else if a <= 0.0 && b <= 0.0 {
        0.0
    } else {
        let p = a.max(b);
        p * p / (2.0 * (a - b).abs())
    }
}

/// Piecewise-linear interpolation through sorted control points, constant beyond the ends.
pub fn piecewise(points: &[[f64; 2]], t: f64) -> f64 {
    let first = points[0];
    if t <= first[0] {
        return first[1];
    }
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        if t <= b[0] {
            let span = b[0] - a[0];
            return if span > 0.0 {
                a[1] + (b[1] - a[1]) * (t - a[0]) / span
            } else {
                b[1]
            };
        }
    }
    points[points.len() - 1][1]
}

/// The map from a data value to the table coordinate t in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ScaleMapping {
    pub scale: Scale,
    pub s_lo: f64,
    pub inv_range: f64,
    /// Lens as (ta, tb, out_a, out_b): [ta, tb] of the base coordinate maps onto [out_a, out_b].
    pub lens: Option<[f64; 4]>,
}

impl ScaleMapping {
    fn identity() -> Self {
        ScaleMapping {
            scale: Scale::Linear,
            s_lo: 0.0,
            inv_range: 1.0,
            lens: None,
        }
    }

    fn base(&self, v: f64) -> f64 {
        ((self.scale.apply(v) - self.s_lo) * self.inv_range).clamp(0.0, 1.0)
    }

    pub fn map(&self, v: f64) -> f64 {
        let t = self.base(v);
        match self.lens {
            None => t,
            Some(l) => lens_map(t, l),
        }
    }

    pub(crate) fn scale_code(&self) -> u32 {
        self.scale.code()
    }

    pub fn linthresh(&self) -> f64 {
        match self.scale {
            Scale::Symlog { linthresh } => linthresh,
            _ => 1.0,
        }
    }
}

fn lens_map(t: f64, [ta, tb, oa, ob]: [f64; 4]) -> f64 {
    if t < ta {
        if ta > 0.0 {
            t * oa / ta
        } else {
            oa
        }
    } else if t <= tb {
        oa + (t - ta) * (ob - oa) / (tb - ta)
    } else if tb < 1.0 {
        ob + (t - tb) * (1.0 - ob) / (1.0 - tb)
    } else {
        ob
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum TfKind {
    EmissionAbsorption { emission: f64, absorption: f64 },
    Lut,
}

/// A transfer function with every number fixed: what the GPU uploads and the CPU reference uses.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedTransfer {
    pub(crate) kind: TfKind,
    pub(crate) mapping: ScaleMapping,
    /// LUT_SIZE entries of (r·e, g·e, b·e, extinction) in linear light; empty for emission–absorption.
    pub lut: Vec<[f64; 4]>,
}

/// Which value ranges a transfer function leaves transparent, in constant time per range: the
/// number of table entries that emit or absorb before each entry.
pub(crate) struct Transparency<'a> {
    tf: &'a ResolvedTransfer,
    visible_before: Vec<u32>,
}

impl Transparency<'_> {
    /// Whether every value in [lo, hi] — and anything trilinear interpolation of such values can
    /// round to — has zero emission and zero extinction, on the GPU as on the CPU. Conservative:
    /// the range is widened by f32 rounding, the scaled coordinate by 1e-5 scaled units (f32
    /// logarithms are far closer), and the table by one entry on each side.
    pub(crate) fn covers(&self, lo: f64, hi: f64) -> bool {
        match self.tf.kind {
            TfKind::EmissionAbsorption {
                emission,
                absorption,
            } => (emission == 0.0 && absorption == 0.0) || hi <= 0.0,
            TfKind::Lut => {
                let widen = 1e-6 * lo.abs().max(hi.abs());
                let m = &self.tf.mapping;
                let margin = 1e-5 * m.inv_range;
                let base = |v: f64, d: f64| {
                    ((m.scale.apply(v) - m.s_lo) * m.inv_range + d).clamp(0.0, 1.0)
                };
                let lens = |t: f64| m.lens.map_or(t, |l| lens_map(t, l));
                let n = (LUT_SIZE - 1) as f64;
                let first = (lens(base(lo - widen, -margin)) * n).floor() - 1.0;
                let last = (lens(base(hi + widen, margin)) * n).ceil() + 1.0;
                let first = first.clamp(0.0, n) as usize;
                let last = last.clamp(0.0, n) as usize;
                self.visible_before[last + 1] == self.visible_before[first]
            }
        }
    }
}

impl ResolvedTransfer {
    /// A table over the data range `domain` on `scale` (a symlog threshold <= 0 becomes a
    /// thousandth of the largest magnitude) whose entries are `f(value)` = (emission in linear
    /// RGB, extinction), both per voxel length, at each entry's value; values beyond the domain
    /// take the end entries.
    pub fn from_functions(
        scale: Scale,
        domain: [f64; 2],
        f: impl Fn(f64) -> ([f64; 3], f64),
    ) -> Result<ResolvedTransfer> {
        let l = LutTransfer {
            scale,
            domain: Some(domain),
            ..Default::default()
        };
        let [lo, hi] = domain;
        let positive = !matches!(scale, Scale::Log10) || lo > 0.0;
        if !(lo.is_finite() && hi.is_finite() && lo < hi && positive) {
            return Err(Error::invalid(
                "tf.domain",
                format!("expected finite lo < hi (above 0 for log10), got [{lo}, {hi}]"),
            ));
        }
        let mapping = l.scale_mapping(lo, hi);
        let lut = (0..LUT_SIZE)
            .map(|i| {
                let t = i as f64 / (LUT_SIZE - 1) as f64;
                let v = mapping.scale.invert(mapping.s_lo + t / mapping.inv_range);
                let (e, s) = f(v.clamp(lo, hi));
                [e[0], e[1], e[2], s]
            })
            .collect();
        Ok(ResolvedTransfer {
            kind: TfKind::Lut,
            mapping,
            lut,
        })
    }

    /// `count` values evenly spaced in the function's own scale across its domain (log-spaced
    /// for log10): where to sample it for a peer whose functions are piecewise linear in value.
    pub(crate) fn scaled_samples(&self, count: usize) -> Vec<f64> {
        let m = &self.mapping;
        (0..count)
            .map(|i| {
                let t = i as f64 / (count.max(2) - 1) as f64;
                m.scale.invert(m.s_lo + t / m.inv_range)
            })
            .collect()
    }

    /// Emission (linear RGB per voxel length) and extinction (per voxel length) for a finite value.
    pub fn eval(&self, v: f64) -> ([f64; 3], f64) {
        match self.kind {
            TfKind::EmissionAbsorption {
                emission,
                absorption,
            } => {
                let v = v.max(0.0);
                ([emission * v; 3], absorption * v)
            }
            TfKind::Lut => self.table_at(self.table_coord(v)),
        }
    }

    /// The table coordinate of a value: its scaled value in units of table entries.
    pub fn table_coord(&self, v: f64) -> f64 {
        self.mapping.map(v) * (LUT_SIZE - 1) as f64
    }

    /// The table, linearly interpolated, at table coordinate x in [0, LUT_SIZE - 1].
    pub fn table_at(&self, x: f64) -> ([f64; 3], f64) {
        let i = table_cell(x);
        let f = x - i as f64;
        let (a, b) = (self.lut[i], self.lut[i + 1]);
        let l = |c: usize| a[c] + (b[c] - a[c]) * f;
        ([l(0), l(1), l(2)], l(3))
    }

    /// The running integral of the table over its coordinate at every entry: C(i) = ∫₀ⁱ
    /// table(x) dx, exact for the piecewise-linear table. Pre-integration reads segment means
    /// from it. Empty for emission–absorption.
    pub fn table_integral(&self) -> Vec<[f64; 4]> {
        let mut sum = [0.0f64; 4];
        let mut out = Vec::with_capacity(self.lut.len());
        for (i, e) in self.lut.iter().enumerate() {
            if i > 0 {
                let prev = self.lut[i - 1];
                for c in 0..4 {
                    sum[c] += 0.5 * (prev[c] + e[c]);
                }
            }
            out.push(sum);
        }
        out
    }

    /// Pre-integrated transfer function: the mean emission and extinction over a segment along
    /// which the value runs linearly from `front` to `back` (for tables: the table coordinate
    /// runs linearly, as in Engel et al.'s pre-integration). Composited as one homogeneous
    /// segment, this keeps transfer-function features narrower than a step that point sampling
    /// would step over. `integral` is [`Self::table_integral`]. The GPU computes the same
    /// quantity from a (hi, lo) f32 split of the integral.
    pub(crate) fn segment_mean(
        &self,
        integral: &[[f64; 4]],
        front: f64,
        back: f64,
    ) -> ([f64; 3], f64) {
        match self.kind {
            TfKind::EmissionAbsorption {
                emission,
                absorption,
            } => {
                let m = mean_positive_part(front, back);
                ([emission * m; 3], absorption * m)
            }
            TfKind::Lut => {
                let (xf, xb) = (self.table_coord(front), self.table_coord(back));
                if table_cell(xf) == table_cell(xb) || (xb - xf).abs() < PREINTEGRATION_MIN_SPAN {
                    // Within one linear piece the mean is the value at the middle.
                    return self.table_at(0.5 * (xf + xb));
                }
                let c = |x: f64, k: usize| {
                    let i = table_cell(x);
                    let f = x - i as f64;
                    let (a, b) = (self.lut[i][k], self.lut[i + 1][k]);
                    integral[i][k] + f * a + 0.5 * f * f * (b - a)
                };
                let m = |k: usize| (c(xb, k) - c(xf, k)) / (xb - xf);
                ([m(0), m(1), m(2)], m(3))
            }
        }
    }

    /// Which value ranges the function leaves transparent (see [`Transparency::covers`]); the
    /// table's visible entries are counted once, so each range costs constant time.
    pub(crate) fn transparency(&self) -> Transparency<'_> {
        let mut visible_before = Vec::with_capacity(self.lut.len() + 1);
        let mut count = 0u32;
        visible_before.push(0);
        for e in &self.lut {
            count += u32::from(e.iter().any(|&c| c as f32 != 0.0));
            visible_before.push(count);
        }
        Transparency {
            tf: self,
            visible_before,
        }
    }

    /// The GPU's pre-integration rows after the table: the running integral split into f32 (hi)
    /// and the f32 of what hi leaves out (lo), so differences of nearby entries keep ~1e-14 of
    /// the integral rather than f32's 6e-8.
    pub(crate) fn table_integral_f32(&self) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
        let c = self.table_integral();
        let hi: Vec<[f32; 4]> = c.iter().map(|e| e.map(|v| v as f32)).collect();
        let lo = c
            .iter()
            .zip(&hi)
            .map(|(e, h)| [0, 1, 2, 3].map(|k| (e[k] - h[k] as f64) as f32))
            .collect();
        (hi, lo)
    }

    /// The table rounded to f32, as the GPU holds it; the CPU reference evaluates the same numbers.
    pub(crate) fn lut_f32(&self) -> Vec<[f32; 4]> {
        self.lut.iter().map(|e| e.map(|v| v as f32)).collect()
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn scale_names_ignore_case_and_accept_aliases() {
        use super::Scale;
        for (name, want) in [
            ("LOG10", "log10"),
            ("Log", "log10"),
            ("logarithmic", "log10"),
            ("Lin", "linear"),
            ("SymLog", "symlog"),
            ("symmetric-log", "symlog"),
        ] {
            assert_eq!(
                Scale::parse(name, Some(1.0)).unwrap().name(),
                want,
                "{name}"
            );
        }
        let err = Scale::parse("lgo10", None).unwrap_err().to_string();
        assert!(err.contains("did you mean log10?"), "{err}");
    }

    #[test]
    fn metadata_text_has_no_program_formatting() {
        let tf = super::TransferFunction::Lut(super::LutTransfer {
            domain: Some([0.001, 3.0]),
            ..Default::default()
        });
        let text = tf.describe();
        assert!(text.contains("domain=[0.001, 3] "), "{text}");
        assert!(text.contains("emission=[[0, 0], [1, 0]]"), "{text}");
        assert!(!text.contains("Some") && !text.contains("None"), "{text}");
    }

    use super::*;

    fn stats(min: f64, max: f64) -> VolumeStats {
        VolumeStats {
            min,
            max,
            min_positive: Some(min.max(1e-30)),
            min_abs_nonzero: Some(min.abs().max(1e-30)),
            finite: 1,
            non_finite: 0,
        }
    }

    #[test]
    fn invert_undoes_apply_on_every_scale() {
        for scale in [
            Scale::Linear,
            Scale::Log10,
            Scale::Symlog { linthresh: 1e-3 },
        ] {
            for s in [-2.5, -0.3, 0.0, 0.7, 3.0] {
                let back = scale.apply(scale.invert(s));
                assert!((back - s).abs() < 1e-12, "{scale:?} {s}: {back}");
            }
        }
    }

    #[test]
    fn log_scale_maps_decades_evenly() {
        let tf = TransferFunction::Lut(LutTransfer {
            scale: Scale::Log10,
            domain: Some([1e-3, 1e2]),
            ..Default::default()
        });
        let r = tf.resolve(&stats(0.0, 1.0)).unwrap();
        assert!((r.mapping.map(1e-3) - 0.0).abs() < 1e-12);
        assert!((r.mapping.map(1.0) - 0.6).abs() < 1e-12);
        assert!((r.mapping.map(1e2) - 1.0).abs() < 1e-12);
        // Zeros and negatives fall to the low end instead of producing NaN.
        assert_eq!(r.mapping.map(0.0), 0.0);
        assert_eq!(r.mapping.map(-5.0), 0.0);
    }

    #[test]
    fn opacity_is_set_in_decades() {
        let tf = TransferFunction::Lut(LutTransfer {
            domain: Some([0.0, 1.0]),
            opacity: vec![[0.0, -4.0], [1.0, 0.0]],
            ..Default::default()
        });
        let r = tf.resolve(&stats(0.0, 1.0)).unwrap();
        assert!((r.eval(0.0).1 - 1e-4).abs() < 1e-16);
        assert!((r.eval(1.0).1 - 1.0).abs() < 1e-12);
        // Halfway is the geometric mean: two decades down.
        let mid = r.eval(0.5).1;
        assert!((mid.log10() + 2.0).abs() < 1e-3, "{mid}");
    }

    #[test]
    fn lens_magnifies_its_subrange_and_stays_monotonic() {
        let tf = TransferFunction::Lut(LutTransfer {
            domain: Some([0.0, 1.0]),
            lens: Some(Lens {
                lo: 0.4,
                hi: 0.5,
                factor: 4.0,
            }),
            ..Default::default()
        });
        let m = tf.resolve(&stats(0.0, 1.0)).unwrap().mapping;
        assert!(((m.map(0.5) - m.map(0.4)) - 0.4).abs() < 1e-12);
        let mut prev = -1.0;
        for i in 0..=1000 {
            let t = m.map(i as f64 / 1000.0);
            assert!(t >= prev);
            prev = t;
        }
        assert!((m.map(1.0) - 1.0).abs() < 1e-12 && m.map(0.0) == 0.0);
    }

    #[test]
    fn symlog_is_odd_and_linear_near_zero() {
        let s = Scale::Symlog { linthresh: 1e-3 };
        assert!((s.apply(-2.0) + s.apply(2.0)).abs() < 1e-15);
        assert!((s.apply(1e-9) - 1e-6 / std::f64::consts::LN_10).abs() < 1e-12);
    }

    #[test]
    fn transparency_of_a_range_follows_the_table() {
        let tf = TransferFunction::Lut(LutTransfer {
            domain: Some([0.0, 1.0]),
            transparent_below: 0.5,
            ..Default::default()
        });
        let r = tf.resolve(&stats(0.0, 1.0)).unwrap();
        assert!(r.transparency().covers(0.0, 0.49));
        assert!(r.transparency().covers(-5.0, 0.1));
        // The first opaque entry is at t = 0.5; the margin keeps ranges just below it out.
        assert!(!r.transparency().covers(0.2, 0.4999));
        assert!(!r.transparency().covers(0.45, 0.6));
        // Every value the table calls transparent evaluates to exactly zero.
        for i in 0..=1000 {
            let v = 0.4998 * i as f64 / 1000.0;
            let (e, a) = r.eval(v);
            assert_eq!((e, a), ([0.0; 3], 0.0), "{v}");
        }
        let ea = TransferFunction::emission_absorption(1.0, 0.5).unwrap();
        let r = ea.resolve(&stats(0.0, 1.0)).unwrap();
        assert!(r.transparency().covers(-3.0, 0.0) && !r.transparency().covers(-3.0, 1e-30));
    }

    #[test]
    fn bad_parameters_are_rejected() {
        assert!(TransferFunction::emission_absorption(-1.0, 1.0).is_err());
        let tf = TransferFunction::Lut(LutTransfer {
            scale: Scale::Log10,
            domain: Some([-1.0, 1.0]),
            ..Default::default()
        });
        assert!(tf.resolve(&stats(0.0, 1.0)).is_err());
        let tf = TransferFunction::Lut(LutTransfer {
            colormap: "nope".into(),
            ..Default::default()
        });
        assert!(tf
            .resolve(&stats(0.0, 1.0))
            .unwrap_err()
            .to_string()
            .contains("viridis"));
    }

    #[test]
    fn segment_means_match_closed_forms() {
        // The mean of max(v, 0) along a linear v.
        assert_eq!(mean_positive_part(2.0, 4.0), 3.0);
        assert_eq!(mean_positive_part(-2.0, -1.0), 0.0);
        assert_eq!(mean_positive_part(-1.0, 1.0), 0.25);
        assert_eq!(mean_positive_part(3.0, -1.0), 9.0 / 8.0);
        let ea = TransferFunction::emission_absorption(2.0, 0.5)
            .unwrap()
            .resolve(&stats(0.0, 1.0))
            .unwrap();
        assert_eq!(ea.segment_mean(&[], -1.0, 1.0), ([0.5; 3], 0.125));
        // A table: the mean over [xf, xb] is the integral of the piecewise-linear table over the
        // span divided by its length, and the middle value within one linear piece.
        let tf = TransferFunction::Lut(LutTransfer {
            domain: Some([0.0, 1.0]),
            opacity: vec![[0.0, -3.0], [0.5, 0.0], [1.0, -3.0]],
            ..Default::default()
        })
        .resolve(&stats(0.0, 1.0))
        .unwrap();
        let integral = tf.table_integral();
        let n = (LUT_SIZE - 1) as f64;
        let (vf, vb) = (0.2, 0.7);
        let (xf, xb) = (tf.table_coord(vf), tf.table_coord(vb));
        let steps = 200_000;
        let quadrature = (0..steps)
            .map(|k| {
                tf.table_at(xf + (xb - xf) * (k as f64 + 0.5) / steps as f64)
                    .1
            })
            .sum::<f64>()
            / steps as f64;
        let mean = tf.segment_mean(&integral, vf, vb).1;
        assert!(
            (mean - quadrature).abs() < 1e-9 * quadrature,
            "{mean} {quadrature}"
        );
        let (a, b) = (100.25 / n, 100.75 / n);
        let mid = tf.table_at(tf.table_coord(0.5 * (a + b))).1;
        assert!((tf.segment_mean(&integral, a, b).1 - mid).abs() < 1e-15);
    }
}
