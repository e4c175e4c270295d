//! Raw volumes described by an NRRD header: a detached `.nhdr` naming its `data file`, or an
//! attached `.nrrd` whose data follow the blank line after the header. Fields read: `type`,
//! `dimension` (3), `sizes` (fastest axis first: x, y, z), `endian`, `encoding` (raw, gzip,
//! bzip2 or ascii, decompressed by the pure-Rust flate2 and bzip2 crates), `spacings`
//! or a diagonal `space directions`, `space origin`, `byte skip`. Voxels are treated as cells.

use super::scalar::Scalar;
use crate::error::{Error, Result};
use crate::model::Volume;
use std::path::Path;

/// The sample type of an NRRD `type` field.
fn sample_type(s: &str) -> Option<Scalar> {
    Some(match s {
        "signed char" | "int8" | "int8_t" | "char" => Scalar::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Scalar::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            Scalar::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => Scalar::U16,
        "int" | "signed int" | "int32" | "int32_t" => Scalar::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Scalar::U32,
        "float" => Scalar::F32,
        "double" => Scalar::F64,
        _ => return None,
    })
}

fn parse_vector(s: &str) -> Option<Vec<f64>> {
    let inner = s.trim().strip_prefix('(')?.strip_suffix(')')?;
    inner.split(',').map(|x| x.trim().parse().ok()).collect()
}

/// How the samples are stored.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Raw,
    Gzip,
    Bzip2,
    Ascii,
}

impl Encoding {
    /// The `encoding` field (raw when absent).
    fn of(fields: &Fields) -> Result<Encoding> {
        Ok(match fields.get("encoding").unwrap_or("raw") {
            "raw" => Encoding::Raw,
            "gzip" | "gz" => Encoding::Gzip,
            "bzip2" | "bz2" => Encoding::Bzip2,
            "ascii" | "txt" | "text" => Encoding::Ascii,
            other => {
                return Err(Error::format(
                    fields.path,
                    format!(
                        "encoding {other:?} is not supported; expected raw, gzip, bzip2 or ascii \
                         (re-save with `unu save -e gzip` or pynrrd)"
                    ),
                ))
            }
        })
    }

    /// `need` bytes after `skip` decompressed bytes of `stored`; at most `skip + need` bytes are
    /// inflated, so a wrong size cannot exhaust memory.
    fn inflate(
        self,
        stored: &[u8],
        skip: usize,
        need: usize,
    ) -> std::result::Result<Vec<u8>, String> {
        use std::io::Read as _;
        let want = skip.saturating_add(need);
        let mut out = Vec::with_capacity(want);
        let (name, result) = match self {
            Encoding::Gzip => (
                "gzip",
                flate2::read::MultiGzDecoder::new(stored)
                    .take(want as u64)
                    .read_to_end(&mut out),
            ),
            _ => (
                "bzip2",
                bzip2::read::MultiBzDecoder::new(stored)
                    .take(want as u64)
                    .read_to_end(&mut out),
            ),
        };
        result.map_err(|e| format!("corrupt {name} data: {e}"))?;
        if out.len() < want {
            return Err(format!(
                "{name} data inflate to {} bytes but {need} are needed{}",
                out.len(),
                if skip > 0 {
                    format!(" after {skip} skipped")
                } else {
                    String::new()
                }
            ));
        }
        out.drain(..skip);
        Ok(out)
    }
}

/// The header's fields (`key: value`, keys lower-case), with the file for error messages.
struct Fields<'a> {
    path: &'a Path,
    map: std::collections::HashMap<String, String>,
}

impl Fields<'_> {
    fn get(&self, key: &str) -> Option<&str> {
        self.map.get(key).map(String::as_str)
    }

    fn need(&self, key: &str) -> Result<&str> {
        self.get(key)
            .ok_or_else(|| Error::format(self.path, format!("missing required field \"{key}\"")))
    }
}

/// Reads a `.nhdr` or `.nrrd` volume (see the module documentation).
pub(crate) fn read_nrrd(path: &Path) -> Result<Volume> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if !bytes.starts_with(b"NRRD000") {
        return Err(Error::format(
            path,
            "not an NRRD header: expected the magic line NRRD0001..NRRD0005",
        ));
    }
    let (header_end, data_start) = header_extent(&bytes);
    let header = std::str::from_utf8(&bytes[..header_end])
        .map_err(|_| Error::format(path, "header is not text"))?;
    let fields = parse_fields(path, header)?;
    let sample = sample_type(fields.need("type")?).ok_or_else(|| {
        Error::format(
            path,
            format!(
                "unsupported type {:?}; expected float, double, (u)char, (u)short or (u)int",
                fields.get("type").unwrap_or("")
            ),
        )
    })?;
    let dims = parse_dims(&fields)?;
    let encoding = Encoding::of(&fields)?;
    let big = match fields.get("endian") {
        None | Some("little") => false,
        Some("big") => true,
        Some(e) => {
            return Err(Error::format(
                path,
                format!("endian: expected little or big, got {e:?}"),
            ))
        }
    };
    if sample.size() > 1 && encoding != Encoding::Ascii && fields.get("endian").is_none() {
        return Err(Error::format(
            path,
            "missing required field \"endian\" for a multi-byte type",
        ));
    }
    let spacing = parse_spacing(&fields)?;
    let mut origin = [0.0; 3];
    if let Some(s) = fields.get("space origin") {
        let v = parse_vector(s)
            .filter(|v| v.len() == 3)
            .ok_or_else(|| Error::format(path, "space origin: expected a vector like (0,0,0)"))?;
        // NRRD's origin is the first sample's position; our origin is the volume's corner.
        for a in 0..3 {
            origin[a] = v[a] - 0.5 * spacing[a];
        }
    }
    let data = read_samples(&fields, &bytes, data_start, dims, (sample, encoding), big)?;
    let name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("volume");
    let mut v = Volume::new(name, dims, spacing, origin, data)
        .map_err(|e| Error::format(path, e.to_string()))?;
    if let Some(u) = fields.get("space units") {
        v.units = u.trim_matches('"').to_string();
    }
    Ok(v)
}

/// Where the header ends and attached data start: at the first empty line (attached data follow
/// it), else both at the end of the file.
fn header_extent(bytes: &[u8]) -> (usize, usize) {
    let mut pos = 0;
    while pos < bytes.len() {
        let nl = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|i| pos + i);
        let end = nl.unwrap_or(bytes.len());
        let line = &bytes[pos..end];
        if line.is_empty() || line == b"\r" {
            return (pos, end + 1);
        }
        pos = end + 1;
    }
    (bytes.len(), bytes.len())
}

/// The header's fields after the magic line; comments and `key:=value` pairs are skipped.
fn parse_fields<'a>(path: &'a Path, header: &str) -> Result<Fields<'a>> {
    let mut map = std::collections::HashMap::new();
    for (n, line) in header.lines().enumerate().skip(1) {
        let line = line.trim_end_matches('\r');
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        // Key/value pairs (key:=value) are user metadata; only fields (key: value) matter here.
        if line.contains(":=") {
            continue;
        }
        let Some((k, v)) = line.split_once(": ") else {
            return Err(Error::format(
                path,
                format!("line {}: expected \"field: value\", got {line:?}", n + 1),
            ));
        };
        map.insert(k.trim().to_ascii_lowercase(), v.trim().to_string());
    }
    Ok(Fields { path, map })
}

/// `dimension` (which must be 3) and `sizes`, checked as volume dimensions.
fn parse_dims(fields: &Fields) -> Result<[usize; 3]> {
    let path = fields.path;
    let dimension: usize = fields
        .need("dimension")?
        .parse()
        .map_err(|_| Error::format(path, "dimension: expected an integer"))?;
    if dimension != 3 {
        return Err(Error::format(
            path,
            format!("dimension: expected 3, got {dimension}"),
        ));
    }
    let sizes: Vec<usize> = fields
        .need("sizes")?
        .split_whitespace()
        .map(|s| s.parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| Error::format(path, "sizes: expected three non-negative integers"))?;
    if sizes.len() != 3 {
        return Err(Error::format(
            path,
            format!("sizes: expected 3 values, got {}", sizes.len()),
        ));
    }
    let dims = [sizes[0], sizes[1], sizes[2]];
    crate::model::volume::check_dims(&dims, &format!("{}: sizes", path.display()))?;
    Ok(dims)
}

/// Voxel spacing from `spacings`, else from a diagonal `space directions`, else 1.
fn parse_spacing(fields: &Fields) -> Result<[f64; 3]> {
    let path = fields.path;
    let mut spacing = [1.0; 3];
    if let Some(s) = fields.get("spacings") {
        let v: Vec<f64> = s
            .split_whitespace()
            .filter_map(|x| x.parse().ok())
            .collect();
        if v.len() != 3 {
            return Err(Error::format(path, "spacings: expected three numbers"));
        }
        spacing = [v[0], v[1], v[2]];
    } else if let Some(s) = fields.get("space directions") {
        let dirs: Vec<Vec<f64>> = s
            .split(')')
            .filter(|p| p.contains('('))
            .map(|p| parse_vector(&format!("{})", p.trim())))
            .collect::<Option<_>>()
            .ok_or_else(|| {
                Error::format(
                    path,
                    "space directions: expected three vectors like (1,0,0)",
                )
            })?;
        if dirs.len() != 3 || dirs.iter().any(|d| d.len() != 3) {
            return Err(Error::format(
                path,
                "space directions: expected three 3-vectors",
            ));
        }
        for a in 0..3 {
            let off_diagonal = (0..3).filter(|&b| b != a).any(|b| dirs[a][b] != 0.0);
            if off_diagonal {
                return Err(Error::format(
                    path,
                    "space directions: only axis-aligned (diagonal) grids are supported",
                ));
            }
            spacing[a] = dirs[a][a].abs();
        }
    }
    Ok(spacing)
}

/// The voxels, from the `data file` the header names or from the data attached after the
/// header (`bytes` from `data_start`), after `byte skip` bytes (of the decompressed data for
/// gzip and bzip2).
fn read_samples(
    fields: &Fields,
    bytes: &[u8],
    data_start: usize,
    dims: [usize; 3],
    (sample, encoding): (Scalar, Encoding),
    big: bool,
) -> Result<Vec<f32>> {
    let path = fields.path;
    let skip: usize = match fields.get("byte skip") {
        None => 0,
        Some(s) => s.parse().map_err(|_| {
            Error::format(
                path,
                "byte skip: expected a non-negative integer (-1 is not supported)",
            )
        })?,
    };
    let count = dims[0] * dims[1] * dims[2];
    let need_bytes = count * sample.size();
    let owned;
    let (data_path, stored): (std::path::PathBuf, &[u8]) = match fields
        .get("data file")
        .or_else(|| fields.get("datafile"))
    {
        Some(name) => {
            let p = super::access::referenced_file(path, "data file", name)?;
            let len = std::fs::metadata(&p).map_err(|e| Error::io(&p, e))?.len() as usize;
            if encoding == Encoding::Raw && len < skip + need_bytes {
                return Err(Error::format(&p, format!("holds {len} bytes but the header {} needs {} ({}x{}x{} {:?} + {skip} skipped)", path.display(), skip + need_bytes, dims[0], dims[1], dims[2], sample)));
            }
            owned = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
            (p, &owned[..])
        }
        None => {
            if data_start > bytes.len() {
                return Err(Error::format(
                    path,
                    "no data: expected a \"data file\" field or data after a blank line",
                ));
            }
            (path.to_path_buf(), &bytes[data_start..])
        }
    };
    let fail = |msg: String| Error::format(&data_path, msg);
    match encoding {
        Encoding::Ascii => ascii_samples(stored, count, sample).map_err(fail),
        Encoding::Raw => {
            let raw = stored.get(skip..).unwrap_or_default();
            if raw.len() < need_bytes {
                return Err(fail(format!(
                    "holds {} data bytes but {need_bytes} are needed",
                    raw.len()
                )));
            }
            Ok(sample.decode(big, &raw[..need_bytes]))
        }
        Encoding::Gzip | Encoding::Bzip2 => {
            let raw = encoding.inflate(stored, skip, need_bytes).map_err(fail)?;
            Ok(sample.decode(big, &raw))
        }
    }
}

/// `count` samples written as text numbers separated by white space.
fn ascii_samples(
    text: &[u8],
    count: usize,
    sample: Scalar,
) -> std::result::Result<Vec<f32>, String> {
    let text = std::str::from_utf8(text).map_err(|_| "ascii data is not text".to_string())?;
    let mut words = text.split_ascii_whitespace();
    let mut out = Vec::with_capacity(count);
    for i in 0..count {
        let w = words
            .next()
            .ok_or_else(|| format!("ascii data end after {i} of {count} values"))?;
        let v = sample
            .parse_text(w)
            .ok_or_else(|| format!("ascii value {i} '{w}' is not a number"))?;
        out.push(v);
    }
    if words.next().is_some() {
        return Err(format!(
            "ascii data hold more than the {count} values the sizes need"
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_detached_big_endian_shorts() {
        let dir = tempfile::tempdir().unwrap();
        let raw: Vec<u8> = (0..24i16)
            .flat_map(|v| (v * 100 - 1000).to_be_bytes())
            .collect();
        std::fs::write(dir.path().join("v.raw"), raw).unwrap();
        let hdr = "NRRD0004\n# test\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: big\nencoding: raw\nspacings: 0.5 1 2\ndata file: v.raw\n";
        std::fs::write(dir.path().join("v.nhdr"), hdr).unwrap();
        let v = read_nrrd(&dir.path().join("v.nhdr")).unwrap();
        assert_eq!(v.dims, [4, 3, 2]);
        assert_eq!(v.spacing, [0.5, 1.0, 2.0]);
        assert_eq!(
            v.data[v.index(1, 2, 1)],
            ((1 + 4 * 2 + 12) * 100 - 1000) as f32
        );
    }

    #[test]
    fn size_mismatch_and_bad_headers_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("v.raw"), [0u8; 10]).unwrap();
        let hdr = "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\ndata file: v.raw\n";
        std::fs::write(dir.path().join("v.nhdr"), hdr).unwrap();
        let e = read_nrrd(&dir.path().join("v.nhdr"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("v.raw") && e.contains("96"), "{e}");
        std::fs::write(dir.path().join("b.nhdr"), "NRRD0004\ntype: quaternion\n").unwrap();
        assert!(read_nrrd(&dir.path().join("b.nhdr"))
            .unwrap_err()
            .to_string()
            .contains("unsupported type"));
        std::fs::write(dir.path().join("c.nhdr"), "hello").unwrap();
        assert!(read_nrrd(&dir.path().join("c.nhdr")).is_err());
        let hdr =
            "NRRD0004\ntype: float\ndimension: 3\nsizes: 0 3 2\nendian: little\ndata file: v.raw\n";
        std::fs::write(dir.path().join("z.nhdr"), hdr).unwrap();
        assert!(read_nrrd(&dir.path().join("z.nhdr"))
            .unwrap_err()
            .to_string()
            .contains("sizes"));
    }

    #[test]
    fn reads_attached_data() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes =
            b"NRRD0004\ntype: float\ndimension: 3\nsizes: 2 1 1\nendian: little\nencoding: raw\n\n"
                .to_vec();
        bytes.extend(1.5f32.to_le_bytes());
        bytes.extend((-2.0f32).to_le_bytes());
        std::fs::write(dir.path().join("a.nrrd"), bytes).unwrap();
        let v = read_nrrd(&dir.path().join("a.nrrd")).unwrap();
        assert_eq!(v.data, vec![1.5, -2.0]);
    }
}

#[cfg(test)]
mod encoding_tests {
    use super::*;
    use std::io::Write as _;

    const HEADER: &str = "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 1 1\nendian: big\n";

    fn attached(dir: &Path, name: &str, encoding: &str, data: &[u8]) -> std::path::PathBuf {
        let mut bytes = format!("{HEADER}encoding: {encoding}\n\n").into_bytes();
        bytes.extend_from_slice(data);
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn shorts() -> Vec<u8> {
        [-300i16, 0, 32000]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect()
    }

    #[test]
    fn gzip_bzip2_and_ascii_read_like_raw() {
        let dir = tempfile::tempdir().unwrap();
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(&shorts()).unwrap();
        let gz = gz.finish().unwrap();
        let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
        bz.write_all(&shorts()).unwrap();
        let bz = bz.finish().unwrap();
        for (name, encoding, data) in [
            ("r.nrrd", "raw", shorts()),
            ("g.nrrd", "gzip", gz.clone()),
            ("z.nrrd", "gz", gz.clone()),
            ("b.nrrd", "bzip2", bz.clone()),
            ("a.nrrd", "ascii", b"-300\n0 32000\n".to_vec()),
        ] {
            let v = read_nrrd(&attached(dir.path(), name, encoding, &data)).unwrap();
            assert_eq!(v.data, [-300.0, 0.0, 32000.0], "{encoding}");
        }
        // Half a gzip stream, a stream of the wrong length, ascii with a word too many.
        let err = read_nrrd(&attached(dir.path(), "h.nrrd", "gzip", &gz[..gz.len() / 2]))
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with(&format!("{}", dir.path().join("h.nrrd").display()))
                && err.contains("gzip"),
            "{err}"
        );
        let mut short = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        short.write_all(&shorts()[..4]).unwrap();
        let err = read_nrrd(&attached(
            dir.path(),
            "s.nrrd",
            "gzip",
            &short.finish().unwrap(),
        ))
        .unwrap_err()
        .to_string();
        assert!(
            err.ends_with("gzip data inflate to 4 bytes but 6 are needed"),
            "{err}"
        );
        let err = read_nrrd(&attached(dir.path(), "m.nrrd", "txt", b"1 2 3 4"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("more than the 3 values"), "{err}");
        let err = read_nrrd(&attached(dir.path(), "x.nrrd", "hex", b"00"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("encoding \"hex\" is not supported") && err.contains("unu save"),
            "{err}"
        );
    }
}
