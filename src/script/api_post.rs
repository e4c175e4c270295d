//! Script API: post-processing of HDR images — `load_image`, `exposure`, `bracket`, `tonemap`,
//! `false_colour` — without re-rendering: each works on an image value a script already holds
//! (a render or a loaded EXR). Tone mapping runs on the GPU of the script's context, shared with
//! the volume renderer. Tone-mapped and false-colour images are marked `display_referred = 1`;
//! `save_png` (registered with the render API) writes those with the sRGB curve only.

use super::api_render::ScriptImage;
use super::convert::{err, num, pair, to_rhai, RResult};
use super::options::{opt, Kind, OptionTable};
use super::ScriptHost;
use crate::tonemap::{Gamut, Operator, ToneMapSettings, MAX_EV};
use rhai::{Array, Dynamic, Engine, Map};
use std::sync::Arc;

/// Options of `tonemap(image, #{...})`: the settings shared by every operator, then every
/// operator parameter (each operator accepts its own, see [`Operator::param_names`]). A
/// parameter's range depends on its operator (and, for ward's ld_max, on another parameter), so
/// the table checks only that it is a finite number and [`Operator::validate`] the range.
pub(crate) const TONEMAP: OptionTable = OptionTable {
    function: "tonemap",
    options: &[
        opt("op", Kind::Choice(&Operator::NAMES), "\"reinhard\"", "the operator"),
        opt("exposure", Kind::Num(-MAX_EV, MAX_EV), "0", "stops: scene values times 2^exposure before the operator"),
        opt("saturation", Kind::Num(0.0, 10.0), "1", "colour saturation s in (C / L)^s L_d; 1 keeps the scene's chromaticity"),
        opt("gamma", Kind::Num(0.1, 10.0), "1", "display gamma, v^(1/gamma) after the offset"),
        opt("offset", Kind::Num(-1.0, 1.0), "0", "added to display values before clamping"),
        opt("gamut", Kind::Choice(Gamut::NAMES), "\"scale\"", "how colours above 1 come into range: scale keeps the hue, clip clips each channel"),
        opt("key", Kind::Finite, "0.18", "reinhard, reinhard-local: the key (middle grey)"),
        opt("white", Kind::Finite, "the largest scaled luminance", "reinhard: L_white"),
        opt("bias", Kind::Finite, "0.85", "drago: the bias b"),
        opt("ld_min", Kind::Finite, "1", "ward: display minimum luminance, cd/m²"),
        opt("ld_max", Kind::Finite, "100", "drago, ward: display maximum luminance, cd/m²"),
        opt("bins", Kind::Finite, "100", "ward: histogram bins (a whole number)"),
        opt("alpha1", Kind::Finite, "0.35", "reinhard-local: the centre's scale, px"),
        opt("ratio", Kind::Finite, "1.6", "reinhard-local: ratio of successive scales"),
        opt("phi", Kind::Finite, "8", "reinhard-local: sharpening"),
        opt("epsilon", Kind::Finite, "0.05", "reinhard-local: threshold of the scale choice"),
        opt("scales", Kind::Finite, "8", "reinhard-local: number of scales (a whole number)"),
        opt("contrast", Kind::Finite, "5", "durand: target contrast of the base layer"),
        opt("sigma_spatial", Kind::Finite, "0.02", "durand: spatial sigma, fraction of the larger image side"),
        opt("sigma_range", Kind::Finite, "0.4", "durand: range sigma, log10 luminance"),
    ],
    // Seven lit pixels: with fewer, the f64 operators map the scene to exactly 0 and 1 and
    // exposure, key and gamma cannot show.
    call: "tonemap(exposure(render_volume(generate_mantle(#{ n: 8 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 8, height: 8 }), 0.0), OPTS)",
    base: "#{}",
};

/// Options of `false_colour(image, #{...})`.
pub(crate) const FALSE_COLOUR: OptionTable = OptionTable {
    function: "false_colour",
    options: &[
        opt("domain", Kind::Value("[lo, hi]", "[0.001, 10.0]"), "the image's whole decades", "the luminances turbo spans, lo > 0 (on a log10 scale): one colour per value across a sweep or movie; values beyond take the end colours"),
    ],
    call: "false_colour(exposure(render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4 }), 0.0), OPTS)",
    base: "#{}",
};

/// The decades `false_colour`'s options choose (none: the image's own).
fn false_colour_decades(opts: &Map) -> RResult<Option<(f64, f64)>> {
    let given = FALSE_COLOUR.read(opts)?;
    let Some(d) = given.value("domain")? else {
        return Ok(None);
    };
    let [lo, hi] = pair(d, "false_colour.domain")?;
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return err(
            "false_colour.domain",
            format!("[{lo}, {hi}]; expected luminances 0 < lo < hi"),
        );
    }
    Ok(Some((lo.log10(), hi.log10())))
}

/// Builds tone-mapping settings from a script's option map (defaults: Reinhard global, 0 EV).
pub(crate) fn settings_from_map(opts: &Map) -> RResult<ToneMapSettings> {
    let given = TONEMAP.read(opts)?;
    let mut s = ToneMapSettings::default();
    s.exposure_ev = given.num("exposure")?.unwrap_or(s.exposure_ev);
    s.saturation = given.num("saturation")?.unwrap_or(s.saturation);
    s.gamma = given.num("gamma")?.unwrap_or(s.gamma);
    s.offset = given.num("offset")?.unwrap_or(s.offset);
    if let Some(g) = given.string("gamut")? {
        s.gamut = Gamut::parse(&g).map_err(to_rhai)?;
    }
    let op_name = given.string("op")?.unwrap_or_else(|| "reinhard".into());
    // The operator parameters, in the script's order (the operator refuses another's).
    let mut params: Vec<(&str, f64)> = Vec::new();
    for key in opts.keys().map(|k| k.as_str()) {
        if Operator::is_param(key) {
            if let Some(v) = given.num(key)? {
                params.push((key, v));
            }
        }
    }
    s.op = Operator::parse(&op_name, &params).map_err(to_rhai)?;
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
        if h.plan_only {
            return Ok(planned_display_image(img));
        }
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
    let false_colour = move |img: &mut ScriptImage, opts: &Map| -> RResult<ScriptImage> {
        let decades = false_colour_decades(opts)?;
        if h.plan_only {
            return Ok(planned_display_image(img));
        }
        h.session.false_colour(img, decades).map_err(to_rhai)
    };
    let false_colour2 = false_colour.clone();
    engine.register_fn(
        "false_colour",
        move |img: &mut ScriptImage| -> RResult<ScriptImage> { false_colour2(img, &Map::new()) },
    );
    engine.register_fn(
        "false_colour",
        move |img: &mut ScriptImage, opts: Map| -> RResult<ScriptImage> {
            false_colour(img, &opts)
        },
    );
}

/// A planning run's tone-mapped image: the input marked display-referred, as the real one is.
fn planned_display_image(img: &ScriptImage) -> ScriptImage {
    let mut out = (**img).clone();
    out.set_meta(crate::tonemap::DISPLAY_REFERRED, "1");
    Arc::new(out)
}
