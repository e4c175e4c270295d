//! Script API for large volumes: `open_volume` opens a file as bricks without loading it (a
//! `.npy` read where needed, NetCDF read by hyperslabs); `render_volume` on such a volume goes to
//! the render session's one entry point like every other render (see `render::route`).

use super::api_render::{blank, render_and_note, render_options, ScriptImage, BRICK_EDGE};
use super::convert::{to_rhai, variable_option, RResult};
use super::options::{opt, Kind, OptionTable};
use super::ScriptHost;
use crate::model::bricks::{BrickedVolume, DEFAULT_BRICK};
use crate::render::VolumeSource;
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

/// A volume opened as bricks (`open_volume`).
pub(crate) type ScriptBricked = Arc<BrickedVolume>;

pub(crate) const OPEN_VOLUME: OptionTable = OptionTable {
    function: "open_volume",
    options: &[
        opt(
            "variable",
            Kind::Text("\"fluctuation\""),
            "the file's first 3-D variable",
            "the array or variable to read",
        ),
        opt(
            "brick",
            BRICK_EDGE,
            "32",
            "brick edge in voxels: 8, 16, 32, 64 or 128",
        ),
        super::api_datasets::SELECT_INDEX,
        super::api_datasets::SELECT_AT,
    ],
    call: "open_volume(generate(\"mantle\", #{ n: 4 }), OPTS)",
    base: "#{}",
};

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
            let given = OPEN_VOLUME.read(&opts)?;
            let (p, from_path) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
            let variable = variable_option(given.string("variable")?, from_path, "open_volume")?;
            let brick = given.count("brick")?.unwrap_or(DEFAULT_BRICK);
            let sel = super::api_datasets::selection(&given)?;
            Ok(Arc::new(
                crate::datasets::bricked::open_bricked_with(&p, variable.as_deref(), &sel, brick)
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
            if h.plan_only {
                return Ok(blank(o.width, o.height));
            }
            render_and_note(&h, &source, &o)
        },
    );
}
