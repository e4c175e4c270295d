//! Script API for large volumes: `open_volume` opens a file as bricks without loading it (a
//! memory-mapped `.npy`, NetCDF read by hyperslabs), and `render_volume` takes the bricked path's
//! options: `memory_budget` (MiB of GPU memory; `hdrvis run --gpu-memory` sets the default),
//! `skip` (empty-space skipping), `brick` (edge in voxels) and `level` (2^level-times coarser
//! quick look). A volume that exceeds the budget streams through a fixed brick cache.

use super::api_render::ScriptCamera;
use super::convert::{boolean, check_keys, int, num, string, to_rhai, RResult};
use super::ScriptHost;
use crate::error::{Error, Result};
use crate::model::bricks::{BrickedVolume, DEFAULT_BRICK};
use crate::model::{HdrImage, Volume};
use crate::render::bricked::BrickCache;
use crate::render::{Precision, VolumeRenderOptions};
use rhai::{Dynamic, Engine, Map};
use std::sync::{Arc, Mutex};

/// A volume opened as bricks (`open_volume`).
pub type ScriptBricked = Arc<BrickedVolume>;

/// The keys `render_volume` takes for bricked rendering.
pub const BRICK_RENDER_KEYS: &[&str] = &["memory_budget", "skip", "brick", "level"];
const OPEN_KEYS: &[&str] = &["var", "brick"];
/// Coarsest quick-look level: 16 times fewer voxels per axis.
const MAX_LEVEL: i64 = 4;

/// The bricked-rendering options of one `render_volume` call.
#[derive(Clone, Debug, Default)]
pub struct BrickOptions {
    pub memory_budget_mib: Option<f64>,
    pub skip: Option<bool>,
    pub brick: Option<usize>,
    pub level: u32,
}

impl BrickOptions {
    /// Takes `key` if it is one of [`BRICK_RENDER_KEYS`]; false otherwise.
    pub fn take(&mut self, key: &str, v: &Dynamic) -> RResult<bool> {
        match key {
            "memory_budget" => {
                let m = num(v, "memory_budget")?;
                if !(m.is_finite() && m > 0.0) {
                    return Err(to_rhai(Error::invalid(
                        "memory_budget",
                        format!("expected MiB > 0, got {m}"),
                    )));
                }
                self.memory_budget_mib = Some(m);
            }
            "skip" => self.skip = Some(boolean(v, "skip")?),
            "brick" => self.brick = Some(int(v, "brick")?.clamp(0, 1 << 20) as usize),
            "level" => {
                let l = int(v, "level")?;
                if !(0..=MAX_LEVEL).contains(&l) {
                    return Err(to_rhai(Error::invalid(
                        "level",
                        format!("expected 0 (full resolution) to {MAX_LEVEL}, got {l}"),
                    )));
                }
                self.level = l as u32;
            }
            _ => return Ok(false),
        }
        Ok(true)
    }
}

/// Any script volume, kept alive so its address identifies it.
type Keepalive = Arc<dyn std::any::Any + Send + Sync>;
/// A coarser level: (source, level, volume).
type Level = (Keepalive, u32, Arc<Volume>);
/// An in-memory volume cut into bricks: (volume, brick edge, bricked).
type Cut = (Arc<Volume>, usize, Arc<BrickedVolume>);

/// What the bricked path keeps between renders of one script run.
#[derive(Default)]
pub(crate) struct BrickState {
    /// Coarser levels by (source address, level); the source is kept so its address stays unique.
    levels: Mutex<Vec<Level>>,
    /// In-memory volumes cut into bricks, by (volume, brick edge).
    bricked: Mutex<Vec<Cut>>,
    /// GPU brick caches, at most one per bricked volume.
    caches: Mutex<Vec<BrickCache>>,
}

/// The volume a render reads.
pub(crate) enum Source {
    Memory(Arc<Volume>),
    Bricked(Arc<BrickedVolume>),
}

impl Source {
    fn any(&self) -> Keepalive {
        match self {
            Source::Memory(v) => v.clone(),
            Source::Bricked(b) => b.clone(),
        }
    }
}

fn level_of(host: &ScriptHost, source: &Source, level: u32) -> Result<Arc<Volume>> {
    let key = source.any();
    {
        let levels = host.bricks.levels.lock().expect("levels poisoned");
        if let Some((_, _, v)) = levels
            .iter()
            .find(|(s, l, _)| Arc::ptr_eq(s, &key) && *l == level)
        {
            return Ok(v.clone());
        }
    }
    let mut coarse = match (level, source) {
        (1, Source::Bricked(b)) => b.downsampled()?,
        (1, Source::Memory(v)) => {
            BrickedVolume::from_volume(v.clone(), DEFAULT_BRICK)?.downsampled()?
        }
        _ => BrickedVolume::from_volume(level_of(host, source, level - 1)?, DEFAULT_BRICK)?
            .downsampled()?,
    };
    coarse.name = format!("{} (level {level})", name_of(source));
    cache_level(host, key, level, Arc::new(coarse))
}

fn cache_level(
    host: &ScriptHost,
    key: Keepalive,
    level: u32,
    v: Arc<Volume>,
) -> Result<Arc<Volume>> {
    host.bricks
        .levels
        .lock()
        .expect("levels poisoned")
        .push((key, level, v.clone()));
    Ok(v)
}

fn name_of(source: &Source) -> String {
    match source {
        Source::Memory(v) => v.name.clone(),
        Source::Bricked(b) => b.name.clone(),
    }
}

/// Renders through the plain, bricked or out-of-core path as the options and the budget say.
pub(crate) fn render(
    host: &ScriptHost,
    source: Source,
    o: &VolumeRenderOptions,
    b: &BrickOptions,
) -> Result<Arc<HdrImage>> {
    let budget = b
        .memory_budget_mib
        .or(host.gpu_memory_mib)
        .map(|m| (m * (1u64 << 20) as f64) as u64);
    let source = if b.level > 0 {
        Source::Memory(level_of(host, &source, b.level)?)
    } else {
        source
    };
    let pixels = o.width as u64 * o.height as u64;
    let bricked = match source {
        Source::Memory(v) => {
            let fits = budget.is_none_or(|m| v.voxel_count() as u64 * 4 + pixels * 32 <= m);
            // f64 runs on the plain path (GPU f64 or the CPU reference), which has no budget.
            if o.precision == Precision::F64 || fits && b.skip != Some(true) && b.brick.is_none() {
                return host.session.raycast(&v, o);
            }
            let brick = b.brick.unwrap_or(DEFAULT_BRICK);
            let mut cut = host.bricks.bricked.lock().expect("bricked poisoned");
            match cut
                .iter()
                .find(|(s, e, _)| Arc::ptr_eq(s, &v) && *e == brick)
            {
                Some((_, _, bv)) => bv.clone(),
                None => {
                    let bv = Arc::new(BrickedVolume::from_volume(v.clone(), brick)?);
                    cut.push((v, brick, bv.clone()));
                    bv
                }
            }
        }
        Source::Bricked(bv) => {
            if let Some(e) = b.brick.filter(|&e| e != bv.layout.brick) {
                return Err(Error::invalid(
                    "brick",
                    format!(
                        "{} was opened with bricks of {}; give brick: {e} to open_volume instead",
                        bv.name, bv.layout.brick
                    ),
                ));
            }
            bv
        }
    };
    if o.shading.is_some() {
        return Err(Error::invalid(
            "shading",
            format!(
                "{} renders bricked here (open_volume, skip, brick or a memory_budget it exceeds), \
                 and the bricked ray caster has no shading: its one-voxel brick apron is too \
                 narrow for the gradient; to shade, load_volume it and render without skip, brick or \
                 memory_budget",
                bricked.name
            ),
        ));
    }
    let renderer = host.session.volume_renderer()?;
    let mut caches = host.bricks.caches.lock().expect("caches poisoned");
    // Under a budget, only this volume's cache may hold GPU memory.
    caches.retain(|c| {
        Arc::ptr_eq(&c.volume, &bricked) && c.serves(budget, o.width, o.height)
            || budget.is_none() && !Arc::ptr_eq(&c.volume, &bricked)
    });
    let idx = match caches.iter().position(|c| Arc::ptr_eq(&c.volume, &bricked)) {
        Some(i) => i,
        None => {
            caches.push(BrickCache::new(
                renderer.context(),
                bricked,
                budget,
                o.width,
                o.height,
            )?);
            caches.len() - 1
        }
    };
    let (img, _) = renderer.render_bricked(&mut caches[idx], o, b.skip.unwrap_or(true))?;
    Ok(Arc::new(img))
}

pub fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
    engine.register_type_with_name::<ScriptBricked>("BrickedVolume");
    engine.register_get("name", |v: &mut ScriptBricked| v.name.clone());
    engine.register_get("dims", |v: &mut ScriptBricked| -> rhai::Array {
        v.dims.iter().map(|&d| Dynamic::from(d as i64)).collect()
    });
    engine.register_fn("volume_stats", |v: &mut ScriptBricked| -> Map {
        super::api_render::stats_map(&v.stats)
    });
    let h = host.clone();
    engine.register_fn("open_volume", move |path: &str| -> RResult<ScriptBricked> {
        let p = h.sandbox.read_path(path).map_err(to_rhai)?;
        Ok(Arc::new(
            crate::datasets::bricked::open_bricked(&p, None, DEFAULT_BRICK).map_err(to_rhai)?,
        ))
    });
    let h = host.clone();
    engine.register_fn(
        "open_volume",
        move |path: &str, opts: Map| -> RResult<ScriptBricked> {
            check_keys(&opts, OPEN_KEYS, "open_volume")?;
            let p = h.sandbox.read_path(path).map_err(to_rhai)?;
            let mut var = None;
            let mut brick = DEFAULT_BRICK;
            for (k, v) in &opts {
                match k.as_str() {
                    "var" => var = Some(string(v, "var")?),
                    "brick" => brick = int(v, "brick")?.clamp(0, 1 << 20) as usize,
                    _ => unreachable!("checked keys"),
                }
            }
            Ok(Arc::new(
                crate::datasets::bricked::open_bricked(&p, var.as_deref(), brick)
                    .map_err(to_rhai)?,
            ))
        },
    );
    let h = host;
    engine.register_fn(
        "render_volume",
        move |volume: &mut ScriptBricked, opts: Map| -> RResult<super::api_render::ScriptImage> {
            let (o, b) = super::api_render::render_options(&opts, |cam: &ScriptCamera| {
                cam.resolve(&volume.bounds())
            })?;
            if o.precision == crate::render::Precision::F64 {
                return Err(to_rhai(Error::invalid(
                    "precision",
                    "f64 runs on the CPU reference, which needs the volume in memory: use load_volume",
                )));
            }
            let img = render(&h, Source::Bricked(volume.clone()), &o, &b).map_err(to_rhai)?;
            h.note_image(&img);
            Ok(img)
        },
    );
}
