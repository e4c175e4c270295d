//! A mesh's cell as a polygon in the (longitude, latitude) plane ([`Ring`]): its longitudes
//! unwrapped from its first node; a node at a pole, which has no longitude, widened to the stretch
//! of the pole between its two neighbours' longitudes; a ring that goes round a pole closed along
//! it. Which points a ring holds (crossing number, closed cells), and the triangles node data are
//! linear over. Shared by the sampler onto latitude–longitude grids and the point locator.

use super::Mesh;
use crate::model::geometry::segment_distance2;

/// One cell in the (longitude, latitude) plane, ready to be drawn.
#[derive(Default)]
pub(crate) struct Ring {
    /// Vertices, longitudes unwrapped.
    pub points: Vec<[f64; 2]>,
    /// The mesh node of each vertex (`None` for a point added on a pole).
    pub nodes: Vec<Option<usize>>,
    /// The ring goes round a pole and was closed along it: its vertices before the last three
    /// are the ring's own.
    pub cap: bool,
    /// Scratch: the unwrapped longitude of each node (NaN at a pole).
    lon: Vec<f64>,
}

/// `l` moved by whole turns to within half a turn of `to`.
pub(crate) fn near(l: f64, to: f64) -> f64 {
    let d = l - to;
    if d.abs() <= 180.0 {
        l
    } else {
        l - 360.0 * (d / 360.0).round()
    }
}

/// Whether a node at latitude `lat` (degrees) is at a pole: within 5e-5° (5.6 m) of it. Files
/// that store radians in float32 put the pole up to 2e-5° off it (π/2 has no float32 value, and
/// ICON's and CDO's own rounding adds to that); no mesh has a node that near a pole but not on it.
pub(crate) fn at_a_pole(lat: f64) -> bool {
    lat.abs() >= 90.0 - POLE_TOLERANCE
}

/// How near a pole (degrees) a node counts as on it ([`at_a_pole`]).
pub(crate) const POLE_TOLERANCE: f64 = 5e-5;

/// Cell `f` of `mesh` as a ring in the plane; `None` when a node has no finite position.
#[cfg(test)]
pub(crate) fn ring(mesh: &Mesh, f: usize) -> Option<Ring> {
    let mut r = Ring::default();
    ring_into(mesh, f, &mut r).then_some(r)
}

/// Cell `f` of `mesh` as a ring in the plane, into `r` (whose buffers are reused from cell to
/// cell); `false` when a node has no finite position.
pub(crate) fn ring_into(mesh: &Mesh, f: usize, r: &mut Ring) -> bool {
    let ids = mesh.face(f);
    let at_pole = |n: usize| at_a_pole(mesh.lat[n]);
    if ids
        .iter()
        .any(|&n| !(mesh.lat[n].is_finite() && (mesh.lon[n].is_finite() || at_pole(n))))
    {
        return false;
    }
    // Unwrap the longitudes of the nodes off the poles, each within half a turn of the last.
    let lon = &mut r.lon;
    lon.clear();
    let mut last: Option<f64> = None;
    for &n in ids {
        if at_pole(n) {
            lon.push(f64::NAN);
            continue;
        }
        let l = last.map_or(mesh.lon[n], |p| near(mesh.lon[n], p));
        lon.push(l);
        last = Some(l);
    }
    if last.is_none() {
        return false;
    }
    let count = ids.len();
    let (points, nodes) = (&mut r.points, &mut r.nodes);
    points.clear();
    nodes.clear();
    for (k, &n) in ids.iter().enumerate() {
        if !at_pole(n) {
            points.push([lon[k], mesh.lat[n]]);
            nodes.push(Some(n));
            continue;
        }
        // The stretch of the pole between the neighbours off it, the shorter way round.
        let prev = (1..count)
            .map(|d| lon[(k + count - d) % count])
            .find(|l| l.is_finite());
        let next = (1..count)
            .map(|d| lon[(k + d) % count])
            .find(|l| l.is_finite());
        let (Some(prev), Some(next)) = (prev, next) else {
            return false;
        };
        let (prev, next) = if k == 0 {
            (near(prev, next), next)
        } else {
            (prev, near(next, prev))
        };
        let pole = mesh.lat[n].signum() * 90.0;
        points.extend([[prev, pole], [next, pole]]);
        nodes.extend([Some(n), Some(n)]);
    }
    // The closing edge, from the last vertex back to the first, unwrapped like the others.
    let (x0, y0) = (points[0][0], points[0][1]);
    let closing = near(x0, points[points.len() - 1][0]);
    r.cap = (closing - x0).abs() > 180.0;
    if r.cap {
        let pole = if points.iter().map(|p| p[1]).sum::<f64>() > 0.0 {
            90.0
        } else {
            -90.0
        };
        points.extend([[closing, y0], [closing, pole], [x0, pole]]);
        let first = nodes[0];
        nodes.extend([first, None, None]);
    }
    true
}

/// Whether `p` is inside the polygon `points` (crossing number: a point on an edge belongs to
/// the polygons on one side of it only).
pub(crate) fn contains(points: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut inside = false;
    let mut j = points.len() - 1;
    for i in 0..points.len() {
        let ([xi, yi], [xj, yj]) = (points[i], points[j]);
        if (yi > p[1]) != (yj > p[1]) && p[0] < (xj - xi) * (p[1] - yi) / (yj - yi) + xi {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// Whether `p` lies on an edge of the polygon (within 1e-9 degrees): cells are closed, so the
/// nodes on a mesh's outer boundary are drawn (an edge shared by two cells goes to the first).
pub(crate) fn on_boundary(points: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut j = points.len() - 1;
    for i in 0..points.len() {
        if segment_distance2(p, points[j], points[i]) <= 1e-18 {
            return true;
        }
        j = i;
    }
    false
}

/// The pole (±90) that cell `f`'s ring goes round, if it does: its longitude steps (off the
/// poles, each the short way) add up to a turn.
pub(crate) fn round_pole(mesh: &Mesh, f: usize) -> Option<f64> {
    let ids = mesh.face(f);
    let off = |n: usize| !at_a_pole(mesh.lat[n]) && mesh.lon[n].is_finite();
    if ids.len() < 3 || !ids.iter().all(|&n| off(n)) {
        return None;
    }
    let (mut turn, mut mean) = (0.0, 0.0);
    // Each edge from the node before (the last node's edge closes the ring): no index
    // arithmetic per node, which a 2.6-million-cell mesh feels.
    let mut before = mesh.lon[ids[ids.len() - 1]];
    for &n in ids {
        let d = mesh.lon[n] - before;
        // The short way round (d itself below half a turn, where the rounding gives 0).
        turn += if d.abs() < 180.0 {
            d
        } else {
            d - 360.0 * (d / 360.0).round()
        };
        mean += mesh.lat[n];
        before = mesh.lon[n];
    }
    (turn.abs() > 180.0).then_some(if mean > 0.0 { 90.0 } else { -90.0 })
}

/// A ring's triangles with the node values at their corners: the fan from its first vertex, or
/// for a ring round a pole two triangles per edge down to the pole, whose value is the mean of
/// the ring's (the trapezoid cut from the edge's western end to the pole below its eastern).
pub(crate) fn triangles(r: &Ring, values: &[f64]) -> Vec<[([f64; 2], f64); 3]> {
    let value = |k: usize| r.nodes[k].map_or(f64::NAN, |n| values[n]);
    if !r.cap {
        return (1..r.points.len().saturating_sub(1))
            .map(|k| [0, k, k + 1].map(|i| (r.points[i], value(i))))
            .collect();
    }
    let own = r.points.len() - 2;
    let ring: Vec<f64> = (0..own - 1).map(value).collect();
    let pole_value = ring.iter().sum::<f64>() / ring.len() as f64;
    let pole = r.points[own][1];
    (0..own - 1)
        .flat_map(|k| {
            // West to east along the edge, so the trapezoid's diagonal does not depend on
            // which way the ring runs.
            let (mut a, mut b) = ((r.points[k], value(k)), (r.points[k + 1], value(k + 1)));
            if a.0[0] > b.0[0] {
                std::mem::swap(&mut a, &mut b);
            }
            let (pa, pb) = (([a.0[0], pole], pole_value), ([b.0[0], pole], pole_value));
            [[a, b, pb], [a, pb, pa]]
        })
        .collect()
}

/// The value at `p` linear over the triangle `t` (corners and their values; `area` twice its
/// signed area, not zero), or `None` when `p` lies outside it (a weight below −1e-12).
pub(crate) fn linear_in(t: &[([f64; 2], f64); 3], area: f64, [x, y]: [f64; 2]) -> Option<f64> {
    let [(a, va), (b, vb), (c, vc)] = *t;
    let wb = ((x - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (y - a[1])) / area;
    let wc = ((b[0] - a[0]) * (y - a[1]) - (x - a[0]) * (b[1] - a[1])) / area;
    let wa = 1.0 - wb - wc;
    let tol = -1e-12;
    (wa >= tol && wb >= tol && wc >= tol).then_some(wa * va + wb * vb + wc * vc)
}
