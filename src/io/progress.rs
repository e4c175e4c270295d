//! The one progress bar on stderr, for a script's `progress(i, n)` and for `hdrvis gen`: the time
//! left is estimated from the measured rate of the items done so far (elapsed / done ×
//! remaining). The count starts when the loop reports 0 done, else when the previous loop
//! finished or the run began, so the first item's time is counted even when the caller reports
//! only after finishing it. indicatif draws it only when stderr is a terminal.

use std::time::Instant;

/// A progress bar and the clock its estimate reads.
pub struct Progress {
    epoch: Instant,
    /// Seconds since `epoch` at which the current loop (or the next one) started.
    started_s: f64,
    bar: Option<indicatif::ProgressBar>,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            epoch: Instant::now(),
            started_s: 0.0,
            bar: None,
        }
    }
}

impl Progress {
    /// Shows a fraction (0 to 1) of one job done, as a percentage.
    pub fn fraction(&mut self, done: f64, label: &str) {
        self.report((done.clamp(0.0, 1.0) * 100.0).floor() as u64, 100, label);
    }

    /// Clears the bar (a job that ended early, or one whose last line should not stay).
    pub fn clear(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }

    /// Shows `done` of `total` items, now.
    pub fn report(&mut self, done: u64, total: u64, label: &str) {
        let now_s = self.epoch.elapsed().as_secs_f64();
        let text = self.status_at(done, total, label, now_s);
        let bar = self.bar.get_or_insert_with(|| {
            let bar = indicatif::ProgressBar::new(total);
            bar.set_style(
                indicatif::ProgressStyle::with_template("[{bar:30}] {pos}/{len} {msg}")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            bar
        });
        bar.set_length(total);
        bar.set_position(done.min(total));
        bar.set_message(text);
        if done >= total {
            bar.finish();
            self.bar = None;
        }
    }

    /// The bar's text at `now_s` seconds (label, elapsed time and the estimate), keeping the
    /// loop's start: the clock is a parameter so the estimate can be tested.
    pub(crate) fn status_at(&mut self, done: u64, total: u64, label: &str, now_s: f64) -> String {
        if self.bar.is_none() && done == 0 {
            self.started_s = now_s;
        }
        let elapsed = (now_s - self.started_s).max(0.0);
        let eta = remaining_s(done, total, elapsed).map_or("?".to_string(), duration_text);
        let text = format!("{label} elapsed {} eta {eta}", duration_text(elapsed));
        if done >= total {
            self.started_s = now_s;
        }
        text.trim_start().to_string()
    }
}

/// Seconds left at the rate measured so far; `None` before the first item is done.
pub(crate) fn remaining_s(done: u64, total: u64, elapsed_s: f64) -> Option<f64> {
    (done > 0).then(|| elapsed_s / done as f64 * total.saturating_sub(done) as f64)
}

/// `42s`, `3m05s`, `2h01m`.
fn duration_text(seconds: f64) -> String {
    let s = seconds.round() as u64;
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eta_is_the_measured_rate_times_the_items_left() {
        let mut state = Progress::default();
        // 24 items of ~3 s each; the script reports 0 at t = 10 s, then after each item.
        assert_eq!(
            state.status_at(0, 24, "sweep", 10.0),
            "sweep elapsed 0s eta ?"
        );
        // 3 done after 9 s: 3 s per item, 21 left -> 63 s (the issue saw "eta 4s" here).
        assert_eq!(
            state.status_at(3, 24, "sweep", 19.0),
            "sweep elapsed 9s eta 1m03s"
        );
        assert_eq!(remaining_s(12, 24, 36.0), Some(36.0));
        assert_eq!(remaining_s(0, 24, 5.0), None);
        assert_eq!(remaining_s(24, 24, 72.0), Some(0.0));
    }

    #[test]
    fn a_loop_that_reports_only_finished_items_counts_from_the_previous_loop() {
        let mut state = Progress::default();
        state.status_at(2, 2, "first", 4.0);
        // The next loop's first report comes after its first item, 5 s after the first loop.
        assert_eq!(state.status_at(1, 4, "", 9.0), "elapsed 5s eta 15s");
        assert_eq!(duration_text(7325.0), "2h02m");
        assert_eq!(duration_text(185.0), "3m05s");
    }
}
