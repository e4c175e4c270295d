//! Pictures printed once, inline, into the terminal's scrollback: the script's `preview(image)`,
//! `hdrvis run --preview` and charts the benchmarks write. Printing is viuer's (kitty, iTerm2,
//! sixel through icy_sixel, else half blocks), restricted to the protocol `--protocol` /
//! `HDRVIS_TUI_PROTOCOL` names when one is given. Nothing here draws a live screen: the
//! interactive TUI (`crate::tui`, the only user of ratatui) shares only [`ProtocolChoice`] and
//! `srgb8_picture` with it. Every printer is a no-op returning `false` when stdout is not a
//! terminal, so batch runs and pipes stay clean. A picture's rows come from the terminal's cell
//! size (`terminal_query`), so it keeps its aspect whatever the font's cell shape.

use crate::error::{Error, Result};
use crate::model::HdrImage;
use std::io::IsTerminal;
use std::path::Path;

/// Environment variable that overrides `--protocol auto`.
pub(crate) const PROTOCOL_ENV: &str = "HDRVIS_TUI_PROTOCOL";

/// The protocol asked for on the command line or in the environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProtocolChoice {
    Auto,
    Kitty,
    Sixel,
    Iterm2,
    Halfblocks,
}

impl ProtocolChoice {
    pub fn parse(s: &str) -> Result<ProtocolChoice> {
        Ok(match s.trim().to_ascii_lowercase().as_str() {
            "auto" => ProtocolChoice::Auto,
            "kitty" => ProtocolChoice::Kitty,
            "sixel" => ProtocolChoice::Sixel,
            "iterm2" => ProtocolChoice::Iterm2,
            "halfblocks" => ProtocolChoice::Halfblocks,
            other => {
                return Err(Error::invalid(
                    "--protocol",
                    format!(
                    "unknown protocol {other:?}; expected auto, kitty, sixel, iterm2 or halfblocks"
                ),
                ))
            }
        })
    }

    /// `--protocol` if given, else `HDRVIS_TUI_PROTOCOL`, else auto.
    pub fn resolve(explicit: Option<&str>) -> Result<ProtocolChoice> {
        match explicit {
            Some(s) => Self::parse(s),
            None => match std::env::var(PROTOCOL_ENV) {
                Ok(s) if !s.trim().is_empty() => {
                    Self::parse(&s).map_err(|e| Error::invalid(PROTOCOL_ENV, e.to_string()))
                }
                _ => Ok(ProtocolChoice::Auto),
            },
        }
    }

    /// viuer's settings for this choice: which graphics protocols it may try (half blocks
    /// always remain) and the picture's size in cells (the height from the aspect when `None`,
    /// as viuer assumes cells twice as tall as wide); printed at the cursor.
    fn viuer_config(self, width_cells: u32, height_cells: Option<u32>) -> viuer::Config {
        let (kitty, iterm, sixel) = match self {
            ProtocolChoice::Auto => (true, true, true),
            ProtocolChoice::Kitty => (true, false, false),
            ProtocolChoice::Iterm2 => (false, true, false),
            ProtocolChoice::Sixel => (false, false, true),
            ProtocolChoice::Halfblocks => (false, false, false),
        };
        viuer::Config {
            absolute_offset: false,
            width: Some(width_cells),
            height: height_cells,
            use_kitty: kitty,
            use_iterm: iterm,
            use_sixel: sixel,
            ..Default::default()
        }
    }
}

/// A display-referred image as the 8-bit sRGB picture a terminal shows
/// ([`HdrImage::to_srgb8`]: values clamped to [0, 1], missing ones black, alpha dropped).
pub(crate) fn srgb8_picture(display: &HdrImage) -> image::RgbImage {
    image::RgbImage::from_raw(
        display.width,
        display.height,
        display.to_srgb8().into_flattened(),
    )
    .expect("a display image holds width * height pixels")
}

/// How long an inline preview waits for the terminal to tell its cell size (terminals answer
/// in milliseconds, also over SSH; the wait is only spent on one that never answers).
const CELL_QUERY_TIMEOUT: std::time::Duration = std::time::Duration::from_millis(1000);

/// Rows of `cell` (width, height in pixels) that a `width` × `height` picture needs at
/// `width_cells` columns to keep its aspect; `None` without a cell size.
fn picture_rows(
    width: u32,
    height: u32,
    width_cells: u32,
    cell: Option<(u16, u16)>,
) -> Option<u32> {
    let (cw, ch) = cell.filter(|&(w, h)| w > 0 && h > 0)?;
    let rows = width_cells as f64 * height as f64 / width.max(1) as f64 * cw as f64 / ch as f64;
    Some(rows.round().max(1.0) as u32)
}

/// Prints `picture` inline at the cursor, `width_cells` columns wide. Returns `false`, printing
/// nothing, when stdout is not a terminal. Errors are reported under `what` (the option or
/// builtin that asked, e.g. `--preview`).
pub(crate) fn print_picture_inline(
    picture: &image::DynamicImage,
    protocol: ProtocolChoice,
    width_cells: u32,
    what: &str,
) -> Result<bool> {
    if !std::io::stdout().is_terminal() {
        return Ok(false);
    }
    // Asked once per process: the cell size stays with the font, and a sweep previews often.
    static CELL: std::sync::OnceLock<Option<(u16, u16)>> = std::sync::OnceLock::new();
    let cell = *CELL.get_or_init(|| crate::io::terminal_query::cell_size(CELL_QUERY_TIMEOUT));
    let height_cells = picture_rows(picture.width(), picture.height(), width_cells, cell);
    viuer::print(picture, &protocol.viuer_config(width_cells, height_cells))
        .map_err(|e| Error::invalid(what, format!("terminal preview failed: {e}")))?;
    Ok(true)
}

/// [`print_picture_inline`] for an HDR image: a display-referred (tone-mapped) image shows as
/// it is, a scene-referred one as the plain 0 EV view (clipped to [0, 1]), which is the same
/// 8-bit picture. An empty image is an error named `what`.
pub(crate) fn print_hdr_inline(
    img: &HdrImage,
    protocol: ProtocolChoice,
    width_cells: u32,
    what: &str,
) -> Result<bool> {
    if !std::io::stdout().is_terminal() {
        return Ok(false);
    }
    if img.width == 0 || img.height == 0 {
        return Err(Error::invalid(what, "empty image"));
    }
    let picture = image::DynamicImage::ImageRgb8(srgb8_picture(img));
    print_picture_inline(&picture, protocol, width_cells, what)
}

/// `print_picture_inline` for a picture file (a chart PNG); an unreadable file is an error
/// named `what`.
pub fn print_file_inline(
    path: &Path,
    protocol: ProtocolChoice,
    width_cells: u32,
    what: &str,
) -> Result<bool> {
    if !std::io::stdout().is_terminal() {
        return Ok(false);
    }
    let picture = image::open(path)
        .map_err(|e| Error::format(path, format!("cannot read the picture: {e}")))?;
    print_picture_inline(&picture, protocol, width_cells, what)
}

/// `hdrvis run --preview`: `img` printed inline with `title` and its size above it. Returns
/// `false`, printing nothing, when stdout is not a terminal.
pub fn print_inline(
    img: &HdrImage,
    title: &str,
    protocol: ProtocolChoice,
    width_cells: u32,
) -> Result<bool> {
    if !std::io::stdout().is_terminal() {
        return Ok(false);
    }
    if img.width == 0 || img.height == 0 {
        return Err(Error::invalid(title, "empty image"));
    }
    println!("{title} ({}×{})", img.width, img.height);
    print_hdr_inline(img, protocol, width_cells, "--preview")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_parse_and_bad_ones_name_the_option() {
        assert_eq!(
            ProtocolChoice::parse("Sixel").unwrap(),
            ProtocolChoice::Sixel
        );
        assert_eq!(ProtocolChoice::parse("auto").unwrap(), ProtocolChoice::Auto);
        let e = ProtocolChoice::parse("png").unwrap_err().to_string();
        assert!(
            e.starts_with("--protocol:") && e.contains("halfblocks"),
            "{e}"
        );
    }

    #[test]
    fn a_forced_protocol_leaves_viuer_only_that_one() {
        let c = ProtocolChoice::Sixel.viuer_config(60, None);
        assert!(c.use_sixel && !c.use_kitty && !c.use_iterm);
        assert_eq!(c.width, Some(60));
        let c = ProtocolChoice::Halfblocks.viuer_config(80, None);
        assert!(!c.use_sixel && !c.use_kitty && !c.use_iterm);
        let c = ProtocolChoice::Auto.viuer_config(80, Some(20));
        assert!(c.use_sixel && c.use_kitty && c.use_iterm && !c.absolute_offset);
    }

    #[test]
    fn the_picture_is_the_srgb8_view() {
        let img = HdrImage::from_pixels(2, 1, vec![[0.18, 0.5, f32::NAN, 1.0], [2.0; 4]]);
        let rgb = srgb8_picture(&img);
        assert_eq!(rgb.get_pixel(0, 0).0, [118, 188, 0]);
        assert_eq!(rgb.get_pixel(1, 0).0, [255; 3]);
    }

    #[test]
    fn pictures_keep_their_aspect_in_any_cell_shape() {
        // A 3:2 picture 60 columns wide: 20 rows of 8 x 16 px cells (480 x 320 px), 25 rows of
        // wider 10 x 16 px cells (600 x 400 px), where a 1:2 guess would give 600 x 320.
        assert_eq!(picture_rows(768, 512, 60, Some((8, 16))), Some(20));
        assert_eq!(picture_rows(768, 512, 60, Some((10, 16))), Some(25));
        assert_eq!(picture_rows(768, 512, 60, None), None);
        assert_eq!(picture_rows(768, 512, 60, Some((0, 16))), None);
        assert_eq!(picture_rows(1000, 1, 10, Some((8, 16))), Some(1));
    }
}
