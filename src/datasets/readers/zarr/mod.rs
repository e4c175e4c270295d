//! Zarr directory stores (versions 2 and 3), the layout of cloud archives (reanalyses, CMIP6
//! copies) and of xarray's `to_zarr`, as a reader of the data model: each array is a variable
//! with its dimension names and attributes, read chunk by chunk (only the chunks a selection
//! touches) and CF-decoded as NetCDF is, so CF time, coordinates, selection and maps work
//! unchanged. Groups below the root are not read.

mod codecs;
mod meta;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::variables::{Dims, NcAttribute, NcVariable};
use crate::datasets::conventions::cf_decode::CfDecoding;
use crate::datasets::select::Selection;
use crate::datasets::{ArrayData, ArrayListing};
use crate::error::{Error, Result};
pub(crate) use meta::is_store;
use meta::{Store, ZArray};

/// The Zarr reader.
pub(crate) struct ZarrReader;

type Stamp = Option<std::time::SystemTime>;

/// Stores read so far, with the time of their root metadata then.
type Stores = HashMap<PathBuf, (Stamp, Arc<Store>)>;

static STORES: Mutex<Option<Stores>> = Mutex::new(None);

fn store(path: &Path) -> Result<Arc<Store>> {
    let root_meta = [
        path.join("zarr.json"),
        path.join(".zgroup"),
        path.join(".zmetadata"),
    ]
    .into_iter()
    .find(|p| p.is_file())
    .unwrap_or_else(|| path.to_path_buf());
    let stamp = std::fs::metadata(&root_meta)
        .and_then(|m| m.modified())
        .ok();
    let mut stores = STORES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((s, store)) = stores.as_ref().and_then(|m| m.get(path)) {
        if *s == stamp {
            return Ok(store.clone());
        }
    }
    let store = Arc::new(meta::read_store(path)?);
    stores
        .get_or_insert_with(HashMap::new)
        .insert(path.to_path_buf(), (stamp, store.clone()));
    Ok(store)
}

fn array<'a>(path: &Path, store: &'a Store, name: &str) -> Result<&'a ZArray> {
    store.arrays.iter().find(|a| a.name == name).ok_or_else(|| {
        let names: Vec<&str> = store.arrays.iter().map(|a| a.name.as_str()).collect();
        Error::invalid(
            "variable",
            format!(
                "'{name}' is not in {}; it holds {}",
                path.display(),
                names.join(", ")
            ),
        )
    })
}

/// The decoded values of the chunk at grid position `at` (the fill value where it was never
/// written), `chunk` elements long.
fn chunk_values(a: &ZArray, at: &[usize], chunk: usize) -> Result<Vec<f64>> {
    let file = a.chunk_path(at);
    let mut bytes = match std::fs::read(&file) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(vec![a.fill; chunk]),
        Err(e) => return Err(Error::io(&file, e)),
    };
    let size = chunk * a.dtype.size;
    for codec in a.codecs.iter().rev() {
        bytes = codec
            .decode(&bytes, size)
            .map_err(|why| Error::format(&file, why))?;
    }
    if bytes.len() != size {
        return Err(Error::format(
            &file,
            format!(
                "holds {} bytes where a chunk of {chunk} {} values needs {size}",
                bytes.len(),
                a.dtype.name()
            ),
        ));
    }
    Ok(a.dtype.values(&bytes))
}

/// The values of `a` at the indices `sel` (one list per dimension), in C order, read chunk by
/// chunk: only the chunks holding a selected index are decoded. Along the last dimension the
/// selected indices go in runs that share a chunk, each run one chunk lookup and a gather.
fn read_selected(a: &ZArray, sel: &[Vec<usize>]) -> Result<Vec<f64>> {
    let count: usize = sel.iter().map(Vec::len).product();
    crate::model::volume::check_allocation(count as u64 * 8, &a.name)?;
    let chunk: usize = a.chunks.iter().product();
    let Some((last, outer)) = sel.split_last() else {
        // A scalar: one chunk of one value.
        return chunk_values(a, &[], 1);
    };
    let n = sel.len();
    // Per dimension, each selected index's chunk coordinate and offset within the chunk.
    let split: Vec<Vec<(usize, usize)>> = sel
        .iter()
        .zip(&a.chunks)
        .map(|(s, &c)| s.iter().map(|&i| (i / c, i % c)).collect())
        .collect();
    // The last dimension's selection in runs of one chunk coordinate: (coordinate, offsets).
    let mut runs: Vec<(usize, Vec<usize>)> = Vec::new();
    for &(g, w) in &split[n - 1] {
        match runs.last_mut() {
            Some((run, offsets)) if *run == g => offsets.push(w),
            _ => runs.push((g, vec![w])),
        }
    }
    let chunks_along: Vec<usize> = a
        .shape
        .iter()
        .zip(&a.chunks)
        .map(|(&len, &c)| len.div_ceil(c).max(1))
        .collect();
    let mut out = Vec::with_capacity(count);
    // Chunks are visited in order, so the few along the last dimensions are enough to hold.
    let mut cache: HashMap<usize, Vec<f64>> = HashMap::new();
    let mut index = vec![0usize; n - 1];
    let mut grid = vec![0usize; n];
    let rows = if last.is_empty() {
        0
    } else {
        outer.iter().map(Vec::len).product()
    };
    for _ in 0..rows {
        let (mut id, mut within) = (0usize, 0usize);
        for (d, &i) in index.iter().enumerate() {
            let (g, w) = split[d][i];
            id = id * chunks_along[d] + g;
            within = within * a.chunks[d] + w;
            grid[d] = g;
        }
        for (g, offsets) in &runs {
            let key = id * chunks_along[n - 1] + g;
            grid[n - 1] = *g;
            if !cache.contains_key(&key) {
                if cache.len() > 64 {
                    cache.clear();
                }
                cache.insert(key, chunk_values(a, &grid, chunk)?);
            }
            let values = &cache[&key];
            let base = within * a.chunks[n - 1];
            out.extend(offsets.iter().map(|&w| values[base + w]));
        }
        for d in (0..index.len()).rev() {
            index[d] += 1;
            if index[d] < outer[d].len() {
                break;
            }
            index[d] = 0;
        }
    }
    Ok(out)
}

impl ZarrReader {
    fn read_array(
        &self,
        a: &ZArray,
        picks: &[Option<usize>],
        window: Option<(usize, std::ops::Range<usize>)>,
    ) -> Result<NcVariable> {
        let dims: Dims = a
            .dims
            .iter()
            .cloned()
            .zip(a.shape.iter().copied())
            .collect();
        let sel = super::variables::kept(&dims, picks, &window)?;
        let mut data = read_selected(a, &sel)?;
        CfDecoding::with_defaults(&a.attributes, a.dtype.stored(), false).apply(&mut data);
        Ok(super::variables::picked_variable(
            &a.name,
            &dims,
            (&sel, picks),
            data,
            &a.attributes,
        ))
    }
}

impl super::Reader for ZarrReader {
    fn list(&self, path: &Path) -> Result<Vec<ArrayListing>> {
        let store = store(path)?;
        let dtype = |name: &str| {
            let a = store.arrays.iter().find(|a| a.name == name);
            a.map_or_else(String::new, |a| a.dtype.name())
        };
        super::variables::listing(self, path, &dtype)
    }

    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        rank: Option<usize>,
        sel: &Selection,
    ) -> Result<ArrayData> {
        crate::datasets::read_netcdf_array(path, var, rank, sel)
    }

    fn variables(&self) -> Option<&dyn super::variables::Variables> {
        Some(self)
    }
}

impl super::variables::Variables for ZarrReader {
    fn list(&self, path: &Path) -> Result<Vec<(String, Dims)>> {
        let store = store(path)?;
        Ok(store
            .arrays
            .iter()
            .map(|a| {
                (
                    a.name.clone(),
                    a.dims
                        .iter()
                        .cloned()
                        .zip(a.shape.iter().copied())
                        .collect(),
                )
            })
            .collect())
    }

    fn attributes(&self, path: &Path, name: &str) -> Result<Vec<(String, NcAttribute)>> {
        let store = store(path)?;
        Ok(array(path, &store, name)?.attributes.clone())
    }

    fn global_attributes(&self, path: &Path) -> Result<Vec<(String, NcAttribute)>> {
        Ok(store(path)?.globals.clone())
    }

    fn read(
        &self,
        path: &Path,
        name: &str,
        picks: &[Option<usize>],
        window: Option<(usize, std::ops::Range<usize>)>,
    ) -> Result<NcVariable> {
        let store = store(path)?;
        self.read_array(array(path, &store, name)?, picks, window)
    }
}
