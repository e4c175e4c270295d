//! A Zarr directory store's metadata, versions 2 and 3, as xarray's `to_zarr` writes it: the
//! root group's attributes, and for each array its shape, chunk shape, element type, fill value,
//! codecs, dimension names (v2: xarray's `_ARRAY_DIMENSIONS` attribute; v3: `dimension_names`)
//! and attributes.

use std::path::{Path, PathBuf};

use super::codecs::{Codec, Dtype};
use crate::datasets::readers::variables::NcAttribute;
use crate::error::{Error, Result};

/// One array of the store.
#[derive(Clone, Debug)]
pub(crate) struct ZArray {
    pub name: String,
    pub dir: PathBuf,
    pub shape: Vec<usize>,
    pub chunks: Vec<usize>,
    pub dtype: Dtype,
    /// The value of chunks that were never written.
    pub fill: f64,
    /// Bytes-to-bytes codecs in the order they were applied when writing.
    pub codecs: Vec<Codec>,
    pub dims: Vec<String>,
    /// Attributes; for v2 the array's `fill_value` is its `_FillValue`, as xarray reads it.
    pub attributes: Vec<(String, NcAttribute)>,
    /// Chunk keys: v3's default encoding puts them under "c" and separates indices with '/';
    /// v2 separates them with '.' (or '/').
    pub key_prefix: Option<&'static str>,
    pub separator: char,
}

impl ZArray {
    /// The file of the chunk at grid position `at`.
    pub(crate) fn chunk_path(&self, at: &[usize]) -> PathBuf {
        let sep = self.separator.to_string();
        let mut parts: Vec<String> = self.key_prefix.iter().map(|p| p.to_string()).collect();
        parts.extend(at.iter().map(usize::to_string));
        if at.is_empty() && self.key_prefix.is_none() {
            parts.push("0".into());
        }
        self.dir.join(parts.join(&sep))
    }
}

/// The store: its global attributes and arrays.
#[derive(Debug)]
pub(crate) struct Store {
    pub globals: Vec<(String, NcAttribute)>,
    pub arrays: Vec<ZArray>,
}

/// Whether `path` is a Zarr store (a folder with v2 or v3 root metadata).
pub(crate) fn is_store(path: &Path) -> bool {
    path.is_dir()
        && [".zgroup", ".zarray", ".zmetadata", "zarr.json"]
            .iter()
            .any(|f| path.join(f).is_file())
}

fn json(path: &Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    serde_json::from_str(&text)
        .or_else(|e| serde_json::from_str(&quote_non_finite(&text)).map_err(|_| e))
        .map_err(|e| Error::format(path, format!("is not valid JSON: {e}")))
}

/// `text` with the bare `NaN`, `Infinity` and `-Infinity` that Python's `json` writes (and
/// zarr-python reads; strict JSON has no such numbers) turned into the strings Zarr's metadata
/// uses for them. Text inside strings is left alone.
fn quote_non_finite(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 16);
    let (mut in_string, mut escaped) = (false, false);
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if in_string {
            in_string = escaped || c != '"';
            escaped = !escaped && c == '\\';
        } else if c == '"' {
            in_string = true;
        } else if let Some(word) = ["-Infinity", "Infinity", "NaN"]
            .into_iter()
            .find(|w| rest.starts_with(w))
        {
            out.push('"');
            out.push_str(word);
            out.push('"');
            rest = &rest[word.len()..];
            continue;
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// A JSON attribute value as the data model keeps it.
fn attribute(v: &serde_json::Value) -> NcAttribute {
    use serde_json::Value;
    match v {
        Value::String(s) => NcAttribute::Text(s.clone()),
        Value::Number(n) => NcAttribute::Numbers(vec![n.as_f64().unwrap_or(f64::NAN)]),
        Value::Bool(b) => NcAttribute::Numbers(vec![f64::from(u8::from(*b))]),
        Value::Array(items) if items.iter().all(|x| x.is_number()) && !items.is_empty() => {
            NcAttribute::Numbers(
                items
                    .iter()
                    .map(|x| x.as_f64().unwrap_or(f64::NAN))
                    .collect(),
            )
        }
        other => NcAttribute::Text(other.to_string()),
    }
}

/// The attributes of a JSON object (none when it is not one), leaving out `skip`.
fn attributes_of(v: &serde_json::Value, skip: &str) -> Vec<(String, NcAttribute)> {
    v.as_object()
        .into_iter()
        .flatten()
        .filter(|(k, _)| *k != skip)
        .map(|(k, v)| (k.clone(), attribute(v)))
        .collect()
}

/// A list of sizes (`shape`, `chunks`) named `key` in the metadata file `meta`.
fn sizes(v: &serde_json::Value, key: &str, meta: &Path) -> Result<Vec<usize>> {
    let bad = |why: String| Error::format(meta, why);
    v.as_array()
        .ok_or_else(|| bad(format!("has no '{key}' list")))?
        .iter()
        .map(|n| {
            n.as_u64()
                .map(|n| n as usize)
                .ok_or_else(|| bad(format!("'{key}' holds a non-integer")))
        })
        .collect()
}

/// A fill value as Zarr writes it: a number, "NaN", "Infinity", "-Infinity", or (v3) raw bits
/// in hexadecimal.
fn fill_value(v: &serde_json::Value, dtype: &Dtype) -> Option<f64> {
    match v {
        serde_json::Value::Number(n) => n.as_f64(),
        serde_json::Value::Bool(b) => Some(f64::from(u8::from(*b))),
        serde_json::Value::String(s) => match s.as_str() {
            "NaN" => Some(f64::NAN),
            "Infinity" => Some(f64::INFINITY),
            "-Infinity" => Some(f64::NEG_INFINITY),
            hex => {
                let bits = u64::from_str_radix(hex.strip_prefix("0x")?, 16).ok()?;
                let bytes = bits.to_le_bytes();
                dtype.values(&bytes[..dtype.size]).first().copied()
            }
        },
        _ => None,
    }
}

/// xarray writes a v3 array's `_FillValue` as the base64 of its bytes (little-endian): the
/// number it stands for.
fn base64_number(text: &str, dtype: &Dtype) -> Option<f64> {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut bits = 0u32;
    let mut count = 0;
    let mut out = Vec::new();
    for c in text.trim_end_matches('=').bytes() {
        let v = ALPHABET.iter().position(|&a| a == c)? as u32;
        bits = bits << 6 | v;
        count += 6;
        if count >= 8 {
            count -= 8;
            out.push((bits >> count) as u8);
        }
    }
    let little = Dtype {
        little: true,
        ..*dtype
    };
    (out.len() == dtype.size).then(|| little.values(&out)[0])
}

/// A v2 array from its `.zarray` metadata and `.zattrs` attributes (from its own files, or the
/// store's consolidated `.zmetadata`, `meta_path`).
fn array_v2(
    dir: &Path,
    name: &str,
    meta: &serde_json::Value,
    attrs: &serde_json::Value,
    meta_path: &Path,
) -> Result<ZArray> {
    let bad = |why: String| Error::format(meta_path, why);
    let dtype = Dtype::from_numpy(meta["dtype"].as_str().unwrap_or("")).map_err(bad)?;
    if meta["order"].as_str() == Some("F") {
        return Err(bad("is in Fortran order, which is not read".into()));
    }
    if meta["filters"].as_array().is_some_and(|f| !f.is_empty()) {
        return Err(bad(format!(
            "has filters {}, which are not read",
            meta["filters"]
        )));
    }
    let codecs = match &meta["compressor"] {
        serde_json::Value::Null => Vec::new(),
        c => vec![Codec::named(c["id"].as_str().unwrap_or("?")).map_err(bad)?],
    };
    let dims: Vec<String> = attrs["_ARRAY_DIMENSIONS"]
        .as_array()
        .map(|d| {
            d.iter()
                .map(|x| x.as_str().unwrap_or("").to_string())
                .collect()
        })
        .unwrap_or_default();
    let mut attributes = attributes_of(attrs, "_ARRAY_DIMENSIONS");
    let fill = fill_value(&meta["fill_value"], &dtype);
    if let Some(f) = fill {
        if !attributes.iter().any(|(k, _)| k == "_FillValue") {
            attributes.push(("_FillValue".into(), NcAttribute::Numbers(vec![f])));
        }
    }
    let separator = if meta["dimension_separator"].as_str() == Some("/") {
        '/'
    } else {
        '.'
    };
    finish(ZArray {
        name: name.to_string(),
        dir: dir.to_path_buf(),
        shape: sizes(&meta["shape"], "shape", meta_path)?,
        chunks: sizes(&meta["chunks"], "chunks", meta_path)?,
        dtype,
        fill: fill.unwrap_or(f64::NAN),
        codecs,
        dims,
        attributes,
        key_prefix: None,
        separator,
    })
}

/// A v3 array from its `zarr.json` metadata (its own, or the root's consolidated copy at
/// `meta_path`).
fn array_v3(dir: &Path, name: &str, meta: &serde_json::Value, meta_path: &Path) -> Result<ZArray> {
    let bad = |why: String| Error::format(meta_path, why);
    let mut dtype = Dtype::from_v3(meta["data_type"].as_str().unwrap_or("?")).map_err(bad)?;
    if meta["chunk_grid"]["name"].as_str() != Some("regular") {
        return Err(bad(format!(
            "has chunk grid {}, only 'regular' is read",
            meta["chunk_grid"]["name"]
        )));
    }
    let mut codecs = Vec::new();
    for c in meta["codecs"].as_array().into_iter().flatten() {
        match c["name"].as_str().unwrap_or("?") {
            "bytes" => dtype.little = c["configuration"]["endian"].as_str() != Some("big"),
            "sharding_indexed" => {
                return Err(bad(
                    "is sharded (sharding_indexed), which is not read yet".into()
                ))
            }
            "transpose" => return Err(bad("has a transpose codec, which is not read".into())),
            other => codecs.push(Codec::named(other).map_err(bad)?),
        }
    }
    let encoding = &meta["chunk_key_encoding"];
    let v2_keys = encoding["name"].as_str() == Some("v2");
    let separator = match encoding["configuration"]["separator"].as_str() {
        Some(".") => '.',
        Some("/") => '/',
        _ if v2_keys => '.',
        _ => '/',
    };
    let mut attributes = attributes_of(&meta["attributes"], "");
    for (k, v) in attributes.iter_mut() {
        if let (true, NcAttribute::Text(t)) = (k == "_FillValue", &*v) {
            if let Some(n) = base64_number(t, &dtype) {
                *v = NcAttribute::Numbers(vec![n]);
            }
        }
    }
    let dims = meta["dimension_names"]
        .as_array()
        .map(|d| {
            d.iter()
                .map(|x| x.as_str().unwrap_or("").to_string())
                .collect()
        })
        .unwrap_or_default();
    finish(ZArray {
        name: name.to_string(),
        dir: dir.to_path_buf(),
        shape: sizes(&meta["shape"], "shape", meta_path)?,
        chunks: sizes(
            &meta["chunk_grid"]["configuration"]["chunk_shape"],
            "chunk_shape",
            meta_path,
        )?,
        fill: fill_value(&meta["fill_value"], &dtype).unwrap_or(f64::NAN),
        dtype,
        codecs,
        dims,
        attributes,
        key_prefix: (!v2_keys).then_some("c"),
        separator,
    })
}

/// Checks that shape, chunks and dimensions agree, naming missing dimension names `dim_k`.
fn finish(mut a: ZArray) -> Result<ZArray> {
    let meta = a.dir.join(if a.key_prefix.is_some() {
        "zarr.json"
    } else {
        ".zarray"
    });
    if a.chunks.len() != a.shape.len() || a.chunks.contains(&0) {
        return Err(Error::format(
            &meta,
            format!(
                "chunk shape {:?} does not fit shape {:?}",
                a.chunks, a.shape
            ),
        ));
    }
    if a.dims.len() != a.shape.len() {
        a.dims = (0..a.shape.len()).map(|k| format!("dim_{k}")).collect();
    }
    Ok(a)
}

/// The store at `root`: its arrays (the root's children that are arrays), by name. Consolidated
/// metadata (v2's `.zmetadata`, v3's `consolidated_metadata` in the root's `zarr.json`) is read
/// when the store has it, as xarray does (`consolidated=None`): one file for the whole store,
/// and the arrays' own files are not opened.
pub(crate) fn read_store(root: &Path) -> Result<Store> {
    let v3 = root.join("zarr.json");
    let mut arrays = Vec::new();
    let globals = if v3.is_file() {
        let meta = json(&v3)?;
        let consolidated = &meta["consolidated_metadata"]["metadata"];
        if let Some(nodes) = consolidated.as_object() {
            for (name, node) in nodes.iter().filter(|(n, _)| !n.contains('/')) {
                if node["node_type"].as_str() == Some("array") {
                    arrays.push(array_v3(&root.join(name), name, node, &v3)?);
                }
            }
        } else {
            for name in child_folders(root)? {
                let (dir, own) = (root.join(&name), root.join(&name).join("zarr.json"));
                if own.is_file() {
                    let node = json(&own)?;
                    if node["node_type"].as_str() == Some("array") {
                        arrays.push(array_v3(&dir, &name, &node, &own)?);
                    }
                }
            }
        }
        attributes_of(&meta["attributes"], "")
    } else {
        let own_or_empty = |path: &Path| -> Result<serde_json::Value> {
            if path.is_file() {
                json(path)
            } else {
                Ok(serde_json::json!({}))
            }
        };
        let zmeta = root.join(".zmetadata");
        let consolidated = if zmeta.is_file() {
            Some(json(&zmeta)?)
        } else {
            None
        };
        match consolidated
            .as_ref()
            .and_then(|c| c["metadata"].as_object())
        {
            Some(entries) => {
                for (key, meta) in entries {
                    let Some(name) = key.strip_suffix("/.zarray").filter(|n| !n.contains('/'))
                    else {
                        continue;
                    };
                    let attrs = entries
                        .get(&format!("{name}/.zattrs"))
                        .cloned()
                        .unwrap_or_else(|| serde_json::json!({}));
                    arrays.push(array_v2(&root.join(name), name, meta, &attrs, &zmeta)?);
                }
                attributes_of(&entries.get(".zattrs").cloned().unwrap_or_default(), "")
            }
            None => {
                for name in child_folders(root)? {
                    let dir = root.join(&name);
                    let own = dir.join(".zarray");
                    if own.is_file() {
                        let attrs = own_or_empty(&dir.join(".zattrs"))?;
                        arrays.push(array_v2(&dir, &name, &json(&own)?, &attrs, &own)?);
                    }
                }
                attributes_of(&own_or_empty(&root.join(".zattrs"))?, "")
            }
        }
    };
    arrays.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(Store { globals, arrays })
}

/// The names of the folders in `root`.
fn child_folders(root: &Path) -> Result<Vec<String>> {
    Ok(std::fs::read_dir(root)
        .map_err(|e| Error::io(root, e))?
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xarray_fill_values_decode() {
        let f8 = Dtype::from_v3("float64").unwrap();
        // xarray's base64 of NaN's bytes (little-endian f64 0x7ff8000000000000).
        assert!(base64_number("AAAAAAAA+H8=", &f8).unwrap().is_nan());
        let f4 = Dtype::from_v3("float32").unwrap();
        assert_eq!(base64_number("AADAfw==", &f4).map(f64::is_nan), Some(true));
        assert_eq!(base64_number("AACAPw==", &f4), Some(1.0));
        assert_eq!(fill_value(&serde_json::json!("0x3f800000"), &f4), Some(1.0));
        assert!(fill_value(&serde_json::json!("NaN"), &f4).unwrap().is_nan());
    }

    #[test]
    fn python_json_non_finite_numbers_are_read() {
        let text = r#"{"fill_value": NaN, "a": [-Infinity, Infinity], "s": "NaN \" Infinity"}"#;
        let v: serde_json::Value = serde_json::from_str(&quote_non_finite(text)).unwrap();
        assert_eq!(v["fill_value"], "NaN");
        assert_eq!(v["a"], serde_json::json!(["-Infinity", "Infinity"]));
        assert_eq!(v["s"], "NaN \" Infinity");
    }
}
