//! Script API: what a run hands back — `save_exr`, `save_png`, `save_animation`, `preview`,
//! `already_done`, `progress` — and `param`, the values a run takes in (`--set name=value`). Outputs go only
//! under the output folder, and with `--resume` ones that exist are not written again.
//! `save_png` writes an HDR image exposed by 2^EV then sRGB, and a display-referred image
//! (`display_referred = 1`: tone-mapped, false colour) as it is; `save_png(img, path, #{legend:
//! true, exposure})` adds the colour bar the render recorded, with labelled ticks and units, and
//! `frame: true` draws a map-view surface with its coordinate axes, the colour bar and fringe
//! legend, a scale bar on lon/lat axes and an optional `title`, in type of `font_size`.

use super::api_render::ScriptImage;
use super::convert::{err, num, to_rhai, RResult};
use super::options::{opt, Kind, OptionTable};
use super::{ParamKind, ParamRecord, ScriptHost};
use crate::io::animation::RgbFrame;
use crate::io::exr::{ExrWrite, EXR_COMPRESSION_NAMES};
use crate::model::text::{TYPE_MAX, TYPE_MIN};
use crate::model::HdrImage;
use crate::tonemap::MAX_EV;
use rhai::{Array, Dynamic, Engine, Map};
use std::collections::HashMap;
use std::sync::Arc;

/// The output functions: saving images and telling the user how the run goes.
pub(crate) fn register_output(engine: &mut Engine, host: &Arc<ScriptHost>) {
    register_saves(engine, host);
    register_animation(engine, host);
    register_feedback(engine, host);
}

/// Keys of `save_exr(img, path, #{...})`.
pub(crate) const SAVE_EXR: OptionTable = OptionTable {
    function: "save_exr",
    options: &[
        opt("compression", Kind::Choice(&EXR_COMPRESSION_NAMES), "\"zip\"", "none, rle, zips, zip, piz: lossless; pxr24, b44, b44a: lossy (rle and none write fastest, zip smallest among the fast ones)"),
        opt("half", Kind::Bool, "false", "R, G, B, A as 16-bit half floats (11 significant bits: enough for a display image, not for data); extra channels stay 32-bit"),
    ],
    call: "save_exr(render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4 }), \"x.exr\", OPTS)",
    base: "#{}",
};

/// Keys of `save_png(img, path, #{...})`.
pub(crate) const SAVE_PNG: OptionTable = OptionTable {
    function: "save_png",
    options: &[
        opt("exposure", Kind::Num(-MAX_EV, MAX_EV), "0", "stops"),
        opt("legend", Kind::Bool, "false; true with frame", "the colour bar the render recorded, with labelled ticks and units: beneath the picture, or with frame beside the map together with the fringe legend (\"1 fringe = 0.25 m (ν = 4 per m)\")"),
        opt("frame", Kind::Bool, "false", "a map-view surface with lat/lon or x/y axes, the colour bar and fringe legend (unless legend: false) and, on lon/lat axes, a scale bar in km"),
        opt("title", Kind::Text("\"Uplift\""), "none", "with frame: a title above the map"),
        opt("font_size", Kind::Num(TYPE_MIN, TYPE_MAX), "2.8 % of the picture's shorter side, at least 11", "with legend or frame: the text's size in pixels per em"),
    ],
    call: "save_png(render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4 }), \"x.png\", OPTS)",
    base: "#{ frame: true }",
};

/// What `save_png` draws around the picture.
#[derive(Clone, PartialEq)]
enum PngDecoration {
    None,
    /// The recorded colour bar beneath (`legend: true`), in type of this size.
    Legend {
        font_size: Option<f64>,
    },
    /// Axes along the left and bottom, with the colour bar and fringe legend beside and under
    /// the map when `legend`, and a title (`frame: true`).
    Frame {
        legend: bool,
        title: Option<String>,
        font_size: Option<f64>,
    },
}

impl PngDecoration {
    /// The decoration `save_png`'s options ask for; options that would draw nothing are
    /// refused.
    fn of(given: &super::options::Given) -> RResult<PngDecoration> {
        let font_size = given.num("font_size")?;
        let title = given.string("title")?;
        let legend = given.bool("legend")?;
        if given.bool("frame")? == Some(true) {
            return Ok(PngDecoration::Frame {
                legend: legend.unwrap_or(true),
                title,
                font_size,
            });
        }
        if title.is_some() {
            return err("title", "a title is drawn on framed maps: add frame: true");
        }
        if legend == Some(true) {
            return Ok(PngDecoration::Legend { font_size });
        }
        if font_size.is_some() {
            return err(
                "font_size",
                "no text is drawn without legend: true or frame: true",
            );
        }
        Ok(PngDecoration::None)
    }
}

/// The fringe legend a render records ("1 fringe = 0.25 m (ν = 4 per m)"), for modes that draw
/// fringes.
fn fringe_note(img: &HdrImage) -> Option<String> {
    use crate::model::text::typeset_number;
    let nu: f64 = img.meta("nu")?.parse().ok()?;
    if img.meta("mode")? == "direct" {
        return None;
    }
    let units = img.meta("legend_units").unwrap_or("");
    let per = if units.is_empty() { "data unit" } else { units };
    Some(format!(
        "{} (ν = {} per {per})",
        crate::render::surface::resolution_label(nu, units),
        typeset_number(nu)
    ))
}

/// The picture `save_png` writes for `decoration`: the image (exposed by 2^`ev` unless
/// display-referred) with the colour bar beneath or in a frame with axes; `None` to write the
/// image as it is. An image without what the decoration needs is a one-line error.
fn decorated(
    img: &HdrImage,
    ev: f64,
    display: bool,
    decoration: &PngDecoration,
) -> crate::Result<Option<HdrImage>> {
    use crate::model::map_frame::{with_map_frame, FrameExtras, MapAxes};
    use crate::model::text::{with_colour_bar, ColourBar, Type};
    let bar = ColourBar::of(img);
    let type_of =
        |size: Option<f64>| size.map_or(Type::for_figure(img.width, img.height), Type::new);
    let view = || -> crate::Result<HdrImage> {
        if display {
            Ok(img.clone())
        } else {
            crate::tonemap::exposure(img, ev)
        }
    };
    match decoration {
        PngDecoration::None => Ok(None),
        PngDecoration::Legend { font_size } => {
            let bar = bar.ok_or_else(|| crate::Error::invalid(
                "legend",
                "this image records no colour bar (render_surface and render_volume with a tf_lut transfer function do)",
            ))?;
            Ok(Some(with_colour_bar(&view()?, &bar, type_of(*font_size))?))
        }
        PngDecoration::Frame {
            legend,
            title,
            font_size,
        } => {
            // A map in a projection is framed without ticks (it has no straight axes).
            let axes = MapAxes::of(img);
            if axes.is_none() && img.meta("map_projection").is_none() {
                return Err(crate::Error::invalid(
                    "frame",
                    "this image records no map axes or projection (render_surface in map view does)",
                ));
            }
            let extras = FrameExtras {
                ty: type_of(*font_size),
                title: title.as_deref(),
                bar: bar.as_ref().filter(|_| *legend),
                notes: fringe_note(img).filter(|_| *legend).into_iter().collect(),
                scale_bar: true,
                graticule: img
                    .meta("graticule")
                    .and_then(|g| g.strip_prefix("every "))
                    .and_then(|g| g.split_whitespace().next())
                    .and_then(|g| g.parse().ok()),
            };
            Ok(Some(with_map_frame(&view()?, axes.as_ref(), &extras)?))
        }
    }
}

/// `save_exr` and `save_png` (with and without an exposure or options).
fn register_saves(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    let save_exr = move |img: &mut ScriptImage, path: &str, how: &ExrWrite| -> RResult<()> {
        let p = h.sandbox.write_path(path).map_err(to_rhai)?;
        h.note_image(img);
        if h.planned(&p) || h.already_done(&p) || !h.write_outputs {
            return Ok(());
        }
        let t = std::time::Instant::now();
        h.write_output(&p, |p| crate::io::exr::write_exr_with(img, p, how))
            .map_err(to_rhai)?;
        h.session
            .record_sink("save-exr", t.elapsed().as_secs_f64() * 1e3);
        Ok(())
    };
    let plain = save_exr.clone();
    engine.register_fn("save_exr", move |img: &mut ScriptImage, path: &str| {
        plain(img, path, &ExrWrite::default())
    });
    engine.register_fn(
        "save_exr",
        move |img: &mut ScriptImage, path: &str, opts: rhai::Map| -> RResult<()> {
            let given = SAVE_EXR.read(&opts)?;
            let mut how = ExrWrite::default();
            if let Some(name) = given.string("compression")? {
                how.compression = ExrWrite::compression_named(&name).map_err(to_rhai)?;
            }
            how.half = given.bool("half")?.unwrap_or(false);
            save_exr(img, path, &how)
        },
    );
    let h = host.clone();
    // A display-referred image (tone-mapped or false colour, metadata `display_referred = 1`)
    // already holds display values: it is written with the sRGB curve only, and asking for an
    // exposure on it is an error (expose the HDR image before tone mapping instead).
    let save_png = move |img: &mut ScriptImage,
                         path: &str,
                         ev: f64,
                         decoration: &PngDecoration|
          -> RResult<()> {
        let display = crate::tonemap::is_display_referred(img);
        if display && ev != 0.0 {
            return err(
                "save_png",
                format!("exposure {ev} given for a tone-mapped (display-referred) image; apply exposure to the HDR image, or in tonemap(image, #{{exposure: {ev}}})"),
            );
        }
        let p = h.sandbox.write_path(path).map_err(to_rhai)?;
        if h.planned(&p) || h.already_done(&p) || !h.write_outputs {
            return Ok(());
        }
        let t = std::time::Instant::now();
        let picture = decorated(img, ev, display, decoration).map_err(to_rhai)?;
        h.write_output(&p, |p| match &picture {
            Some(picture) => crate::io::png::write_display_png(picture, p, false),
            None if display => crate::io::png::write_display_png(img, p, false),
            None => crate::io::png::write_exposed_png(img, p, ev),
        })
        .map_err(to_rhai)?;
        h.session
            .record_sink("save-png", t.elapsed().as_secs_f64() * 1e3);
        Ok(())
    };
    let save_png2 = save_png.clone();
    engine.register_fn("save_png", move |img: &mut ScriptImage, path: &str| {
        save_png2(img, path, 0.0, &PngDecoration::None)
    });
    engine.register_fn(
        "save_png",
        move |img: &mut ScriptImage, path: &str, ev: Dynamic| -> RResult<()> {
            // An exposure in stops, or a map #{exposure, legend, frame}.
            if let Some(opts) = ev.clone().try_cast::<rhai::Map>() {
                let given = SAVE_PNG.read(&opts)?;
                let exposure = given.num("exposure")?.unwrap_or(0.0);
                let decoration = PngDecoration::of(&given)?;
                return save_png(img, path, exposure, &decoration);
            }
            save_png(img, path, num(&ev, "exposure")?, &PngDecoration::None)
        },
    );
}

pub(crate) const SAVE_ANIMATION: OptionTable = OptionTable {
    function: "save_animation",
    options: &[
        opt("fps", Kind::Num(0.1, 1000.0), "12", "frames per second"),
        opt("exposure", Kind::Num(-MAX_EV, MAX_EV), "0", "stops, for HDR images"),
    ],
    call: "save_animation([render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4 })], \"x.gif\", OPTS)",
    base: "#{}",
};

/// `save_animation(frames, path[, #{fps, exposure}])`: images, or PNG files under the output
/// folder, as one movie (see `io::animation`); frames are converted one at a time as the encoder
/// takes them.
fn register_animation(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    let save = move |frames: Array, path: &str, opts: &Map| -> RResult<()> {
        let given = SAVE_ANIMATION.read(opts)?;
        let fps = given.num("fps")?.unwrap_or(12.0);
        let ev = given.num("exposure")?.unwrap_or(0.0);
        let p = h.sandbox.write_path(path).map_err(to_rhai)?;
        crate::io::animation::MovieFormat::of(&p).map_err(to_rhai)?;
        if h.planned(&p) || h.already_done(&p) || !h.write_outputs {
            return Ok(());
        }
        let t = std::time::Instant::now();
        let frame =
            |i: usize| -> crate::Result<RgbFrame> { animation_frame(&h, &frames[i], i, ev) };
        h.write_output(&p, |p| {
            crate::io::animation::write_animation(p, frames.len(), fps, frame)
        })
        .map_err(to_rhai)?;
        h.session
            .record_sink("save-animation", t.elapsed().as_secs_f64() * 1e3);
        Ok(())
    };
    let save2 = save.clone();
    engine.register_fn("save_animation", move |frames: Array, path: &str| {
        save2(frames, path, &Map::new())
    });
    engine.register_fn(
        "save_animation",
        move |frames: Array, path: &str, opts: Map| save(frames, path, &opts),
    );
}

/// Frame `i` of `save_animation`: an image exposed by 2^`ev` (a display-referred one as it is),
/// or a PNG file named relative to the output folder, as `save_png` names them.
fn animation_frame(h: &ScriptHost, item: &Dynamic, i: usize, ev: f64) -> crate::Result<RgbFrame> {
    let field = format!("frames[{i}]");
    if let Some(img) = item.clone().try_cast::<ScriptImage>() {
        if crate::tonemap::is_display_referred(&img) && ev != 0.0 {
            return Err(crate::Error::invalid(
                field,
                format!("exposure {ev} given for a tone-mapped (display-referred) image"),
            ));
        }
        let view = crate::io::png::exposed(&img, ev)?;
        return Ok(RgbFrame {
            width: view.width,
            height: view.height,
            rgb: view.to_srgb8().into_flattened(),
        });
    }
    match item.clone().into_immutable_string() {
        Ok(name) => {
            let p = h.sandbox.write_path(&name)?;
            crate::io::animation::read_png_frame(&p)
        }
        Err(found) => Err(crate::Error::invalid(
            field,
            format!("expected an Image or the path of a PNG under the output folder, got {found}"),
        )),
    }
}

/// `preview`, `already_done` and `progress` (with and without a label).
fn register_feedback(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn("preview", move |img: &mut ScriptImage| -> RResult<()> {
        if h.plan_only {
            return Ok(());
        }
        if h.capture_previews {
            h.previews
                .lock()
                .expect("previews poisoned")
                .push(img.clone());
            return Ok(());
        }
        preview(img).map_err(to_rhai)
    });

    let h = host.clone();
    engine.register_fn("already_done", move |path: &str| -> RResult<bool> {
        Ok(h.already_done(&h.sandbox.write_path(path).map_err(to_rhai)?))
    });
    let h = host.clone();
    engine.register_fn("progress", move |done: i64, total: i64| {
        h.progress(done.max(0) as u64, total.max(0) as u64, "")
    });
    let h = host.clone();
    engine.register_fn("progress", move |done: i64, total: i64, label: &str| {
        h.progress(done.max(0) as u64, total.max(0) as u64, label)
    });
}

/// `param(name, default)`: the `--set` value of `name`, or the default; every call is noted.
pub(crate) fn register_params(engine: &mut Engine, h: Arc<ScriptHost>) {
    engine.register_fn(
        "param",
        move |name: &str, default: Dynamic| -> RResult<Dynamic> {
            let value = param_value(&h.sets, name, &default)?;
            let kind = if default.is_int() {
                ParamKind::Int
            } else if default.is_float() {
                ParamKind::Float
            } else if default.is_bool() {
                ParamKind::Bool
            } else {
                ParamKind::Text
            };
            h.note_param(ParamRecord {
                name: name.to_string(),
                kind,
                default: default.to_string(),
                value: value.to_string(),
            });
            Ok(value)
        },
    );
}

/// The value `param(name, default)` returns: the `--set` override parsed as the default's type,
/// or the default.
fn param_value(sets: &HashMap<String, String>, name: &str, default: &Dynamic) -> RResult<Dynamic> {
    let default = default.clone();
    let Some(text) = sets.get(name) else {
        return Ok(default);
    };
    let bad = |what: &str| {
        err::<Dynamic>(
            &format!("--set {name}"),
            format!("expected {what} (the type of the default), got {text:?}"),
        )
    };
    if default.is_int() {
        text.trim()
            .parse::<i64>()
            .map(Dynamic::from)
            .or_else(|_| bad("an integer"))
    } else if default.is_float() {
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .map(Dynamic::from)
            .map_or_else(|| bad("a finite number"), Ok)
    } else if default.is_bool() {
        text.trim()
            .parse::<bool>()
            .map(Dynamic::from)
            .or_else(|_| bad("true or false"))
    } else {
        Ok(Dynamic::from(text.clone()))
    }
}

/// Shows an image inline when stdout is a terminal (kitty, iTerm2 or sixel where the terminal
/// speaks them, else half blocks); a no-op otherwise, so scripts can call it in batch runs.
/// An empty image shows nothing.
pub(crate) fn preview(img: &HdrImage) -> crate::Result<()> {
    use crate::io::terminal::{print_hdr_inline, ProtocolChoice};
    if img.width == 0 || img.height == 0 {
        return Ok(());
    }
    print_hdr_inline(img, ProtocolChoice::Auto, 60, "preview").map(|_| ())
}
