//! Decoders for what the TUI sends to the terminal, so tests can compare the pixels a terminal
//! would draw with the rendered image: DEC sixel
//! (palette definitions in RGB or HLS percent, repeats, carriage returns and line feeds, raster
//! attributes) and the kitty graphics protocol's direct transmission (`f=24`/`f=32` raw pixels,
//! `o=z` zlib compression, chunked with `m=1`). Both accept the tmux passthrough wrapping
//! (`ESC P tmux; … ESC \`, escapes doubled) the TUI uses inside tmux.

use crate::error::{Error, Result};
use base64::Engine as _;

/// A decoded picture: RGBA, rows from the top. Pixels a sixel image never paints stay
/// transparent (alpha 0).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DecodedImage {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) rgba: Vec<[u8; 4]>,
}

impl DecodedImage {
    pub(crate) fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        self.rgba[(y * self.width + x) as usize]
    }
}

/// Removes tmux passthrough wrappers: `ESC P tmux; <payload with ESC doubled> ESC \`.
pub(crate) fn unwrap_tmux(data: &str) -> String {
    let mut out = String::with_capacity(data.len());
    let mut rest = data;
    while let Some(start) = rest.find("\x1bPtmux;") {
        out.push_str(&rest[..start]);
        let body = &rest[start + 7..];
        // The wrapper ends at the first ESC \ whose ESC is not doubled.
        let bytes = body.as_bytes();
        let mut i = 0;
        let mut end = body.len();
        while i < bytes.len() {
            if bytes[i] == 0x1b {
                if bytes.get(i + 1) == Some(&0x1b) {
                    i += 2;
                    continue;
                }
                if bytes.get(i + 1) == Some(&b'\\') {
                    end = i;
                    break;
                }
            }
            i += 1;
        }
        out.push_str(&body[..end].replace("\x1b\x1b", "\x1b"));
        rest = body.get(end + 2..).unwrap_or("");
    }
    out.push_str(rest);
    out
}

/// HLS (hue in degrees, lightness and saturation in percent) to RGB 0–255, as DEC terminals
/// define it (hue 0 is blue).
fn hls_to_rgb(h: u32, l: u32, s: u32) -> [u8; 3] {
    let (l, s) = (l.min(100) as f64 / 100.0, s.min(100) as f64 / 100.0);
    // DEC's hue origin is blue; the usual HSL formula's is red: rotate by 240 degrees.
    let h = ((h as f64 + 240.0) % 360.0) / 360.0;
    let q = if l < 0.5 {
        l * (1.0 + s)
    } else {
        l + s - l * s
    };
    let p = 2.0 * l - q;
    let channel = |t: f64| {
        let t = t.rem_euclid(1.0);
        let v = if t < 1.0 / 6.0 {
            p + (q - p) * 6.0 * t
        } else if t < 0.5 {
            q
        } else if t < 2.0 / 3.0 {
            p + (q - p) * (2.0 / 3.0 - t) * 6.0
        } else {
            p
        };
        (v * 255.0).round() as u8
    };
    [channel(h + 1.0 / 3.0), channel(h), channel(h - 1.0 / 3.0)]
}

fn sixel_error(msg: &str) -> Error {
    Error::invalid("sixel", msg.to_string())
}

/// The body of the first sixel image in `data`: what follows `ESC P … q`, up to `ESC \`.
fn sixel_body(data: &str) -> Result<String> {
    let data = unwrap_tmux(data);
    let start = data
        .find("\x1bP")
        .ok_or_else(|| sixel_error("no DCS introducer (ESC P)"))?;
    let after = &data[start + 2..];
    let q = after
        .find('q')
        .ok_or_else(|| sixel_error("DCS without the sixel final character q"))?;
    let body = &after[q + 1..];
    Ok(body[..body.find("\x1b\\").unwrap_or(body.len())].to_string())
}

/// Reads a sixel body byte by byte, with its decimal parameters.
struct SixelReader<'a> {
    bytes: &'a [u8],
    i: usize,
}

impl SixelReader<'_> {
    fn next(&mut self) -> Option<u8> {
        let c = *self.bytes.get(self.i)?;
        self.i += 1;
        Some(c)
    }

    /// A decimal number (0 when there is none), saturating.
    fn number(&mut self) -> u32 {
        let mut v: u32 = 0;
        while let Some(d) = self.bytes.get(self.i).filter(|d| d.is_ascii_digit()) {
            v = v.saturating_mul(10).saturating_add((d - b'0') as u32);
            self.i += 1;
        }
        v
    }

    /// Numbers separated by `;` (at least one).
    fn numbers(&mut self) -> Vec<u32> {
        let mut v = vec![self.number()];
        while self.bytes.get(self.i) == Some(&b';') {
            self.i += 1;
            v.push(self.number());
        }
        v
    }
}

/// What a sixel body has painted so far: the palette, the cursor and the pixels set.
struct SixelCanvas {
    palette: Vec<[u8; 3]>,
    colour: usize,
    x: u32,
    y: u32,
    /// The raster attributes' size, if the image declares one.
    declared: Option<(u32, u32)>,
    pixels: std::collections::HashMap<(u32, u32), [u8; 3]>,
    max_x: u32,
    max_y: u32,
}

impl SixelCanvas {
    fn new() -> SixelCanvas {
        SixelCanvas {
            palette: vec![[0u8; 3]; 1024],
            colour: 0,
            x: 0,
            y: 0,
            declared: None,
            pixels: Default::default(),
            max_x: 0,
            max_y: 0,
        }
    }

    /// `# index` selects a colour; `# index ; 1|2 ; a ; b ; c` defines it (HLS or RGB percent)
    /// and selects it.
    fn colour_command(&mut self, v: &[u32]) {
        let idx = v[0] as usize % self.palette.len();
        if v.len() >= 5 {
            self.palette[idx] = match v[1] {
                1 => hls_to_rgb(v[2], v[3], v[4]),
                _ => [v[2], v[3], v[4]].map(|p| ((p.min(100) * 255 + 50) / 100) as u8),
            };
        }
        self.colour = idx;
    }

    /// Paints the six-pixel column `ch` at the cursor in the current colour and moves right.
    fn paint(&mut self, ch: u8) {
        let bits = ch - 0x3f;
        let rgb = self.palette[self.colour];
        for b in 0..6 {
            if bits & (1 << b) != 0 {
                self.pixels.insert((self.x, self.y + b), rgb);
                self.max_x = self.max_x.max(self.x + 1);
                self.max_y = self.max_y.max(self.y + b + 1);
            }
        }
        self.x += 1;
    }

    /// The picture: the declared size, else the painted extent.
    fn into_image(self) -> Result<DecodedImage> {
        let (width, height) = self
            .declared
            .filter(|(w, h)| *w > 0 && *h > 0)
            .unwrap_or((self.max_x, self.max_y));
        if width == 0 || height == 0 {
            return Err(sixel_error("the image paints no pixel"));
        }
        let mut rgba = vec![[0u8; 4]; width as usize * height as usize];
        for ((px, py), [r, g, b]) in self.pixels {
            if px < width && py < height {
                rgba[(py * width + px) as usize] = [r, g, b, 255];
            }
        }
        Ok(DecodedImage {
            width,
            height,
            rgba,
        })
    }
}

/// Decodes the first sixel image (`ESC P … q … ESC \`) in `data`.
pub(crate) fn decode_sixel(data: &str) -> Result<DecodedImage> {
    let body = sixel_body(data)?;
    let mut reader = SixelReader {
        bytes: body.as_bytes(),
        i: 0,
    };
    let mut canvas = SixelCanvas::new();
    while let Some(c) = reader.next() {
        match c {
            b'"' => {
                let v = reader.numbers();
                if v.len() >= 4 {
                    canvas.declared = Some((v[2], v[3]));
                }
            }
            b'#' => canvas.colour_command(&reader.numbers()),
            b'!' => {
                let n = reader.number();
                if let Some(ch) = reader.next() {
                    if (0x3f..=0x7e).contains(&ch) {
                        for _ in 0..n {
                            canvas.paint(ch);
                        }
                    }
                }
            }
            b'$' => canvas.x = 0,
            b'-' => {
                canvas.x = 0;
                canvas.y += 6;
            }
            0x3f..=0x7e => canvas.paint(c),
            _ => {}
        }
    }
    canvas.into_image()
}

/// Decodes the first kitty graphics transmission (`ESC _ G keys ; base64 ESC \`, possibly
/// chunked with `m=1`) in `data`: raw RGB (`f=24`) or RGBA (`f=32`), optionally `o=z`.
pub(crate) fn decode_kitty(data: &str) -> Result<DecodedImage> {
    let data = unwrap_tmux(data);
    let bad = |msg: String| Error::invalid("kitty", msg);
    let mut keys: Vec<(String, String)> = Vec::new();
    let mut payload = String::new();
    let mut rest = data.as_str();
    let mut first = true;
    while let Some(start) = rest.find("\x1b_G") {
        let body = &rest[start + 3..];
        let end = body
            .find("\x1b\\")
            .ok_or_else(|| bad("unterminated APC (no ESC \\)".into()))?;
        let chunk = &body[..end];
        rest = &body[end + 2..];
        let (k, p) = chunk.split_once(';').unwrap_or((chunk, ""));
        let chunk_keys: Vec<(String, String)> = k
            .split(',')
            .filter_map(|kv| kv.split_once('='))
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        if first {
            keys = chunk_keys.clone();
            first = false;
        }
        payload.push_str(p);
        let more = chunk_keys.iter().any(|(k, v)| k == "m" && v == "1");
        if !more {
            break;
        }
    }
    if first {
        return Err(bad("no kitty graphics command (ESC _ G)".into()));
    }
    let key = |name: &str| {
        keys.iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    };
    let num = |name: &str| -> Result<u32> {
        key(name)
            .ok_or_else(|| bad(format!("missing key {name}")))?
            .parse()
            .map_err(|_| bad(format!("key {name} is not a number")))
    };
    let format = key("f").unwrap_or("32");
    let (width, height) = (num("s")?, num("v")?);
    let mut bytes = base64::engine::general_purpose::STANDARD
        .decode(payload.as_bytes())
        .map_err(|e| bad(format!("payload is not base64: {e}")))?;
    if key("o") == Some("z") {
        use std::io::Read;
        let mut inflated = Vec::new();
        flate2::read::ZlibDecoder::new(&bytes[..])
            .read_to_end(&mut inflated)
            .map_err(|e| bad(format!("o=z payload does not inflate: {e}")))?;
        bytes = inflated;
    }
    let channels = match format {
        "24" => 3,
        "32" => 4,
        other => return Err(bad(format!("f={other} is not raw RGB/RGBA"))),
    };
    let n = width as usize * height as usize;
    if bytes.len() != n * channels {
        return Err(bad(format!(
            "{} bytes for {width}x{height} at {channels} bytes per pixel",
            bytes.len()
        )));
    }
    let rgba = bytes
        .chunks_exact(channels)
        .map(|c| [c[0], c[1], c[2], if channels == 4 { c[3] } else { 255 }])
        .collect();
    Ok(DecodedImage {
        width,
        height,
        rgba,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixel_by_hand_with_repeats_palette_and_rows() {
        // 2 colours, 3 px wide, 7 px tall: row band 0 all 6 bits of colour 1 ('~'), band 1 one
        // pixel high of colour 2 ('@' = bit 0), declared 3 x 7.
        let s = "\x1bPq\"1;1;3;7#1;2;100;0;0#2;2;0;0;100#1!3~-#2@@@\x1b\\";
        let d = decode_sixel(s).unwrap();
        assert_eq!((d.width, d.height), (3, 7));
        assert_eq!(d.pixel(2, 5), [255, 0, 0, 255]);
        assert_eq!(d.pixel(1, 6), [0, 0, 255, 255]);
        // HLS: hue 120 is red in DEC's wheel, lightness 50, saturation 100.
        assert_eq!(hls_to_rgb(120, 50, 100), [255, 0, 0]);
        assert_eq!(hls_to_rgb(0, 50, 100), [0, 0, 255]);
    }

    #[test]
    fn tmux_passthrough_is_unwrapped() {
        let inner = "\x1bPq#0;2;0;100;0#0~\x1b\\";
        let wrapped = format!("\x1bPtmux;{}\x1b\\", inner.replace('\x1b', "\x1b\x1b"));
        assert_eq!(unwrap_tmux(&wrapped), inner);
        let d = decode_sixel(&wrapped).unwrap();
        assert_eq!(d.pixel(0, 3), [0, 255, 0, 255]);
    }

    #[test]
    fn kitty_chunks_and_compression_round_trip() {
        use std::io::Write;
        let rgba: Vec<u8> = (0..4 * 3 * 2).map(|i| (i * 7) as u8).collect();
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&rgba).unwrap();
        let b64 = base64::engine::general_purpose::STANDARD.encode(z.finish().unwrap());
        let (a, b) = b64.split_at(8);
        let s = format!("\x1b_Gq=2,a=T,f=32,s=3,v=2,o=z,m=1;{a}\x1b\\\x1b_Gm=0;{b}\x1b\\");
        let d = decode_kitty(&s).unwrap();
        assert_eq!((d.width, d.height), (3, 2));
        assert_eq!(d.pixel(1, 1), [112, 119, 126, 133]); // pixel 4: bytes 16..20, times 7
        assert!(
            decode_kitty("\x1b_Gf=32,s=2,v=2;AAAA\x1b\\").is_err(),
            "size mismatch"
        );
    }
}
