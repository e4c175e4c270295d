//! The TUI's state and what keys do to it, without a terminal: an [`App`] struct and
//! [`App::apply`] of a key's [`Action`] (the keys themselves are in [`crate::tui::keys`]), which changes the state and says what has to happen next ([`Effect`]):
//! redisplay the HDR image already held (exposure, operator, channel), render again (a script
//! parameter changed: re-run the script; else only its last render with the keys' edit),
//! save, reload or quit. The workers' replies
//! are state transitions too: [`App::on_render_done`], [`App::on_view_done`] and
//! [`App::on_saved`] drop stale replies (to a request a newer one replaced), keep the last good
//! image on errors and say what the event loop has to do next ([`FollowUp`]).
//!
//! Script contract: every `param(name, default)` the script calls is listed in the parameter
//! panel and can be stepped; these names have keys of their own: `azimuth`, `elevation` (degrees),
//! `zoom` (a factor), `nu`, `mode` (surfaces), `opacity` (decades added to the transfer
//! function's extinction), `lens_lo`, `lens_hi` (the magnification window, in data values), and
//! `preview_scale` (set by the TUI: 0.25 for the quick first render, 1 for the full one). Where
//! the script declares no such parameter, the camera, opacity and lens keys (on a volume) and the
//! camera, ν, mode and lens keys (on a surface, where the lens keys move the colour range)
//! change the TUI's own [`SceneEdit`] of the script's last render, which renders again without a
//! script run.

use crate::model::HdrImage;
use crate::model::Scale;
use crate::render::surface::FringeMode;
use crate::script::{ParamKind, ParamRecord};
use crate::tonemap::MAX_EV;
use crate::tui::histogram::LogHistogram;
use crate::tui::keys::action_for_key;
pub(crate) use crate::tui::keys::{Action, KEYS};
use crate::tui::protocol::Picture;
use crate::tui::scene::{format_number, step_window, KeyTarget, SceneEdit, SceneKeys};
use crate::tui::view::{main_parameter, Channel, ViewSettings, VIEW_OPERATORS};
use crate::tui::worker::{pass_summary, RenderDone, RenderJob, ViewDone, ViewJob, PREVIEW_SCALE};
use ratatui::crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::Rect;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Whether the camera keys act on `target`: a volume's, a surface's 3-D view's.
fn camera(target: KeyTarget) -> std::result::Result<(), &'static str> {
    match target {
        KeyTarget::Surface { camera: false, .. } => {
            Err("a map view has no camera: view \"globe\" or \"perspective\" has")
        }
        _ => Ok(()),
    }
}

/// Whether the ν keys act on `target`: a surface's fringes.
fn surface(target: KeyTarget) -> std::result::Result<(), &'static str> {
    match target {
        KeyTarget::Volume => Err("a volume render has no ν (interference fringes are on surfaces)"),
        KeyTarget::Surface { .. } => Ok(()),
    }
}

/// Whether the opacity keys act on `target`: a volume's transfer function.
fn volume(target: KeyTarget) -> std::result::Result<(), &'static str> {
    match target {
        KeyTarget::Volume => Ok(()),
        KeyTarget::Surface { .. } => Err("a surface has no opacity (a volume render has)"),
    }
}

/// Exposure step of `+` / `-`, in stops.
pub(crate) const EV_STEP: f64 = 0.5;

/// What has to happen after an action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Effect {
    /// Nothing changed (a key for a parameter the script does not have, for instance).
    None,
    /// Only the view of the HDR image changed: tone-map and encode again, no re-render.
    Redisplay,
    /// A script parameter changed: re-run the script (quick preview, then full resolution).
    Rerender,
    Save,
    Reload,
    Quit,
    /// Only the screen changed (help overlay, selection).
    Redraw,
}

/// What the event loop has to do after a worker's reply or a reload.
pub(crate) enum FollowUp {
    /// A stale reply: nothing changed, not even the screen.
    Ignore,
    /// The state changed: draw the screen again.
    Redraw,
    /// A new HDR image (or the same one re-read): request its view for the terminal.
    RequestView,
    /// The script has to run again.
    RequestRender,
    /// A new picture for the terminal: show it.
    ShowPicture(Picture),
}

impl std::fmt::Debug for FollowUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FollowUp::Ignore => write!(f, "Ignore"),
            FollowUp::Redraw => write!(f, "Redraw"),
            FollowUp::RequestView => write!(f, "RequestView"),
            FollowUp::RequestRender => write!(f, "RequestRender"),
            FollowUp::ShowPicture(_) => write!(f, "ShowPicture(..)"),
        }
    }
}

/// Sequence numbers of the requests sent to the workers: a reply whose id is not the last one
/// sent answers a request a newer one replaced.
#[derive(Clone, Debug, Default)]
struct Requests {
    last: u64,
    render: u64,
    view: u64,
}

impl Requests {
    fn next(&mut self) -> u64 {
        self.last += 1;
        self.last
    }
}

/// What the TUI shows: a script's scene or an HDR image file.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Source {
    Script(PathBuf),
    Image(PathBuf),
}

/// The last render's report for the status line.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct RenderStatus {
    pub adapter: String,
    pub render_ms: Option<f64>,
    /// Passes that ran in the last render with their times, e.g. `volume 212 ms`. The script
    /// layer's per-pass log fills this when it reports one; until then the whole run is timed.
    pub passes: Vec<String>,
    /// `preview` (quick low-resolution) or `full`.
    pub stage: String,
    pub busy: bool,
}

/// The whole state of the TUI.
#[derive(Clone, Debug)]
pub(crate) struct App {
    pub source: Source,
    pub out_dir: PathBuf,
    /// Parameters the script asked for in its last successful run.
    pub params: Vec<ParamRecord>,
    /// Values set by keys, sent to the script as `--set` overrides.
    pub overrides: BTreeMap<String, String>,
    /// Overrides given on the command line, kept under the interactive ones.
    pub base_sets: Vec<(String, String)>,
    pub selected: usize,
    pub view: ViewSettings,
    /// The last good HDR image (kept when a reload fails).
    pub hdr: Option<Arc<HdrImage>>,
    pub histogram: Option<LogHistogram>,
    pub status: RenderStatus,
    /// The last script error, multi-line with the caret; cleared by a good run.
    pub error: Option<String>,
    /// A one-line notice (saved files, protocol fallback).
    pub message: String,
    /// How images reach the terminal, e.g. `sixel` or `halfblocks (no graphics answer)`.
    pub protocol_note: String,
    pub show_help: bool,
    /// The keys' own changes to the script's last render (camera, opacity, window, ν, mode),
    /// for the quantities the script declares no `param` for.
    pub edit: SceneEdit,
    /// What those keys can act on: `None` until a run rendered a volume or a surface.
    pub keys: Option<SceneKeys>,
    /// The last line the script printed.
    pub log_line: String,
    /// A script parameter (or the file) changed since the last render job: the script has to
    /// run again, not only its last volume render.
    script_dirty: bool,
    requests: Requests,
    /// When the last view was requested: the status line reports key → picture time.
    view_requested: Instant,
    /// Key → coarse picture of the last view (ms), when it showed one first.
    view_coarse_ms: Option<f64>,
}

impl App {
    pub(crate) fn new(source: Source, out_dir: PathBuf, base_sets: Vec<(String, String)>) -> App {
        App {
            source,
            out_dir,
            params: Vec::new(),
            overrides: BTreeMap::new(),
            base_sets,
            selected: 0,
            view: ViewSettings::default(),
            hdr: None,
            histogram: None,
            status: RenderStatus::default(),
            error: None,
            message: String::new(),
            protocol_note: String::new(),
            show_help: false,
            edit: SceneEdit::default(),
            keys: None,
            log_line: String::new(),
            script_dirty: true,
            requests: Requests::default(),
            view_requested: Instant::now(),
            view_coarse_ms: None,
        }
    }

    /// The `--set` pairs of the next run: command-line ones, then the keys' overrides (the
    /// render worker adds the preview scale).
    pub(crate) fn script_sets(&self) -> Vec<(String, String)> {
        let mut sets: Vec<(String, String)> = self
            .base_sets
            .iter()
            .filter(|(k, _)| !self.overrides.contains_key(k))
            .cloned()
            .collect();
        sets.extend(self.overrides.iter().map(|(k, v)| (k.clone(), v.clone())));
        sets
    }

    /// The parameters shown in the panel (the preview scale is the TUI's own).
    pub(crate) fn panel_params(&self) -> Vec<&ParamRecord> {
        self.params
            .iter()
            .filter(|p| p.name != PREVIEW_SCALE)
            .collect()
    }

    /// Whether the script reads `preview_scale`, so a quick low-resolution run is worth doing.
    pub(crate) fn has_preview_scale(&self) -> bool {
        self.params.iter().any(|p| p.name == PREVIEW_SCALE)
    }

    /// The current value of a parameter (override, else what the script last received).
    pub(crate) fn param_value(&self, name: &str) -> Option<String> {
        self.overrides.get(name).cloned().or_else(|| {
            self.params
                .iter()
                .find(|p| p.name == name)
                .map(|p| p.value.clone())
        })
    }

    /// Takes a finished run's parameter list (values the script received).
    pub(crate) fn set_params(&mut self, params: Vec<ParamRecord>) {
        self.params = params;
        let n = self.panel_params().len();
        if self.selected >= n {
            self.selected = n.saturating_sub(1);
        }
    }

    /// Sets a script parameter's `--set` value: the next render job runs the script.
    fn set_override(&mut self, name: impl Into<String>, value: impl Into<String>) {
        self.overrides.insert(name.into(), value.into());
        self.script_dirty = true;
    }

    /// Whether the script declares `param(name, ...)`: then that parameter, not the TUI's own
    /// edit of the last render, is what the key changes.
    pub(crate) fn declares(&self, name: &str) -> bool {
        self.params.iter().any(|p| p.name == name)
    }

    /// A camera, opacity, ν or mode key: steps the script's parameter `name` with `by_param`
    /// when it declares one, else changes the TUI's edit of the last render with `by_edit` when
    /// `acts` says the key means something there (or why not).
    fn scene_key(
        &mut self,
        name: &str,
        by_param: impl Fn(f64) -> f64,
        acts: impl Fn(KeyTarget) -> std::result::Result<(), &'static str>,
        by_edit: impl Fn(&mut SceneEdit),
    ) -> Effect {
        if self.declares(name) {
            return self.step_number(name, by_param);
        }
        let Some(keys) = &self.keys else {
            self.message = format!("the script has no render and no param(\"{name}\", ...)");
            return Effect::None;
        };
        if let Err(why) = acts(keys.target) {
            self.message = why.into();
            return Effect::None;
        }
        by_edit(&mut self.edit);
        Effect::Rerender
    }

    /// Changes a numeric parameter with `f`; `Effect::None` when the script has no such
    /// parameter or it is not a number.
    fn step_number(&mut self, name: &str, f: impl Fn(f64) -> f64) -> Effect {
        let Some(record) = self.params.iter().find(|p| p.name == name) else {
            self.message = format!("the script has no param(\"{name}\", ...)");
            return Effect::None;
        };
        let kind = record.kind;
        let Some(current) = self
            .param_value(name)
            .and_then(|v| v.trim().parse::<f64>().ok())
        else {
            return Effect::None;
        };
        let next = f(current);
        let text = match kind {
            ParamKind::Int => format!("{}", next.round() as i64),
            ParamKind::Float => format_float(next),
            _ => return Effect::None,
        };
        self.set_override(name.to_string(), text);
        Effect::Rerender
    }

    /// Steps the selected panel parameter up (`dir` = 1) or down (-1) by a step that suits it.
    fn step_selected(&mut self, dir: f64) -> Effect {
        let Some(record) = self.panel_params().get(self.selected).map(|p| (*p).clone()) else {
            return Effect::None;
        };
        match record.kind {
            ParamKind::Bool => {
                let v = self.param_value(&record.name).unwrap_or_default() == "true";
                self.set_override(record.name, (!v).to_string());
                Effect::Rerender
            }
            ParamKind::Text => {
                if record.name == "mode" {
                    self.cycle_mode()
                } else {
                    self.message = format!("{} is text; set it with --set", record.name);
                    Effect::None
                }
            }
            ParamKind::Int => self.step_number(&record.name, |v| {
                if v.abs() >= 64.0 {
                    if dir > 0.0 {
                        v * 2.0
                    } else {
                        (v / 2.0).round()
                    }
                } else {
                    v + dir
                }
            }),
            ParamKind::Float => {
                let name = record.name.clone();
                match well_known_step(&name) {
                    Some(Step::Add(d)) => self.step_number(&name, |v| v + dir * d),
                    Some(Step::Mul(m)) => {
                        self.step_number(&name, |v| if dir > 0.0 { v * m } else { v / m })
                    }
                    None => self.step_number(&name, |v| {
                        if v == 0.0 {
                            dir * 0.1
                        } else {
                            v * if dir > 0.0 { 1.1 } else { 1.0 / 1.1 }
                        }
                    }),
                }
            }
        }
    }

    /// The next colour mode: the script's `mode` parameter when it declares one, else the
    /// edit's mode of the last surface render.
    fn cycle_mode(&mut self) -> Effect {
        if let Some(current) = self.param_value("mode") {
            let now = FringeMode::parse(&current).unwrap_or(FringeMode::Cyclic);
            self.set_override("mode", now.next().name());
            return Effect::Rerender;
        }
        let Some(SceneKeys {
            target: KeyTarget::Surface { mode, .. },
            ..
        }) = self.keys
        else {
            self.message = "the script has no surface render and no param(\"mode\", ...)".into();
            return Effect::None;
        };
        let next = mode.next();
        self.edit.mode = Some(next);
        self.message = format!("mode {}", next.name());
        Effect::Rerender
    }

    /// Moves the window by `shift` of its width and widens it by `grow` of its width on each
    /// side, in its scale (decades on log10 and symlog): the script's `lens_lo`/`lens_hi` when it
    /// declares them, else the TUI's edit of the last render's window (a volume's magnification
    /// window, a surface's colour range).
    fn lens(&mut self, shift: f64, grow: f64) -> Effect {
        let space = self.keys.as_ref().and_then(|v| v.lens);
        let scale = space.map_or(Scale::Linear, |s| s.scale);
        if self.declares("lens_lo") && self.declares("lens_hi") {
            let get = |n: &str| self.param_value(n).and_then(|v| v.parse::<f64>().ok());
            let (Some(lo), Some(hi)) = (get("lens_lo"), get("lens_hi")) else {
                return Effect::None;
            };
            let Some([lo, hi]) = step_window([lo, hi], scale, shift, grow) else {
                self.message = "the magnification window is at its limit".into();
                return Effect::None;
            };
            self.set_override("lens_lo", format_float(lo));
            self.set_override("lens_hi", format_float(hi));
            return Effect::Rerender;
        }
        let target = self.keys.as_ref().map(|k| k.target);
        let Some(space) = space else {
            self.message = match target {
                Some(KeyTarget::Volume) => {
                    "the transfer function has no colour table to magnify (use tf_lut)"
                }
                Some(KeyTarget::Surface { .. }) => {
                    "cyclic colours follow the phase: m for a mode with a colour range"
                }
                None => "the script has no render and no param(\"lens_lo\"/\"lens_hi\", ...)",
            }
            .into();
            return Effect::None;
        };
        let start = self.edit.lens.unwrap_or_else(|| space.start());
        let Some(window) = step_window(start, space.scale, shift, grow) else {
            self.message = "the window is at its limit".into();
            return Effect::None;
        };
        self.edit.lens = Some(window);
        let what = match target {
            Some(KeyTarget::Surface { .. }) => "colour range",
            _ => "window",
        };
        self.message = format!(
            "{what} [{}, {}]",
            format_number(window[0]),
            format_number(window[1])
        );
        Effect::Rerender
    }

    /// The effect of a key press: Esc closes the help overlay, other keys go through
    /// [`action_for_key`] and [`App::apply`]; `None` for a key bound to nothing. Every action
    /// but saving clears the last notice.
    pub(crate) fn on_key(&mut self, key: KeyEvent) -> Option<Effect> {
        if self.show_help && key.code == KeyCode::Esc {
            self.show_help = false;
            return Some(Effect::Redraw);
        }
        let action = action_for_key(key)?;
        if action != Action::Save {
            self.message.clear();
        }
        Some(self.apply(action))
    }

    /// Applies an action and says what has to follow.
    pub(crate) fn apply(&mut self, action: Action) -> Effect {
        use Action::*;
        if action.changes_scene() && !matches!(self.source, Source::Script(_)) {
            self.message = "an image file has no scene parameters".into();
            return Effect::Redraw;
        }
        match action {
            Quit => Effect::Quit,
            ExposureUp => self.set_exposure((self.view.exposure_ev + EV_STEP).min(MAX_EV)),
            ExposureDown => self.set_exposure((self.view.exposure_ev - EV_STEP).max(-MAX_EV)),
            ExposureReset => self.set_exposure(0.0),
            NextOperator => self.cycle_operator(1),
            PrevOperator => self.cycle_operator(VIEW_OPERATORS.len() - 1),
            OperatorParamUp => self.step_operator_param(1.0),
            OperatorParamDown => self.step_operator_param(-1.0),
            ToggleFalseColour => {
                self.view.false_colour = !self.view.false_colour;
                Effect::Redisplay
            }
            NextChannel => self.cycle_channel(),
            OrbitLeft => self.scene_key("azimuth", |v| v - 15.0, camera, |e| e.azimuth_deg -= 15.0),
            OrbitRight => {
                self.scene_key("azimuth", |v| v + 15.0, camera, |e| e.azimuth_deg += 15.0)
            }
            OrbitUp => self.scene_key(
                "elevation",
                |v| (v + 10.0).min(89.0),
                camera,
                |e| e.elevation_deg += 10.0,
            ),
            OrbitDown => self.scene_key(
                "elevation",
                |v| (v - 10.0).max(-89.0),
                camera,
                |e| e.elevation_deg -= 10.0,
            ),
            ZoomIn => self.scene_key("zoom", |v| v * 1.25, camera, |e| e.zoom *= 1.25),
            ZoomOut => self.scene_key("zoom", |v| v / 1.25, camera, |e| e.zoom /= 1.25),
            NuUp => self.scene_key("nu", |v| v * 1.25, surface, |e| e.nu_factor *= 1.25),
            NuDown => self.scene_key("nu", |v| v / 1.25, surface, |e| e.nu_factor /= 1.25),
            NextMode => self.cycle_mode(),
            OpacityUp => self.scene_key(
                "opacity",
                |v| v + 0.25,
                volume,
                |e| e.opacity_decades += 0.25,
            ),
            OpacityDown => self.scene_key(
                "opacity",
                |v| v - 0.25,
                volume,
                |e| e.opacity_decades -= 0.25,
            ),
            LensLeft => self.lens(-0.25, 0.0),
            LensRight => self.lens(0.25, 0.0),
            LensWider => self.lens(0.0, 0.125),
            LensNarrower => self.lens(0.0, -0.1),
            SelectNext => self.select(1),
            SelectPrev => self.select(-1),
            StepUp => self.step_selected(1.0),
            StepDown => self.step_selected(-1.0),
            Save => Effect::Save,
            Reload => Effect::Reload,
            ToggleHelp => {
                self.show_help = !self.show_help;
                Effect::Redraw
            }
        }
    }

    /// A new exposure: the picture is mapped again, unless the operator divides exposure out,
    /// where it would come back the same; the histogram's window and a saved EXR still follow
    /// the exposure.
    fn set_exposure(&mut self, ev: f64) -> Effect {
        self.view.exposure_ev = ev;
        if self.view.picture_ignores_exposure() {
            // Short enough for an 80-column status line; docs/tui.md says the rest.
            self.message = format!(
                "{} divides exposure out: same picture",
                self.view.operator_name()
            );
            return Effect::Redraw;
        }
        Effect::Redisplay
    }

    /// Moves `by` places along [`VIEW_OPERATORS`] (cyclically), back to the operator's default
    /// parameter.
    fn cycle_operator(&mut self, by: usize) -> Effect {
        self.view.operator = (self.view.operator + by) % VIEW_OPERATORS.len();
        self.view.op_param = None;
        Effect::Redisplay
    }

    /// Steps the operator's main parameter one step up (`dir` = 1) or down (-1), within its
    /// range.
    fn step_operator_param(&mut self, dir: f64) -> Effect {
        let Some((name, default, step, lo, hi)) = main_parameter(self.view.operator_name()) else {
            self.message = format!("{} has no parameter", self.view.operator_name());
            return Effect::Redraw;
        };
        let v = (self.view.op_param.unwrap_or(default) + dir * step).clamp(lo, hi);
        self.view.op_param = Some((v * 1e6).round() / 1e6);
        self.message = format!("{name} = {}", self.view.op_param.unwrap_or(default));
        Effect::Redisplay
    }

    fn cycle_channel(&mut self) -> Effect {
        let all = Channel::all(self.hdr.as_deref());
        let i = all
            .iter()
            .position(|c| *c == self.view.channel)
            .unwrap_or(0);
        self.view.channel = all[(i + 1) % all.len()].clone();
        Effect::Redisplay
    }

    /// Moves the panel's selection one parameter down (`dir` = 1) or up (-1), cyclically.
    fn select(&mut self, dir: isize) -> Effect {
        let n = self.panel_params().len().max(1);
        self.selected = if dir > 0 {
            (self.selected + 1) % n
        } else {
            (self.selected + n - 1) % n
        };
        Effect::Redraw
    }

    /// The next script run to send to the render worker: a new id (replies to older runs
    /// become stale) and the busy mark in the status line.
    pub(crate) fn render_job(&mut self) -> RenderJob {
        let id = self.requests.next();
        self.requests.render = id;
        self.status.busy = true;
        RenderJob {
            id,
            // Before the first run nothing is known: try the quick pass (a script that does
            // not read preview_scale just renders at full size once).
            low_res_first: self.params.is_empty() || self.has_preview_scale(),
            sets: self.script_sets(),
            edit: self.edit.clone(),
            rerun_script: std::mem::take(&mut self.script_dirty) || self.keys.is_none(),
        }
    }

    /// The next view to send to the view worker for the picture's `area`, timed from now;
    /// `None` without an image or with an empty area.
    pub(crate) fn view_job(&mut self, area: Rect) -> Option<ViewJob> {
        self.view_requested = Instant::now();
        self.view_coarse_ms = None;
        let hdr = self.hdr.clone()?;
        if area.width == 0 || area.height == 0 {
            return None;
        }
        let id = self.requests.next();
        self.requests.view = id;
        Some(ViewJob {
            id,
            hdr,
            view: self.view.clone(),
            area,
        })
    }

    /// A script run finished. A stale one is ignored; a good one replaces the image and the
    /// parameters (the view has to follow); a failed one shows its error over the last good
    /// image.
    pub(crate) fn on_render_done(&mut self, done: RenderDone) -> FollowUp {
        if done.id != self.requests.render {
            return FollowUp::Ignore;
        }
        self.status.adapter = done.adapter.unwrap_or_default();
        self.status.render_ms = Some(done.ms);
        self.status.stage = match (done.rerender, done.low_res && !done.last) {
            (true, true) => "preview re-render",
            (true, false) => "re-render",
            (false, true) => "preview",
            (false, false) => "full",
        }
        .into();
        self.status.busy = !done.last;
        match done.outcome {
            Ok(scene) => {
                self.error = None;
                self.hdr = Some(scene.image);
                self.set_params(scene.params);
                self.keys = scene.keys;
                if let Some(line) = scene.printed.last() {
                    self.log_line = line.clone();
                }
                self.status.passes = pass_summary(&scene.passes);
                FollowUp::RequestView
            }
            Err(msg) => {
                self.error = Some(msg);
                FollowUp::Redraw
            }
        }
    }

    /// The view worker finished. A stale picture is ignored; a current one is shown with its
    /// histogram and timing; an error is a notice (the last picture stays).
    pub(crate) fn on_view_done(&mut self, done: ViewDone) -> FollowUp {
        if done.id != self.requests.view {
            return FollowUp::Ignore;
        }
        match done.outcome {
            Ok(prepared) => {
                self.histogram = prepared.histogram;
                let total = self.view_requested.elapsed().as_secs_f64() * 1e3;
                self.status.passes.retain(|p| !p.starts_with("view "));
                self.status
                    .passes
                    .push(match (done.coarse, self.view_coarse_ms) {
                        (true, _) => {
                            format!("view coarse {:.0} ms (key→picture {total:.0} ms)", done.ms)
                        }
                        (false, Some(first)) => format!(
                            "view {:.0} ms (key→picture {first:.0} ms coarse, {total:.0} ms full)",
                            done.ms
                        ),
                        (false, None) => {
                            format!("view {:.0} ms (key→picture {total:.0} ms)", done.ms)
                        }
                    });
                if done.coarse {
                    self.view_coarse_ms = Some(total);
                }
                FollowUp::ShowPicture(prepared.protocol)
            }
            Err(msg) => {
                self.message = format!("view: {msg}");
                FollowUp::Redraw
            }
        }
    }

    /// A save finished: the notice names the two files written, or the error.
    pub(crate) fn on_saved(&mut self, saved: std::result::Result<(PathBuf, PathBuf), String>) {
        let name = |p: &Path| {
            p.file_name()
                .map(|n| n.to_string_lossy().to_string())
                .unwrap_or_default()
        };
        self.message = match saved {
            Ok((exr, png)) => format!("saved {} + {}", name(&exr), name(&png)),
            Err(e) => format!("save failed: {e}"),
        };
    }

    /// Reload (a key or a change of the file on disk), with `notice` in the status line. An
    /// image file is re-read here (one that fails to read keeps the last good image and shows
    /// the error); a script is re-read by the render worker on its next run.
    pub(crate) fn reload(&mut self, notice: &str) -> FollowUp {
        self.message = notice.into();
        match &self.source {
            Source::Image(path) => {
                match crate::io::exr::read_exr(path) {
                    Ok(img) => {
                        self.hdr = Some(Arc::new(img));
                        self.error = None;
                    }
                    Err(e) => self.error = Some(e.to_string()),
                }
                FollowUp::RequestView
            }
            Source::Script(_) => {
                self.script_dirty = true;
                FollowUp::RequestRender
            }
        }
    }
}

/// How the panel steps a well-known float parameter.
enum Step {
    Add(f64),
    Mul(f64),
}

fn well_known_step(name: &str) -> Option<Step> {
    Some(match name {
        "azimuth" => Step::Add(15.0),
        "elevation" => Step::Add(10.0),
        "zoom" | "nu" => Step::Mul(1.25),
        "opacity" => Step::Add(0.25),
        "exposure" => Step::Add(0.5),
        _ => return None,
    })
}

/// A float as `param()` parses it back: always with a decimal point, no noise digits, in
/// scientific notation (all digits kept) for magnitudes from 1e6 and below 1e-4.
fn format_float(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        return format!("{v:e}");
    }
    let rounded = (v * 1e9).round() / 1e9;
    let s = format!("{rounded}");
    if s.contains(['.', 'e', 'E']) || !rounded.is_finite() {
        s
    } else {
        format!("{s}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::protocol::Display;
    use crate::tui::protocol::ProtocolChoice;
    use crate::tui::worker::{Prepared, Scene};
    use ratatui::crossterm::event::KeyModifiers;

    fn record(name: &str, kind: ParamKind, value: &str) -> ParamRecord {
        ParamRecord {
            name: name.into(),
            kind,
            default: value.into(),
            value: value.into(),
        }
    }

    fn script_app() -> App {
        let mut app = App::new(Source::Script("s.rhai".into()), "out".into(), Vec::new());
        app.set_params(vec![
            record("azimuth", ParamKind::Float, "30.0"),
            record("elevation", ParamKind::Float, "85.0"),
            record("zoom", ParamKind::Float, "1.0"),
            record("n", ParamKind::Int, "128"),
            record("mode", ParamKind::Text, "cyclic"),
            record("lens_lo", ParamKind::Float, "0.4"),
            record("lens_hi", ParamKind::Float, "0.6"),
            record(PREVIEW_SCALE, ParamKind::Float, "1.0"),
        ]);
        app
    }

    #[test]
    fn exposure_and_operator_keys_redisplay_without_rerendering() {
        let mut app = script_app();
        assert_eq!(app.apply(Action::ExposureUp), Effect::Redisplay);
        assert_eq!(app.view.exposure_ev, 0.5);
        assert_eq!(app.apply(Action::NextOperator), Effect::Redisplay);
        assert_eq!(app.view.operator_name(), "linear");
        assert_eq!(app.apply(Action::ExposureUp), Effect::Redisplay);
        app.apply(Action::NextOperator);
        assert_eq!(app.apply(Action::OperatorParamUp), Effect::Redisplay);
        assert_eq!(app.view.op_param, Some(0.21));
        // Reinhard divides exposure out: the exposure changes, the picture is not mapped
        // again, and the status line says why; in false colour exposure moves the colours.
        assert_eq!(app.apply(Action::ExposureUp), Effect::Redraw);
        assert_eq!(app.view.exposure_ev, 1.5);
        assert!(
            app.message.contains("reinhard divides exposure out"),
            "{}",
            app.message
        );
        app.apply(Action::ToggleFalseColour);
        assert_eq!(app.apply(Action::ExposureDown), Effect::Redisplay);
        assert!(app.overrides.is_empty(), "no script parameter changed");
    }

    #[test]
    fn camera_keys_step_the_well_known_parameters() {
        let mut app = script_app();
        assert_eq!(app.apply(Action::OrbitRight), Effect::Rerender);
        assert_eq!(app.overrides["azimuth"], "45.0");
        app.apply(Action::OrbitUp);
        assert_eq!(app.overrides["elevation"], "89.0", "clamped below the pole");
        app.apply(Action::ZoomIn);
        assert_eq!(app.overrides["zoom"], "1.25");
        assert_eq!(app.apply(Action::NextMode), Effect::Rerender);
        assert_eq!(app.overrides["mode"], "modulated");
        // No `nu` parameter: nothing to do, and the user is told so.
        assert_eq!(app.apply(Action::NuUp), Effect::None);
        assert!(app.message.contains("nu"));
        app.apply(Action::LensRight);
        assert_eq!(
            (
                app.overrides["lens_lo"].as_str(),
                app.overrides["lens_hi"].as_str()
            ),
            ("0.45", "0.65")
        );
        let sets = app.script_sets();
        assert!(sets.contains(&("azimuth".into(), "45.0".into())));
        assert!(app.has_preview_scale());
        assert_eq!(app.panel_params().len(), 7);
    }

    #[test]
    fn without_params_the_keys_edit_the_last_volume_render() {
        use crate::tui::scene::LensSpace;
        let mut app = App::new(Source::Script("s.rhai".into()), "out".into(), Vec::new());
        app.set_params(vec![record("n", ParamKind::Int, "64")]);
        assert_eq!(app.apply(Action::OrbitRight), Effect::None, "no volume yet");
        app.keys = Some(SceneKeys {
            lens: Some(LensSpace {
                scale: Scale::Log10,
                scaled_domain: [10.0, 14.0],
                window: Some([1e12, 1e13]),
            }),
            target: KeyTarget::Volume,
        });
        assert_eq!(app.apply(Action::NuUp), Effect::None, "a volume has no ν");
        assert!(
            app.render_job().rerun_script,
            "the first job runs the script"
        );
        assert_eq!(app.apply(Action::OrbitRight), Effect::Rerender);
        assert_eq!(app.apply(Action::OrbitUp), Effect::Rerender);
        assert_eq!(app.apply(Action::ZoomIn), Effect::Rerender);
        assert_eq!(app.apply(Action::OpacityDown), Effect::Rerender);
        let e = &app.edit;
        assert_eq!(
            (e.azimuth_deg, e.elevation_deg, e.zoom, e.opacity_decades),
            (15.0, 10.0, 1.25, -0.25)
        );
        assert!(app.overrides.is_empty());
        let job = app.render_job();
        assert!(!job.rerun_script, "only the volume render runs again");
        assert_eq!(job.edit, app.edit);
        // `<` then `w` on the log scale: decades, never a bound at or below 0.
        app.apply(Action::LensLeft);
        app.apply(Action::LensWider);
        let [lo, hi] = app.edit.lens.unwrap();
        assert!((lo.log10() - 11.625).abs() < 1e-9 && (hi.log10() - 12.875).abs() < 1e-9);
        assert_eq!(app.message, "window [4.217e11, 7.499e12]");
        // A declared parameter changes the script's value and re-runs the script.
        app.selected = 0;
        assert_eq!(app.apply(Action::StepUp), Effect::Rerender);
        assert!(app.render_job().rerun_script);
    }

    #[test]
    fn without_params_the_keys_edit_the_last_surface_render() {
        use crate::tui::scene::LensSpace;
        let mut app = App::new(Source::Script("s.rhai".into()), "out".into(), Vec::new());
        app.set_params(vec![record("n", ParamKind::Int, "64")]);
        assert_eq!(app.apply(Action::NuUp), Effect::None, "no render yet");
        let map = |mode, lens| SceneKeys {
            lens,
            target: KeyTarget::Surface {
                mode,
                camera: false,
            },
        };
        app.keys = Some(map(FringeMode::Cyclic, None));
        app.render_job();
        assert_eq!(app.apply(Action::NuUp), Effect::Rerender);
        assert_eq!(app.apply(Action::NuUp), Effect::Rerender);
        assert_eq!(app.apply(Action::NuDown), Effect::Rerender);
        assert_eq!(app.edit.nu_factor, 1.25);
        assert_eq!(app.apply(Action::OrbitLeft), Effect::None);
        assert!(
            app.message.contains("map view has no camera"),
            "{}",
            app.message
        );
        assert_eq!(app.apply(Action::OpacityUp), Effect::None);
        assert_eq!(app.apply(Action::LensRight), Effect::None);
        assert!(app.message.starts_with("cyclic colours"), "{}", app.message);
        assert_eq!(app.apply(Action::NextMode), Effect::Rerender);
        assert_eq!(app.edit.mode, Some(FringeMode::Modulated));
        assert!(
            !app.render_job().rerun_script,
            "only the surface renders again"
        );
        // The re-render reports its colour range: the lens keys move it.
        app.keys = Some(map(
            FringeMode::Modulated,
            Some(LensSpace {
                scale: Scale::Linear,
                scaled_domain: [0.0, 8.0],
                window: Some([0.0, 8.0]),
            }),
        ));
        assert_eq!(app.apply(Action::LensRight), Effect::Rerender);
        assert_eq!(app.edit.lens, Some([2.0, 10.0]));
        assert_eq!(app.message, "colour range [2, 10]");
        app.apply(Action::NextMode);
        assert_eq!(app.edit.mode, Some(FringeMode::Direct));
        // A 3-D view turns.
        app.keys = Some(SceneKeys {
            lens: None,
            target: KeyTarget::Surface {
                mode: FringeMode::Direct,
                camera: true,
            },
        });
        assert_eq!(app.apply(Action::OrbitRight), Effect::Rerender);
        assert_eq!(app.edit.azimuth_deg, 15.0);
        // A declared mode parameter is the script's: the script runs again.
        app.set_params(vec![record("mode", ParamKind::Text, "cyclic")]);
        assert_eq!(app.apply(Action::NextMode), Effect::Rerender);
        assert_eq!(app.overrides["mode"], "modulated");
        assert!(app.render_job().rerun_script);
    }

    #[test]
    fn the_selected_parameter_steps_by_its_kind() {
        let mut app = script_app();
        app.selected = 3; // n = 128, an integer >= 64: doubles
        assert_eq!(app.apply(Action::StepUp), Effect::Rerender);
        assert_eq!(app.overrides["n"], "256");
        app.apply(Action::StepDown);
        app.apply(Action::StepDown);
        assert_eq!(app.overrides["n"], "64");
        app.apply(Action::SelectPrev);
        assert_eq!(app.selected, 2);
    }

    #[test]
    fn every_action_has_a_key_and_every_key_its_action() {
        use ratatui::crossterm::event::KeyEvent;
        for (keys, action, _) in KEYS {
            let first = keys.split(" / ").next().unwrap();
            let code = match first {
                "Left" => KeyCode::Left,
                "Right" => KeyCode::Right,
                "Up" => KeyCode::Up,
                "Down" => KeyCode::Down,
                "Tab" => KeyCode::Tab,
                "Shift-Tab" => KeyCode::BackTab,
                "PgUp" => KeyCode::PageUp,
                "PgDn" => KeyCode::PageDown,
                "+" => KeyCode::Char('+'),
                s if s.chars().count() == 1 => KeyCode::Char(s.chars().next().unwrap()),
                other => panic!("unparsed key {other}"),
            };
            assert_eq!(
                action_for_key(KeyEvent::new(code, KeyModifiers::NONE)),
                Some(*action),
                "{keys}"
            );
        }
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(action_for_key(ctrl_c), Some(Action::Quit));
    }

    #[test]
    fn an_image_file_has_no_scene_to_change() {
        let mut app = App::new(Source::Image("a.exr".into()), "out".into(), Vec::new());
        assert_eq!(app.apply(Action::OrbitLeft), Effect::Redraw);
        assert_eq!(app.apply(Action::ExposureDown), Effect::Redisplay);
        assert_eq!(format_float(2.0), "2.0");
        assert_eq!(format_float(0.1 + 0.2), "0.3");
    }

    fn scene(value: f32, params: Vec<ParamRecord>) -> Scene {
        Scene {
            image: Arc::new(HdrImage::from_pixels(1, 1, vec![[value; 4]])),
            params,
            passes: Vec::new(),
            keys: None,
            printed: Vec::new(),
        }
    }

    fn render_done(id: u64, low_res: bool, outcome: Result<Scene, String>) -> RenderDone {
        // As the worker says: a quick pass is the last one when the script ignores the scale.
        let last = !low_res
            || outcome
                .as_ref()
                .map_or(true, |s| !s.params.iter().any(|p| p.name == PREVIEW_SCALE));
        RenderDone {
            id,
            low_res,
            rerender: false,
            last,
            outcome,
            ms: 12.0,
            adapter: Some("llvmpipe (Vulkan)".into()),
        }
    }

    fn view_done(id: u64, outcome: Result<(), String>) -> ViewDone {
        let outcome = outcome.map(|()| {
            let display = Display::fixed(ProtocolChoice::Halfblocks, (8, 16));
            let area = Rect::new(0, 0, 2, 1);
            Prepared {
                protocol: display
                    .encode(image::RgbImage::new(16, 16), (16, 16), area)
                    .unwrap(),
                histogram: None,
            }
        });
        ViewDone {
            id,
            outcome,
            ms: 3.0,
            coarse: false,
        }
    }

    fn image_value(app: &App) -> Option<f32> {
        app.hdr.as_ref().map(|h| h.pixels[0][0])
    }

    #[test]
    fn a_finished_quick_render_shows_its_image_and_waits_for_the_full_one() {
        let mut app = script_app();
        let job = app.render_job();
        assert!(job.low_res_first && app.status.busy);
        assert!(job.sets.is_empty());
        let params = app.params.clone();
        let next = app.on_render_done(render_done(job.id, true, Ok(scene(0.5, params.clone()))));
        assert!(matches!(next, FollowUp::RequestView), "{next:?}");
        assert_eq!(image_value(&app), Some(0.5));
        assert_eq!(app.status.stage, "preview");
        assert!(app.status.busy, "the full-resolution run follows");
        assert_eq!(app.status.adapter, "llvmpipe (Vulkan)");
        let next = app.on_render_done(render_done(job.id, false, Ok(scene(0.7, params))));
        assert!(matches!(next, FollowUp::RequestView));
        assert_eq!(
            (app.status.stage.as_str(), app.status.busy),
            ("full", false)
        );
        assert_eq!(image_value(&app), Some(0.7));
        // The view follows the new image.
        let view = app
            .view_job(Rect::new(0, 0, 10, 5))
            .expect("an image to show");
        assert_eq!(view.hdr.pixels[0][0], 0.7);
    }

    #[test]
    fn a_quick_render_of_a_script_without_preview_scale_is_the_full_one() {
        let mut app = App::new(Source::Script("s.rhai".into()), "out".into(), Vec::new());
        let job = app.render_job();
        let params = vec![record("zoom", ParamKind::Float, "1.0")];
        app.on_render_done(render_done(job.id, true, Ok(scene(0.5, params))));
        assert_eq!(
            (app.status.stage.as_str(), app.status.busy),
            ("full", false)
        );
        assert!(!app.render_job().low_res_first, "no quick pass is worth it");
    }

    #[test]
    fn a_stale_render_reply_is_ignored() {
        let mut app = script_app();
        let old = app.render_job();
        let new = app.render_job();
        let next = app.on_render_done(render_done(old.id, false, Ok(scene(0.5, Vec::new()))));
        assert!(matches!(next, FollowUp::Ignore));
        assert!(app.hdr.is_none() && app.status.busy && app.status.render_ms.is_none());
        let next = app.on_render_done(render_done(new.id, false, Err("late".into())));
        assert!(matches!(next, FollowUp::Redraw));
    }

    #[test]
    fn a_failed_render_shows_its_error_over_the_last_image() {
        let mut app = script_app();
        let job = app.render_job();
        app.on_render_done(render_done(
            job.id,
            false,
            Ok(scene(0.5, app.params.clone())),
        ));
        let job = app.render_job();
        let error = "s.rhai:3:7: unknown function\n  bad(1)\n      ^".to_string();
        let next = app.on_render_done(render_done(job.id, false, Err(error.clone())));
        assert!(
            matches!(next, FollowUp::Redraw),
            "no new view: the old one stays"
        );
        assert_eq!(app.error.as_deref(), Some(error.as_str()));
        assert_eq!(image_value(&app), Some(0.5), "the last good image is kept");
        assert!(!app.status.busy);
        // The next good run clears the error.
        let job = app.render_job();
        app.on_render_done(render_done(
            job.id,
            false,
            Ok(scene(0.6, app.params.clone())),
        ));
        assert!(app.error.is_none());
    }

    #[test]
    fn only_the_newest_view_reaches_the_screen() {
        let mut app = script_app();
        let area = Rect::new(0, 0, 10, 5);
        assert!(app.view_job(area).is_none(), "no image yet");
        app.hdr = Some(scene(0.5, Vec::new()).image);
        assert!(app.view_job(Rect::new(0, 0, 0, 5)).is_none(), "no room");
        let old = app.view_job(area).unwrap();
        let new = app.view_job(area).unwrap();
        assert!(matches!(
            app.on_view_done(view_done(old.id, Ok(()))),
            FollowUp::Ignore
        ));
        assert!(app.status.passes.is_empty());
        let next = app.on_view_done(view_done(new.id, Ok(())));
        assert!(matches!(next, FollowUp::ShowPicture(_)), "{next:?}");
        assert!(app.status.passes[0].starts_with("view 3 ms (key→picture "));
        let again = app.view_job(area).unwrap();
        app.on_view_done(view_done(again.id, Ok(())));
        assert_eq!(app.status.passes.len(), 1, "one view timing, the newest");
        let failed = app.view_job(area).unwrap();
        let next = app.on_view_done(view_done(failed.id, Err("no memory".into())));
        assert!(matches!(next, FollowUp::Redraw), "the last picture stays");
        assert_eq!(app.message, "view: no memory");
    }

    #[test]
    fn keys_clear_the_notice_and_esc_closes_the_help() {
        use ratatui::crossterm::event::KeyEvent;
        let key = |c: KeyCode| KeyEvent::new(c, KeyModifiers::NONE);
        let mut app = script_app();
        app.message = "saved a + b".into();
        assert_eq!(app.on_key(key(KeyCode::Char('s'))), Some(Effect::Save));
        assert_eq!(app.message, "saved a + b", "saving keeps the notice");
        assert_eq!(app.on_key(key(KeyCode::F(1))), Some(Effect::Redraw));
        assert!(app.show_help && app.message.is_empty());
        assert_eq!(app.on_key(key(KeyCode::Esc)), Some(Effect::Redraw));
        assert!(!app.show_help);
        assert_eq!(
            app.on_key(key(KeyCode::Esc)),
            None,
            "Esc is bound to nothing"
        );
        assert_eq!(app.on_key(key(KeyCode::Char('x'))), None);
    }

    #[test]
    fn saves_and_reloads_report_in_the_status_line() {
        let mut app = script_app();
        app.on_saved(Ok(("out/a_view000.exr".into(), "out/a_view000.png".into())));
        assert_eq!(app.message, "saved a_view000.exr + a_view000.png");
        app.on_saved(Err("disk full".into()));
        assert_eq!(app.message, "save failed: disk full");
        assert!(matches!(app.reload("reloading"), FollowUp::RequestRender));
        assert_eq!(app.message, "reloading");
        // An image file that no longer reads keeps the last good image.
        let mut app = App::new(
            Source::Image("missing.exr".into()),
            "out".into(),
            Vec::new(),
        );
        app.hdr = Some(scene(0.5, Vec::new()).image);
        let next = app.reload("file changed: reloading");
        assert!(matches!(next, FollowUp::RequestView));
        assert!(app
            .error
            .as_deref()
            .is_some_and(|e| e.contains("missing.exr")));
        assert_eq!(image_value(&app), Some(0.5));
    }
}
