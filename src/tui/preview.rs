//! `hdrvis run --preview`: after a script run, its result images are printed inline once,
//! for non-interactive use (a job log viewed in a terminal, a quick look over SSH). Printing is
//! viuer's (kitty, iTerm2, sixel, else half blocks), restricted to the protocol `--protocol` /
//! `HDRVIS_TUI_PROTOCOL` names when one is given. HDR images show as the plain 0 EV view,
//! tone-mapped ones as they are.

use crate::error::{Error, Result};
use crate::model::HdrImage;
use crate::tui::protocol::ProtocolChoice;
use crate::tui::view::{display_image, to_rgb8, ViewSettings};

/// Prints `img` inline, `width_cells` columns wide, with the title above it. Returns `false`
/// (printing nothing) when stdout is not a terminal.
pub fn print_inline(
    img: &HdrImage,
    title: &str,
    protocol: ProtocolChoice,
    width_cells: u32,
) -> Result<bool> {
    use std::io::IsTerminal;
    if !std::io::stdout().is_terminal() {
        return Ok(false);
    }
    if img.width == 0 || img.height == 0 {
        return Err(Error::invalid(title, "empty image"));
    }
    let shown = if crate::tonemap::is_display_referred(img) {
        img.clone()
    } else {
        display_image(img, &ViewSettings::default())?
    };
    let rgb = to_rgb8(&shown);
    let (kitty, iterm, sixel) = match protocol {
        ProtocolChoice::Auto => (true, true, true),
        ProtocolChoice::Kitty => (true, false, false),
        ProtocolChoice::Iterm2 => (false, true, false),
        ProtocolChoice::Sixel => (false, false, true),
        ProtocolChoice::Halfblocks => (false, false, false),
    };
    let config = viuer::Config {
        absolute_offset: false,
        width: Some(width_cells),
        use_kitty: kitty,
        use_iterm: iterm,
        use_sixel: sixel,
        ..Default::default()
    };
    println!("{title} ({}×{})", img.width, img.height);
    viuer::print(&image::DynamicImage::ImageRgb8(rgb), &config)
        .map_err(|e| Error::invalid("--preview", format!("terminal preview failed: {e}")))?;
    Ok(true)
}
