//! `hdrvis bench tui`: key press to updated preview, measured through the same code the TUI
//! runs, without a terminal. The scene is `scripts/tui_demo.rhai` (embedded) with a 256³
//! mantle volume and, for ν, the Okada surface on a 513² grid; the preview is the quick
//! `preview_scale` 0.25 render (96² of 384²) shown in the 48 × 21-cell picture area of an 80 × 24
//! terminal at 8 × 16-pixel cells (384 × 336 pixels), encoded as sixel and as half blocks.
//!
//! Cases: exposure +0.5 EV and the next operator (no script run: tone-map, encode), ν × 1.25
//! (script re-run in the kept session: only the fringe pass renders), and a 15° orbit (script
//! re-run: the ray cast at preview size). Then exposure, operator and false colour on the
//! full-resolution image the TUI holds after its full pass, rendered at 600² and 1200²
//! ([`FULL_SIZES`]). Each is timed from applying the key's action to the encoded picture, after
//! a warm-up, and reported as the median.

use crate::error::Result;
use crate::gpu::BackendChoice;
use crate::render::session::RenderSession;
use crate::script::ScriptOptions;
use crate::tui::app::{Action, App, Effect, Source};
use crate::tui::protocol::Display;
use crate::tui::scene::SceneEdit;
use crate::tui::worker::{prepare, render_scene};
use crate::tui::worker::{LOW_RES_SCALE, PREVIEW_SCALE};
use ratatui::layout::Rect;
use ratatui_image::picker::ProtocolType;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

const DEMO: &str = include_str!("../../scripts/tui_demo.rhai");

/// One benchmark case's timings.
#[derive(Clone, Debug)]
pub struct TuiBenchRow {
    pub case: String,
    pub protocol: String,
    /// Milliseconds from key to encoded picture, every run.
    pub runs_ms: Vec<f64>,
    /// The budget the issue sets for this case.
    pub budget_ms: f64,
}

impl TuiBenchRow {
    pub fn median(&self) -> f64 {
        super::median(&self.runs_ms)
    }
}

/// Runs every case `runs` times (after one warm-up) for each protocol.
pub fn bench_tui(
    backend: BackendChoice,
    n: usize,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<(String, Vec<TuiBenchRow>)> {
    let dir = tempfile::tempdir().map_err(|e| crate::Error::io(std::env::temp_dir(), e))?;
    let script = dir.path().join("tui_demo.rhai");
    std::fs::write(&script, DEMO).map_err(|e| crate::Error::io(&script, e))?;
    let session = Arc::new(RenderSession::new(
        backend,
        crate::render::cache::DEFAULT_BUDGET_MIB << 20,
    ));
    let mut base = ScriptOptions::new(dir.path().join("out"));
    base.backend = backend;
    base.progress = false;
    let area = Rect::new(1, 1, 48, 21);
    let mut rows = Vec::new();
    for protocol in [ProtocolType::Sixel, ProtocolType::Halfblocks] {
        let display = Display::fixed(protocol, (8, 16));
        let pname = display.note.clone();
        for (scene, sets) in [
            ("volume", vec![("n".to_string(), n.to_string())]),
            (
                "surface",
                vec![
                    ("scene".to_string(), "surface".to_string()),
                    ("n".to_string(), n.to_string()),
                ],
            ),
        ] {
            let mut app = App::new(Source::Script(script.clone()), dir.path().into(), sets);
            log(&format!(
                "{pname}: first {scene} run (data generation or cache read)"
            ));
            let first = run(&script, &base, &session, &app)?;
            app.set_params(first.params);
            app.hdr = Some(first.image);
            let cases: &[(&str, Action, f64)] = if scene == "volume" {
                &[
                    ("exposure +0.5 EV", Action::ExposureUp, 100.0),
                    ("next operator", Action::NextOperator, 100.0),
                    ("camera orbit 15°", Action::OrbitRight, 500.0),
                ]
            } else {
                &[("nu x1.25", Action::NuUp, 100.0)]
            };
            for &(case, action, budget) in cases {
                let mut times = Vec::new();
                for i in 0..=runs {
                    let t0 = Instant::now();
                    let effect = app.apply(action);
                    if effect == Effect::Rerender {
                        let s = run(&script, &base, &session, &app)?;
                        app.hdr = Some(s.image);
                    }
                    let hdr = app.hdr.clone().expect("a first run gave an image");
                    let p = prepare(&display, &hdr, &app.view, area)?;
                    std::hint::black_box(&p.protocol);
                    if i > 0 {
                        times.push(t0.elapsed().as_secs_f64() * 1e3);
                    }
                    // Cycling through every operator would time different work per run.
                    if action == Action::NextOperator {
                        app.view.operator = 1;
                    }
                }
                let row = TuiBenchRow {
                    case: format!("{case} ({scene} {})", size_label(scene, n)),
                    protocol: pname.clone(),
                    runs_ms: times,
                    budget_ms: budget,
                };
                log(&format!(
                    "{}: {} median {:.1} ms",
                    row.protocol,
                    row.case,
                    row.median()
                ));
                rows.push(row);
            }
        }
    }
    rows.extend(bench_full_size_views(
        &script,
        &base,
        &session,
        dir.path(),
        n,
        runs,
        log,
    )?);
    let adapter = crate::tui::worker::adapter_of(&session).unwrap_or_default();
    Ok((adapter, rows))
}

/// Side lengths of the full-size renders whose view keys are timed: the 600² and a
/// larger one.
pub const FULL_SIZES: [u32; 2] = [600, 1200];

/// The view keys (exposure, operator, false colour) on the full-resolution HDR image the TUI
/// holds after its full pass, at each of [`FULL_SIZES`]: the image is downsampled to the
/// picture's pixels first and tone-mapped there; only saving touches every pixel.
fn bench_full_size_views(
    script: &Path,
    base: &ScriptOptions,
    session: &Arc<RenderSession>,
    dir: &Path,
    n: usize,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<TuiBenchRow>> {
    let area = Rect::new(1, 1, 48, 21);
    let mut rows = Vec::new();
    for size in FULL_SIZES {
        let sets = vec![
            ("n".to_string(), n.to_string()),
            ("size".to_string(), size.to_string()),
        ];
        let mut app = App::new(Source::Script(script.into()), dir.into(), sets);
        log(&format!("full-size {size}² render of the {n}³ volume"));
        let mut full = app.script_sets();
        full.push((PREVIEW_SCALE.into(), "1".into()));
        let scene = render_scene(script, base, session, full, &SceneEdit::default())?.scene;
        app.hdr = Some(scene.image);
        for protocol in [ProtocolType::Sixel, ProtocolType::Halfblocks] {
            let display = Display::fixed(protocol, (8, 16));
            for (case, action) in [
                ("exposure +0.5 EV", Action::ExposureUp),
                ("next operator", Action::NextOperator),
                ("false colour", Action::ToggleFalseColour),
            ] {
                let mut times = Vec::new();
                for i in 0..=runs {
                    let t0 = Instant::now();
                    app.apply(action);
                    let hdr = app.hdr.clone().expect("rendered above");
                    let p = prepare(&display, &hdr, &app.view, area)?;
                    std::hint::black_box(&p.protocol);
                    if i > 0 {
                        times.push(t0.elapsed().as_secs_f64() * 1e3);
                    }
                    // Every run times the same work: operator 1 (linear), false colour on.
                    app.view.operator = 0;
                    app.view.false_colour = false;
                    app.view.exposure_ev = 0.0;
                }
                let row = TuiBenchRow {
                    case: format!("{case} (render {size}²)"),
                    protocol: display.note.clone(),
                    runs_ms: times,
                    budget_ms: 100.0,
                };
                log(&format!(
                    "{}: {} median {:.1} ms",
                    row.protocol,
                    row.case,
                    row.median()
                ));
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

fn size_label(scene: &str, n: usize) -> String {
    if scene == "volume" {
        format!("{n}³")
    } else {
        format!("{}²", 2 * n + 1)
    }
}

/// One run at the preview scale, as the TUI's quick pass.
fn run(
    script: &Path,
    base: &ScriptOptions,
    session: &Arc<RenderSession>,
    app: &App,
) -> Result<crate::tui::worker::Scene> {
    let mut sets = app.script_sets();
    sets.push((PREVIEW_SCALE.into(), format!("{LOW_RES_SCALE}")));
    Ok(render_scene(script, base, session, sets, &SceneEdit::default())?.scene)
}

/// The table `hdrvis bench tui` prints.
pub fn format_tui_table(adapter: &str, rows: &[TuiBenchRow]) -> String {
    let mut s = format!(
        "key press -> updated preview (adapter: {adapter}; picture 48x21 cells, 384x336 px; preview render 96x96, full renders as named)\n"
    );
    s.push_str(&format!(
        "{:<44} {:<11} {:>10} {:>8} {:>8}\n",
        "case", "protocol", "median ms", "budget", "within"
    ));
    for r in rows {
        s.push_str(&format!(
            "{:<44} {:<11} {:>10.1} {:>8.0} {:>8}\n",
            r.case,
            r.protocol,
            r.median(),
            r.budget_ms,
            if r.median() <= r.budget_ms {
                "yes"
            } else {
                "NO"
            }
        ));
    }
    s
}
