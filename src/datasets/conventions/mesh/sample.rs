//! A mesh's field sampled onto a regular latitude–longitude grid, so every grid tool (maps,
//! globes, coastlines, `save_grid`, statistics, movies, the TUI) works on it unchanged. A cell is
//! the polygon of its nodes joined by straight lines in (longitude, latitude), its longitudes
//! unwrapped from its first node; a node at a pole, which has no longitude, is widened to the
//! stretch of the pole between its two neighbours' longitudes; a ring that goes round a pole is
//! closed along it. Cell data: a grid node takes the value of the cell it falls in (by the
//! crossing-number rule, so a node on an edge shared by two cells belongs to one of them). Node
//! data: linear over the cell's fan of triangles from its first node (barycentric weights; a
//! ring round a pole is cut into one trapezoid per edge, down to the pole, whose value is the
//! mean of the ring's). Nodes no cell covers are missing. Cells are found by scanning each
//! cell's bounding box on the target grid — the target grid is the spatial index, so the work is
//! proportional to the cells plus the grid's nodes.

use super::{Location, Mesh};
use crate::datasets::conventions::curvilinear::{
    finite_range, linear_in, span_of, target_axes, Regridded,
};
use crate::error::{Error, Result};
use rayon::prelude::*;

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
fn near(l: f64, to: f64) -> f64 {
    let d = l - to;
    if d.abs() <= 180.0 {
        l
    } else {
        l - 360.0 * (d / 360.0).round()
    }
}

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
    let at_pole = |n: usize| mesh.lat[n].abs() >= 90.0 - 1e-9;
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
fn on_boundary(points: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut j = points.len() - 1;
    for i in 0..points.len() {
        let (a, b) = (points[j], points[i]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 {
            (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (ex, ey) = (a[0] + t * dx - p[0], a[1] + t * dy - p[1]);
        if ex * ex + ey * ey <= 1e-18 {
            return true;
        }
        j = i;
    }
    false
}

/// The pole (±90) that cell `f`'s ring goes round, if it does: its longitude steps (off the
/// poles, each the short way) add up to a turn.
fn round_pole(mesh: &Mesh, f: usize) -> Option<f64> {
    let ids = mesh.face(f);
    let off: Vec<usize> = ids
        .iter()
        .copied()
        .filter(|&n| mesh.lat[n].abs() < 90.0 - 1e-9 && mesh.lon[n].is_finite())
        .collect();
    if off.len() < 3 || off.len() != ids.len() {
        return None;
    }
    let turn: f64 = (0..off.len())
        .map(|k| {
            let d = mesh.lon[off[(k + 1) % off.len()]] - mesh.lon[off[k]];
            d - 360.0 * (d / 360.0).round()
        })
        .sum();
    let mean = off.iter().map(|&n| mesh.lat[n]).sum::<f64>();
    (turn.abs() > 180.0).then_some(if mean > 0.0 { 90.0 } else { -90.0 })
}

/// The regular grid a mesh is sampled onto: nodes, step, and whether it goes all round.
struct Plan {
    lon: Vec<f64>,
    lat: Vec<f64>,
    step_lon: f64,
    step: f64,
    all_round: bool,
}

/// The grid for `mesh` at `step` degrees (default: its cells' median size, the square root of
/// their area): all round from −180° when the mesh spans the globe, else its extent in whichever of
/// [−180°, 180°) and [0°, 360°) keeps it in one piece.
fn plan(mesh: &Mesh, step: Option<f64>) -> Result<Plan> {
    let step = match step {
        Some(s) if s.is_finite() && s > 0.0 => s,
        Some(s) => {
            return Err(Error::invalid(
                "resolution",
                format!("{s}; expected a step in degrees above 0"),
            ))
        }
        None => mesh
            .median_size()
            .ok_or_else(|| Error::invalid("mesh", "every cell has zero size"))?,
    };
    let (mut south, mut north) = finite_range(&mesh.lat);
    if !(south.is_finite() && north.is_finite()) {
        return Err(Error::invalid(
            "mesh",
            "no cell has nodes at finite positions",
        ));
    }
    let caps: Vec<f64> = (0..mesh.faces())
        .into_par_iter()
        .filter_map(|f| round_pole(mesh, f))
        .collect();
    for pole in &caps {
        (south, north) = (south.min(*pole), north.max(*pole));
    }
    let polar = !caps.is_empty() || south <= -90.0 + 1e-9 || north >= 90.0 - 1e-9;
    let west: Vec<f64> = mesh.lon.iter().map(|l| l.rem_euclid(360.0)).collect();
    let centred: Vec<f64> = west
        .iter()
        .map(|l| if *l >= 180.0 { l - 360.0 } else { *l })
        .collect();
    let (a, b) = finite_range(&west);
    let (c, d) = finite_range(&centred);
    let (lo, hi) = if b - a < d - c { (a, b) } else { (c, d) };
    let all_round = polar || hi - lo >= 360.0 - 2.0 * step;
    let (lon, lat, step_lon) = target_axes(step, (south, north), (lo, hi), all_round)?;
    Ok(Plan {
        lon,
        lat,
        step_lon,
        step,
        all_round,
    })
}

impl Plan {
    /// Calls `visit(k, lon, lat)` for every grid node in the bounding box of `points`, at every
    /// turn of longitude that meets the grid, with the node's longitude moved to that turn.
    fn each_node_near(&self, points: &[[f64; 2]], mut visit: impl FnMut(usize, [f64; 2])) {
        let (mut west, mut east, mut south, mut north) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in points {
            (west, east) = (west.min(p[0]), east.max(p[0]));
            (south, north) = (south.min(p[1]), north.max(p[1]));
        }
        let shifts: &[f64] = if self.all_round {
            &[-720.0, -360.0, 0.0, 360.0, 720.0]
        } else {
            &[-360.0, 0.0, 360.0]
        };
        let Some(js) = span_of([south, north], self.lat[0], self.step, self.lat.len()) else {
            return;
        };
        let nx = self.lon.len();
        let (first, last) = (self.lon[0], self.lon[nx - 1]);
        for &shift in shifts {
            // Most turns miss the grid: skip them before finding the columns.
            if east + shift < first - self.step_lon || west + shift > last + self.step_lon {
                continue;
            }
            let Some(is) = span_of([west + shift, east + shift], self.lon[0], self.step_lon, nx)
            else {
                continue;
            };
            for j in js.0..=js.1 {
                for i in is.0..=is.1 {
                    visit(j * nx + i, [self.lon[i] - shift, self.lat[j]]);
                }
            }
        }
    }
}

/// `values` on `mesh` (one per cell or per node, as its location says) sampled onto a regular
/// latitude–longitude grid of `step` degrees (default: the cells' median size).
pub(crate) fn regrid(mesh: &Mesh, values: &[f64], step: Option<f64>) -> Result<Regridded> {
    let plan = plan(mesh, step)?;
    let cells = plan.lon.len() * plan.lat.len();
    // The cells in chunks on every core, each chunk's grid nodes and values in cell order; then
    // written in that order, so the first cell to reach a node keeps it, as drawn one by one.
    const CHUNK: usize = 4096;
    let hits: Vec<Vec<(usize, f64)>> = (0..mesh.faces().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut hits, mut r) = (Vec::new(), Ring::default());
            for f in c * CHUNK..((c + 1) * CHUNK).min(mesh.faces()) {
                if !ring_into(mesh, f, &mut r) {
                    continue;
                }
                match mesh.location {
                    Location::Faces => {
                        let v = values[f];
                        plan.each_node_near(&r.points, |k, p| {
                            if contains(&r.points, p) || on_boundary(&r.points, p) {
                                hits.push((k, v));
                            }
                        });
                    }
                    Location::Nodes => {
                        for tri in triangles(&r, values) {
                            triangle_hits(&plan, tri, &mut hits);
                        }
                    }
                }
            }
            hits
        })
        .collect();
    let mut out = vec![f64::NAN; cells];
    let mut written = vec![false; cells];
    for (k, v) in hits.into_iter().flatten() {
        if !written[k] {
            out[k] = v;
            written[k] = true;
        }
    }
    Ok(Regridded {
        lon: plan.lon,
        lat: plan.lat,
        data: out,
        step: plan.step,
    })
}

/// A ring's triangles with the node values at their corners: the fan from its first vertex, or
/// for a ring round a pole two triangles per edge down to the pole, whose value is the mean of
/// the ring's (the trapezoid cut from the edge's western end to the pole below its eastern).
fn triangles(r: &Ring, values: &[f64]) -> Vec<[([f64; 2], f64); 3]> {
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

/// The grid nodes inside the triangle with the value linear over it (a missing corner makes
/// them missing).
fn triangle_hits(plan: &Plan, t: [([f64; 2], f64); 3], hits: &mut Vec<(usize, f64)>) {
    let [(a, _), (b, _), (c, _)] = t;
    let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
    if area == 0.0 {
        return;
    }
    plan.each_node_near(&[a, b, c], |k, p| {
        if let Some(v) = linear_in(&t, area, p) {
            hits.push((k, v));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(lon: Vec<f64>, lat: Vec<f64>, cells: &[&[usize]], location: Location) -> Mesh {
        let mut offsets = vec![0];
        let mut nodes = Vec::new();
        for c in cells {
            nodes.extend_from_slice(c);
            offsets.push(nodes.len());
        }
        Mesh {
            kind: "test".into(),
            lon,
            lat,
            offsets,
            nodes,
            location,
            dim: "cell".into(),
        }
    }

    #[test]
    fn a_ring_round_the_pole_is_closed_along_it() {
        // A pentagon at 80°N round the pole, its longitudes across the antimeridian.
        let lon: Vec<f64> = (0..5).map(|k| 170.0 + 72.0 * k as f64).collect();
        let m = mesh(lon, vec![80.0; 5], &[&[0, 1, 2, 3, 4]], Location::Faces);
        let r = ring(&m, 0).unwrap();
        assert!(r.cap);
        for x in [-180.0, -90.0, 0.0, 45.0, 170.0, 350.0] {
            let inside = (-2..=2).any(|t| contains(&r.points, [x + 360.0 * t as f64, 85.0]));
            assert!(inside, "{x}");
            let below = (-2..=2).any(|t| contains(&r.points, [x + 360.0 * t as f64, 75.0]));
            assert!(!below, "{x}");
        }
        let g = regrid(&m, &[7.0], Some(2.0)).unwrap();
        assert_eq!(g.lon.len(), 180);
        let row = g.lat.iter().position(|&l| l == 86.0).unwrap();
        assert!(g.data[row * 180..(row + 1) * 180].iter().all(|&v| v == 7.0));
    }

    #[test]
    fn a_node_at_the_pole_widens_to_its_neighbours_longitudes() {
        // ICON's triangle with a vertex on the pole (longitude 0 there, meaningless).
        let m = mesh(
            vec![0.0, 10.0, 82.0],
            vec![90.0, 80.0, 80.0],
            &[&[0, 1, 2]],
            Location::Nodes,
        );
        let r = ring(&m, 0).unwrap();
        assert!(!r.cap);
        assert_eq!(r.points.len(), 4);
        assert!(contains(&r.points, [46.0, 85.0]));
        assert!(!contains(&r.points, [100.0, 85.0]));
        // Node data: the pole's value along its stretch, linear down to the ring.
        let g = regrid(&m, &[10.0, 0.0, 0.0], Some(1.0)).unwrap();
        let at = |lon: f64, lat: f64| {
            let (i, j) = (
                g.lon.iter().position(|&l| l == lon).unwrap(),
                g.lat.iter().position(|&l| l == lat).unwrap(),
            );
            g.data[j * g.lon.len() + i]
        };
        assert!((at(20.0, 85.0) - 5.0).abs() < 1e-9, "{}", at(20.0, 85.0));
        assert!(at(100.0, 85.0).is_nan());
    }

    #[test]
    fn cells_across_the_antimeridian_are_drawn_whole() {
        let m = mesh(
            vec![170.0, -170.0, -170.0, 170.0],
            vec![0.0, 0.0, 10.0, 10.0],
            &[&[0, 1, 2, 3]],
            Location::Faces,
        );
        let g = regrid(&m, &[3.0], Some(5.0)).unwrap();
        // The extent in [0, 360): 170..190, five columns, all set.
        assert_eq!(g.lon, vec![170.0, 175.0, 180.0, 185.0, 190.0]);
        assert!(g.data.iter().all(|&v| v == 3.0), "{:?}", g.data);
    }
}
