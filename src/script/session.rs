//! What survives between runs of a script in an interactive session (`hdrvis tui`): the GPU
//! context and renderers, volumes and grids already loaded (keyed by path, size and modification
//! time, so an edited file is read again), their GPU uploads, and the surface renderer's data-pass
//! cache. A re-run with another camera, ν or transfer function then costs the render, not the
//! file read, the upload and the adapter start. Entries a run did not touch are dropped when it
//! ends, so memory holds one scene, not every scene seen.
//!
//! A plain `hdrvis run` gets a fresh session per run, which is the old behaviour.

use crate::error::Result;
use crate::gpu::{BackendChoice, GpuContext};
use crate::model::{Grid, Volume};
use crate::render::surface::SurfaceRenderer;
use crate::render::volume::{GpuVolume, VolumeRenderer};
use crate::tonemap::GpuToneMapper;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::SystemTime;

/// A file's identity for the caches: a changed size or modification time means "read again".
#[derive(Clone, Debug, PartialEq, Eq)]
struct FileKey {
    path: PathBuf,
    len: u64,
    modified: Option<SystemTime>,
    /// The variable or array asked for (load_grid's second argument).
    var: Option<String>,
}

impl FileKey {
    fn of(path: &Path, var: Option<&str>) -> Option<FileKey> {
        let meta = std::fs::metadata(path).ok()?;
        Some(FileKey {
            path: path.to_path_buf(),
            len: meta.len(),
            modified: meta.modified().ok(),
            var: var.map(str::to_string),
        })
    }
}

/// One cache entry and whether the current run used it.
struct Entry<K, V> {
    key: K,
    value: V,
    used: bool,
}

/// A small cache whose untouched entries are evicted at the end of each run.
struct RunCache<K, V> {
    entries: Vec<Entry<K, V>>,
}

impl<K: PartialEq, V: Clone> RunCache<K, V> {
    const fn new() -> Self {
        RunCache {
            entries: Vec::new(),
        }
    }

    fn get(&mut self, key: &K) -> Option<V> {
        let e = self.entries.iter_mut().find(|e| e.key == *key)?;
        e.used = true;
        Some(e.value.clone())
    }

    fn insert(&mut self, key: K, value: V) {
        self.entries.retain(|e| e.key != key);
        self.entries.push(Entry {
            key,
            value,
            used: true,
        });
    }

    fn end_run(&mut self) {
        self.entries.retain(|e| e.used);
        for e in &mut self.entries {
            e.used = false;
        }
    }
}

/// GPU objects and loaded data shared by every run of one session.
pub struct ScriptSession {
    backend: BackendChoice,
    renderer: OnceLock<Arc<VolumeRenderer>>,
    surface: OnceLock<Arc<SurfaceRenderer>>,
    tone_mapper: OnceLock<Arc<GpuToneMapper>>,
    volumes: Mutex<RunCache<FileKey, Arc<Volume>>>,
    grids: Mutex<RunCache<FileKey, Arc<Grid>>>,
    /// In-memory generated volumes (`generate_mantle`), keyed by their options.
    generated: Mutex<RunCache<String, Arc<Volume>>>,
    /// Uploads keyed by the address of the volume; the Arc is kept so the address cannot be
    /// reused while the entry lives.
    uploads: Mutex<RunCache<usize, (Arc<Volume>, Arc<GpuVolume>)>>,
    /// How many volume uploads ran (tests check that a re-run reuses the upload).
    upload_count: Mutex<u64>,
}

impl std::fmt::Debug for ScriptSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScriptSession")
            .field("backend", &self.backend)
            .field("gpu_started", &self.renderer.get().is_some())
            .finish_non_exhaustive()
    }
}

impl ScriptSession {
    pub fn new(backend: BackendChoice) -> Arc<ScriptSession> {
        Arc::new(ScriptSession {
            backend,
            renderer: OnceLock::new(),
            surface: OnceLock::new(),
            tone_mapper: OnceLock::new(),
            volumes: Mutex::new(RunCache::new()),
            grids: Mutex::new(RunCache::new()),
            generated: Mutex::new(RunCache::new()),
            uploads: Mutex::new(RunCache::new()),
            upload_count: Mutex::new(0),
        })
    }

    pub fn backend(&self) -> BackendChoice {
        self.backend
    }

    /// The volume renderer, started (adapter and device) on first use.
    pub fn renderer(&self) -> Result<Arc<VolumeRenderer>> {
        if let Some(r) = self.renderer.get() {
            return Ok(r.clone());
        }
        let ctx = GpuContext::new(self.backend)?;
        Ok(self
            .renderer
            .get_or_init(|| Arc::new(VolumeRenderer::new(ctx)))
            .clone())
    }

    /// The adapter's name and backend, e.g. `llvmpipe (Vulkan)`, once the GPU has started.
    pub fn adapter(&self) -> Option<String> {
        self.renderer.get().map(|r| {
            let ctx = r.context();
            let full = ctx.describe();
            let name = full.split(" (").next().unwrap_or(&full).to_string();
            format!("{name} ({})", ctx.backend_name())
        })
    }

    pub fn surface_renderer(&self) -> Result<Arc<SurfaceRenderer>> {
        if let Some(r) = self.surface.get() {
            return Ok(r.clone());
        }
        let ctx = self.renderer()?.context().clone();
        Ok(self
            .surface
            .get_or_init(|| Arc::new(SurfaceRenderer::new(ctx)))
            .clone())
    }

    pub fn tone_mapper(&self) -> Result<Arc<GpuToneMapper>> {
        if let Some(m) = self.tone_mapper.get() {
            return Ok(m.clone());
        }
        let ctx = self.renderer()?.context().clone();
        Ok(self
            .tone_mapper
            .get_or_init(|| Arc::new(GpuToneMapper::new(ctx)))
            .clone())
    }

    /// The GPU copy of `volume`, uploaded on first use.
    pub fn upload(&self, volume: &Arc<Volume>) -> Result<Arc<GpuVolume>> {
        let renderer = self.renderer()?;
        let key = Arc::as_ptr(volume) as usize;
        let mut uploads = self.uploads.lock().expect("upload cache poisoned");
        if let Some((_, g)) = uploads.get(&key) {
            return Ok(g);
        }
        let g = Arc::new(GpuVolume::upload(renderer.context(), volume)?);
        uploads.insert(key, (volume.clone(), g.clone()));
        *self.upload_count.lock().expect("upload count poisoned") += 1;
        Ok(g)
    }

    pub fn upload_count(&self) -> u64 {
        *self.upload_count.lock().expect("upload count poisoned")
    }

    /// A volume file, read once per (path, size, modification time).
    pub fn load_volume(&self, path: &Path) -> Result<Arc<Volume>> {
        let key = FileKey::of(path, None);
        if let Some(k) = &key {
            if let Some(v) = self.volumes.lock().expect("volume cache poisoned").get(k) {
                return Ok(v);
            }
        }
        let v = Arc::new(crate::datasets::load_volume(path)?);
        if let Some(k) = key {
            self.volumes
                .lock()
                .expect("volume cache poisoned")
                .insert(k, v.clone());
        }
        Ok(v)
    }

    /// A grid file (optionally one named array), read once per (path, size, modification time).
    pub fn load_grid(&self, path: &Path, var: Option<&str>) -> Result<Arc<Grid>> {
        let key = FileKey::of(path, var);
        if let Some(k) = &key {
            if let Some(g) = self.grids.lock().expect("grid cache poisoned").get(k) {
                return Ok(g);
            }
        }
        let g = Arc::new(Grid::load(path, var)?);
        if let Some(k) = key {
            self.grids
                .lock()
                .expect("grid cache poisoned")
                .insert(k, g.clone());
        }
        Ok(g)
    }

    /// A generated in-memory volume, made once per option set `key`.
    pub fn generated(
        &self,
        key: String,
        make: impl FnOnce() -> Result<Volume>,
    ) -> Result<Arc<Volume>> {
        if let Some(v) = self.generated.lock().expect("cache poisoned").get(&key) {
            return Ok(v);
        }
        let v = Arc::new(make()?);
        self.generated
            .lock()
            .expect("cache poisoned")
            .insert(key, v.clone());
        Ok(v)
    }

    /// Drops what the run that just ended did not use.
    pub(crate) fn end_run(&self) {
        self.volumes
            .lock()
            .expect("volume cache poisoned")
            .end_run();
        self.grids.lock().expect("grid cache poisoned").end_run();
        self.generated.lock().expect("cache poisoned").end_run();
        self.uploads
            .lock()
            .expect("upload cache poisoned")
            .end_run();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_cache_keeps_what_the_last_run_used() {
        let mut c: RunCache<u32, &str> = RunCache::new();
        c.insert(1, "a");
        c.insert(2, "b");
        c.end_run();
        assert_eq!(c.get(&1), Some("a"));
        c.end_run(); // 2 was not used in this run
        assert_eq!(c.get(&2), None);
        assert_eq!(c.get(&1), Some("a"));
    }

    #[test]
    fn a_changed_file_is_read_again() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.npy");
        let write = |value: f32| {
            crate::datasets::npy::write_npy(&path, &[2, 2, 2], &[value; 8]).unwrap();
        };
        write(1.0);
        let session = ScriptSession::new(BackendChoice::Auto);
        let a = session.load_volume(&path).unwrap();
        let b = session.load_volume(&path).unwrap();
        assert!(Arc::ptr_eq(&a, &b), "an unchanged file is read once");
        // A different size makes a different key even within the clock's resolution.
        crate::datasets::npy::write_npy(&path, &[2, 2, 3], &[3.0f32; 12]).unwrap();
        let c = session.load_volume(&path).unwrap();
        assert!(!Arc::ptr_eq(&a, &c));
        assert_eq!(c.dims, [3, 2, 2]);
    }
}
