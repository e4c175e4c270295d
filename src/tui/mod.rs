//! The terminal front end, `hdrvis tui SCRIPT.rhai | IMAGE.exr`: the only user of ratatui,
//! crossterm and ratatui-image. `app` holds the state and the keys, `ui` draws it,
//! `view` turns the HDR image into the display image, `worker` runs scripts and encodes
//! pictures off the UI thread, `protocol` finds how the terminal shows pictures (`sixel` writes
//! sixel pictures from a palette found at the image's own size), `terminal`
//! guarantees the terminal is restored, `decode` (test code) reads sixel/kitty payloads back,
//! and [`crate::bench::tui`] times key press to updated preview. One-shot inline pictures
//! (`hdrvis run --preview`) are the io layer's ([`crate::io::terminal`]). The event loop here
//! polls input every 15 ms and never waits on a render; what keys and worker replies do to the
//! state is `App`'s.

pub(crate) mod app;
#[cfg(test)]
mod decode;
pub(crate) mod histogram;
pub(crate) mod keys;
pub(crate) mod protocol;
pub(crate) mod scene;
mod sixel;
pub(crate) mod terminal;
pub(crate) mod ui;
pub(crate) mod view;
pub(crate) mod worker;

use crate::error::{Error, Result};
use crate::gpu::BackendChoice;
use crate::render::session::RenderSession;
use crate::script::ScriptOptions;
use app::{App, Effect, FollowUp, Source};
use protocol::Picture;
use protocol::ProtocolChoice;
use ratatui::crossterm::event::{self, Event, KeyEventKind};
use ratatui::layout::Rect;
use ratatui_image::picker::ProtocolType;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime};

/// Everything `hdrvis tui` needs.
#[derive(Clone, Debug)]
pub struct TuiOptions {
    /// A `.rhai` script (the scene and its parameters) or an OpenEXR image.
    pub input: PathBuf,
    /// Where saved views (and the script's own outputs) go.
    pub out_dir: PathBuf,
    pub sets: Vec<(String, String)>,
    pub allowed_paths: Vec<PathBuf>,
    pub backend: BackendChoice,
    pub protocol: ProtocolChoice,
    /// Result-cache budget of the session, MiB.
    pub cache_mib: u64,
}

/// The input's kind by extension: `.exr` is an image, anything else a script.
pub(crate) fn source_of(path: &Path) -> Source {
    if crate::datasets::Format::from_extension(path) == Some(crate::datasets::Format::Exr) {
        Source::Image(path.to_path_buf())
    } else {
        Source::Script(path.to_path_buf())
    }
}

/// Runs the TUI until `q`, Ctrl-C or a signal. Errors before the screen is taken (missing file,
/// unreadable image, no terminal) are returned; script errors are shown inside the TUI.
pub fn run_tui(opts: &TuiOptions) -> Result<()> {
    crate::io::check_regular_file(&opts.input)?;
    let source = source_of(&opts.input);
    let first_image = match &source {
        Source::Image(p) => Some(Arc::new(crate::io::exr::read_exr(p)?)),
        Source::Script(_) => None,
    };
    protocol::prepare_environment();
    worker::keep_freed_memory();
    let mut guard = terminal::TerminalGuard::enter()?;
    let display = protocol::detect(opts.protocol);
    if display.kitty_direct || display.picker.protocol_type() == ProtocolType::Kitty {
        terminal::note_kitty_images();
    }
    let finished = Arc::new(AtomicBool::new(false));
    let (signal_tx, signal_rx) = channel();
    terminal::watch_signals(signal_tx, finished.clone())?;
    let result = event_loop(&mut guard, opts, source, first_image, display, signal_rx);
    finished.store(true, Ordering::SeqCst);
    drop(guard);
    result
}

/// A finished save: the EXR and PNG written, or the error.
type SaveResult = std::result::Result<(PathBuf, PathBuf), String>;

/// The event loop: the [`App`] state, the screen, the picture on it and the channels to the
/// workers. Keys and worker replies change the state ([`App::on_key`], [`App::on_render_done`],
/// …); this only carries out what they ask for.
struct EventLoop<'a> {
    guard: &'a mut terminal::TerminalGuard,
    app: App,
    /// `None` for an image file: nothing to render.
    render: Option<(Sender<worker::RenderJob>, Receiver<worker::RenderDone>)>,
    view: (Sender<worker::ViewJob>, Receiver<worker::ViewDone>),
    saves: (Sender<SaveResult>, Receiver<SaveResult>),
    picture: Option<Picture>,
    /// A directly placed kitty picture has to be written again (new picture, cleared screen).
    place_kitty: bool,
    image_area: Rect,
    /// The screen needs drawing.
    dirty: bool,
    /// Clear the screen when the picture changes ([`protocol::Display::redraw_on_change`]).
    redraw_on_change: bool,
    /// Saved views are named after the input: `<stem>_view<NNN>`.
    stem: String,
    watch: FileWatch,
}

/// Polls the input file's modification time every half second.
struct FileWatch {
    path: PathBuf,
    mtime: Option<SystemTime>,
    checked: Instant,
}

impl FileWatch {
    fn new(path: &Path) -> FileWatch {
        FileWatch {
            path: path.to_path_buf(),
            mtime: modified(path),
            checked: Instant::now(),
        }
    }

    /// Whether the file changed since the last look (at most every 500 ms).
    fn changed(&mut self) -> bool {
        if self.checked.elapsed() <= Duration::from_millis(500) {
            return false;
        }
        self.checked = Instant::now();
        let now = modified(&self.path);
        if now == self.mtime {
            return false;
        }
        self.mtime = now;
        true
    }
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

fn terminal_error(e: std::io::Error) -> Error {
    Error::invalid("terminal", e.to_string())
}

fn event_loop(
    guard: &mut terminal::TerminalGuard,
    opts: &TuiOptions,
    source: Source,
    first_image: Option<Arc<crate::model::HdrImage>>,
    display: protocol::Display,
    signals: Receiver<i32>,
) -> Result<()> {
    let mut app = App::new(source.clone(), opts.out_dir.clone(), opts.sets.clone());
    app.protocol_note = display.note.clone();
    if let Some(img) = first_image {
        app.hdr = Some(img);
        app.status.stage = "file".into();
    }
    let redraw_on_change = display.redraw_on_change;
    let view = worker::spawn_view_worker(display);
    let render = match &source {
        Source::Script(path) => Some(spawn_render(path, opts)),
        Source::Image(_) => None,
    };
    let stem = opts
        .input
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "view".into());
    let mut tui = EventLoop {
        guard,
        app,
        render,
        view,
        saves: channel(),
        picture: None,
        place_kitty: false,
        image_area: Rect::default(),
        dirty: true,
        redraw_on_change,
        stem,
        watch: FileWatch::new(&opts.input),
    };
    let result = tui.run(&signals);
    tui.finish_render();
    result
}

/// Longest wait on quitting for a render in flight (see [`EventLoop::finish_render`]).
const FINISH_RENDER: Duration = Duration::from_secs(30);

/// The render worker for `script`, with one [`RenderSession`] for the whole TUI session.
fn spawn_render(
    script: &Path,
    opts: &TuiOptions,
) -> (Sender<worker::RenderJob>, Receiver<worker::RenderDone>) {
    let session = Arc::new(RenderSession::new(
        opts.backend,
        opts.cache_mib.saturating_mul(1 << 20),
    ));
    let mut base = ScriptOptions::new(&opts.out_dir);
    base.backend = opts.backend;
    base.allowed_paths = opts.allowed_paths.clone();
    worker::spawn_render_worker(script.to_path_buf(), base, session)
}

impl EventLoop<'_> {
    /// Lets a render in flight end before the process does: process exit unmaps the shader code
    /// that lavapipe's threads may still be running (a segfault after `q`). The worker ends once
    /// its job channel closes, dropping the GPU session on its own thread; at most
    /// [`FINISH_RENDER`].
    fn finish_render(&mut self) {
        let Some((jobs, done)) = self.render.take() else {
            return;
        };
        drop(jobs);
        let deadline = Instant::now() + FINISH_RENDER;
        while done
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .is_ok()
        {}
    }

    /// Polls input every 15 ms and never waits on a worker, until `q`, Ctrl-C or a signal.
    fn run(&mut self, signals: &Receiver<i32>) -> Result<()> {
        // Library notices (a cache entry made again, a fallback folder) would tear the screen
        // on stderr: they become the notice line instead.
        let (notice_tx, notices) = channel::<String>();
        crate::io::set_notice_sink(move |line| {
            let _ = notice_tx.send(line.to_string());
        });
        self.send_render();
        loop {
            if let Ok(line) = notices.try_recv() {
                self.app.message = line;
                self.dirty = true;
            }
            self.follow_layout()?;
            if self.dirty {
                let (app, picture) = (&self.app, self.picture.as_ref());
                self.guard
                    .terminal
                    .draw(|f| ui::draw(f, app, picture))
                    .map_err(terminal_error)?;
                self.place_kitty_picture()?;
                self.dirty = false;
            }
            if let Ok(sig) = signals.try_recv() {
                self.app.message = format!("signal {sig}: quitting");
                return Ok(());
            }
            if event::poll(Duration::from_millis(15)).map_err(terminal_error)?
                && self.on_event(event::read().map_err(terminal_error)?) == Effect::Quit
            {
                return Ok(());
            }
            self.take_replies();
            if self.watch.changed() {
                let next = self.app.reload("file changed: reloading");
                self.follow_up(next);
            }
        }
    }

    /// Writes a directly placed kitty picture at the picture area's top-left cell, replacing
    /// the one shown before (kitty before 0.28; other pictures are part of the frame).
    fn place_kitty_picture(&mut self) -> Result<()> {
        use std::io::Write;
        let Some(Picture::KittyDirect(escape)) = &self.picture else {
            return Ok(());
        };
        if !std::mem::take(&mut self.place_kitty) {
            return Ok(());
        }
        let id = protocol::KITTY_DIRECT_ID;
        let mut out = std::io::stdout().lock();
        write!(
            out,
            "\x1b_Ga=d,d=I,i={id},q=2\x1b\\\x1b[{};{}H{escape}",
            self.image_area.y + 1,
            self.image_area.x + 1
        )
        .and_then(|_| out.flush())
        .map_err(terminal_error)
    }

    /// A new picture area (first frame, resized terminal) needs a view of its own size.
    fn follow_layout(&mut self) -> Result<()> {
        let size = self.guard.terminal.size().map_err(terminal_error)?;
        let areas = ui::layout(Rect::new(0, 0, size.width, size.height));
        if areas.image != self.image_area {
            self.image_area = areas.image;
            self.send_view();
            self.dirty = true;
        }
        Ok(())
    }

    /// A key or a resize; returns the key's effect ([`Effect::Quit`] ends the loop).
    fn on_event(&mut self, event: Event) -> Effect {
        match event {
            Event::Key(key) if key.kind != KeyEventKind::Release => {
                let Some(effect) = self.app.on_key(key) else {
                    return Effect::None;
                };
                self.follow_effect(effect);
                self.dirty = true;
                effect
            }
            Event::Resize(..) => {
                // Pictures drawn by the terminal (sixel) are not cleared by a diff.
                let _ = self.guard.terminal.clear();
                self.dirty = true;
                self.place_kitty = true;
                Effect::Redraw
            }
            _ => Effect::None,
        }
    }

    /// Carries out what a key asked for.
    fn follow_effect(&mut self, effect: Effect) {
        match effect {
            Effect::Quit | Effect::None | Effect::Redraw => {}
            Effect::Redisplay => self.send_view(),
            Effect::Rerender => self.send_render(),
            Effect::Reload => {
                let next = self.app.reload("reloading");
                self.follow_up(next);
            }
            Effect::Save => self.start_save(),
        }
    }

    /// Carries out what a worker's reply or a reload asked for.
    fn follow_up(&mut self, next: FollowUp) {
        match next {
            FollowUp::Ignore => return,
            FollowUp::Redraw => {}
            FollowUp::RequestView => self.send_view(),
            FollowUp::RequestRender => self.send_render(),
            FollowUp::ShowPicture(picture) => {
                self.picture = Some(picture);
                self.place_kitty = true;
                if self.redraw_on_change {
                    let _ = self.guard.terminal.clear();
                }
            }
        }
        self.dirty = true;
    }

    /// Everything the workers sent since the last look.
    fn take_replies(&mut self) {
        while let Some(done) = self.render.as_ref().and_then(|(_, rx)| rx.try_recv().ok()) {
            let next = self.app.on_render_done(done);
            self.follow_up(next);
        }
        while let Ok(done) = self.view.1.try_recv() {
            let next = self.app.on_view_done(done);
            self.follow_up(next);
        }
        while let Ok(saved) = self.saves.1.try_recv() {
            self.app.on_saved(saved);
            self.dirty = true;
        }
    }

    /// Re-runs the script (nothing to do for an image file).
    fn send_render(&mut self) {
        if let Some((tx, _)) = &self.render {
            let _ = tx.send(self.app.render_job());
        }
    }

    fn send_view(&mut self) {
        if let Some(job) = self.app.view_job(self.image_area) {
            let _ = self.view.0.send(job);
        }
    }

    /// Saves the current view at full resolution on a thread of its own; the result comes
    /// back through `saves`.
    fn start_save(&mut self) {
        let Some(hdr) = self.app.hdr.clone() else {
            self.app.message = "nothing to save yet".into();
            return;
        };
        let (view, out, stem) = (
            self.app.view.clone(),
            self.app.out_dir.clone(),
            self.stem.clone(),
        );
        let tx = self.saves.0.clone();
        self.app.message = "saving…".into();
        std::thread::spawn(move || {
            let r = view::save_view(&hdr, &view, &out, &stem).map_err(|e| e.to_string());
            let _ = tx.send(r);
        });
    }
}
