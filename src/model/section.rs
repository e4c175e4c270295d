//! Looking inside a volume: great-circle sections of a spherical volume and axis slices of a box,
//! each sampled into a [`Grid`] so that every surface mode (interference fringes, map frames,
//! colour bars, `save_grid`) works on it. Samples are trilinear in the volume's native index
//! space (radius, latitude, longitude for a shell), as the renderers sample it, with missing
//! voxels handled by a [`Missing`] rule. A section's grid has the distance along the arc at the
//! surface along x and the depth below the surface along y (both in the volume's length unit),
//! and keeps each column's latitude and longitude as the properties `latitude` and `longitude`.

use super::geometry::{Geometry, SphericalGrid};
use super::grid::{CoordKind, Grid, GridCoords};
use super::vec3::{cross, dot, norm, normalize};
use super::volume::{check_allocation, Missing, Volume};
use crate::error::{Error, Result};

/// Most nodes along either side of a section or slice: the grid's own limit.
pub(crate) const MAX_SECTION_SIDE: usize = 16384;

/// What `section(volume, #{...})` asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct SectionSpec {
    /// Start of the arc: latitude and longitude in degrees.
    pub from: [f64; 2],
    /// End of the arc.
    pub to: [f64; 2],
    /// Depths of the first and last rows below the planet's surface, in the volume's unit.
    pub depth: [f64; 2],
    /// Columns (points along the arc, ends included) and rows (depths, ends included).
    pub n: [usize; 2],
    pub missing: Missing,
}

/// A short great-circle arc: the unit vectors of its end points and the angle between them.
struct GreatArc {
    a: [f64; 3],
    b: [f64; 3],
    angle: f64,
}

impl GreatArc {
    /// The short arc from `from` to `to` (latitude, longitude in degrees); identical and
    /// antipodal end points have no unique great circle and are refused.
    fn new(from: [f64; 2], to: [f64; 2]) -> Result<GreatArc> {
        for (what, p) in [("from", from), ("to", to)] {
            if !(p[0].is_finite() && p[1].is_finite() && p[0].abs() <= 90.0) {
                return Err(Error::invalid(
                    format!("section {what}"),
                    format!(
                        "[{}, {}]; expected [latitude within ±90, longitude] in degrees",
                        p[0], p[1]
                    ),
                ));
            }
        }
        let a = SphericalGrid::to_world(1.0, from[0], from[1]);
        let b = SphericalGrid::to_world(1.0, to[0], to[1]);
        let sin = norm(cross(a, b));
        let cos = dot(a, b);
        // Below a nanoradian (6 mm on the Earth) the plane of the arc is not determined.
        if sin < 1e-9 {
            let what = if cos > 0.0 {
                "the same point"
            } else {
                "antipodal: every great circle joins them"
            };
            return Err(Error::invalid(
                "section",
                format!(
                    "from [{}, {}] and to [{}, {}] are {what}; expected two distinct, non-antipodal points",
                    from[0], from[1], to[0], to[1]
                ),
            ));
        }
        Ok(GreatArc {
            a,
            b,
            angle: sin.atan2(cos),
        })
    }

    /// The unit vector a fraction `t` of the way along the arc (spherical interpolation).
    fn at(&self, t: f64) -> [f64; 3] {
        let s = self.angle.sin();
        let wa = ((1.0 - t) * self.angle).sin() / s;
        let wb = (t * self.angle).sin() / s;
        normalize([0, 1, 2].map(|k| wa * self.a[k] + wb * self.b[k]))
    }
}

/// The great-circle section `spec` of the spherical volume `v`: `n[0]` columns evenly spaced
/// along the short arc from `from` to `to` (the first at `from`, the last at `to`) and `n[1]`
/// rows evenly spaced from `depth[0]` to `depth[1]`. Columns outside a wedge's latitudes or
/// longitudes are missing (NaN). Distances are measured along the arc at the planet's surface.
pub fn great_circle_section(v: &Volume, spec: &SectionSpec) -> Result<Grid> {
    let Geometry::Spherical(g) = &v.geometry else {
        return Err(Error::invalid(
            "section",
            format!(
                "{} is a {} volume (a box); sections follow great circles of spherical volumes: use slice(volume, #{{ axis, at }}) for boxes",
                v.name,
                v.geometry.name()
            ),
        ));
    };
    let [columns, rows] = check_counts(spec.n, "section n")?;
    let arc = GreatArc::new(spec.from, spec.to)?;
    let depth = check_depths(g, spec.depth)?;
    check_allocation((columns * rows * 3 * 8) as u64, "section n")?;
    let planet = g.planet_radius;
    let mid_radius = 0.5 * (g.radius.lo + g.radius.hi);
    let depths: Vec<f64> = (0..rows).map(|j| lerp(depth, j, rows)).collect();
    let mut distance = Vec::with_capacity(columns);
    let mut lats: Vec<f64> = Vec::with_capacity(columns);
    let mut lons: Vec<f64> = Vec::with_capacity(columns);
    let mut units = Vec::with_capacity(columns);
    for i in 0..columns {
        let t = i as f64 / (columns - 1) as f64;
        let u = match i {
            0 => arc.a,
            _ if i == columns - 1 => arc.b,
            _ => arc.at(t),
        };
        let (_, lat, lon) = SphericalGrid::from_world(u);
        // Longitudes continue from the previous column (no jump at the antimeridian), the
        // first one as the script wrote it.
        let lon = match lons.last() {
            None => spec.from[1],
            Some(&prev) => prev + (lon - prev + 180.0).rem_euclid(360.0) - 180.0,
        };
        distance.push(t * arc.angle * planet);
        lats.push(if i == 0 { spec.from[0] } else { lat });
        lons.push(lon);
        units.push(u);
    }
    let mut values = vec![f64::NAN; columns * rows];
    for (i, u) in units.iter().enumerate() {
        // A rotated-pole volume lies in its grid's frame: the true arc is turned into it (a
        // great circle stays one).
        let (inside, u) = match &g.rotated_pole {
            None => (SphericalGrid::to_world(mid_radius, lats[i], lons[i]), *u),
            Some(p) => {
                let ug = p.turn(*u);
                (ug.map(|c| c * mid_radius), ug)
            }
        };
        // The wedge test at a radius inside the shell: only the angles decide.
        if !g.contains(inside) {
            continue;
        }
        for (j, d) in depths.iter().enumerate() {
            let r = planet - d;
            values[j * columns + i] = v.sample_world_with(u.map(|c| c * r), spec.missing);
        }
    }
    let per_node = |col: &[f64]| -> Vec<f64> { (0..rows).flat_map(|_| col.to_vec()).collect() };
    let unit = g.length_unit.clone();
    let mut grid = Grid::with_coords(
        &v.name,
        GridCoords {
            name: "distance".into(),
            units: unit.clone(),
            values: distance,
            kind: CoordKind::Plain,
            edges: None,
        },
        GridCoords {
            name: "depth".into(),
            units: unit,
            values: depths,
            kind: CoordKind::Depth,
            edges: None,
        },
        vec![
            (property_name(v), values),
            ("latitude".into(), per_node(&lats)),
            ("longitude".into(), per_node(&lons)),
        ],
        None,
    )?;
    grid.set_units(&property_name(v), &v.units)?;
    grid.set_units("latitude", "degrees_north")?;
    grid.set_units("longitude", "degrees_east")?;
    Ok(grid)
}

/// The property a section or slice stores the volume's values under: its variable's name (the
/// name's first word: a loaded volume's name goes on to say how it was selected), or `value`.
fn property_name(v: &Volume) -> String {
    let name = v.name.split_whitespace().next().unwrap_or("");
    if name.is_empty() || name == "latitude" || name == "longitude" {
        "value".into()
    } else {
        name.to_string()
    }
}

/// The `k`-th of `n` values evenly spaced from `ends[0]` to `ends[1]`, ends exact.
fn lerp(ends: [f64; 2], k: usize, n: usize) -> f64 {
    if k + 1 == n {
        return ends[1];
    }
    let t = k as f64 / (n - 1) as f64;
    ends[0] + t * (ends[1] - ends[0])
}

/// Node counts of a section or plane slice: each from 2 to [`MAX_SECTION_SIDE`].
fn check_counts(n: [usize; 2], field: &str) -> Result<[usize; 2]> {
    if n.iter().any(|&k| !(2..=MAX_SECTION_SIDE).contains(&k)) {
        return Err(Error::invalid(
            field,
            format!(
                "[{}, {}]; expected [columns, rows], each 2 to {MAX_SECTION_SIDE}",
                n[0], n[1]
            ),
        ));
    }
    Ok(n)
}

/// The depth range of a section, checked against the shell's radii (depth = planet radius −
/// radius, in the volume's length unit).
fn check_depths(g: &SphericalGrid, depth: [f64; 2]) -> Result<[f64; 2]> {
    let top = g.planet_radius - g.radius.hi;
    let bottom = g.planet_radius - g.radius.lo;
    let unit = &g.length_unit;
    if !(depth[0].is_finite() && depth[1].is_finite()) || depth[0] == depth[1] {
        return Err(Error::invalid(
            "section depth",
            format!(
                "[{}, {}]; expected two different depths in {unit}",
                depth[0], depth[1]
            ),
        ));
    }
    // Rounding of a file's depths to radii and back is forgiven.
    let slack = 1e-9 * g.planet_radius.abs().max(1.0);
    let inside = |d: f64| d >= top - slack && d <= bottom + slack;
    if !(inside(depth[0]) && inside(depth[1])) {
        return Err(Error::invalid(
            "section depth",
            format!(
                "[{}, {}] {unit} reaches outside the volume, whose depths span [{top}, {bottom}] {unit}",
                depth[0], depth[1]
            ),
        ));
    }
    Ok(depth.map(|d| d.clamp(top, bottom)))
}

/// What `slice(volume, #{ axis, at })` asks for: the plane where world coordinate `axis`
/// (0 = x, 1 = y, 2 = z) equals `at`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SliceSpec {
    pub axis: usize,
    pub at: f64,
    pub missing: Missing,
}

/// The axis slice `spec` of the box volume `v`: a grid on the voxel centres of the two other
/// axes (x then y, x then z, or y then z), each node trilinear at coordinate `at` along the
/// sliced axis (exactly the voxels when `at` is a voxel centre).
pub(crate) fn axis_slice(v: &Volume, spec: &SliceSpec) -> Result<Grid> {
    let axes = ["x", "y", "z"];
    if matches!(v.geometry, Geometry::Spherical(_)) {
        return Err(Error::invalid(
            "slice",
            format!(
                "{} is a spherical volume; slices are planes of boxes: use section(volume, #{{ from, to, depth, n }})",
                v.name
            ),
        ));
    }
    let b = v.bounds();
    let a = spec.axis;
    if !(spec.at.is_finite() && spec.at >= b.lo[a] && spec.at <= b.hi[a]) {
        return Err(Error::invalid(
            "slice at",
            format!(
                "{} lies outside the volume, whose {} spans [{}, {}]",
                spec.at, axes[a], b.lo[a], b.hi[a]
            ),
        ));
    }
    let centres = |k: usize| -> Vec<f64> {
        match &v.geometry {
            Geometry::Rectilinear(c) => c[k].centres.clone(),
            _ => (0..v.dims[k])
                .map(|i| v.origin[k] + (i as f64 + 0.5) * v.spacing[k])
                .collect(),
        }
    };
    let (p, q) = match a {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let (cp, cq) = (centres(p), centres(q));
    let mut values = Vec::with_capacity(cp.len() * cq.len());
    for &y in &cq {
        for &x in &cp {
            let mut w = [0.0; 3];
            w[a] = spec.at;
            w[p] = x;
            w[q] = y;
            values.push(v.sample_world_with(w, spec.missing));
        }
    }
    let coords = |k: usize, values: Vec<f64>| GridCoords {
        name: axes[k].into(),
        units: String::new(),
        values,
        kind: CoordKind::Plain,
        edges: None,
    };
    let mut grid = Grid::with_coords(
        &v.name,
        coords(p, cp),
        coords(q, cq),
        vec![(property_name(v), values)],
        None,
    )?;
    grid.set_units(&property_name(v), &v.units)?;
    Ok(grid)
}

/// What `slice(volume, #{ origin, normal, n })` asks for: a plane of any orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PlaneSpec {
    pub origin: [f64; 3],
    pub normal: [f64; 3],
    /// Nodes along u and along v.
    pub n: [usize; 2],
    pub missing: Missing,
}

/// The plane `spec` through the box volume `v`: `n[0]` × `n[1]` nodes evenly spaced over the
/// plane's part within the box's bounding box, on in-plane axes u (the world axis least aligned
/// with the normal, made perpendicular to it) and v = normal × u, measured from `origin` in
/// world units. Nodes outside the box are missing.
pub(crate) fn plane_slice(v: &Volume, spec: &PlaneSpec) -> Result<Grid> {
    if matches!(v.geometry, Geometry::Spherical(_)) {
        return axis_slice(
            v,
            &SliceSpec {
                axis: 0,
                at: 0.0,
                missing: spec.missing,
            },
        );
    }
    let [nu, nv] = check_counts(spec.n, "slice n")?;
    let len = norm(spec.normal);
    if !(len.is_finite() && len > 0.0) || spec.origin.iter().any(|c| !c.is_finite()) {
        return Err(Error::invalid(
            "slice",
            format!(
                "origin {:?} and normal {:?}: expected finite coordinates and a non-zero normal",
                spec.origin, spec.normal
            ),
        ));
    }
    let n = normalize(spec.normal);
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let u = normalize([0, 1, 2].map(|a| e[a] - dot(e, n) * n[a]));
    let w = cross(n, u);
    let b = v.bounds();
    let corners: Vec<[f64; 3]> = (0..8)
        .map(|c| {
            [0, 1, 2].map(|a| if c >> a & 1 == 1 { b.hi[a] } else { b.lo[a] } - spec.origin[a])
        })
        .collect();
    let along = |axis: [f64; 3]| {
        let s: Vec<f64> = corners.iter().map(|c| dot(*c, axis)).collect();
        let lo = s.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = s.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        [lo, hi]
    };
    let [dlo, dhi] = along(n);
    if dlo > 0.0 || dhi < 0.0 {
        return Err(Error::invalid(
            "slice",
            format!(
                "the plane through {:?} with normal {:?} misses the volume's box {:?} to {:?}",
                spec.origin, spec.normal, b.lo, b.hi
            ),
        ));
    }
    let us: Vec<f64> = (0..nu).map(|i| lerp(along(u), i, nu)).collect();
    let vs: Vec<f64> = (0..nv).map(|j| lerp(along(w), j, nv)).collect();
    check_allocation((nu * nv * 8) as u64, "slice n")?;
    let slack = 1e-12 * b.diagonal();
    let mut values = Vec::with_capacity(nu * nv);
    for &y in &vs {
        for &x in &us {
            let p = [0, 1, 2].map(|a| spec.origin[a] + x * u[a] + y * w[a]);
            let inside = (0..3).all(|a| p[a] >= b.lo[a] - slack && p[a] <= b.hi[a] + slack);
            values.push(if inside {
                v.sample_world_with(p, spec.missing)
            } else {
                f64::NAN
            });
        }
    }
    let coords = |name: &str, values: Vec<f64>| GridCoords {
        name: name.into(),
        units: String::new(),
        values,
        kind: CoordKind::Plain,
        edges: None,
    };
    let mut grid = Grid::with_coords(
        &v.name,
        coords("u", us),
        coords("v", vs),
        vec![(property_name(v), values)],
        None,
    )?;
    grid.set_units(&property_name(v), &v.units)?;
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::CoordAxis;

    const R: f64 = 6371.0;

    /// The field linear in depth, latitude and longitude that the sections must reproduce.
    fn field(depth: f64, lat: f64, lon: f64) -> f64 {
        100.0 + 0.01 * depth + 0.5 * lat - 0.25 * lon
    }

    /// A global shell on uneven depths from 0 to 2800 km and a 2° grid (lon from −180), axes
    /// stored (depth slowest, latitude, longitude fastest), holding [`field`].
    fn shell() -> Volume {
        let depths: Vec<f64> = (0..12)
            .map(|k| 2800.0 * (k as f64 / 11.0).powi(2))
            .collect();
        let radius = CoordAxis::new(depths.iter().map(|d| R - d).collect(), None, "r").unwrap();
        let lat = CoordAxis::uniform_cells(-90.0, 2.0, 90);
        let lon = CoordAxis::uniform_cells(-180.0, 2.0, 180);
        let mut data = Vec::new();
        for d in &depths {
            for la in &lat.centres {
                for lo in &lon.centres {
                    data.push(field(*d, *la, *lo) as f32);
                }
            }
        }
        let g = SphericalGrid {
            axis_of: [2, 1, 0],
            radius,
            latitude: lat,
            longitude: lon,
            lon_wraps: true,
            planet_radius: R,
            length_unit: "km".into(),
            vertical: "depth".into(),
            rotated_pole: None,
        };
        Volume::new("dvs", [180, 90, 12], [1.0; 3], [0.0; 3], data)
            .unwrap()
            .with_geometry(Geometry::Spherical(Box::new(g)))
            .unwrap()
    }

    fn spec(from: [f64; 2], to: [f64; 2]) -> SectionSpec {
        SectionSpec {
            from,
            to,
            depth: [50.0, 2700.0],
            n: [61, 23],
            missing: Missing::Strict,
        }
    }

    #[test]
    fn a_linear_field_is_reproduced_on_the_great_circle() {
        let v = shell();
        let s = spec([10.0, -40.0], [50.0, 60.0]);
        let g = great_circle_section(&v, &s).unwrap();
        assert_eq!((g.nx(), g.ny()), (61, 23));
        let (value, lat, lon) = (
            g.property("dvs").unwrap(),
            g.property("latitude").unwrap(),
            g.property("longitude").unwrap(),
        );
        let a = SphericalGrid::to_world(1.0, 10.0, -40.0);
        let b = SphericalGrid::to_world(1.0, 50.0, 60.0);
        let pole = normalize(cross(a, b));
        let angle = norm(cross(a, b)).atan2(dot(a, b));
        for j in 0..g.ny() {
            let depth = g.y().values[j];
            for i in 0..g.nx() {
                let k = j * g.nx() + i;
                let want = field(depth, lat[k], lon[k]);
                assert!(
                    ((value[k] - want) / want).abs() < 1e-5,
                    "node ({i}, {j}): {} vs {want}",
                    value[k]
                );
                let u = SphericalGrid::to_world(1.0, lat[k], lon[k]);
                assert!(dot(u, pole).abs() < 1e-6, "node {i} off the great circle");
                // Distance along the arc: the angle from `from` times the planet's radius.
                let from_a = norm(cross(a, u)).atan2(dot(a, u));
                assert!((from_a * R - g.x().values[i]).abs() < 1e-6 * R);
            }
        }
        assert!((g.x().values[60] - angle * R).abs() < 1e-9 * R);
        assert_eq!((g.y().values[0], g.y().values[22]), (50.0, 2700.0));
        assert!((lat[0] - 10.0).abs() < 1e-9 && (lon[0] + 40.0).abs() < 1e-9);
        assert!((lat[60] - 50.0).abs() < 1e-9 && (lon[60] - 60.0).abs() < 1e-9);
    }

    #[test]
    fn longitudes_continue_across_the_antimeridian() {
        let g = great_circle_section(&shell(), &spec([0.0, 170.0], [0.0, -170.0])).unwrap();
        let lon = g.property("longitude").unwrap();
        assert!((lon[0] - 170.0).abs() < 1e-12 && (lon[60] - 190.0).abs() < 1e-9);
        assert!(lon.windows(2).take(60).all(|w| w[1] > w[0]));
        assert!((g.x().values[60] - 20f64.to_radians() * R).abs() < 1e-6);
    }

    #[test]
    fn bad_sections_are_one_line_errors() {
        let v = shell();
        let e = |s: &SectionSpec| great_circle_section(&v, s).unwrap_err().to_string();
        let msg = e(&spec([10.0, 20.0], [10.0, 20.0]));
        assert!(msg.contains("the same point"), "{msg}");
        let msg = e(&spec([10.0, 20.0], [-10.0, -160.0]));
        assert!(msg.contains("antipodal"), "{msg}");
        let mut deep = spec([0.0, 0.0], [10.0, 10.0]);
        deep.depth = [0.0, 3000.0];
        let msg = e(&deep);
        assert!(
            msg.contains("section depth") && msg.contains("[0, 2800] km"),
            "{msg}"
        );
        let mut none = spec([0.0, 0.0], [10.0, 10.0]);
        none.n = [0, 5];
        assert!(e(&none).contains("section n: [0, 5]"));
        let boxed = Volume::from_fn("b", [4, 4, 4], |x, _, _| x).unwrap();
        let msg = great_circle_section(&boxed, &spec([0.0, 0.0], [1.0, 1.0]))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("cartesian") && msg.contains("slice"), "{msg}");
        assert!(msg.lines().count() == 1);
    }

    #[test]
    fn axis_slices_interpolate_along_the_cut_axis_only() {
        let v = Volume::from_fn("ramp", [5, 6, 7], |x, y, z| 2.0 * x - y + 0.5 * z).unwrap();
        let g = axis_slice(
            &v,
            &SliceSpec {
                axis: 1,
                at: 2.3,
                missing: Missing::Strict,
            },
        )
        .unwrap();
        assert_eq!((g.nx(), g.ny()), (5, 7));
        assert_eq!((g.x().name.as_str(), g.y().name.as_str()), ("x", "z"));
        let vals = g.property("ramp").unwrap();
        for (k, z) in g.y().values.iter().enumerate() {
            for (i, x) in g.x().values.iter().enumerate() {
                let want = 2.0 * x - 2.3 + 0.5 * z;
                assert!((vals[k * 5 + i] - want).abs() < 1e-5);
            }
        }
        let e = axis_slice(
            &v,
            &SliceSpec {
                axis: 2,
                at: 7.5,
                missing: Missing::Strict,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("slice at: 7.5") && e.contains("[0, 7]"), "{e}");
        let e = axis_slice(
            &shell(),
            &SliceSpec {
                axis: 0,
                at: 0.0,
                missing: Missing::Strict,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("spherical") && e.contains("section("), "{e}");
    }

    #[test]
    fn oblique_planes_sample_the_field_at_their_nodes() {
        let f = |x: f64, y: f64, z: f64| 2.0 * x - y + 0.5 * z;
        let v = Volume::from_fn("ramp", [5, 6, 7], f).unwrap();
        let spec = PlaneSpec {
            origin: [2.5, 3.0, 3.5],
            normal: [1.0, 1.0, 1.0],
            n: [40, 30],
            missing: Missing::Strict,
        };
        let g = plane_slice(&v, &spec).unwrap();
        let n = normalize(spec.normal);
        // u: the x axis (least aligned, first of the tie) made perpendicular to n; v = n × u.
        let u = normalize([1.0 - n[0] * n[0], -n[0] * n[1], -n[0] * n[2]]);
        let w = cross(n, u);
        let vals = g.property("ramp").unwrap();
        let mut finite = 0;
        for (j, b) in g.y().values.iter().enumerate() {
            for (i, a) in g.x().values.iter().enumerate() {
                let p = [0, 1, 2].map(|k| spec.origin[k] + a * u[k] + b * w[k]);
                let inside = (0..3).all(|k| p[k] >= 0.0 && p[k] <= [5.0, 6.0, 7.0][k]);
                let got = vals[j * 40 + i];
                if !inside {
                    assert!(got.is_nan());
                    continue;
                }
                assert!(got.is_finite());
                // Within half a voxel of a face the clamped edge is not the linear field.
                if (0..3).all(|k| p[k] >= 0.5 && p[k] <= [4.5, 5.5, 6.5][k]) {
                    finite += 1;
                    assert!((got - f(p[0], p[1], p[2])).abs() < 1e-5, "({i}, {j})");
                }
            }
        }
        assert!(finite > 300, "{finite}");
        let mut far = spec;
        far.origin = [50.0, 50.0, 50.0];
        let e = plane_slice(&v, &far).unwrap_err().to_string();
        assert!(e.contains("misses the volume"), "{e}");
    }

    #[test]
    fn renormalised_missing_voxels_change_only_their_cells() {
        // A smooth field with one missing voxel at (5, 4, 3).
        let f = |x: f64, y: f64, z: f64| (0.3 * x).sin() + (0.2 * y).cos() * z;
        let clean = Volume::from_fn("f", [10, 9, 8], f).unwrap();
        let mut holed = clean.clone();
        let hole = holed.index(5, 4, 3);
        holed.data[hole] = f32::NAN;
        let true_value = clean.data[hole] as f64;
        let (mut changed, mut strict_missing) = (0, 0);
        for k in 0..35 {
            for j in 0..40 {
                for i in 0..45 {
                    let p = [0.22 * i as f64, 0.226 * j as f64, 0.234 * k as f64];
                    let reference = clean.sample_world(p);
                    let renorm = holed.sample_world_with(p, Missing::Renormalise);
                    strict_missing += holed.sample_world(p).is_nan() as usize;
                    // The hole's centre is (5.5, 4.5, 3.5): its cells span one voxel each way.
                    let weight: f64 = [(p[0], 5.5), (p[1], 4.5), (p[2], 3.5)]
                        .iter()
                        .map(|(c, h)| (1.0 - (c - h).abs()).max(0.0))
                        .product();
                    if weight == 0.0 {
                        assert_eq!(renorm.to_bits(), reference.to_bits(), "at {p:?}");
                        continue;
                    }
                    changed += 1;
                    // The closed form of the renormalised value's difference.
                    let expect = weight * (true_value - renorm);
                    assert!(
                        (reference - renorm - expect).abs() < 1e-9,
                        "at {p:?}: {reference} vs {renorm}"
                    );
                }
            }
        }
        assert!(changed > 0 && strict_missing >= changed);
        // At the missing voxel's centre every weight is on it.
        assert!(holed
            .sample_world_with([5.5, 4.5, 3.5], Missing::Renormalise)
            .is_nan());
    }
}
