//! Exposure and tone mapping of HDR images: operator parameters (names and defaults from the
//! papers), their f64 CPU references, the GPU passes (`shaders/tonemap/`, host code in [`gpu`]),
//! and exposure in stops and exposure brackets (several views of one HDR image, no re-render);
//! [`mapper`] decides which of the two maps a caller's images. The `hdrvis bench tonemap`
//! benchmark is [`crate::bench::tonemap`].

pub(crate) mod bands;
pub mod cpu;
pub mod gpu;
pub mod mapper;
pub mod params;

use crate::error::{Error, Result};
use crate::model::HdrImage;

pub use gpu::GpuToneMapper;
pub use mapper::{MapperChoice, ToneMapper};

pub(crate) use gpu::DISPLAY_REFERRED;
pub use params::{Gamut, Operator, ToneMapSettings};

/// Stage times on stderr when `HDRVIS_TONEMAP_PROFILE` is set, each counted from the previous
/// mark (for finding where the time goes: the tone mapper's upload, passes and readback, the
/// `tonemap` command's read, map and write; the benchmark measures whole calls).
pub struct StageClock(Option<std::cell::Cell<std::time::Instant>>);

impl StageClock {
    pub fn start() -> StageClock {
        StageClock(
            std::env::var_os("HDRVIS_TONEMAP_PROFILE")
                .map(|_| std::cell::Cell::new(std::time::Instant::now())),
        )
    }

    /// Whether stage times are printed (callers wait for the GPU only then).
    pub fn on(&self) -> bool {
        self.0.is_some()
    }

    pub fn mark(&self, stage: &str) {
        if let Some(t) = &self.0 {
            let now = std::time::Instant::now();
            eprintln!(
                "tonemap {stage}: {:.1} ms",
                (now - t.get()).as_secs_f64() * 1e3
            );
            t.set(now);
        }
    }
}

/// Largest exposure magnitude accepted, in stops (as [`ToneMapSettings::validate`]).
pub(crate) const MAX_EV: f64 = 200.0;

/// Checks an exposure in stops: finite and within ±`MAX_EV`.
pub fn check_ev(field: &str, ev: f64) -> Result<()> {
    if ev.is_finite() && ev.abs() <= MAX_EV {
        Ok(())
    } else {
        Err(Error::invalid(
            field,
            format!("{ev} must be a finite number of stops in [-{MAX_EV}, {MAX_EV}]"),
        ))
    }
}

/// Scene-referred exposure: colour × 2^EV, alpha unchanged, so +1 EV doubles every linear value
/// exactly (a power of two). Missing (NaN/Inf) values stay missing. The result is still
/// scene-referred: a `display_referred` mark of the input is dropped, and `exposure_ev` records
/// the total exposure applied.
pub fn exposure(img: &HdrImage, ev: f64) -> Result<HdrImage> {
    check_ev("exposure", ev)?;
    let gain = 2f64.powf(ev);
    let mut out = img.clone();
    for p in &mut out.pixels {
        for c in p.iter_mut().take(3) {
            *c = (*c as f64 * gain) as f32;
        }
    }
    let total = img
        .meta("exposure_ev")
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(0.0)
        + ev;
    out.metadata.retain(|(k, _)| k != DISPLAY_REFERRED);
    out.set_meta("exposure_ev", format!("{total}"));
    Ok(out)
}

/// An exposure bracket: one exposed copy of `img` per entry of `evs` (as the paper's Fig. 5,
/// four exposures of one HDR render), computed from the image alone, never re-rendered.
pub fn bracket(img: &HdrImage, evs: &[f64]) -> Result<Vec<HdrImage>> {
    check_bracket(evs)?;
    evs.iter().map(|&ev| exposure(img, ev)).collect()
}

/// A bracket holds 1 to 64 exposures.
pub(crate) fn check_bracket(evs: &[f64]) -> Result<()> {
    if evs.is_empty() || evs.len() > 64 {
        return Err(Error::invalid(
            "bracket",
            format!("expected 1 to 64 exposures, got {}", evs.len()),
        ));
    }
    Ok(())
}

/// Whether `img` holds display-referred values in [0, 1] (tone-mapped or false colour), which a
/// PNG writer should only sRGB-encode, never expose again.
pub(crate) fn is_display_referred(img: &HdrImage) -> bool {
    img.meta(DISPLAY_REFERRED) == Some("1")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_stop_doubles_and_bracket_keeps_order() {
        let img = HdrImage::from_pixels(2, 1, vec![[0.25, 1.0, 3.0, 0.5], [1e-30, 0.0, 7.0, 1.0]]);
        let up = exposure(&img, 1.0).unwrap();
        for (a, b) in img.pixels.iter().zip(&up.pixels) {
            for k in 0..3 {
                assert_eq!(b[k], 2.0 * a[k]);
            }
            assert_eq!(a[3], b[3]);
        }
        let b = bracket(&img, &[-2.0, 0.0, 2.0]).unwrap();
        assert_eq!(b.len(), 3);
        assert_eq!(b[0].pixels[0][1], 0.25);
        assert_eq!(b[2].pixels[0][1], 4.0);
        assert!(exposure(&img, f64::NAN).is_err());
        assert!(bracket(&img, &[]).is_err());
    }
}
