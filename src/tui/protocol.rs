//! How pictures reach the terminal. The protocol is found by asking the terminal (environment
//! variables do not cross SSH): [`probe`] sends the kitty graphics query, XTVERSION, the cell
//! size query and DA1 (sixel flag) and reads the answers with `poll` and a deadline; or it is
//! forced with `--protocol` / `HDRVIS_TUI_PROTOCOL`. Pictures are encoded by ratatui-image.
//! Workarounds for known pitfalls:
//!
//! * tmux: ratatui-image recognises tmux only from `TERM`/`TERM_PROGRAM`, which are often
//!   `screen`/unset; [`prepare_environment`] also trusts `$TMUX`, so queries and images are
//!   wrapped in tmux passthrough (and `allow-passthrough` is switched on for the pane).
//! * sixel inside tmux < 3.4: tmux does not know about a passed-through image, so it does not
//!   clear it; the TUI clears the screen whenever the picture changes
//!   ([`Display::redraw_on_change`]), and the picture never touches the last row (a sixel
//!   there would scroll the screen).
//! * kitty < 0.28 has no Unicode placeholders, which ratatui-image's kitty images need: the
//!   terminal's version (XTVERSION) decides, and older kitty falls back to half blocks, said so
//!   in the status line.
//! * ratatui-image's own query reads stdin on a thread that stays blocked when the answers do
//!   not parse (seen inside tmux 3.3) and then steals key presses: it is used only with a
//!   terminal that has just answered as kitty (to learn its `o=z` compression).
//! * kitty over SSH: images are sent directly in the escape stream (`t=d`, no shared files),
//!   zlib-compressed (`o=z`) where the terminal says it can inflate.

use crate::error::{Error, Result};
use crate::io::terminal_query::{cell_from_winsize, in_tmux, probe};
use crate::tui::sixel::{widget_data, Indexed};
use crate::tui::view::{enlarge_nearest, fit_within};
use ratatui::layout::{Rect, Size};
use ratatui_image::picker::{cap_parser::QueryStdioOptions, Picker, ProtocolType};
use ratatui_image::protocol::{halfblocks::Halfblocks, sixel::Sixel, Protocol};
use std::time::Duration;

pub(crate) use crate::io::terminal::ProtocolChoice;

/// The ratatui-image protocol `--protocol` forces, `None` for auto.
fn forced(choice: ProtocolChoice) -> Option<ProtocolType> {
    match choice {
        ProtocolChoice::Auto => None,
        ProtocolChoice::Kitty => Some(ProtocolType::Kitty),
        ProtocolChoice::Sixel => Some(ProtocolType::Sixel),
        ProtocolChoice::Iterm2 => Some(ProtocolType::Iterm2),
        ProtocolChoice::Halfblocks => Some(ProtocolType::Halfblocks),
    }
}

/// Makes ratatui-image see tmux when only `$TMUX` says so. Changes this process's environment:
/// call it before any other thread starts.
pub(crate) fn prepare_environment() {
    let term_says_tmux = std::env::var("TERM").is_ok_and(|t| t.starts_with("tmux"))
        || std::env::var("TERM_PROGRAM").is_ok_and(|t| t == "tmux");
    if in_tmux() && !term_says_tmux {
        std::env::set_var("TERM_PROGRAM", "tmux");
    }
}

/// The tmux server's version as (major, minor), e.g. (3, 3) for "3.3a".
pub(crate) fn tmux_version() -> Option<(u32, u32)> {
    let out = std::process::Command::new("tmux")
        .args(["display-message", "-p", "#{version}"])
        .stdin(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    parse_version(String::from_utf8_lossy(&out.stdout).trim())
}

/// "3.3a" -> (3, 3); "0.26.5" -> (0, 26); "next-3.5" -> (3, 5).
pub(crate) fn parse_version(s: &str) -> Option<(u32, u32)> {
    let s = s.trim_start_matches(|c: char| !c.is_ascii_digit());
    let mut parts = s.split(|c: char| !c.is_ascii_digit());
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next().and_then(|m| m.parse().ok()).unwrap_or(0);
    Some((major, minor))
}

/// Kitty image id of the TUI's picture in direct-placement mode.
pub(crate) const KITTY_DIRECT_ID: u32 = 7431;

/// A picture ready for the terminal.
pub(crate) enum Picture {
    /// Drawn by ratatui-image's widget inside the frame (half blocks, sixel, kitty placeholders).
    Widget(Protocol),
    /// The escape sequence of a kitty image placed directly at the cursor (`a=T`), for kitty
    /// before 0.28; written after the frame at the picture area's corner.
    KittyDirect(String),
}

/// The kitty graphics escape that transmits `img` (24-bit RGB, sent in the stream: `t=d`) and
/// shows it at the cursor under the text (`z=-1`) without moving the cursor (`C=1`), in
/// base64 chunks of 4096 bytes.
pub(crate) fn kitty_direct_escape(img: &image::RgbImage) -> String {
    use base64::Engine as _;
    let data = base64::engine::general_purpose::STANDARD.encode(img.as_raw());
    let chunks: Vec<&[u8]> = data.as_bytes().chunks(4096).collect();
    let mut out = String::with_capacity(data.len() + chunks.len() * 16 + 80);
    for (i, chunk) in chunks.iter().enumerate() {
        let more = u8::from(i + 1 < chunks.len());
        let chunk = std::str::from_utf8(chunk).unwrap_or_default();
        if i == 0 {
            out.push_str(&format!(
                "\x1b_Ga=T,f=24,t=d,s={},v={},i={KITTY_DIRECT_ID},z=-1,C=1,q=2,m={more};{chunk}\x1b\\",
                img.width(),
                img.height()
            ));
        } else {
            out.push_str(&format!("\x1b_Gm={more};{chunk}\x1b\\"));
        }
    }
    out
}

/// The chosen protocol with what the status line should say about it.
#[derive(Clone)]
pub(crate) struct Display {
    pub picker: Picker,
    /// Place kitty images directly (kitty before 0.28, which lacks Unicode placeholders).
    pub kitty_direct: bool,
    /// e.g. `sixel`, `kitty (compressed)`, `halfblocks: the terminal shows no graphics`.
    pub note: String,
    /// Clear the screen when the picture changes (sixel through tmux passthrough).
    pub redraw_on_change: bool,
}

impl Display {
    /// A display for tests and benchmarks: `choice` (auto means half blocks) at a fixed cell
    /// size, no terminal query.
    pub(crate) fn fixed(choice: ProtocolChoice, cell: (u16, u16)) -> Display {
        let protocol = forced(choice).unwrap_or(ProtocolType::Halfblocks);
        #[allow(deprecated)] // the only constructor that takes a cell size without a terminal
        let mut picker = Picker::from_fontsize(cell.into());
        picker.set_protocol_type(protocol);
        Display {
            picker,
            note: name(protocol).to_string(),
            redraw_on_change: false,
            kitty_direct: false,
        }
    }

    /// Whether pictures are shown pixel for pixel (sixel, kitty), not one colour per half cell.
    pub(crate) fn shows_pixels(&self) -> bool {
        self.picker.protocol_type() != ProtocolType::Halfblocks
    }

    /// The size in pixels a `width` × `height` image is shown at inside `area`: the largest with
    /// its aspect inside the area's pixels at the terminal's cell size, or, for half blocks,
    /// that picture counted in half cells (one column and two rows a cell, whole cells). Half blocks show no
    /// more than that, so the image is downsampled, tone-mapped and encoded at this size only.
    pub(crate) fn picture_size(&self, width: u32, height: u32, area: Rect) -> (u32, u32) {
        let fs = self.picker.font_size();
        let (cw, ch) = (u32::from(fs.width).max(1), u32::from(fs.height).max(1));
        let (pw, ph) = fit_within(
            width,
            height,
            u32::from(area.width) * cw,
            u32::from(area.height) * ch,
        );
        if self.picker.protocol_type() != ProtocolType::Halfblocks {
            return (pw, ph);
        }
        // Whole cells: the encoder fills both halves of every cell it draws.
        let columns = (pw as f64 / cw as f64).round() as u32;
        let rows = (ph as f64 / ch as f64).round() as u32;
        (
            columns.clamp(1, u32::from(area.width).max(1)),
            2 * rows.clamp(1, u32::from(area.height).max(1)),
        )
    }

    /// Encodes `img` for the terminal, shown at `shown` (at most [`Display::picture_size`] for
    /// `area`): a smaller `img` is enlarged by repeating pixels ([`enlarge_nearest`]). Sixel
    /// reduces `img` to its palette before it is enlarged ([`crate::tui::sixel`]).
    pub(crate) fn encode(
        &self,
        img: image::RgbImage,
        shown: (u32, u32),
        area: Rect,
    ) -> Result<Picture> {
        if self.picker.protocol_type() == ProtocolType::Sixel && !self.kitty_direct {
            return Ok(Picture::Widget(self.sixel(&img, shown)));
        }
        let img = if img.dimensions() == shown {
            img
        } else {
            enlarge_nearest(&img, shown.0, shown.1)
        };
        if self.kitty_direct {
            return Ok(Picture::KittyDirect(kitty_direct_escape(&img)));
        }
        if self.picker.protocol_type() == ProtocolType::Halfblocks {
            // The image is already one pixel per half cell: ratatui-image's own path would
            // take it for pixels at the font size and shrink it again.
            let cells = Size::new(
                img.width().min(u32::from(area.width)) as u16,
                img.height().div_ceil(2).min(u32::from(area.height)) as u16,
            );
            return Halfblocks::new(image::DynamicImage::ImageRgb8(img), cells)
                .map(|h| Picture::Widget(Protocol::Halfblocks(h)))
                .map_err(|e| Error::invalid("terminal image", e.to_string()));
        }
        self.picker
            .new_protocol(
                image::DynamicImage::ImageRgb8(img),
                area.as_size(),
                ratatui_image::Resize::Fit(None),
            )
            .map(Picture::Widget)
            .map_err(|e| Error::invalid("terminal image", e.to_string()))
    }

    /// ratatui-image's sixel widget showing `img` enlarged to `shown`, over the cells those
    /// pixels cover (rounded up, as ratatui-image counts them).
    fn sixel(&self, img: &image::RgbImage, shown: (u32, u32)) -> Protocol {
        let image = Indexed::quantise(img).enlarged(shown.0, shown.1).sixel();
        let fs = self.picker.font_size();
        let cells = (
            shown.0.div_ceil(u32::from(fs.width).max(1)) as u16,
            shown.1.div_ceil(u32::from(fs.height).max(1)) as u16,
        );
        let is_tmux = self.picker.tmux_detected();
        Protocol::Sixel(Sixel {
            data: widget_data(&image, cells, is_tmux),
            size: Size::new(cells.0, cells.1),
            is_tmux,
        })
    }
}

fn name(p: ProtocolType) -> &'static str {
    match p {
        ProtocolType::Halfblocks => "halfblocks",
        ProtocolType::Sixel => "sixel",
        ProtocolType::Kitty => "kitty",
        ProtocolType::Iterm2 => "iterm2",
    }
}

/// Finds how to show pictures. Must run after the terminal entered raw mode and the alternate
/// screen and before events are read (the answers arrive on stdin).
pub(crate) fn detect(choice: ProtocolChoice) -> Display {
    if choice == ProtocolChoice::Halfblocks {
        let mut picker = Picker::halfblocks();
        picker.set_protocol_type(ProtocolType::Halfblocks);
        return Display {
            picker,
            note: "halfblocks (forced)".into(),
            redraw_on_change: false,
            kitty_direct: false,
        };
    }
    let tmux = in_tmux();
    let found = probe(tmux, Duration::from_millis(1500));
    // ratatui-image's own query learns kitty's o=z compression; it is asked only of a terminal
    // that just answered as kitty, so its reader thread finishes.
    let queried = if found.answered && found.kitty {
        let options = QueryStdioOptions {
            timeout: Duration::from_millis(1500),
            kitty_compression: true,
            ..QueryStdioOptions::default()
        };
        Picker::from_query_stdio_with_options(options).ok()
    } else {
        None
    };
    let mut picker = queried.unwrap_or_else(|| {
        let cell = found.cell.or_else(cell_from_winsize).unwrap_or((10, 20));
        #[allow(deprecated)] // the constructor for a cell size found without ratatui-image
        let mut p = Picker::from_fontsize(cell.into());
        p.set_protocol_type(if found.kitty {
            ProtocolType::Kitty
        } else if found.sixel {
            ProtocolType::Sixel
        } else {
            ProtocolType::Halfblocks
        });
        p
    });
    let mut note;
    let mut kitty_direct = false;
    if let Some(forced) = forced(choice) {
        picker.set_protocol_type(forced);
        note = format!("{} (forced)", name(forced));
    } else {
        let p = picker.protocol_type();
        note = name(p).to_string();
        if p == ProtocolType::Halfblocks {
            note = if found.answered {
                "halfblocks: the terminal shows no graphics".into()
            } else {
                "halfblocks: the terminal did not answer".into()
            };
        }
        if p == ProtocolType::Kitty {
            if let Some(v) = &found.version {
                if let Some(rest) = v.strip_prefix("kitty") {
                    if parse_version(rest).is_some_and(|ver| ver < (0, 28)) {
                        // Direct placement needs the cursor where the picture goes, which tmux
                        // does not pass through faithfully.
                        if tmux {
                            picker.set_protocol_type(ProtocolType::Halfblocks);
                            note = format!(
                                "halfblocks: {v} predates Unicode placeholders (kitty 0.28)"
                            );
                        } else {
                            kitty_direct = true;
                            note = format!("kitty direct placement ({v})");
                        }
                    }
                }
            }
        }
    }
    if picker.protocol_type() == ProtocolType::Kitty
        && picker
            .capabilities()
            .contains(&ratatui_image::picker::Capability::KittyCompression)
    {
        note.push_str(" (compressed)");
    }
    let mut redraw_on_change = false;
    if tmux && picker.protocol_type() != ProtocolType::Halfblocks {
        note.push_str(" via tmux");
        if picker.protocol_type() == ProtocolType::Sixel
            && tmux_version().is_none_or(|v| v < (3, 4))
        {
            redraw_on_change = true;
        }
    }
    Display {
        picker,
        note,
        redraw_on_change,
        kitty_direct,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_and_xtversion_answers_parse() {
        assert_eq!(parse_version("3.3a"), Some((3, 3)));
        assert_eq!(parse_version("(0.26.5)"), Some((0, 26)));
        assert_eq!(parse_version("next-3.5"), Some((3, 5)));
    }

    #[test]
    fn kitty_direct_placement_decodes_to_the_picture() {
        // 100 x 60 RGB is 18000 bytes, 24000 base64 characters: six chunks.
        let img = image::RgbImage::from_fn(100, 60, |x, y| image::Rgb([x as u8, y as u8, 77]));
        let escape = kitty_direct_escape(&img);
        assert_eq!(escape.matches("\x1b_G").count(), 6);
        assert!(escape.starts_with("\x1b_Ga=T,f=24,t=d,s=100,v=60,"));
        let back = crate::tui::decode::decode_kitty(&escape).unwrap();
        assert_eq!((back.width, back.height), (100, 60));
        for (x, y) in [(0, 0), (99, 0), (37, 59)] {
            assert_eq!(back.pixel(x, y), [x as u8, y as u8, 77, 255]);
        }
    }

    /// Half blocks get one pixel per half cell with the image's aspect at the cell size, and
    /// the encoded picture covers exactly those cells with the image's colours.
    #[test]
    fn half_blocks_are_prepared_at_one_pixel_per_half_cell() {
        use ratatui::buffer::Buffer;
        use ratatui::style::Color;
        use ratatui::widgets::Widget;
        let area = Rect::new(0, 0, 128, 47);
        let display = Display::fixed(ProtocolChoice::Halfblocks, (10, 20));
        // 768 x 512 fits 1280 x 853 pixels of the area: 128 columns, 43 rows of two half cells
        // (1280 x 860 pixels on screen, aspect 1.49 for 1.5).
        assert_eq!(display.picture_size(768, 512, area), (128, 86));
        // A tall image keeps its aspect too: 100 x 400 fits 235 x 940 pixels, 24 columns.
        assert_eq!(display.picture_size(100, 400, area), (24, 94));
        let img = image::RgbImage::from_fn(128, 86, |x, y| image::Rgb([x as u8, (y * 3) as u8, 7]));
        let Picture::Widget(encoded) = display.encode(img, (128, 86), area).unwrap() else {
            panic!("a widget picture");
        };
        let mut buf = Buffer::empty(area);
        ratatui_image::Image::new(&encoded).render(area, &mut buf);
        for (x, y) in [(0u16, 0u16), (127, 0), (5, 42), (127, 42), (64, 20)] {
            let cell = &buf[(x, y)];
            let upper = Color::Rgb(x as u8, (2 * y * 3) as u8, 7);
            let lower = Color::Rgb(x as u8, ((2 * y + 1) * 3) as u8, 7);
            let (fg, bg) = (cell.fg, cell.bg);
            assert!(
                (fg, bg) == (upper, lower) || (fg, bg) == (lower, upper),
                "cell ({x}, {y}): {fg:?} / {bg:?}"
            );
        }
        // Nothing drawn below the picture's 43 rows.
        assert_eq!(buf[(3, 44)].symbol(), " ");
        assert_eq!(buf[(3, 44)].bg, Color::Reset);
    }

    #[test]
    fn sixel_and_kitty_payloads_decode_to_the_picture() {
        use crate::tui::decode::{decode_kitty, decode_sixel};
        use ratatui::buffer::Buffer;
        use ratatui::widgets::Widget;
        let area = Rect::new(0, 0, 12, 5);
        // A smooth two-axis gradient: every pixel distinct, so misplaced rows or columns show.
        // Two pictures: a smooth two-axis gradient (3000 colours: every pixel distinct, so
        // misplaced rows or columns show; a sixel palette of 256 must approximate it), and
        // blocks of 12 colours whose levels (multiples of 51) sixel's percent scale holds
        // exactly, which must come back bit-exact from both protocols.
        let gradient = |x: u32, y: u32| image::Rgb([(x * 2) as u8, (y * 2) as u8, 128]);
        let blocks =
            |x: u32, y: u32| image::Rgb([(x / 20 % 6 * 51) as u8, (y / 50 % 2 * 255) as u8, 102]);
        type Pattern<'a> = &'a dyn Fn(u32, u32) -> image::Rgb<u8>;
        // Each also from a picture of half the size, enlarged by the encoder (sixel: its
        // palette indices).
        let cases: [(ProtocolChoice, Pattern, bool, u32); 8] = [
            (ProtocolChoice::Sixel, &gradient, false, 1),
            (ProtocolChoice::Kitty, &gradient, true, 1),
            (ProtocolChoice::Sixel, &blocks, true, 1),
            (ProtocolChoice::Kitty, &blocks, true, 1),
            (ProtocolChoice::Sixel, &gradient, false, 2),
            (ProtocolChoice::Kitty, &gradient, true, 2),
            (ProtocolChoice::Sixel, &blocks, true, 2),
            (ProtocolChoice::Kitty, &blocks, true, 2),
        ];
        for (protocol, pattern, exact, shrink) in cases {
            let display = Display::fixed(protocol, (10, 20));
            let (w, h) = display.picture_size(120, 100, area);
            assert_eq!((w, h), (120, 100));
            let small = image::RgbImage::from_fn(w / shrink, h / shrink, |x, y| {
                pattern(x * shrink, y * shrink)
            });
            let img = crate::tui::view::enlarge_nearest(&small, w, h);
            let Picture::Widget(encoded) = display.encode(small, (w, h), area).unwrap() else {
                panic!("a widget picture");
            };
            let mut buf = Buffer::empty(area);
            ratatui_image::Image::new(&encoded).render(area, &mut buf);
            let payload = buf[(0, 0)].symbol().to_string();
            let decoded = if protocol == ProtocolChoice::Sixel {
                decode_sixel(&payload).unwrap()
            } else {
                decode_kitty(&payload).unwrap()
            };
            assert_eq!((decoded.width, decoded.height), (w, h), "{protocol:?}");
            // Per pixel (a palette quantiser may dither) and over 8 x 8 blocks (what the eye
            // sees, and where dithering must average out).
            let mut sum = 0u64;
            let mut worst = 0u8;
            let mut worst_block = 0f64;
            for by in 0..h / 8 {
                for bx in 0..w / 8 {
                    let mut block = [0f64; 3];
                    for y in by * 8..by * 8 + 8 {
                        for x in bx * 8..bx * 8 + 8 {
                            let d = decoded.pixel(x, y);
                            let e = img.get_pixel(x, y).0;
                            for k in 0..3 {
                                let diff = d[k].abs_diff(e[k]);
                                sum += diff as u64;
                                worst = worst.max(diff);
                                block[k] += d[k] as f64 - e[k] as f64;
                            }
                        }
                    }
                    for b in block {
                        worst_block = worst_block.max((b / 64.0).abs());
                    }
                }
            }
            let mean = sum as f64 / ((w / 8) * (h / 8) * 64 * 3) as f64;
            if exact {
                assert_eq!(worst, 0, "{protocol:?}");
            } else {
                // Palette quantisation: a few levels per pixel on average; the worst 8 x 8
                // block (near the gradient's dark edge, where the palette is sparse) within 32.
                assert!(
                    mean < 6.0 && worst_block < 32.0,
                    "{protocol:?}: mean {mean}, worst block {worst_block}, worst pixel {worst}"
                );
            }
        }
    }
}
