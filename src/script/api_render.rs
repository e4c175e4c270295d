//! Script API: datasets, transfer functions, cameras and volume rendering. Names fixed by the
//! issues: `load_volume`, `tf_emission_absorption`, `camera_axis`, `render_volume`. Saving,
//! previews, progress and `param` live in `api_output`.

use super::convert::{err, num, pair, points, to_rhai, variable_option, vec3, RResult};
use super::options::{opt, Given, Kind, OptionTable};
use super::ScriptHost;
use crate::datasets::LoadOptions;
use crate::model::bricks::BRICK_SIZES;
use crate::model::{
    Aabb, Axis, Camera, Cut, CutFaces, CutPlane, Geometry, HdrImage, Lens, LutTransfer, Missing,
    Scale, TransferFunction, Volume, VolumeStats,
};
use crate::render::route::MAX_LEVEL;
use crate::render::{
    Bricking, FilterMode, Precision, Shading, TfSampling, VolumeRenderOptions, VolumeSource,
    MAX_IMAGE_SIDE,
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
        let camera = self.resolve_in(&bounds, sphere)?;
        // A rotated-pole volume lies in its grid's frame: views that frame it are made there,
        // cameras placed in the true frame (camera_geo, camera_look_at) turn into it.
        let pole = match source {
            VolumeSource::Memory(v) => match &v.geometry {
                Geometry::Spherical(g) => g.rotated_pole,
                _ => None,
            },
            VolumeSource::Bricked(_) => None,
        };
        Ok(match (self, pole) {
            (ScriptCamera::Geo { .. } | ScriptCamera::Fixed(_), Some(p)) => camera.turned(&p),
            _ => camera,
        })
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
            } => {
                // What is drawn lies in the box and within the sphere: about the box's centre,
                // no farther than the box's corners nor than the sphere's far side (a globe's
                // box circumscribes it by √3, and would leave it at 58 % of the frame).
                let c = bounds.center();
                let off = (0..3)
                    .map(|i| (c[i] - sphere.0[i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let radius = (0.5 * bounds.diagonal()).min(off + sphere.1);
                Camera::orbit_sphere(c, radius, *azimuth, *elevation, *fov)
            }
            ScriptCamera::Fixed(c) => Ok(*c),
        }
    }
}

pub(crate) type ScriptVolume = Arc<Volume>;
pub(crate) type ScriptImage = Arc<HdrImage>;

/// A brick edge as an option range (the bricking itself refuses edges other than its sizes).
pub(crate) const BRICK_EDGE: Kind = Kind::Int(
    BRICK_SIZES[0] as i64,
    BRICK_SIZES[BRICK_SIZES.len() - 1] as i64,
);

/// The image side limit as an option range.
const SIDE: Kind = Kind::Int(1, MAX_IMAGE_SIDE as i64);

pub(crate) const LOAD_VOLUME: OptionTable = OptionTable {
    function: "load_volume",
    options: &[
        opt("variable", Kind::Text("\"fluctuation\""), "the file's first 3-D variable", "the array or variable to read (an unknown one lists the file's)"),
        opt("geometry", Kind::Choice(&["auto", "cartesian"]), "\"auto\"", "auto: CF latitude, longitude and depth/radius/height make a spherical volume; cartesian: coordinates as box lengths"),
        opt("planet_radius", Kind::NumAbove(0.0, f64::INFINITY), "the file's, else 6371 km", "the planet's radius in the vertical axis's unit"),
        opt("vertical", Kind::Text("\"radius\""), "the vertical dimension's coordinate", "a NetCDF variable in m or km along one of the dimensions (a model level's height) placing the volume instead; pressure levels are otherwise placed at the 1976 standard atmosphere's heights, other levels (model levels) by index"),
        opt("resolution", Kind::NumAbove(0.0, 90.0), "the mesh's median cell size", "a variable on an unstructured mesh with one level dimension (ICON's S(depth, ncells)): the step in degrees of the latitude-longitude grid each level is sampled onto; the levels' depth, radius or height place it on the sphere"),
        opt("grid", Kind::Text("\"grid.nc\""), "the variable's own file", "an unstructured mesh kept in a file of its own (ICON and MPAS grid files, SCRIP)"),
        super::api_datasets::SELECT_INDEX,
        super::api_datasets::SELECT_AT,
    ],
    call: "load_volume(generate(\"mantle\", #{ n: 4, native: true }), OPTS)",
    base: "#{}",
};

pub(crate) const RENDER_VOLUME: OptionTable = OptionTable {
    function: "render_volume",
    options: &[
        opt("tf", Kind::Value("TransferFunction", "tf_emission_absorption(1.0, 1.0)"), "required", "from tf_lut, tf_preset or tf_emission_absorption"),
        opt("camera", Kind::Value("Camera", "camera_axis(\"z\")"), "camera_orbit(30, 25)", "from camera_axis, camera_orbit, camera_geo or camera_look_at"),
        opt("width", SIDE, "512", "pixels (an axis view given only one side keeps square pixels)"),
        opt("height", SIDE, "512", "pixels"),
        opt("step", Kind::Num(1e-4, 1e4), "1", "ray-march step in voxels"),
        opt("jitter", Kind::Bool, "false", "offset each ray's first sample randomly (hides wood-grain)"),
        opt("seed", Kind::Int(0, u32::MAX as i64), "0", "seed of the jitter (with jitter: true; refused without it)"),
        opt("early_exit", Kind::Num(0.0, 0.999_999), "0", "stop a ray once its transmittance falls below this (0: never)"),
        opt("background", Kind::Value("[r, g, b]", "[0.0, 0.0, 0.0]"), "[0, 0, 0]", "linear radiance behind the volume"),
        opt("filter", Kind::Choice(FilterMode::NAMES), "\"auto\"", "trilinear filtering: hardware where exact enough, exact in the shader otherwise"),
        opt("precision", Kind::Choice(Precision::NAMES), "\"f32\"", "compositing precision (f64 on the GPU where the adapter has shader f64, else the CPU)"),
        opt("shading", Kind::Value("true | false | #{ambient, diffuse, specular, shininess}", "true"), "false", "Blinn–Phong headlight on the data gradient (absent: no shading code; not on the bricked path)"),
        opt("tf_sampling", Kind::Choice(TfSampling::NAMES), "\"point\"", "preintegrated: the transfer function's mean between the values at each segment's ends (not on the bricked path)"),
        opt("cut", Kind::Value("#{lat, lon, depth} | #{x, y, z, plane}", "#{ lon: [0.0, 180.0] }"), "none", "a cut-away: the region where every given range holds is removed, rays clipped analytically (spherical volumes: lat, lon, depth; boxes: world x, y, z and planes; on the mapped GPU ray caster, whole in GPU memory; in f64 on the f64 CPU reference, a regular box's on the f64 GPU shader where it runs)"),
        opt("cut_faces", Kind::Value("true | false | #{nu}", "true"), "false", "with cut: the faces it opens drawn as opaque surfaces of the field, the radiance of a thick layer of their value (emission / extinction of the transfer function; values that absorb nothing are not drawn), with nu: times the fringes 1 + cos(2π nu value)"),
        opt("coastlines", Kind::Value("true | #{ colour, width, resolution }", "true"), "false", "spherical volumes: Natural Earth coastlines (public domain) on the outer surface, drawn into the HDR image in linear RGB, hidden on the far side and where a wedge or cut leaves no outer surface (the scale by the domain's extent)"),
        opt("graticule", Kind::Value("true | degrees", "30.0"), "false", "spherical volumes: meridians and parallels on the outer surface at the multiples of this step (true: 10), in linear grey 0.2"),
        opt("missing", Kind::Choice(Missing::NAMES), "\"strict\"", "strict: a missing voxel among a sample's 8 neighbours makes it missing; renormalise: the finite neighbours' weights renormalised (the mapped GPU ray caster, whole and without skipping, or the f64 CPU reference)"),
        opt("empty_space_skipping", Kind::Bool, "true", "jump over space the transfer function leaves empty (missing data, transparent values), with the same image"),
        opt("memory_budget", Kind::NumAbove(0.0, 1e9), "--gpu-memory, else unlimited", "MiB of GPU memory; larger volumes stream through a brick cache"),
        opt("brick", BRICK_EDGE, "none", "brick edge in voxels (8, 16, 32, 64 or 128): render bricked"),
        opt("level", Kind::Int(0, MAX_LEVEL as i64), "0", "0 full resolution, 1 half, ... 4: quick look"),
    ],
    call: "render_volume(generate_mantle(#{ n: 4 }), OPTS)",
    base: "#{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4 }",
};

pub(crate) const SHADING: OptionTable = OptionTable {
    function: "render_volume shading",
    options: &[
        opt("ambient", Kind::Num(0.0, 100.0), "0.3", "light everywhere"),
        opt("diffuse", Kind::Num(0.0, 100.0), "0.7", "Lambertian term"),
        opt("specular", Kind::Num(0.0, 100.0), "0.3", "Blinn–Phong highlight"),
        opt("shininess", Kind::Num(1.0, 10_000.0), "32", "highlight exponent"),
    ],
    call: "render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4, shading: OPTS })",
    base: "#{}",
};

pub(crate) const CUT: OptionTable = OptionTable {
    function: "render_volume cut",
    options: &[
        opt("lat", Kind::Value("[south, north] in degrees", "[0.0, 90.0]"), "all latitudes", "the latitudes removed"),
        opt("lon", Kind::Value("[west, east] in degrees", "[0.0, 180.0]"), "all longitudes", "the longitudes removed, eastward from west to east"),
        opt("depth", Kind::Value("[top, bottom] in the volume's length unit", "[0.0, 100.0]"), "all depths", "the depths removed (planet radius − radius)"),
        opt("x", Kind::Value("[lo, hi] in world units", "[0.0, 1.0]"), "all x", "a box's cut: the world x removed"),
        opt("y", Kind::Value("[lo, hi] in world units", "[0.0, 1.0]"), "all y", "a box's cut: the world y removed"),
        opt("z", Kind::Value("[lo, hi] in world units", "[0.0, 1.0]"), "all z", "a box's cut: the world z removed"),
        opt("plane", Kind::Value("#{point, normal} | [#{point, normal}, ...]", "#{ point: [0.5, 0.5, 0.5], normal: [1.0, 1.0, 0.0] }"), "none", "a box's cut: the side of the plane through point that normal points to (world units); up to 3 planes as an array, their half-spaces and the ranges all holding where the volume is removed"),
    ],
    call: "render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4, cut: OPTS })",
    base: "#{ lon: [0.0, 180.0] }",
};

pub(crate) const CUT_PLANE: OptionTable = OptionTable {
    function: "render_volume cut plane",
    options: &[
        opt("point", Kind::Value("[x, y, z] in world units", "[0.5, 0.5, 0.5]"), "required", "a point on the plane"),
        opt("normal", Kind::Value("[x, y, z], not zero", "[0.0, 0.0, 1.0]"), "required", "the plane's normal, pointing into the removed side"),
    ],
    call: "render_volume(generate_mantle(#{ n: 4 }), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4, cut: #{ plane: OPTS } })",
    base: "#{ point: [0.5, 0.5, 0.5], normal: [1.0, 0.0, 0.0] }",
};

pub(crate) const CUT_FACES: OptionTable = OptionTable {
    function: "render_volume cut_faces",
    options: &[
        opt("nu", Kind::NumAbove(0.0, f64::INFINITY), "none", "fringes per unit of the value over the faces (the interference method's 1 + cos(2π nu value))"),
        opt("depth_rings", Kind::Value("true | [depth, ...]", "true"), "none", "spherical volumes: dark lines 1.5 px wide where the faces meet these depths (the volume's length unit, at most 4); true: 410 km, 660 km and the core–mantle boundary at 2891 km"),
    ],
    call: "render_volume(load_volume(generate(\"mantle\", #{ n: 4, native: true })), #{ tf: tf_emission_absorption(1.0, 1.0), width: 4, height: 4, cut: #{ lon: [0.0, 90.0] }, cut_faces: OPTS })",
    base: "#{}",
};

pub(crate) const TF_LUT: OptionTable = OptionTable {
    function: "tf_lut",
    options: &[
        opt("scale", Kind::Text("\"symlog\""), "\"linear\"", "\"linear\" | \"log10\" | \"symlog\" (case ignored; aliases lin, log, logarithmic, symmetric-log)"),
        opt("linthresh", Kind::NumAbove(0.0, f64::INFINITY), "1e-3 of the domain's largest magnitude", "symlog: half-width of the linear part around zero"),
        opt("domain", Kind::Value("[lo, hi]", "[0.0, 1.0]"), "the data's range", "values mapped to t = 0 and 1"),
        opt("lens", Kind::Value("#{lo, hi, factor}", "#{ lo: 0.2, hi: 0.4, factor: 4.0 }"), "none", "magnify the sub-range [lo, hi] of t by factor (all three required)"),
        opt("colormap", Kind::Text("\"viridis\""), "\"viridis\"", "a colour map name (tf_lut lists them on a typo)"),
        opt("emission", Kind::Value("[[t, log10 e], ...]", "[[0.0, -1.0], [1.0, 0.0]]"), "a ramp", "log10 emission control points over t"),
        opt("opacity", Kind::Value("[[t, log10 sigma], ...]", "[[0.0, -1.0], [1.0, 0.0]]"), "a ramp", "log10 extinction control points over t"),
        opt("transparent_below", Kind::Finite, "none", "the scaled value t (as in emission and opacity) below which voxels emit and absorb nothing; a data value v on a linear domain [lo, hi] is t = (v - lo) / (hi - lo)"),
    ],
    call: "tf_lut(OPTS)",
    base: "#{}",
};

pub(crate) const LENS: OptionTable = OptionTable {
    function: "tf_lut lens",
    options: &[
        opt(
            "lo",
            Kind::Finite,
            "required",
            "start of the magnified sub-range of t",
        ),
        opt("hi", Kind::Finite, "required", "its end"),
        opt("factor", Kind::Finite, "required", "magnification"),
    ],
    call: "tf_lut(#{ lens: OPTS })",
    base: "#{ lo: 0.2, hi: 0.4, factor: 4.0 }",
};

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
    engine.register_fn("meta", |i: &mut ScriptImage, key: &str| -> Dynamic {
        i.meta(key).map_or(Dynamic::UNIT, |v| v.to_string().into())
    });
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
            let given = LOAD_VOLUME.read(&opts)?;
            let (p, from_path) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
            let load = LoadOptions {
                variable: variable_option(given.string("variable")?, from_path, "load_volume")?,
                cartesian: given.string("geometry")?.as_deref() == Some("cartesian"),
                planet_radius: given.num("planet_radius")?,
                select: super::api_datasets::selection(&given)?,
                band: None,
                vertical: given.string("vertical")?,
                resolution: given.num("resolution")?,
                grid: match given.string("grid")? {
                    Some(g) => Some(h.sandbox.read_path(&g).map_err(to_rhai)?),
                    None => None,
                },
                reduce: None,
            };
            h.session.load_volume(&p, &load).map_err(to_rhai)
        },
    );

    let h = host.clone();
    engine.register_fn(
        "generate_mantle",
        move |opts: Map| -> RResult<ScriptVolume> {
            let (o, field, _) =
                super::api_datasets::mantle_options(&opts, &super::api_datasets::GENERATE_MANTLE)?;
            // Generation takes seconds at 256³; a re-run of the script (TUI, sweep) reuses it.
            h.session
                .generated_volume(&("mantle", &o, field.name()), || {
                    let m = crate::datasets::mantle::generate(&o, &mut |_| h.check_deadline())?;
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

/// `tf_lut(#{...})`: a colour-map transfer function from the options in [`TF_LUT`].
fn tf_lut(opts: Map) -> RResult<TransferFunction> {
    let given = TF_LUT.read(&opts)?;
    let mut l = LutTransfer::default();
    if let Some(d) = given.value("domain")? {
        let d = points(&Dynamic::from(vec![d.clone()]), "domain")?;
        l.domain = Some(d[0]);
    }
    if let Some(v) = given.value("lens")? {
        l.lens = Some(lens(v)?);
    }
    if let Some(c) = given.string("colormap")? {
        l.colormap = c;
    }
    if let Some(v) = given.value("emission")? {
        l.emission = points(v, "emission")?;
    }
    if let Some(v) = given.value("opacity")? {
        l.opacity = points(v, "opacity")?;
    }
    let scale = given.string("scale")?.unwrap_or_else(|| "linear".into());
    l.scale = Scale::parse(&scale, given.num("linthresh")?).map_err(to_rhai)?;
    if let Some(t) = given.num("transparent_below")? {
        l.transparent_below = t;
        l.check_transparent_below().map_err(to_rhai)?;
    }
    crate::model::colormap::Colormap::by_name(&l.colormap).map_err(to_rhai)?;
    Ok(TransferFunction::Lut(l))
}

/// The `lens` option of `tf_lut`: a map #{lo, hi, factor} ([`LENS`]), all required.
fn lens(v: &Dynamic) -> RResult<Lens> {
    let m = v.clone().try_cast::<Map>().ok_or_else(|| {
        to_rhai(crate::Error::invalid(
            "lens",
            "expected a map #{lo, hi, factor}",
        ))
    })?;
    let given = LENS.read(&m)?;
    let get = |key: &str| {
        given
            .num(key)?
            .ok_or_else(|| to_rhai(crate::Error::invalid("lens", format!("missing {key}"))))
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
            if h.plan_only {
                return Ok(blank(o.width, o.height));
            }
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

/// `cut_faces: true | false | #{ nu, depth_rings }` ([`CUT_FACES`]).
fn cut_faces(v: &Dynamic) -> RResult<Option<CutFaces>> {
    CUT_FACES.switch_or_map(v, "cut_faces", |given| {
        let depth_rings = match given.value("depth_rings")? {
            Some(v) => super::lines::depth_rings(v, "cut_faces.depth_rings")?,
            None => None,
        };
        Ok(CutFaces {
            nu: given.num("nu")?,
            depth_rings,
        })
    })
}

/// `shading: true` (the default coefficients), `false`, or a map of coefficients ([`SHADING`]).
fn shading(v: &Dynamic) -> RResult<Option<Shading>> {
    SHADING.switch_or_map(v, "shading", |given| {
        let mut s = Shading::default();
        for (target, name) in [
            (&mut s.ambient, "ambient"),
            (&mut s.diffuse, "diffuse"),
            (&mut s.specular, "specular"),
            (&mut s.shininess, "shininess"),
        ] {
            if let Some(x) = given.num(name)? {
                *target = x;
            }
        }
        s.validate().map_err(to_rhai)?;
        Ok(s)
    })
}

/// `cut: #{ lat, lon, depth }` or `#{ x, y, z }` ([`CUT`]); the ranges are checked against the
/// volume when it renders.
fn cut(v: &Dynamic) -> RResult<Cut> {
    let m = v.clone().try_cast::<Map>().ok_or_else(|| {
        to_rhai(crate::Error::invalid(
            "cut",
            "expected a map #{ lat: [a, b], lon: [a, b], depth: [a, b] } or #{ x: [a, b], y: [a, b], z: [a, b], plane: #{ point, normal } }",
        ))
    })?;
    let given = CUT.read(&m)?;
    let range = |name: &str| -> RResult<Option<[f64; 2]>> {
        given
            .value(name)?
            .map(|x| pair(x, &format!("cut {name}")))
            .transpose()
    };
    let planes = match given.value("plane")? {
        None => Vec::new(),
        Some(v) => match v.clone().into_array() {
            Ok(list) => list.iter().map(cut_plane).collect::<RResult<_>>()?,
            Err(_) => vec![cut_plane(v)?],
        },
    };
    Ok(Cut {
        x: range("x")?,
        y: range("y")?,
        z: range("z")?,
        planes,
        lat: range("lat")?,
        lon: range("lon")?,
        depth: range("depth")?,
    })
}

/// One plane of a box's cut: `#{ point, normal }` ([`CUT_PLANE`]), both required.
fn cut_plane(v: &Dynamic) -> RResult<CutPlane> {
    let m = v.clone().try_cast::<Map>().ok_or_else(|| {
        to_rhai(crate::Error::invalid(
            "cut plane",
            "expected a map #{ point: [x, y, z], normal: [x, y, z] } or an array of them",
        ))
    })?;
    let given = CUT_PLANE.read(&m)?;
    let field = |key: &str| -> RResult<[f64; 3]> {
        let name = format!("cut plane {key}");
        let v = given
            .value(key)?
            .ok_or_else(|| to_rhai(crate::Error::invalid(&name, "missing; expected [x, y, z]")))?;
        vec3(v, &name)
    };
    Ok(CutPlane {
        point: field("point")?,
        normal: field("normal")?,
    })
}

/// A planning run's stand-in for a rendered image: the size the real one would have, no pixels
/// worth looking at.
pub(crate) fn blank(width: u32, height: u32) -> ScriptImage {
    Arc::new(HdrImage::new(width, height))
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
    host.note_render(super::LastRender::Volume(super::LastVolumeRender {
        source: source.clone(),
        options: o.clone(),
    }));
    Ok(img)
}

/// The options map of `render_volume`, with the camera resolved for the source's bounds and the
/// run's default GPU memory budget (`hdrvis run --gpu-memory`) where the map gives none.
pub(crate) fn render_options(
    host: &ScriptHost,
    opts: &Map,
    source: &VolumeSource,
) -> RResult<VolumeRenderOptions> {
    let given = RENDER_VOLUME.read(opts)?;
    let tf = match given.value("tf")? {
        Some(v) => v.clone().try_cast::<TransferFunction>().ok_or_else(|| to_rhai(crate::Error::invalid("tf", "expected a TransferFunction (from tf_lut or tf_emission_absorption)")))?,
        None => return err("tf", "render_volume needs a transfer function: tf: tf_lut(#{...}) or tf_emission_absorption(e, a)"),
    };
    let camera = match given.value("camera")? {
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
    take_render_options(&mut o, &given)?;
    take_bricking(&mut o.bricking, &given)?;
    if is_axis {
        // Square pixels: a missing side follows the box, a given size is letterboxed.
        let side = |key: &str, v: u32| given.has(key).then_some(v);
        let (w, h) = o.camera.square_pixel_size(
            side("width", o.width),
            side("height", o.height),
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

/// Sets the rendering options of [`RENDER_VOLUME`] the script gave (the transfer function and
/// camera are read before).
fn take_render_options(o: &mut VolumeRenderOptions, given: &Given) -> RResult<()> {
    if let Some(w) = given.int("width")? {
        o.width = w as u32;
    }
    if let Some(h) = given.int("height")? {
        o.height = h as u32;
    }
    o.step = given.num("step")?.unwrap_or(o.step);
    o.jitter = given.bool("jitter")?.unwrap_or(o.jitter);
    if let Some(seed) = given.int("seed")? {
        // A seed varies only jittered rays: without jitter it would change nothing.
        if !o.jitter {
            return Err(to_rhai(crate::Error::invalid(
                "seed",
                format!("{seed} with jitter off; a seed varies only jittered renders (add jitter: true)"),
            )));
        }
        o.seed = seed as u32;
    }
    o.early_exit = given.num("early_exit")?.unwrap_or(o.early_exit);
    if let Some(v) = given.value("background")? {
        o.background = vec3(v, "background")?;
    }
    if let Some(f) = given.string("filter")? {
        o.filter = FilterMode::parse(&f).map_err(to_rhai)?;
    }
    if let Some(p) = given.string("precision")? {
        o.precision = Precision::parse(&p).map_err(to_rhai)?;
    }
    if let Some(v) = given.value("shading")? {
        o.shading = shading(v)?;
    }
    if let Some(t) = given.string("tf_sampling")? {
        o.tf_sampling = TfSampling::parse(&t).map_err(to_rhai)?;
    }
    if let Some(m) = given.string("missing")? {
        o.missing = Missing::parse(&m).map_err(to_rhai)?;
    }
    if let Some(c) = given.value("cut")? {
        o.cut = Some(cut(c)?);
    }
    if let Some(f) = given.value("cut_faces")? {
        o.cut_faces = cut_faces(f)?;
    }
    if let Some(v) = given.value("coastlines")? {
        o.coastlines = super::lines::coastline_style(v)?;
    }
    if let Some(v) = given.value("graticule")? {
        o.graticule = super::lines::graticule_step(v)?;
    }
    o.empty_space_skipping = given
        .bool("empty_space_skipping")?
        .unwrap_or(o.empty_space_skipping);
    Ok(())
}

fn mib_to_bytes(mib: f64) -> u64 {
    (mib * (1u64 << 20) as f64) as u64
}

/// Sets the bricked and out-of-core options of [`RENDER_VOLUME`] the script gave.
fn take_bricking(b: &mut Bricking, given: &Given) -> RResult<()> {
    if let Some(m) = given.num("memory_budget")? {
        b.memory_budget = Some(mib_to_bytes(m));
    }
    if let Some(edge) = given.count("brick")? {
        b.brick = Some(edge);
    }
    if let Some(l) = given.int("level")? {
        b.level = l as u32;
    }
    Ok(())
}
