//! Cut-aways of spherical volumes: the region where every given range of latitude, longitude and
//! depth holds is removed from a render (one range: a hemisphere, a band or a shell; two or
//! three: a wedge). Rays are clipped analytically: the cut's boundaries — latitude cones,
//! longitude half-planes and depth spheres — are more crossings of the ray, and a piece between
//! crossings is drawn when its middle lies in the domain and outside the cut, as
//! [`SphericalGrid::ray_intervals`] does for the domain alone. Boxes (regular and rectilinear)
//! take world ranges of x, y and z and half-spaces bounded by planes instead: the removed region
//! is their intersection, convex, so a ray crosses it in one piece (the slab method, a plane being
//! one more slab open on one side), taken out of the ray's piece inside the volume
//! ([`Cut::clip_box`]).
//! The faces a cut opens may show the field as an opaque surface ([`CutFaces`]).

use super::geometry::{cone_hits, sphere_hit, SphericalGrid};
use super::vec3::dot;
use super::Aabb;
use crate::error::{Error, Result};

/// The removed region: the points whose latitude, longitude and depth (spherical volumes), or
/// world x, y and z (boxes), lie in every given range and, on boxes, on the removed side of
/// every plane (absent ranges hold everywhere; at least one range or plane is given).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cut {
    /// World x, y and z ranges `lo < hi` of a box's cut.
    pub x: Option<[f64; 2]>,
    pub y: Option<[f64; 2]>,
    pub z: Option<[f64; 2]>,
    /// Half-spaces of a box's cut (at most [`MAX_CUT_PLANES`]).
    pub planes: Vec<CutPlane>,
    /// Degrees north, `lo < hi` within ±90.
    pub lat: Option<[f64; 2]>,
    /// Degrees east, from `lo` eastward to `hi` (`lo < hi`, at most a turn apart).
    pub lon: Option<[f64; 2]>,
    /// Depths below the surface (planet radius − radius), in the volume's length unit, `lo < hi`.
    pub depth: Option<[f64; 2]>,
}

/// A plane of a box's cut: the side its normal points to (boundary included) is removed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutPlane {
    /// A point on the plane, in world coordinates.
    pub point: [f64; 3],
    /// The plane's normal, towards the removed side (any non-zero length).
    pub normal: [f64; 3],
}

/// The most planes one cut takes (the shaders' fixed uniform slots).
pub const MAX_CUT_PLANES: usize = 3;

impl CutPlane {
    /// The unit normal `n` and offset `c` of the removed half-space `n·p ≥ c`, for points `p`
    /// relative to `corner`.
    pub(crate) fn in_frame(&self, corner: [f64; 3]) -> ([f64; 3], f64) {
        let len = self.normal.iter().map(|c| c * c).sum::<f64>().sqrt();
        let n = self.normal.map(|c| c / len);
        let c = (0..3).map(|a| n[a] * (self.point[a] - corner[a])).sum();
        (n, c)
    }
}

/// How the faces a cut-away opens are drawn (`cut_faces`): where a ray enters the kept volume
/// from the removed region, the field there as an opaque surface whose radiance is that of a
/// thick layer of its value under the transfer function, emission over extinction (e / σ: the
/// colour the volume itself takes where it is thick), times the interference intensity
/// 1 + cos(2πν·value) with `nu`. A face whose value absorbs nothing (σ = 0, or missing) is not
/// drawn: the ray goes on through it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CutFaces {
    /// Fringes per unit of the value.
    pub nu: Option<f64>,
    /// Lines on the faces of a spherical volume where they meet these depths.
    pub depth_rings: Option<DepthRings>,
}

/// The depths of the rings on a spherical volume's cut faces, drawn as dark lines.
#[derive(Clone, Debug, PartialEq)]
pub enum DepthRings {
    /// The mantle's discontinuities at 410 and 660 km and the core–mantle boundary at 2891 km.
    Earth,
    /// Depths in the volume's length unit (at most [`MAX_RINGS`]).
    Depths(Vec<f64>),
}

impl DepthRings {
    /// The Earth's ring depths (410, 660 and 2891 km) in a length unit written `km` or `m`;
    /// `None` for any other unit.
    pub(crate) fn earth_in(unit: &str) -> Option<[f64; 3]> {
        let per_km = match unit {
            "km" => 1.0,
            "m" => 1e3,
            _ => return None,
        };
        Some([410.0, 660.0, 2891.0].map(|d| d * per_km))
    }
}

/// Rings one render draws at most.
pub const MAX_RINGS: usize = 4;
/// A ring's line, in pixels at the volume's centre.
const RING_WIDTH_PX: f64 = 1.5;

/// How far before a part's start, in voxel lengths, a point is tested for lying in the removed
/// region (whether the part starts on a face of the cut): far beyond f32 rounding of a ray's
/// parameter, well within a voxel.
pub(crate) const FACE_PROBE: f64 = 1e-2;

impl CutFaces {
    /// The radii of the depth rings on `volume` (spherical) and the half width of their lines
    /// in world units: half of [`RING_WIDTH_PX`] pixels at the volume's centre in the view of
    /// `camera` `height` pixels high. An error naming the option for a box, a depth outside the
    /// volume's planet or too many rings.
    pub(crate) fn rings(
        &self,
        volume: &super::Volume,
        camera: &super::Camera,
        height: u32,
    ) -> Result<(Vec<f64>, f64)> {
        let field = "cut_faces depth_rings";
        let Some(rings) = &self.depth_rings else {
            return Ok((Vec::new(), 0.0));
        };
        let super::Geometry::Spherical(g) = &volume.geometry else {
            return Err(Error::invalid(
                field,
                format!(
                    "rings are drawn at depths of spherical volumes; {} is a box",
                    volume.name
                ),
            ));
        };
        let depths = match rings {
            DepthRings::Depths(d) => d.clone(),
            DepthRings::Earth => DepthRings::earth_in(&g.length_unit)
                .ok_or_else(|| {
                    Error::invalid(
                        field,
                        format!(
                            "the Earth's rings need a volume in km or m, not {:?}; give the depths",
                            g.length_unit
                        ),
                    )
                })?
                .to_vec(),
        };
        if depths.is_empty() || depths.len() > MAX_RINGS {
            return Err(Error::invalid(
                field,
                format!("expected 1 to {MAX_RINGS} depths, got {}", depths.len()),
            ));
        }
        let r = g.planet_radius;
        if let Some(d) = depths
            .iter()
            .find(|d| !(d.is_finite() && **d > 0.0 && **d < r))
        {
            return Err(Error::invalid(
                field,
                format!(
                    "depth {d} is not inside the planet (0 to {r} {})",
                    g.length_unit
                ),
            ));
        }
        let pixel = match camera.projection {
            super::Projection::Orthographic { half_height, .. } => 2.0 * half_height,
            super::Projection::Perspective { fov_y_deg } => {
                let c = volume.bounds().center();
                let d = (0..3)
                    .map(|a| (c[a] - camera.eye[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                2.0 * d * (0.5 * fov_y_deg).to_radians().tan()
            }
        } / f64::from(height);
        Ok((
            depths.iter().map(|d| r - d).collect(),
            0.5 * RING_WIDTH_PX * pixel,
        ))
    }

    /// The radiance of a face of value `v` whose transfer is emission `e` and extinction `a`
    /// (per voxel length), or `None` where it is not drawn.
    pub(crate) fn radiance(&self, v: f64, e: [f64; 3], a: f64) -> Option<[f64; 3]> {
        if !(v.is_finite() && a > 0.0) {
            return None;
        }
        let fringe = self
            .nu
            .map_or(1.0, |nu| 1.0 + (std::f64::consts::TAU * nu * v).cos());
        Some(e.map(|c| c / a * fringe))
    }
}

impl Cut {
    /// Whether the world point `p` lies in a box's removed region.
    pub(crate) fn removes_box(&self, p: [f64; 3]) -> bool {
        let r = self.box_ranges();
        (0..3).all(|a| p[a] >= r[a][0] && p[a] <= r[a][1])
            && self.planes.iter().all(|plane| {
                let (n, c) = plane.in_frame([0.0; 3]);
                dot(n, p) >= c
            })
    }

    /// Checks the ranges on their own and against the shell `g`: a cut that removes the whole
    /// volume is refused.
    pub fn check(&self, g: &SphericalGrid) -> Result<()> {
        let bad = |name: &str, r: [f64; 2], expected: &str| {
            Err(Error::invalid(
                format!("cut {name}"),
                format!("[{}, {}]; expected {expected}", r[0], r[1]),
            ))
        };
        let ordered = |r: [f64; 2]| r[0].is_finite() && r[1].is_finite() && r[0] < r[1];
        if self.x.is_some() || self.y.is_some() || self.z.is_some() || !self.planes.is_empty() {
            return Err(Error::invalid(
                "cut",
                format!(
                    "x, y, z and planes cut boxes; the spherical volume ({g}) takes lat, lon and depth"
                ),
            ));
        }
        if self.lat.is_none() && self.lon.is_none() && self.depth.is_none() {
            return Err(Error::invalid(
                "cut",
                "expected at least one of lat, lon, depth",
            ));
        }
        if let Some(r) = self
            .lat
            .filter(|r| !ordered(*r) || r[0] < -90.0 || r[1] > 90.0)
        {
            return bad("lat", r, "[south, north] within ±90 degrees, south < north");
        }
        if let Some(r) = self.lon.filter(|r| !ordered(*r) || r[1] - r[0] > 360.0) {
            return bad(
                "lon",
                r,
                "[west, east] in degrees, west < east, at most 360 apart",
            );
        }
        if let Some(r) = self.depth.filter(|r| !ordered(*r)) {
            return bad("depth", r, "[top, bottom], top < bottom");
        }
        let covers = |range: Option<[f64; 2]>, lo: f64, hi: f64| {
            range.is_none_or(|r| r[0] <= lo && r[1] >= hi)
        };
        let lon_covers = self.lon.is_none_or(|r| {
            r[1] - r[0] >= 360.0
                || (!g.lon_wraps && {
                    let lo = r[0] + (g.longitude.lo - r[0]).rem_euclid(360.0);
                    lo + (g.longitude.hi - g.longitude.lo) <= r[1]
                })
        });
        let (top, bottom) = (g.planet_radius - g.radius.hi, g.planet_radius - g.radius.lo);
        if covers(self.lat, g.latitude.lo, g.latitude.hi)
            && lon_covers
            && covers(self.depth, top, bottom)
        {
            return Err(Error::invalid(
                "cut",
                format!("removes the whole volume ({g}); expected ranges that leave part of it"),
            ));
        }
        Ok(())
    }

    /// The world ranges of a box's cut, absent ones unbounded.
    fn box_ranges(&self) -> [[f64; 2]; 3] {
        let all = [f64::NEG_INFINITY, f64::INFINITY];
        [self.x, self.y, self.z].map(|r| r.unwrap_or(all))
    }

    /// Checks a box's cut against the box `bounds`: x, y, z only, each ordered, and leaving part
    /// of the box.
    pub(crate) fn check_box(&self, name: &str, bounds: &Aabb) -> Result<()> {
        if self.lat.is_some() || self.lon.is_some() || self.depth.is_some() {
            return Err(Error::invalid(
                "cut",
                format!("{name} is a box; its cut takes world ranges x, y, z (lat, lon and depth cut spherical volumes)"),
            ));
        }
        if self.x.is_none() && self.y.is_none() && self.z.is_none() && self.planes.is_empty() {
            return Err(Error::invalid(
                "cut",
                "expected at least one of x, y, z, plane",
            ));
        }
        for (axis, r) in ["x", "y", "z"].into_iter().zip([self.x, self.y, self.z]) {
            if let Some(r) = r.filter(|r| !(r[0].is_finite() && r[1].is_finite() && r[0] < r[1])) {
                return Err(Error::invalid(
                    format!("cut {axis}"),
                    format!(
                        "[{}, {}]; expected [lo, hi] in world units, lo < hi",
                        r[0], r[1]
                    ),
                ));
            }
        }
        self.check_planes()?;
        // The removed region is convex: it holds the box when it holds the box's corners.
        let corners = (0..8).map(|i| {
            [0, 1, 2].map(|a| {
                if i >> a & 1 == 0 {
                    bounds.lo[a]
                } else {
                    bounds.hi[a]
                }
            })
        });
        if corners.into_iter().all(|p| self.removes_box(p)) {
            return Err(Error::invalid(
                "cut",
                format!(
                    "removes the whole volume ({name}: x {}..{}, y {}..{}, z {}..{}); expected ranges that leave part of it",
                    bounds.lo[0], bounds.hi[0], bounds.lo[1], bounds.hi[1], bounds.lo[2], bounds.hi[2]
                ),
            ));
        }
        Ok(())
    }

    /// Checks the planes: at most [`MAX_CUT_PLANES`], finite points and finite non-zero normals.
    fn check_planes(&self) -> Result<()> {
        if self.planes.len() > MAX_CUT_PLANES {
            return Err(Error::invalid(
                "cut plane",
                format!(
                    "{} planes; expected at most {MAX_CUT_PLANES}",
                    self.planes.len()
                ),
            ));
        }
        for p in &self.planes {
            let finite = p.point.iter().chain(&p.normal).all(|c| c.is_finite());
            if !finite || p.normal.iter().all(|c| *c == 0.0) {
                return Err(Error::invalid(
                    "cut plane",
                    format!(
                        "point {:?}, normal {:?}; expected a finite point and a finite non-zero normal",
                        p.point, p.normal
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The planes' removed half-spaces `n·p ≥ c` for points relative to `corner`, as `[n, c]`
    /// rows, the unused of [`MAX_CUT_PLANES`] slots `[0, 0, 0, −1]` (which every point satisfies).
    pub(crate) fn planes_in_frame(&self, corner: [f64; 3]) -> [[f64; 4]; MAX_CUT_PLANES] {
        let mut out = [[0.0, 0.0, 0.0, -1.0]; MAX_CUT_PLANES];
        for (row, plane) in out.iter_mut().zip(&self.planes) {
            let (n, c) = plane.in_frame(corner);
            *row = [n[0], n[1], n[2], c];
        }
        out
    }

    /// The removed box's lower and upper corners relative to `corner` (a box's frame in the
    /// shaders), an absent range spanning 1e30 each way: far beyond any volume, and finite, so
    /// the slab method's quotients are.
    pub(crate) fn box_in_frame(&self, corner: [f64; 3]) -> [[f64; 3]; 2] {
        let mut out = [[-1e30; 3], [1e30; 3]];
        for (a, r) in [self.x, self.y, self.z].into_iter().enumerate() {
            if let Some([lo, hi]) = r {
                (out[0][a], out[1][a]) = (lo - corner[a], hi - corner[a]);
            }
        }
        out
    }

    /// The pieces of the ray `o + t·d` over `[t0, t1]` (its piece inside a box) that lie outside
    /// a box's cut: the piece less the ray's piece inside the cut (slab method, each plane a slab
    /// open on one side; a ray parallel to a slab is inside it or misses it), so none, one or two
    /// pieces.
    pub(crate) fn clip_box(
        &self,
        o: [f64; 3],
        d: [f64; 3],
        (t0, t1): (f64, f64),
    ) -> Vec<(f64, f64)> {
        let ranges = self.box_ranges();
        let (mut c0, mut c1) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            let [lo, hi] = ranges[a];
            if d[a] == 0.0 {
                if o[a] < lo || o[a] > hi {
                    return vec![(t0, t1)];
                }
                continue;
            }
            let (ta, tb) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
            c0 = c0.max(ta.min(tb));
            c1 = c1.min(ta.max(tb));
        }
        for plane in &self.planes {
            // n·(o + t·d) ≥ c: from a crossing on when the ray heads into the removed side,
            // up to it when it heads out, always or never when it runs along the plane.
            let (n, c) = plane.in_frame([0.0; 3]);
            let (no, nd) = (dot(n, o), dot(n, d));
            if nd == 0.0 {
                if no < c {
                    return vec![(t0, t1)];
                }
            } else if nd > 0.0 {
                c0 = c0.max((c - no) / nd);
            } else {
                c1 = c1.min((c - no) / nd);
            }
        }
        if c1 <= c0 {
            return vec![(t0, t1)];
        }
        [(t0, c0.min(t1)), (c1.max(t0), t1)]
            .into_iter()
            .filter(|(a, b)| b > a)
            .collect()
    }

    /// The radii of the depth range, `[inner, outer]`.
    pub(crate) fn radii(&self, planet_radius: f64) -> Option<[f64; 2]> {
        self.depth
            .map(|d| [planet_radius - d[1], planet_radius - d[0]])
    }

    /// Whether the world point `p` lies in the removed region.
    pub(crate) fn removes(&self, planet_radius: f64, p: [f64; 3]) -> bool {
        let (r, lat, lon) = SphericalGrid::from_world(p);
        self.lat.is_none_or(|[a, b]| lat >= a && lat <= b)
            && self
                .lon
                .is_none_or(|[a, b]| (lon - a).rem_euclid(360.0) <= b - a)
            && self
                .radii(planet_radius)
                .is_none_or(|[a, b]| r >= a && r <= b)
    }

    /// Where the ray `o + t·d` crosses the cut's boundaries (both nappes of each cone and both
    /// halves of each longitude plane: extra crossings only split a piece).
    pub(crate) fn crossings(&self, planet_radius: f64, o: [f64; 3], d: [f64; 3]) -> Vec<f64> {
        let mut t = Vec::new();
        for lat in self.lat.into_iter().flatten() {
            if lat == 0.0 {
                // The equator's "cone" is the plane z = 0, whose double root rounding can lose.
                t.push(-o[2] / d[2]);
            } else if lat.abs() < 90.0 {
                t.extend(cone_hits(o, d, lat));
            }
        }
        for lon in self.lon.into_iter().flatten() {
            let (s, c) = lon.to_radians().sin_cos();
            let (no, nd) = (-s * o[0] + c * o[1], -s * d[0] + c * d[1]);
            if nd != 0.0 {
                t.push(-no / nd);
            }
        }
        for r in self.radii(planet_radius).into_iter().flatten() {
            if r > 0.0 {
                if let Some((a, b)) = sphere_hit(o, d, r) {
                    t.extend([a, b]);
                }
            }
        }
        t
    }
}

/// Rays through a shell less what a cut removes, beside the shell's own crossings.
impl SphericalGrid {
    /// [`Self::ray_intervals`] less the region `cut` removes: its boundaries are more crossings,
    /// and a piece whose middle it removes is left out.
    pub(crate) fn ray_intervals_cut(
        &self,
        o: [f64; 3],
        d: [f64; 3],
        cut: Option<&Cut>,
    ) -> Vec<(f64, f64)> {
        let Some((t0, t1)) = sphere_hit(o, d, self.radius.hi) else {
            return Vec::new();
        };
        let (t0, t1) = (t0.max(0.0), t1);
        if t1 <= t0 {
            return Vec::new();
        }
        let mut cuts = vec![t0, t1];
        if self.radius.lo > 0.0 {
            if let Some((a, b)) = sphere_hit(o, d, self.radius.lo) {
                cuts.extend([a, b]);
            }
        }
        for lat in [self.latitude.lo, self.latitude.hi] {
            if lat.abs() < 90.0 {
                cuts.extend(cone_hits(o, d, lat));
            }
        }
        if !self.lon_wraps {
            for lon in [self.longitude.lo, self.longitude.hi] {
                let (s, c) = lon.to_radians().sin_cos();
                let (no, nd) = (-s * o[0] + c * o[1], -s * d[0] + c * d[1]);
                if nd != 0.0 {
                    cuts.push(-no / nd);
                }
            }
        }
        if let Some(c) = cut {
            cuts.extend(c.crossings(self.planet_radius, o, d));
        }
        cuts.retain(|t| t.is_finite() && *t >= t0 && *t <= t1);
        cuts.sort_by(f64::total_cmp);
        let mut parts: Vec<(f64, f64)> = Vec::new();
        for w in cuts.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b <= a {
                continue;
            }
            let m = 0.5 * (a + b);
            let p = [o[0] + m * d[0], o[1] + m * d[1], o[2] + m * d[2]];
            if !self.contains(p) || cut.is_some_and(|c| c.removes(self.planet_radius, p)) {
                continue;
            }
            match parts.last_mut() {
                Some(last) if last.1 == a => last.1 = b,
                _ => parts.push((a, b)),
            }
        }
        parts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray along z through a box [0, 2]³ with the half x < 1 cut: the whole chord where x > 1,
    /// nothing where x < 1; a cut inside the chord splits it in two; a whole-box cut is refused.
    #[test]
    fn box_cuts_take_the_cut_piece_out_of_the_chord() {
        let b = Aabb {
            lo: [0.0; 3],
            hi: [2.0; 3],
        };
        let half = Cut {
            x: Some([-1.0, 1.0]),
            ..Default::default()
        };
        half.check_box("b", &b).unwrap();
        let d = [0.0, 0.0, 1.0];
        assert_eq!(
            half.clip_box([1.5, 1.0, -5.0], d, (5.0, 7.0)),
            vec![(5.0, 7.0)]
        );
        assert!(half.clip_box([0.5, 1.0, -5.0], d, (5.0, 7.0)).is_empty());
        let slab = Cut {
            z: Some([0.5, 1.5]),
            ..Default::default()
        };
        assert_eq!(
            slab.clip_box([1.0, 1.0, -5.0], d, (5.0, 7.0)),
            vec![(5.0, 5.5), (6.5, 7.0)]
        );
        let all = Cut {
            x: Some([-1.0, 3.0]),
            ..Default::default()
        };
        let e = all.check_box("b", &b).unwrap_err().to_string();
        assert!(e.starts_with("cut: removes the whole volume (b:"), "{e}");
        let wrong = Cut {
            lat: Some([0.0, 90.0]),
            ..Default::default()
        };
        assert!(wrong.check_box("b", &b).is_err());
    }

    /// A plane is a slab open on one side: a ray heading into the removed side loses the rest of
    /// its piece from the crossing on, one heading out keeps it from there, one along the plane
    /// all or nothing; with a range the removed region is their intersection. A box whose eight
    /// corners a plane removes is refused, one with a corner kept is not.
    #[test]
    fn planes_clip_rays_at_their_crossings() {
        let b = Aabb {
            lo: [0.0; 3],
            hi: [2.0; 3],
        };
        // Removed: x + z ≥ 2 (the normal's length does not matter).
        let diagonal = Cut {
            planes: vec![CutPlane {
                point: [1.0, 0.0, 1.0],
                normal: [3.0, 0.0, 3.0],
            }],
            ..Default::default()
        };
        diagonal.check_box("b", &b).unwrap();
        let up = [0.0, 0.0, 1.0];
        let close = |got: Vec<(f64, f64)>, want: (f64, f64)| {
            assert!(
                got.len() == 1
                    && (got[0].0 - want.0).abs() < 1e-12
                    && (got[0].1 - want.1).abs() < 1e-12,
                "{got:?} against {want:?}"
            )
        };
        // Along +z at x = 0.5: removed from z = 1.5, i.e. t = 6.5 from z = −5.
        close(
            diagonal.clip_box([0.5, 1.0, -5.0], up, (5.0, 7.0)),
            (5.0, 6.5),
        );
        // Along −z from z = 7: in the removed side until z = 1.5 (t = 5.5).
        close(
            diagonal.clip_box([0.5, 1.0, 7.0], [0.0, 0.0, -1.0], (5.0, 7.0)),
            (5.5, 7.0),
        );
        // Parallel to the plane: kept below it, gone above it.
        let along = [0.5f64.sqrt(), 0.0, -(0.5f64.sqrt())];
        assert_eq!(
            diagonal.clip_box([0.0, 1.0, 1.0], along, (0.0, 1.0)),
            vec![(0.0, 1.0)]
        );
        assert!(diagonal
            .clip_box([1.0, 1.0, 1.5], along, (0.0, 1.0))
            .is_empty());
        assert!(diagonal.removes_box([1.0, 0.0, 1.0]) && !diagonal.removes_box([0.9, 0.0, 1.0]));
        // With y ≥ 1 as well: a ray at y = 0.5 keeps everything.
        let corner = Cut {
            y: Some([1.0, 5.0]),
            ..diagonal.clone()
        };
        assert_eq!(
            corner.clip_box([0.5, 0.5, -5.0], up, (5.0, 7.0)),
            vec![(5.0, 7.0)]
        );
        // x + z ≥ 0 holds on every corner of the box: refused; x + z ≥ 0.1 leaves the origin.
        let all = |c: f64| Cut {
            planes: vec![CutPlane {
                point: [c, 0.0, 0.0],
                normal: [1.0, 0.0, 1.0],
            }],
            ..Default::default()
        };
        let e = all(0.0).check_box("b", &b).unwrap_err().to_string();
        assert!(e.starts_with("cut: removes the whole volume (b:"), "{e}");
        all(0.1).check_box("b", &b).unwrap();
        // Planes cut boxes, not shells.
        let axis = crate::model::CoordAxis::uniform_cells;
        let shell = SphericalGrid {
            axis_of: [0, 1, 2],
            radius: axis(0.5, 0.1, 5),
            latitude: axis(-90.0, 10.0, 18),
            longitude: axis(0.0, 10.0, 36),
            lon_wraps: true,
            planet_radius: 1.0,
            length_unit: "m".into(),
            vertical: "radius".into(),
            rotated_pole: None,
        };
        let e = diagonal.check(&shell).unwrap_err().to_string();
        assert!(e.starts_with("cut: x, y, z and planes cut boxes"), "{e}");
    }
}
