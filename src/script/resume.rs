//! What `--resume` trusts. An output that exists is skipped only when it reads back whole: an
//! image decodes (PNG's chunk checksums included) and ends where its format ends, an OpenEXR
//! file reads, a data file's every array reads, a JSON report parses, anything else is not
//! empty. Outputs appear atomically, so a damaged one comes from outside a run (a copy cut short,
//! a quota met by another tool, a disk error); it is written again, with a notice.

use std::path::Path;

/// The last 12 bytes of every complete PNG file: the empty IEND chunk with its CRC.
const PNG_END: [u8; 12] = [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xAE, 0x42, 0x60, 0x82];

/// Whether the output at `path` reads back whole; why not, in a few words.
pub(crate) fn output_intact(path: &Path) -> Result<(), String> {
    let len = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    if len == 0 {
        return Err("is empty".into());
    }
    match crate::io::extension(path).as_str() {
        "png" => {
            let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
            if !bytes.ends_with(&PNG_END) {
                return Err("does not end with PNG's IEND chunk (cut short)".into());
            }
            image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
                .map(|_| ())
                .map_err(|e| format!("does not decode as PNG ({e})"))
        }
        "gif" => {
            let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
            // A GIF stream ends with its trailer byte, ';'.
            if bytes.last() != Some(&0x3B) {
                return Err("does not end with GIF's trailer (cut short)".into());
            }
            Ok(())
        }
        "json" => {
            let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
            serde_json::from_slice::<serde_json::Value>(&bytes)
                .map(|_| ())
                .map_err(|e| format!("does not parse as JSON ({e})"))
        }
        // Pictures and data files by the one registry of formats.
        _ => match crate::datasets::Format::from_extension(path) {
            Some(crate::datasets::Format::Exr) => crate::io::exr::read_exr(path)
                .map(|_| ())
                .map_err(|e| format!("does not read as OpenEXR ({e})")),
            Some(_) => every_array_reads(path),
            None => Ok(()),
        },
    }
}

/// Reads every array of a data file in full.
fn every_array_reads(path: &Path) -> Result<(), String> {
    let listing = crate::datasets::list_arrays(path).map_err(|e| e.to_string())?;
    for array in listing.iter().filter(|a| a.unreadable.is_none()) {
        crate::datasets::read_array(path, Some(&array.name), None).map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::HdrImage;

    #[test]
    fn outputs_cut_short_or_changed_are_not_trusted() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = HdrImage::new(16, 8);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = [i as f32 * 0.01, 0.5, 1.0, 1.0];
        }
        let png = dir.path().join("a.png");
        crate::io::png::write_display_png(&img, &png, false).unwrap();
        let exr = dir.path().join("a.exr");
        crate::io::exr::write_exr(&img, &exr).unwrap();
        assert_eq!(output_intact(&png), Ok(()));
        assert_eq!(output_intact(&exr), Ok(()));
        for path in [&png, &exr] {
            let bytes = std::fs::read(path).unwrap();
            std::fs::write(path, &bytes[..bytes.len() / 2]).unwrap();
            assert!(output_intact(path).is_err(), "{path:?} cut short");
        }
        // A changed byte inside PNG's image data: its chunk checksum no longer matches.
        crate::io::png::write_display_png(&img, &png, false).unwrap();
        let mut bytes = std::fs::read(&png).unwrap();
        let idat = bytes.windows(4).position(|w| w == b"IDAT").unwrap();
        bytes[idat + 8] ^= 0x40;
        std::fs::write(&png, &bytes).unwrap();
        assert!(output_intact(&png).unwrap_err().contains("decode"));
        let json = dir.path().join("r.json");
        std::fs::write(&json, b"{\"a\": [1, 2").unwrap();
        assert!(output_intact(&json).is_err());
        std::fs::write(&json, b"{\"a\": [1, 2]}").unwrap();
        assert_eq!(output_intact(&json), Ok(()));
        let empty = dir.path().join("notes.txt");
        std::fs::write(&empty, b"").unwrap();
        assert_eq!(output_intact(&empty), Err("is empty".into()));
    }
}
