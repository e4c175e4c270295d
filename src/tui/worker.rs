//! The slow work, off the UI thread. The render worker re-runs the script (one
//! [`RenderSession`] for the whole TUI session, so loaded data, uploads, renders and the GPU
//! stay in its result cache and only the passes a change touches run again) first at
//! `preview_scale` 0.25 when the script reads it, then at full resolution, skipping the full run
//! when a newer request is already waiting. The view worker turns the HDR image into what the
//! terminal shows (downsample, tone-map, encode for the protocol, histogram). Both keep only the
//! newest request: keys pressed while a job runs coalesce into one job.

use crate::error::{Error, Result};
use crate::io::terminal::srgb8_picture;
use crate::model::HdrImage;
use crate::render::passes::{PassOutcome, PassRecord};
use crate::render::session::RenderSession;
use crate::script::{run_script_file, ParamRecord, ScriptOptions};
use crate::tui::histogram::LogHistogram;
use crate::tui::protocol::Display;
use crate::tui::view::{display_image, resample, ViewSettings};
use ratatui::layout::Rect;
use ratatui_image::protocol::Protocol;
use std::path::PathBuf;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;
use std::time::Instant;

/// The parameter the TUI sets for the quick low-resolution render (then 1 for the full one).
pub(crate) const PREVIEW_SCALE: &str = "preview_scale";
/// Scale of the quick first render.
pub(crate) const LOW_RES_SCALE: f64 = 0.25;

/// What a script run gave the TUI.
#[derive(Clone, Debug)]
pub(crate) struct Scene {
    pub image: Arc<HdrImage>,
    pub params: Vec<ParamRecord>,
    /// The passes of the run: what ran and what came from the session's cache.
    pub passes: Vec<PassRecord>,
}

/// Passes for the status line: `raycast 41 ms`, cached ones as `load (cached)`.
pub(crate) fn pass_summary(passes: &[PassRecord]) -> Vec<String> {
    passes
        .iter()
        .map(|p| match p.outcome {
            PassOutcome::Ran { ms } => format!("{} {ms:.0} ms", p.name),
            PassOutcome::Cached => format!("{} (cached)", p.name),
        })
        .collect()
}

/// The adapter's name and backend, e.g. `llvmpipe (Vulkan)`, once a run has started the GPU.
pub(crate) fn adapter_of(session: &RenderSession) -> Option<String> {
    let ctx = session.context().ok()?;
    let full = ctx.describe();
    let name = full.split(" (").next().unwrap_or(&full).to_string();
    Some(format!("{name} ({})", ctx.backend_name()))
}

/// Runs the script once with `sets` in `session` and picks the image to show: the last one
/// passed to `preview(image)`, else the last one rendered, loaded or saved.
pub(crate) fn render_scene(
    script: &std::path::Path,
    base: &ScriptOptions,
    session: &Arc<RenderSession>,
    sets: Vec<(String, String)>,
) -> Result<Scene> {
    let mut opts = base.clone();
    opts.sets = sets;
    opts.session = Some(session.clone());
    opts.capture_previews = true;
    opts.progress = false;
    let report = run_script_file(script, &opts)?;
    let image = report
        .previews
        .last()
        .cloned()
        .or(report.last_image)
        .ok_or_else(|| {
            Error::invalid(
                script.display().to_string(),
                "the script produced no image: call preview(image) on what the TUI should show",
            )
        })?;
    Ok(Scene {
        image,
        params: report.params,
        passes: report.passes,
    })
}

/// A request to re-run the script.
#[derive(Clone, Debug)]
pub(crate) struct RenderJob {
    pub id: u64,
    /// Whether to run a quick `preview_scale` = 0.25 pass first.
    pub low_res_first: bool,
    /// The `--set` pairs without `preview_scale` (the worker adds it).
    pub sets: Vec<(String, String)>,
}

/// A finished run.
#[derive(Debug)]
pub(crate) struct RenderDone {
    pub id: u64,
    /// `true` for the quick low-resolution pass.
    pub low_res: bool,
    pub outcome: std::result::Result<Scene, String>,
    pub ms: f64,
    pub adapter: Option<String>,
}

/// Starts the render worker for `script`; results arrive on the returned receiver.
pub(crate) fn spawn_render_worker(
    script: PathBuf,
    base: ScriptOptions,
    session: Arc<RenderSession>,
) -> (Sender<RenderJob>, Receiver<RenderDone>) {
    let (job_tx, job_rx) = channel::<RenderJob>();
    let (done_tx, done_rx) = channel();
    std::thread::Builder::new()
        .name("hdrvis-render".into())
        .spawn(move || {
            let mut pending: Option<RenderJob> = None;
            loop {
                let job = match pending.take() {
                    Some(j) => j,
                    None => match job_rx.recv() {
                        Ok(j) => j,
                        Err(_) => return,
                    },
                };
                let job = latest(job, &job_rx);
                let run = |scale: f64| {
                    let mut sets = job.sets.clone();
                    sets.push((PREVIEW_SCALE.to_string(), format!("{scale}")));
                    let t0 = Instant::now();
                    let outcome =
                        render_scene(&script, &base, &session, sets).map_err(|e| e.to_string());
                    (outcome, t0.elapsed().as_secs_f64() * 1e3)
                };
                if job.low_res_first {
                    let (outcome, ms) = run(LOW_RES_SCALE);
                    // A failed run, or a script that ignores preview_scale (its quick run was
                    // already the full one), ends the job here.
                    let failed = outcome
                        .as_ref()
                        .map_or(true, |s| !s.params.iter().any(|p| p.name == PREVIEW_SCALE));
                    let sent = done_tx.send(RenderDone {
                        id: job.id,
                        low_res: true,
                        outcome,
                        ms,
                        adapter: adapter_of(&session),
                    });
                    if sent.is_err() {
                        return;
                    }
                    if failed {
                        continue;
                    }
                    // A newer request makes the full-resolution run of this one pointless.
                    if let Ok(newer) = job_rx.try_recv() {
                        pending = Some(newer);
                        continue;
                    }
                }
                let (outcome, ms) = run(1.0);
                let sent = done_tx.send(RenderDone {
                    id: job.id,
                    low_res: false,
                    outcome,
                    ms,
                    adapter: adapter_of(&session),
                });
                if sent.is_err() {
                    return;
                }
            }
        })
        .expect("spawning the render thread");
    (job_tx, done_rx)
}

/// The newest job: `first` or anything queued behind it.
fn latest<T>(first: T, rx: &Receiver<T>) -> T {
    let mut job = first;
    while let Ok(newer) = rx.try_recv() {
        job = newer;
    }
    job
}

/// What the terminal shows for one HDR image and view.
pub(crate) struct Prepared {
    pub protocol: Protocol,
    pub histogram: Option<LogHistogram>,
}

/// HDR image -> resampled to the area's pixels -> tone-mapped view -> encoded for the
/// terminal, plus the log-luminance histogram of the resampled image.
pub(crate) fn prepare(
    display: &Display,
    hdr: &HdrImage,
    view: &ViewSettings,
    area: Rect,
) -> Result<Prepared> {
    let (pw, ph) = display.pixels(area);
    let small = resample(hdr, pw.max(1), ph.max(1));
    let shown = display_image(&small, view)?;
    let histogram = LogHistogram::new(
        &crate::tui::view::select_channel(&small, &view.channel)?,
        64,
    );
    let protocol = display.encode(srgb8_picture(&shown), area)?;
    Ok(Prepared {
        protocol,
        histogram,
    })
}

/// A request to show an image.
pub(crate) struct ViewJob {
    pub id: u64,
    pub hdr: Arc<HdrImage>,
    pub view: ViewSettings,
    pub area: Rect,
}

pub(crate) struct ViewDone {
    pub id: u64,
    pub outcome: std::result::Result<Prepared, String>,
    pub ms: f64,
}

/// Starts the view worker; results arrive on the returned receiver.
pub(crate) fn spawn_view_worker(display: Display) -> (Sender<ViewJob>, Receiver<ViewDone>) {
    let (job_tx, job_rx) = channel::<ViewJob>();
    let (done_tx, done_rx) = channel();
    std::thread::Builder::new()
        .name("hdrvis-view".into())
        .spawn(move || {
            while let Ok(first) = job_rx.recv() {
                let job = latest(first, &job_rx);
                let t0 = Instant::now();
                let outcome =
                    prepare(&display, &job.hdr, &job.view, job.area).map_err(|e| e.to_string());
                let done = ViewDone {
                    id: job.id,
                    outcome,
                    ms: t0.elapsed().as_secs_f64() * 1e3,
                };
                if done_tx.send(done).is_err() {
                    return;
                }
            }
        })
        .expect("spawning the view thread");
    (job_tx, done_rx)
}
