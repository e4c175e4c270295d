//! Sixel pictures for the TUI. The tone-mapped picture is reduced to a palette of at most 256
//! colours at the size it was tone-mapped at (quantette: Wu's quantiser in Oklab and
//! Floyd–Steinberg dithering, on every core), enlarged to the size shown by repeating palette
//! indices, and written as DEC sixel bands, each band on its own thread and each colour of a
//! band only where it appears. ratatui-image's own sixel path (icy_sixel, the same quantiser
//! and dithering) works on one thread on the enlarged picture, up to three times the pixels,
//! and walks every colour across the whole width of every band; a sixel key cost 50–150 ms
//! more than the same key with kitty at 160 × 50 cells and larger.

use super::view::enlarge_nearest_raw;
use quantette::deps::palette::Srgb;
use quantette::dither::FloydSteinberg;
use quantette::{ImageRef, PaletteSize, Pipeline};
use rayon::prelude::*;
use std::fmt::Write as _;

/// A picture as palette indices.
pub(crate) struct Indexed {
    pub palette: Vec<[u8; 3]>,
    /// One index into `palette` per pixel, rows from the top.
    pub indices: Vec<u8>,
    pub width: u32,
    pub height: u32,
}

impl Indexed {
    /// `img` reduced to at most 256 colours, dithered.
    pub(crate) fn quantise(img: &image::RgbImage) -> Indexed {
        let (width, height) = img.dimensions();
        let pixels: Vec<Srgb<u8>> = img.pixels().map(|p| Srgb::new(p[0], p[1], p[2])).collect();
        let Ok(image) = ImageRef::new(width, height, &pixels) else {
            // Empty (or beyond quantette's 2^32 pixels, which no terminal shows): black.
            let n = width as usize * height as usize;
            return Indexed {
                palette: vec![[0; 3]],
                indices: vec![0; n],
                width,
                height,
            };
        };
        let (palette, indices) = Pipeline::new()
            .palette_size(PaletteSize::MAX)
            .ditherer(FloydSteinberg::new())
            .parallel(true)
            .input_image(image)
            .output_srgb8_indexed_image()
            .into_parts();
        Indexed {
            palette: palette.iter().map(|c| [c.red, c.green, c.blue]).collect(),
            indices,
            width,
            height,
        }
    }

    /// The picture enlarged to `w` × `h` by repeating indices, as
    /// [`super::view::enlarge_nearest`] repeats pixels.
    pub(crate) fn enlarged(self, w: u32, h: u32) -> Indexed {
        if (w, h) == (self.width, self.height) {
            return self;
        }
        Indexed {
            indices: enlarge_nearest_raw(&self.indices, self.width, self.height, 1, w, h),
            width: w,
            height: h,
            ..self
        }
    }

    /// The sixel image (`ESC P 9;1;0 q` … `ESC \`): square pixels, the raster size, the
    /// palette in percent, then the bands of six rows.
    pub(crate) fn sixel(&self) -> String {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut out = format!("\x1bP9;1;0q\"1;1;{w};{h}");
        for (i, c) in self.palette.iter().enumerate() {
            let [r, g, b] = c.map(|v| (u32::from(v) * 100 + 127) / 255);
            let _ = write!(out, "#{i};2;{r};{g};{b}");
        }
        let bands: Vec<String> = (0..h.div_ceil(6))
            .into_par_iter()
            .map_init(
                || vec![Vec::new(); self.palette.len()],
                |runs, band| self.band(band, runs),
            )
            .collect();
        for band in &bands {
            out.push_str(band);
        }
        out.push_str("\x1b\\");
        out
    }

    /// One band of six rows: for each colour present, in palette order, `#colour`, its sixels
    /// from its first column to its last (gaps and repeats run-length coded), `$` (back to the
    /// band's start); then `-` (the next band). `columns` is scratch space, one list per colour
    /// of (column, six-bit mask) in column order.
    fn band(&self, band: usize, columns: &mut [Vec<(u32, u8)>]) -> String {
        let w = self.width as usize;
        let rows = band * 6..(band * 6 + 6).min(self.height as usize);
        for list in columns.iter_mut() {
            list.clear();
        }
        for x in 0..w {
            for (bit, y) in rows.clone().enumerate() {
                let list = &mut columns[usize::from(self.indices[y * w + x])];
                match list.last_mut() {
                    Some((at, mask)) if *at == x as u32 => *mask |= 1 << bit,
                    _ => list.push((x as u32, 1 << bit)),
                }
            }
        }
        let mut out = String::new();
        for (colour, list) in columns.iter().enumerate() {
            if list.is_empty() {
                continue;
            }
            let _ = write!(out, "#{colour}");
            let mut x = 0;
            let mut i = 0;
            while i < list.len() {
                let (at, mask) = list[i];
                push_run(&mut out, at - x, 0);
                let mut n = 1;
                while i + n < list.len() && list[i + n] == (at + n as u32, mask) {
                    n += 1;
                }
                push_run(&mut out, n as u32, mask);
                x = at + n as u32;
                i += n;
            }
            out.push('$');
        }
        out.push('-');
        out
    }
}

/// `n` sixels of `mask` (bit k: row k of the band): `!n` and the sixel where that is shorter.
fn push_run(out: &mut String, n: u32, mask: u8) {
    let sixel = char::from(63 + mask);
    if n > 3 {
        let _ = write!(out, "!{n}{sixel}");
    } else {
        for _ in 0..n {
            out.push(sixel);
        }
    }
}

/// What ratatui-image's sixel widget draws for a sixel image over `cells` (columns, rows): the
/// cells erased first (a sixel does not clear what is under it), then the image; inside tmux
/// both are wrapped in one passthrough sequence, as ratatui-image wraps its own.
pub(crate) fn widget_data(sixel: &str, cells: (u16, u16), is_tmux: bool) -> String {
    let (start, escape, end) = if is_tmux {
        ("\x1bPtmux;", "\x1b\x1b", "\x1b\\")
    } else {
        ("", "\x1b", "")
    };
    let (width, height) = cells;
    let mut data = String::with_capacity(sixel.len() + 16 * usize::from(height) + 32);
    data.push_str(start);
    if height == 1 {
        let _ = write!(data, "{escape}[{width}X");
    } else {
        for _ in 0..height {
            let _ = write!(data, "{escape}[{width}X{escape}[1B");
        }
        let _ = write!(data, "{escape}[{height}A");
    }
    data.push_str(escape);
    data.push_str(sixel.strip_prefix('\x1b').unwrap_or(sixel));
    data.push_str(end);
    data
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::decode::decode_sixel;

    #[test]
    fn bands_code_gaps_and_repeats_and_decode_to_the_indices() {
        // 9 x 8: two bands (the second of two rows); colour 1 only in columns 2..=7 of row 0,
        // colour 2 a single pixel, the rest colour 0.
        let (w, h) = (9u32, 8u32);
        let mut indices = vec![0u8; (w * h) as usize];
        indices[2..8].fill(1);
        indices[(7 * w + 4) as usize] = 2;
        let picture = Indexed {
            palette: vec![[0, 0, 0], [255, 0, 0], [51, 102, 255]],
            indices,
            width: w,
            height: h,
        };
        let sixel = picture.sixel();
        // Colour 1 in band 0: two empty columns, then six sixels of row 0 (`@`) as one run.
        assert!(sixel.contains("#1??!6@$"), "{sixel}");
        // Colour 2 in band 1: four empty columns, then row 1 of the band (`A`).
        assert!(sixel.contains("#2!4?A$"), "{sixel}");
        let decoded = decode_sixel(&sixel).unwrap();
        assert_eq!((decoded.width, decoded.height), (w, h));
        for y in 0..h {
            for x in 0..w {
                let c = picture.palette[usize::from(picture.indices[(y * w + x) as usize])];
                assert_eq!(&decoded.pixel(x, y)[..3], &c[..], "({x}, {y})");
            }
        }
    }

    #[test]
    fn the_widget_wraps_a_picture_as_ratatui_images_own_sixel_does() {
        use ratatui::layout::Size;
        use ratatui_image::protocol::sixel::Sixel;
        // Only the image between the wrapping differs (its own encoder, its own palette).
        let img = image::RgbImage::from_fn(20, 40, |x, y| image::Rgb([x as u8 * 9, y as u8, 40]));
        let ours = Indexed::quantise(&img).sixel();
        for (cells, tmux) in [
            ((2, 2), false),
            ((2, 2), true),
            ((2, 1), true),
            ((3, 1), false),
        ] {
            let size = Size::new(cells.0, cells.1);
            let theirs = Sixel::new(image::DynamicImage::ImageRgb8(img.clone()), size, tmux)
                .unwrap()
                .data;
            let mine = widget_data(&ours, cells, tmux);
            // Up to and including the escape that opens the image's DCS ("ESC P" or, doubled
            // inside tmux's passthrough, "ESC ESC P").
            let head = |d: &str| {
                let at = d.find("P9;1;0q").or_else(|| d.find("P0;1;0q")).unwrap();
                d[..at].to_string()
            };
            // The last band's end, the image's terminator and (tmux) the passthrough's.
            let tail = |d: &str| d[d.len() - if tmux { 6 } else { 4 }..].to_string();
            assert_eq!(head(&mine), head(&theirs), "{cells:?} tmux {tmux}");
            assert_eq!(tail(&mine), tail(&theirs), "{cells:?} tmux {tmux}");
        }
    }

    #[test]
    fn an_enlarged_picture_repeats_indices_as_pixels_repeat() {
        let img =
            image::RgbImage::from_fn(7, 5, |x, y| image::Rgb([x as u8 * 30, y as u8 * 50, 9]));
        let small = Indexed::quantise(&img);
        // The indices as a picture, enlarged as pixels are, must be the enlarged indices.
        let coded = image::RgbImage::from_fn(7, 5, |x, y| {
            image::Rgb([small.indices[(y * 7 + x) as usize], 0, 0])
        });
        let expected = crate::tui::view::enlarge_nearest(&coded, 16, 11);
        let big = small.enlarged(16, 11);
        assert_eq!((big.width, big.height), (16, 11));
        let got: Vec<u8> = expected.pixels().map(|p| p[0]).collect();
        assert_eq!(big.indices, got);
    }
}
