//! Script API for interference surfaces: `load_grid(path)`, `load_grid(path, name)`,
//! `load_grid(path, #{ variable, index, at })`,
//! `render_surface(grid, options)` and `surface_colorbar(grid, options)`. One `SurfaceRenderer`
//! per script run caches the data pass, so rendering the same grid and view again with another
//! ν, mode or colour map runs only the fringe pass. `property` may be one name (the result is one
//! image) or an array of up to four names (the result is an array of images, all from one data
//! pass). `view: "globe"` (or `globe: true` with a camera) drapes a geographic grid on the
//! sphere.

use super::api_render::{ScriptCamera, ScriptImage};
use super::convert::{err, numbers, pair, string, to_rhai, variable_option, RResult};
use super::lines::{cell_edge_style, coastline_style, graticule_step};
use super::options::{opt, Given, Kind, OptionTable};
use super::{LastRender, LastSurfaceRender, ScriptHost, SurfaceField};
use crate::datasets::LoadOptions;
use crate::model::mesh::MeshField;
use crate::model::text::{TYPE_MAX, TYPE_MIN};
use crate::model::{Aabb, Axis, Grid, HdrImage, MapProjection, ProjectionKind};
use crate::render::surface::{
    colorbar, legend_in, legend_type, mesh_extent_grid, FringeMode, MissingColour, PhaseMethod,
    SurfaceOptions, SurfaceView, MAX_COLORBAR_HEIGHT,
};
use crate::render::MAX_IMAGE_SIDE;
use rhai::{Dynamic, Engine, Map};
use std::sync::Arc;

pub(crate) type ScriptGrid = Arc<Grid>;
pub(crate) type ScriptMesh = Arc<MeshField>;

/// The options `render_surface`, `surface_colorbar` and `surface_legend` share (what sets the
/// colours), followed by the function's own (`render_surface`'s view, all three's sizes).
macro_rules! surface_option_specs {
    ($($own:expr),* $(,)?) => {
        [
            opt("nu", Kind::Value("number > 0, or one per property", "[2.0]"), "1", "ν: fringes per data unit (one fringe per 1/ν)"),
            opt("mode", Kind::Choice(FringeMode::NAMES), "\"cyclic\"", "cyclic: the colour map over each fringe; modulated: the data's colour modulated by the fringes; direct: the data's colour"),
            opt("colormap", Kind::Text("\"viridis\""), "sinebow (cyclic), else viridis", "a colour map name"),
            opt("property", Kind::Value("string, or an array of up to four", "\"uz\""), "the grid's first property", "what is drawn; an array renders each from one data pass and returns an array (render_surface only)"),
            opt("modulation", Kind::Num(0.0, 1.0), "1", "cyclic and modulated modes: depth of the fringes' modulation"),
            opt("absolute", Kind::Bool, "false", "fringes of |d|"),
            opt("log_color", Kind::Bool, "false", "modulated and direct modes: colours over log10 of the data"),
            opt("domain", Kind::Value("[lo, hi]", "[-1.0, 1.0]"), "the data's range", "modulated and direct modes: the values the colours span (magnitudes with absolute or log_color); values beyond take the end colours and the colour bar gets a triangle at that end"),
            opt("label", Kind::Text("\"SST (°C)\""), "the property's long_name (else its name) and units", "what the colour bar says it measures, in its caption and in frames and legends"),
            opt("centre", Kind::Finite, "none", "modulated and direct modes: the colour range made symmetric about this value (the middle colour of a diverging map); without a domain, half-width max |d − centre| over the data"),
            $($own),*
        ]
    };
}

pub(crate) const LOAD_GRID: OptionTable = OptionTable {
    function: "load_grid",
    options: &[
        opt(
            "variable",
            Kind::Text("\"uz\""),
            "the file's first 2-D data variable",
            "the array or variable to read (an unknown one lists the file's)",
        ),
        super::api_datasets::SELECT_INDEX,
        super::api_datasets::SELECT_AT,
        opt(
            "band",
            Kind::Int(1, 65535),
            "none (a one-band file)",
            "the band of a multi-band GeoTIFF, counted from 1 as GDAL does",
        ),
        opt(
            "resolution",
            Kind::NumAbove(0.0, 90.0),
            "the grid's median cell edge; a mesh's median cell size",
            "a curvilinear grid (2-D latitude and longitude named in the variable's coordinates) or an unstructured mesh (UGRID, ICON, MPAS, SCRIP, FVCOM, ADCIRC): the step in degrees of the regular latitude-longitude grid it is regridded or sampled onto; refused for other grids",
        ),
        opt(
            "grid",
            Kind::Text("\"grid.nc\""),
            "the variable's own file",
            "an unstructured mesh kept in a file of its own (ICON and MPAS grid files, SCRIP): the variable's values run along its cells or nodes",
        ),
        opt("mean", Kind::Text("\"time\""), "none", "the grid averaged over the steps of this dimension, node by node, missing values skipped (xarray's mean(skipna)); the other dimensions fixed by index or at"),
        opt("min", Kind::Text("\"time\""), "none", "as mean, the smallest value over the steps"),
        opt("max", Kind::Text("\"time\""), "none", "as mean, the largest value over the steps"),
        opt("std", Kind::Text("\"time\""), "none", "as mean, the standard deviation over the steps (ddof 0, numpy's nanstd)"),
        opt("steps", Kind::Value("[first, last]", "[0, 1]"), "every step", "with mean, min, max or std: the steps reduced over, by index, both ends included"),
    ],
    call: "load_grid(\"geo.nc\", OPTS)",
    base: "#{}",
};

pub(crate) const LOAD_MESH: OptionTable = OptionTable {
    function: "load_mesh",
    options: &[
        opt(
            "variable",
            Kind::Text("\"h\""),
            "the file's first variable on a mesh",
            "the variable to read (an unknown one lists the file's)",
        ),
        super::api_datasets::SELECT_INDEX,
        super::api_datasets::SELECT_AT,
        opt(
            "grid",
            Kind::Text("\"grid.nc\""),
            "the variable's own file",
            "the file that holds the mesh when the variable's file has only its values (ICON and MPAS grid files, SCRIP)",
        ),
    ],
    call: "load_mesh(\"mesh.nc\", OPTS)",
    base: "#{ variable: \"h\" }",
};

/// The side limit of images as an option range.
const SIDE: Kind = Kind::Int(1, MAX_IMAGE_SIDE as i64);

pub(crate) const RENDER_SURFACE: OptionTable = OptionTable {
    function: "render_surface",
    options: &surface_option_specs!(
        opt("view", Kind::Value("\"map\" | \"perspective\" | \"globe\" | Camera", "\"perspective\""), "\"map\"", "map (a geographic grid keeps the cos-latitude aspect), perspective, globe (a lon/lat grid draped on the unit sphere, seen from 3 radii above its centre) or a camera"),
        opt("globe", Kind::Bool, "false", "a camera view looks at the grid on the sphere, in the Earth-centred frame"),
        opt("exaggeration", Kind::Num(0.0, f64::INFINITY), "1", "perspective views: vertical exaggeration of the relief"),
        opt("relief", Kind::Text("\"uz\""), "the grid's elevation", "perspective views: the property that lifts the surface"),
        opt("phase", Kind::Choice(PhaseMethod::NAMES), "\"reduced\"", "reduced: f64-exact phase; naive: cos(2πνd) in f32, for comparison"),
        opt("antialias", Kind::Bool, "true", "colours from the fringe averaged over each pixel's footprint"),
        opt("missing", Kind::Text("\"grey\""), "\"transparent\"", "colour of missing data: \"transparent\", a colour name or #rrggbb"),
        opt("coastlines", Kind::Value("true | #{ colour, width, resolution }", "true"), "false", "map and globe views of longitude/latitude grids: Natural Earth coastlines (public domain) drawn into the HDR image, hidden on the globe's far side"),
        opt("cell_edges", Kind::Value("true | #{ colour, width }", "true"), "false", "meshes (load_mesh): the cells' outlines drawn into the HDR image over the field and under coastlines and graticule"),
        opt("graticule", Kind::Value("true | degrees", "30.0"), "false", "map and globe views of longitude/latitude grids: meridians and parallels at the multiples of this step (true: 10), in linear grey 0.2"),
        opt("contours", Kind::Value("true | count | [level, ...] | #{ levels, property, grid, colour, width, labels }", "true"), "false", "contour lines of the rendered property (or another's, or another grid's) by marching squares, drawn into the HDR image on maps (any axes, projected), globes and sections"),
        opt("vectors", Kind::Value("#{ u, v, grid, spacing, scale, reference, colour, width }", "#{ u: \"uz\", v: \"uz\", spacing: 4.0 }"), "none", "arrows of the vector (u, v) on a lattice of the picture, pointing as the view places the vector (east and north on longitude/latitude grids), with a reference arrow"),
        opt("projection", Kind::Value("name | #{ name, lon_0, lat_0, lat_1, lat_2 }", "\"robinson\""), "\"equirectangular\"", "map views of longitude/latitude grids and meshes: equirectangular, robinson, mollweide, orthographic, polar_north, polar_south or lambert (conformal conic), PROJ's formulas on a sphere of the Earth's mean radius; lon_0 defaults to 0 on world and polar maps and to the middle of the data's longitudes otherwise, lat_0 to the middle of its latitudes, lambert's lat_1 and lat_2 a sixth of its height inside its edges"),
        opt("depth_rings", Kind::Value("true | [depth, ...]", "true"), "none", "map views of sections (a grid on depth): black lines 1.5 px wide across the section at these depths (its depth unit); true: 410 km, 660 km and the core–mantle boundary at 2891 km where the section reaches them"),
        opt(
            "width",
            SIDE,
            "from the view and the grid's aspect",
            "pixels; a map is about 1000 on its long side by default (a pixel centred on every node, more pixels where the grid has more nodes), other views 512"
        ),
        opt(
            "height",
            SIDE,
            "from the view and the grid's aspect",
            "pixels"
        ),
    ),
    call: "render_surface(load_grid(\"geo.nc\"), OPTS)",
    base: "#{ width: 8, height: 8, mode: \"modulated\" }",
};

pub(crate) const SURFACE_COLORBAR: OptionTable = OptionTable {
    function: "surface_colorbar",
    options: &surface_option_specs!(
        opt("width", SIDE, "256", "the bar's length in pixels"),
        opt(
            "height",
            Kind::Int(1, MAX_COLORBAR_HEIGHT as i64),
            "16",
            "the bar's thickness in pixels"
        ),
    ),
    call: "surface_colorbar(load_grid(\"geo.nc\"), OPTS)",
    base: "#{ mode: \"modulated\" }",
};

pub(crate) const SURFACE_LEGEND: OptionTable = OptionTable {
    function: "surface_legend",
    options: &surface_option_specs!(
        opt("width", SIDE, "384", "the legend's width in pixels"),
        opt(
            "font_size",
            Kind::Num(TYPE_MIN, TYPE_MAX),
            "3.5 % of the width, at least 11",
            "the text's size in pixels per em"
        ),
    ),
    call: "surface_legend(load_grid(\"geo.nc\"), OPTS)",
    base: "#{ mode: \"modulated\" }",
};

/// The colour options every surface table has (see [`surface_option_specs`]); the boolean says
/// whether `property` was an array. Options that would change nothing in the mode given are
/// refused.
fn parse_options(given: &Given) -> RResult<(SurfaceOptions, bool)> {
    let mut o = SurfaceOptions::default();
    let mut many = false;
    if let Some(v) = given.value("nu")? {
        o.nu = numbers(v, "nu")?;
    }
    if let Some(m) = given.string("mode")? {
        o.mode = FringeMode::parse(&m).map_err(to_rhai)?;
    }
    o.colormap = given.string("colormap")?;
    if let Some(v) = given.value("property")? {
        match v.clone().into_array() {
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
        }
    }
    o.modulation = given.num("modulation")?.unwrap_or(o.modulation);
    o.absolute = given.bool("absolute")?.unwrap_or(o.absolute);
    o.log_color = given.bool("log_color")?.unwrap_or(o.log_color);
    if let Some(d) = given.value("domain")? {
        let [lo, hi] = pair(d, "domain")?;
        o.domain = Some((lo, hi));
    }
    o.centre = given.num("centre")?;
    o.label = given.string("label")?;
    o.validate_colour_range().map_err(to_rhai)?;
    // A value other than the default would be ignored: refused. (The default itself changes
    // nothing, so a loop over modes may pass it.)
    if o.mode == FringeMode::Direct && o.modulation != 1.0 {
        return err(
            "modulation",
            "direct mode draws no fringes; modulation applies to the cyclic and modulated modes",
        );
    }
    if o.mode == FringeMode::Cyclic && o.log_color {
        return err("log_color", "cyclic colours follow the fringe phase; log_color applies to the modulated and direct modes");
    }
    Ok((o, many))
}

/// `render_surface`'s options ([`RENDER_SURFACE`]): the colour options, the view and the
/// image's size. A relief, or an exaggeration other than 1, on a map or the globe (which are
/// flat) is refused.
pub(crate) fn render_surface_options(grid: &Grid, opts: &Map) -> RResult<(SurfaceOptions, bool)> {
    let given = RENDER_SURFACE.read(opts)?;
    let (mut o, many) = parse_options(&given)?;
    o.exaggeration = given.num("exaggeration")?.unwrap_or(o.exaggeration);
    o.relief = given.string("relief")?;
    if let Some(p) = given.string("phase")? {
        o.phase = PhaseMethod::parse(&p).map_err(to_rhai)?;
    }
    o.antialias = given.bool("antialias")?.unwrap_or(o.antialias);
    if let Some(m) = given.string("missing")? {
        o.missing = MissingColour::parse(&m).map_err(to_rhai)?;
    }
    if let Some(v) = given.value("coastlines")? {
        o.coastlines = coastline_style(v)?;
    }
    if let Some(v) = given.value("graticule")? {
        o.graticule = graticule_step(v)?;
    }
    if let Some(v) = given.value("cell_edges")? {
        o.cell_edges = cell_edge_style(v)?;
    }
    if let Some(v) = given.value("depth_rings")? {
        o.depth_rings = super::lines::depth_rings(v, "depth_rings")?;
    }
    if let Some(v) = given.value("contours")? {
        o.contours = super::lines::contour_style(v)?;
    }
    if let Some(v) = given.value("vectors")? {
        o.vectors = Some(super::lines::vector_style(v)?);
    }
    if let Some(v) = given.value("projection")? {
        o.projection = Some(map_projection(v)?);
    }
    let globe = given.bool("globe")?.unwrap_or(false);
    o.view = surface_view(grid, given.value("view")?, globe)?;
    if matches!(o.view, SurfaceView::Map | SurfaceView::Globe(_)) {
        let flat =
            "a map or globe view is flat; relief and exaggeration apply to perspective views";
        if o.relief.is_some() {
            return err("relief", flat);
        }
        if o.exaggeration != 1.0 {
            return err("exaggeration", flat);
        }
    } else if o.relief.is_none() && grid.elevation().is_some() {
        // Relief defaults to the grid's elevation in 3-D views over the plane.
        o.relief = Some("elevation".into());
    }
    o.width = given.int("width")?.map(|w| w as u32);
    o.height = given.int("height")?.map(|h| h as u32);
    Ok((o, many))
}

/// The colour options of `surface_colorbar` and `surface_legend`, which draw one property at one
/// ν: an array of properties or of several ν is refused rather than cut to its first.
fn bar_options(given: &Given) -> RResult<SurfaceOptions> {
    let (o, many) = parse_options(given)?;
    if many && o.properties.len() > 1 {
        return err("property", "a colour bar shows one property; give one name");
    }
    if o.nu.len() > 1 {
        return err("nu", "a colour bar shows one ν; give one number");
    }
    Ok(o)
}

/// Distance of the default globe camera from the planet's centre, in sphere radii, and its
/// field of view in degrees.
const GLOBE_DISTANCE: f64 = 3.0;
const GLOBE_FOV: f64 = 35.0;

/// The view of `view` (a name or a camera; the map when absent). With `globe` the grid lies on
/// the unit sphere and the camera is in the Earth-centred frame: `camera_axis` frames the sphere's
/// box along that axis, `camera_orbit` orbits the centre, `"globe"` or no view looks from
/// above the grid's centre.
/// `projection: "name"` or `#{ name, lon_0, lat_0, lat_1, lat_2 }` (degrees).
fn map_projection(v: &Dynamic) -> RResult<MapProjection> {
    let Some(map) = v.clone().try_cast::<Map>() else {
        let name = string(v, "projection")?;
        return Ok(MapProjection::new(
            ProjectionKind::parse(&name).map_err(to_rhai)?,
        ));
    };
    const KEYS: [&str; 5] = ["name", "lon_0", "lat_0", "lat_1", "lat_2"];
    if let Some(k) = map.keys().find(|k| !KEYS.contains(&k.as_str())) {
        return err(
            "projection",
            format!("unknown key {k:?}; expected {}", KEYS.join(", ")),
        );
    }
    let name = match map.get("name") {
        Some(n) => string(n, "projection.name")?,
        None => {
            return err(
                "projection",
                "a map needs a name, e.g. #{ name: \"lambert\" }",
            )
        }
    };
    let mut p = MapProjection::new(ProjectionKind::parse(&name).map_err(to_rhai)?);
    let num = |k: &str| -> RResult<Option<f64>> {
        map.get(k)
            .map(|v| super::convert::num(v, &format!("projection.{k}")))
            .transpose()
    };
    (p.lon_0, p.lat_0, p.lat_1, p.lat_2) =
        (num("lon_0")?, num("lat_0")?, num("lat_1")?, num("lat_2")?);
    p.validate().map_err(to_rhai)?;
    Ok(p)
}

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
    engine.register_get("wavelength", |g: &mut ScriptGrid| {
        g.wavelength().map_or(Dynamic::UNIT, Dynamic::from)
    });
    engine.register_get("properties", |g: &mut ScriptGrid| -> rhai::Array {
        g.property_names()
            .into_iter()
            .map(|n| Dynamic::from(n.to_string()))
            .collect()
    });

    register_load_grid(engine, &host);
    register_meshes(engine, &host);

    let h = host;
    engine.register_fn(
        "render_surface",
        move |grid: &mut ScriptGrid, opts: Map| -> RResult<Dynamic> {
            let (o, many) = render_surface_options(grid, &opts)?;
            surface_images(&h, SurfaceField::Grid(grid.clone()), o, many)
        },
    );
    engine.register_fn("render_surface", |_: &mut ScriptGrid| -> RResult<Dynamic> {
        err(
            "render_surface",
            format!(
                "expected render_surface(grid, #{{...}}) with keys {}",
                RENDER_SURFACE.names().join(", ")
            ),
        )
    });

    engine.register_fn(
        "surface_colorbar",
        |grid: &mut ScriptGrid, opts: Map| -> RResult<ScriptImage> {
            let given = SURFACE_COLORBAR.read(&opts)?;
            let o = bar_options(&given)?;
            let w = given.int("width")?.unwrap_or(256) as u32;
            let h = given.int("height")?.unwrap_or(16) as u32;
            Ok(Arc::new(colorbar(grid, &o, w, h).map_err(to_rhai)?))
        },
    );

    engine.register_fn(
        "surface_legend",
        |grid: &mut ScriptGrid, opts: Map| -> RResult<ScriptImage> {
            let given = SURFACE_LEGEND.read(&opts)?;
            let o = bar_options(&given)?;
            let w = given.int("width")?.unwrap_or(384) as u32;
            let ty = legend_type(w, given.num("font_size")?);
            Ok(Arc::new(legend_in(grid, &o, w, ty).map_err(to_rhai)?))
        },
    );
}

/// `render_surface`'s result: one image, or an array when `property` was an array; a blank
/// image of the asked size per property when the script is only planned. The render is noted
/// as the run's last, for the TUI's keys.
fn surface_images(
    h: &ScriptHost,
    field: SurfaceField,
    o: SurfaceOptions,
    many: bool,
) -> RResult<Dynamic> {
    let mut images = if h.plan_only {
        let img = HdrImage::new(o.width.unwrap_or(1), o.height.unwrap_or(1));
        vec![img; o.properties.len().max(1)]
    } else {
        field.render(&h.session, &o).map_err(to_rhai)?.to_vec()
    };
    if let Some(first) = images.first() {
        h.note_image(&Arc::new(first.clone()));
    }
    h.note_render(LastRender::Surface(LastSurfaceRender { field, options: o }));
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
}

/// `load_mesh` (two forms), the `Mesh` type's getters and `render_surface` of a mesh.
fn register_meshes(engine: &mut Engine, host: &Arc<ScriptHost>) {
    engine.register_type_with_name::<ScriptMesh>("Mesh");
    engine.register_get("name", |m: &mut ScriptMesh| m.name().to_string());
    engine.register_get("units", |m: &mut ScriptMesh| m.units().to_string());
    engine.register_get("cells", |m: &mut ScriptMesh| m.mesh().faces() as i64);
    engine.register_get("nodes", |m: &mut ScriptMesh| m.mesh().nodes() as i64);
    engine.register_get("kind", |m: &mut ScriptMesh| m.mesh().kind().to_string());
    engine.register_fn("describe", |m: &mut ScriptMesh| m.describe());
    let h = host.clone();
    engine.register_fn("load_mesh", move |path: &str| -> RResult<ScriptMesh> {
        let (p, variable) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
        let opts = LoadOptions {
            variable,
            ..LoadOptions::default()
        };
        h.session.load_mesh(&p, &opts).map_err(to_rhai)
    });
    let h = host.clone();
    engine.register_fn(
        "load_mesh",
        move |path: &str, opts: Map| -> RResult<ScriptMesh> {
            let given = LOAD_MESH.read(&opts)?;
            let (p, from_path) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
            let opts = LoadOptions {
                variable: variable_option(given.string("variable")?, from_path, "load_mesh")?,
                select: super::api_datasets::selection(&given)?,
                grid: match given.string("grid")? {
                    Some(g) => Some(h.sandbox.read_path(&g).map_err(to_rhai)?),
                    None => None,
                },
                ..LoadOptions::default()
            };
            h.session.load_mesh(&p, &opts).map_err(to_rhai)
        },
    );
    let h = host.clone();
    engine.register_fn(
        "render_surface",
        move |mesh: &mut ScriptMesh, opts: Map| -> RResult<Dynamic> {
            let extent = mesh_extent_grid(mesh).map_err(to_rhai)?;
            let (o, many) = render_surface_options(&extent, &opts)?;
            surface_images(&h, SurfaceField::Mesh(mesh.clone()), o, many)
        },
    );
}

/// `mean`, `min`, `max` or `std` (one of them) naming the dimension a grid is reduced over,
/// with `steps`.
fn reduce_over(given: &Given) -> RResult<Option<crate::datasets::ReduceOver>> {
    use crate::model::arithmetic::Reduction;
    let mut asked = Vec::new();
    for (key, how) in [
        ("mean", Reduction::Mean),
        ("min", Reduction::Min),
        ("max", Reduction::Max),
        ("std", Reduction::Std),
    ] {
        if let Some(dim) = given.string(key)? {
            asked.push((key, how, dim));
        }
    }
    let steps = match given.value("steps")? {
        Some(v) => {
            let [a, b] = pair(v, "steps")?;
            if !(a >= 0.0 && b >= a && a.fract() == 0.0 && b.fract() == 0.0) {
                return err(
                    "steps",
                    format!(
                        "expected [first, last] indices with 0 <= first <= last, got [{a}, {b}]"
                    ),
                );
            }
            Some((a as usize, b as usize))
        }
        None => None,
    };
    match asked.as_slice() {
        [] if steps.is_some() => err(
            "steps",
            "steps choose what mean, min, max or std reduce over",
        ),
        [] => Ok(None),
        [(_, how, dim)] => Ok(Some(crate::datasets::ReduceOver {
            dim: dim.clone(),
            how: *how,
            steps,
        })),
        [(a, ..), (b, ..), ..] => err(
            a,
            format!("one reduction per grid: {a} and {b} were both given"),
        ),
    }
}

/// The three forms of `load_grid`.
fn register_load_grid(engine: &mut Engine, host: &Arc<ScriptHost>) {
    let h = host.clone();
    engine.register_fn("load_grid", move |path: &str| -> RResult<ScriptGrid> {
        let (p, variable) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
        let opts = LoadOptions {
            variable,
            ..LoadOptions::default()
        };
        h.session.load_grid(&p, &opts).map_err(to_rhai)
    });
    let h = host.clone();
    engine.register_fn(
        "load_grid",
        move |path: &str, name: &str| -> RResult<ScriptGrid> {
            let p = h.sandbox.read_path(path).map_err(to_rhai)?;
            let opts = LoadOptions {
                variable: Some(name.to_string()),
                ..LoadOptions::default()
            };
            h.session.load_grid(&p, &opts).map_err(to_rhai)
        },
    );
    let h = host.clone();
    engine.register_fn(
        "load_grid",
        move |path: &str, opts: Map| -> RResult<ScriptGrid> {
            let given = LOAD_GRID.read(&opts)?;
            let (p, from_path) = h.sandbox.read_data_path(path).map_err(to_rhai)?;
            let opts = LoadOptions {
                variable: variable_option(given.string("variable")?, from_path, "load_grid")?,
                select: super::api_datasets::selection(&given)?,
                band: given.int("band")?.map(|b| b as usize),
                resolution: given.num("resolution")?,
                grid: match given.string("grid")? {
                    Some(g) => Some(h.sandbox.read_path(&g).map_err(to_rhai)?),
                    None => None,
                },
                reduce: reduce_over(&given)?,
                ..LoadOptions::default()
            };
            h.session.load_grid(&p, &opts).map_err(to_rhai)
        },
    );
}
