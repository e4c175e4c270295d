//! Raw volumes described by an NRRD header: a detached `.nhdr` naming its `data file`, or an
//! attached `.nrrd` whose data follow the blank line after the header. Fields read: `type`,
//! `dimension` (3), `sizes` (fastest axis first: x, y, z), `endian`, `encoding` (raw, gzip,
//! bzip2 or ascii, decompressed by the pure-Rust flate2 and bzip2 crates), `spacings`
//! or a diagonal `space directions`, `space origin`, `line skip` and `byte skip`. Voxels are
//! treated as cells.
//!
//! `data file` names one file, a `LIST` of files (their names on the header's following lines)
//! or a printf pattern (`slice.%03d 1 93 1 [subdim]`); the files hold consecutive slabs of
//! `subdim` axes (default 2: one z slice each) and are read in order. Every name resolves
//! through [`crate::datasets::access::referenced_file`]. Per the NRRD specification `line skip` lines are
//! skipped in each data file before decoding and `byte skip` bytes after it (of the
//! decompressed data for gzip and bzip2); a `byte skip` of -1 (raw only) reads the data from
//! the file's end.

use super::scalar::Scalar;
use crate::error::{excerpt, Error, Result};
use crate::model::Volume;
use std::io::{BufRead, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// How many characters of a header line or value an error message quotes.
const QUOTED: usize = 60;

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
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => Scalar::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            Scalar::U64
        }
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
                        "encoding {} is not supported; expected raw, gzip, bzip2 or ascii \
                         (re-save with `unu save -e gzip` or pynrrd)",
                        excerpt(other, QUOTED)
                    ),
                ))
            }
        })
    }

    /// `need` bytes after `skip` decompressed bytes of the stream `stored`. The skipped bytes
    /// are discarded as they inflate and the output grows only with the data actually there,
    /// so neither a huge `byte skip` nor a wrong size can exhaust memory.
    fn inflate(
        self,
        stored: impl BufRead,
        skip: u64,
        need: usize,
    ) -> std::result::Result<Vec<u8>, String> {
        let name = if self == Encoding::Gzip {
            "gzip"
        } else {
            "bzip2"
        };
        let mut decoder: Box<dyn Read + '_> = match self {
            Encoding::Gzip => Box::new(flate2::bufread::MultiGzDecoder::new(stored)),
            _ => Box::new(bzip2::bufread::MultiBzDecoder::new(stored)),
        };
        let corrupt = |e: std::io::Error| format!("corrupt {name} data: {e}");
        let skipped =
            std::io::copy(&mut (&mut decoder).take(skip), &mut std::io::sink()).map_err(corrupt)?;
        let mut out = Vec::new();
        if skipped == skip {
            decoder
                .take(need as u64)
                .read_to_end(&mut out)
                .map_err(corrupt)?;
        }
        if out.len() < need {
            let total = u128::from(skipped) + out.len() as u128;
            return Err(if skip > 0 {
                format!(
                    "{name} data inflate to {total} bytes but {} are needed (byte skip {skip} + \
                     {need})",
                    u128::from(skip) + need as u128
                )
            } else {
                format!("{name} data inflate to {total} bytes but {need} are needed")
            });
        }
        Ok(out)
    }
}

/// The header's fields (`key: value`, keys lower-case), with the file for error messages.
struct Fields<'a> {
    path: &'a Path,
    map: std::collections::HashMap<String, String>,
    /// The file names that follow a `data file: LIST` line.
    list: Vec<String>,
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

/// How the samples are stored.
#[derive(Clone, Copy, Debug)]
struct Layout {
    sample: Scalar,
    encoding: Encoding,
    big_endian: bool,
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
    let layout = parse_layout(&fields)?;
    let dims = parse_dims(&fields)?;
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
    let data = read_samples(&fields, &bytes, data_start, dims, layout)?;
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

/// `type`, `encoding` and `endian`.
fn parse_layout(fields: &Fields) -> Result<Layout> {
    let path = fields.path;
    let sample = sample_type(fields.need("type")?).ok_or_else(|| {
        Error::format(
            path,
            format!(
                "unsupported type {}; expected float, double, (u)char, (u)short, (u)int or \
                 (u)longlong",
                excerpt(fields.get("type").unwrap_or(""), QUOTED)
            ),
        )
    })?;
    let encoding = Encoding::of(fields)?;
    let big_endian = match fields.get("endian") {
        None | Some("little") => false,
        Some("big") => true,
        Some(e) => {
            return Err(Error::format(
                path,
                format!("endian: expected little or big, got {}", excerpt(e, QUOTED)),
            ))
        }
    };
    if sample.size() > 1 && encoding != Encoding::Ascii && fields.get("endian").is_none() {
        return Err(Error::format(
            path,
            "missing required field \"endian\" for a multi-byte type",
        ));
    }
    Ok(Layout {
        sample,
        encoding,
        big_endian,
    })
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

/// The header's fields after the magic line; comments and `key:=value` pairs are skipped. The
/// lines after `data file: LIST` are its file names, to the end of the header.
fn parse_fields<'a>(path: &'a Path, header: &str) -> Result<Fields<'a>> {
    let mut map = std::collections::HashMap::new();
    let mut list = Vec::new();
    let mut lines = header.lines().enumerate().skip(1);
    for (n, line) in lines.by_ref() {
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
                format!(
                    "line {}: expected \"field: value\", got {}",
                    n + 1,
                    excerpt(line, QUOTED)
                ),
            ));
        };
        let key = k.trim().to_ascii_lowercase();
        let is_list = matches!(key.as_str(), "data file" | "datafile")
            && v.split_whitespace().next() == Some("LIST");
        map.insert(key, v.trim().to_string());
        if is_list {
            break;
        }
    }
    for (_, line) in lines {
        let name = line.trim_end_matches('\r');
        if !name.trim().is_empty() {
            list.push(name.to_string());
        }
    }
    Ok(Fields { path, map, list })
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

/// Where the samples of each data file begin: `lines` lines in, then `bytes` bytes into the
/// decoded data.
#[derive(Clone, Copy, Debug)]
struct Skip {
    lines: u64,
    bytes: ByteSkip,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum ByteSkip {
    Start(u64),
    /// `byte skip: -1`: the data end the file (raw encoding only).
    FromEnd,
}

impl Skip {
    fn of(fields: &Fields, encoding: Encoding) -> Result<Skip> {
        let path = fields.path;
        let get = |a: &str, b: &str| fields.get(a).or_else(|| fields.get(b));
        let lines = match get("line skip", "lineskip") {
            None => 0,
            Some(s) => s.parse().map_err(|_| {
                Error::format(
                    path,
                    format!(
                        "line skip: expected a non-negative integer, got {}",
                        excerpt(s, QUOTED)
                    ),
                )
            })?,
        };
        let bytes = match get("byte skip", "byteskip") {
            None => ByteSkip::Start(0),
            Some("-1") if encoding == Encoding::Raw => ByteSkip::FromEnd,
            Some("-1") => {
                return Err(Error::format(
                    path,
                    "byte skip: -1 (data at the end of the file) needs raw encoding",
                ))
            }
            Some(s) => ByteSkip::Start(s.parse().map_err(|_| {
                Error::format(
                    path,
                    format!(
                        "byte skip: expected a non-negative integer or -1, got {}",
                        excerpt(s, QUOTED)
                    ),
                )
            })?),
        };
        Ok(Skip { lines, bytes })
    }
}

/// The voxels, from the data files the header names or from the data attached after the
/// header (`bytes` from `data_start`).
fn read_samples(
    fields: &Fields,
    bytes: &[u8],
    data_start: usize,
    dims: [usize; 3],
    layout: Layout,
) -> Result<Vec<f32>> {
    let path = fields.path;
    let skip = Skip::of(fields, layout.encoding)?;
    let Some((files, per_file)) = data_files(fields, dims)? else {
        if data_start > bytes.len() {
            return Err(Error::format(
                path,
                "no data: expected a \"data file\" field or data after a blank line",
            ));
        }
        let mut attached = std::io::Cursor::new(bytes);
        attached.set_position(data_start as u64);
        let count = dims.iter().product();
        return read_piece(&mut attached, count, layout, skip).map_err(|m| Error::format(path, m));
    };
    let mut out = Vec::new();
    for file in &files {
        crate::io::check_regular_file(file)?;
        let opened = std::fs::File::open(file).map_err(|e| Error::io(file, e))?;
        let piece = read_piece(&mut std::io::BufReader::new(opened), per_file, layout, skip)
            .map_err(|m| Error::format(file, m))?;
        if files.len() == 1 {
            return Ok(piece);
        }
        out.extend_from_slice(&piece);
    }
    Ok(out)
}

/// The files `data file` names, each resolved through the sandbox, and the samples in each;
/// `None` for attached data.
fn data_files(fields: &Fields, dims: [usize; 3]) -> Result<Option<(Vec<PathBuf>, usize)>> {
    let path = fields.path;
    let Some(value) = fields.get("data file").or_else(|| fields.get("datafile")) else {
        return Ok(None);
    };
    let words: Vec<&str> = value.split_whitespace().collect();
    let pattern = FilePattern::parse(&words);
    let subdim_word = match (words.first(), &pattern) {
        (Some(&"LIST"), _) if words.len() <= 2 => words.get(1).copied(),
        (Some(&"LIST"), _) => {
            return Err(Error::format(path, "data file: expected LIST [<subdim>]"))
        }
        (_, Some(p)) => p.subdim,
        _ => Some("3"),
    };
    let subdim = match subdim_word {
        None => 2,
        Some(w) => w
            .parse()
            .ok()
            .filter(|d| (1..=3).contains(d))
            .ok_or_else(|| {
                Error::format(
                    path,
                    format!(
                        "data file: subdim {}: expected 1, 2 or 3",
                        excerpt(w, QUOTED)
                    ),
                )
            })?,
    };
    let files_needed: usize = dims[subdim..].iter().product();
    let names = if words.first() == Some(&"LIST") {
        fields.list.clone()
    } else if let Some(p) = pattern {
        p.names(files_needed)
            .map_err(|m| Error::format(path, format!("data file: {m}")))?
    } else {
        vec![value.to_string()]
    };
    if names.len() != files_needed {
        return Err(Error::format(
            path,
            format!(
                "data file: {} file names, but sizes {} {} {} in slabs of {subdim} axes need \
                 {files_needed}",
                names.len(),
                dims[0],
                dims[1],
                dims[2]
            ),
        ));
    }
    let files = names
        .iter()
        .map(|n| crate::datasets::access::referenced_file(path, "data file", n))
        .collect::<Result<Vec<_>>>()?;
    Ok(Some((files, dims[..subdim].iter().product())))
}

/// `data file: <printf pattern> <min> <max> <step> [<subdim>]`, the pattern holding one
/// `%d` (with an optional zero flag and width, as in `slice.%03d`).
struct FilePattern<'a> {
    prefix: &'a str,
    zero_pad: bool,
    width: usize,
    suffix: &'a str,
    range: [i64; 3],
    subdim: Option<&'a str>,
}

impl<'a> FilePattern<'a> {
    /// The pattern form of the field's words, if they have it.
    fn parse(words: &[&'a str]) -> Option<FilePattern<'a>> {
        if !(4..=5).contains(&words.len()) {
            return None;
        }
        let (prefix, rest) = words[0].split_once('%')?;
        let digits = rest.find(|c: char| !c.is_ascii_digit())?;
        let (spec, suffix) = (&rest[..digits], rest[digits..].strip_prefix('d')?);
        if suffix.contains('%') {
            return None;
        }
        let mut range = [0i64; 3];
        for (r, w) in range.iter_mut().zip(&words[1..4]) {
            *r = w.parse().ok()?;
        }
        Some(FilePattern {
            prefix,
            zero_pad: spec.starts_with('0'),
            width: spec.parse().unwrap_or(0),
            suffix,
            range,
            subdim: words.get(4).copied(),
        })
    }

    /// The names from min to max by step, refused unless there are `expected` of them (checked
    /// before any is made, so a huge range costs nothing).
    fn names(&self, expected: usize) -> std::result::Result<Vec<String>, String> {
        let [min, max, step] = self.range.map(i128::from);
        if step == 0 || (max - min).signum() * step.signum() < 0 {
            return Err(format!(
                "pattern range {min} to {max} by {step} is empty; the step must be non-zero and \
                 lead from min to max"
            ));
        }
        let count = (max - min) / step + 1;
        if count != expected as i128 {
            return Err(format!(
                "pattern range {min} to {max} by {step} names {count} files but the sizes need \
                 {expected}"
            ));
        }
        Ok((0..count)
            .map(|i| {
                let n = min + i * step;
                let w = self.width;
                let number = if self.zero_pad {
                    format!("{n:0w$}")
                } else {
                    format!("{n:w$}")
                };
                format!("{}{number}{}", self.prefix, self.suffix)
            })
            .collect())
    }
}

/// The `count` samples of one data file (or of the attached data), read from `r`'s position.
fn read_piece<R: BufRead + Seek>(
    r: &mut R,
    count: usize,
    layout: Layout,
    skip: Skip,
) -> std::result::Result<Vec<f32>, String> {
    let io = |e: std::io::Error| e.to_string();
    skip_lines(r, skip.lines)?;
    let need = count
        .checked_mul(layout.sample.size())
        .ok_or_else(|| format!("{count} samples are more than memory can address"))?;
    let start = r.stream_position().map_err(io)?;
    let end = r.seek(SeekFrom::End(0)).map_err(io)?;
    let available = end.saturating_sub(start);
    let at = match (layout.encoding, skip.bytes) {
        (Encoding::Raw, ByteSkip::FromEnd) => (available >= need as u64).then(|| end - need as u64),
        (Encoding::Gzip | Encoding::Bzip2, _) => Some(start),
        (_, ByteSkip::Start(b)) => (b <= available).then(|| start + b),
        (_, ByteSkip::FromEnd) => None,
    };
    let skipped = match skip.bytes {
        ByteSkip::Start(b) if b > 0 => format!(" after {b} skipped"),
        _ => String::new(),
    };
    let Some(at) = at else {
        return Err(format!(
            "holds {available} data bytes but {need} are needed{skipped}"
        ));
    };
    r.seek(SeekFrom::Start(at)).map_err(io)?;
    match (layout.encoding, skip.bytes) {
        (Encoding::Raw, _) => {
            if end - at < need as u64 {
                return Err(format!(
                    "holds {available} data bytes but {need} are needed{skipped}"
                ));
            }
            let mut raw = vec![0u8; need];
            r.read_exact(&mut raw).map_err(io)?;
            Ok(layout.sample.decode(layout.big_endian, &raw))
        }
        (Encoding::Ascii, _) => {
            let mut text = Vec::new();
            r.read_to_end(&mut text).map_err(io)?;
            ascii_samples(&text, count, layout.sample)
        }
        (encoding, ByteSkip::Start(b)) => {
            let raw = encoding.inflate(r, b, need)?;
            Ok(layout.sample.decode(layout.big_endian, &raw))
        }
        (_, ByteSkip::FromEnd) => Err("byte skip -1 needs raw encoding".into()),
    }
}

/// Skips `n` lines (each ending in a newline) from `r`, without holding any of them.
fn skip_lines(r: &mut impl BufRead, n: u64) -> std::result::Result<(), String> {
    for i in 0..n {
        loop {
            let buf = r.fill_buf().map_err(|e| e.to_string())?;
            if buf.is_empty() {
                return Err(format!("ends after {i} lines but line skip is {n}"));
            }
            if let Some(p) = buf.iter().position(|&b| b == b'\n') {
                r.consume(p + 1);
                break;
            }
            let len = buf.len();
            r.consume(len);
        }
    }
    Ok(())
}

/// `count` samples written as text numbers separated by white space.
fn ascii_samples(
    text: &[u8],
    count: usize,
    sample: Scalar,
) -> std::result::Result<Vec<f32>, String> {
    let text = std::str::from_utf8(text).map_err(|_| "ascii data is not text".to_string())?;
    let mut words = text.split_ascii_whitespace();
    // Each value takes at least two bytes (digit and separator) but the last.
    let mut out = Vec::with_capacity(count.min(text.len() / 2 + 1));
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

/// The file's one volume (the registry's reader), refused when `var` names another.
pub(crate) fn volume(path: &Path, var: Option<&str>) -> Result<Volume> {
    crate::datasets::named_volume(path, read_nrrd(path)?, var)
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

#[cfg(test)]
mod skip_and_list_tests {
    use super::*;
    use std::io::Write as _;

    const FLOATS: &str = "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 3\nendian: little\n";

    fn floats(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    fn gzip(data: &[u8]) -> Vec<u8> {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(data).unwrap();
        gz.finish().unwrap()
    }

    fn values() -> Vec<f32> {
        (0..12).map(|i| -28.25 + 105.25 * i as f32).collect()
    }

    /// Writes `header` (after the magic and the float fields) as `name` in `dir` and reads it.
    fn read(dir: &Path, name: &str, fields: &str, attached: &[u8]) -> Result<Volume> {
        let mut bytes = format!("{FLOATS}{fields}").into_bytes();
        bytes.extend_from_slice(attached);
        std::fs::write(dir.join(name), bytes).unwrap();
        read_nrrd(&dir.join(name))
    }

    #[test]
    fn line_skip_comes_before_decoding_and_byte_skip_after() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut raw = b"P7\nWIDTH 2\n\n".to_vec();
        raw.extend(floats(&values()));
        std::fs::write(d.join("v.raw"), &raw).unwrap();
        let v = read(d, "l.nhdr", "line skip: 3\ndata file: v.raw\n", b"").unwrap();
        assert_eq!(v.data, values());
        // Without the skip the text lines are read as floats: the values are wrong.
        let wrong = read(d, "n.nhdr", "byte skip: 0\ndata file: v.raw\n", b"").unwrap();
        assert_ne!(wrong.data, values());
        // gzip: the lines precede the stream, the byte skip counts decompressed bytes.
        let mut inflated = vec![7u8; 5];
        inflated.extend(floats(&values()));
        let mut attached = b"\nline one\nline two\n".to_vec();
        attached.extend(gzip(&inflated));
        let fields = "encoding: gzip\nline skip: 2\nbyte skip: 5\n";
        assert_eq!(read(d, "g.nrrd", fields, &attached).unwrap().data, values());
        // byte skip -1: the data end the file, whatever precedes them.
        let mut tail = vec![1u8; 9];
        tail.extend(floats(&values()));
        std::fs::write(d.join("t.raw"), &tail).unwrap();
        let v = read(d, "t.nhdr", "byte skip: -1\ndata file: t.raw\n", b"").unwrap();
        assert_eq!(v.data, values());
        let err = read(d, "x.nhdr", "line skip: 4\ndata file: v.raw\n", b"")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("v.raw: ends after 3 lines but line skip is 4"),
            "{err}"
        );
        let err = read(d, "y.nrrd", "encoding: gzip\nbyte skip: -1\n", b"\n")
            .unwrap_err()
            .to_string();
        assert!(err.ends_with("byte skip: -1 (data at the end of the file) needs raw encoding"));
    }

    #[test]
    fn huge_skips_and_sizes_are_one_line_errors() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let data = floats(&values());
        let skip = format!("byte skip: {}\n", 1u64 << 63);
        let encoded = [
            ("raw", data.clone()),
            ("gzip", gzip(&data)),
            ("bzip2", {
                let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::fast());
                bz.write_all(&data).unwrap();
                bz.finish().unwrap()
            }),
        ];
        for (encoding, stored) in &encoded {
            let mut attached = b"\n".to_vec();
            attached.extend(stored);
            let fields = format!("encoding: {encoding}\n{skip}");
            let err = read(d, "s.nrrd", &fields, &attached)
                .unwrap_err()
                .to_string();
            assert!(
                !err.contains('\n') && err.contains("9223372036854775808"),
                "{encoding}: {err}"
            );
        }
        assert!(
            read(d, "o.nrrd", "byte skip: 18446744073709551616\n", b"\n")
                .unwrap_err()
                .to_string()
                .contains("byte skip: expected a non-negative integer or -1")
        );
        // 3e10 voxels declared over 48 bytes of data: refused, whatever the memory.
        for encoding in ["raw", "gzip", "ascii"] {
            let mut bytes = "NRRD0004\ntype: float\ndimension: 3\nsizes: 30000 1000 1000\n\
                             endian: little\n"
                .to_string()
                .into_bytes();
            bytes.extend(format!("encoding: {encoding}\n\n").bytes());
            bytes.extend(if encoding == "gzip" {
                gzip(&data)
            } else {
                data.clone()
            });
            std::fs::write(d.join("h.nrrd"), bytes).unwrap();
            let err = read_nrrd(&d.join("h.nrrd")).unwrap_err().to_string();
            assert!(!err.contains('\n'), "{encoding}: {err}");
        }
    }

    #[test]
    fn header_errors_quote_a_short_escaped_excerpt() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = b"NRRD0004\ntype: float\n".to_vec();
        bytes.extend(vec![0u8; 1 << 20]);
        bytes.extend(b"\n");
        std::fs::write(dir.path().join("z.nhdr"), bytes).unwrap();
        let err = read_nrrd(&dir.path().join("z.nhdr"))
            .unwrap_err()
            .to_string();
        assert!(err.len() < 300, "{} bytes", err.len());
        assert!(
            err.contains(&format!(
                "line 3: expected \"field: value\", got \"{}\"",
                "\\0".repeat(60)
            )) && err.ends_with("... (1048516 more bytes)"),
            "{err}"
        );
        let long_type = format!("type: {}\n", "x".repeat(5000));
        std::fs::write(dir.path().join("t.nhdr"), format!("NRRD0004\n{long_type}")).unwrap();
        let err = read_nrrd(&dir.path().join("t.nhdr"))
            .unwrap_err()
            .to_string();
        assert!(err.len() < 300 && err.contains("unsupported type"), "{err}");
    }

    #[test]
    fn list_and_pattern_data_files_concatenate_their_slabs() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let v = values();
        for z in 0..3 {
            std::fs::write(
                d.join(format!("s{:02}.raw", z + 1)),
                floats(&v[4 * z..4 * z + 4]),
            )
            .unwrap();
            std::fs::write(
                d.join(format!("p{}.raw", z + 7)),
                floats(&v[4 * z..4 * z + 4]),
            )
            .unwrap();
        }
        let list = "data file: LIST\ns01.raw\ns02.raw\ns03.raw\n";
        assert_eq!(read(d, "a.nhdr", list, b"").unwrap().data, v);
        assert_eq!(
            read(d, "b.nhdr", "data file: s%02d.raw 1 3 1\n", b"")
                .unwrap()
                .data,
            v
        );
        assert_eq!(
            read(d, "c.nhdr", "data file: p%d.raw 7 9 1 2\n", b"")
                .unwrap()
                .data,
            v
        );
        // A falling range reads the slices in its order: z reversed.
        let reversed: Vec<f32> = (0..3)
            .rev()
            .flat_map(|z| v[4 * z..4 * z + 4].to_vec())
            .collect();
        assert_eq!(
            read(d, "r.nhdr", "data file: s%02d.raw 3 1 -1\n", b"")
                .unwrap()
                .data,
            reversed
        );
        // Subdim 1: one row per file; subdim 3: one file holds everything.
        for r in 0..6 {
            std::fs::write(d.join(format!("row{r}.raw")), floats(&v[2 * r..2 * r + 2])).unwrap();
        }
        let rows: String = (0..6).map(|r| format!("row{r}.raw\n")).collect();
        let header = format!("data file: LIST 1\n{rows}");
        assert_eq!(read(d, "rows.nhdr", &header, b"").unwrap().data, v);
        std::fs::write(d.join("all.raw"), floats(&v)).unwrap();
        let whole = read(d, "w.nhdr", "data file: LIST 3\nall.raw\n", b"").unwrap();
        assert_eq!(whole.data, v);
        let errors = [
            (
                "data file: LIST\ns01.raw\ns02.raw\n",
                "2 file names, but sizes 2 2 3 in slabs of 2 axes need 3",
            ),
            (
                "data file: s%02d.raw 1 4 1\n",
                "pattern range 1 to 4 by 1 names 4 files but the sizes need 3",
            ),
            (
                "data file: s%d.raw 0 9223372036854775807 1\n",
                "names 9223372036854775808 files",
            ),
            (
                "data file: s%d.raw 3 1 1\n",
                "the step must be non-zero and lead from min to max",
            ),
            ("data file: s%d.raw 1 3 0\n", "the step must be non-zero"),
            (
                "data file: s%02d.raw 1 3 1 4\n",
                "subdim \"4\": expected 1, 2 or 3",
            ),
            (
                "data file: LIST\ns01.raw\nmissing.raw\ns03.raw\n",
                "missing.raw",
            ),
        ];
        for (fields, expected) in errors {
            let err = read(d, "e.nhdr", fields, b"").unwrap_err().to_string();
            assert!(
                err.contains(expected) && !err.contains('\n'),
                "{fields}: {err}"
            );
        }
    }

    #[test]
    fn every_listed_or_patterned_name_goes_through_the_sandbox() {
        let root = tempfile::tempdir().unwrap();
        let inside = root.path().join("in");
        std::fs::create_dir(&inside).unwrap();
        let v = values();
        for z in 0..3 {
            let slab = floats(&v[4 * z..4 * z + 4]);
            std::fs::write(inside.join(format!("s{z}.raw")), &slab).unwrap();
            std::fs::write(root.path().join(format!("s{z}.raw")), &slab).unwrap();
        }
        let _scope = crate::datasets::access::ReadScope::enter(&[
            crate::datasets::access::resolve(&inside).unwrap(),
        ]);
        assert_eq!(
            read(
                &inside,
                "ok.nhdr",
                "data file: LIST\ns0.raw\ns1.raw\ns2.raw\n",
                b""
            )
            .unwrap()
            .data,
            v
        );
        for fields in [
            "data file: LIST\ns0.raw\n../s1.raw\ns2.raw\n",
            "data file: ../s%d.raw 0 2 1\n",
        ] {
            let err = read(&inside, "out.nhdr", fields, b"")
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("outside the folders this script may read"),
                "{fields}: {err}"
            );
        }
    }
}
