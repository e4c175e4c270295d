//! Terminal set-up and its guaranteed undoing: raw mode, the alternate screen and a hidden
//! cursor on entry; on quit, on panic (a hook that restores before the message is printed) and
//! on SIGINT, SIGTERM or SIGHUP (signal-hook delivers them to the event loop, which quits
//! normally; if the loop does not end within a second the signal thread restores the terminal
//! and exits itself). Restoring is idempotent, so every path may call it.

use crate::error::{Error, Result};
use ratatui::backend::CrosstermBackend;
use ratatui::crossterm::{cursor, execute, terminal};
use ratatui::Terminal;
use std::io::{Stdout, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::time::Duration;

/// Whether the terminal is currently in the TUI's state (raw, alternate screen).
static ACTIVE: AtomicBool = AtomicBool::new(false);
/// Whether images were sent with the kitty protocol (they are deleted on exit).
static KITTY_IMAGES: AtomicBool = AtomicBool::new(false);

/// Puts the terminal back: kitty images deleted, alternate screen left, cursor shown, raw mode
/// off. Safe to call more than once and from any thread.
pub(crate) fn restore() {
    if !ACTIVE.swap(false, Ordering::SeqCst) {
        return;
    }
    let mut out = std::io::stdout();
    if KITTY_IMAGES.load(Ordering::SeqCst) {
        // Delete every image placement this client made (a=d, d=A).
        let _ = if crate::io::terminal_query::in_tmux() {
            out.write_all(b"\x1bPtmux;\x1b\x1b_Ga=d,d=A\x1b\x1b\\\x1b\\")
        } else {
            out.write_all(b"\x1b_Ga=d,d=A\x1b\\")
        };
    }
    let _ = execute!(out, terminal::LeaveAlternateScreen, cursor::Show);
    let _ = terminal::disable_raw_mode();
    let _ = out.flush();
}

/// Remembers that kitty images were sent, so [`restore`] deletes them.
pub(crate) fn note_kitty_images() {
    KITTY_IMAGES.store(true, Ordering::SeqCst);
}

/// The TUI's terminal; dropping it restores the screen.
pub(crate) struct TerminalGuard {
    pub terminal: Terminal<CrosstermBackend<Stdout>>,
}

impl TerminalGuard {
    /// Enters raw mode and the alternate screen and installs the panic hook.
    pub(crate) fn enter() -> Result<TerminalGuard> {
        use std::io::IsTerminal;
        if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
            return Err(Error::invalid(
                "tui",
                "stdin and stdout must be a terminal (for a non-interactive view use `hdrvis run --preview`)",
            ));
        }
        let term_err = |e: std::io::Error| Error::invalid("terminal", e.to_string());
        terminal::enable_raw_mode().map_err(term_err)?;
        ACTIVE.store(true, Ordering::SeqCst);
        let mut out = std::io::stdout();
        if let Err(e) = execute!(out, terminal::EnterAlternateScreen, cursor::Hide) {
            restore();
            return Err(term_err(e));
        }
        install_panic_hook();
        let terminal = match Terminal::new(CrosstermBackend::new(std::io::stdout())) {
            Ok(t) => t,
            Err(e) => {
                restore();
                return Err(term_err(e));
            }
        };
        Ok(TerminalGuard { terminal })
    }
}

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        restore();
    }
}

fn install_panic_hook() {
    static INSTALLED: AtomicBool = AtomicBool::new(false);
    if INSTALLED.swap(true, Ordering::SeqCst) {
        return;
    }
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        restore();
        previous(info);
    }));
}

/// Delivers SIGINT, SIGTERM and SIGHUP to `events` as their numbers. If `finished` is not set
/// within a second of a signal, the terminal is restored here and the process exits with
/// 128 + the signal's number.
pub(crate) fn watch_signals(
    events: Sender<i32>,
    finished: std::sync::Arc<AtomicBool>,
) -> Result<std::thread::JoinHandle<()>> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
        .map_err(|e| Error::invalid("signals", e.to_string()))?;
    std::thread::Builder::new()
        .name("hdrvis-signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let _ = events.send(sig);
                std::thread::sleep(Duration::from_secs(1));
                if !finished.load(Ordering::SeqCst) {
                    restore();
                    std::process::exit(128 + sig);
                }
            }
        })
        .map_err(|e| Error::invalid("signals", e.to_string()))
}
