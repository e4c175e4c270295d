//! VTK XML ImageData (`.vti`) volumes, for ParaView and VisIt. Our volumes are cell-centred, so
//! they are written as `CellData` on a grid of `n + 1` points per axis (`WholeExtent 0 nx 0 ny 0
//! nz`) whose `Origin` is the volume's minimum corner: ParaView then draws each value over the
//! box it stands for, with no half-voxel shift. Writing uses a raw appended little-endian block
//! after a UInt64 byte count, the most compact uncompressed layout VTK defines. Reading accepts
//! one scalar array in ascii, inline base64 or appended (raw or base64) form, uncompressed or
//! compressed in VTK's block layout (a header of block count, block size, last block size and
//! each block's compressed size, then the blocks) by zlib (VTK's default), LZ4 or LZMA; a
//! `PointData` array is read as cells centred on its points (origin moved back half a voxel).

use std::path::Path;

use crate::model::Volume;

use quick_xml::events::{BytesStart, Event};

mod blocks;

use super::scalar::Scalar;
use crate::error::{Error, Result};
use blocks::{
    decode_base64_block, decode_compressed_base64, read_compressed_raw, read_raw_block, Compressor,
};

/// A cell-centred scalar volume: `dims = [nx, ny, nz]` cells of size `spacing`, the first cell's
/// minimum corner at `origin`, values x fastest then y then z.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct VtiVolume {
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    pub name: String,
    pub data: Vec<f32>,
}

/// The file's one volume (the registry's reader), refused when `var` names another.
pub(crate) fn volume(path: &Path, var: Option<&str>) -> Result<Volume> {
    let v = read_vti(path)?;
    let volume = Volume::new(v.name, v.dims, v.spacing, v.origin, v.data)
        .map_err(|e| Error::format(path, e.to_string()))?;
    crate::datasets::named_volume(path, volume, var)
}

#[cfg(test)]
pub(crate) fn write_vti(
    path: impl AsRef<Path>,
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    name: &str,
    data: &[f32],
) -> Result<()> {
    let path = path.as_ref();
    crate::datasets::check_volume_geometry(dims, spacing, origin)?;
    let cells = dims.iter().try_fold(1usize, |acc, &n| acc.checked_mul(n));
    if cells != Some(data.len()) {
        return Err(Error::invalid(
            "data",
            format!(
                "has {} values; dims {}x{}x{} need {}",
                data.len(),
                dims[0],
                dims[1],
                dims[2],
                cells.map_or("more than usize::MAX".to_string(), |c| c.to_string())
            ),
        ));
    }
    if name.is_empty()
        || name
            .chars()
            .any(|c| matches!(c, '"' | '<' | '>' | '&') || c.is_control())
    {
        return Err(Error::invalid(
            "name",
            "must be non-empty without quotes, '<', '>', '&' or control characters",
        ));
    }
    let [nx, ny, nz] = dims;
    let header = format!(
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n\
         \x20 <ImageData WholeExtent=\"0 {nx} 0 {ny} 0 {nz}\" Origin=\"{} {} {}\" Spacing=\"{} {} {}\" Direction=\"1 0 0 0 1 0 0 0 1\">\n\
         \x20   <Piece Extent=\"0 {nx} 0 {ny} 0 {nz}\">\n\
         \x20     <PointData>\n\
         \x20     </PointData>\n\
         \x20     <CellData Scalars=\"{name}\">\n\
         \x20       <DataArray type=\"Float32\" Name=\"{name}\" format=\"appended\" offset=\"0\"/>\n\
         \x20     </CellData>\n\
         \x20   </Piece>\n\
         \x20 </ImageData>\n\
         \x20 <AppendedData encoding=\"raw\">\n   _",
        origin[0], origin[1], origin[2], spacing[0], spacing[1], spacing[2],
    );
    crate::io::write_atomically(path, |out| {
        out.write_all(header.as_bytes())?;
        out.write_all(&((data.len() * 4) as u64).to_le_bytes())?;
        let mut block = Vec::with_capacity(64 * 1024);
        for chunk in data.chunks(16 * 1024) {
            block.clear();
            block.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
            out.write_all(&block)?;
        }
        out.write_all(b"\n  </AppendedData>\n</VTKFile>\n")
    })
}

/// Reads a `.vti` file's scalar array: the `CellData` array named by its `Scalars` attribute (or
/// its first), else the first `PointData` array.
pub(crate) fn read_vti(path: impl AsRef<Path>) -> Result<VtiVolume> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_vti_bytes(path, &bytes)
}

/// `read_vti` on bytes already in memory; `path` only names the file in errors.
fn read_vti_bytes(path: &Path, bytes: &[u8]) -> Result<VtiVolume> {
    let doc = parse_document(bytes).map_err(|msg| Error::format(path, msg))?;
    let fail = |msg: String| Error::format(path, msg);

    let extent = doc
        .whole_extent
        .ok_or_else(|| fail("ImageData has no WholeExtent".into()))?;
    if let Some(piece) = doc.piece_extent {
        if piece != extent {
            return Err(fail(
                "multi-piece ImageData is not supported; save it as one piece".into(),
            ));
        }
    }
    let spacing = doc.spacing.unwrap_or([1.0; 3]);
    if spacing.iter().any(|d| !(d.is_finite() && *d > 0.0)) {
        return Err(fail(format!(
            "Spacing {spacing:?} must be finite and positive"
        )));
    }
    let mut origin = doc.origin.unwrap_or([0.0; 3]);
    if origin.iter().any(|o| !o.is_finite()) {
        return Err(fail(format!("Origin {origin:?} must be finite")));
    }
    let array = doc
        .pick_array()
        .ok_or_else(|| fail("ImageData has no CellData or PointData array".into()))?;
    if array.components != 1 {
        return Err(fail(format!(
            "array '{}' has {} components; only scalars are supported",
            array.name, array.components
        )));
    }
    let mut dims = [0usize; 3];
    for a in 0..3 {
        let (lo, hi) = (extent[2 * a], extent[2 * a + 1]);
        if hi < lo {
            return Err(fail(format!("WholeExtent {extent:?} is empty")));
        }
        let points = hi
            .checked_sub(lo)
            .and_then(|span| usize::try_from(span).ok())
            .and_then(|span| span.checked_add(1))
            .ok_or_else(|| fail(format!("WholeExtent {extent:?} too large")))?;
        origin[a] += lo as f64 * spacing[a];
        dims[a] = if array.on_points {
            origin[a] -= 0.5 * spacing[a];
            points
        } else {
            // A flat axis (one point) still holds one layer of cells in VTK's convention.
            (points - 1).max(1)
        };
    }
    let count = dims
        .iter()
        .try_fold(1usize, |acc, &n| acc.checked_mul(n))
        .ok_or_else(|| fail(format!("WholeExtent {extent:?} too large")))?;
    let element = array
        .element_type
        .ok_or_else(|| fail(format!("array '{}' has an unknown type", array.name)))?;

    let data = array_values(&doc, array, element, count, bytes)
        .map_err(|e| fail(format!("array '{}': {e}", array.name)))?;
    if data.len() != count {
        return Err(fail(format!(
            "array '{}' has {} values; the extent needs {count} ({})",
            array.name,
            data.len(),
            if array.on_points { "points" } else { "cells" }
        )));
    }
    Ok(VtiVolume {
        dims,
        spacing,
        origin,
        name: array.name.clone(),
        data,
    })
}

/// The values of `array` as f32, decoded from its ascii or base64 text or from the file's
/// appended block (`bytes` is the whole file); a compressed array must inflate to `count`
/// values.
fn array_values(
    doc: &Document,
    array: &ArrayInfo,
    element: Scalar,
    count: usize,
    bytes: &[u8],
) -> std::result::Result<Vec<f32>, String> {
    let expected_bytes = count
        .checked_mul(element.size())
        .ok_or("the extent is too large")?;
    let raw: Vec<u8> = match array.format.as_str() {
        "ascii" => {
            let text = std::str::from_utf8(&array.text)
                .map_err(|_| "ascii DataArray is not UTF-8".to_string())?;
            return text
                .split_ascii_whitespace()
                .map(|t| {
                    element
                        .parse_text(t)
                        .ok_or_else(|| format!("'{t}' in ascii DataArray is not a number"))
                })
                .collect();
        }
        "binary" => {
            let text: Vec<u8> = array
                .text
                .iter()
                .copied()
                .filter(|b| !b.is_ascii_whitespace())
                .collect();
            match doc.compressor {
                None => decode_base64_block(&text, doc.header_size, doc.little_endian)?,
                Some(c) => decode_compressed_base64(&text, doc, c, expected_bytes)?,
            }
        }
        "appended" => {
            let start = doc
                .appended_start
                .ok_or("array is appended but the file has no AppendedData")?;
            let offset = usize::try_from(array.offset.unwrap_or(0))
                .map_err(|_| "offset too large".to_string())?;
            let from = start
                .checked_add(offset)
                .filter(|&f| f <= bytes.len())
                .ok_or_else(|| format!("appended offset {offset} is past the end of the file"))?;
            match (doc.appended_raw, doc.compressor) {
                (true, None) => read_raw_block(&bytes[from..], doc.header_size, doc.little_endian)?,
                (true, Some(c)) => read_compressed_raw(&bytes[from..], doc, c, expected_bytes)?,
                (false, compressor) => {
                    let text: Vec<u8> = bytes[from..]
                        .iter()
                        .copied()
                        .take_while(|&b| b != b'<')
                        .filter(|b| !b.is_ascii_whitespace())
                        .collect();
                    match compressor {
                        None => decode_base64_block(&text, doc.header_size, doc.little_endian)?,
                        Some(c) => decode_compressed_base64(&text, doc, c, expected_bytes)?,
                    }
                }
            }
        }
        other => {
            return Err(format!(
                "DataArray format '{other}' is not one of ascii, binary, appended"
            ))
        }
    };
    if !raw.len().is_multiple_of(element.size()) {
        return Err(format!(
            "{} data bytes is not a whole number of {}-byte values",
            raw.len(),
            element.size()
        ));
    }
    Ok(element.decode(!doc.little_endian, &raw))
}

/// The sample type of a VTK `DataArray` `type` attribute.
fn sample_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "Int8" | "Char" => Scalar::I8,
        "UInt8" | "UnsignedChar" => Scalar::U8,
        "Int16" | "Short" => Scalar::I16,
        "UInt16" | "UnsignedShort" => Scalar::U16,
        "Int32" | "Int" => Scalar::I32,
        "UInt32" | "UnsignedInt" => Scalar::U32,
        "Int64" | "Long" => Scalar::I64,
        "UInt64" | "UnsignedLong" => Scalar::U64,
        "Float32" | "Float" => Scalar::F32,
        "Float64" | "Double" => Scalar::F64,
        _ => return None,
    })
}

#[derive(Debug, Default)]
struct ArrayInfo {
    name: String,
    element_type: Option<Scalar>,
    format: String,
    offset: Option<u64>,
    components: usize,
    on_points: bool,
    text: Vec<u8>,
}

/// What the XML document says: the compressor, header type and byte order, the image's extent
/// and placement, and its data arrays.
#[derive(Debug)]
struct Document {
    compressor: Option<Compressor>,
    little_endian: bool,
    header_size: usize,
    whole_extent: Option<[i64; 6]>,
    piece_extent: Option<[i64; 6]>,
    origin: Option<[f64; 3]>,
    spacing: Option<[f64; 3]>,
    cell_scalars: Option<String>,
    point_scalars: Option<String>,
    arrays: Vec<ArrayInfo>,
    appended_start: Option<usize>,
    appended_raw: bool,
}

impl Document {
    fn pick_array(&self) -> Option<&ArrayInfo> {
        let named = |on_points: bool, wanted: &Option<String>| {
            let mut of_kind = self.arrays.iter().filter(move |a| a.on_points == on_points);
            match wanted {
                Some(w) => of_kind
                    .clone()
                    .find(|a| &a.name == w)
                    .or_else(|| of_kind.next()),
                None => of_kind.next(),
            }
        };
        named(false, &self.cell_scalars).or_else(|| named(true, &self.point_scalars))
    }
}

/// Walks the XML up to the `AppendedData` marker; the binary block after it is not XML.
fn parse_document(bytes: &[u8]) -> std::result::Result<Document, String> {
    let mut reader = quick_xml::Reader::from_reader(bytes);
    let mut doc = Document {
        compressor: None,
        little_endian: true,
        header_size: 4,
        whole_extent: None,
        piece_extent: None,
        origin: None,
        spacing: None,
        cell_scalars: None,
        point_scalars: None,
        arrays: Vec::new(),
        appended_start: None,
        appended_raw: true,
    };
    let mut saw_root = false;
    let mut section: Option<bool> = None; // Some(on_points) inside PointData/CellData
    let mut open_array: Option<ArrayInfo> = None;
    let mut buf = Vec::new();
    loop {
        let event = reader.read_event_into(&mut buf).map_err(|e| {
            format!(
                "not valid VTK XML near byte {}: {}",
                reader.error_position(),
                // quick-xml quotes the document around the fault, newlines and all.
                crate::error::excerpt(&e.to_string(), 120)
            )
        })?;
        match event {
            Event::Start(ref tag) | Event::Empty(ref tag) => {
                let is_empty = matches!(event, Event::Empty(_));
                match tag.local_name().as_ref() {
                    "VTKFile" => {
                        saw_root = true;
                        read_root(&mut doc, tag)?;
                    }
                    _ if !saw_root => return Err("the root element is not VTKFile".into()),
                    "ImageData" => read_image_data(&mut doc, tag)?,
                    "Piece" => {
                        if doc.piece_extent.is_some() {
                            return Err(
                                "multi-piece ImageData is not supported; save it as one piece"
                                    .into(),
                            );
                        }
                        doc.piece_extent = attr(tag, "Extent")?
                            .map(|s| numbers(&s, "Extent"))
                            .transpose()?;
                    }
                    "PointData" | "CellData" => {
                        let on_points = tag.local_name().as_ref() == "PointData";
                        let scalars = attr(tag, "Scalars")?;
                        if on_points {
                            doc.point_scalars = scalars
                        } else {
                            doc.cell_scalars = scalars
                        }
                        section = (!is_empty).then_some(on_points);
                    }
                    "DataArray" => {
                        if let Some(on_points) = section {
                            let array = data_array(tag, on_points)?;
                            if is_empty {
                                doc.arrays.push(array)
                            } else {
                                open_array = Some(array)
                            }
                        }
                    }
                    "AppendedData" => {
                        read_appended_data(&mut doc, tag, reader.buffer_position(), bytes)?;
                        break;
                    }
                    _ => {}
                }
            }
            Event::Text(text) => {
                if let Some(array) = open_array.as_mut() {
                    array.text.extend_from_slice(text.as_bytes());
                }
            }
            Event::End(tag) => match tag.local_name().as_ref() {
                "DataArray" => doc.arrays.extend(open_array.take()),
                "PointData" | "CellData" => section = None,
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    if !saw_root {
        return Err("no VTKFile element: not a VTK XML file".into());
    }
    Ok(doc)
}

/// The `VTKFile` root's attributes: type ImageData, compressor, byte order, header size.
fn read_root(doc: &mut Document, tag: &BytesStart<'_>) -> std::result::Result<(), String> {
    let kind = attr(tag, "type")?.unwrap_or_default();
    if kind != "ImageData" {
        return Err(format!("VTKFile type is '{kind}', expected ImageData"));
    }
    doc.compressor = attr(tag, "compressor")?
        .map(|c| Compressor::from_name(&c))
        .transpose()?;
    doc.little_endian = attr(tag, "byte_order")?.as_deref() != Some("BigEndian");
    doc.header_size = match attr(tag, "header_type")?.as_deref() {
        None | Some("UInt32") => 4,
        Some("UInt64") => 8,
        Some(other) => return Err(format!("header_type '{other}' is not UInt32 or UInt64")),
    };
    Ok(())
}

/// The `ImageData` element's extent, origin and spacing; a rotated grid is refused.
fn read_image_data(doc: &mut Document, tag: &BytesStart<'_>) -> std::result::Result<(), String> {
    doc.whole_extent = attr(tag, "WholeExtent")?
        .map(|s| numbers(&s, "WholeExtent"))
        .transpose()?;
    doc.origin = attr(tag, "Origin")?
        .map(|s| numbers(&s, "Origin"))
        .transpose()?;
    doc.spacing = attr(tag, "Spacing")?
        .map(|s| numbers(&s, "Spacing"))
        .transpose()?;
    if let Some(d) = attr(tag, "Direction")? {
        let d: [f64; 9] = numbers(&d, "Direction")?;
        if d != [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
            return Err("rotated ImageData (non-identity Direction) is not supported".into());
        }
    }
    Ok(())
}

/// A `DataArray` element's attributes (its text follows as events).
fn data_array(tag: &BytesStart<'_>, on_points: bool) -> std::result::Result<ArrayInfo, String> {
    let type_name = attr(tag, "type")?.unwrap_or_default();
    Ok(ArrayInfo {
        name: attr(tag, "Name")?.unwrap_or_default(),
        element_type: sample_type(&type_name),
        format: attr(tag, "format")?.unwrap_or_else(|| "ascii".into()),
        offset: attr(tag, "offset")?
            .map(|s| {
                s.trim()
                    .parse()
                    .map_err(|_| format!("DataArray offset '{s}' is not a number"))
            })
            .transpose()?,
        components: attr(tag, "NumberOfComponents")?
            .map(|s| {
                s.trim()
                    .parse()
                    .map_err(|_| format!("NumberOfComponents '{s}' is not a number"))
            })
            .transpose()?
            .unwrap_or(1),
        on_points,
        text: Vec::new(),
    })
}

/// The `AppendedData` element's encoding and where its block starts: after the first '_'
/// following the tag, which ends at `after_tag` in `bytes`.
fn read_appended_data(
    doc: &mut Document,
    tag: &BytesStart<'_>,
    after_tag: u64,
    bytes: &[u8],
) -> std::result::Result<(), String> {
    let encoding = attr(tag, "encoding")?.unwrap_or_else(|| "raw".into());
    doc.appended_raw = match encoding.as_str() {
        "raw" => true,
        "base64" => false,
        other => {
            return Err(format!(
                "AppendedData encoding '{other}' is not raw or base64"
            ))
        }
    };
    let after_tag = usize::try_from(after_tag).map_err(|_| "file too large".to_string())?;
    let underscore = bytes[after_tag..]
        .iter()
        .position(|&b| b == b'_')
        .ok_or("AppendedData has no '_' marker")?;
    doc.appended_start = Some(after_tag + underscore + 1);
    Ok(())
}

fn attr(tag: &BytesStart<'_>, key: &str) -> std::result::Result<Option<String>, String> {
    match tag.try_get_attribute(key) {
        Ok(Some(a)) => a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map(|v| Some(v.into_owned()))
            .map_err(|e| format!("attribute {key}: {e}")),
        Ok(None) => Ok(None),
        Err(e) => Err(format!("attributes of <{}>: {e}", tag.name().as_ref())),
    }
}

fn numbers<T: std::str::FromStr + Copy + Default, const N: usize>(
    text: &str,
    what: &str,
) -> std::result::Result<[T; N], String> {
    let parsed: Vec<T> = text
        .split_ascii_whitespace()
        .map(|t| {
            t.parse()
                .map_err(|_| format!("{what} '{text}' is not {N} numbers"))
        })
        .collect::<std::result::Result<_, _>>()?;
    parsed
        .try_into()
        .map_err(|_| format!("{what} '{text}' is not {N} numbers"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine as _;
    use std::path::PathBuf;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("datasets/fixtures")
            .join(name)
    }

    /// What datasets/fixtures/make_fixtures.py gave VTK: 4x3x2 cells, value 100k + 10j + i.
    fn fixture_volume() -> VtiVolume {
        let data = (0..2)
            .flat_map(|k| {
                (0..3).flat_map(move |j| (0..4).map(move |i| (100 * k + 10 * j + i) as f32))
            })
            .collect();
        VtiVolume {
            dims: [4, 3, 2],
            spacing: [0.5, 0.25, 2.0],
            origin: [-1.0, 2.0, 0.5],
            name: "density".into(),
            data,
        }
    }

    #[test]
    fn reads_vtk_written_fixtures_in_every_uncompressed_layout() {
        for name in [
            "cells_ascii.vti",
            "cells_binary.vti",
            "cells_appended.vti",
            "cells_appended_base64.vti",
        ] {
            assert_eq!(read_vti(fixture(name)).unwrap(), fixture_volume(), "{name}");
        }
    }

    #[test]
    fn reads_the_vtk_written_zlib_fixture() {
        assert_eq!(
            read_vti(fixture("cells_zlib.vti")).unwrap(),
            fixture_volume()
        );
    }

    /// A compressed block in VTK's layout around `payload`: one block, UInt32 header.
    fn one_block_file(dir: &Path, compressor: &str, payload: &[u8], size: u32) -> PathBuf {
        let mut block = Vec::new();
        for n in [1, size, size, payload.len() as u32] {
            block.extend(n.to_le_bytes());
        }
        let engine = base64::engine::general_purpose::STANDARD;
        let text = format!("{}{}", engine.encode(&block), engine.encode(payload));
        let path = dir.join(format!("{compressor}.vti"));
        std::fs::write(&path, format!(
            "<VTKFile type=\"ImageData\" version=\"0.1\" byte_order=\"LittleEndian\" compressor=\"{compressor}\">\
             <ImageData WholeExtent=\"0 2 0 1 0 1\" Origin=\"0 0 0\" Spacing=\"1 1 1\"><Piece Extent=\"0 2 0 1 0 1\">\
             <CellData Scalars=\"s\"><DataArray type=\"Float32\" Name=\"s\" format=\"binary\">{text}</DataArray></CellData>\
             </Piece></ImageData></VTKFile>")).unwrap();
        path
    }

    #[test]
    fn lz4_blocks_round_trip_and_bad_blocks_name_the_array() {
        let dir = tempfile::tempdir().unwrap();
        let values: Vec<u8> = [1.5f32, -2.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let lz4 = lz4_flex::block::compress(&values);
        let path = one_block_file(dir.path(), "vtkLZ4DataCompressor", &lz4, 8);
        assert_eq!(read_vti(&path).unwrap().data, [1.5, -2.0]);
        // A header that promises 12 bytes for 2 cells, and a block that is not LZ4.
        let path = one_block_file(dir.path(), "vtkLZ4DataCompressor", &lz4, 12);
        let err = read_vti(&path).unwrap_err().to_string();
        assert!(
            err.contains("array 's'") && err.contains("12 bytes in all; the extent needs 8"),
            "{err}"
        );
        let path = one_block_file(dir.path(), "vtkZLibDataCompressor", &lz4, 8);
        let err = read_vti(&path).unwrap_err().to_string();
        assert!(
            err.contains("Compressor.vti: array 's': corrupt zlib block"),
            "{err}"
        );
        let path = one_block_file(dir.path(), "vtkZstdCompressor", &lz4, 8);
        let err = read_vti(&path).unwrap_err().to_string();
        assert!(
            err.contains("compressor 'vtkZstdCompressor' is not supported"),
            "{err}"
        );
    }

    #[test]
    fn write_then_read_round_trips_bit_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.vti");
        let data = vec![
            0.0,
            -1.5,
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::NAN,
            1e-30,
            3.25,
            7.0,
            8.0,
            9.0,
            10.0,
            11.0,
        ];
        write_vti(
            &path,
            [3, 2, 2],
            [0.1, 0.2, 0.3],
            [1.0, -2.0, 1e6],
            "rho",
            &data,
        )
        .unwrap();
        let v = read_vti(&path).unwrap();
        assert_eq!(
            (v.dims, v.spacing, v.origin, v.name.as_str()),
            ([3, 2, 2], [0.1, 0.2, 0.3], [1.0, -2.0, 1e6], "rho")
        );
        let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&v.data), bits(&data));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn point_data_becomes_cells_centred_on_the_points() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.vti");
        // Two points along x at 10 and 12, written as uncompressed inline base64 (UInt32 count).
        let mut block = 8u32.to_le_bytes().to_vec();
        block.extend([1.0f32, 2.0].iter().flat_map(|v| v.to_le_bytes()));
        let text = base64::engine::general_purpose::STANDARD.encode(&block);
        std::fs::write(&path, format!(
            "<VTKFile type=\"ImageData\" version=\"0.1\" byte_order=\"LittleEndian\">\
             <ImageData WholeExtent=\"0 1 0 0 0 0\" Origin=\"10 0 0\" Spacing=\"2 1 1\"><Piece Extent=\"0 1 0 0 0 0\">\
             <PointData Scalars=\"s\"><DataArray type=\"Float32\" Name=\"s\" format=\"binary\">{text}</DataArray></PointData>\
             <CellData></CellData></Piece></ImageData></VTKFile>")).unwrap();
        let v = read_vti(&path).unwrap();
        assert_eq!(
            (v.dims, v.origin, v.data),
            ([2, 1, 1], [9.0, -0.5, -0.5], vec![1.0, 2.0])
        );
    }

    #[test]
    fn truncated_and_garbage_files_give_one_line_errors() {
        let cut = Path::new("cut.vti");
        for name in [
            "cells_ascii.vti",
            "cells_binary.vti",
            "cells_appended.vti",
            "cells_appended_base64.vti",
            "cells_zlib.vti",
        ] {
            let bytes = std::fs::read(fixture(name)).unwrap();
            for len in 0..bytes.len() {
                // Cutting only the closing tags of a file loses no data, so success is allowed then.
                match read_vti_bytes(cut, &bytes[..len]) {
                    Ok(v) => assert_eq!(v, fixture_volume(), "{name} cut to {len}"),
                    Err(e) => {
                        let text = e.to_string();
                        assert!(
                            text.starts_with("cut.vti: ") && !text.contains('\n'),
                            "{text}"
                        );
                    }
                }
            }
        }
        let garbage = b"\x89HDF\r\n\x1a\n not xml at all";
        assert!(read_vti_bytes(cut, garbage).is_err());
        // The path-based entry point reports the same way.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cut.vti");
        std::fs::write(&path, &garbage[..]).unwrap();
        assert!(read_vti(&path).unwrap_err().to_string().contains("cut.vti"));
    }

    #[test]
    fn bad_parameters_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.vti");
        let err = write_vti(&path, [2, 2, 2], [1.0; 3], [0.0; 3], "a", &[0.0; 7]).unwrap_err();
        assert_eq!(err.to_string(), "data: has 7 values; dims 2x2x2 need 8");
        let err =
            write_vti(&path, [2, 2, 2], [1.0, 0.0, 1.0], [0.0; 3], "a", &[0.0; 8]).unwrap_err();
        assert!(err.to_string().starts_with("spacing.y:"), "{err}");
        assert!(!path.exists());
    }
}
