//! `hdrvis bench tui`: key press to encoded picture, measured through the same code the TUI's
//! workers run, without a terminal. The scene is `scripts/tui_demo.rhai` (embedded) with a
//! mantle volume and, for ν, the Okada surface. Scene keys (exposure, next operator, a 15° orbit
//! that re-renders, ν × 1.25 that re-runs the fringe pass) are timed on the quick
//! `preview_scale` 0.25 render in a 160 × 50 terminal; view keys (exposure, operator, false
//! colour, the local operators Reinhard and Durand, and a new image arriving) on a
//! full-resolution 768² render in 80 × 24, 160 × 50 and 240 × 70 terminals. Every case runs for
//! half blocks, sixel and kitty at 10 × 20-pixel cells, the picture area taken from the TUI's
//! own layout; medians after a warm-up. Where the view worker shows a coarse picture first
//! ([`ViewPreparer`]), the time to it and to the full picture are both reported, with the runs
//! that showed one; the budget (50 ms) holds for the first picture.

use crate::error::Result;
use crate::gpu::BackendChoice;
use crate::render::session::RenderSession;
use crate::script::ScriptOptions;
use crate::tui::app::{Action, App, Effect, Source};
use crate::tui::protocol::{Display, ProtocolChoice};
use crate::tui::scene::SceneEdit;
use crate::tui::ui::{picture_area, PictureArea as Rect};
use crate::tui::view::view_operator;
use crate::tui::worker::{render_scene, ViewPreparer};
use crate::tui::worker::{LOW_RES_SCALE, PREVIEW_SCALE};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

const DEMO: &str = include_str!("../../scripts/tui_demo.rhai");

/// One benchmark case's timings.
#[derive(Clone, Debug)]
pub struct TuiBenchRow {
    pub case: String,
    pub protocol: String,
    /// Columns and rows of the terminal.
    pub terminal: (u16, u16),
    /// Milliseconds from key to the full encoded picture, every run.
    pub runs_ms: Vec<f64>,
    /// Milliseconds from key to the first picture, every run: the coarse one where the view
    /// worker showed one, else the full one.
    pub first_ms: Vec<f64>,
    /// Runs that showed a coarse picture first.
    pub coarse_runs: usize,
    /// The budget for the first picture.
    pub budget_ms: f64,
}

impl TuiBenchRow {
    pub fn median(&self) -> f64 {
        super::median(&self.runs_ms)
    }

    /// The median time to the first picture.
    pub fn first_median(&self) -> f64 {
        super::median(&self.first_ms)
    }
}

/// The budget of every key, press to the first picture.
const BUDGET_MS: f64 = 50.0;

/// The terminal sizes (columns × rows) the view keys are timed at: a default terminal, a
/// typical full-screen one and a large one.
pub(crate) const TERMINALS: [(u16, u16); 3] = [(80, 24), (160, 50), (240, 70)];

/// The terminal the scene keys (which re-run the script) are timed in.
const SCENE_TERMINAL: (u16, u16) = (160, 50);

/// The cell size in pixels assumed for sixel and kitty (ratatui-image's default; half blocks
/// show one column and two rows a cell whatever the font).
pub(crate) const CELL: (u16, u16) = (10, 20);

/// The protocols timed, in the order of the table.
const PROTOCOLS: [ProtocolChoice; 3] = [
    ProtocolChoice::Halfblocks,
    ProtocolChoice::Sixel,
    ProtocolChoice::Kitty,
];

/// Runs every case `runs` times (after one warm-up) for each protocol: the scene keys at
/// [`SCENE_TERMINAL`], the view keys on a full-resolution render at every size of [`TERMINALS`].
pub fn bench_tui(
    backend: BackendChoice,
    n: usize,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<(String, Vec<TuiBenchRow>)> {
    // As the TUI runs.
    crate::tui::worker::keep_freed_memory();
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
    let bench = Bench {
        script: &script,
        base: &base,
        session: &session,
        dir: dir.path(),
        n,
        runs,
    };
    let mut rows = Vec::new();
    for protocol in PROTOCOLS {
        rows.extend(bench.scene_keys(protocol, log)?);
    }
    rows.extend(bench.full_size_views(log)?);
    let adapter = crate::tui::worker::adapter_of(&session).unwrap_or_default();
    Ok((adapter, rows))
}

/// What every case shares: the demo script, its session and the run counts.
struct Bench<'a> {
    script: &'a Path,
    base: &'a ScriptOptions,
    session: &'a Arc<RenderSession>,
    dir: &'a Path,
    n: usize,
    runs: usize,
}

impl Bench<'_> {
    /// Exposure, operator and orbit on the volume scene, ν on the surface scene, at the quick
    /// preview scale the TUI shows first.
    fn scene_keys(
        &self,
        protocol: ProtocolChoice,
        log: &mut dyn FnMut(&str),
    ) -> Result<Vec<TuiBenchRow>> {
        let display = Display::fixed(protocol, CELL);
        let area = picture_area(SCENE_TERMINAL.0, SCENE_TERMINAL.1);
        let n = self.n.to_string();
        let mut rows = Vec::new();
        for (scene, sets) in [
            ("volume", vec![("n".to_string(), n.clone())]),
            (
                "surface",
                vec![
                    ("scene".to_string(), "surface".to_string()),
                    ("n".to_string(), n),
                ],
            ),
        ] {
            let mut app = App::new(Source::Script(self.script.into()), self.dir.into(), sets);
            log(&format!(
                "{}: first {scene} run (data generation or cache read)",
                display.note
            ));
            let first = self.preview(&app)?;
            app.set_params(first.params);
            app.hdr = Some(first.image);
            let cases: &[(&str, Action)] = if scene == "volume" {
                &[
                    ("exposure +0.5 EV", Action::ExposureUp),
                    ("next operator", Action::NextOperator),
                    ("camera orbit 15°", Action::OrbitRight),
                ]
            } else {
                &[("nu x1.25", Action::NuUp)]
            };
            let mut preparer = ViewPreparer::default();
            for &(case, action) in cases {
                let times =
                    self.time(&mut app, Key::Press(action), &display, area, &mut preparer)?;
                rows.push(self.row(
                    format!("{case} ({scene} {}, preview)", size_label(scene, self.n)),
                    &display,
                    SCENE_TERMINAL,
                    times,
                    log,
                ));
            }
        }
        Ok(rows)
    }

    /// Exposure, operator and false colour on the full-resolution image the TUI holds after its
    /// full pass ([`FULL_SIZE`]²), at every terminal size and protocol: the image is downsampled
    /// once to what the picture shows and then only tone-mapped and encoded.
    fn full_size_views(&self, log: &mut dyn FnMut(&str)) -> Result<Vec<TuiBenchRow>> {
        let sets = vec![
            ("n".to_string(), self.n.to_string()),
            ("size".to_string(), FULL_SIZE.to_string()),
        ];
        let mut app = App::new(Source::Script(self.script.into()), self.dir.into(), sets);
        log(&format!(
            "full-size {FULL_SIZE}² render of the {}³ volume",
            self.n
        ));
        let mut full = app.script_sets();
        full.push((PREVIEW_SCALE.into(), "1".into()));
        let scene = render_scene(
            self.script,
            self.base,
            self.session,
            full,
            &SceneEdit::default(),
        )?;
        app.hdr = Some(scene.scene.image);
        let mut rows = Vec::new();
        for terminal in TERMINALS {
            let area = picture_area(terminal.0, terminal.1);
            for protocol in PROTOCOLS {
                let display = Display::fixed(protocol, CELL);
                let mut preparer = ViewPreparer::default();
                for (case, key) in [
                    ("image arrives", Key::NewImage),
                    ("exposure +0.5 EV", Key::Press(Action::ExposureUp)),
                    ("next operator", Key::Press(Action::NextOperator)),
                    ("reinhard local", Key::Operator("reinhard-local")),
                    ("durand", Key::Operator("durand")),
                    ("false colour", Key::Press(Action::ToggleFalseColour)),
                ] {
                    let times = self.time(&mut app, key, &display, area, &mut preparer)?;
                    rows.push(self.row(
                        format!("{case} (render {FULL_SIZE}²)"),
                        &display,
                        terminal,
                        times,
                        log,
                    ));
                }
            }
        }
        Ok(rows)
    }

    /// `runs` timings (after a warm-up) of `key` to the encoded pictures, as the TUI's workers
    /// do it: a re-render at the preview scale where the key needs one, then the view worker's
    /// coarse picture where it shows one, and its full one. The view settings are restored
    /// after each run so every run does the same work (the camera keeps turning).
    fn time(
        &self,
        app: &mut App,
        key: Key,
        display: &Display,
        area: Rect,
        preparer: &mut ViewPreparer,
    ) -> Result<Timings> {
        let mut times = Timings::default();
        for i in 0..=self.runs {
            let before = app.view.clone();
            let t0 = Instant::now();
            match key {
                Key::Press(action) => {
                    if app.apply(action) == Effect::Rerender {
                        app.hdr = Some(self.preview(app)?.image);
                    }
                }
                Key::NewImage => preparer.forget_images(),
                Key::Operator(name) => {
                    app.view.operator = view_operator(name).expect("a view operator")
                }
            }
            let hdr = app.hdr.clone().expect("a first run gave an image");
            let coarse = preparer
                .coarse(display, &hdr, &app.view, area)
                .transpose()?;
            let coarse_ms = t0.elapsed().as_secs_f64() * 1e3;
            let showed_coarse = std::hint::black_box(coarse.map(|p| p.protocol)).is_some();
            let p = preparer.full(display, &hdr, &app.view, area)?;
            std::hint::black_box(&p.protocol);
            if i > 0 {
                let full_ms = t0.elapsed().as_secs_f64() * 1e3;
                times.full.push(full_ms);
                times
                    .first
                    .push(if showed_coarse { coarse_ms } else { full_ms });
                times.coarse_runs += usize::from(showed_coarse);
            }
            app.view = before;
        }
        Ok(times)
    }

    /// One run at the preview scale, as the TUI's quick pass.
    fn preview(&self, app: &App) -> Result<crate::tui::worker::Scene> {
        let mut sets = app.script_sets();
        sets.push((PREVIEW_SCALE.into(), format!("{LOW_RES_SCALE}")));
        Ok(render_scene(
            self.script,
            self.base,
            self.session,
            sets,
            &SceneEdit::default(),
        )?
        .scene)
    }

    /// A table row, logged as it is made.
    fn row(
        &self,
        case: String,
        display: &Display,
        terminal: (u16, u16),
        times: Timings,
        log: &mut dyn FnMut(&str),
    ) -> TuiBenchRow {
        let row = TuiBenchRow {
            case,
            protocol: display.note.clone(),
            terminal,
            runs_ms: times.full,
            first_ms: times.first,
            coarse_runs: times.coarse_runs,
            budget_ms: BUDGET_MS,
        };
        log(&format!(
            "{}x{} {}: {} median {:.1} ms (first picture {:.1} ms)",
            terminal.0,
            terminal.1,
            row.protocol,
            row.case,
            row.median(),
            row.first_median()
        ));
        row
    }
}

/// One case's milliseconds per run, to the first picture and to the full one, and how many
/// runs showed a coarse picture first.
#[derive(Default)]
struct Timings {
    first: Vec<f64>,
    full: Vec<f64>,
    coarse_runs: usize,
}

/// What a timed case does before the picture is prepared.
#[derive(Clone, Copy)]
enum Key {
    /// A key the TUI maps to this action.
    Press(Action),
    /// A new image to show (the full pass arriving): downsampled afresh.
    NewImage,
    /// The view switched to this operator of [`crate::tui::view::VIEW_OPERATORS`] (as `o` pressed until it shows).
    Operator(&'static str),
}

/// Side of the full-resolution render whose view keys are timed (a 768² image, the size of the
/// EXR pictures users open).
pub(crate) const FULL_SIZE: u32 = 768;

fn size_label(scene: &str, n: usize) -> String {
    if scene == "volume" {
        format!("{n}³")
    } else {
        format!("{}²", 2 * n + 1)
    }
}

/// The table `hdrvis bench tui` prints.
pub fn format_tui_table(adapter: &str, rows: &[TuiBenchRow]) -> String {
    let mut s = format!(
        "key press -> encoded picture (adapter: {adapter}; cells {}x{} px for sixel and kitty; \
         preview renders at preview_scale {LOW_RES_SCALE}, view keys on a {FULL_SIZE}² render)\n",
        CELL.0, CELL.1
    );
    s.push_str(&format!(
        "{:<40} {:>8} {:>9} {:<11} {:>9} {:>7} {:>9} {:>7} {:>7}\n",
        "case",
        "terminal",
        "picture",
        "protocol",
        "first ms",
        "coarse",
        "full ms",
        "budget",
        "within"
    ));
    for r in rows {
        let area = picture_area(r.terminal.0, r.terminal.1);
        s.push_str(&format!(
            "{:<40} {:>8} {:>9} {:<11} {:>9.1} {:>7} {:>9.1} {:>7.0} {:>7}\n",
            r.case,
            format!("{}x{}", r.terminal.0, r.terminal.1),
            format!("{}x{}", area.width, area.height),
            r.protocol,
            r.first_median(),
            format!("{}/{}", r.coarse_runs, r.runs_ms.len()),
            r.median(),
            r.budget_ms,
            if r.first_median() <= r.budget_ms {
                "yes"
            } else {
                "NO"
            }
        ));
    }
    s
}
