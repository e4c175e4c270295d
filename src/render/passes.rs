//! What a render did, pass by pass: each stage of the pass graph (load, upload, ray cast, surface
//! data, fringe, exposure, tone mapping, and the sinks) appends one record saying whether it ran
//! and for how long, or came from the cache. `hdrvis run --stats` prints the log, the TUI shows
//! it, and every image carries the records of the passes that produced it in its metadata.

use std::sync::Mutex;

/// Whether a pass ran (and its wall time) or its result came from the cache.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PassOutcome {
    Ran { ms: f64 },
    Cached,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PassRecord {
    pub name: String,
    pub outcome: PassOutcome,
    /// Effects compiled into the pass, e.g. "shading, jitter" for a ray cast; empty for none.
    pub detail: String,
    /// How this run of the pass went (e.g. "pipeline built"): printed in the log, but not part
    /// of the image's provenance, which says only what made the image.
    pub note: String,
}

impl PassRecord {
    pub fn ran(name: &str, ms: f64) -> Self {
        PassRecord {
            name: name.to_string(),
            outcome: PassOutcome::Ran { ms },
            detail: String::new(),
            note: String::new(),
        }
    }

    pub fn cached(name: &str) -> Self {
        PassRecord {
            name: name.to_string(),
            outcome: PassOutcome::Cached,
            detail: String::new(),
            note: String::new(),
        }
    }

    pub(crate) fn with_detail(mut self, detail: impl Into<String>) -> Self {
        self.detail = detail.into();
        self
    }

    pub fn is_cached(&self) -> bool {
        self.outcome == PassOutcome::Cached
    }
}

/// `pass NAME ran MS` or `pass NAME cached`, then the effects in brackets if any.
impl std::fmt::Display for PassRecord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.outcome {
            PassOutcome::Ran { ms } => write!(f, "pass {} ran {ms:.1} ms", self.name)?,
            PassOutcome::Cached => write!(f, "pass {} cached", self.name)?,
        }
        let extra: Vec<&str> = [self.detail.as_str(), self.note.as_str()]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect();
        if !extra.is_empty() {
            write!(f, " [{}]", extra.join(", "))?;
        }
        Ok(())
    }
}

/// The records of one run (or one TUI update), in the order the passes finished.
#[derive(Default)]
pub(crate) struct PassLog(Mutex<Vec<PassRecord>>);

impl PassLog {
    pub(crate) fn push(&self, record: PassRecord) {
        self.0.lock().expect("pass log poisoned").push(record);
    }

    #[cfg(test)]
    pub(crate) fn snapshot(&self) -> Vec<PassRecord> {
        self.0.lock().expect("pass log poisoned").clone()
    }

    /// The records so far, leaving the log empty for the next run.
    pub(crate) fn take(&self) -> Vec<PassRecord> {
        std::mem::take(&mut *self.0.lock().expect("pass log poisoned"))
    }

    /// How many times the pass `name` actually ran (cache hits not counted).
    #[cfg(test)]
    pub(crate) fn ran_count(&self, name: &str) -> usize {
        count_ran(&self.snapshot(), name)
    }
}

/// How many records in `records` say the pass `name` ran.
pub fn count_ran(records: &[PassRecord], name: &str) -> usize {
    records
        .iter()
        .filter(|r| r.name == name && !r.is_cached())
        .count()
}

/// Records as the image's `passes` metadata: `raycast [jitter]; tonemap [aces]`. Times, cache
/// hits and notes are left out, so the same work writes the same file bytes on every run.
pub fn describe(records: &[PassRecord]) -> String {
    records
        .iter()
        .map(|r| match r.detail.as_str() {
            "" => r.name.clone(),
            detail => format!("{} [{detail}]", r.name),
        })
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_print_in_the_documented_form() {
        assert_eq!(
            PassRecord::ran("raycast", 12.345).to_string(),
            "pass raycast ran 12.3 ms"
        );
        assert_eq!(
            PassRecord::cached("upload").to_string(),
            "pass upload cached"
        );
        assert_eq!(
            PassRecord::ran("raycast", 1.0)
                .with_detail("shading")
                .to_string(),
            "pass raycast ran 1.0 ms [shading]"
        );
        let log = PassLog::default();
        log.push(PassRecord::cached("upload"));
        log.push(PassRecord::ran("raycast", 2.0));
        assert_eq!(log.ran_count("raycast"), 1);
        assert_eq!(log.ran_count("upload"), 0);
        let mut built = PassRecord::ran("raycast", 3.0).with_detail("jitter");
        built.note = "pipeline built".into();
        assert_eq!(
            built.to_string(),
            "pass raycast ran 3.0 ms [jitter, pipeline built]"
        );
        log.push(built);
        assert_eq!(describe(&log.take()), "upload; raycast; raycast [jitter]");
        assert!(log.snapshot().is_empty());
    }
}
