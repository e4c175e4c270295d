//! Script API for interference surfaces: `load_grid(path)`, `load_grid(path, name)`,
//! `render_surface(grid, options)` and `surface_colorbar(grid, options)`. One `SurfaceRenderer`
//! per script run caches the data pass, so rendering the same grid and view again with another
//! ν, mode or colour map runs only the fringe pass. `property` may be one name (the result is one
//! image) or an array of up to four names (the result is an array of images, all from one data
//! pass). `view: "globe"` (or `globe: true` with a camera) drapes a geographic grid on the
//! sphere.

use super::api_render::{ScriptCamera, ScriptImage};
use super::convert::{boolean, check_keys, err, int, num, string, to_rhai, RResult};
use super::ScriptHost;
use crate::model::{Aabb, Axis, Grid};
use crate::render::surface::{
    colorbar, legend, FringeMode, MissingColour, PhaseMethod, SurfaceOptions, SurfaceView,
};
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

pub(crate) type ScriptGrid = Arc<Grid>;

/// Every key `render_surface` accepts.
pub(crate) const SURFACE_KEYS: &[&str] = &[
    "nu",
    "mode",
    "colormap",
    "property",
    "view",
    "globe",
    "width",
    "height",
    "modulation",
    "absolute",
    "log_color",
    "exaggeration",
    "relief",
    "phase",
    "antialias",
    "missing",
];

fn numbers(v: &Dynamic, field: &str) -> RResult<Vec<f64>> {
    match v.clone().into_array() {
        Ok(a) => a.iter().map(|x| num(x, field)).collect(),
        Err(_) => Ok(vec![num(v, field)?]),
    }
}

/// Parses the option map; the boolean says whether `property` was an array.
pub(crate) fn parse_options(grid: &Grid, opts: &Map) -> RResult<(SurfaceOptions, bool)> {
    check_keys(opts, SURFACE_KEYS, "render_surface")?;
    let mut o = SurfaceOptions::default();
    let mut many = false;
    for (k, v) in opts {
        match k.as_str() {
            "nu" => o.nu = numbers(v, "nu")?,
            "mode" => o.mode = FringeMode::parse(&string(v, "mode")?).map_err(to_rhai)?,
            "colormap" => o.colormap = Some(string(v, "colormap")?),
            "property" => match v.clone().into_array() {
                Ok(a) => {
                    many = true;
                    o.properties = a
                        .iter()
                        .map(|p| string(p, "property"))
                        .collect::<RResult<_>>()?;
                    if o.properties.is_empty() {
                        return err("property", "expected at least one property name");
                    }
                }
                Err(_) => o.properties = vec![string(v, "property")?],
            },
            // Resolved after the loop: the view depends on `globe` too.
            "view" | "globe" => {}
            "width" => o.width = Some(int(v, "width")?.clamp(0, u32::MAX as i64) as u32),
            "height" => o.height = Some(int(v, "height")?.clamp(0, u32::MAX as i64) as u32),
            "modulation" => o.modulation = num(v, "modulation")?,
            "absolute" => o.absolute = boolean(v, "absolute")?,
            "log_color" => o.log_color = boolean(v, "log_color")?,
            "exaggeration" => o.exaggeration = num(v, "exaggeration")?,
            "relief" => o.relief = Some(string(v, "relief")?),
            "phase" => o.phase = PhaseMethod::parse(&string(v, "phase")?).map_err(to_rhai)?,
            "antialias" => o.antialias = boolean(v, "antialias")?,
            "missing" => {
                o.missing = MissingColour::parse(&string(v, "missing")?).map_err(to_rhai)?
            }
            _ => unreachable!("checked keys"),
        }
    }
    let globe = opts
        .get("globe")
        .map(|v| boolean(v, "globe"))
        .transpose()?
        .unwrap_or(false);
    o.view = surface_view(grid, opts.get("view"), globe)?;
    // Relief defaults to the grid's elevation in 3-D views over the plane.
    if o.relief.is_none()
        && !matches!(o.view, SurfaceView::Map | SurfaceView::Globe(_))
        && grid.elevation().is_some()
    {
        o.relief = Some("elevation".into());
    }
    Ok((o, many))
}

/// Distance of the default globe camera from the planet's centre, in sphere radii, and its
/// field of view in degrees.
const GLOBE_DISTANCE: f64 = 3.0;
const GLOBE_FOV: f64 = 35.0;

/// The view of `view` (a name or a camera; the map when absent). With `globe` the grid lies on
/// the unit sphere and the camera is in the Earth-centred frame: `camera_axis` frames the sphere's
/// box along that axis, `camera_orbit` orbits the centre, `"globe"` or no view looks from
/// above the grid's centre.
fn surface_view(grid: &Grid, view: Option<&Dynamic>, globe: bool) -> RResult<SurfaceView> {
    let camera = view.and_then(|v| v.clone().try_cast::<ScriptCamera>());
    let name = match (view, &camera) {
        (Some(v), None) => Some(string(v, "view")?),
        _ => None,
    };
    if globe || name.as_deref() == Some("globe") {
        let sphere_box = Aabb {
            lo: [-1.0; 3],
            hi: [1.0; 3],
        };
        return match (camera, name.as_deref()) {
            (Some(c), _) => Ok(SurfaceView::Globe(
                c.resolve_in(&sphere_box, ([0.0; 3], 1.0))
                    .map_err(to_rhai)?,
            )),
            (None, None | Some("globe")) => {
                SurfaceView::globe_above(grid, GLOBE_DISTANCE, GLOBE_FOV).map_err(to_rhai)
            }
            (None, Some(other)) => err(
                "view",
                format!("globe: true takes \"globe\" or a camera as the view, got {other:?}"),
            ),
        };
    }
    if let Some(c) = camera {
        return Ok(match c {
            ScriptCamera::Axis(Axis::Z) => SurfaceView::Map,
            ScriptCamera::Axis(_) => {
                return err("view", "a surface is seen from above: camera_axis(\"z\"), \"map\", \"perspective\", \"globe\" or camera_orbit(...)")
            }
            ScriptCamera::Orbit {
                azimuth,
                elevation,
                fov,
            } => SurfaceView::Orbit {
                azimuth,
                elevation,
                fov,
            },
            ScriptCamera::Fixed(c) => SurfaceView::Camera(c),
            ScriptCamera::Geo { .. } => {
                return err("view", "camera_geo looks at a sphere: use it with view \"globe\" (globe: true) or on a spherical volume")
            }
        });
    }
    match name.as_deref() {
        None | Some("map") => Ok(SurfaceView::Map),
        Some("perspective" | "3d") => Ok(SurfaceView::Orbit {
            azimuth: -60.0,
            elevation: 35.0,
            fov: 40.0,
        }),
        Some(other) => err(
            "view",
            format!("expected \"map\", \"perspective\", \"globe\" or a camera, got {other:?}"),
        ),
    }
}

pub(crate) fn register(engine: &mut Engine, host: Arc<ScriptHost>) {
    engine.register_type_with_name::<ScriptGrid>("Grid");
    engine.register_get("nx", |g: &mut ScriptGrid| g.nx() as i64);
    engine.register_get("ny", |g: &mut ScriptGrid| g.ny() as i64);
    engine.register_get("name", |g: &mut ScriptGrid| g.name().to_string());
    engine.register_get("properties", |g: &mut ScriptGrid| -> rhai::Array {
        g.property_names()
            .into_iter()
            .map(|n| Dynamic::from(n.to_string()))
            .collect()
    });

    let h = host.clone();
    engine.register_fn("load_grid", move |path: &str| -> RResult<ScriptGrid> {
        let (p, variable) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
        h.session
            .load_grid(&p, variable.as_deref())
            .map_err(to_rhai)
    });
    let h = host.clone();
    engine.register_fn(
        "load_grid",
        move |path: &str, name: &str| -> RResult<ScriptGrid> {
            let p = h.sandbox.read_path(path).map_err(to_rhai)?;
            h.session.load_grid(&p, Some(name)).map_err(to_rhai)
        },
    );

    let h = host;
    engine.register_fn(
        "render_surface",
        move |grid: &mut ScriptGrid, opts: Map| -> RResult<Dynamic> {
            let (o, many) = parse_options(grid, &opts)?;
            let mut images = h.session.surface(grid, &o).map_err(to_rhai)?.to_vec();
            if let Some(first) = images.first() {
                h.note_image(&Arc::new(first.clone()));
            }
            if many {
                Ok(Dynamic::from(
                    images
                        .into_iter()
                        .map(|i| Dynamic::from(Arc::new(i) as ScriptImage))
                        .collect::<rhai::Array>(),
                ))
            } else {
                Ok(Dynamic::from(Arc::new(images.remove(0)) as ScriptImage))
            }
        },
    );
    engine.register_fn("render_surface", |_: &mut ScriptGrid| -> RResult<Dynamic> {
        err(
            "render_surface",
            format!(
                "expected render_surface(grid, #{{...}}) with keys {}",
                SURFACE_KEYS.join(", ")
            ),
        )
    });

    engine.register_fn(
        "surface_colorbar",
        |grid: &mut ScriptGrid, opts: Map| -> RResult<ScriptImage> {
            let mut rest = opts.clone();
            let w = rest
                .remove("width")
                .map(|v| int(&v, "width"))
                .transpose()?
                .unwrap_or(256);
            let hgt = rest
                .remove("height")
                .map(|v| int(&v, "height"))
                .transpose()?
                .unwrap_or(16);
            let (o, _) = parse_options(grid, &rest)?;
            let img = colorbar(
                grid,
                &o,
                w.clamp(0, 16384) as u32,
                hgt.clamp(0, 16384) as u32,
            )
            .map_err(to_rhai)?;
            Ok(Arc::new(img))
        },
    );

    engine.register_fn(
        "surface_legend",
        |grid: &mut ScriptGrid, opts: Map| -> RResult<ScriptImage> {
            let mut rest = opts.clone();
            let w = rest
                .remove("width")
                .map(|v| int(&v, "width"))
                .transpose()?
                .unwrap_or(384);
            let (o, _) = parse_options(grid, &rest)?;
            let img = legend(grid, &o, w.clamp(0, 16384) as u32).map_err(to_rhai)?;
            Ok(Arc::new(img))
        },
    );
}
