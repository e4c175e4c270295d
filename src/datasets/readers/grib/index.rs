//! What a GRIB file holds, as the data model presents it: its messages found and described
//! (parameter, level, reference time, step, ensemble member, grid), then grouped into variables
//! with dimensions as cfgrib groups them — one variable per parameter and level type on one
//! grid, with `number`, `time`, `step` and the level as dimensions where a variable's messages
//! take several values, and the grid as (`latitude`, `longitude`) on regular and Gaussian grids
//! or (`y`, `x`) with two-dimensional `latitude` and `longitude` on rotated and projected ones.
//! A combination no message holds is missing. The index of a file is built once per process
//! and kept while the file's length and time stay the same.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::model::{GribIndex, Located};
use crate::error::{Error, Result};

/// Splits a file into its messages: each starts at "GRIB" (anything between messages, such as
/// WMO bulletin headers, is skipped, as ecCodes does) and is as long as its indicator section
/// says. Returns (offset, length, edition) of each.
pub(crate) fn split(path: &Path, bytes: &[u8]) -> Result<Vec<(usize, usize, u8)>> {
    let mut found = Vec::new();
    let mut at = 0;
    while let Some(start) = find(bytes, at) {
        let edition = bytes.get(start + 7).copied().unwrap_or(0);
        let length = match edition {
            1 => bytes
                .get(start + 4..start + 7)
                .map(|b| (b[0] as usize) << 16 | (b[1] as usize) << 8 | b[2] as usize),
            2 => bytes
                .get(start + 8..start + 16)
                .map(|b| u64::from_be_bytes(b.try_into().expect("8 octets")) as usize),
            _ => None,
        };
        let what = format!("message {} (offset {start})", found.len());
        let Some(length) = length else {
            let why = if matches!(edition, 1 | 2) {
                "the file ends inside its indicator section (truncated)".to_string()
            } else {
                format!("GRIB edition {edition} is not 1 or 2")
            };
            return Err(Error::format(path, format!("{what}: {why}")));
        };
        let end = start.checked_add(length).filter(|&e| e <= bytes.len());
        match end {
            Some(end) if length >= 12 && &bytes[end - 4..end] == b"7777" => {
                found.push((start, length, edition));
                at = end;
            }
            Some(_) => {
                return Err(Error::format(
                    path,
                    format!("{what}: no end section '7777' where its length of {length} octets ends (damaged)"),
                ))
            }
            None => {
                return Err(Error::format(
                    path,
                    format!(
                        "{what}: the message is {length} octets long but the file ends after {} (truncated)",
                        bytes.len() - start
                    ),
                ))
            }
        }
    }
    if found.is_empty() {
        return Err(Error::format(path, "holds no GRIB message"));
    }
    Ok(found)
}

fn find(bytes: &[u8], from: usize) -> Option<usize> {
    bytes
        .get(from..)?
        .windows(4)
        .position(|w| w == b"GRIB")
        .map(|p| p + from)
}

type Stamp = (u64, Option<std::time::SystemTime>);

/// Indexes built so far, by file, with the stamp they were built at.
type Indexes = HashMap<PathBuf, (Stamp, Arc<GribIndex>)>;

static INDEXES: Mutex<Option<Indexes>> = Mutex::new(None);

/// The index of the GRIB file at `path`, built on first use and kept while the file is unchanged.
pub(crate) fn index_of(path: &Path) -> Result<Arc<GribIndex>> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let stamp = (meta.len(), meta.modified().ok());
    if let Some((s, index)) = INDEXES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .as_ref()
        .and_then(|m| m.get(path))
    {
        if *s == stamp {
            return Ok(index.clone());
        }
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let mut messages = Vec::new();
    for (k, (offset, length, edition)) in split(path, &bytes)?.into_iter().enumerate() {
        let msg = &bytes[offset..offset + length];
        let named = |why: String| {
            Error::format(
                path,
                format!("message {k} (GRIB{edition}, offset {offset}): {why}"),
            )
        };
        // Each field of a message is one message to the rest of hdrvis, as to cfgrib.
        let fields = match edition {
            1 => 1,
            _ => super::grib2::field_count(msg).map_err(named)?,
        };
        for sub in 0..fields {
            let field = match edition {
                1 => super::grib1::field(msg),
                _ => super::grib2::field(msg, sub),
            }
            .map_err(named)?;
            messages.push(Located {
                offset,
                length,
                sub,
                field,
            });
        }
    }
    let index = Arc::new(super::dataset::build(messages));
    INDEXES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get_or_insert_with(HashMap::new)
        .insert(path.to_path_buf(), (stamp, index.clone()));
    Ok(index)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_found_between_headers_and_cut_ones_named() {
        let mut msg = b"GRIB\0\0\x10\x01".to_vec();
        msg.extend_from_slice(&[0; 4]);
        msg.extend_from_slice(b"7777");
        let mut file = b"TTAA01 KWBC\r\r\n".to_vec();
        file.extend_from_slice(&msg);
        file.extend_from_slice(&msg);
        let got = split(Path::new("f.grib"), &file).unwrap();
        assert_eq!(got, [(14, 16, 1), (30, 16, 1)]);
        let cut = &file[..file.len() - 3];
        let err = split(Path::new("f.grib"), cut).unwrap_err().to_string();
        assert!(
            err.contains("message 1 (offset 30)") && err.contains("truncated"),
            "{err}"
        );
    }
}
