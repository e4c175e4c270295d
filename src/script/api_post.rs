//! Script API: post-processing of HDR images — `load_image`, `exposure`, `bracket`, `tonemap`,
//! `false_colour` — without re-rendering: each works on an image value a script already holds
//! (a render or a loaded EXR). Tone mapping runs on the GPU of the script's context, shared with
//! the volume renderer. Tone-mapped and false-colour images are marked `display_referred = 1`;
//! `save_png` (registered with the render API) writes those with the sRGB curve only.

use super::api_render::ScriptImage;
use super::convert::{check_keys, err, num, string, to_rhai, RResult};
use super::ScriptHost;
use crate::tonemap::{Gamut, Operator, ToneMapSettings};
use rhai::{Array, Dynamic, Engine, Map};
use std::sync::Arc;

/// Options of `tonemap(image, #{...})`: the settings shared by every operator, then every
/// operator parameter (each operator accepts its own, see [`Operator::param_names`]).
const TONEMAP_KEYS: &[&str] = &[
    "op",
    "exposure",
    "saturation",
    "gamma",
    "offset",
    "gamut",
    "key",
    "white",
    "bias",
    "ld_min",
    "ld_max",
    "bins",
    "alpha1",
    "ratio",
    "phi",
    "epsilon",
    "scales",
    "contrast",
    "sigma_spatial",
    "sigma_range",
];

/// Builds tone-mapping settings from a script's option map (defaults: Reinhard global, 0 EV).
pub(crate) fn settings_from_map(opts: &Map) -> RResult<ToneMapSettings> {
    check_keys(opts, TONEMAP_KEYS, "tonemap")?;
    let mut s = ToneMapSettings::default();
    let mut op_name = "reinhard".to_string();
    let mut params: Vec<(String, f64)> = Vec::new();
    for (k, v) in opts {
        match k.as_str() {
            "op" => op_name = string(v, "op")?,
            "exposure" => s.exposure_ev = num(v, "exposure")?,
            "saturation" => s.saturation = num(v, "saturation")?,
            "gamma" => s.gamma = num(v, "gamma")?,
            "offset" => s.offset = num(v, "offset")?,
            "gamut" => s.gamut = Gamut::parse(&string(v, "gamut")?).map_err(to_rhai)?,
            other => params.push((other.to_string(), num(v, other)?)),
        }
    }
    let borrowed: Vec<(&str, f64)> = params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    s.op = Operator::parse(&op_name, &borrowed).map_err(to_rhai)?;
    s.validate().map_err(to_rhai)?;
    Ok(s)
}

pub(crate) fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn("load_image", move |path: &str| -> RResult<ScriptImage> {
        let p = h.sandbox.read_path(path).map_err(to_rhai)?;
        let img = h.session.load_image(&p).map_err(to_rhai)?;
        h.note_image(&img);
        Ok(img)
    });

    let h = host.clone();
    engine.register_fn(
        "exposure",
        move |img: &mut ScriptImage, ev: Dynamic| -> RResult<ScriptImage> {
            let ev = num(&ev, "exposure")?;
            h.session.exposure(img, ev).map_err(to_rhai)
        },
    );

    let h = host.clone();
    engine.register_fn(
        "bracket",
        move |img: &mut ScriptImage, evs: Array| -> RResult<Array> {
            let evs = evs
                .iter()
                .map(|v| num(v, "bracket"))
                .collect::<RResult<Vec<f64>>>()?;
            crate::tonemap::check_bracket(&evs).map_err(to_rhai)?;
            evs.iter()
                .map(|&ev| {
                    h.session
                        .exposure(img, ev)
                        .map(Dynamic::from)
                        .map_err(to_rhai)
                })
                .collect()
        },
    );

    let h = host.clone();
    let tonemap = move |img: &ScriptImage, opts: &Map| -> RResult<ScriptImage> {
        if crate::tonemap::is_display_referred(img) {
            return err(
                "tonemap",
                "this image is already display-referred (tone-mapped); tone-map the HDR image",
            );
        }
        let settings = settings_from_map(opts)?;
        h.session.tonemap(img, &settings).map_err(to_rhai)
    };
    let tonemap2 = tonemap.clone();
    engine.register_fn(
        "tonemap",
        move |img: &mut ScriptImage, opts: Map| -> RResult<ScriptImage> { tonemap2(img, &opts) },
    );
    engine.register_fn(
        "tonemap",
        move |img: &mut ScriptImage, op: &str| -> RResult<ScriptImage> {
            let mut opts = Map::new();
            opts.insert("op".into(), op.into());
            tonemap(img, &opts)
        },
    );

    let h = host;
    engine.register_fn(
        "false_colour",
        move |img: &mut ScriptImage| -> RResult<ScriptImage> {
            h.session.false_colour(img).map_err(to_rhai)
        },
    );
}
