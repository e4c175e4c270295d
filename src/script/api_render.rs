//! Script API: datasets, transfer functions, cameras and volume rendering. Names fixed by the
//! issues: `load_volume`, `tf_emission_absorption`, `camera_axis`, `render_volume`. Saving,
//! previews, progress and `param` live in `api_output`.

use super::convert::{
    boolean, check_keys, err, int, num, points, string, to_rhai, variable_option, vec3, RResult,
};
use super::ScriptHost;
use crate::datasets::LoadOptions;
use crate::model::{
    Aabb, Axis, Camera, Geometry, HdrImage, Lens, LutTransfer, Scale, TransferFunction, Volume,
    VolumeStats,
};
use crate::render::{
    Bricking, FilterMode, Precision, Shading, TfSampling, VolumeRenderOptions, VolumeSource,
};
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

/// A camera as scripts describe it; views that frame "the volume" are fixed at render time.
#[derive(Clone, Debug)]
pub(crate) enum ScriptCamera {
    Axis(Axis),
    Orbit {
        azimuth: f64,
        elevation: f64,
        fov: f64,
    },
    /// Above a latitude and longitude, at a distance in outer radii of the volume's shell.
    Geo {
        lat: f64,
        lon: f64,
        distance: f64,
        fov: f64,
    },
    Fixed(Camera),
}

impl ScriptCamera {
    /// The camera for `source`.
    pub(crate) fn resolve(&self, source: &VolumeSource) -> crate::Result<Camera> {
        let bounds = source.bounds();
        // A shell's centre is the planet's; a box's its middle.
        let sphere = match source {
            VolumeSource::Memory(v) => match &v.geometry {
                Geometry::Spherical(g) => ([0.0; 3], g.outer_radius()),
                _ => (bounds.center(), 0.5 * bounds.diagonal()),
            },
            VolumeSource::Bricked(_) => (bounds.center(), 0.5 * bounds.diagonal()),
        };
        self.resolve_in(&bounds, sphere)
    }

    /// The camera for a scene with these bounds, `camera_geo` counting from the centre and in
    /// units of the radius of `sphere`.
    pub(crate) fn resolve_in(
        &self,
        bounds: &Aabb,
        sphere: ([f64; 3], f64),
    ) -> crate::Result<Camera> {
        match self {
            ScriptCamera::Geo {
                lat,
                lon,
                distance,
                fov,
            } => Camera::geo(sphere.0, *lat, *lon, distance * sphere.1, *fov),
            ScriptCamera::Axis(a) => Ok(Camera::axis(*a, bounds)),
            ScriptCamera::Orbit {
                azimuth,
                elevation,
                fov,
            } => Camera::orbit(bounds, *azimuth, *elevation, *fov),
            ScriptCamera::Fixed(c) => Ok(*c),
        }
    }
}

pub(crate) type ScriptVolume = Arc<Volume>;
pub(crate) type ScriptImage = Arc<HdrImage>;

const RENDER_KEYS: &[&str] = &[
    "tf",
    "camera",
    "width",
    "height",
    "step",
    "jitter",
    "seed",
    "early_exit",
    "background",
    "filter",
    "precision",
    "shading",
    "tf_sampling",
    "empty_space_skipping",
];
const SHADING_KEYS: &[&str] = &["ambient", "diffuse", "specular", "shininess"];
const LUT_KEYS: &[&str] = &[
    "scale",
    "linthresh",
    "domain",
    "lens",
    "colormap",
    "emission",
    "opacity",
    "transparent_below",
];

pub(crate) fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
    register_types(engine);
    register_volumes(engine, &host);
    register_transfer_functions(engine);
    register_cameras(engine);
    register_render(engine, &host);
}

/// The script-visible types and their read-only properties.
fn register_types(engine: &mut Engine) {
    engine
        .register_type_with_name::<ScriptVolume>("Volume")
        .register_type_with_name::<TransferFunction>("TransferFunction")
        .register_type_with_name::<ScriptCamera>("Camera")
        .register_type_with_name::<ScriptImage>("Image");

    engine.register_get("name", |v: &mut ScriptVolume| v.name.clone());
    engine.register_get("dims", |v: &mut ScriptVolume| -> rhai::Array {
        v.dims.iter().map(|&d| Dynamic::from(d as i64)).collect()
    });
    engine.register_get("geometry", |v: &mut ScriptVolume| {
        v.geometry.name().to_string()
    });
    engine.register_fn("to_string", |v: &mut ScriptVolume| v.to_string());
    engine.register_fn("to_debug", |v: &mut ScriptVolume| v.to_string());
    engine.register_get("width", |i: &mut ScriptImage| i.width as i64);
    engine.register_get("height", |i: &mut ScriptImage| i.height as i64);
}

/// `load_volume`, `generate_mantle` and `volume_stats`.
fn register_volumes(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn("load_volume", move |path: &str| -> RResult<ScriptVolume> {
        let (p, variable) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
        let opts = LoadOptions {
            variable,
            ..LoadOptions::default()
        };
        h.session.load_volume(&p, &opts).map_err(to_rhai)
    });
    let h = host.clone();
    engine.register_fn(
        "load_volume",
        move |path: &str, opts: Map| -> RResult<ScriptVolume> {
            check_keys(
                &opts,
                &["variable", "geometry", "planet_radius"],
                "load_volume",
            )?;
            let (p, from_path) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
            let load = LoadOptions {
                variable: variable_option(&opts, from_path, "load_volume")?,
                cartesian: match opts
                    .get("geometry")
                    .map(|g| string(g, "geometry"))
                    .transpose()?
                {
                    None => false,
                    Some(g) if g == "cartesian" => true,
                    Some(g) if g == "auto" => false,
                    Some(g) => {
                        return err(
                            "geometry",
                            format!("expected \"auto\" or \"cartesian\", got {g:?}"),
                        )
                    }
                },
                planet_radius: opts
                    .get("planet_radius")
                    .map(|r| num(r, "planet_radius"))
                    .transpose()?,
            };
            h.session.load_volume(&p, &load).map_err(to_rhai)
        },
    );

    let h = host.clone();
    engine.register_fn(
        "generate_mantle",
        move |opts: Map| -> RResult<ScriptVolume> {
            let (o, field) = super::api_datasets::mantle_options(&opts, "generate_mantle")?;
            // Generation takes seconds at 256³; a re-run of the script (TUI, sweep) reuses it.
            h.session
                .generated_volume(&("mantle", &o, field.name()), || {
                    let m = crate::datasets::mantle::generate(&o, &mut |_| {})?;
                    let n = m.n;
                    let data = m.field(field).map(|d| d.to_vec()).unwrap_or_default();
                    let mut v = Volume::new(
                        format!("mantle-{} n={n} seed={}", field.name(), o.seed),
                        [n; 3],
                        [2.0 / n as f64; 3],
                        [-1.0; 3],
                        data,
                    )?;
                    v.units = "non-dimensional".into();
                    Ok(v)
                })
                .map_err(to_rhai)
        },
    );

    engine.register_fn("volume_stats", |v: &mut ScriptVolume| -> Map {
        stats_map(&v.stats())
    });
}

/// `tf_emission_absorption` and `tf_lut`.
fn register_transfer_functions(engine: &mut Engine) {
    engine.register_fn(
        "tf_emission_absorption",
        |e: Dynamic, a: Dynamic| -> RResult<TransferFunction> {
            TransferFunction::emission_absorption(num(&e, "emission")?, num(&a, "absorption")?)
                .map_err(to_rhai)
        },
    );
    engine.register_fn("tf_lut", tf_lut);
}

/// `tf_lut(#{...})`: a colour-map transfer function from the keys in [`LUT_KEYS`].
fn tf_lut(opts: Map) -> RResult<TransferFunction> {
    check_keys(&opts, LUT_KEYS, "tf_lut")?;
    let mut l = LutTransfer::default();
    let mut scale = "linear".to_string();
    let mut linthresh = None;
    for (k, v) in &opts {
        match k.as_str() {
            "scale" => scale = string(v, "scale")?,
            "linthresh" => linthresh = Some(num(v, "linthresh")?),
            "domain" => {
                let d = points(&Dynamic::from(vec![v.clone()]), "domain")?;
                l.domain = Some(d[0]);
            }
            "lens" => l.lens = Some(lens(v)?),
            "colormap" => l.colormap = string(v, "colormap")?,
            "emission" => l.emission = points(v, "emission")?,
            "opacity" => l.opacity = points(v, "opacity")?,
            "transparent_below" => l.transparent_below = num(v, "transparent_below")?,
            _ => unreachable!("checked keys"),
        }
    }
    l.scale = Scale::parse(&scale, linthresh).map_err(to_rhai)?;
    crate::model::colormap::Colormap::by_name(&l.colormap).map_err(to_rhai)?;
    Ok(TransferFunction::Lut(l))
}

/// The `lens` key of `tf_lut`: a map #{lo, hi, factor}, all required.
fn lens(v: &Dynamic) -> RResult<Lens> {
    let m = v.clone().try_cast::<Map>().ok_or_else(|| {
        to_rhai(crate::Error::invalid(
            "lens",
            "expected a map #{lo, hi, factor}",
        ))
    })?;
    check_keys(&m, &["lo", "hi", "factor"], "lens")?;
    let get = |key: &str| {
        m.get(key)
            .ok_or_else(|| to_rhai(crate::Error::invalid("lens", format!("missing {key}"))))
            .and_then(|x| num(x, key))
    };
    Ok(Lens {
        lo: get("lo")?,
        hi: get("hi")?,
        factor: get("factor")?,
    })
}

/// `camera_axis`, `camera_orbit` (with and without a field of view) and `camera_look_at`.
fn register_cameras(engine: &mut Engine) {
    engine.register_fn("camera_axis", |axis: &str| -> RResult<ScriptCamera> {
        Ok(ScriptCamera::Axis(Axis::parse(axis).map_err(to_rhai)?))
    });
    engine.register_fn(
        "camera_orbit",
        |az: Dynamic, el: Dynamic| -> RResult<ScriptCamera> {
            Ok(ScriptCamera::Orbit {
                azimuth: num(&az, "azimuth")?,
                elevation: num(&el, "elevation")?,
                fov: 35.0,
            })
        },
    );
    engine.register_fn(
        "camera_orbit",
        |az: Dynamic, el: Dynamic, fov: Dynamic| -> RResult<ScriptCamera> {
            Ok(ScriptCamera::Orbit {
                azimuth: num(&az, "azimuth")?,
                elevation: num(&el, "elevation")?,
                fov: num(&fov, "fov")?,
            })
        },
    );
    for with_fov in [false, true] {
        let geo = move |lat: Dynamic, lon: Dynamic, d: Dynamic, fov: Option<Dynamic>| {
            Ok(ScriptCamera::Geo {
                lat: num(&lat, "lat")?,
                lon: num(&lon, "lon")?,
                distance: num(&d, "distance")?,
                fov: fov.map(|f| num(&f, "fov")).transpose()?.unwrap_or(35.0),
            })
        };
        if with_fov {
            engine.register_fn(
                "camera_geo",
                move |lat: Dynamic,
                      lon: Dynamic,
                      d: Dynamic,
                      fov: Dynamic|
                      -> RResult<ScriptCamera> { geo(lat, lon, d, Some(fov)) },
            );
        } else {
            engine.register_fn(
                "camera_geo",
                move |lat: Dynamic, lon: Dynamic, d: Dynamic| -> RResult<ScriptCamera> {
                    geo(lat, lon, d, None)
                },
            );
        }
    }
    engine.register_fn(
        "camera_look_at",
        |eye: Dynamic, target: Dynamic, up: Dynamic, fov: Dynamic| -> RResult<ScriptCamera> {
            Ok(ScriptCamera::Fixed(
                Camera::look_at(
                    vec3(&eye, "eye")?,
                    vec3(&target, "target")?,
                    vec3(&up, "up")?,
                    num(&fov, "fov")?,
                )
                .map_err(to_rhai)?,
            ))
        },
    );
}

/// `render_volume(volume, #{...})`.
fn register_render(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn(
        "render_volume",
        move |volume: &mut ScriptVolume, opts: Map| -> RResult<ScriptImage> {
            let source = VolumeSource::Memory(volume.clone());
            let o = render_options(&h, &opts, &source)?;
            let img = render_and_note(&h, &source, &o)?;
            // The transfer function's colour bar, for save_png(img, path, #{legend: true}).
            Ok(match o.tf.colour_bar(&volume.stats(), &volume.units) {
                Some(bar) => {
                    let mut with_bar = (*img).clone();
                    bar.record(&mut with_bar);
                    Arc::new(with_bar)
                }
                None => img,
            })
        },
    );
}

/// `shading: true` (the default coefficients), `false`, or a map of coefficients.
fn shading(v: &Dynamic) -> RResult<Option<Shading>> {
    if v.is_bool() {
        return Ok(boolean(v, "shading")?.then(Shading::default));
    }
    let m = v.clone().try_cast::<Map>().ok_or_else(|| {
        to_rhai(crate::Error::invalid(
            "shading",
            "expected true, false or a map #{ambient, diffuse, specular, shininess}",
        ))
    })?;
    check_keys(&m, SHADING_KEYS, "shading")?;
    let mut s = Shading::default();
    for (k, x) in &m {
        let x = num(x, k)?;
        match k.as_str() {
            "ambient" => s.ambient = x,
            "diffuse" => s.diffuse = x,
            "specular" => s.specular = x,
            "shininess" => s.shininess = x,
            _ => unreachable!("checked keys"),
        }
    }
    s.validate().map_err(to_rhai)?;
    Ok(Some(s))
}

/// `volume_stats` as a script map.
pub(crate) fn stats_map(s: &VolumeStats) -> Map {
    let mut m = Map::new();
    m.insert("min".into(), Dynamic::from(s.min));
    m.insert("max".into(), Dynamic::from(s.max));
    m.insert(
        "min_positive".into(),
        s.min_positive.map(Dynamic::from).unwrap_or(Dynamic::UNIT),
    );
    m.insert("finite".into(), Dynamic::from(s.finite as i64));
    m.insert("missing".into(), Dynamic::from(s.non_finite as i64));
    m
}

/// Renders through the session's one entry point and notes the image as the run's latest.
pub(crate) fn render_and_note(
    host: &ScriptHost,
    source: &VolumeSource,
    o: &VolumeRenderOptions,
) -> RResult<ScriptImage> {
    let img = host.session.render_volume(source, o).map_err(to_rhai)?;
    host.note_image(&img);
    *host
        .last_volume_render
        .lock()
        .expect("last volume render poisoned") = Some(super::LastVolumeRender {
        source: source.clone(),
        options: o.clone(),
    });
    Ok(img)
}

/// The options map of `render_volume`, with the camera resolved for the source's bounds and the
/// run's default GPU memory budget (`hdrvis run --gpu-memory`) where the map gives none.
pub(crate) fn render_options(
    host: &ScriptHost,
    opts: &Map,
    source: &VolumeSource,
) -> RResult<VolumeRenderOptions> {
    let keys: Vec<&str> = RENDER_KEYS.iter().chain(BRICKING_KEYS).copied().collect();
    check_keys(opts, &keys, "render_volume")?;
    let tf = match opts.get("tf") {
        Some(v) => v.clone().try_cast::<TransferFunction>().ok_or_else(|| to_rhai(crate::Error::invalid("tf", "expected a TransferFunction (from tf_lut or tf_emission_absorption)")))?,
        None => return err("tf", "render_volume needs a transfer function: tf: tf_lut(#{...}) or tf_emission_absorption(e, a)"),
    };
    let camera = match opts.get("camera") {
        Some(v) => v.clone().try_cast::<ScriptCamera>().ok_or_else(|| {
            to_rhai(crate::Error::invalid(
                "camera",
                "expected a Camera (from camera_axis, camera_orbit or camera_look_at)",
            ))
        })?,
        None => ScriptCamera::Orbit {
            azimuth: 30.0,
            elevation: 25.0,
            fov: 35.0,
        },
    };
    let is_axis = matches!(camera, ScriptCamera::Axis(_));
    let camera = camera.resolve(source).map_err(to_rhai)?;
    let mut o = VolumeRenderOptions::new(camera, tf);
    for (k, v) in opts {
        if !take_bricking(&mut o.bricking, k.as_str(), v)? {
            take_render_option(&mut o, k.as_str(), v)?;
        }
    }
    if is_axis {
        // Square pixels: a missing side follows the box, a given size is letterboxed.
        let given = |key: &str, v: u32| opts.contains_key(key).then_some(v);
        let (w, h) = o.camera.square_pixel_size(
            given("width", o.width),
            given("height", o.height),
            AXIS_LONG_SIDE,
        );
        (o.width, o.height) = (w, h);
        o.camera = o.camera.letterboxed(w, h);
    }
    if o.bricking.memory_budget.is_none() {
        o.bricking.memory_budget = host.gpu_memory_mib.map(mib_to_bytes);
    }
    Ok(o)
}

/// Pixels on the longer side of an axis view given no width or height.
const AXIS_LONG_SIDE: u32 = 512;

/// Sets one of [`RENDER_KEYS`] (checked before).
fn take_render_option(o: &mut VolumeRenderOptions, key: &str, v: &Dynamic) -> RResult<()> {
    match key {
        "tf" | "camera" => {}
        "width" => o.width = int(v, "width")?.clamp(0, u32::MAX as i64) as u32,
        "height" => o.height = int(v, "height")?.clamp(0, u32::MAX as i64) as u32,
        "step" => o.step = num(v, "step")?,
        "jitter" => o.jitter = boolean(v, "jitter")?,
        "seed" => o.seed = int(v, "seed")? as u32,
        "early_exit" => o.early_exit = num(v, "early_exit")?,
        "background" => o.background = vec3(v, "background")?,
        "filter" => o.filter = FilterMode::parse(&string(v, "filter")?).map_err(to_rhai)?,
        "precision" => o.precision = Precision::parse(&string(v, "precision")?).map_err(to_rhai)?,
        "shading" => o.shading = shading(v)?,
        "tf_sampling" => {
            o.tf_sampling = TfSampling::parse(&string(v, "tf_sampling")?).map_err(to_rhai)?
        }
        "empty_space_skipping" => o.empty_space_skipping = boolean(v, "empty_space_skipping")?,
        _ => unreachable!("checked keys"),
    }
    Ok(())
}

/// The keys of `render_volume` for the bricked and out-of-core paths.
const BRICKING_KEYS: &[&str] = &["memory_budget", "brick", "level"];

fn mib_to_bytes(mib: f64) -> u64 {
    (mib * (1u64 << 20) as f64) as u64
}

/// Takes `key` if it is one of [`BRICKING_KEYS`]; false otherwise.
fn take_bricking(b: &mut Bricking, key: &str, v: &Dynamic) -> RResult<bool> {
    match key {
        "memory_budget" => {
            let m = num(v, "memory_budget")?;
            if !(m.is_finite() && m > 0.0) {
                return err("memory_budget", format!("expected MiB > 0, got {m}"));
            }
            b.memory_budget = Some(mib_to_bytes(m));
        }
        "brick" => b.brick = Some(int(v, "brick")?.clamp(0, 1 << 20) as usize),
        "level" => {
            let l = int(v, "level")?;
            let max = crate::render::route::MAX_LEVEL as i64;
            if !(0..=max).contains(&l) {
                return err(
                    "level",
                    format!("expected 0 (full resolution) to {max}, got {l}"),
                );
            }
            b.level = l as u32;
        }
        _ => return Ok(false),
    }
    Ok(true)
}
