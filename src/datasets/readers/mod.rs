//! The one place that decides which reader opens a file. A file's format is read from its first
//! bytes (the signatures the formats' own specifications fix), as xarray's backends guess an
//! engine; the extension is only a hint, used where the content allows two readings (a NetCDF-4
//! file is an HDF5 file: named `.nc` it is read as NetCDF with its dimensions and CF metadata,
//! named `.h5` as NetCDF too when it is laid out as NetCDF-4 is, with dimension scales in its root
//! group, and as plain HDF5 datasets otherwise). Every reader, the CLI's messages and the writers that
//! choose a format by name ask this table; no other module lists extensions.
//!
//! Each format's reader implements [`Reader`], as an xarray backend does: list what a file holds,
//! read one array (under a selection, where the format has dimensions), and, where the format
//! says more than an array does, place a volume or a grid's axes. `load_volume`, `load_grid`,
//! `info`, `list_arrays` and `read_array` ask the registry for the reader and call it.
//!
//! Formats with named dimensions also give the data model the CF conventions read
//! ([`variables::Variables`]).
//!
//! Adding a format: a variant of [`Format`], its row in [`FORMATS`] (name, extensions, the
//! signature test and the reader), and its module here implementing [`Reader`]; nothing else.

mod exr;
pub(crate) mod geotiff;
pub(crate) mod grib;
pub(crate) mod hdf5;
pub(crate) mod mintpy;
pub mod netcdf;
pub(crate) mod nhdr;
pub mod npy;
mod npz;
pub(crate) mod scalar;
pub(crate) mod variables;
pub(crate) mod vti;
pub(crate) mod vtk_legacy;
pub(crate) mod zarr;

use std::io::Read;
use std::path::Path;

use crate::datasets::select::Selection;
use crate::datasets::{ArrayData, ArrayListing, GridAxis, GridFile, LoadOptions};
use crate::error::{Error, Result};
use crate::model::{RotatedPole, Volume};

/// What one format's reader does. Only `read` is required; the rest have the defaults of a
/// format that holds one array or bare arrays (no dimensions to select, no coordinates), or,
/// for a format with named dimensions ([`Reader::variables`]), the CF conventions' readings:
/// many variables, volumes and grid axes placed by CF coordinates, CF time steps.
pub(crate) trait Reader: Sync {
    /// Every array the file holds, in file order; by default the one array `read` gives.
    fn list(&self, path: &Path) -> Result<Vec<ArrayListing>> {
        let array = self.read(path, None, None, &Selection::default())?;
        Ok(vec![ArrayListing {
            name: array.name,
            shape: array.shape,
            dtype: array.dtype,
            is_coordinate: false,
            is_auxiliary: false,
            unreadable: None,
        }])
    }

    /// One array, decoded (missing values NaN): `var`, else the reader's default for `rank`,
    /// with the dimensions `sel` fixes (only where [`Reader::selects`]).
    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        rank: Option<usize>,
        sel: &Selection,
    ) -> Result<ArrayData>;

    /// Whether `read` takes a selection by dimension for this file: where it has named
    /// dimensions.
    fn selects(&self, _path: &Path) -> Result<bool> {
        Ok(self.variables().is_some())
    }

    /// Whether the file holds many arrays (`hdrvis info` lists them).
    fn holds_many(&self) -> bool {
        self.variables().is_some()
    }

    /// A volume: the 3-D array placed by CF coordinates where the format has named dimensions,
    /// else by index (spacing 1).
    fn volume(&self, path: &Path, opts: &LoadOptions) -> Result<Volume> {
        if self.variables().is_some() {
            return crate::datasets::volume_from_netcdf(path, opts);
        }
        let array = self.read(path, opts.variable.as_deref(), Some(3), &opts.select)?;
        crate::datasets::volume_from_array(path, array, [None, None, None])
    }

    /// A 2-D field with its axes; a band is GeoTIFF's and refused elsewhere.
    fn grid(
        &self,
        path: &Path,
        var: Option<&str>,
        sel: &Selection,
        band: Option<usize>,
        resolution: Option<f64>,
    ) -> Result<GridFile> {
        crate::datasets::grid_of_array(self, path, var, sel, band, resolution)
    }

    /// Where the rows and columns of a 2-D array read from the file lie: by CF coordinates
    /// where the format has named dimensions, else nowhere.
    fn grid_axes(&self, path: &Path, array: &ArrayData) -> Result<GridAxes> {
        if self.variables().is_some() {
            return crate::datasets::netcdf_grid_axes(path, array);
        }
        Ok(GridAxes::default())
    }

    /// The file's other arrays that join a grid as properties and its relief: none by default.
    fn grid_extras(&self, _path: &Path, _ask: &ExtrasAsked) -> Result<GridExtras> {
        Ok(GridExtras::default())
    }

    /// The file's variables with named dimensions and attributes, where the format has them
    /// (the model the CF conventions read): none by default.
    fn variables(&self) -> Option<&dyn variables::Variables> {
        None
    }

    /// The dates of a time axis of `var` (else of the first data variable with one).
    fn time_steps(&self, path: &Path, var: Option<&str>) -> Result<Vec<String>> {
        if self.variables().is_some() {
            return crate::datasets::select::time_steps(path, var);
        }
        Err(Error::format(path, "has no time axis"))
    }
}

/// Where a grid's rows and columns lie, as a format's metadata says.
#[derive(Default)]
pub(crate) struct GridAxes {
    pub x: Option<GridAxis>,
    pub y: Option<GridAxis>,
    /// The rotated pole of a CF `rotated_latitude_longitude` grid (x and y are then rotated
    /// longitudes and latitudes).
    pub rotated_pole: Option<RotatedPole>,
    /// The 2-D latitude and longitude of a curvilinear grid, to regrid onto.
    pub curvilinear: Option<(netcdf::NcVariable, netcdf::NcVariable)>,
    /// The radar wavelength (m) of an InSAR product.
    pub wavelength: Option<f64>,
}

/// What a grid's further arrays are looked for beside: its main array and axes.
pub(crate) struct ExtrasAsked<'a> {
    pub main: &'a str,
    pub coord_names: [&'a str; 2],
    pub shape: [usize; 2],
    /// Only the relief, not further properties (a named variable, a selection, a regridding).
    pub only_elevation: bool,
    /// Whether x is a longitude axis (a saved section's columns carry their own positions).
    pub x_is_longitude: bool,
}

/// A grid's further arrays: `(name, values, units)` of each property, and the relief.
#[derive(Default)]
pub(crate) struct GridExtras {
    pub properties: Vec<(String, Vec<f64>, String)>,
    pub elevation: Option<Vec<f64>>,
}

/// The reader of a format that holds one volume with its own geometry (NRRD, VTK ImageData,
/// legacy VTK), from the function that reads that volume (refusing a `var` that names another).
pub(crate) struct OneVolume(pub fn(&Path, Option<&str>) -> Result<Volume>);

impl Reader for OneVolume {
    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        _rank: Option<usize>,
        _sel: &Selection,
    ) -> Result<ArrayData> {
        Ok(crate::datasets::volume_array((self.0)(path, var)?))
    }

    fn volume(&self, path: &Path, opts: &LoadOptions) -> Result<Volume> {
        (self.0)(path, opts.variable.as_deref())
    }
}

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
    /// GRIB editions 1 and 2 (weather services' forecasts and analyses).
    Grib,
    /// Zarr directory stores, versions 2 and 3 (cloud archives, xarray's `to_zarr`).
    Zarr,
}

/// One row of the registry: a format's name in messages, its extensions (the first is the one
/// written) and the test of its signature.
struct FormatRow {
    format: Format,
    name: &'static str,
    extensions: &'static [&'static str],
    signature: fn(&[u8]) -> bool,
    reader: &'static dyn Reader,
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

const FORMATS: [FormatRow; 11] = [
    FormatRow {
        format: Format::Npy,
        name: "NumPy .npy",
        extensions: &["npy"],
        signature: |h| h.starts_with(b"\x93NUMPY"),
        reader: &npy::NpyReader,
    },
    FormatRow {
        format: Format::Npz,
        name: "NumPy .npz",
        extensions: &["npz"],
        signature: |h| h.starts_with(b"PK\x03\x04") || h.starts_with(b"PK\x05\x06"),
        reader: &npz::NpzReader,
    },
    FormatRow {
        format: Format::NetCdf,
        name: "NetCDF",
        extensions: &["nc", "nc4", "cdf", "netcdf"],
        signature: |h| is_netcdf_classic(h) || is_hdf5(h),
        reader: &netcdf::NetcdfReader,
    },
    FormatRow {
        format: Format::Hdf5,
        name: "HDF5",
        extensions: &["h5", "hdf5", "he5"],
        signature: is_hdf5,
        reader: &mintpy::Hdf5Reader,
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
        reader: &geotiff::GeoTiffReader,
    },
    FormatRow {
        format: Format::Nrrd,
        name: "NRRD",
        extensions: &["nrrd", "nhdr"],
        signature: |h| h.starts_with(b"NRRD000"),
        reader: &OneVolume(nhdr::volume),
    },
    FormatRow {
        format: Format::Vti,
        name: "VTK ImageData",
        extensions: &["vti"],
        signature: is_xml_vtk_image,
        reader: &OneVolume(vti::volume),
    },
    FormatRow {
        format: Format::VtkLegacy,
        name: "legacy VTK",
        extensions: &["vtk"],
        signature: |h| h.starts_with(b"# vtk DataFile"),
        reader: &OneVolume(vtk_legacy::volume),
    },
    FormatRow {
        format: Format::Exr,
        name: "OpenEXR",
        extensions: &["exr"],
        signature: |h| h.starts_with(&[0x76, 0x2f, 0x31, 0x01]),
        reader: &exr::ExrReader,
    },
    FormatRow {
        format: Format::Grib,
        name: "GRIB",
        extensions: &["grib", "grib2", "grb", "grb2", "grib1", "grb1"],
        signature: grib::is_grib,
        reader: &grib::GribReader,
    },
    FormatRow {
        format: Format::Zarr,
        name: "Zarr",
        extensions: &["zarr"],
        // A store is a folder, recognised by its metadata files (`Format::of`), not by bytes.
        signature: |_| false,
        reader: &zarr::ZarrReader,
    },
];

/// Formats hdrvis recognises but does not read, so that a user hears what the file is.
const KNOWN_OTHERS: [(&str, &[u8], &str); 7] = [
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

    /// The format's reader.
    pub(crate) fn reader(self) -> &'static dyn Reader {
        self.row().reader
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
        if zarr::is_store(path) {
            return Ok(Format::Zarr);
        }
        crate::io::check_regular_file(path)?;
        let mut head = Vec::with_capacity(HEAD_BYTES);
        std::fs::File::open(path)
            .and_then(|f| f.take(HEAD_BYTES as u64).read_to_end(&mut head))
            .map_err(|e| Error::io(path, e))?;
        match Self::of_head(path, &head)? {
            // An HDF5 file with NetCDF-4's dimensions reads as NetCDF whatever its name.
            Format::Hdf5 if hdf5::has_netcdf_dimensions(path) => Ok(Format::NetCdf),
            format => Ok(format),
        }
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
        let msg = of("swath.hdf", &[0x0e, 0x03, 0x13, 0x01, 0, 0])
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("HDF4 is not read; convert it with h4toh5"),
            "{msg}"
        );
        // GRIB is read, also after a WMO bulletin header.
        assert_eq!(
            of("f.bin", b"TTAA01 KWBC\r\r\nGRIB\0\0\0\x02").unwrap(),
            Format::Grib
        );
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
