//! `hdrvis animate 'out/orbit/*.png' -o orbit.mp4`: numbered frames (PNG files) as one movie,
//! through the library's [`hdrvis::io::animation`].

use hdrvis::io::animation::{expand_frames, read_png_frame, write_animation};
use hdrvis::Result;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct AnimateArgs {
    /// Frames: PNG files, or quoted patterns such as 'out/orbit/*.png' (expanded in natural
    /// order: az45 before az135); arguments keep their order.
    #[arg(required = true, value_name = "FRAMES")]
    pub frames: Vec<String>,
    /// The movie: .mp4 or .webm (through ffmpeg), .gif or .png (animated PNG).
    #[arg(long, short)]
    pub output: PathBuf,
    /// Frames per second.
    #[arg(long, default_value_t = 12.0)]
    pub fps: f64,
}

/// Encodes the frames, decoding one PNG at a time, and returns the number of frames.
pub fn run_animate(args: &AnimateArgs) -> Result<usize> {
    let mut paths = Vec::new();
    for pattern in &args.frames {
        paths.extend(expand_frames(pattern)?);
    }
    write_animation(&args.output, paths.len(), args.fps, |i| {
        read_png_frame(&paths[i])
    })?;
    Ok(paths.len())
}
