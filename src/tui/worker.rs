//! The slow work, off the UI thread. The render worker re-runs the script (one
//! [`RenderSession`] for the whole TUI session, so loaded data, uploads, renders and the GPU
//! stay in its result cache and only the passes a change touches run again) first at
//! `preview_scale` 0.25 when the script reads it, then at full resolution, skipping the full run
//! when a newer request is already waiting. A job that changes no script parameter only renders
//! the last full run's last render (volume or surface) again with the keys' [`SceneEdit`]. Script runs here never
//! write the script's outputs and capture its prints. The view worker turns the HDR image into
//! what the terminal shows (downsample, tone-map, encode for the protocol, histogram). Both keep
//! only the newest request: keys pressed while a job runs coalesce into one job.

use crate::error::{Error, Result};
use crate::io::terminal::srgb8_picture;
use crate::model::HdrImage;
use crate::render::passes::{PassOutcome, PassRecord};
use crate::render::session::RenderSession;
use crate::script::{run_script_file, LastRender, ParamRecord, ScriptOptions};
use crate::tui::histogram::LogHistogram;
use crate::tui::protocol::{Display, Picture};
use crate::tui::scene::{SceneEdit, SceneKeys};
use crate::tui::view::{
    display_image, fit_within, resample, select_channel, Channel, ViewSettings,
};
use ratatui::layout::Rect;
use std::path::PathBuf;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;
use std::time::Instant;

/// The parameter the TUI sets for the quick low-resolution render (then 1 for the full one).
pub(crate) const PREVIEW_SCALE: &str = "preview_scale";
/// Scale of the quick first render.
pub(crate) const LOW_RES_SCALE: f64 = 0.25;

/// What a script run (or a re-render of its last render) gave the TUI.
#[derive(Clone, Debug)]
pub(crate) struct Scene {
    pub image: Arc<HdrImage>,
    pub params: Vec<ParamRecord>,
    /// The passes of the run: what ran and what came from the session's cache.
    pub passes: Vec<PassRecord>,
    /// What the TUI's own keys act on; `None` when the script rendered no volume or surface
    /// (then the camera, ν and mode keys need the script's `param`s).
    pub keys: Option<SceneKeys>,
    /// What the script printed, in order.
    pub printed: Vec<String>,
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

/// A script run's result with the render it ended on (to render again with the keys'
/// changes).
pub(crate) struct ScriptRun {
    pub scene: Scene,
    pub last_render: Option<LastRender>,
}

/// Runs the script once with `sets` in `session`, without writing its outputs and with its
/// prints captured, and picks the image to show: with a non-identity `edit`, the last render
/// rendered again with it; else the last image passed to `preview(image)`, else the last
/// one rendered, loaded or saved.
pub(crate) fn render_scene(
    script: &std::path::Path,
    base: &ScriptOptions,
    session: &Arc<RenderSession>,
    sets: Vec<(String, String)>,
    edit: &SceneEdit,
) -> Result<ScriptRun> {
    let mut opts = base.clone();
    opts.sets = sets;
    opts.session = Some(session.clone());
    opts.capture_previews = true;
    opts.capture_prints = true;
    opts.write_outputs = false;
    opts.progress = false;
    // A parameter change must never hang the session.
    opts.timeout = Some(crate::script::INTERACTIVE_TIMEOUT);
    let report = run_script_file(script, &opts)?;
    let mut passes = report.passes;
    let shown = report.previews.last().cloned().or(report.last_image);
    let image = match (&report.last_render, edit.is_identity()) {
        (Some(render), false) => {
            let img = rerender(session, render, edit, 1.0)?;
            passes.extend(session.log().take());
            img
        }
        _ => shown.ok_or_else(|| {
            Error::invalid(
                script.display().to_string(),
                "the script produced no image: call preview(image) on what the TUI should show",
            )
        })?,
    };
    Ok(ScriptRun {
        scene: Scene {
            params: report.params,
            passes,
            keys: report
                .last_render
                .as_ref()
                .map(|r| SceneKeys::of(r, edit, &image)),
            image,
            printed: report.printed,
        },
        last_render: report.last_render,
    })
}

/// The script's last render again with `edit`, from the session: no data reload, no script
/// run. A volume renders at `scale` times its size (at least 16 pixels a side); a surface,
/// whose data pass is cached apart from its fringe pass, at its own size.
pub(crate) fn rerender(
    session: &RenderSession,
    render: &LastRender,
    edit: &SceneEdit,
    scale: f64,
) -> Result<Arc<HdrImage>> {
    match render {
        LastRender::Volume(v) => {
            let mut o = edit.apply(v);
            if scale < 1.0 {
                let shrink = |v: u32| ((v as f64 * scale).round() as u32).max(16).min(v);
                (o.width, o.height) = (shrink(o.width), shrink(o.height));
            }
            session.render_volume(&v.source, &o)
        }
        LastRender::Surface(s) => {
            let o = edit.apply_surface(s);
            let images = s.field.render(session, &o)?;
            let first = images.first().cloned();
            first
                .map(Arc::new)
                .ok_or_else(|| Error::invalid("render_surface", "the surface render gave no image"))
        }
    }
}

/// The pixels a quick pass of `render` would save: a volume's image size; `0` for a surface,
/// which takes no quick pass.
fn quick_pass_pixels(render: &LastRender) -> u64 {
    match render {
        LastRender::Volume(v) => v.options.width as u64 * v.options.height as u64,
        LastRender::Surface(_) => 0,
    }
}

/// A request to re-run the script, or only to render its last volume render again.
#[derive(Clone, Debug)]
pub(crate) struct RenderJob {
    pub id: u64,
    /// Whether to run a quick `preview_scale` = 0.25 pass first.
    pub low_res_first: bool,
    /// The `--set` pairs without `preview_scale` (the worker adds it).
    pub sets: Vec<(String, String)>,
    /// The keys' changes to the last volume render.
    pub edit: SceneEdit,
    /// A parameter changed (or the file): the script runs again. Otherwise the last full run's
    /// volume render is rendered again with `edit`.
    pub rerun_script: bool,
}

/// A finished run.
#[derive(Debug)]
pub(crate) struct RenderDone {
    pub id: u64,
    /// `true` for the quick low-resolution pass.
    pub low_res: bool,
    /// `true` when only the last volume render ran again (no script run).
    pub rerender: bool,
    /// Whether this is the job's last reply (no full-resolution pass follows).
    pub last: bool,
    pub outcome: std::result::Result<Scene, String>,
    pub ms: f64,
    pub adapter: Option<String>,
}

/// Re-renders smaller than this many pixels skip the quick pass.
const QUICK_PASS_MIN_PIXELS: u64 = 160 * 160;

/// The render worker's state between jobs: the last full run's last render and parameters.
struct RenderWorker {
    script: PathBuf,
    base: ScriptOptions,
    session: Arc<RenderSession>,
    last_render: Option<LastRender>,
    params: Vec<ParamRecord>,
    jobs: Receiver<RenderJob>,
    done: Sender<RenderDone>,
}

impl RenderWorker {
    /// Sends one reply; `false` when the TUI has gone.
    fn send(&self, job: &RenderJob, low_res: bool, rerender: bool, last: bool, run: Timed) -> bool {
        let (outcome, ms) = run;
        self.done
            .send(RenderDone {
                id: job.id,
                low_res,
                rerender,
                last,
                outcome,
                ms,
                adapter: adapter_of(&self.session),
            })
            .is_ok()
    }

    /// Runs the script at `scale` (the quick pass at [`LOW_RES_SCALE`], the full one at 1).
    fn run_script(&mut self, job: &RenderJob, scale: f64) -> Timed {
        let mut sets = job.sets.clone();
        // A script that reads no preview_scale would refuse it (a misspelt --set).
        if crate::script::may_read_param(&self.script, PREVIEW_SCALE) {
            sets.push((PREVIEW_SCALE.to_string(), format!("{scale}")));
        }
        let t0 = Instant::now();
        let outcome = render_scene(&self.script, &self.base, &self.session, sets, &job.edit);
        let outcome = outcome.map(|run| {
            if scale == 1.0 || !reads_preview_scale(&run.scene) {
                self.last_render = run.last_render;
                self.params = run.scene.params.clone();
            }
            run.scene
        });
        (outcome.map_err(|e| e.to_string()), ms_since(t0))
    }

    /// Renders the last render again with the job's edit at `scale`.
    fn rerender(&self, job: &RenderJob, render: &LastRender, scale: f64) -> Timed {
        let t0 = Instant::now();
        self.session.log().take();
        let outcome = rerender(&self.session, render, &job.edit, scale).map(|image| Scene {
            keys: Some(SceneKeys::of(render, &job.edit, &image)),
            image,
            params: self.params.clone(),
            passes: self.session.log().take(),
            printed: Vec::new(),
        });
        (outcome.map_err(|e| e.to_string()), ms_since(t0))
    }

    /// Carries out one job; returns a newer job that pre-empted its full pass, or `Err` when
    /// the TUI has gone.
    fn handle(&mut self, job: RenderJob) -> std::result::Result<Option<RenderJob>, ()> {
        let sent = |ok: bool| if ok { Ok(()) } else { Err(()) };
        if let (false, Some(render)) = (job.rerun_script, self.last_render.clone()) {
            if quick_pass_pixels(&render) >= QUICK_PASS_MIN_PIXELS {
                let quick = self.rerender(&job, &render, LOW_RES_SCALE);
                let failed = quick.0.is_err();
                sent(self.send(&job, true, true, failed, quick))?;
                if failed {
                    return Ok(None);
                }
                if let Ok(newer) = self.jobs.try_recv() {
                    return Ok(Some(newer));
                }
            }
            let full = self.rerender(&job, &render, 1.0);
            sent(self.send(&job, false, true, true, full))?;
            return Ok(None);
        }
        if job.low_res_first {
            let quick = self.run_script(&job, LOW_RES_SCALE);
            // A failed run, or a script that ignores preview_scale (its quick run was already
            // the full one), ends the job here.
            let last = quick.0.as_ref().map_or(true, |s| !reads_preview_scale(s));
            sent(self.send(&job, true, false, last, quick))?;
            if last {
                return Ok(None);
            }
            // A newer request makes the full-resolution run of this one pointless; the kept
            // volume render is the quick run's, so the newer job must run the script.
            if let Ok(newer) = self.jobs.try_recv() {
                return Ok(Some(RenderJob {
                    rerun_script: true,
                    ..newer
                }));
            }
        }
        let full = self.run_script(&job, 1.0);
        sent(self.send(&job, false, false, true, full))?;
        Ok(None)
    }
}

/// A run's outcome and its milliseconds.
type Timed = (std::result::Result<Scene, String>, f64);

fn ms_since(t0: Instant) -> f64 {
    t0.elapsed().as_secs_f64() * 1e3
}

fn reads_preview_scale(scene: &Scene) -> bool {
    scene.params.iter().any(|p| p.name == PREVIEW_SCALE)
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
            let mut worker = RenderWorker {
                script,
                base,
                session,
                last_render: None,
                params: Vec::new(),
                jobs: job_rx,
                done: done_tx,
            };
            let mut pending: Option<RenderJob> = None;
            loop {
                let job = match pending.take() {
                    Some(j) => j,
                    None => match worker.jobs.recv() {
                        Ok(j) => j,
                        Err(_) => return,
                    },
                };
                let job = latest_render(job, &worker.jobs);
                match worker.handle(job) {
                    Ok(next) => pending = next,
                    Err(()) => return,
                }
            }
        })
        .expect("spawning the render thread");
    (job_tx, done_rx)
}

/// The newest render job, `first` or one queued behind it; it re-runs the script when any job it
/// replaces would have.
fn latest_render(first: RenderJob, rx: &Receiver<RenderJob>) -> RenderJob {
    let mut job = first;
    while let Ok(newer) = rx.try_recv() {
        let rerun_script = job.rerun_script || newer.rerun_script;
        job = RenderJob {
            rerun_script,
            ..newer
        };
    }
    job
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
    pub protocol: Picture,
    pub histogram: Option<LogHistogram>,
}

/// The last downsampled image and its histogram, kept because most keys (exposure, operator,
/// false colour) change the view of the same image at the same size: only tone mapping and
/// encoding run again.
#[derive(Default)]
pub(crate) struct Downsampled {
    source: Option<Arc<HdrImage>>,
    size: (u32, u32),
    image: Option<Arc<HdrImage>>,
    /// The log-luminance histogram of an image (as `get` gave it) in a channel.
    histogram: Option<(Arc<HdrImage>, Channel, Option<LogHistogram>)>,
}

impl Downsampled {
    /// `hdr` at `size`, resampled only when the image or the size changed.
    fn get(&mut self, hdr: &Arc<HdrImage>, size: (u32, u32)) -> Arc<HdrImage> {
        if size == (hdr.width, hdr.height) {
            return hdr.clone();
        }
        let same_source = self.source.as_ref().is_some_and(|s| Arc::ptr_eq(s, hdr));
        match &self.image {
            Some(image) if same_source && self.size == size => image.clone(),
            _ => {
                let image = Arc::new(resample(hdr, size.0, size.1));
                self.source = Some(hdr.clone());
                self.size = size;
                self.image = Some(image.clone());
                image
            }
        }
    }

    /// The histogram of `image` (from [`Downsampled::get`]) in `channel`, counted only when
    /// either changed: exposure and operator keys leave it as it is.
    fn histogram(
        &mut self,
        image: &Arc<HdrImage>,
        channel: &Channel,
    ) -> Result<Option<LogHistogram>> {
        if let Some((of, shown, histogram)) = &self.histogram {
            if Arc::ptr_eq(of, image) && shown == channel {
                return Ok(histogram.clone());
            }
        }
        let histogram = LogHistogram::new(&select_channel(image, channel)?, 64);
        self.histogram = Some((image.clone(), channel.clone(), histogram.clone()));
        Ok(histogram)
    }
}

/// Keeps freed memory in the process for the TUI's repeated work. Every key allocates and
/// frees the same few large buffers (f64 planes, the picture, its escape sequence); glibc's
/// malloc gives large freed blocks back to the kernel, and each new one then costs a page fault
/// per 4 KiB touched, which in the virtual machines we measure on costs as much as the tone
/// mapping ([performance.md](../../docs/performance.md#terminal-front-end)). Blocks up to
/// 64 MiB now come from the heap, which is trimmed only beyond 256 MiB free. Other C
/// libraries keep their own policy.
pub(crate) fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets two of glibc's malloc parameters; it is thread-safe (it takes
    // the arenas' locks) and these values are within what glibc accepts.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 64 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}

/// HDR image -> downsampled to what the picture shows ([`Display::picture_size`]) -> tone-mapped
/// view -> encoded for the terminal, plus the log-luminance histogram of the image as viewed.
pub(crate) fn prepare(
    display: &Display,
    hdr: &Arc<HdrImage>,
    view: &ViewSettings,
    area: Rect,
    downsampled: &mut Downsampled,
) -> Result<Prepared> {
    prepare_at(display, hdr, view, area, downsampled, 1)
}

/// [`prepare`] with the image tone-mapped at 1/`coarse` of its size along each axis and
/// enlarged to the same picture.
fn prepare_at(
    display: &Display,
    hdr: &Arc<HdrImage>,
    view: &ViewSettings,
    area: Rect,
    downsampled: &mut Downsampled,
    coarse: u32,
) -> Result<Prepared> {
    let size = display.picture_size(hdr.width, hdr.height, area);
    let (picture, shown, histogram) = view_picture(hdr, view, size, downsampled, coarse)?;
    let protocol = display.encode(picture, shown, area)?;
    Ok(Prepared {
        protocol,
        histogram,
    })
}

/// Views expected to take longer than this (ms) show a coarse picture first: those that would
/// come close to the 50 ms a key may take to its picture. The coarse picture delays the full
/// one by its own time (a fifth to a quarter of it), so quicker views go without.
pub(crate) const COARSE_VIEW_MS: f64 = 40.0;

/// The coarse picture tone-maps one pixel in this many along each axis.
pub(crate) const COARSE_STEP: u32 = 2;

/// The view worker's state: the downsampled images of the full and the coarse pictures, and
/// what each kind of view last cost, so that a view expected to take longer than
/// [`COARSE_VIEW_MS`] (a local operator on a large picture, or any view on a slow machine)
/// shows a coarse picture first, tone-mapped at 1/[`COARSE_STEP`] of the size along each axis,
/// and then the full one. Half blocks, which tone-map only what they show, never need it.
#[derive(Default)]
pub(crate) struct ViewPreparer {
    full: Downsampled,
    coarse: Downsampled,
    /// Milliseconds of a full view of each operator (with false colour or not) at each picture
    /// size: a running mean of the last few.
    costs: std::collections::HashMap<(usize, bool, (u32, u32)), f64>,
}

impl ViewPreparer {
    /// Forgets the downsampled images (a new image arrives), keeping the costs.
    pub(crate) fn forget_images(&mut self) {
        self.full = Downsampled::default();
        self.coarse = Downsampled::default();
    }

    /// The coarse picture of a view expected to be slow; `None` for one expected to be quick.
    /// A view not timed yet is expected slow when its operator is a local one.
    pub(crate) fn coarse(
        &mut self,
        display: &Display,
        hdr: &Arc<HdrImage>,
        view: &ViewSettings,
        area: Rect,
    ) -> Option<Result<Prepared>> {
        let size = display.picture_size(hdr.width, hdr.height, area);
        let pixels = display.shows_pixels() && size.0.min(hdr.width) >= 64 * COARSE_STEP;
        let expected = self.costs.get(&(view.operator, view.false_colour, size));
        let slow = match expected {
            Some(&ms) => ms > COARSE_VIEW_MS,
            None => matches!(view.operator_name(), "reinhard-local" | "durand"),
        };
        (pixels && slow)
            .then(|| prepare_at(display, hdr, view, area, &mut self.coarse, COARSE_STEP))
    }

    /// The full picture, its cost recorded.
    pub(crate) fn full(
        &mut self,
        display: &Display,
        hdr: &Arc<HdrImage>,
        view: &ViewSettings,
        area: Rect,
    ) -> Result<Prepared> {
        let t0 = Instant::now();
        let prepared = prepare(display, hdr, view, area, &mut self.full)?;
        let size = display.picture_size(hdr.width, hdr.height, area);
        let ms = ms_since(t0);
        // A running mean, so that one slow or quick run does not flip the choice.
        self.costs
            .entry((view.operator, view.false_colour, size))
            .and_modify(|m| *m = 0.5 * (*m + ms))
            .or_insert(ms);
        Ok(prepared)
    }
}

/// The view of `hdr` as an 8-bit sRGB picture to be shown at a size within `size` (keeping the
/// aspect), returned with that size and the log-luminance histogram of what was tone-mapped.
/// A picture smaller than the image is tone-mapped at its own size (only the pixels shown); a
/// larger one is the image tone-mapped at its own size, to be enlarged by repeating pixels
/// ([`Display::encode`]), so that a local operator's scales stay in image pixels, as
/// `hdrvis tonemap` and a saved view have them, and no more pixels are tone-mapped than the
/// image has. A `coarse` picture tone-maps 1/`coarse` of those pixels along each axis.
pub(crate) fn view_picture(
    hdr: &Arc<HdrImage>,
    view: &ViewSettings,
    size: (u32, u32),
    downsampled: &mut Downsampled,
    coarse: u32,
) -> Result<(image::RgbImage, (u32, u32), Option<LogHistogram>)> {
    let size = (size.0.max(1), size.1.max(1));
    let has_pixels = hdr.width > 0 && hdr.height > 0;
    let enlarged = has_pixels && (size.0 > hdr.width || size.1 > hdr.height);
    let (tone_size, shown) = if enlarged {
        (
            (hdr.width, hdr.height),
            fit_within(hdr.width, hdr.height, size.0, size.1),
        )
    } else {
        (size, size)
    };
    let coarse = coarse.max(1);
    let tone_size = (
        tone_size.0.div_ceil(coarse).max(1),
        tone_size.1.div_ceil(coarse).max(1),
    );
    let small = downsampled.get(hdr, tone_size);
    let picture = srgb8_picture(&display_image(&small, view)?);
    let histogram = downsampled.histogram(&small, &view.channel)?;
    Ok((picture, shown, histogram))
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
    /// A coarse first picture: the full one follows unless a newer view replaces it.
    pub coarse: bool,
}

/// Starts the view worker; results arrive on the returned receiver.
pub(crate) fn spawn_view_worker(display: Display) -> (Sender<ViewJob>, Receiver<ViewDone>) {
    let (job_tx, job_rx) = channel::<ViewJob>();
    let (done_tx, done_rx) = channel();
    std::thread::Builder::new()
        .name("hdrvis-view".into())
        .spawn(move || {
            let mut preparer = ViewPreparer::default();
            let mut pending: Option<ViewJob> = None;
            loop {
                let job = match pending.take() {
                    Some(job) => job,
                    None => match job_rx.recv() {
                        Ok(first) => latest(first, &job_rx),
                        Err(_) => return,
                    },
                };
                let (hdr, view, area) = (&job.hdr, &job.view, job.area);
                // Sends one picture; `false` when the TUI has gone.
                let send = |outcome: Result<Prepared>, t0: Instant, coarse: bool| {
                    let outcome = outcome.map_err(|e| e.to_string());
                    let ms = ms_since(t0);
                    let done = ViewDone {
                        id: job.id,
                        outcome,
                        ms,
                        coarse,
                    };
                    done_tx.send(done).is_ok()
                };
                let t0 = Instant::now();
                if let Some(outcome) = preparer.coarse(&display, hdr, view, area) {
                    if !send(outcome, t0, true) {
                        return;
                    }
                    // A newer view makes this one's full picture pointless.
                    if let Ok(newer) = job_rx.try_recv() {
                        pending = Some(latest(newer, &job_rx));
                        continue;
                    }
                }
                let t0 = Instant::now();
                if !send(preparer.full(&display, hdr, view, area), t0, false) {
                    return;
                }
            }
        })
        .expect("spawning the view thread");
    (job_tx, done_rx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tonemap::cpu::tonemap_cpu;
    use crate::tui::view::{enlarge_nearest, view_operator};

    /// A 48 × 32 image with a bright spot on a gradient, so that a local operator's result
    /// depends on its scales in pixels.
    fn spot() -> Arc<HdrImage> {
        let pixels = (0..48 * 32)
            .map(|i| {
                let (x, y) = ((i % 48) as f32, (i / 48) as f32);
                let d2 = (x - 20.0).powi(2) + (y - 12.0).powi(2);
                let v = 0.05 + x / 48.0 + 400.0 * (-d2 / 8.0).exp();
                [v, 0.8 * v, 0.6 * v, 1.0]
            })
            .collect();
        Arc::new(HdrImage::from_pixels(48, 32, pixels))
    }

    fn view_of(name: &str) -> ViewSettings {
        ViewSettings {
            operator: view_operator(name).unwrap(),
            ..ViewSettings::default()
        }
    }

    #[test]
    fn an_enlarged_view_is_the_images_own_tone_mapping_enlarged() {
        let hdr = spot();
        for name in ["reinhard-local", "durand", "reinhard"] {
            let view = view_of(name);
            // Twice the image's size: every image pixel becomes a 2 × 2 block.
            let (picture, shown, _) =
                view_picture(&hdr, &view, (96, 64), &mut Downsampled::default(), 1).unwrap();
            assert_eq!(shown, (96, 64));
            let picture = enlarge_nearest(&picture, shown.0, shown.1);
            let settings = view.tonemap_settings().unwrap().unwrap();
            let own = tonemap_cpu(&hdr, &settings).unwrap().to_srgb8();
            for (x, y, p) in picture.enumerate_pixels() {
                let expected = own[(y / 2 * 48 + x / 2) as usize];
                assert_eq!(p.0, expected, "{name} at ({x}, {y})");
            }
        }
    }

    #[test]
    fn a_smaller_view_is_tone_mapped_at_the_pictures_size() {
        let hdr = spot();
        let view = view_of("reinhard-local");
        let (picture, shown, histogram) =
            view_picture(&hdr, &view, (24, 16), &mut Downsampled::default(), 1).unwrap();
        assert_eq!(shown, (24, 16));
        let small = resample(&hdr, 24, 16);
        let settings = view.tonemap_settings().unwrap().unwrap();
        let expected = tonemap_cpu(&small, &settings).unwrap().to_srgb8();
        let got: Vec<[u8; 3]> = picture.pixels().map(|p| p.0).collect();
        assert_eq!(got, expected);
        let counted = histogram.map(|h| h.counts.iter().sum::<u64>() + h.dark_or_missing);
        assert_eq!(counted, Some(24 * 16));
    }

    #[test]
    fn slow_views_show_a_coarse_picture_of_the_same_size_first() {
        use crate::tui::protocol::ProtocolChoice;
        let hdr = Arc::new(HdrImage::from_pixels(
            256,
            160,
            (0..256 * 160)
                .map(|i| [0.01 + (i % 256) as f32, 1.0, 0.5, 1.0])
                .collect(),
        ));
        let (local, exposure) = (view_of("reinhard-local"), view_of("exposure"));
        // A coarse picture tone-maps half the pixels along each axis, for the same picture.
        let (full, shown, _) =
            view_picture(&hdr, &local, (400, 250), &mut Downsampled::default(), 1).unwrap();
        let (coarse, coarse_shown, _) =
            view_picture(&hdr, &local, (400, 250), &mut Downsampled::default(), 2).unwrap();
        assert_eq!((full.dimensions(), shown), ((256, 160), (400, 250)));
        assert_eq!((coarse.dimensions(), coarse_shown), ((128, 80), (400, 250)));
        let sixel = Display::fixed(ProtocolChoice::Sixel, (10, 20));
        let area = Rect::new(0, 0, 40, 13);
        let mut p = ViewPreparer::default();
        // Not timed yet: a local operator is expected slow, the exposure view quick.
        assert!(p.coarse(&sixel, &hdr, &local, area).is_some());
        assert!(p.coarse(&sixel, &hdr, &exposure, area).is_none());
        // Timed: the measured cost decides, as a running mean.
        let size = sixel.picture_size(256, 160, area);
        p.costs.insert((local.operator, false, size), 10.0);
        assert!(p.coarse(&sixel, &hdr, &local, area).is_none());
        p.costs
            .insert((exposure.operator, false, size), 2.0 * COARSE_VIEW_MS);
        assert!(p.coarse(&sixel, &hdr, &exposure, area).is_some());
        // A full view of a few milliseconds pulls the mean down from there.
        p.full(&sixel, &hdr, &exposure, area).unwrap();
        assert!(p.costs[&(exposure.operator, false, size)] < 2.0 * COARSE_VIEW_MS);
        // Half blocks show one colour per half cell: never a coarse picture.
        let blocks = Display::fixed(ProtocolChoice::Halfblocks, (10, 20));
        assert!(p.coarse(&blocks, &hdr, &local, area).is_none());
    }
}
