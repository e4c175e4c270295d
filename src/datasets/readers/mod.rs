//! The one place that decides which reader opens a file. A file's format is read from its first
//! bytes (the signatures the formats' own specifications fix), as xarray's backends guess an
//! engine; the extension is only a hint, used where the content allows two readings (a NetCDF-4
//! file is an HDF5 file: named `.nc` it is read as NetCDF with its dimensions and CF metadata,
//! named `.h5` as plain HDF5 datasets). Every reader, the CLI's messages and the writers that
//! choose a format by name ask this table; no other module lists extensions.
//!
//! Adding a format: a variant of [`Format`], its row in [`FORMATS`] (name, extensions and the
//! signature test), and its reader module; the readers' dispatch in `datasets` names the variant.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// A file format hdrvis reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// NumPy `.npy`: one array.
    Npy,
    /// NumPy `.npz`: a zip of `.npy` members.
    Npz,
    /// NetCDF classic (CDF-1, -2, -5) or NetCDF-4 (HDF5 with NetCDF's dimensions).
    NetCdf,
    /// Plain HDF5 (and MintPy's products).
    Hdf5,
    /// GeoTIFF rasters (TIFF and BigTIFF).
    GeoTiff,
    /// NRRD, attached (`.nrrd`) or detached header (`.nhdr`).
    Nrrd,
    /// VTK XML ImageData.
    Vti,
    /// Legacy VTK structured points.
    VtkLegacy,
    /// OpenEXR images (`hdrvis info` and the TUI read them).
    Exr,
}

/// One row of the registry: a format's name in messages, its extensions (the first is the one
/// written) and the test of its signature.
struct FormatRow {
    format: Format,
    name: &'static str,
    extensions: &'static [&'static str],
    signature: fn(&[u8]) -> bool,
}

/// The HDF5 superblock signature (HDF5 file format specification, section II.A); it sits at 0
/// or, after a user block, at 512, 1024, 2048, ...
const HDF5_SIGNATURE: [u8; 8] = [0x89, b'H', b'D', b'F', b'\r', b'\n', 0x1a, b'\n'];

/// Bytes read to find a signature: HDF5's may follow a user block of up to 512 bytes here (the
/// readers look further themselves), and an XML declaration precedes VTK's root element.
const HEAD_BYTES: usize = 1024;

fn is_netcdf_classic(head: &[u8]) -> bool {
    head.len() >= 4 && &head[..3] == b"CDF" && matches!(head[3], 1 | 2 | 5)
}

fn is_hdf5(head: &[u8]) -> bool {
    [0usize, 512]
        .iter()
        .any(|&at| head.get(at..at + 8) == Some(&HDF5_SIGNATURE[..]))
}

fn is_xml_vtk_image(head: &[u8]) -> bool {
    let text = String::from_utf8_lossy(head);
    let text = text.trim_start_matches('\u{feff}').trim_start();
    (text.starts_with("<?xml") || text.starts_with("<VTKFile")) && text.contains("ImageData")
}

const FORMATS: [FormatRow; 9] = [
    FormatRow {
        format: Format::Npy,
        name: "NumPy .npy",
        extensions: &["npy"],
        signature: |h| h.starts_with(b"\x93NUMPY"),
    },
    FormatRow {
        format: Format::Npz,
        name: "NumPy .npz",
        extensions: &["npz"],
        signature: |h| h.starts_with(b"PK\x03\x04") || h.starts_with(b"PK\x05\x06"),
    },
    FormatRow {
        format: Format::NetCdf,
        name: "NetCDF",
        extensions: &["nc", "nc4", "cdf", "netcdf"],
        signature: |h| is_netcdf_classic(h) || is_hdf5(h),
    },
    FormatRow {
        format: Format::Hdf5,
        name: "HDF5",
        extensions: &["h5", "hdf5", "he5"],
        signature: is_hdf5,
    },
    FormatRow {
        format: Format::GeoTiff,
        name: "GeoTIFF",
        extensions: &["tif", "tiff"],
        signature: |h| {
            [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"]
                .iter()
                .any(|m| h.starts_with(&m[..]))
        },
    },
    FormatRow {
        format: Format::Nrrd,
        name: "NRRD",
        extensions: &["nrrd", "nhdr"],
        signature: |h| h.starts_with(b"NRRD000"),
    },
    FormatRow {
        format: Format::Vti,
        name: "VTK ImageData",
        extensions: &["vti"],
        signature: is_xml_vtk_image,
    },
    FormatRow {
        format: Format::VtkLegacy,
        name: "legacy VTK",
        extensions: &["vtk"],
        signature: |h| h.starts_with(b"# vtk DataFile"),
    },
    FormatRow {
        format: Format::Exr,
        name: "OpenEXR",
        extensions: &["exr"],
        signature: |h| h.starts_with(&[0x76, 0x2f, 0x31, 0x01]),
    },
];

/// Formats hdrvis recognises but does not read, so that a user hears what the file is.
const KNOWN_OTHERS: [(&str, &[u8], &str); 8] = [
    ("GRIB", b"GRIB", "GRIB is not read yet"),
    (
        "HDF4",
        &[0x0e, 0x03, 0x13, 0x01],
        "HDF4 is not read; convert it with h4toh5",
    ),
    ("PNG image", b"\x89PNG", "a picture, not data"),
    ("JPEG image", &[0xff, 0xd8, 0xff], "a picture, not data"),
    (
        "gzip-compressed file",
        &[0x1f, 0x8b],
        "decompress it first (gunzip)",
    ),
    (
        "bzip2-compressed file",
        b"BZh",
        "decompress it first (bunzip2)",
    ),
    (
        "xz-compressed file",
        &[0xfd, b'7', b'z', b'X', b'Z', 0],
        "decompress it first (unxz)",
    ),
    ("PDF document", b"%PDF", "a document, not data"),
];

impl Format {
    fn row(self) -> &'static FormatRow {
        FORMATS
            .iter()
            .find(|r| r.format == self)
            .expect("every format has a row")
    }

    /// The format's name in messages ("NetCDF", "GeoTIFF").
    pub fn name(self) -> &'static str {
        self.row().name
    }

    /// The extensions the format is written with, the usual one first.
    pub fn extensions(self) -> &'static [&'static str] {
        self.row().extensions
    }

    /// The format an extension names, if any: for outputs, which have no content yet.
    pub fn from_extension(path: &Path) -> Option<Format> {
        let ext = crate::io::extension(path);
        FORMATS
            .iter()
            .find(|r| r.extensions.contains(&ext.as_str()))
            .map(|r| r.format)
    }

    /// The format of the file at `path`, read from its first bytes. The extension decides only
    /// between readings the content allows (HDF5 as NetCDF-4 or plain HDF5), and names the
    /// reader for content no signature matches, which that reader then refuses in its own terms
    /// (a damaged header, a bad magic number). An empty file, one that holds a known format
    /// hdrvis does not read (GRIB, a PNG picture, a gzip stream) and one of unknown content and
    /// extension are an error naming the file, what it holds when that is known, and what was
    /// expected.
    pub fn of(path: &Path) -> Result<Format> {
        crate::io::check_regular_file(path)?;
        let mut head = Vec::with_capacity(HEAD_BYTES);
        std::fs::File::open(path)
            .and_then(|f| f.take(HEAD_BYTES as u64).read_to_end(&mut head))
            .map_err(|e| Error::io(path, e))?;
        Self::of_head(path, &head)
    }

    fn of_head(path: &Path, head: &[u8]) -> Result<Format> {
        let hinted = Format::from_extension(path);
        let matching: Vec<Format> = FORMATS
            .iter()
            .filter(|r| (r.signature)(head))
            .map(|r| r.format)
            .collect();
        if let Some(&f) = hinted.iter().find(|h| matching.contains(h)) {
            return Ok(f);
        }
        if let Some(&f) = matching.first() {
            return Ok(f);
        }
        let other = KNOWN_OTHERS.iter().any(|(_, m, _)| head.starts_with(m));
        match hinted {
            Some(f) if !other && !head.is_empty() => Ok(f),
            _ => Err(Error::format(path, Self::unreadable(head, hinted))),
        }
    }

    /// Why a file with first bytes `head` cannot be read, and what was expected.
    fn unreadable(head: &[u8], hinted: Option<Format>) -> String {
        let expected = match hinted {
            Some(f) => format!("named as {} but not one", f.name()),
            None => "not a format hdrvis reads".to_string(),
        };
        let held = KNOWN_OTHERS
            .iter()
            .find(|(_, magic, _)| head.starts_with(magic))
            .map(|(what, _, why)| format!(" (it is a {what}: {why})"))
            .unwrap_or_default();
        let first = if head.is_empty() {
            " (the file is empty)".to_string()
        } else if held.is_empty() {
            let shown: String = head
                .iter()
                .take(8)
                .map(|&b| {
                    if b.is_ascii_graphic() || b == b' ' {
                        (b as char).to_string()
                    } else {
                        format!("\\x{b:02x}")
                    }
                })
                .collect();
            format!(" (it begins \"{shown}\")")
        } else {
            String::new()
        };
        format!(
            "{expected}{held}{first}; expected {}",
            Self::list(&Self::READABLE)
        )
    }

    /// Every format whose data `load_volume`, `load_grid` and `info` read.
    pub(crate) const READABLE: [Format; 8] = [
        Format::Npy,
        Format::Npz,
        Format::NetCdf,
        Format::Hdf5,
        Format::GeoTiff,
        Format::Nrrd,
        Format::Vti,
        Format::VtkLegacy,
    ];

    /// `formats` for a message: "NumPy .npy (.npy), NetCDF (.nc, .nc4, …), …".
    pub(crate) fn list(formats: &[Format]) -> String {
        formats
            .iter()
            .map(|f| {
                let exts: Vec<String> = f.extensions().iter().map(|e| format!(".{e}")).collect();
                format!("{} ({})", f.name(), exts.join(", "))
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn of(name: &str, head: &[u8]) -> Result<Format> {
        Format::of_head(Path::new(name), head)
    }

    #[test]
    fn content_decides_and_the_extension_only_breaks_ties() {
        let hdf5 = HDF5_SIGNATURE.to_vec();
        assert_eq!(of("a.nc", &hdf5).unwrap(), Format::NetCdf);
        assert_eq!(of("a.h5", &hdf5).unwrap(), Format::Hdf5);
        assert_eq!(of("a.cdf", b"CDF\x01\0\0\0\0").unwrap(), Format::NetCdf);
        // Content wins over a wrong name.
        assert_eq!(of("a.npy", b"CDF\x02\0\0\0\0").unwrap(), Format::NetCdf);
        assert_eq!(of("data", b"\x93NUMPY\x01\0").unwrap(), Format::Npy);
        assert_eq!(of("x.dat", b"NRRD0004\n").unwrap(), Format::Nrrd);
        let vti = b"<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\">";
        assert_eq!(of("x", vti).unwrap(), Format::Vti);
        assert_eq!(of("x.tif", b"II*\0").unwrap(), Format::GeoTiff);
        // An HDF5 superblock after a 512-byte user block.
        let mut user_block = vec![0u8; 512];
        user_block.extend_from_slice(&HDF5_SIGNATURE);
        assert_eq!(of("u.nc", &user_block).unwrap(), Format::NetCdf);
    }

    #[test]
    fn unreadable_content_names_what_it_is_and_what_was_expected() {
        let msg = of("f.nc", b"\x89PNG\r\n\x1a\n").unwrap_err().to_string();
        assert!(
            msg.contains("named as NetCDF but not one") && msg.contains("PNG image"),
            "{msg}"
        );
        let msg = of("f.grib2", b"GRIB\0\0\0\x02").unwrap_err().to_string();
        assert!(msg.contains("GRIB is not read yet"), "{msg}");
        let msg = of("f.nc", b"").unwrap_err().to_string();
        assert!(msg.contains("the file is empty"), "{msg}");
        // Unknown content under a known name goes to that reader, which says what is wrong.
        assert_eq!(of("f.npy", b"hello world").unwrap(), Format::Npy);
        let msg = of("notes.txt", b"hello world").unwrap_err().to_string();
        assert!(
            msg.contains("not a format hdrvis reads") && msg.contains("\"hello wo\""),
            "{msg}"
        );
        assert_eq!(msg.lines().count(), 1);
    }
}
