//! The log-luminance histogram of the HDR image with the current exposure window: which decades
//! of scene luminance the display shows between 1/256 of white and white at this exposure.
//! Counting is pure (tested); drawing produces ratatui lines of block characters.

use crate::model::image::rec709_luminance;
use crate::model::HdrImage;
use ratatui::style::{Color, Style};
use ratatui::text::{Line, Span};

/// Counts of log10 luminance over the positive finite pixels of an image.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LogHistogram {
    /// log10 of the smallest and largest positive luminance.
    pub lo: f64,
    pub hi: f64,
    pub counts: Vec<u64>,
    /// Pixels with zero, negative or missing luminance (not in any bin).
    pub dark_or_missing: u64,
}

/// The display window in log10 scene luminance at `exposure_ev`: scene values that land between
/// 1/256 of display white and white (eight stops) under the plain exposure view.
pub(crate) fn exposure_window(exposure_ev: f64) -> (f64, f64) {
    let white = -exposure_ev * std::f64::consts::LOG10_2;
    (white - 8.0 * std::f64::consts::LOG10_2, white)
}

impl LogHistogram {
    /// `bins` equal bins in log10 luminance between the image's extremes; `None` when no pixel
    /// has a positive finite luminance.
    pub(crate) fn new(img: &HdrImage, bins: usize) -> Option<LogHistogram> {
        let bins = bins.max(1);
        let logs: Vec<f64> = img
            .pixels
            .iter()
            .map(|p| rec709_luminance(*p) as f64)
            .filter(|l| l.is_finite() && *l > 0.0)
            .map(f64::log10)
            .collect();
        if logs.is_empty() {
            return None;
        }
        let lo = logs.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = logs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let width = (hi - lo).max(1e-9);
        let mut counts = vec![0u64; bins];
        for l in &logs {
            let b = (((l - lo) / width) * bins as f64) as usize;
            counts[b.min(bins - 1)] += 1;
        }
        Some(LogHistogram {
            lo,
            hi,
            counts,
            dark_or_missing: (img.pixels.len() - logs.len()) as u64,
        })
    }

    /// The log10 luminance at the centre of bin `i`.
    pub(crate) fn bin_centre(&self, i: usize) -> f64 {
        let w = (self.hi - self.lo).max(1e-9) / self.counts.len() as f64;
        self.lo + (i as f64 + 0.5) * w
    }

    /// `height` lines of `width` columns (one bin per column, resampled), columns inside the
    /// exposure window drawn in yellow, others in grey, with a last line of decade labels.
    pub(crate) fn lines(
        &self,
        exposure_ev: f64,
        width: usize,
        height: usize,
    ) -> Vec<Line<'static>> {
        if width == 0 || height < 2 {
            return Vec::new();
        }
        let resampled = LogHistogram {
            counts: (0..width)
                .map(|c| {
                    let a = c * self.counts.len() / width;
                    let b = ((c + 1) * self.counts.len() / width).max(a + 1);
                    self.counts[a..b.min(self.counts.len())].iter().sum()
                })
                .collect(),
            ..self.clone()
        };
        let max = resampled.counts.iter().cloned().max().unwrap_or(1).max(1) as f64;
        let (wlo, whi) = exposure_window(exposure_ev);
        let bar_rows = height - 1;
        const EIGHTHS: [char; 9] = [' ', '▁', '▂', '▃', '▄', '▅', '▆', '▇', '█'];
        let mut lines = Vec::with_capacity(height);
        for row in 0..bar_rows {
            let from_bottom = (bar_rows - 1 - row) as f64;
            let spans: Vec<Span> = resampled
                .counts
                .iter()
                .enumerate()
                .map(|(c, &n)| {
                    // Square-root scale so that small populations remain visible.
                    let level = (n as f64 / max).sqrt() * bar_rows as f64;
                    let fill = ((level - from_bottom) * 8.0).round().clamp(0.0, 8.0) as usize;
                    let centre = resampled.bin_centre(c);
                    let colour = if (wlo..=whi).contains(&centre) {
                        Color::Yellow
                    } else {
                        Color::DarkGray
                    };
                    Span::styled(EIGHTHS[fill].to_string(), Style::default().fg(colour))
                })
                .collect();
            lines.push(Line::from(spans));
        }
        let label = format!(
            "1e{:.1} … 1e{:.1}  window 1e{:.1}…1e{:.1}",
            self.lo, self.hi, wlo, whi
        );
        lines.push(Line::from(label.chars().take(width).collect::<String>()));
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_decades_and_skips_dark_and_missing_pixels() {
        // Luminance of grey v is v; values 1e-3, 10^-1.5 (x2), 1e0, plus 0 and NaN: three
        // one-decade bins, the middle values at a bin centre.
        let grey = |v: f32| [v, v, v, 1.0];
        let img = HdrImage::from_pixels(
            6,
            1,
            vec![
                grey(1e-3),
                grey(10f32.powf(-1.5)),
                grey(10f32.powf(-1.5)),
                grey(1.0),
                grey(0.0),
                grey(f32::NAN),
            ],
        );
        let h = LogHistogram::new(&img, 3).unwrap();
        assert!((h.lo + 3.0).abs() < 1e-6 && h.hi.abs() < 1e-6);
        assert_eq!(h.counts, vec![1, 2, 1]);
        assert_eq!(h.dark_or_missing, 2);
        assert!(LogHistogram::new(&HdrImage::new(2, 2), 8).is_none());
    }

    #[test]
    fn exposure_window_moves_one_stop_per_ev() {
        let (lo0, hi0) = exposure_window(0.0);
        assert!(hi0.abs() < 1e-12);
        assert!((lo0 + 8.0 * 2f64.log10()).abs() < 1e-12);
        let (_, hi1) = exposure_window(1.0);
        assert!(
            (hi1 + 2f64.log10()).abs() < 1e-12,
            "+1 EV shows values half as bright"
        );
    }
}
