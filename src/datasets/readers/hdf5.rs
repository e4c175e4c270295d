//! Plain HDF5 datasets (`.h5`, `.hdf5`, `.he5`), read by `hdf5-reader`, the pure-Rust reader
//! that `netcdf-reader` uses for NetCDF-4: any layout (contiguous, compact, chunked with deflate,
//! shuffle, Fletcher-32 or LZ4, whose filter hdrvis decodes itself), integers and floats of either
//! byte order. A dataset is named by its path inside the file (`file.h5:/group/name`); a 3-D one
//! of shape (nz, ny, nx) loads like a `.npy` (spacing 1, origin 0), with units from a `units`
//! attribute. CF's masking and packing attributes, where a writer gave them (`_FillValue`,
//! `missing_value`, `valid_range`, `scale_factor`, `add_offset`, `_Unsigned`), are decoded by the
//! same decoder as NetCDF's (`conventions::cf_decode`), without netCDF's default fills, which
//! are netCDF's own. A dataset the reader cannot open (a virtual dataset) is listed with the
//! reason and leaves the rest of the file readable.

use std::path::Path;

use hdf5_reader::filters::FILTER_LZ4;
use hdf5_reader::group::Group;
use hdf5_reader::{ByteOrder, Dataset, Datatype, FilterRegistry, Hdf5File};

use super::scalar::Scalar;
use super::variables::NcAttribute;
use crate::datasets::conventions::cf_decode::{CfDecoding, Stored};
use crate::datasets::{ArrayData, ArrayListing};
use crate::error::{Error, Result};

fn open(path: &Path) -> Result<Hdf5File> {
    let options = hdf5_reader::OpenOptions::default().with_filter_registry(filters());
    Hdf5File::open_with_options(path, options)
        .map_err(|e| Error::format(path, format!("not a readable HDF5 file: {e}")))
}

/// The reader's filters with its LZ4 decoder replaced by [`decode_lz4`]: `hdf5-reader` 0.12 reads
/// a block size before every block, which holds only when a chunk is one block.
pub(crate) fn filters() -> FilterRegistry {
    let mut registry = FilterRegistry::new();
    registry.register(
        FILTER_LZ4,
        Box::new(|_, data, _| {
            decode_lz4(data)
                .map_err(|e| hdf5_reader::error::Error::DecompressionError(format!("LZ4: {e}")))
        }),
    );
    registry
}

/// LZ4 expands by at most 255:1, so a declared size past this multiple of the input is corrupt
/// and refused before anything is allocated for it.
const LZ4_MAX_EXPANSION: usize = 256;

/// One chunk of the HDF5 LZ4 filter (id 32004, the HDF Group's `H5Zlz4.c`): the original size
/// (8 bytes, big-endian), the block size (4 bytes), then per block its compressed size (4 bytes)
/// and the block, stored raw where that size equals the block's original size (the last block
/// holds what remains).
pub(crate) fn decode_lz4(data: &[u8]) -> std::result::Result<Vec<u8>, String> {
    let word = |at: usize, n: usize| -> std::result::Result<u64, String> {
        let bytes = data
            .get(at..at + n)
            .ok_or_else(|| format!("truncated header at byte {at} of {}", data.len()))?;
        Ok(bytes.iter().fold(0u64, |acc, &b| acc << 8 | u64::from(b)))
    };
    let total = usize::try_from(word(0, 8)?).map_err(|_| "declared size too large".to_string())?;
    let block = word(8, 4)? as usize;
    if total > data.len().saturating_mul(LZ4_MAX_EXPANSION) {
        return Err(format!(
            "declares {total} bytes from {} compressed bytes",
            data.len()
        ));
    }
    if block == 0 && total > 0 {
        return Err("block size 0".into());
    }
    let mut out = Vec::with_capacity(total);
    let mut at = 12;
    while out.len() < total {
        let want = block.min(total - out.len());
        let size = word(at, 4)? as usize;
        at += 4;
        let bytes = data
            .get(at..at.saturating_add(size))
            .ok_or_else(|| format!("block of {size} bytes past the end of the chunk"))?;
        if size == want {
            out.extend_from_slice(bytes);
        } else {
            let decoded = lz4_flex::decompress(bytes, want).map_err(|e| e.to_string())?;
            if decoded.len() != want {
                return Err(format!(
                    "a block decodes to {} bytes, not {want}",
                    decoded.len()
                ));
            }
            out.extend_from_slice(&decoded);
        }
        at += size;
    }
    Ok(out)
}

/// The stored sample type and byte order (`true`: big-endian) of a numeric datatype.
fn sample_type(dtype: &Datatype) -> Option<(Scalar, bool)> {
    let (scalar, order) = match *dtype {
        Datatype::FloatingPoint { size, byte_order } => (
            match size {
                2 => Scalar::F16,
                4 => Scalar::F32,
                8 => Scalar::F64,
                _ => return None,
            },
            byte_order,
        ),
        Datatype::FixedPoint {
            size,
            signed,
            byte_order,
        } => (
            match (size, signed) {
                (1, true) => Scalar::I8,
                (1, false) => Scalar::U8,
                (2, true) => Scalar::I16,
                (2, false) => Scalar::U16,
                (4, true) => Scalar::I32,
                (4, false) => Scalar::U32,
                (8, true) => Scalar::I64,
                (8, false) => Scalar::U64,
                _ => return None,
            },
            byte_order,
        ),
        _ => return None,
    };
    Some((scalar, order == ByteOrder::BigEndian))
}

/// The stored type CF decoding compares attributes in.
fn stored_of(sample: Scalar) -> Stored {
    let int = |bits, unsigned| Stored::Int { bits, unsigned };
    match sample {
        Scalar::F32 => Stored::Float32,
        Scalar::F64 => Stored::Float64,
        Scalar::I8 => int(8, false),
        Scalar::U8 => int(8, true),
        Scalar::I16 => int(16, false),
        Scalar::U16 => int(16, true),
        Scalar::I32 => int(32, false),
        Scalar::U32 => int(32, true),
        Scalar::I64 => int(64, false),
        Scalar::U64 => int(64, true),
        _ => Stored::Other,
    }
}

/// A dataset's attributes as CF decoding reads them: numbers as f64, strings as text.
fn cf_attributes(dataset: &Dataset) -> Vec<(String, NcAttribute)> {
    dataset
        .attributes()
        .into_iter()
        .filter_map(|a| match sample_type(&a.datatype) {
            Some((sample, big)) => Some((
                a.name.clone(),
                NcAttribute::Numbers(sample.decode_f64(big, &a.raw_data)),
            )),
            None => a.read_string().ok().map(|t| {
                let t = t.trim_end_matches('\0').to_string();
                (a.name.clone(), NcAttribute::Text(t))
            }),
        })
        .collect()
}

/// A short name of a datatype for listings: `float32`, `int16`, … or `other`.
fn type_name(dtype: &Datatype) -> String {
    sample_type(dtype)
        .map_or("other", |(s, _)| s.name())
        .to_string()
}

/// Every dataset in the file, by full path (`/group/name`), in listing order. A dataset that
/// cannot be opened (a virtual dataset) is listed with the reason instead of failing the file.
pub(crate) fn list_datasets(path: &Path) -> Result<Vec<ArrayListing>> {
    let file = open(path)?;
    let root = file
        .root_group()
        .map_err(|e| Error::format(path, e.to_string()))?;
    let mut listed = Vec::new();
    let mut pending = vec![(String::new(), root)];
    while let Some((prefix, group)) = pending.pop() {
        let (groups, datasets) = match group.members() {
            Ok(members) => members,
            Err(whole) => members_one_by_one(&file, &group, &prefix, &mut listed)
                .map_err(|_| Error::format(path, format!("group '{prefix}/': {whole}")))?,
        };
        for d in datasets {
            listed.push(ArrayListing {
                name: format!("{prefix}/{}", d.name()),
                shape: d.shape().iter().map(|&n| n as usize).collect(),
                dtype: type_name(d.dtype()),
                is_coordinate: false,
                is_auxiliary: false,
                unreadable: None,
            });
        }
        // Reversed so that the stack visits groups in listing order.
        for g in groups.into_iter().rev() {
            pending.push((format!("{prefix}/{}", g.name()), g));
        }
    }
    Ok(listed)
}

/// Whether an HDF5 file is laid out as NetCDF-4 is, so that the NetCDF reader's dimensions and
/// CF decoding apply: netCDF-C's `_NCProperties` on the root group, or (as h5py and h5netcdf
/// write) datasets in the root group only, some of them dimension scales or attached to one
/// (`CLASS`, `DIMENSION_LIST`), and no MintPy product. Any trouble reading the file says no: the
/// HDF5 reader then says what is wrong.
pub(crate) fn has_netcdf_dimensions(path: &Path) -> bool {
    let Ok(file) = open(path) else {
        return false;
    };
    let Ok(root) = file.root_group() else {
        return false;
    };
    let Ok(root_attrs) = root.attributes() else {
        return false;
    };
    let root_attrs: Vec<String> = root_attrs.into_iter().map(|a| a.name).collect();
    if root_attrs.iter().any(|n| n == "_NCProperties") {
        return true;
    }
    if root_attrs.iter().any(|n| n == "FILE_TYPE") {
        return false;
    }
    let Ok((groups, datasets)) = root.members() else {
        return false;
    };
    groups.is_empty()
        && datasets.iter().any(|d| {
            d.attributes()
                .iter()
                .any(|a| a.name == "DIMENSION_LIST" || a.name == "CLASS")
        })
}

/// A group's members opened one at a time, for a group where opening them all at once fails:
/// `hdf5-reader` 0.12 fails the whole of `Group::members` on one child it cannot parse (a
/// virtual dataset's layout, class 3). Each child that opens as neither a group nor a dataset is
/// pushed onto `listed` as unreadable, with the reason.
fn members_one_by_one(
    file: &Hdf5File,
    group: &Group,
    prefix: &str,
    listed: &mut Vec<ArrayListing>,
) -> std::result::Result<(Vec<Group>, Vec<Dataset>), hdf5_reader::error::Error> {
    use hdf5_reader::error::Error as H5Error;
    let (mut groups, mut datasets) = (Vec::new(), Vec::new());
    for name in link_names(file, group)? {
        if let Ok(g) = group.group(&name) {
            groups.push(g);
            continue;
        }
        match group.dataset(&name) {
            Ok(d) => datasets.push(d),
            // Neither a group nor a dataset: a committed datatype, as the reader skips it too.
            Err(H5Error::DatasetNotFound(_)) => {}
            Err(e) => {
                let text = e.to_string();
                let why = if text.contains("layout class 3") {
                    "a virtual dataset (VDS), which hdrvis's HDF5 reader does not read".to_string()
                } else {
                    text.replace(['\n', '\r'], " ")
                };
                listed.push(ArrayListing {
                    name: format!("{prefix}/{name}"),
                    shape: Vec::new(),
                    dtype: "other".into(),
                    is_coordinate: false,
                    is_auxiliary: false,
                    unreadable: Some(why),
                });
            }
        }
    }
    Ok((groups, datasets))
}

/// The names of a group's links, read from the group's own header and name heap without opening
/// the objects they name: compact links, or an old-style group's symbol table (h5py's default).
/// Links in dense storage (a fractal heap) are not walked here.
fn link_names(
    file: &Hdf5File,
    group: &Group,
) -> std::result::Result<Vec<String>, hdf5_reader::error::Error> {
    use hdf5_reader::btree_v1::collect_btree_v1_leaves_storage;
    use hdf5_reader::io::Cursor;
    use hdf5_reader::local_heap::LocalHeap;
    use hdf5_reader::messages::HdfMessage;
    use hdf5_reader::symbol_table::SymbolTableNode;
    let storage = group.storage();
    let (offsets, lengths) = (group.offset_size(), group.length_size());
    let mut names = Vec::new();
    for message in &file.get_or_parse_header(group.address())?.messages {
        match message {
            HdfMessage::Link(link) => names.push(link.name.clone()),
            HdfMessage::LinkInfo(info)
                if !Cursor::is_undefined_offset(info.fractal_heap_address, offsets) =>
            {
                return Err(hdf5_reader::error::Error::Other(
                    "links in dense storage".into(),
                ));
            }
            HdfMessage::SymbolTable(table) => {
                let heap =
                    LocalHeap::parse_at_storage(storage, table.heap_address, offsets, lengths)?;
                let leaves = collect_btree_v1_leaves_storage(
                    storage,
                    table.btree_address,
                    offsets,
                    lengths,
                    None,
                    &[],
                    None,
                )?;
                for (_, node) in leaves {
                    // A symbol table node: "SNOD", version, reserved, the entry count (u16 LE),
                    // then entries of two addresses, two u32 and a 16-byte scratch pad each.
                    let head = storage.read_range(node, 8)?;
                    let count = usize::from(u16::from_le_bytes([head[6], head[7]]));
                    let len = 8 + count * (2 * usize::from(offsets) + 24);
                    let bytes = storage.read_range(node, len)?;
                    let node = SymbolTableNode::parse(&mut Cursor::new(&bytes), offsets, lengths)?;
                    for entry in &node.entries {
                        names.push(heap.get_string_storage(entry.link_name_offset, storage)?);
                    }
                }
            }
            _ => {}
        }
    }
    Ok(names)
}

/// The numeric dataset `name` (a path inside the file, with or without the leading '/'): its
/// shape, values (C order, in f64: float64 data keep their precision) and `units` attribute. Without `name`, an
/// error lists the 3-D numeric datasets.
pub(crate) fn read_dataset(path: &Path, name: Option<&str>) -> Result<ArrayData> {
    let listed = list_datasets(path)?;
    let describe = |rank: Option<usize>| {
        let names: Vec<String> = listed
            .iter()
            .filter(|a| rank.is_none_or(|r| a.shape.len() == r) && a.dtype != "other")
            .map(|a| format!("{} {:?} {}", a.name, a.shape, a.dtype))
            .collect();
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    };
    let Some(name) = name else {
        return Err(Error::format(
            path,
            format!(
                "name the dataset to read as FILE:/group/name (or variable); the 3-D datasets are: {}",
                describe(Some(3))
            ),
        ));
    };
    let full = format!("/{}", name.trim_start_matches('/'));
    let Some(listing) = listed.iter().find(|a| a.name == full) else {
        return Err(Error::format(
            path,
            format!(
                "no dataset '{full}'; the numeric datasets are: {}",
                describe(None)
            ),
        ));
    };
    let fail = |msg: String| Error::format(path, format!("dataset '{full}': {msg}"));
    if let Some(why) = &listing.unreadable {
        return Err(fail(format!("not read: {why}")));
    }
    let file = open(path)?;
    let dataset = file.dataset(&full).map_err(|e| fail(e.to_string()))?;
    let (sample, big) = sample_type(dataset.dtype()).ok_or_else(|| {
        fail(format!(
            "type {:?} is not an integer or float type",
            dataset.dtype()
        ))
    })?;
    let count = listing
        .shape
        .iter()
        .try_fold(1usize, |acc, &n| acc.checked_mul(n))
        .ok_or_else(|| fail(format!("shape {:?} is too large", listing.shape)))?;
    crate::model::volume::check_allocation(
        (count as u64).saturating_mul(8 + sample.size() as u64),
        &format!("{}: dataset '{full}'", path.display()),
    )?;
    let raw = dataset.read_raw_bytes().map_err(|e| fail(e.to_string()))?;
    if raw.len() != count * sample.size() {
        return Err(fail(format!(
            "read {} bytes; shape {:?} needs {}",
            raw.len(),
            listing.shape,
            count * sample.size()
        )));
    }
    let units = dataset
        .attribute("units")
        .ok()
        .and_then(|a| a.read_string().ok())
        .map(|u| u.trim_end_matches('\0').to_string())
        .filter(|u| !u.is_empty());
    let mut values = sample.decode_f64(big, &raw);
    // CF's attributes where the writer gave them (xarray's h5netcdf, satellite products):
    // NaN stored as data is not a fill.
    let stored_nan = values.iter().filter(|v| v.is_nan()).count();
    let decoding = CfDecoding::with_defaults(&cf_attributes(&dataset), stored_of(sample), false);
    decoding.apply(&mut values);
    let fill_count = values.iter().filter(|v| v.is_nan()).count() - stored_nan;
    let mut array =
        crate::datasets::plain_array(&full, listing.shape.clone(), listing.dtype.clone(), values);
    array.units = units;
    array.fill_count = fill_count;
    Ok(array)
}

/// The root group's attributes as text: strings as stored (fixed or variable length, trailing
/// NULs dropped), numeric scalars formatted; others are left out. MintPy keeps its metadata
/// there, every value a string.
pub(crate) fn root_attributes(path: &Path) -> Result<Vec<(String, String)>> {
    let file = open(path)?;
    let root = file
        .root_group()
        .map_err(|e| Error::format(path, e.to_string()))?;
    let attrs = root
        .attributes()
        .map_err(|e| Error::format(path, format!("root attributes: {e}")))?;
    Ok(attrs
        .into_iter()
        .filter_map(|a| {
            let text = match a.read_string() {
                Ok(s) => s.trim_end_matches('\0').to_string(),
                Err(_) => a.read_as_f64().ok()?.to_string(),
            };
            Some((a.name.clone(), text))
        })
        .collect())
}

/// The strings of a 1-D string dataset (MintPy's `date` list of `YYYYMMDD` byte strings).
pub(crate) fn read_strings(path: &Path, name: &str) -> Result<Vec<String>> {
    let file = open(path)?;
    let full = format!("/{}", name.trim_start_matches('/'));
    let fail = |msg: String| Error::format(path, format!("dataset '{full}': {msg}"));
    let dataset = file.dataset(&full).map_err(|e| fail(e.to_string()))?;
    let strings = dataset.read_strings().map_err(|e| fail(e.to_string()))?;
    Ok(strings
        .into_iter()
        .map(|s| s.trim_end_matches('\0').trim().to_string())
        .collect())
}

/// One plane `[first, ..]` of a numeric dataset of rank 2 or more (only that plane is read),
/// or the whole dataset without `first`; values in C order as f64 and the shape read.
pub(crate) fn read_plane(path: &Path, name: &str, first: Option<usize>) -> Result<ArrayData> {
    let Some(first) = first else {
        return read_dataset(path, Some(name));
    };
    use hdf5_reader::{SliceInfo, SliceInfoElem};
    let file = open(path)?;
    let full = format!("/{}", name.trim_start_matches('/'));
    let fail = |msg: String| Error::format(path, format!("dataset '{full}': {msg}"));
    let dataset = file.dataset(&full).map_err(|e| fail(e.to_string()))?;
    let shape: Vec<usize> = dataset.shape().iter().map(|&n| n as usize).collect();
    let mut selections = vec![SliceInfoElem::Index(first as u64)];
    selections.extend((1..shape.len()).map(|_| SliceInfoElem::Slice {
        start: 0,
        end: u64::MAX,
        step: 1,
    }));
    let slice = SliceInfo { selections };
    let (sample, _) = sample_type(dataset.dtype()).ok_or_else(|| {
        fail(format!(
            "type {:?} is not an integer or float type",
            dataset.dtype()
        ))
    })?;
    macro_rules! plane {
        ($t:ty) => {
            dataset
                .read_slice::<$t>(&slice)
                .map(|a| a.iter().map(|&v| v as f64).collect::<Vec<f64>>())
        };
    }
    let values = match sample {
        Scalar::F32 => plane!(f32),
        Scalar::F64 => plane!(f64),
        Scalar::I8 => plane!(i8),
        Scalar::I16 => plane!(i16),
        Scalar::I32 => plane!(i32),
        Scalar::I64 => plane!(i64),
        Scalar::U8 => plane!(u8),
        Scalar::U16 => plane!(u16),
        Scalar::U32 => plane!(u32),
        Scalar::U64 => plane!(u64),
        Scalar::F16 => return Err(fail("float16 planes are not read one at a time".into())),
    }
    .map_err(|e| fail(e.to_string()))?;
    let mut array = crate::datasets::plain_array(
        &full,
        shape[1..].to_vec(),
        sample.name().to_string(),
        values,
    );
    array.units = dataset
        .attribute("units")
        .ok()
        .and_then(|a| a.read_string().ok())
        .map(|u| u.trim_end_matches('\0').to_string())
        .filter(|u| !u.is_empty());
    Ok(array)
}
