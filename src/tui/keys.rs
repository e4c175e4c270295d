//! The keys of the TUI: an [`Action`] per key, and [`KEYS`], the one table the help overlay, the
//! README and the key handler share.

use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

/// Something a key asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Action {
    Quit,
    ExposureUp,
    ExposureDown,
    ExposureReset,
    NextOperator,
    PrevOperator,
    OperatorParamUp,
    OperatorParamDown,
    ToggleFalseColour,
    NextChannel,
    OrbitLeft,
    OrbitRight,
    OrbitUp,
    OrbitDown,
    ZoomIn,
    ZoomOut,
    NuUp,
    NuDown,
    NextMode,
    OpacityUp,
    OpacityDown,
    LensLeft,
    LensRight,
    LensWider,
    LensNarrower,
    SelectNext,
    SelectPrev,
    StepUp,
    StepDown,
    Save,
    Reload,
    ToggleHelp,
}

impl Action {
    /// Whether the action changes a script parameter (an image file has none).
    pub(crate) fn changes_scene(self) -> bool {
        use Action::*;
        matches!(
            self,
            OrbitLeft
                | OrbitRight
                | OrbitUp
                | OrbitDown
                | ZoomIn
                | ZoomOut
                | NuUp
                | NuDown
                | NextMode
                | OpacityUp
                | OpacityDown
                | LensLeft
                | LensRight
                | LensWider
                | LensNarrower
                | StepUp
                | StepDown
        )
    }
}

/// Every key binding: (keys as shown, action, what it does). The help overlay lists exactly this.
pub(crate) const KEYS: &[(&str, Action, &str)] = &[
    ("+ / =", Action::ExposureUp, "exposure +0.5 EV"),
    ("-", Action::ExposureDown, "exposure -0.5 EV"),
    ("0", Action::ExposureReset, "exposure 0 EV"),
    ("o", Action::NextOperator, "next tone-mapping operator"),
    ("O", Action::PrevOperator, "previous operator"),
    (
        "]",
        Action::OperatorParamUp,
        "operator parameter up (key, bias…)",
    ),
    ("[", Action::OperatorParamDown, "operator parameter down"),
    (
        "f",
        Action::ToggleFalseColour,
        "false colour (log10 luminance)",
    ),
    (
        "c",
        Action::NextChannel,
        "channel: RGB, R, G, B, A, Y, extra",
    ),
    ("Left / h", Action::OrbitLeft, "orbit: azimuth -15°"),
    ("Right / l", Action::OrbitRight, "orbit: azimuth +15°"),
    ("Up / k", Action::OrbitUp, "orbit: elevation +10°"),
    ("Down / j", Action::OrbitDown, "orbit: elevation -10°"),
    ("z", Action::ZoomIn, "zoom in (x1.25)"),
    ("Z", Action::ZoomOut, "zoom out"),
    ("n", Action::NuUp, "interference ν x1.25"),
    ("N", Action::NuDown, "interference ν /1.25"),
    (
        "m",
        Action::NextMode,
        "surface mode: cyclic/modulated/direct",
    ),
    ("a", Action::OpacityUp, "TF opacity +0.25 decade"),
    ("A", Action::OpacityDown, "opacity -0.25 decade"),
    ("<", Action::LensLeft, "magnification window left"),
    (">", Action::LensRight, "magnification window right"),
    ("w", Action::LensWider, "magnification window wider"),
    ("W", Action::LensNarrower, "magnification window narrower"),
    ("Tab", Action::SelectNext, "select next parameter"),
    ("Shift-Tab", Action::SelectPrev, "select previous parameter"),
    ("PgUp / .", Action::StepUp, "selected parameter up"),
    ("PgDn / ,", Action::StepDown, "selected parameter down"),
    ("s", Action::Save, "save view: EXR + PNG into --out"),
    ("r", Action::Reload, "reload (also when the file changes)"),
    ("? / F1", Action::ToggleHelp, "this help"),
    ("q / Ctrl-C", Action::Quit, "quit"),
];

/// The action bound to a key, if any.
pub(crate) fn action_for_key(key: KeyEvent) -> Option<Action> {
    use Action::*;
    if key.modifiers.contains(KeyModifiers::CONTROL) {
        return matches!(key.code, KeyCode::Char('c')).then_some(Quit);
    }
    Some(match key.code {
        KeyCode::Char('q') => Quit,
        KeyCode::Char('+') | KeyCode::Char('=') => ExposureUp,
        KeyCode::Char('-') | KeyCode::Char('_') => ExposureDown,
        KeyCode::Char('0') => ExposureReset,
        KeyCode::Char('o') => NextOperator,
        KeyCode::Char('O') => PrevOperator,
        KeyCode::Char(']') => OperatorParamUp,
        KeyCode::Char('[') => OperatorParamDown,
        KeyCode::Char('f') => ToggleFalseColour,
        KeyCode::Char('c') => NextChannel,
        KeyCode::Left | KeyCode::Char('h') => OrbitLeft,
        KeyCode::Right | KeyCode::Char('l') => OrbitRight,
        KeyCode::Up | KeyCode::Char('k') => OrbitUp,
        KeyCode::Down | KeyCode::Char('j') => OrbitDown,
        KeyCode::Char('z') => ZoomIn,
        KeyCode::Char('Z') => ZoomOut,
        KeyCode::Char('n') => NuUp,
        KeyCode::Char('N') => NuDown,
        KeyCode::Char('m') => NextMode,
        KeyCode::Char('a') => OpacityUp,
        KeyCode::Char('A') => OpacityDown,
        KeyCode::Char('<') => LensLeft,
        KeyCode::Char('>') => LensRight,
        KeyCode::Char('w') => LensWider,
        KeyCode::Char('W') => LensNarrower,
        KeyCode::Tab => SelectNext,
        KeyCode::BackTab => SelectPrev,
        KeyCode::PageUp | KeyCode::Char('.') => StepUp,
        KeyCode::PageDown | KeyCode::Char(',') => StepDown,
        KeyCode::Char('s') => Save,
        KeyCode::Char('r') => Reload,
        KeyCode::Char('?') | KeyCode::F(1) => ToggleHelp,
        _ => return None,
    })
}
