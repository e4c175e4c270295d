//! What the terminal can tell about itself: whether it runs inside tmux, and, asked with escape
//! sequences (through tmux's passthrough when inside it), its graphics protocols, version and
//! cell size in pixels, else the cell size from the window size the kernel keeps. The TUI
//! chooses its picture protocol from these answers; inline previews size their pictures by the
//! cell size, so a picture keeps its aspect with any font.

use std::time::Duration;

/// Whether this process runs inside tmux (by `$TMUX`, which tmux always sets, or the terminal
/// names ratatui-image looks at).
pub(crate) fn in_tmux() -> bool {
    std::env::var_os("TMUX").is_some_and(|v| !v.is_empty())
        || std::env::var("TERM").is_ok_and(|t| t.starts_with("tmux"))
        || std::env::var("TERM_PROGRAM").is_ok_and(|t| t == "tmux")
}

/// What the terminal said to [`probe`].
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Probe {
    /// The status report came back (the terminal answers queries at all).
    pub answered: bool,
    pub kitty: bool,
    pub sixel: bool,
    /// Cell size in pixels (width, height) from `CSI 16 t`.
    pub cell: Option<(u16, u16)>,
    /// XTVERSION text, e.g. `kitty(0.26.5)` or `XTerm(390)`.
    pub version: Option<String>,
}

/// Asks the terminal, through tmux passthrough when `tmux`: kitty graphics (a 1-pixel query
/// image), XTVERSION, cell size, primary device attributes (sixel is attribute 4), and a status
/// report that every terminal answers, which ends the read. Reads with `poll` and a deadline, so
/// no thread is left behind reading stdin (it would steal key presses).
pub(crate) fn probe(tmux: bool, timeout: Duration) -> Probe {
    let (start, esc, end) = if tmux {
        ("\x1bPtmux;", "\x1b\x1b", "\x1b\\")
    } else {
        ("", "\x1b", "")
    };
    let query = format!(
        "{start}{esc}_Gi=31,s=1,v=1,a=q,t=d,f=24;AAAA{esc}\\{esc}[>0q{esc}[16t{esc}[c{end}\x1b[5n"
    );
    let answer = String::from_utf8_lossy(&exchange(&query, timeout)).to_string();
    parse_probe(&answer)
}

/// Parses the answers to [`probe`]'s queries.
pub(crate) fn parse_probe(answer: &str) -> Probe {
    let mut p = Probe {
        answered: answer.contains("\x1b[0n"),
        kitty: answer.contains("\x1b_Gi=31;OK"),
        version: parse_xtversion(answer),
        ..Probe::default()
    };
    // DA1: ESC [ ? a ; b ; ... c
    if let Some(i) = answer.find("\x1b[?") {
        if let Some(j) = answer[i..].find('c') {
            p.sixel = answer[i + 3..i + j].split(';').any(|a| a == "4");
        }
    }
    // Cell size: ESC [ 6 ; height ; width t
    if let Some(i) = answer.find("\x1b[6;") {
        if let Some(j) = answer[i..].find('t') {
            let nums: Vec<u16> = answer[i + 4..i + j]
                .split(';')
                .filter_map(|v| v.parse().ok())
                .collect();
            if let [h, w] = nums[..] {
                if w > 0 && h > 0 {
                    p.cell = Some((w, h));
                }
            }
        }
    }
    p
}

/// Writes `query` with the terminal in non-canonical, no-echo mode and collects what comes back
/// until the status report's answer (`ESC [ 0 n`) or the deadline.
fn exchange(query: &str, timeout: Duration) -> Vec<u8> {
    use rustix::termios::{self, LocalModes, OptionalActions};
    use std::io::{Read, Write};
    let stdin = std::io::stdin();
    let Ok(saved) = termios::tcgetattr(&stdin) else {
        return Vec::new();
    };
    let mut raw = saved.clone();
    raw.local_modes &= !(LocalModes::ICANON | LocalModes::ECHO);
    if termios::tcsetattr(&stdin, OptionalActions::Drain, &raw).is_err() {
        return Vec::new();
    }
    let mut out = std::io::stdout();
    let _ = out.write_all(query.as_bytes()).and_then(|_| out.flush());
    let mut answer = Vec::new();
    let deadline = std::time::Instant::now() + timeout;
    while !answer.windows(4).any(|w| w == b"\x1b[0n") {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        if left.is_zero() {
            break;
        }
        let mut fds = [rustix::event::PollFd::new(
            &stdin,
            rustix::event::PollFlags::IN,
        )];
        let wait = rustix::event::Timespec {
            tv_sec: left.as_secs() as _,
            tv_nsec: left.subsec_nanos() as _,
        };
        match rustix::event::poll(&mut fds, Some(&wait)) {
            Ok(n) if n > 0 => {
                let mut buf = [0u8; 512];
                match std::io::stdin().lock().read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => answer.extend_from_slice(&buf[..n]),
                }
            }
            _ => break,
        }
    }
    let _ = termios::tcsetattr(&stdin, OptionalActions::Now, &saved);
    answer
}

/// The cell size from the terminal's window size in pixels, when it reports one.
pub(crate) fn cell_from_winsize() -> Option<(u16, u16)> {
    let ws = rustix::termios::tcgetwinsize(std::io::stdout()).ok()?;
    (ws.ws_xpixel > 0 && ws.ws_ypixel > 0 && ws.ws_col > 0 && ws.ws_row > 0)
        .then(|| (ws.ws_xpixel / ws.ws_col, ws.ws_ypixel / ws.ws_row))
}

/// The text of an XTVERSION answer, `ESC P > | text ESC \`.
pub(crate) fn parse_xtversion(answer: &str) -> Option<String> {
    let start = answer.find("\x1bP>|")? + 4;
    let end = answer[start..].find("\x1b\\")? + start;
    Some(answer[start..end].trim().to_string())
}

/// The terminal's cell size in pixels (width, height): from the window size when the terminal
/// reports pixels there, else asked ([`probe`], waiting at most `timeout`); `None` when neither
/// answers (not a terminal, or one that keeps quiet).
pub(crate) fn cell_size(timeout: Duration) -> Option<(u16, u16)> {
    cell_from_winsize().or_else(|| probe(in_tmux(), timeout).cell)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xtversion_answers_parse() {
        assert_eq!(
            parse_xtversion("\x1bP>|kitty(0.26.5)\x1b\\\x1b[0n").as_deref(),
            Some("kitty(0.26.5)")
        );
        assert_eq!(parse_xtversion("\x1b[0n"), None);
    }

    #[test]
    fn probe_answers_parse() {
        // xterm -ti vt340: DA1 with 4 (sixel), a cell size, no kitty.
        let xterm = "\x1bP>|XTerm(379)\x1b\\\x1b[6;17;8t\x1b[?63;1;2;4;6;9;15;22c\x1b[0n";
        let p = parse_probe(xterm);
        assert!(p.answered && p.sixel && !p.kitty);
        assert_eq!(p.cell, Some((8, 17)));
        assert_eq!(p.version.as_deref(), Some("XTerm(379)"));
        // kitty 0.26: graphics OK, no sixel.
        let kitty = "\x1b_Gi=31;OK\x1b\\\x1bP>|kitty(0.26.5)\x1b\\\x1b[?62;c\x1b[0n";
        let p = parse_probe(kitty);
        assert!(p.kitty && !p.sixel && p.answered);
        // tmux 3.3 itself: no graphics.
        let p = parse_probe("\x1b[?1;2c\x1b[0n");
        assert!(p.answered && !p.kitty && !p.sixel && p.cell.is_none());
        assert!(!parse_probe("").answered);
    }
}
