//! Figure drawing into images, with no I/O: text in the embedded DejaVu Sans typeface, number formats
//! and round tick values, colour bars and legends (`text`), and the frame of a map or section
//! with its ticks, graticule labels, titles and scale bar (`map_frame`).

pub(crate) mod map_frame;
pub mod text;
