//! NumPy `.npy` arrays (C order; f32, f64, i16, u16, u8, bool and the other plain numeric types)
//! read through the `npyz` crate, with the declared size checked against the file before anything
//! is allocated; `.npy` output for generated fields and `.npz` archives of named arrays. Headers
//! that Python 2's numpy wrote (sizes as long integers, `(2L, 3L)`) are read as numpy reads them.

use crate::error::{Error, Result};
use npyz::{DType, TypeChar};
use std::io::Read;
use std::path::Path;

/// The stream an `.npy` reader reads from: the (possibly rewritten) magic and header, then the
/// rest of the file.
pub(crate) type NpyStream<R> = std::io::Chain<std::io::Cursor<Vec<u8>>, R>;

/// Opens an `.npy` stream with npyz. Python 2's numpy wrote the sizes of the shape as long
/// integers (`'shape': (2L, 3L)`), which numpy still reads and npyz's parser refuses, so that
/// `L` is dropped from the header before npyz sees it.
pub(crate) fn open_npy<R: Read>(mut reader: R) -> std::io::Result<npyz::NpyFile<NpyStream<R>>> {
    let mut lead = vec![0u8; 8];
    reader.read_exact(&mut lead)?;
    let len_bytes = if lead[6] == 1 { 2 } else { 4 };
    let mut len = [0u8; 4];
    reader.read_exact(&mut len[..len_bytes])?;
    let header_len = u32::from_le_bytes(len) as u64;
    let mut header = Vec::new();
    // Grows only with the bytes actually there, whatever length the file claims.
    (&mut reader).take(header_len).read_to_end(&mut header)?;
    let fixed = drop_long_suffixes(&header);
    let mut head = lead;
    match (&fixed, len_bytes) {
        (Some(fixed), 2) => head.extend((fixed.len() as u16).to_le_bytes()),
        (Some(fixed), _) => head.extend((fixed.len() as u32).to_le_bytes()),
        (None, _) => head.extend(&len[..len_bytes]),
    }
    head.extend(fixed.as_ref().unwrap_or(&header));
    npyz::NpyFile::new(std::io::Cursor::new(head).chain(reader))
}

/// The header with the `L` of Python 2 long integers (`3L,` `3L)`) removed, if it has any.
fn drop_long_suffixes(header: &[u8]) -> Option<Vec<u8>> {
    let is_long = |i: usize| {
        header[i] == b'L'
            && i > 0
            && header[i - 1].is_ascii_digit()
            && matches!(header.get(i + 1), Some(b',' | b')' | b' '))
    };
    let longs: Vec<usize> = (0..header.len()).filter(|&i| is_long(i)).collect();
    if longs.is_empty() {
        return None;
    }
    // Keep the header's length (numpy pads it to a multiple of 64 bytes): a space per `L`.
    let mut out = header.to_vec();
    for i in longs.into_iter().rev() {
        out.remove(i);
        let at = out.iter().rposition(|&b| b == b'\n').unwrap_or(out.len());
        out.insert(at, b' ');
    }
    Some(out)
}

/// npyz's error for a header it cannot read, as one line: the parser's multi-line report of a
/// header that is not a Python literal becomes its position.
pub(crate) fn header_error(e: &std::io::Error) -> String {
    let text = e.to_string();
    if let Some(rest) = text.strip_prefix("could not parse Python expression:") {
        let at = rest
            .split_whitespace()
            .skip_while(|w| *w != "-->")
            .nth(1)
            .map(|p| format!(" (parse error at line:column {p})"))
            .unwrap_or_default();
        return format!(
            "not a valid .npy file: the header is not the Python dict literal numpy writes{at}"
        );
    }
    let first: String = text
        .lines()
        .next()
        .unwrap_or_default()
        .chars()
        .take(160)
        .flat_map(char::escape_debug)
        .collect();
    format!("not a valid .npy file: {first}")
}

/// An n-dimensional array read from disk, converted to the requested float type.
#[derive(Clone, Debug)]
pub(crate) struct NpyArray<T> {
    /// Shape as NumPy reports it (slowest axis first).
    pub shape: Vec<usize>,
    pub data: Vec<T>,
    /// The on-disk dtype, e.g. "<f4".
    pub dtype: String,
}

/// Floating types an array can be read into.
pub(crate) trait ReadAs: Copy + Send + 'static {
    fn from_f64(v: f64) -> Self;
    fn from_f32(v: f32) -> Self;
}
impl ReadAs for f32 {
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    fn from_f32(v: f32) -> Self {
        v
    }
}
impl ReadAs for f64 {
    fn from_f64(v: f64) -> Self {
        v
    }
    fn from_f32(v: f32) -> Self {
        v as f64
    }
}

pub(crate) fn read_npy<T: ReadAs>(path: &Path) -> Result<NpyArray<T>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let file_len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    read_npy_from(std::io::BufReader::new(file), file_len, path)
}

/// Reads an array from any reader (a plain file or a member of an `.npz` archive); `byte_len` is
/// the stored size, used to refuse headers that promise more data than exists.
pub(crate) fn read_npy_from<T: ReadAs, R: std::io::Read>(
    reader: R,
    byte_len: u64,
    path: &Path,
) -> Result<NpyArray<T>> {
    let npy = open_npy(reader).map_err(|e| Error::format(path, header_error(&e)))?;
    let shape: Vec<usize> = npy.shape().iter().map(|&s| s as usize).collect();
    if npy.order() == npyz::Order::Fortran {
        return Err(Error::format(
            path,
            "array is in Fortran order; expected C order (save with np.ascontiguousarray)",
        ));
    }
    let ts = match npy.dtype() {
        DType::Plain(ts) => ts,
        other => {
            return Err(Error::format(
                path,
                format!(
                    "unsupported dtype {}; expected a plain numeric type such as <f4",
                    other.descr()
                ),
            ))
        }
    };
    let dtype = ts.to_string();
    let item = ts.num_bytes().unwrap_or(0) as u64;
    let count: u64 = shape.iter().map(|&s| s as u64).product();
    if count.saturating_mul(item) > byte_len {
        return Err(Error::format(
            path,
            format!(
                "header declares shape {shape:?} of {dtype} ({} bytes) but the file holds only {byte_len} bytes",
                count.saturating_mul(item)
            ),
        ));
    }
    let data: Vec<T> = match (ts.type_char(), item) {
        (TypeChar::Float, 4) => values(npy, path, T::from_f32)?,
        (TypeChar::Float, 8) => values(npy, path, T::from_f64)?,
        (TypeChar::Float, 2) => values(npy, path, |v: half::f16| T::from_f32(v.to_f32()))?,
        (TypeChar::Int, 1) => values(npy, path, |v: i8| T::from_f32(v as f32))?,
        (TypeChar::Int, 2) => values(npy, path, |v: i16| T::from_f32(v as f32))?,
        (TypeChar::Int, 4) => values(npy, path, |v: i32| T::from_f64(v as f64))?,
        (TypeChar::Int, 8) => values(npy, path, |v: i64| T::from_f64(v as f64))?,
        (TypeChar::Uint, 1) => values(npy, path, |v: u8| T::from_f32(v as f32))?,
        (TypeChar::Bool, 1) => values(npy, path, |v: bool| T::from_f32(f32::from(u8::from(v))))?,
        (TypeChar::Uint, 2) => values(npy, path, |v: u16| T::from_f32(v as f32))?,
        (TypeChar::Uint, 4) => values(npy, path, |v: u32| T::from_f64(v as f64))?,
        (TypeChar::Uint, 8) => values(npy, path, |v: u64| T::from_f64(v as f64))?,
        _ => {
            return Err(Error::format(
                path,
                format!("unsupported dtype {dtype}; expected float (f2/f4/f8), int or uint"),
            ))
        }
    };
    if data.len() as u64 != count {
        return Err(Error::format(
            path,
            format!("expected {count} values, read {}", data.len()),
        ));
    }
    Ok(NpyArray { shape, data, dtype })
}

/// Every value of the array read as its stored type `S` and converted by `convert`.
fn values<S: npyz::Deserialize, T, R: std::io::Read>(
    npy: npyz::NpyFile<R>,
    path: &Path,
    convert: impl Fn(S) -> T,
) -> Result<Vec<T>> {
    let stored = npy
        .into_vec::<S>()
        .map_err(|e| Error::format(path, format!("data truncated or unreadable: {e}")))?;
    Ok(stored.into_iter().map(convert).collect())
}

/// Writes a C-ordered array (f32 or f64) atomically.
pub fn write_npy<T: npyz::AutoSerialize + Copy>(
    path: &Path,
    shape: &[usize],
    data: &[T],
) -> Result<()> {
    crate::io::write_atomic(path, |w| write_npy_to(w, path, shape, data))
}

/// One named array of an `.npz` archive: name, shape (C order) and values.
pub(crate) type NpzArray<'a, T> = (&'a str, &'a [usize], &'a [T]);

/// Writes named C-ordered arrays as an `.npz` archive atomically, one `NAME.npy` member each:
/// stored as `np.savez` writes them or, with `compressed`, deflated as `np.savez_compressed` does.
pub fn write_npz<T: npyz::AutoSerialize + Copy>(
    path: &Path,
    arrays: &[NpzArray<'_, T>],
    compressed: bool,
) -> Result<()> {
    use zip::write::SimpleFileOptions;
    let zip_error = |e: zip::result::ZipError| Error::io(path, e.into());
    let method = if compressed {
        zip::CompressionMethod::Deflated
    } else {
        zip::CompressionMethod::Stored
    };
    crate::io::write_atomic(path, |w| {
        let mut archive = zip::ZipWriter::new(w);
        for &(name, shape, data) in arrays {
            // Zip64 records only where a member may pass 4 GiB (the header adds at most a few KiB).
            let large = std::mem::size_of_val(data) as u64 + 65_536 > u64::from(u32::MAX);
            let options = SimpleFileOptions::default()
                .compression_method(method)
                .large_file(large);
            archive
                .start_file(npyz::npz::file_name_from_array_name(name), options)
                .map_err(zip_error)?;
            write_npy_to(&mut archive, path, shape, data)?;
        }
        archive.finish().map_err(zip_error)?;
        Ok(())
    })
}

/// The `.npy` bytes of a C-ordered array, written to `w`; `path` names the file in errors.
fn write_npy_to<T: npyz::AutoSerialize + Copy, W: std::io::Write>(
    w: W,
    path: &Path,
    shape: &[usize],
    data: &[T],
) -> Result<()> {
    use npyz::WriterBuilder;
    let shape: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    let mut writer = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&shape)
        .writer(w)
        .begin_nd()
        .map_err(|e| Error::io(path, e))?;
    writer
        .extend(data.iter().copied())
        .map_err(|e| Error::io(path, e))?;
    writer.finish().map_err(|e| Error::io(path, e))
}

/// Writes a C-ordered f32 array atomically.
pub fn write_npy_f32(path: &Path, shape: &[usize], data: &[f32]) -> Result<()> {
    write_npy(path, shape, data)
}

/// The `.npy` reader: one array named after the file; a volume is its (nz, ny, nx) read as f32.
pub(crate) struct NpyReader;

impl super::Reader for NpyReader {
    fn read(
        &self,
        path: &Path,
        _var: Option<&str>,
        _rank: Option<usize>,
        _sel: &crate::datasets::select::Selection,
    ) -> Result<crate::datasets::ArrayData> {
        let npy = read_npy::<f64>(path)?;
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("array");
        Ok(crate::datasets::plain_array(
            name, npy.shape, npy.dtype, npy.data,
        ))
    }

    fn volume(
        &self,
        path: &Path,
        _opts: &crate::datasets::LoadOptions,
    ) -> Result<crate::model::Volume> {
        crate::datasets::volume_from_npy(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version 1.0 `.npy` file: `header` (the dict literal) padded as numpy pads it, then
    /// `data`.
    fn npy_bytes(header: &str, data: &[u8]) -> Vec<u8> {
        let mut text = header.to_string();
        while !(10 + text.len() + 1).is_multiple_of(64) {
            text.push(' ');
        }
        text.push('\n');
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend((text.len() as u16).to_le_bytes());
        bytes.extend(text.as_bytes());
        bytes.extend(data);
        bytes
    }

    #[test]
    fn bool_arrays_read_as_zero_and_one() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mask.npy");
        let header = "{'descr': '|b1', 'fortran_order': False, 'shape': (2, 3), }";
        std::fs::write(&p, npy_bytes(header, &[1, 0, 1, 1, 0, 0])).unwrap();
        let a = read_npy::<f64>(&p).unwrap();
        assert_eq!((a.shape, a.dtype.as_str()), (vec![2, 3], "|b1"));
        assert_eq!(a.data, [1.0, 0.0, 1.0, 1.0, 0.0, 0.0]);
        std::fs::write(&p, npy_bytes(header, &[1, 0, 2, 1, 0, 0])).unwrap();
        let err = read_npy::<f32>(&p).unwrap_err().to_string();
        assert!(
            err.contains("invalid value for bool: 2") && !err.contains('\n'),
            "{err}"
        );
    }

    #[test]
    fn python2_headers_read_and_unparsable_ones_are_one_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("py2.npy");
        let values: Vec<u8> = (0..6)
            .flat_map(|i| (i as f32 * 1.5).to_le_bytes())
            .collect();
        let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2L, 3L), }";
        let bytes = npy_bytes(header, &values);
        std::fs::write(&p, &bytes).unwrap();
        let a = read_npy::<f32>(&p).unwrap();
        assert_eq!(a.shape, [2, 3]);
        assert_eq!(a.data, [0.0, 1.5, 3.0, 4.5, 6.0, 7.5]);
        // The rewritten header keeps its length, so the data start where the file says.
        let fixed = drop_long_suffixes(&bytes[10..74]).unwrap();
        assert_eq!(fixed.len(), 64);
        assert!(String::from_utf8(fixed)
            .unwrap()
            .contains("'shape': (2, 3), }"));
        // A one-element Python 2 tuple, `(5L,)`, and a long inside a name stay as they are.
        assert_eq!(
            drop_long_suffixes(b"{'shape': (5L,)}").unwrap(),
            b"{'shape': (5,)} "
        );
        assert_eq!(drop_long_suffixes(b"{'descr': 'L'}"), None);
        let broken = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3) 'x'}";
        std::fs::write(&p, npy_bytes(broken, &values)).unwrap();
        let err = read_npy::<f32>(&p).unwrap_err().to_string();
        assert!(!err.contains('\n'), "{err}");
        assert!(
            err.contains(
                "not a valid .npy file: the header is not the Python dict literal numpy \
                          writes (parse error at line:column 1:"
            ),
            "{err}"
        );
    }
}
