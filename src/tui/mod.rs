//! The terminal front end, `hdrvis tui SCRIPT.rhai | IMAGE.exr`: the only user of ratatui,
//! crossterm and ratatui-image. [`app`] holds the state and the keys, [`ui`] draws it,
//! [`view`] turns the HDR image into the display image, [`worker`] runs scripts and encodes
//! pictures off the UI thread, [`protocol`] finds how the terminal shows pictures, [`terminal`]
//! guarantees the terminal is restored, [`decode`] reads sixel/kitty payloads back (for tests),
//! and [`bench`] times key press to updated preview. One-shot inline pictures
//! (`hdrvis run --preview`) are the io layer's ([`crate::io::terminal`]). The event loop here polls input every 15 ms and never waits on a render.

pub mod app;
pub mod bench;
pub mod decode;
pub mod histogram;
pub mod protocol;
pub mod terminal;
pub mod ui;
pub mod view;
pub mod worker;

/// `hdrvis run --preview` prints through the one inline printer of the io layer (the script's
/// `preview(image)` uses it too); this name keeps `tui::preview::print_inline` working.
pub use crate::io::terminal as preview;

use crate::error::{Error, Result};
use crate::gpu::BackendChoice;
use crate::render::session::RenderSession;
use crate::script::ScriptOptions;
use app::{Action, App, Effect, Source};
use protocol::ProtocolChoice;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind};
use ratatui::layout::Rect;
use ratatui_image::picker::ProtocolType;
use ratatui_image::protocol::Protocol;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver};
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
pub fn source_of(path: &Path) -> Source {
    if crate::io::extension(path) == "exr" {
        Source::Image(path.to_path_buf())
    } else {
        Source::Script(path.to_path_buf())
    }
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// Runs the TUI until `q`, Ctrl-C or a signal. Errors before the screen is taken (missing file,
/// unreadable image, no terminal) are returned; script errors are shown inside the TUI.
pub fn run_tui(opts: &TuiOptions) -> Result<()> {
    if !opts.input.is_file() {
        return Err(Error::io(
            &opts.input,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        ));
    }
    let source = source_of(&opts.input);
    let first_image = match &source {
        Source::Image(p) => Some(Arc::new(crate::io::exr::read_exr(p)?)),
        Source::Script(_) => None,
    };
    protocol::prepare_environment();
    let mut guard = terminal::TerminalGuard::enter()?;
    let display = protocol::detect(opts.protocol);
    if display.picker.protocol_type() == ProtocolType::Kitty {
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

/// Sequence numbers of requests, so stale answers are recognised.
#[derive(Default)]
struct Requests {
    next: u64,
    render_sent: u64,
    view_sent: u64,
}

impl Requests {
    fn next(&mut self) -> u64 {
        self.next += 1;
        self.next
    }
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
    let redraw_on_change = display.redraw_on_change;
    let (wake_tx, _wake_rx) = channel();
    let (view_tx, view_rx) = worker::spawn_view_worker(display, wake_tx.clone());
    let session = Arc::new(RenderSession::new(
        opts.backend,
        opts.cache_mib.saturating_mul(1 << 20),
    ));
    let mut base = ScriptOptions::new(&opts.out_dir);
    base.backend = opts.backend;
    base.allowed_paths = opts.allowed_paths.clone();
    let watched = opts.input.clone();
    let mut watched_mtime = modified(&watched);
    let mut last_watch = Instant::now();
    let mut requests = Requests::default();
    let mut picture: Option<Protocol> = None;
    let mut image_area = Rect::default();
    let (save_tx, save_rx) = channel::<std::result::Result<(PathBuf, PathBuf), String>>();
    let render = match &source {
        Source::Script(path) => {
            let (tx, rx) = worker::spawn_render_worker(
                path.clone(),
                base.clone(),
                session.clone(),
                wake_tx.clone(),
            );
            Some((tx, rx))
        }
        Source::Image(_) => None,
    };
    let send_render = |app: &mut App, requests: &mut Requests| {
        if let Some((tx, _)) = &render {
            let id = requests.next();
            requests.render_sent = id;
            app.status.busy = true;
            let _ = tx.send(worker::RenderJob {
                id,
                // Before the first run nothing is known: try the quick pass (a script that does
                // not read preview_scale just renders at full size once).
                low_res_first: app.params.is_empty() || app.has_preview_scale(),
                sets: app.script_sets(),
            });
        }
    };
    let send_view = |app: &App, requests: &mut Requests, area: Rect| {
        if let (Some(hdr), true) = (&app.hdr, area.width > 0 && area.height > 0) {
            let id = requests.next();
            requests.view_sent = id;
            let _ = view_tx.send(worker::ViewJob {
                id,
                hdr: hdr.clone(),
                view: app.view.clone(),
                area,
            });
        }
    };
    if let Some(img) = first_image {
        app.hdr = Some(img.clone());
        app.status.stage = "file".into();
    }
    send_render(&mut app, &mut requests);
    let mut dirty = true;
    let mut view_started = Instant::now();
    loop {
        let size = guard
            .terminal
            .size()
            .map_err(|e| Error::invalid("terminal", e.to_string()))?;
        let areas = ui::layout(Rect::new(0, 0, size.width, size.height));
        if areas.image != image_area {
            image_area = areas.image;
            view_started = Instant::now();
            send_view(&app, &mut requests, image_area);
            dirty = true;
        }
        if dirty {
            guard
                .terminal
                .draw(|f| ui::draw(f, &app, picture.as_ref()))
                .map_err(|e| Error::invalid("terminal", e.to_string()))?;
            dirty = false;
        }
        if let Ok(sig) = signals.try_recv() {
            app.message = format!("signal {sig}: quitting");
            return Ok(());
        }
        if event::poll(Duration::from_millis(15))
            .map_err(|e| Error::invalid("terminal", e.to_string()))?
        {
            match event::read().map_err(|e| Error::invalid("terminal", e.to_string()))? {
                Event::Key(key) if key.kind != KeyEventKind::Release => {
                    if app.show_help && matches!(key.code, KeyCode::Esc) {
                        app.show_help = false;
                        dirty = true;
                        continue;
                    }
                    let Some(action) = app::action_for_key(key) else {
                        continue;
                    };
                    if action != Action::Save {
                        app.message.clear();
                    }
                    match app.apply(action) {
                        Effect::Quit => return Ok(()),
                        Effect::None | Effect::Redraw => {}
                        Effect::Redisplay => {
                            view_started = Instant::now();
                            send_view(&app, &mut requests, image_area);
                        }
                        Effect::Rerender => send_render(&mut app, &mut requests),
                        Effect::Reload => {
                            app.message = "reloading".into();
                            reload(&mut app, &source);
                            if matches!(source, Source::Image(_)) {
                                send_view(&app, &mut requests, image_area);
                            }
                            send_render(&mut app, &mut requests);
                        }
                        Effect::Save => match &app.hdr {
                            Some(hdr) => {
                                let (hdr, view, out) =
                                    (hdr.clone(), app.view.clone(), app.out_dir.clone());
                                let stem = opts
                                    .input
                                    .file_stem()
                                    .map(|s| s.to_string_lossy().to_string())
                                    .unwrap_or_else(|| "view".into());
                                let tx = save_tx.clone();
                                app.message = "saving…".into();
                                std::thread::spawn(move || {
                                    let r = view::save_view(&hdr, &view, &out, &stem)
                                        .map_err(|e| e.to_string());
                                    let _ = tx.send(r);
                                });
                            }
                            None => app.message = "nothing to save yet".into(),
                        },
                    }
                    dirty = true;
                }
                Event::Resize(..) => {
                    // Pictures drawn by the terminal (sixel) are not cleared by a diff.
                    let _ = guard.terminal.clear();
                    dirty = true;
                }
                _ => {}
            }
        }
        if let Some((_, rx)) = &render {
            while let Ok(done) = rx.try_recv() {
                if done.id != requests.render_sent {
                    continue;
                }
                app.status.adapter = done.adapter.unwrap_or_default();
                app.status.render_ms = Some(done.ms);
                app.status.stage = if done.low_res { "preview" } else { "full" }.into();
                match done.outcome {
                    Ok(scene) => {
                        app.error = None;
                        let quick_only = done.low_res
                            && !scene.params.iter().any(|p| p.name == app::PREVIEW_SCALE);
                        app.status.busy = done.low_res && !quick_only;
                        if quick_only {
                            app.status.stage = "full".into();
                        }
                        app.hdr = Some(scene.image);
                        app.set_params(scene.params);
                        app.status.passes = worker::pass_summary(&scene.passes);
                        view_started = Instant::now();
                        send_view(&app, &mut requests, image_area);
                    }
                    Err(msg) => {
                        app.status.busy = false;
                        app.error = Some(msg);
                    }
                }
                dirty = true;
            }
        }
        while let Ok(done) = view_rx.try_recv() {
            if done.id != requests.view_sent {
                continue;
            }
            match done.outcome {
                Ok(prepared) => {
                    picture = Some(prepared.protocol);
                    app.histogram = prepared.histogram;
                    let total = view_started.elapsed().as_secs_f64() * 1e3;
                    app.status.passes.retain(|p| !p.starts_with("view "));
                    app.status.passes.push(format!(
                        "view {:.0} ms (key→picture {total:.0} ms)",
                        done.ms
                    ));
                    if redraw_on_change {
                        let _ = guard.terminal.clear();
                    }
                }
                Err(msg) => app.message = format!("view: {msg}"),
            }
            dirty = true;
        }
        while let Ok(saved) = save_rx.try_recv() {
            app.message = match saved {
                Ok((exr, png)) => {
                    let name = |p: &Path| {
                        p.file_name()
                            .map(|n| n.to_string_lossy().to_string())
                            .unwrap_or_default()
                    };
                    format!("saved {} + {}", name(&exr), name(&png))
                }
                Err(e) => format!("save failed: {e}"),
            };
            dirty = true;
        }
        if last_watch.elapsed() > Duration::from_millis(500) {
            last_watch = Instant::now();
            let now = modified(&watched);
            if now != watched_mtime {
                watched_mtime = now;
                app.message = "file changed: reloading".into();
                reload(&mut app, &source);
                if matches!(source, Source::Image(_)) {
                    send_view(&app, &mut requests, image_area);
                }
                send_render(&mut app, &mut requests);
                dirty = true;
            }
        }
    }
}

/// Re-reads an image file (a script is re-read by the render worker on its next run). A file
/// that fails to read keeps the last good image and shows the error.
fn reload(app: &mut App, source: &Source) {
    if let Source::Image(path) = source {
        match crate::io::exr::read_exr(path) {
            Ok(img) => {
                app.hdr = Some(Arc::new(img));
                app.error = None;
            }
            Err(e) => app.error = Some(e.to_string()),
        }
    }
}
