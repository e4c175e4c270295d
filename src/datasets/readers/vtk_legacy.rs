//! Legacy VTK files (`.vtk`): `DATASET STRUCTURED_POINTS` (DIMENSIONS, SPACING or ASPECT_RATIO,
//! ORIGIN) and `DATASET RECTILINEAR_GRID` (DIMENSIONS, X/Y/Z_COORDINATES), in ASCII or BINARY
//! (big-endian), with one `SCALARS` array (or a one-component `FIELD` array) in `POINT_DATA` or
//! `CELL_DATA`. Points become cell-centred voxels as `.vti` points do: a point array gives one
//! voxel per point, centred on it (origin half a spacing before the first point); a cell array
//! gives the cells between the points. A rectilinear grid with evenly spaced coordinates is a
//! regular volume; otherwise its coordinates become a rectilinear geometry.

use std::path::Path;

use super::scalar::Scalar;
use crate::error::{Error, Result};
use crate::model::{CoordAxis, Geometry, Volume};

/// Relative tolerance within which coordinates count as evenly spaced (as for NetCDF axes).
const EVEN_SPACING: f64 = 1e-5;

/// Reads the scalar array `var` (else the first one) of a legacy `.vtk` file as a volume.
pub(crate) fn read_vtk(path: &Path, var: Option<&str>) -> Result<Volume> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    read_vtk_bytes(path, &bytes, var)
}

/// `read_vtk` on bytes already in memory; `path` names the file in errors and the volume.
fn read_vtk_bytes(path: &Path, bytes: &[u8], var: Option<&str>) -> Result<Volume> {
    let fail = |msg: String| Error::format(path, msg);
    let mut tokens = Tokens::after_header(bytes).map_err(fail)?;
    let grid = read_grid(&mut tokens).map_err(fail)?;
    let (array, on_points) = find_array(&mut tokens, &grid, var).map_err(fail)?;
    let name = array.name.clone();
    volume_of(grid, array, on_points).map_err(|e| fail(format!("array '{name}': {e}")))
}

/// The file's dimensions and where its points lie.
struct GridHeader {
    /// Points per axis.
    points: [usize; 3],
    placement: Placement,
}

enum Placement {
    /// STRUCTURED_POINTS: the first point and the spacing.
    Uniform { origin: [f64; 3], spacing: [f64; 3] },
    /// RECTILINEAR_GRID: every point's coordinate per axis.
    Coordinates([Vec<f64>; 3]),
}

/// One data array: its name and values.
struct Array {
    name: String,
    values: Vec<f32>,
}

/// A cursor over the file: whitespace-separated words, and binary runs after a line.
struct Tokens<'a> {
    bytes: &'a [u8],
    at: usize,
    binary: bool,
}

impl<'a> Tokens<'a> {
    /// Checks the version line, skips the title and reads ASCII or BINARY.
    fn after_header(bytes: &'a [u8]) -> std::result::Result<Tokens<'a>, String> {
        let mut t = Tokens {
            bytes,
            at: 0,
            binary: false,
        };
        let first = t.line();
        if !first.starts_with("# vtk DataFile") {
            return Err(
                "not a legacy VTK file: the first line is not '# vtk DataFile Version …'".into(),
            );
        }
        t.line(); // the title
        t.binary = match t.word()?.to_ascii_uppercase().as_str() {
            "ASCII" => false,
            "BINARY" => true,
            other => return Err(format!("expected ASCII or BINARY, got '{other}'")),
        };
        Ok(t)
    }

    /// The rest of the current line (lossy text), moving past its end.
    fn line(&mut self) -> String {
        let rest = &self.bytes[self.at.min(self.bytes.len())..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        self.at += (end + 1).min(rest.len());
        String::from_utf8_lossy(&rest[..end]).trim().to_string()
    }

    /// The next word, or `None` at the end of the file.
    fn next_word(&mut self) -> Option<&'a str> {
        let bytes = self.bytes;
        while self.at < bytes.len() && bytes[self.at].is_ascii_whitespace() {
            self.at += 1;
        }
        let start = self.at;
        while self.at < bytes.len() && !bytes[self.at].is_ascii_whitespace() {
            self.at += 1;
        }
        (self.at > start).then(|| std::str::from_utf8(&bytes[start..self.at]).unwrap_or("\u{fffd}"))
    }

    fn word(&mut self) -> std::result::Result<&'a str, String> {
        self.next_word()
            .ok_or_else(|| "the file ends too early".to_string())
    }

    /// The next word without moving past it.
    fn peek(&mut self) -> Option<&'a str> {
        let at = self.at;
        let w = self.next_word();
        self.at = at;
        w
    }

    fn number<T: std::str::FromStr>(&mut self, what: &str) -> std::result::Result<T, String> {
        let w = self.word()?;
        w.parse()
            .map_err(|_| format!("{what}: '{w}' is not a valid number"))
    }

    fn triple<T: std::str::FromStr>(&mut self, what: &str) -> std::result::Result<[T; 3], String> {
        Ok([self.number(what)?, self.number(what)?, self.number(what)?])
    }

    /// `n` values of VTK type `type_name` as f32, in ASCII words or as big-endian binary
    /// starting on the next line.
    fn values(
        &mut self,
        n: usize,
        type_name: &str,
        what: &str,
    ) -> std::result::Result<Vec<f32>, String> {
        match self.run(n, type_name, what)? {
            Run::Words(sample, words) => words
                .iter()
                .map(|w| {
                    sample
                        .parse_text(w)
                        .ok_or_else(|| format!("{what}: '{w}' is not a number"))
                })
                .collect(),
            Run::Binary(sample, bytes) => Ok(sample.decode(true, bytes)),
        }
    }

    /// Like [`Tokens::values`], as f64 so that double coordinates keep their precision.
    fn coordinates(
        &mut self,
        n: usize,
        type_name: &str,
        what: &str,
    ) -> std::result::Result<Vec<f64>, String> {
        match self.run(n, type_name, what)? {
            Run::Words(_, words) => words
                .iter()
                .map(|w| {
                    w.parse::<f64>()
                        .map_err(|_| format!("{what}: '{w}' is not a number"))
                })
                .collect(),
            Run::Binary(Scalar::F64, bytes) => Ok(bytes
                .chunks_exact(8)
                .map(|c| f64::from_be_bytes(c.try_into().expect("8-byte chunk")))
                .collect()),
            Run::Binary(sample, bytes) => Ok(sample
                .decode(true, bytes)
                .into_iter()
                .map(f64::from)
                .collect()),
        }
    }

    /// The next `n` values, as words or as the bytes of a binary run.
    fn run(
        &mut self,
        n: usize,
        type_name: &str,
        what: &str,
    ) -> std::result::Result<Run<'a>, String> {
        let sample = sample_type(type_name).ok_or_else(|| {
            format!("{what}: data type '{type_name}' is not supported; expected a numeric type such as float, double, int or unsigned_char")
        })?;
        if !self.binary {
            let words = (0..n)
                .map(|i| {
                    self.next_word()
                        .ok_or_else(|| format!("{what}: the file ends after {i} of {n} values"))
                })
                .collect::<std::result::Result<_, _>>()?;
            return Ok(Run::Words(sample, words));
        }
        self.line();
        let len = n
            .checked_mul(sample.size())
            .ok_or_else(|| format!("{what}: {n} values are too many"))?;
        let data = self
            .at
            .checked_add(len)
            .and_then(|end| self.bytes.get(self.at..end))
            .ok_or_else(|| {
                format!(
                    "{what}: the file ends inside its {n} binary values ({} of {len} bytes)",
                    self.bytes.len().saturating_sub(self.at)
                )
            })?;
        self.at += len;
        Ok(Run::Binary(sample, data))
    }
}

/// A run of values as stored: ASCII words or big-endian bytes, with their sample type.
enum Run<'a> {
    Words(Scalar, Vec<&'a str>),
    Binary(Scalar, &'a [u8]),
}

/// The sample type of a legacy VTK data type name.
fn sample_type(name: &str) -> Option<Scalar> {
    Some(match name.to_ascii_lowercase().as_str() {
        "char" | "signed_char" | "vtktypeint8" => Scalar::I8,
        "unsigned_char" | "vtktypeuint8" => Scalar::U8,
        "short" | "vtktypeint16" => Scalar::I16,
        "unsigned_short" | "vtktypeuint16" => Scalar::U16,
        "int" | "vtktypeint32" => Scalar::I32,
        "unsigned_int" | "vtktypeuint32" => Scalar::U32,
        "long" | "vtktypeint64" | "vtkidtype" => Scalar::I64,
        "unsigned_long" | "vtktypeuint64" => Scalar::U64,
        "float" | "vtktypefloat32" => Scalar::F32,
        "double" | "vtktypefloat64" => Scalar::F64,
        _ => return None,
    })
}

/// The `DATASET` section up to the first `POINT_DATA` or `CELL_DATA` keyword (not consumed).
fn read_grid(t: &mut Tokens) -> std::result::Result<GridHeader, String> {
    if !t.word()?.eq_ignore_ascii_case("DATASET") {
        return Err("expected DATASET after the ASCII/BINARY line".into());
    }
    let kind = t.word()?.to_ascii_uppercase();
    if kind != "STRUCTURED_POINTS" && kind != "RECTILINEAR_GRID" {
        return Err(format!(
            "DATASET {kind} is not supported; expected STRUCTURED_POINTS or RECTILINEAR_GRID (save image data as .vti or .npy from ParaView)"
        ));
    }
    let mut points: Option<[usize; 3]> = None;
    let (mut origin, mut spacing) = ([0.0; 3], [1.0; 3]);
    let mut coords: [Option<Vec<f64>>; 3] = [None, None, None];
    while let Some(word) = t.peek() {
        let key = word.to_ascii_uppercase();
        if key == "POINT_DATA" || key == "CELL_DATA" {
            break;
        }
        t.word()?;
        match key.as_str() {
            "DIMENSIONS" => points = Some(t.triple("DIMENSIONS")?),
            "SPACING" | "ASPECT_RATIO" => spacing = t.triple(&key)?,
            "ORIGIN" => origin = t.triple("ORIGIN")?,
            "X_COORDINATES" | "Y_COORDINATES" | "Z_COORDINATES" => {
                let axis = usize::from(key.as_bytes()[0] - b'X');
                let n: usize = t.number(&key)?;
                let type_name = t.word()?;
                coords[axis] = Some(t.coordinates(n, type_name, &key)?);
            }
            "FIELD" => skip_field(t)?,
            "METADATA" => skip_metadata(t),
            other => return Err(format!("unexpected '{other}' in the DATASET section")),
        }
    }
    let points = points.ok_or("the DATASET section has no DIMENSIONS")?;
    if points.contains(&0) {
        return Err(format!("DIMENSIONS {points:?} has an empty axis"));
    }
    let placement = if kind == "STRUCTURED_POINTS" {
        Placement::Uniform { origin, spacing }
    } else {
        let [x, y, z] = coords;
        let mut axes = [Vec::new(), Vec::new(), Vec::new()];
        for (a, (c, slot)) in [x, y, z].into_iter().zip(axes.iter_mut()).enumerate() {
            let name = ["X", "Y", "Z"][a];
            let c = c.ok_or_else(|| format!("RECTILINEAR_GRID has no {name}_COORDINATES"))?;
            if c.len() != points[a] {
                return Err(format!(
                    "{name}_COORDINATES has {} values; DIMENSIONS says {}",
                    c.len(),
                    points[a]
                ));
            }
            *slot = c;
        }
        Placement::Coordinates(axes)
    };
    Ok(GridHeader { points, placement })
}

/// Skips a `FIELD name n` block (its keyword already read).
fn skip_field(t: &mut Tokens) -> std::result::Result<(), String> {
    t.word()?;
    let arrays: usize = t.number("FIELD")?;
    for _ in 0..arrays {
        field_entry(t)?;
    }
    Ok(())
}

/// One array of a `FIELD` block: `name components tuples type`, its values and any `METADATA`.
struct FieldEntry {
    name: String,
    components: usize,
    tuples: usize,
    values: Vec<f32>,
}

fn field_entry(t: &mut Tokens) -> std::result::Result<FieldEntry, String> {
    let name = t.word()?.to_string();
    let components: usize = t.number(&name)?;
    let tuples: usize = t.number(&name)?;
    let type_name = t.word()?;
    let count = components
        .checked_mul(tuples)
        .ok_or_else(|| format!("FIELD array '{name}' is too large"))?;
    let values = t.values(count, type_name, &name)?;
    if t.peek().is_some_and(|w| w.eq_ignore_ascii_case("METADATA")) {
        t.word()?;
        skip_metadata(t);
    }
    Ok(FieldEntry {
        name,
        components,
        tuples,
        values,
    })
}

/// Skips a `METADATA` block (its keyword already read): its lines up to an empty one.
fn skip_metadata(t: &mut Tokens) {
    t.line();
    while t.at < t.bytes.len() && !t.line().is_empty() {}
}

/// Reads through `POINT_DATA`/`CELL_DATA` sections until the `SCALARS` (or one-component
/// `FIELD`) array named `var`, else the first one; returns it and whether it lies on points.
fn find_array(
    t: &mut Tokens,
    grid: &GridHeader,
    var: Option<&str>,
) -> std::result::Result<(Array, bool), String> {
    let mut on_points = None;
    let mut seen = Vec::new();
    while let Some(word) = t.next_word() {
        let key = word.to_ascii_uppercase();
        let n_of = |on_points: Option<bool>| -> std::result::Result<usize, String> {
            let p = on_points.ok_or(format!("{key} before POINT_DATA or CELL_DATA"))?;
            let per_axis = grid.points.map(|n| if p { n } else { (n - 1).max(1) });
            per_axis
                .iter()
                .try_fold(1usize, |acc, &n| acc.checked_mul(n))
                .ok_or(format!("DIMENSIONS {:?} are too large", grid.points))
        };
        match key.as_str() {
            "POINT_DATA" | "CELL_DATA" => {
                on_points = Some(key == "POINT_DATA");
                let declared: usize = t.number(&key)?;
                let expected = n_of(on_points)?;
                if declared != expected {
                    return Err(format!(
                        "{key} {declared} does not match DIMENSIONS {:?} ({expected} expected)",
                        grid.points
                    ));
                }
            }
            "SCALARS" => {
                let n = n_of(on_points)?;
                let name = t.word()?.to_string();
                let type_name = t.word()?;
                // An optional component count follows on the same line.
                let rest = t.line();
                let components: usize = match rest.split_whitespace().next() {
                    None => 1,
                    Some(c) => c
                        .parse()
                        .map_err(|_| format!("SCALARS {name}: component count '{c}' is not a number"))?,
                };
                t.at -= usize::from(t.binary && t.at > 0 && t.bytes[t.at - 1] == b'\n');
                if t.peek().is_some_and(|w| w.eq_ignore_ascii_case("LOOKUP_TABLE")) {
                    t.word()?;
                    t.word()?;
                }
                let values = t.values(n * components, type_name, &format!("array '{name}'"))?;
                if var.is_none_or(|v| v == name) {
                    if components != 1 {
                        return Err(format!(
                            "array '{name}' has {components} components; only scalars are supported"
                        ));
                    }
                    return Ok((Array { name, values }, on_points == Some(true)));
                }
                seen.push(name);
            }
            "FIELD" => {
                let n = n_of(on_points)?;
                if let Some(found) = field_array(t, n, var, &mut seen)? {
                    return Ok((found, on_points == Some(true)));
                }
            }
            "VECTORS" | "NORMALS" | "TENSORS" => {
                let n = n_of(on_points)? * if key == "TENSORS" { 9 } else { 3 };
                let name = t.word()?.to_string();
                let type_name = t.word()?;
                t.values(n, type_name, &name)?;
            }
            "METADATA" => skip_metadata(t),
            other => {
                return Err(format!(
                    "'{other}' is not supported in point or cell data; save the volume as one SCALARS array"
                ))
            }
        }
    }
    Err(match var {
        Some(v) => format!(
            "no array '{v}'; the file has: {}",
            if seen.is_empty() {
                "none".to_string()
            } else {
                seen.join(", ")
            }
        ),
        None => "no SCALARS array in POINT_DATA or CELL_DATA".to_string(),
    })
}

/// The arrays of a `FIELD name k` block in point or cell data (keyword read): the one-component
/// array of `n` tuples named `var` (else the first such), or `None` after skipping them all.
fn field_array(
    t: &mut Tokens,
    n: usize,
    var: Option<&str>,
    seen: &mut Vec<String>,
) -> std::result::Result<Option<Array>, String> {
    t.word()?;
    let arrays: usize = t.number("FIELD")?;
    for _ in 0..arrays {
        let entry = field_entry(t)?;
        if entry.components == 1 && entry.tuples == n && var.is_none_or(|v| v == entry.name) {
            return Ok(Some(Array {
                name: entry.name,
                values: entry.values,
            }));
        }
        seen.push(entry.name);
    }
    Ok(None)
}

/// The volume of `array` on `grid`: a regular one, or a rectilinear one for uneven coordinates.
fn volume_of(
    grid: GridHeader,
    array: Array,
    on_points: bool,
) -> std::result::Result<Volume, String> {
    let cells = |n: usize| if on_points { n } else { (n - 1).max(1) };
    let dims = grid.points.map(cells);
    let mut data = array.values;
    match grid.placement {
        Placement::Uniform { origin, spacing } => {
            if let Some(s) = spacing.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
                return Err(format!("SPACING {s} must be finite and positive"));
            }
            let corner: [f64; 3] =
                std::array::from_fn(|a| origin[a] - if on_points { 0.5 * spacing[a] } else { 0.0 });
            Volume::new(array.name, dims, spacing, corner, data).map_err(|e| e.to_string())
        }
        Placement::Coordinates(coords) => {
            let mut axes = Vec::with_capacity(3);
            for (a, c) in coords.into_iter().enumerate() {
                let field = format!("{}_COORDINATES", ["X", "Y", "Z"][a]);
                axes.push(axis_of(c, on_points, &field)?);
            }
            if axes.iter().all(|a| a.uniform_step(EVEN_SPACING).is_some()) {
                let mut spacing = [0.0; 3];
                let mut corner = [0.0; 3];
                for (a, axis) in axes.iter().enumerate() {
                    let step = axis.uniform_step(EVEN_SPACING).unwrap_or(1.0);
                    if step < 0.0 {
                        crate::datasets::flip_axis(&mut data, dims, a);
                    }
                    spacing[a] = step.abs();
                    corner[a] = axis.lo;
                }
                return Volume::new(array.name, dims, spacing, corner, data)
                    .map_err(|e| e.to_string());
            }
            // The box the rectilinear axes span, as the volume's nominal origin and mean spacing.
            let corner = std::array::from_fn(|a| axes[a].axis.lo);
            let spacing =
                std::array::from_fn(|a| (axes[a].axis.hi - axes[a].axis.lo) / dims[a] as f64);
            let [x, y, z]: [CoordAxis; 3] = axes
                .into_iter()
                .map(|a| a.axis)
                .collect::<Vec<_>>()
                .try_into()
                .map_err(|_| "three axes expected".to_string())?;
            Volume::new(array.name, dims, spacing, corner, data)
                .and_then(|v| v.with_geometry(Geometry::Rectilinear(Box::new([x, y, z]))))
                .map_err(|e| e.to_string())
        }
    }
}

/// One rectilinear axis as voxel centres: the points themselves for point data (domain from the
/// first to the last), the midpoints between them (domain from the first to the last point) for
/// cell data; a single point spans one unit around it (point data) or from it (cell data).
struct LoadedAxis {
    axis: CoordAxis,
    /// The domain's ends as a regular volume would span them: half a step beyond the end
    /// centres for point data.
    lo: f64,
    hi: f64,
    /// The coordinates as the file gives them.
    points: Vec<f64>,
}

impl LoadedAxis {
    /// The signed step when the file's points (the centres for point data, the cell bounds for
    /// cell data) are evenly spaced within `tolerance` of it.
    fn uniform_step(&self, tolerance: f64) -> Option<f64> {
        let c = &self.points;
        let n = c.len();
        if n < 2 {
            return Some(self.hi - self.lo);
        }
        let step = (c[n - 1] - c[0]) / (n - 1) as f64;
        c.windows(2)
            .all(|w| ((w[1] - w[0]) - step).abs() <= tolerance * step.abs())
            .then_some(step)
    }
}

fn axis_of(
    points: Vec<f64>,
    on_points: bool,
    field: &str,
) -> std::result::Result<LoadedAxis, String> {
    let n = points.len();
    let (axis, lo, hi) = if on_points && n > 1 {
        let axis = CoordAxis::new(points.clone(), None, field).map_err(|e| e.to_string())?;
        let half = 0.5 * (axis.hi - axis.lo) / (n - 1) as f64;
        let (lo, hi) = (axis.lo - half, axis.hi + half);
        (axis, lo, hi)
    } else if n < 2 {
        // One point: a unit voxel centred on it (point data), or one layer of unit cells from it
        // (cell data, VTK's convention for a flat axis, as `.vti` reads it).
        let p = points.first().copied().unwrap_or(0.0);
        let lo = if on_points { p - 0.5 } else { p };
        let axis = CoordAxis::new(vec![lo + 0.5], Some((lo, lo + 1.0)), field)
            .map_err(|e| e.to_string())?;
        (axis, lo, lo + 1.0)
    } else {
        let mids = points.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        let bounds = (points[0], points[n - 1]);
        let axis = CoordAxis::new(mids, Some(bounds), field).map_err(|e| e.to_string())?;
        let (lo, hi) = (axis.lo, axis.hi);
        (axis, lo, hi)
    };
    Ok(LoadedAxis {
        axis,
        lo,
        hi,
        points,
    })
}

/// The file's one volume (the registry's reader), refused when `var` names another.
pub(crate) fn volume(path: &Path, var: Option<&str>) -> Result<Volume> {
    crate::datasets::named_volume(path, read_vtk(path, var)?, var)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &[u8], var: Option<&str>) -> Result<Volume> {
        read_vtk_bytes(Path::new("t.vtk"), text, var)
    }

    #[test]
    fn ascii_cell_data_sits_between_the_points() {
        let v = read(
            b"# vtk DataFile Version 3.0\ncells\nASCII\nDATASET STRUCTURED_POINTS\n\
              DIMENSIONS 3 2 2\nASPECT_RATIO 0.5 2 4\nORIGIN 10 20 30\nCELL_DATA 2\n\
              SCALARS other int 1\nLOOKUP_TABLE default\n7 8\n\
              SCALARS rho float\nLOOKUP_TABLE default\n1.5 -2.25\n",
            Some("rho"),
        )
        .unwrap();
        assert_eq!(
            (v.name.as_str(), v.dims, v.spacing, v.origin, v.data),
            (
                "rho",
                [2, 1, 1],
                [0.5, 2.0, 4.0],
                [10.0, 20.0, 30.0],
                vec![1.5, -2.25]
            )
        );
    }

    #[test]
    fn binary_point_data_is_big_endian_and_centred_on_the_points() {
        let mut file = b"# vtk DataFile Version 5.1\npoints\nBINARY\nDATASET STRUCTURED_POINTS\n\
            DIMENSIONS 2 1 1\nSPACING 2 1 1\nORIGIN 4 0 0\nPOINT_DATA 2\nSCALARS s double\n\
            LOOKUP_TABLE default\n"
            .to_vec();
        file.extend(3.0f64.to_be_bytes());
        file.extend((-1e-30f64).to_be_bytes());
        file.extend(b"\nMETADATA\nINFORMATION 0\n\n");
        let v = read(&file, None).unwrap();
        assert_eq!(
            (v.dims, v.spacing, v.origin, v.data),
            (
                [2, 1, 1],
                [2.0, 1.0, 1.0],
                [3.0, -0.5, -0.5],
                vec![3.0, -1e-30]
            )
        );
        // Cut inside the values: the error names the file and the array.
        let err = read(&file[..file.len() - 30], None)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("t.vtk: ") && err.contains("array 's'") && !err.contains('\n'),
            "{err}"
        );
    }

    #[test]
    fn rectilinear_grids_are_regular_when_even_and_keep_uneven_coordinates() {
        let grid = |x: &str, z: &str| {
            format!(
                "# vtk DataFile Version 3.0\nr\nASCII\nDATASET RECTILINEAR_GRID\nDIMENSIONS 3 1 2\n\
                 X_COORDINATES 3 double\n{x}\nY_COORDINATES 1 float\n5\nZ_COORDINATES 2 float\n{z}\n\
                 CELL_DATA 2\nFIELD FieldData 1\nv 1 2 float\n1 2\n"
            )
        };
        // Cell data on x = 0, 1, 3: centres 0.5 and 2, domain [0, 3]; z cells of 1 to 2.
        let v = read(grid("0 1 3", "1 2").as_bytes(), None).unwrap();
        let Geometry::Rectilinear(axes) = &v.geometry else {
            panic!("{:?}", v.geometry)
        };
        assert_eq!(
            (axes[0].centres.clone(), axes[0].lo, axes[0].hi),
            (vec![0.5, 2.0], 0.0, 3.0)
        );
        assert_eq!(
            (axes[2].centres.clone(), axes[2].lo, axes[2].hi),
            (vec![1.5], 1.0, 2.0)
        );
        assert_eq!((v.name.as_str(), v.data.clone()), ("v", vec![1.0, 2.0]));
        // Decreasing even x (3, 2, 1): a regular volume, flipped to run in increasing x.
        let v = read(grid("3 2 1", "1 2").as_bytes(), None).unwrap();
        assert_eq!(v.geometry, Geometry::Regular);
        assert_eq!(
            (v.spacing[0], v.origin[0], v.data),
            (1.0, 1.0, vec![2.0, 1.0])
        );
    }

    #[test]
    fn unsupported_datasets_and_wrong_counts_are_one_line_errors() {
        let err = read(
            b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 0 float\n",
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("DATASET POLYDATA is not supported") && err.contains(".vti"),
            "{err}"
        );
        let err = read(
            b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n\
              POINT_DATA 7\nSCALARS s float\n1 2 3 4 5 6 7\n",
            None,
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            err,
            "t.vtk: POINT_DATA 7 does not match DIMENSIONS [2, 2, 2] (8 expected)"
        );
        let err = read(b"hello", None).unwrap_err().to_string();
        assert!(err.contains("not a legacy VTK file"), "{err}");
        let err = read(
            b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1 1 1\n\
              POINT_DATA 1\nSCALARS s float\n1\n",
            Some("t"),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(err, "t.vtk: no array 't'; the file has: s");
    }
}
