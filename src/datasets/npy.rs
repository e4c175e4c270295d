//! NumPy `.npy` arrays (C order; f32, f64, i16, u16, u8 and the other plain numeric types) read
//! through the `npyz` crate, with the declared size checked against the file before anything is
//! allocated; `.npy` output for generated fields and `.npz` archives of named arrays.

use crate::error::{Error, Result};
use npyz::{DType, TypeChar};
use std::path::Path;

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
    let npy = npyz::NpyFile::new(reader)
        .map_err(|e| Error::format(path, format!("not a valid .npy file: {e}")))?;
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
        (TypeChar::Uint, 1) | (TypeChar::Bool, 1) => {
            values(npy, path, |v: u8| T::from_f32(v as f32))?
        }
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
pub type NpzArray<'a, T> = (&'a str, &'a [usize], &'a [T]);

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
