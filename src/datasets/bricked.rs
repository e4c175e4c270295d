//! Voxel sources for bricked, out-of-core volumes: `.npy` files read by positioned reads (any
//! plain numeric dtype, either byte order, converted to f32 row by row) and NetCDF variables read
//! by hyperslabs (with the same decoding, coordinates and axis flips as
//! [`super::load_volume`]). Neither holds the whole volume: a read touches only the rows it
//! needs. Neither maps the file, so a file truncated while it is read is an error, not a SIGBUS. [`open_bricked`] builds the brick
//! index of a file this way; other formats are loaded whole and bricked in memory.

use super::netcdf;
use super::scalar::Scalar;
use crate::error::{Error, Result};
use crate::model::bricks::{BrickedVolume, VoxelSource};
use std::os::unix::fs::FileExt as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Opens `path` as a bricked volume with bricks of `brick` voxels, reading it in slabs.
pub fn open_bricked(path: &Path, var: Option<&str>, brick: usize) -> Result<BrickedVolume> {
    open_bricked_with(path, var, &super::select::Selection::default(), brick)
}

/// [`open_bricked`] with the dimensions `sel` fixes (NetCDF, read by hyperslabs; an `at`
/// between two levels, which would interpolate, is refused).
pub(crate) fn open_bricked_with(
    path: &Path,
    var: Option<&str>,
    sel: &super::select::Selection,
    brick: usize,
) -> Result<BrickedVolume> {
    crate::io::check_regular_file(path)?;
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("volume")
        .to_string();
    let at = |e: Error| match e {
        Error::Invalid { field, msg } => Error::format(path, format!("{field}: {msg}")),
        other => other,
    };
    match super::Format::of(path)? {
        super::Format::Npy => {
            let src = NpyFileSource::open(path)?;
            BrickedVolume::build(stem, Arc::new(src), [1.0; 3], [0.0; 3], brick).map_err(at)
        }
        super::Format::NetCdf => {
            let src = NetcdfSource::open(path, var, sel)?;
            let (spacing, origin, units, name) =
                (src.spacing, src.origin, src.units.clone(), src.var.clone());
            let mut b =
                BrickedVolume::build(name, Arc::new(src), spacing, origin, brick).map_err(at)?;
            b.units = units;
            Ok(b)
        }
        _ if !sel.is_empty() => Err(Error::format(
            path,
            "selecting by dimension (index, at) needs a NetCDF file",
        )),
        _ => {
            let v = Arc::new(super::load_volume_var(path, var)?);
            BrickedVolume::from_volume(v, brick).map_err(at)
        }
    }
}

/// The sample type and byte order (true: big-endian) of a NumPy dtype descriptor.
fn scalar_of_descr(d: &str) -> Option<(Scalar, bool)> {
    let (order, rest) = d.split_at(1.min(d.len()));
    let big = match order {
        ">" => true,
        "<" | "|" | "=" => false,
        _ => return None,
    };
    let e = match rest {
        "f2" => Scalar::F16,
        "f4" => Scalar::F32,
        "f8" => Scalar::F64,
        "i1" => Scalar::I8,
        "i2" => Scalar::I16,
        "i4" => Scalar::I32,
        "i8" => Scalar::I64,
        "u1" | "b1" => Scalar::U8,
        "u2" => Scalar::U16,
        "u4" => Scalar::U32,
        "u8" => Scalar::U64,
        _ => return None,
    };
    Some((e, big))
}

/// A C-ordered 3-D `.npy` array read by positioned reads (`pread`), one z slice's rows at a
/// time. No memory map: a file that shrinks while it is open makes a read fail with an error
/// instead of killing the process with SIGBUS, and nothing stays resident after a read.
pub(crate) struct NpyFileSource {
    path: PathBuf,
    layout: NpyLayout,
    dims: [usize; 3],
}

/// Where a C-ordered `.npy` array's values lie in its file, and how they are stored: the
/// header read and checked against the file's length, no values read.
pub(crate) struct NpyLayout {
    pub file: std::fs::File,
    /// Byte offset of the first value.
    pub offset: u64,
    pub shape: Vec<usize>,
    pub element: Scalar,
    pub big_endian: bool,
    /// The dtype as NumPy spells it (`<f4`).
    pub descr: String,
}

impl NpyLayout {
    pub(crate) fn open(path: &Path) -> Result<NpyLayout> {
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        let bad = |m: String| Error::format(path, m);
        let mut lead = [0u8; 12];
        let got = read_at_most(&file, &mut lead, 0).map_err(|e| Error::io(path, e))?;
        if got < 10 || &lead[..6] != b"\x93NUMPY" {
            return Err(bad("not a .npy file: missing the \\x93NUMPY magic".into()));
        }
        let (header_len, start) = match lead[6] {
            1 => (u64::from(u16::from_le_bytes([lead[8], lead[9]])), 10),
            2 | 3 if got >= 12 => (
                u64::from(u32::from_le_bytes([lead[8], lead[9], lead[10], lead[11]])),
                12,
            ),
            v => return Err(bad(format!("unsupported .npy version {v}"))),
        };
        let offset = start + header_len;
        if offset > len {
            return Err(bad("header runs past the end of the file".into()));
        }
        // offset <= len < 4 GiB + 12 here (the header length is a u32).
        let mut header = vec![0u8; offset as usize];
        file.read_exact_at(&mut header, 0)
            .map_err(|e| Error::io(path, e))?;
        let npy =
            super::npy::open_npy(&header[..]).map_err(|e| bad(super::npy::header_error(&e)))?;
        if npy.order() == npyz::Order::Fortran {
            return Err(bad(
                "array is in Fortran order; expected C order (save with np.ascontiguousarray)"
                    .into(),
            ));
        }
        let descr = match npy.dtype() {
            npyz::DType::Plain(ts) => ts.to_string(),
            other => other.descr(),
        };
        let (element, big_endian) = scalar_of_descr(&descr).ok_or_else(|| {
            bad(format!(
                "unsupported dtype {descr}; expected a plain numeric type such as <f4"
            ))
        })?;
        let shape: Vec<usize> = npy.shape().iter().map(|&s| s as usize).collect();
        let need = shape
            .iter()
            .try_fold(element.size() as u64, |acc, &d| acc.checked_mul(d as u64))
            .unwrap_or(u64::MAX);
        if offset.saturating_add(need) > len {
            return Err(bad(format!(
                "header declares shape {shape:?} of {descr} ({need} bytes) but the file holds only {} bytes after the header",
                len - offset
            )));
        }
        Ok(NpyLayout {
            file,
            offset,
            shape,
            element,
            big_endian,
            descr,
        })
    }

    /// Values `start .. start + count` (in C order), decoded to f64; a file that shrank since it
    /// was opened is an error naming the byte it ends before.
    pub(crate) fn read_f64(&self, path: &Path, start: usize, count: usize) -> Result<Vec<f64>> {
        let es = self.element.size();
        let at = self.offset + (start * es) as u64;
        let mut bytes = vec![0u8; count * es];
        self.file
            .read_exact_at(&mut bytes, at)
            .map_err(|e| shrank(path, e, at + bytes.len() as u64))?;
        Ok(self.element.decode_f64(self.big_endian, &bytes))
    }
}

/// The error of a positioned read that failed: a file that ended early shrank after it was
/// opened (its header was checked against its length then).
fn shrank(path: &Path, e: std::io::Error, end: u64) -> Error {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        Error::format(
            path,
            format!("ends before byte {end}: the file shrank after it was opened"),
        )
    } else {
        Error::io(path, e)
    }
}

impl NpyFileSource {
    pub(crate) fn open(path: &Path) -> Result<NpyFileSource> {
        let layout = NpyLayout::open(path)?;
        let shape = &layout.shape;
        if shape.len() != 3 {
            return Err(Error::format(
                path,
                format!("expected a 3-D array of shape (nz, ny, nx), got shape {shape:?}"),
            ));
        }
        let dims = [shape[2], shape[1], shape[0]];
        crate::model::volume::check_shape(&dims, "shape")
            .map_err(|e| Error::format(path, e.to_string()))?;
        Ok(NpyFileSource {
            path: path.to_path_buf(),
            layout,
            dims,
        })
    }

    fn byte_of(&self, i: usize, j: usize, k: usize) -> u64 {
        let (offset, es) = (self.layout.offset, self.layout.element.size());
        offset + (((k * self.dims[1] + j) * self.dims[0] + i) * es) as u64
    }
}

/// Reads into `buf` from `at` until it is full or the file ends; the count read.
fn read_at_most(file: &std::fs::File, buf: &mut [u8], at: u64) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match file.read_at(&mut buf[got..], at + got as u64) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

impl VoxelSource for NpyFileSource {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn read_box(&self, lo: [usize; 3], size: [usize; 3], out: &mut [f32]) -> Result<()> {
        if size.contains(&0) {
            return Ok(());
        }
        let es = self.layout.element.size();
        let row = size[0] * es;
        // The rows of one z slice lie `dims[0]` samples apart: one read spans them all (with
        // the gaps between them when the box is narrower than the volume).
        let pitch = self.dims[0] * es;
        let mut span = vec![0u8; (size[1] - 1) * pitch + row];
        let mut o = 0;
        for k in lo[2]..lo[2] + size[2] {
            let at = self.byte_of(lo[0], lo[1], k);
            self.layout
                .file
                .read_exact_at(&mut span, at)
                .map_err(|e| shrank(&self.path, e, at + span.len() as u64))?;
            for j in 0..size[1] {
                self.layout.element.decode_into(
                    self.layout.big_endian,
                    &span[j * pitch..j * pitch + row],
                    &mut out[o..o + size[0]],
                );
                o += size[0];
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("{} (read by slices)", self.path.display())
    }
}

/// A 3-D NetCDF variable read by hyperslabs, decoded (fill values to NaN, scale and offset) like
/// [`super::load_volume`], with evenly spaced coordinates giving spacing and origin and
/// decreasing ones flipped.
pub(crate) struct NetcdfSource {
    path: PathBuf,
    file: netcdf_reader::NcFile,
    pub var: String,
    /// Per dimension of the variable: the index a selection fixed or a leading length-1
    /// dimension takes (`Some`), or `None` for the three volume axes (z, y, x).
    fixed: Vec<Option<usize>>,
    dims: [usize; 3],
    flip: [bool; 3],
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    pub units: String,
}

impl NetcdfSource {
    pub(crate) fn open(
        path: &Path,
        var: Option<&str>,
        sel: &super::select::Selection,
    ) -> Result<NetcdfSource> {
        let (name, dims) = variable_to_brick(path, var, sel)?;
        let plan = super::select::plan(path, &name, &dims, sel)?;
        let mut fixed = plan.positions(path, &name)?;
        let kept: Vec<usize> = (0..dims.len()).filter(|&a| fixed[a].is_none()).collect();
        super::select::refuse_time(path, &name, &plan.kept(&dims))?;
        if !fits_brick(&dims, sel) {
            let shape: Vec<String> = kept
                .iter()
                .map(|&a| format!("{}={}", dims[a].0, dims[a].1))
                .collect();
            return Err(Error::format(
                path,
                format!(
                    "'{name}' has dimensions ({}){}; expected a 3-D array",
                    shape.join(", "),
                    if sel.is_empty() {
                        ""
                    } else {
                        " after the selection"
                    }
                ),
            ));
        }
        // The leading kept dimensions are of length 1: read at their index 0.
        let axes = &kept[kept.len() - 3..];
        for &a in &kept[..kept.len() - 3] {
            fixed[a] = Some(0);
        }
        let file = super::netcdf::open(path)?;
        let v = file
            .variable(&name)
            .map_err(|e| Error::format(path, e.to_string()))?;
        let dim_names: Vec<String> = axes.iter().map(|&a| dims[a].0.clone()).collect();
        let s: Vec<usize> = axes.iter().map(|&a| dims[a].1).collect();
        let units = v
            .attribute("units")
            .and_then(|a| a.value.as_string())
            .unwrap_or_default();
        let dims = [s[2], s[1], s[0]];
        crate::model::volume::check_shape(&dims, "shape")
            .map_err(|e| Error::format(path, e.to_string()))?;
        refuse_geographic(path, &name, &dim_names, &s)?;
        let mut spacing = [1.0; 3];
        let mut origin = [0.0; 3];
        let mut flip = [false; 3];
        for a in 0..3 {
            let dim = &dim_names[2 - a];
            let Some(values) = super::cf::read_coordinate(path, dim)?.map(|v| v.data) else {
                continue;
            };
            match values.as_slice() {
                [single] => origin[a] = single - 0.5,
                [first, .., last] => {
                    let step = (last - first) / (values.len() - 1) as f64;
                    let even = values
                        .windows(2)
                        .all(|w| ((w[1] - w[0]) - step).abs() <= 1e-5 * step.abs());
                    if !even {
                        return Err(Error::format(
                            path,
                            format!("'{name}': coordinate '{dim}' is unevenly spaced; bricked (opened) volumes need even spacing, so read it with load_volume"),
                        ));
                    }
                    spacing[a] = step.abs();
                    origin[a] = first.min(*last) - 0.5 * step.abs();
                    flip[a] = step < 0.0;
                }
                [] => {}
            }
        }
        Ok(NetcdfSource {
            path: path.to_path_buf(),
            file,
            var: name,
            fixed,
            dims,
            flip,
            spacing,
            origin,
            units,
        })
    }
}

/// Whether a variable of `dims` has three dimensions that `sel` leaves, any before them of
/// length 1.
fn fits_brick(dims: &[(String, usize)], sel: &super::select::Selection) -> bool {
    let kept: Vec<usize> = dims
        .iter()
        .filter(|(d, _)| !sel.dims().any(|s| s == d))
        .map(|(_, n)| *n)
        .collect();
    kept.len() >= 3 && kept[..kept.len() - 3].iter().all(|&s| s == 1)
}

/// The variable `open_volume` bricks, with its dimensions: `var`, else the first data variable
/// that has the dimensions `sel` fixes and three more.
fn variable_to_brick(
    path: &Path,
    var: Option<&str>,
    sel: &super::select::Selection,
) -> Result<(String, netcdf::Dims)> {
    let listed = super::list_arrays(path)?;
    let all_dims = netcdf::list_variables(path)?;
    let dims_of = |name: &str| netcdf::dims_in(&all_dims, name);
    // Data variables with the selected dimensions; of those, one that fits, else one with more
    // dimensions (whose opening then says which are left to fix).
    let candidates: Vec<&super::ArrayListing> = listed
        .iter()
        .filter(|a| {
            let dims = dims_of(&a.name);
            a.is_data() && sel.dims().all(|s| dims.iter().any(|(d, _)| d == s))
        })
        .collect();
    let name = match var {
        Some(v) => v.to_string(),
        None => candidates
            .iter()
            .find(|a| fits_brick(&dims_of(&a.name), sel))
            .or_else(|| {
                candidates
                    .iter()
                    .find(|a| dims_of(&a.name).len() > 3 + sel.dims().count())
            })
            .map(|a| a.name.clone())
            .ok_or_else(|| {
                Error::format(path, "no 3-D data variable to pick; name one with variable")
            })?,
    };
    if !listed.iter().any(|a| a.name == name) {
        return Err(super::missing_array(path, &name, &listed));
    }
    let dims = dims_of(&name);
    Ok((name, dims))
}

/// Bricks and out-of-core rendering work on regular boxes: a variable on latitude and
/// longitude (1-D, rotated or 2-D curvilinear) is refused with what to do instead.
fn refuse_geographic(path: &Path, name: &str, dims: &[String], shape: &[usize]) -> Result<()> {
    let attributes = super::netcdf::variable_attributes(path, name)?;
    let placed = if super::cf::rotated_pole(path, name)?.is_some() {
        Some("a rotated-pole grid; read it with load_volume (native spherical rendering)")
    } else if super::cf::curvilinear_coords(path, name, &attributes, dims)?.is_some() {
        Some("a curvilinear grid (2-D latitude and longitude); read one level with load_grid (regridded) or the volume in index space with load_volume(path, #{ geometry: \"cartesian\" })")
    } else {
        None
    };
    if let Some(what) = placed {
        return Err(Error::format(
            path,
            format!("'{name}' lies on {what}; bricked (opened) volumes are regular boxes"),
        ));
    }
    let dims: Vec<(String, usize)> = dims.iter().cloned().zip(shape.iter().copied()).collect();
    for d in super::cf::dim_coords(path, &dims)? {
        let Some(c) = &d.coord else { continue };
        if matches!(
            super::cf::axis_role(path, c)?,
            super::cf::AxisRole::Latitude | super::cf::AxisRole::Longitude
        ) {
            return Err(Error::format(
                path,
                format!("'{name}' lies on geographic coordinates ('{}'); bricked (opened) volumes are regular boxes, so read it with load_volume (native spherical rendering) or load it with geometry: \"cartesian\" and save a box", d.name),
            ));
        }
    }
    Ok(())
}

impl VoxelSource for NetcdfSource {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn read_box(&self, lo: [usize; 3], size: [usize; 3], out: &mut [f32]) -> Result<()> {
        use netcdf_reader::{NcSliceInfo, NcSliceInfoElem};
        // The file's index range of a volume axis (flipped axes run backwards on disk).
        let file_lo = |a: usize| {
            if self.flip[a] {
                self.dims[a] - lo[a] - size[a]
            } else {
                lo[a]
            }
        };
        // Volume axes z, y, x are the kept dimensions in file order.
        let mut axes = [2, 1, 0].into_iter();
        let selections = self
            .fixed
            .iter()
            .map(|f| match f {
                Some(i) => NcSliceInfoElem::Index(*i as u64),
                None => {
                    let a = axes.next().expect("three kept dimensions");
                    let start = file_lo(a) as u64;
                    NcSliceInfoElem::Slice {
                        start,
                        end: start + size[a] as u64,
                        step: 1,
                    }
                }
            })
            .collect();
        let flat = netcdf::read_slice(&self.file, &self.var, &NcSliceInfo { selections })
            .map_err(|e| Error::format(&self.path, format!("{}: {e}", self.var)))?;
        if flat.len() != out.len() {
            return Err(Error::format(
                &self.path,
                format!(
                    "{}: hyperslab returned {} values, expected {}",
                    self.var,
                    flat.len(),
                    out.len()
                ),
            ));
        }
        let [sx, sy, sz] = size;
        for k in 0..sz {
            let fk = if self.flip[2] { sz - 1 - k } else { k };
            for j in 0..sy {
                let fj = if self.flip[1] { sy - 1 - j } else { j };
                for i in 0..sx {
                    let fi = if self.flip[0] { sx - 1 - i } else { i };
                    out[(k * sy + j) * sx + i] = flat[(fk * sy + fj) * sx + fi] as f32;
                }
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("{}:{} (NetCDF hyperslabs)", self.path.display(), self.var)
    }
}

/// Writes a C-ordered f32 `.npy` of shape (nz, ny, nx) slice by slice, `slice(k, out)` filling
/// z-slice k: how large benchmark volumes are made without holding them. Atomic (temp + rename).
pub(crate) fn write_npy_f32_streaming(
    path: &Path,
    dims: [usize; 3],
    slice: &(dyn Fn(usize, &mut [f32]) + Sync),
) -> Result<()> {
    use std::io::Write;
    let [nx, ny, nz] = dims;
    crate::io::write_atomic(path, |w| {
        let header =
            format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({nz}, {ny}, {nx}), }}");
        // Magic, version 1.0, header padded with spaces to a multiple of 64 bytes, newline.
        let total = (10 + header.len() + 1).div_ceil(64) * 64;
        let mut h = header.into_bytes();
        h.resize(total - 10 - 1, b' ');
        h.push(b'\n');
        let io = |e| Error::io(path, e);
        w.write_all(b"\x93NUMPY\x01\x00").map_err(io)?;
        w.write_all(&(h.len() as u16).to_le_bytes()).map_err(io)?;
        w.write_all(&h).map_err(io)?;
        let mut buf = vec![0f32; nx * ny];
        for k in 0..nz {
            slice(k, &mut buf);
            w.write_all(bytemuck::cast_slice(&buf)).map_err(io)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Volume;

    fn field() -> Volume {
        Volume::from_fn("f", [13, 9, 11], |x, y, z| {
            (x * 0.7).sin() * 10.0 + y * y - 3.0 * z
        })
        .unwrap()
    }

    #[test]
    fn mapped_npy_matches_the_loaded_volume_for_several_dtypes() {
        let dir = tempfile::tempdir().unwrap();
        let v = field();
        let shape = [v.dims[2], v.dims[1], v.dims[0]];
        let p32 = dir.path().join("a.npy");
        crate::datasets::npy::write_npy(&p32, &shape, &v.data).unwrap();
        let p64 = dir.path().join("b.npy");
        let d64: Vec<f64> = v.data.iter().map(|&x| x as f64).collect();
        crate::datasets::npy::write_npy(&p64, &shape, &d64).unwrap();
        for p in [&p32, &p64] {
            let src = NpyFileSource::open(p).unwrap();
            assert_eq!(src.dims(), v.dims);
            let mut out = vec![0f32; 4 * 3 * 2];
            src.read_box([5, 2, 7], [4, 3, 2], &mut out).unwrap();
            let mut o = 0;
            for k in 7..9 {
                for j in 2..5 {
                    for i in 5..9 {
                        assert_eq!(out[o], v.data[v.index(i, j, k)]);
                        o += 1;
                    }
                }
            }
            let b = open_bricked(p, None, 8).unwrap();
            let mem = BrickedVolume::from_volume(Arc::new(v.clone()), 8).unwrap();
            assert_eq!(b.ranges, mem.ranges);
            assert_eq!(b.stats, mem.stats);
        }
    }

    #[test]
    fn truncated_or_wrong_npy_files_are_one_line_errors() {
        let dir = tempfile::tempdir().unwrap();
        let v = field();
        let p = dir.path().join("t.npy");
        crate::datasets::npy::write_npy(&p, &[v.dims[2], v.dims[1], v.dims[0]], &v.data).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 100]).unwrap();
        let err = open_bricked(&p, None, 8).unwrap_err().to_string();
        assert!(err.contains("holds only") && !err.contains('\n'), "{err}");
        let flat = dir.path().join("flat.npy");
        crate::datasets::npy::write_npy(&flat, &[6], &[1.0f32; 6]).unwrap();
        let err = open_bricked(&flat, None, 8).unwrap_err().to_string();
        assert!(err.contains("3-D array"), "{err}");
        std::fs::write(&p, b"not numpy at all").unwrap();
        assert!(open_bricked(&p, None, 8)
            .unwrap_err()
            .to_string()
            .contains("magic"));
        let err = open_bricked(&flat, None, 12).unwrap_err().to_string();
        assert!(err.contains("3-D array") || err.contains("brick"), "{err}");
    }

    /// Truncates `path` to `len` bytes through another handle, as another process would.
    fn shrink(path: &Path, len: u64) {
        std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .unwrap()
            .set_len(len)
            .unwrap();
    }

    #[test]
    fn files_truncated_while_open_are_errors_not_sigbus() {
        let dir = tempfile::tempdir().unwrap();
        let v = field();
        let p = dir.path().join("t.npy");
        crate::datasets::npy::write_npy(&p, &[v.dims[2], v.dims[1], v.dims[0]], &v.data).unwrap();
        let b = open_bricked(&p, None, 8).unwrap();
        let mut out = Vec::new();
        b.read_brick(0, &mut out).unwrap();
        // A memory map of the file would fault (SIGBUS) on the pages cut off here.
        shrink(&p, 200);
        let last = b.layout.count() - 1;
        let err = b.read_brick(last, &mut out).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!("{}: ends before byte", p.display()))
                && err.ends_with("the file shrank after it was opened"),
            "{err}"
        );
        // A classic NetCDF file, read by hyperslabs.
        let nc = dir.path().join("t.nc");
        crate::datasets::netcdf::write_volume(
            &nc,
            v.dims,
            [1.0; 3],
            [0.0; 3],
            "m",
            ("f", &v.data, "1", "field"),
            &[],
        )
        .unwrap();
        let src = NetcdfSource::open(&nc, None, &Default::default()).unwrap();
        let mut boxed = vec![0f32; v.dims.iter().product()];
        src.read_box([0; 3], v.dims, &mut boxed).unwrap();
        assert_eq!(boxed, v.data);
        shrink(&nc, 400);
        let err = src
            .read_box([0; 3], v.dims, &mut boxed)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with(&nc.display().to_string()) && !err.contains('\n'),
            "{err}"
        );
    }

    #[test]
    fn streamed_npy_writer_round_trips_through_the_npy_reader() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.npy");
        let v = field();
        let f = |k: usize, out: &mut [f32]| {
            let n = v.dims[0] * v.dims[1];
            out.copy_from_slice(&v.data[k * n..(k + 1) * n]);
        };
        write_npy_f32_streaming(&p, v.dims, &f).unwrap();
        let back = crate::datasets::load_volume(&p).unwrap();
        assert_eq!((back.dims, &back.data), (v.dims, &v.data));
    }

    #[test]
    fn netcdf_hyperslabs_match_the_loaded_volume_with_flipped_axes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.nc");
        let v = field();
        // y decreasing on disk: the reader must flip it back.
        let z: Vec<f64> = (0..11).map(|k| k as f64 * 2.0).collect();
        let y: Vec<f64> = (0..9).map(|j| 50.0 - j as f64).collect();
        let x: Vec<f64> = (0..13).map(|i| i as f64 * 0.5).collect();
        let data: Vec<f64> = v.data.iter().map(|&d| d as f64).collect();
        netcdf::write_grid::<f64>(
            &path,
            &[("z", &z, "m"), ("y", &y, "m"), ("x", &x, "m")],
            &[("t", &data, "K", "temperature")],
            &[],
        )
        .unwrap();
        let loaded = crate::datasets::load_volume(&path).unwrap();
        let b = open_bricked(&path, None, 8).unwrap();
        assert_eq!(
            (b.dims, b.spacing, b.origin),
            (loaded.dims, loaded.spacing, loaded.origin)
        );
        assert_eq!(b.units, "K");
        let mem = BrickedVolume::from_volume(Arc::new(loaded.clone()), 8).unwrap();
        assert_eq!(b.ranges, mem.ranges);
        let mut a = Vec::new();
        let mut c = Vec::new();
        for id in 0..b.layout.count() {
            b.read_brick(id, &mut a).unwrap();
            mem.read_brick(id, &mut c).unwrap();
            assert_eq!(a, c, "brick {id}");
        }
    }

    #[test]
    fn a_step_of_a_series_opens_like_the_loaded_step_and_time_is_refused() {
        use crate::datasets::select::{At, Selection};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.nc");
        let (t, z, y, x) = (
            [0.0, 1.0, 2.0],
            [0.0, 1.0],
            [0.0, 1.0, 2.0],
            [0.0, 1.0, 2.0, 3.0],
        );
        let data: Vec<f64> = (0..3 * 2 * 3 * 4).map(f64::from).collect();
        netcdf::write_grid::<f64>(
            &path,
            &[
                ("time", &t, "days since 2000-01-01"),
                ("z", &z, "m"),
                ("y", &y, "m"),
                ("x", &x, "m"),
            ],
            &[("v", &data, "K", "")],
            &[],
        )
        .unwrap();
        let err = open_bricked(&path, None, 8).unwrap_err().to_string();
        assert!(
            err.contains("dimension 'time' is time (3 steps, 2000-01-01T00:00:00 to 2000-01-03T00:00:00 (standard calendar))"),
            "{err}"
        );
        let sel = Selection {
            at: vec![("time".into(), At::Date("2000-01-02T10:00".into()))],
            ..Selection::default()
        };
        let b = open_bricked_with(&path, None, &sel, 8).unwrap();
        let opts = crate::datasets::LoadOptions {
            select: sel.clone(),
            ..Default::default()
        };
        let loaded = crate::datasets::load_volume_with(&path, &opts).unwrap();
        // The nearest step is index 1: values 24 ..= 47.
        let want: Vec<f32> = (24..48).map(|v| v as f32).collect();
        assert_eq!(loaded.data, want);
        let mem = BrickedVolume::from_volume(Arc::new(loaded), 8).unwrap();
        let (mut a, mut c) = (Vec::new(), Vec::new());
        b.read_brick(0, &mut a).unwrap();
        mem.read_brick(0, &mut c).unwrap();
        assert_eq!(a, c);
        let sel = Selection {
            at: vec![("z".into(), At::Value(0.5))],
            index: vec![("time".into(), 0)],
        };
        // Named, so that the interpolation is refused before the rank it leaves.
        let err = open_bricked_with(&path, Some("v"), &sel, 8)
            .unwrap_err()
            .to_string();
        assert!(err.contains("interpolates"), "{err}");
    }
}
