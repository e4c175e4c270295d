//! Script API for large volumes: `open_volume` opens a file as bricks without loading it (a
//! memory-mapped `.npy`, NetCDF read by hyperslabs); `render_volume` on such a volume goes to
//! the render session's one entry point like every other render (see `render::route`).

use super::api_render::{render_and_note, render_options, ScriptImage};
use super::convert::{check_keys, int, to_rhai, variable_option, RResult};
use super::ScriptHost;
use crate::model::bricks::{BrickedVolume, DEFAULT_BRICK};
use crate::render::VolumeSource;
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

/// A volume opened as bricks (`open_volume`).
pub(crate) type ScriptBricked = Arc<BrickedVolume>;

const OPEN_KEYS: &[&str] = &["variable", "brick"];

pub(crate) fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
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
        let (p, variable) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
        Ok(Arc::new(
            crate::datasets::bricked::open_bricked(&p, variable.as_deref(), DEFAULT_BRICK)
                .map_err(to_rhai)?,
        ))
    });
    let h = host.clone();
    engine.register_fn(
        "open_volume",
        move |path: &str, opts: Map| -> RResult<ScriptBricked> {
            check_keys(&opts, OPEN_KEYS, "open_volume")?;
            let (p, from_path) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
            let variable = variable_option(&opts, from_path, "open_volume")?;
            let brick = match opts.get("brick") {
                Some(v) => int(v, "brick")?.clamp(0, 1 << 20) as usize,
                None => DEFAULT_BRICK,
            };
            Ok(Arc::new(
                crate::datasets::bricked::open_bricked(&p, variable.as_deref(), brick)
                    .map_err(to_rhai)?,
            ))
        },
    );
    let h = host;
    engine.register_fn(
        "render_volume",
        move |volume: &mut ScriptBricked, opts: Map| -> RResult<ScriptImage> {
            let source = VolumeSource::Bricked(volume.clone());
            let o = render_options(&h, &opts, &source)?;
            render_and_note(&h, &source, &o)
        },
    );
}
