//! OpenEXR through the `exr` crate: the linear master of every render. Images are written with
//! 32-bit float channels R, G, B, A plus any extra named channels, and text attributes recording
//! provenance (dataset, camera, transfer function, precision, adapter). Reading accepts RGB(A)
//! in half or float from any producer and refuses truncated files.

use crate::error::{Error, Result};
use crate::model::HdrImage;
use exr::prelude::*;
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

pub fn write_exr(image: &HdrImage, path: &Path) -> Result<()> {
    let (w, h) = (image.width as usize, image.height as usize);
    if w == 0 || h == 0 {
        return Err(Error::invalid("image", "cannot write an empty image"));
    }
    let plane = |c: usize| FlatSamples::F32(image.pixels.iter().map(|p| p[c]).collect());
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::from_vec(vec![
        AnyChannel::new("R", plane(0)),
        AnyChannel::new("G", plane(1)),
        AnyChannel::new("B", plane(2)),
        AnyChannel::new("A", plane(3)),
    ]);
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
        Encoding::SMALL_LOSSLESS,
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

/// Reads the first layer's R, G, B (and A if present, else 1) as f32, plus every other channel
/// as an extra channel, and the text attributes as metadata.
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
        .map_err(|e| Error::format(path, format!("not a readable OpenEXR file: {e}")))?;
    let layer = img.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let n = w * h;
    let as_f32 = |s: &FlatSamples| -> Vec<f32> {
        match s {
            FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
        }
    };
    let find = |name: &str| {
        layer.channel_data.list.iter().find(|c| {
            c.name.to_string() == name || c.name.to_string().ends_with(&format!(".{name}"))
        })
    };
    let (r, g, b) = match (find("R"), find("G"), find("B")) {
        (Some(r), Some(g), Some(b)) => (
            as_f32(&r.sample_data),
            as_f32(&g.sample_data),
            as_f32(&b.sample_data),
        ),
        (_, _, _) => match find("Y") {
            Some(y) => {
                let y = as_f32(&y.sample_data);
                (y.clone(), y.clone(), y)
            }
            None => {
                let names: Vec<String> = layer
                    .channel_data
                    .list
                    .iter()
                    .map(|c| c.name.to_string())
                    .collect();
                return Err(Error::format(
                    path,
                    format!(
                        "no R, G, B (or Y) channels; the file has: {}",
                        names.join(", ")
                    ),
                ));
            }
        },
    };
    let a = find("A")
        .map(|c| as_f32(&c.sample_data))
        .unwrap_or_else(|| vec![1.0; n]);
    let pixels = (0..n).map(|i| [r[i], g[i], b[i], a[i]]).collect();
    let mut out = HdrImage::from_pixels(w as u32, h as u32, pixels);
    for c in &layer.channel_data.list {
        let name = c.name.to_string();
        if !["R", "G", "B", "A", "Y"].contains(&name.as_str()) {
            out.extra_channels.push((name, as_f32(&c.sample_data)));
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
    // The attributes come out of a HashMap; name order is the one files are written in.
    out.metadata.sort();
    Ok(out)
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
