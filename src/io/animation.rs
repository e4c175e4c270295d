//! Movies of sweeps: a sequence of frames (images of a script, or PNG files) written as one
//! animation. MP4 (H.264) and WebM (VP9) go through the system's `ffmpeg`, fed raw RGB frames on
//! its standard input; animated PNG (the `png` crate) and GIF (the `image` crate) are written in
//! pure Rust. Frames are made one at a time by the caller and streamed to the encoder, never
//! held together. The movie appears under its name only when the encode finished: it is written
//! to a `.hdrvis-*.tmp` file beside it and renamed, as every output is (see [`super::write_atomic`]).

use crate::error::{Error, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// One frame as 8-bit sRGB, rows top to bottom.
pub struct RgbFrame {
    pub width: u32,
    pub height: u32,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
}

/// The containers [`write_animation`] writes, chosen by the output's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MovieFormat {
    Mp4,
    WebM,
    Gif,
    /// Animated PNG (`.png` or `.apng`).
    Apng,
}

impl MovieFormat {
    /// The format of an output path, or a one-line error naming the extensions known.
    pub fn of(path: &Path) -> Result<MovieFormat> {
        match super::extension(path).as_str() {
            "mp4" => Ok(MovieFormat::Mp4),
            "webm" => Ok(MovieFormat::WebM),
            "gif" => Ok(MovieFormat::Gif),
            "png" | "apng" => Ok(MovieFormat::Apng),
            other => Err(Error::invalid(
                "path",
                format!(
                    "{}: unknown movie extension {other:?}; expected .mp4, .webm (through ffmpeg), .gif or .png (animated PNG)",
                    path.display()
                ),
            )),
        }
    }

    /// Whether this format is encoded by the system's `ffmpeg`.
    pub fn needs_ffmpeg(self) -> bool {
        matches!(self, MovieFormat::Mp4 | MovieFormat::WebM)
    }
}

/// Whether an `ffmpeg` that runs is on the `PATH`.
pub(crate) fn ffmpeg_available() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// That the movie `path` can be written here: a known extension, and ffmpeg installed where the
/// format needs it (a one-line error naming the path and the fix otherwise).
pub(crate) fn check_encoder(path: &Path) -> Result<()> {
    let format = MovieFormat::of(path)?;
    if format.needs_ffmpeg() && !ffmpeg_available() {
        return Err(Error::invalid(
            "path",
            format!(
                "{}: writing .{} needs ffmpeg, which is not installed (Debian: apt install ffmpeg); .png (animated PNG) and .gif need nothing",
                path.display(),
                super::extension(path)
            ),
        ));
    }
    Ok(())
}

/// Writes `count` frames, made in order by `frame(i)`, as the movie `path` at `fps` frames per
/// second. All frames must have the first one's size.
pub fn write_animation(
    path: &Path,
    count: usize,
    fps: f64,
    mut frame: impl FnMut(usize) -> Result<RgbFrame>,
) -> Result<()> {
    let format = MovieFormat::of(path)?;
    if count == 0 {
        return Err(Error::invalid("frames", "expected at least one frame"));
    }
    if !(fps.is_finite() && (0.1..=1000.0).contains(&fps)) {
        return Err(Error::invalid(
            "fps",
            format!("expected frames per second in [0.1, 1000], got {fps}"),
        ));
    }
    check_encoder(path)?;
    let first = frame(0)?;
    let (width, height) = (first.width, first.height);
    if width == 0 || height == 0 || first.rgb.len() != (width * height * 3) as usize {
        return Err(Error::invalid("frames", "frame 0 is empty"));
    }
    // Frame 0 is already made; later ones are made when the encoder asks and checked for size.
    let mut pending = Some(first);
    let mut next = |i: usize| -> Result<RgbFrame> {
        let f = match pending.take() {
            Some(f) => f,
            None => frame(i)?,
        };
        if (f.width, f.height) != (width, height) {
            return Err(Error::invalid(
                "frames",
                format!(
                    "frame {i} is {}x{}, frame 0 is {width}x{height}; a movie's frames share one size",
                    f.width, f.height
                ),
            ));
        }
        Ok(f)
    };
    match format {
        MovieFormat::Apng => super::write_atomic(path, |w| {
            write_apng(w, path, (width, height), count, fps, &mut next)
        }),
        MovieFormat::Gif => super::write_atomic(path, |w| {
            write_gif(w, path, (width, height), count, fps, &mut next)
        }),
        MovieFormat::Mp4 | MovieFormat::WebM => {
            encode_with_ffmpeg(path, format, (width, height), count, fps, &mut next)
        }
    }
}

/// Animated PNG, looping forever, each frame shown 1/fps s (in milliseconds).
fn write_apng(
    w: &mut dyn Write,
    path: &Path,
    (width, height): (u32, u32),
    count: usize,
    fps: f64,
    next: &mut dyn FnMut(usize) -> Result<RgbFrame>,
) -> Result<()> {
    let bad = |e: png::EncodingError| Error::format(path, format!("cannot encode APNG: {e}"));
    let mut encoder = png::Encoder::new(w, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let frames = u32::try_from(count).map_err(|_| Error::invalid("frames", "too many"))?;
    encoder.set_animated(frames, 0).map_err(bad)?;
    let delay_ms = (1000.0 / fps).round().clamp(1.0, u16::MAX as f64) as u16;
    encoder.set_frame_delay(delay_ms, 1000).map_err(bad)?;
    let mut writer = encoder.write_header().map_err(bad)?;
    for i in 0..count {
        writer.write_image_data(&next(i)?.rgb).map_err(bad)?;
    }
    writer.finish().map_err(bad)
}

/// GIF, looping forever: each frame quantised to its own 256-colour palette (NeuQuant).
fn write_gif(
    w: &mut dyn Write,
    path: &Path,
    (width, height): (u32, u32),
    count: usize,
    fps: f64,
    next: &mut dyn FnMut(usize) -> Result<RgbFrame>,
) -> Result<()> {
    use image::codecs::gif::{GifEncoder, Repeat};
    let bad = |e: image::ImageError| Error::format(path, format!("cannot encode GIF: {e}"));
    let mut encoder = GifEncoder::new_with_speed(w, 10);
    encoder.set_repeat(Repeat::Infinite).map_err(bad)?;
    let delay = image::Delay::from_numer_denom_ms((1000.0 / fps).round().max(1.0) as u32, 1);
    for i in 0..count {
        let rgb = next(i)?.rgb;
        let rgba: Vec<u8> = rgb
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect();
        let buffer = image::RgbaImage::from_raw(width, height, rgba)
            .ok_or_else(|| Error::invalid("frames", format!("frame {i} has the wrong length")))?;
        let frame = image::Frame::from_parts(buffer, 0, 0, delay);
        encoder.encode_frame(frame).map_err(bad)?;
    }
    Ok(())
}

/// The codec arguments of `ffmpeg` for a format: H.264 or VP9 in 4:2:0, which every player
/// reads (odd sizes are padded to even ones, as 4:2:0 needs).
fn ffmpeg_codec_args(format: MovieFormat) -> &'static [&'static str] {
    match format {
        MovieFormat::WebM => &[
            "-c:v",
            "libvpx-vp9",
            "-b:v",
            "0",
            "-crf",
            "32",
            "-row-mt",
            "1",
            "-pix_fmt",
            "yuv420p",
            "-f",
            "webm",
        ],
        _ => &[
            "-c:v", "libx264", "-crf", "18", "-pix_fmt", "yuv420p", "-f", "mp4",
        ],
    }
}

/// Streams raw RGB frames into `ffmpeg`'s standard input, which encodes into a temporary file
/// beside `path`; the file is renamed to `path` only when ffmpeg ends successfully.
fn encode_with_ffmpeg(
    path: &Path,
    format: MovieFormat,
    (width, height): (u32, u32),
    count: usize,
    fps: f64,
    next: &mut dyn FnMut(usize) -> Result<RgbFrame>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let tmp = super::temporary_beside(&dir)?;
    let mut child = Command::new("ffmpeg")
        .args(["-hide_banner", "-loglevel", "error", "-y"])
        .args(["-f", "rawvideo", "-pix_fmt", "rgb24"])
        .args(["-s", &format!("{width}x{height}")])
        .args(["-framerate", &format!("{fps}"), "-i", "-"])
        .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
        .args(ffmpeg_codec_args(format))
        .arg(tmp.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error::io("ffmpeg", e))?;
    // ffmpeg's messages are read on the side, so a full stderr pipe can never stall it.
    let mut stderr = child.stderr.take().expect("stderr is piped");
    let messages = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = stderr.read_to_string(&mut text);
        text
    });
    let mut stdin = child.stdin.take().expect("stdin is piped");
    let fed = (0..count).try_for_each(|i| {
        let rgb = next(i)?.rgb;
        stdin.write_all(&rgb).map_err(|e| Error::io("ffmpeg", e))
    });
    drop(stdin);
    let status = child.wait().map_err(|e| Error::io("ffmpeg", e));
    let messages = messages.join().unwrap_or_default();
    let last = messages.lines().rev().find(|l| !l.trim().is_empty());
    match (fed, status) {
        (Ok(()), Ok(s)) if s.success() => super::persist(tmp, path),
        // A frame that could not be made is the cause, not the broken pipe it leaves.
        (Err(e), _) if !matches!(e, Error::Io { .. }) => Err(e),
        (_, status) => Err(Error::format(
            path,
            format!(
                "ffmpeg failed ({}): {}",
                status.map_or_else(|e| e.to_string(), |s| s.to_string()),
                last.unwrap_or("no message")
            ),
        )),
    }
}

/// Decodes a PNG file into an [`RgbFrame`] (any colour type; alpha is dropped).
pub fn read_png_frame(path: &Path) -> Result<RgbFrame> {
    let img = image::ImageReader::open(path)
        .map_err(|e| Error::io(path, e))?
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?
        .decode()
        .map_err(|e| Error::format(path, format!("cannot decode image: {e}")))?
        .to_rgb8();
    Ok(RgbFrame {
        width: img.width(),
        height: img.height(),
        rgb: img.into_raw(),
    })
}

/// The frames an `animate` argument names: an existing file as it is, else a pattern whose last
/// component may hold `*` and `?`, expanded to the matching files in natural order (digit runs
/// compared as numbers, so `az45.png` comes before `az135.png`). A pattern that matches nothing
/// is an error.
pub fn expand_frames(pattern: &str) -> Result<Vec<PathBuf>> {
    let as_path = Path::new(pattern);
    if as_path.is_file() {
        return Ok(vec![as_path.to_path_buf()]);
    }
    let name = as_path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    let dir = match as_path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if dir.to_string_lossy().contains(['*', '?']) {
        return Err(Error::invalid(
            "frames",
            format!("{pattern}: wildcards may stand only in the file name"),
        ));
    }
    let mut found: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.is_file())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| wildcard_match(name, n))
            })
            .collect(),
        Err(_) => Vec::new(),
    };
    if found.is_empty() {
        return Err(Error::invalid(
            "frames",
            format!("{pattern}: no such file, and no file matches it as a pattern"),
        ));
    }
    found.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(found)
}

/// Whether `name` matches `pattern`, where `*` is any run of characters and `?` any one.
fn wildcard_match(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    // Greedy matching with one back-track point, the last `*` seen.
    let (mut pi, mut ni, mut star, mut mark) = (0, 0, None, 0);
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some(pi);
            pi += 1;
            mark = ni;
        } else if let Some(s) = star {
            pi = s + 1;
            mark += 1;
            ni = mark;
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// Orders names with their digit runs compared as numbers: `f2` < `f10`, `az45` < `az135`.
fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for i in 1..=bytes.len() {
            if i == bytes.len() || bytes[i].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..i]));
                start = i;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (x, y) in ca.iter().zip(&cb) {
        let order = match (x, y) {
            ((true, dx), (true, dy)) => {
                let (tx, ty) = (dx.trim_start_matches('0'), dy.trim_start_matches('0'));
                tx.len()
                    .cmp(&ty.len())
                    .then(tx.cmp(ty))
                    .then(dx.len().cmp(&dy.len()))
            }
            ((_, sx), (_, sy)) => sx.cmp(sy),
        };
        if order.is_ne() {
            return order;
        }
    }
    ca.len().cmp(&cb.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_and_natural_order() {
        assert!(wildcard_match("az*.png", "az135.png"));
        assert!(wildcard_match("*", ""));
        assert!(wildcard_match("f?.png", "f1.png"));
        assert!(!wildcard_match("f?.png", "f10.png"));
        assert!(wildcard_match("*a*b", "xxaxxbxb"));
        assert!(!wildcard_match("*.png", "x.exr"));
        let mut names = vec!["az90.png", "az135.png", "az0.png", "az45.png", "az315.png"];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            names,
            ["az0.png", "az45.png", "az90.png", "az135.png", "az315.png"]
        );
        // Equal numbers differing in leading zeros still order, and text breaks ties.
        assert!(natural_cmp("f007", "f7").is_gt());
        assert!(natural_cmp("a2b", "a2c").is_lt());
    }

    fn gradient(i: usize, (w, h): (u32, u32)) -> RgbFrame {
        let rgb = (0..w * h)
            .flat_map(|p| [(p % w * 4) as u8, (p / w * 5) as u8, (i * 7) as u8])
            .collect();
        RgbFrame {
            width: w,
            height: h,
            rgb,
        }
    }

    #[test]
    fn apng_decodes_back_to_every_frame() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        write_animation(&path, 5, 10.0, |i| Ok(gradient(i, (16, 12)))).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let control = reader.info().animation_control.unwrap();
        assert_eq!((control.num_frames, control.num_plays), (5, 0));
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        for i in 0..5 {
            reader.next_frame(&mut buf).unwrap();
            let fc = reader.info().frame_control.unwrap();
            assert_eq!((fc.delay_num, fc.delay_den), (100, 1000));
            assert_eq!(buf, gradient(i, (16, 12)).rgb, "frame {i}");
        }
    }

    #[test]
    fn bad_frames_leave_no_movie() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.gif");
        let err = write_animation(&path, 3, 12.0, |i| {
            Ok(gradient(i, if i == 2 { (8, 8) } else { (16, 12) }))
        })
        .unwrap_err();
        assert!(
            err.to_string().contains("frame 2 is 8x8, frame 0 is 16x12"),
            "{err}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let err = write_animation(&dir.path().join("m.avi"), 1, 12.0, |i| {
            Ok(gradient(i, (4, 4)))
        })
        .unwrap_err();
        assert!(err.to_string().contains("expected .mp4, .webm"), "{err}");
    }

    #[test]
    fn gif_holds_every_frame() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.gif");
        write_animation(&path, 4, 20.0, |i| Ok(gradient(i, (16, 12)))).unwrap();
        use image::AnimationDecoder;
        let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let frames = image::codecs::gif::GifDecoder::new(file)
            .unwrap()
            .into_frames()
            .collect_frames()
            .unwrap();
        assert_eq!(frames.len(), 4);
        let (num, den) = frames[1].delay().numer_denom_ms();
        assert_eq!(num as f64 / den as f64, 50.0);
        assert_eq!(frames[3].buffer().dimensions(), (16, 12));
    }
}
