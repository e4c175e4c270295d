//! OpenEXR through the `exr` crate: the linear master of every render. Images are written with
//! 32-bit float channels R, G, B, A plus any extra named channels, and text attributes recording
//! provenance (dataset, camera, transfer function, precision, adapter). Reading accepts RGB(A)
//! in half or float from any producer, luminance (Y) and luminance-chroma (Y, RY, BY) images and
//! files with only some colour channels, and refuses truncated files.

use crate::error::{Error, Result};
use crate::model::HdrImage;
use exr::meta::attribute::Chromaticities;
use exr::prelude::*;
use std::borrow::Cow;
use std::path::Path;

/// EXR text attributes are Latin-1; anything else becomes '?' rather than failing the write.
fn text(s: &str) -> Text {
    let ascii: String = s
        .chars()
        .map(|c| {
            if c.is_ascii() && !c.is_ascii_control() {
                c
            } else {
                '?'
            }
        })
        .collect();
    Text::new_or_none(&ascii).unwrap_or_else(|| Text::new_or_none("?").expect("ascii text"))
}

/// Attribute names must not collide with the standard ones, so provenance lives under "hdrvis:".
fn attribute_name(key: &str) -> Text {
    text(&format!("hdrvis:{key}"))
}

/// How [`write_exr_with`] stores an image. The default is what renders are kept as: 32-bit
/// float R, G, B, A, ZIP-compressed (lossless, the usual size-for-speed balance).
#[derive(Clone, Copy, Debug)]
pub struct ExrWrite {
    pub compression: Compression,
    /// R, G, B (and A) as 16-bit half floats: a relative step of 2⁻¹¹, ample for
    /// display-referred values in [0, 1], and half the bytes to compress.
    pub half: bool,
    /// Write A even where every pixel is opaque (readers take a missing A as 1).
    pub keep_opaque_alpha: bool,
}

impl Default for ExrWrite {
    fn default() -> Self {
        ExrWrite {
            compression: Compression::ZIP16,
            half: false,
            keep_opaque_alpha: true,
        }
    }
}

/// EXR compression methods by the names OpenEXR's tools use: none, rle, zips, zip and piz are
/// lossless; pxr24, b44 and b44a lossy.
pub const EXR_COMPRESSION_NAMES: [&str; 8] =
    ["none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a"];

impl ExrWrite {
    /// The compression method named `name` (one of [`EXR_COMPRESSION_NAMES`]).
    pub fn compression_named(name: &str) -> Result<Compression> {
        Ok(match name.to_ascii_lowercase().as_str() {
            "none" => Compression::Uncompressed,
            "rle" => Compression::RLE,
            "zips" => Compression::ZIP1,
            "zip" => Compression::ZIP16,
            "piz" => Compression::PIZ,
            "pxr24" => Compression::PXR24,
            "b44" => Compression::B44,
            "b44a" => Compression::B44A,
            _ => {
                return Err(Error::invalid(
                    "compression",
                    format!(
                        "unknown EXR compression {name:?}; known: {}",
                        EXR_COMPRESSION_NAMES.join(", ")
                    ),
                ));
            }
        })
    }
}

/// Writes `image` as 32-bit float RGBA, ZIP-compressed, with its extra channels and provenance.
pub fn write_exr(image: &HdrImage, path: &Path) -> Result<()> {
    write_exr_with(image, path, &ExrWrite::default())
}

/// Writes `image` as `how` says; extra channels (data, not colour) stay 32-bit float.
pub fn write_exr_with(image: &HdrImage, path: &Path, how: &ExrWrite) -> Result<()> {
    use rayon::prelude::*;
    let (w, h) = (image.width as usize, image.height as usize);
    if w == 0 || h == 0 {
        return Err(Error::invalid("image", "cannot write an empty image"));
    }
    let plane = |c: usize| {
        let values = image.pixels.par_iter().map(|p| p[c]);
        if how.half {
            FlatSamples::F16(values.map(f16::from_f32).collect())
        } else {
            FlatSamples::F32(values.collect())
        }
    };
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::from_vec(vec![
        AnyChannel::new("R", plane(0)),
        AnyChannel::new("G", plane(1)),
        AnyChannel::new("B", plane(2)),
    ]);
    if how.keep_opaque_alpha || image.pixels.par_iter().any(|p| p[3] != 1.0) {
        list.push(AnyChannel::new("A", plane(3)));
    }
    for (name, data) in &image.extra_channels {
        if data.len() != w * h {
            return Err(Error::invalid(
                format!("channel {name}"),
                format!("expected {} values, got {}", w * h, data.len()),
            ));
        }
        if ["R", "G", "B", "A"].contains(&name.as_str()) {
            return Err(Error::invalid(
                format!("channel {name}"),
                "extra channels must not reuse R, G, B or A",
            ));
        }
        list.push(AnyChannel::new(text(name), FlatSamples::F32(data.clone())));
    }
    let mut attributes = LayerAttributes::default();
    for (k, v) in &image.metadata {
        attributes
            .other
            .insert(attribute_name(k), AttributeValue::Text(text(v)));
    }
    let layer = Layer::new(
        (w, h),
        attributes,
        Encoding {
            compression: how.compression,
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        },
        AnyChannels::sort(list),
    );
    let exr_image = Image::from_layer(layer);
    crate::io::write_atomic(path, |writer| {
        // exr needs Seek; the temporary file is seekable but a BufWriter is only via its inner file.
        let file = writer.get_mut();
        exr_image
            .write()
            .to_buffered(std::io::BufWriter::new(&mut **file))
            .map_err(|e| Error::format(path, format!("cannot encode EXR: {e}")))?;
        sort_header_in_place(file).map_err(|why| {
            Error::format(
                path,
                format!("cannot order the EXR header's attributes: {why}"),
            )
        })
    })
}

/// Reads back the start of the written file, which holds the whole header (attributes are
/// short: a header over [`HEADER_READ`] bytes is refused), and rewrites it in order.
fn sort_header_in_place(file: &mut std::fs::File) -> std::result::Result<(), String> {
    use std::io::{Read, Seek, SeekFrom, Write};
    let io = |e: std::io::Error| e.to_string();
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    let mut head = Vec::new();
    Read::take(&mut *file, HEADER_READ)
        .read_to_end(&mut head)
        .map_err(io)?;
    sort_provenance_attributes(&mut head)?;
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    file.write_all(&head).map_err(io)?;
    file.seek(SeekFrom::End(0)).map_err(io)?;
    Ok(())
}

/// How much of a written file [`sort_header_in_place`] reads: far more than any header hdrvis
/// writes (a few KiB of attributes).
const HEADER_READ: u64 = 1 << 20;

/// The exr crate keeps custom attributes in a `HashMap` and writes them in its per-process random
/// order, so the same render gave different bytes from run to run. They are written last in the
/// header, one after the other; this puts them in name order in place. The header keeps its
/// length, so the chunk offsets after it stay valid.
fn sort_provenance_attributes(bytes: &mut [u8]) -> std::result::Result<(), String> {
    let mut spans = Vec::new();
    let mut at = 8; // magic number and version field
    loop {
        let name_end = nul_after(bytes, at)?;
        if name_end == at {
            break;
        }
        let type_end = nul_after(bytes, name_end + 1)?;
        let size_at = type_end + 1;
        let size = bytes
            .get(size_at..size_at + 4)
            .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or("header ends inside an attribute")?;
        let end = size_at + 4 + usize::try_from(size).map_err(|_| "negative attribute size")?;
        if end > bytes.len() {
            return Err("header ends inside an attribute".into());
        }
        spans.push((at, end, bytes[at..name_end].starts_with(b"hdrvis:")));
        at = end;
    }
    let Some(first) = spans.iter().position(|s| s.2) else {
        return Ok(());
    };
    let ours = &spans[first..];
    if ours.iter().any(|s| !s.2) {
        return Err("provenance attributes are not the header's last".into());
    }
    let (start, end) = (ours[0].0, ours[ours.len() - 1].1);
    let mut records: Vec<Vec<u8>> = ours.iter().map(|s| bytes[s.0..s.1].to_vec()).collect();
    records.sort();
    bytes[start..end].copy_from_slice(&records.concat());
    Ok(())
}

fn nul_after(bytes: &[u8], from: usize) -> std::result::Result<usize, String> {
    bytes
        .get(from..)
        .and_then(|rest| rest.iter().position(|&b| b == 0))
        .map(|i| from + i)
        .ok_or_else(|| "header ends inside a name".into())
}

/// Reads the first layer's colour as R, G, B (see [`colour`] for files without all three), A if
/// present (else 1), every other channel as an extra channel, and the text attributes as
/// metadata.
pub fn read_exr(path: &Path) -> Result<HdrImage> {
    crate::io::check_regular_file(path)?;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .from_file(path)
        .map_err(|e| read_error(path, &e.to_string()))?;
    let layer = img.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let n = w * h;
    let list = &layer.channel_data.list;
    let (rgb, note) = colour(path, list, img.attributes.chromaticities)?;
    let a = channel(list, "A").map(|c| samples(&c.sample_data));
    let pixels = {
        use rayon::prelude::*;
        let [r, g, b] = &rgb;
        let alpha = |i: usize| a.as_ref().map_or(1.0, |a| a[i]);
        (0..n)
            .into_par_iter()
            .map(|i| [r[i], g[i], b[i], alpha(i)])
            .collect()
    };
    let mut out = HdrImage::from_pixels(w as u32, h as u32, pixels);
    for c in &layer.channel_data.list {
        let name = c.name.to_string();
        if !COLOUR_CHANNELS.contains(&name.as_str()) {
            out.extra_channels
                .push((name, samples(&c.sample_data).into_owned()));
        }
    }
    for (k, v) in &layer.attributes.other {
        if let AttributeValue::Text(t) = v {
            let key = k.to_string();
            out.metadata.push((
                key.strip_prefix("hdrvis:").unwrap_or(&key).to_string(),
                t.to_string(),
            ));
        }
    }
    if let Some(note) = note {
        out.metadata.push(("read".into(), note));
    }
    // The attributes come out of a HashMap; name order is the one files are written in.
    out.metadata.sort();
    Ok(out)
}

/// The channels that make the colour and alpha, not kept as extra channels.
const COLOUR_CHANNELS: [&str; 7] = ["R", "G", "B", "A", "Y", "RY", "BY"];

/// The channel `name` of a layer, bare or after a layer prefix (`diffuse.R`).
fn channel<'a>(
    list: &'a [AnyChannel<FlatSamples>],
    name: &str,
) -> Option<&'a AnyChannel<FlatSamples>> {
    list.iter().find(|c| {
        let full = c.name.to_string();
        full == name || full.ends_with(&format!(".{name}"))
    })
}

/// A channel's samples as f32: float channels borrowed, the others converted.
fn samples(s: &FlatSamples) -> Cow<'_, [f32]> {
    match s {
        FlatSamples::F16(v) => Cow::Owned(v.iter().map(|x| x.to_f32()).collect()),
        FlatSamples::F32(v) => Cow::Borrowed(v),
        FlatSamples::U32(v) => Cow::Owned(v.iter().map(|&x| x as f32).collect()),
    }
}

/// R, G, B planes, borrowed from the file's channels where they are stored as 32-bit floats.
type Planes<'a> = [Cow<'a, [f32]>; 3];

/// The R, G, B planes of an image, and a note where they are not the file's own R, G, B:
/// - R, G and B: as stored;
/// - Y with RY and BY (OpenEXR's luminance-chroma images): R = (RY + 1) Y, B = (BY + 1) Y and
///   G = (Y − wr R − wb B) / wg, with the luminance weights of the file's chromaticities,
///   as OpenEXR's RGBA interface converts them;
/// - Y alone, or one of R, G, B alone: grey, that channel in R, G and B;
/// - two of R, G, B: the missing one 0, said in the note.
///
/// A file with none of R, G, B and Y (depth alone) is refused.
fn colour<'a>(
    path: &Path,
    list: &'a [AnyChannel<FlatSamples>],
    chromaticities: Option<Chromaticities>,
) -> Result<(Planes<'a>, Option<String>)> {
    let find = |name: &str| channel(list, name).map(|c| samples(&c.sample_data));
    let n = list.first().map_or(0, |c| c.sample_data.len());
    let (r, g, b) = (find("R"), find("G"), find("B"));
    if let (Some(r), Some(g), Some(b)) = (&r, &g, &b) {
        return Ok(([r.clone(), g.clone(), b.clone()], None));
    }
    if let Some(y) = find("Y") {
        if let (Some(ry), Some(by)) = (find("RY"), find("BY")) {
            let [wr, wg, wb] = luminance_weights(chromaticities);
            let r: Vec<f32> = y
                .iter()
                .zip(ry.iter())
                .map(|(y, c)| (c + 1.0) * y)
                .collect();
            let b: Vec<f32> = y
                .iter()
                .zip(by.iter())
                .map(|(y, c)| (c + 1.0) * y)
                .collect();
            let g: Vec<f32> = (0..n)
                .map(|i| (y[i] - wr * r[i] - wb * b[i]) / wg)
                .collect();
            let note = format!(
                "luminance-chroma (Y, RY, BY) converted with weights {wr:.4} {wg:.4} {wb:.4}"
            );
            return Ok(([r.into(), g.into(), b.into()], Some(note)));
        }
        return Ok((
            [y.clone(), y.clone(), y],
            Some("luminance Y read as grey".into()),
        ));
    }
    let present: Vec<(&str, Cow<[f32]>)> = [("R", &r), ("G", &g), ("B", &b)]
        .into_iter()
        .filter_map(|(name, c)| Some((name, c.clone()?)))
        .collect();
    if let [(name, v)] = present.as_slice() {
        let note = format!("the one colour channel {name} read as grey");
        return Ok(([v.clone(), v.clone(), v.clone()], Some(note)));
    }
    if !present.is_empty() {
        let missing: Vec<&str> = [("R", &r), ("G", &g), ("B", &b)]
            .iter()
            .filter(|(_, c)| c.is_none())
            .map(|(name, _)| *name)
            .collect();
        let note = format!("no {} channel: read as 0", missing.join(", "));
        let or_zero = |c: Option<Cow<'a, [f32]>>| c.unwrap_or_else(|| vec![0.0; n].into());
        return Ok(([or_zero(r), or_zero(g), or_zero(b)], Some(note)));
    }
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    Err(Error::format(
        path,
        format!(
            "no R, G, B (or Y) channels; the file has: {}",
            names.join(", ")
        ),
    ))
}

/// The weights of R, G, B in luminance Y for the file's primaries and white point (OpenEXR's
/// `computeYw`: the Y row of the RGB-to-XYZ matrix, normalised to sum 1); without a
/// chromaticities attribute, those of OpenEXR's default, Rec. 709 with a D65 white
/// (0.2126, 0.7152, 0.0722 to four places).
fn luminance_weights(chromaticities: Option<Chromaticities>) -> [f32; 3] {
    let c = chromaticities.unwrap_or(Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    let xy = |v: Vec2<f32>| (f64::from(v.0), f64::from(v.1));
    let ((rx, ry), (gx, gy), (bx, by), (wx, wy)) =
        (xy(c.red), xy(c.green), xy(c.blue), xy(c.white));
    // The primaries' scales S that make white (X, 1, Z) from R = G = B = 1 (Cramer's rule).
    let (x, z) = (wx / wy, (1.0 - wx - wy) / wy);
    let d = rx * (by - gy) + bx * (gy - ry) + gx * (ry - by);
    let sr = (x * (by - gy) - gx * (by - 1.0 + by * (x + z)) + bx * (gy - 1.0 + gy * (x + z))) / d;
    let sg = (x * (ry - by) + rx * (by - 1.0 + by * (x + z)) - bx * (ry - 1.0 + ry * (x + z))) / d;
    let sb = (x * (gy - ry) - rx * (gy - 1.0 + gy * (x + z)) + gx * (ry - 1.0 + ry * (x + z))) / d;
    let (yr, yg, yb) = (sr * ry, sg * gy, sb * by);
    let sum = yr + yg + yb;
    [(yr / sum) as f32, (yg / sum) as f32, (yb / sum) as f32]
}

/// The reader's error in one line. What the `exr` crate does not read but only calls invalid or
/// unsupported is named from the header: a compression method it does not know (ZSTD, 13, in
/// OpenEXR 3.4) and subsampled channels (OpenEXR's luminance-chroma images store RY and BY at
/// half resolution).
fn read_error(path: &Path, message: &str) -> Error {
    let head = std::fs::File::open(path).ok().and_then(|f| {
        use std::io::Read;
        let mut bytes = Vec::new();
        // The header's attributes come first; 64 KiB holds any a producer writes before it.
        f.take(1 << 16).read_to_end(&mut bytes).ok()?;
        Some(bytes)
    });
    let named = head.and_then(|bytes| unknown_compression(&bytes).or_else(|| subsampled(&bytes)));
    let message = named.unwrap_or_else(|| format!("not a readable OpenEXR file: {message}"));
    Error::format(path, message.replace(['\n', '\r'], " "))
}

/// The header's value of attribute `name` of type `kind`.
fn header_value<'b>(bytes: &'b [u8], name: &str, kind: &str) -> Option<&'b [u8]> {
    let key = format!("{name}\0{kind}\0");
    let at = bytes.windows(key.len()).position(|w| w == key.as_bytes())? + key.len();
    let size = i32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?);
    bytes.get(at + 4..at + 4 + usize::try_from(size).ok()?)
}

fn unknown_compression(bytes: &[u8]) -> Option<String> {
    let id = *header_value(bytes, "compression", "compression")?.first()?;
    let name = match id {
        12 => "LJ2K",
        13 => "ZSTD",
        _ => return None,
    };
    Some(format!(
        "{name} compression (method {id}) is not read by hdrvis's OpenEXR reader (the exr \
         crate); save the file with ZIP, PIZ or no compression"
    ))
}

/// The channels stored at less than full resolution, from the header's channel list (each
/// entry: name, NUL, pixel type, linear flag and three reserved bytes, x and y sampling).
fn subsampled(bytes: &[u8]) -> Option<String> {
    let mut list = header_value(bytes, "channels", "chlist")?;
    let mut found = Vec::new();
    while let Some(end) = list.iter().position(|&b| b == 0).filter(|&e| e > 0) {
        let name = String::from_utf8_lossy(&list[..end]).into_owned();
        let field = |k: usize| {
            let at = end + 1 + 8 + 4 * k;
            Some(i32::from_le_bytes(list.get(at..at + 4)?.try_into().ok()?))
        };
        let (x, y) = (field(0)?, field(1)?);
        if (x, y) != (1, 1) {
            found.push(format!("{name} (1 in {x} x {y})"));
        }
        list = list.get(end + 1 + 16..)?;
    }
    (!found.is_empty()).then(|| {
        format!(
            "channels {} are stored subsampled, which hdrvis's OpenEXR reader (the exr crate) \
             does not decode; save the image with every channel at full resolution (RGB, or Y, \
             RY, BY unsubsampled)",
            found.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_values_channels_and_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = HdrImage::new(3, 2);
        img.pixels[4] = [1e-30, 5e3, f32::MAX, 0.25];
        img.extra_channels
            .push(("uz".into(), vec![0.5, 1.0, 2.0, 3.0, 4.0, 5.0]));
        img.set_meta("dataset", "mantle n=64");
        let p = dir.path().join("x.exr");
        write_exr(&img, &p).unwrap();
        let back = read_exr(&p).unwrap();
        assert_eq!(back.pixels, img.pixels);
        assert_eq!(back.extra_channels, img.extra_channels);
        assert_eq!(back.meta("dataset"), Some("mantle n=64"));
        // Only the final file remains: the temporary was renamed, not copied.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn the_same_image_is_written_as_the_same_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = HdrImage::new(5, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = [i as f32, 1e-6, 3e4, 1.0];
        }
        let keys = [
            "dataset",
            "camera",
            "tf",
            "precision",
            "adapter",
            "exposure",
        ];
        for (i, k) in keys.iter().enumerate() {
            img.set_meta(k, format!("value {i}"));
        }
        let files: Vec<Vec<u8>> = (0..6)
            .map(|i| {
                let p = dir.path().join(format!("{i}.exr"));
                write_exr(&img, &p).unwrap();
                std::fs::read(&p).unwrap()
            })
            .collect();
        assert!(files.iter().all(|f| *f == files[0]));
        let back = read_exr(&dir.path().join("0.exr")).unwrap();
        let mut sorted: Vec<&str> = keys.to_vec();
        sorted.sort();
        let read_keys: Vec<&str> = back.metadata.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(read_keys, sorted);
        assert_eq!(back.meta("tf"), Some("value 2"));
    }

    #[test]
    fn truncated_and_foreign_files_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = HdrImage::new(64, 64);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = [i as f32, 1.0, 2.0, 1.0];
        }
        let p = dir.path().join("x.exr");
        write_exr(&img, &p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let t = dir.path().join("t.exr");
        std::fs::write(&t, &bytes[..bytes.len() / 2]).unwrap();
        assert!(read_exr(&t).unwrap_err().to_string().contains("t.exr"));
        let n = dir.path().join("n.exr");
        std::fs::write(&n, b"P6 not an exr").unwrap();
        assert!(read_exr(&n).is_err());
    }
}
