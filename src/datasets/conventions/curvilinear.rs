//! Curvilinear grids: a field on (y, x) whose latitude and longitude are 2-D auxiliary coordinates
//! (CF `coordinates`), as ocean and regional models write them. Maps, globes, coastlines and
//! fringes work on regular latitude–longitude grids, so the field is regridded once, at load, onto
//! one: each cell of the curvilinear grid is split into two triangles along its (i, j)–(i+1, j+1)
//! diagonal, and every regular node inside a triangle takes the value linear in (longitude,
//! latitude) over it (barycentric weights of its three nodes; a missing node makes the triangle
//! missing, as a missing voxel does its cell). Nodes no triangle covers are missing. The regridded
//! field is therefore exact for fields linear in longitude and latitude and otherwise the grid's
//! own piecewise-linear interpolant, sampled at the regular nodes; the default step is the median
//! edge of the grid's cells, so no detail the source resolves is lost to the sampling. Longitudes
//! are unwrapped along rows and the first column (each within half a turn of its neighbour), so a
//! grid across the antimeridian stays one piece; one that goes all round (a global ocean grid: in
//! most rows the last node is within one and a half steps of the first, a turn on) is periodic, its
//! last column joined to its first, and gives a regular grid all round from −180°, triangles across
//! the seam drawn on both sides. Triangles spanning more than half a turn of longitude (at a pole
//! or a fold of a tripolar grid) are left out.

use crate::error::{Error, Result};
use crate::model::mesh::ring::linear_in;
pub(crate) use crate::model::numeric::finite_range;

/// The most nodes a regridded grid may have.
const MAX_NODES: usize = 1 << 26;

/// A curvilinear field on the regular grid it was regridded to.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Regridded {
    /// Node longitudes, rising, degrees east.
    pub lon: Vec<f64>,
    /// Node latitudes, rising, degrees north.
    pub lat: Vec<f64>,
    /// Row-major, longitude fastest; NaN where no triangle covers a node.
    pub data: Vec<f64>,
    /// The grid step in degrees.
    pub step: f64,
}

/// The curvilinear grid's node positions, `ny * nx` each, longitude fastest.
pub(crate) struct Curvilinear<'a> {
    pub shape: [usize; 2],
    pub lat: &'a [f64],
    pub lon: &'a [f64],
}

impl Curvilinear<'_> {
    /// The extent and default step, for `hdrvis info`: "latitudes a to b, longitudes c to d
    /// (unwrapped), median cell edge e degrees".
    pub(crate) fn describe(&self) -> String {
        let lon = self.unwrapped();
        let ((a, b), (c, d)) = (finite_range(self.lat), finite_range(&lon));
        let edge = self
            .median_edge(&lon)
            .map_or("no cell of non-zero size".to_string(), |e| {
                format!("median cell edge {e:.4} degrees")
            });
        format!("latitudes {a:.4} to {b:.4}, longitudes {c:.4} to {d:.4}, {edge}")
    }

    /// Longitudes made continuous: along the first column from node (0, 0), then along each row
    /// from its first node, each within half a turn of the one before. Non-finite stay so.
    fn unwrapped(&self) -> Vec<f64> {
        let [ny, nx] = self.shape;
        let near = |v: f64, reference: f64| {
            if v.is_finite() && reference.is_finite() {
                v - 360.0 * ((v - reference) / 360.0).round()
            } else {
                v
            }
        };
        let mut out = self.lon.to_vec();
        let mut previous_first = out[0];
        for j in 0..ny {
            let row = &mut out[j * nx..(j + 1) * nx];
            row[0] = near(row[0], previous_first);
            if row[0].is_finite() {
                previous_first = row[0];
            }
            let mut previous = row[0];
            for v in row.iter_mut().skip(1) {
                *v = near(*v, previous);
                if v.is_finite() {
                    previous = *v;
                }
            }
        }
        out
    }

    /// Whether the grid goes all round in x: in most rows the gap from the last node back to
    /// the first, a turn on, is at most one and a half of the row's mean step.
    fn rows_close(&self, lon: &[f64]) -> bool {
        let [ny, nx] = self.shape;
        let closing = (0..ny)
            .filter(|j| {
                let row = &lon[j * nx..(j + 1) * nx];
                let travelled: f64 = row.windows(2).map(|w| (w[1] - w[0]).abs()).sum();
                let mean = travelled / (nx - 1) as f64;
                travelled.is_finite() && mean > 0.0 && 360.0 - travelled <= 1.5 * mean
            })
            .count();
        2 * closing > ny
    }

    /// The median length (degrees of arc on the sphere) of the cells' edges along x and y.
    fn median_edge(&self, lon: &[f64]) -> Option<f64> {
        let [ny, nx] = self.shape;
        let arc = |a: usize, b: usize| {
            let (p, q) = (self.lat[a].to_radians(), self.lat[b].to_radians());
            let dl = (lon[b] - lon[a]).to_radians();
            let c = p.sin() * q.sin() + p.cos() * q.cos() * dl.cos();
            c.clamp(-1.0, 1.0).acos().to_degrees()
        };
        let mut edges: Vec<f64> = (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (j, i)))
            .flat_map(|(j, i)| {
                let k = j * nx + i;
                [
                    (i + 1 < nx).then(|| arc(k, k + 1)),
                    (j + 1 < ny).then(|| arc(k, k + nx)),
                ]
            })
            .flatten()
            .filter(|e| e.is_finite() && *e > 0.0)
            .collect();
        if edges.is_empty() {
            return None;
        }
        let mid = edges.len() / 2;
        Some(*edges.select_nth_unstable_by(mid, f64::total_cmp).1)
    }
}

/// Regrids `data` (on `grid`'s nodes) onto a regular latitude–longitude grid of `step` degrees
/// (default: the median cell edge). Errors are messages for the caller to put the file's name
/// and the variable to.
pub(crate) fn regrid(grid: &Curvilinear, data: &[f64], step: Option<f64>) -> Result<Regridded> {
    let [ny, nx] = grid.shape;
    if ny < 2 || nx < 2 {
        return Err(Error::invalid(
            "curvilinear grid",
            format!("{ny} x {nx} nodes; expected at least 2 x 2"),
        ));
    }
    if let Some(bad) = grid.lat.iter().find(|v| v.abs() > 90.0) {
        return Err(Error::invalid(
            "curvilinear grid",
            format!("latitude {bad}; expected values within [-90, 90]"),
        ));
    }
    let lon = grid.unwrapped();
    let ((lat_lo, lat_hi), (lon_lo, lon_hi)) = (finite_range(grid.lat), finite_range(&lon));
    if !(lat_lo.is_finite() && lon_lo.is_finite()) {
        return Err(Error::invalid(
            "curvilinear grid",
            "no node has a finite latitude and longitude",
        ));
    }
    let step = match step {
        Some(s) => s,
        None => grid
            .median_edge(&lon)
            .ok_or_else(|| Error::invalid("curvilinear grid", "every cell has zero size"))?,
    };
    let all_round = grid.rows_close(&lon);
    let (lon_nodes, lat_nodes, step_lon) =
        target_axes(step, (lat_lo, lat_hi), (lon_lo, lon_hi), all_round)?;
    let cells = lon_nodes.len() * lat_nodes.len();
    let target = Target {
        lon0: lon_nodes[0],
        lat0: lat_nodes[0],
        step_lon,
        step_lat: step,
        nx: lon_nodes.len(),
        ny: lat_nodes.len(),
        all_round,
    };
    let mut out = vec![f64::NAN; cells];
    let mut written = vec![false; cells];
    // A grid all round is periodic in x: its last column joins its first.
    let columns = if all_round { nx } else { nx - 1 };
    for j in 0..ny - 1 {
        for i in 0..columns {
            let (k, right) = (j * nx + i, j * nx + (i + 1) % nx);
            for tri in [[k, right, right + nx], [k, right + nx, k + nx]] {
                let corners = tri.map(|n| ([lon[n], grid.lat[n]], data[n]));
                target.fill(corners, &mut out, &mut written);
            }
        }
    }
    Ok(Regridded {
        lon: lon_nodes,
        lat: lat_nodes,
        data: out,
        step,
    })
}

/// The nodes of the regular grid a field is regridded onto at `step` degrees over the latitudes
/// `lat` and longitudes `lon` (ranges): longitudes all round from the antimeridian in whole
/// steps (as global products have them) when `all_round`, else over the range; with the
/// longitude step. Refused when the grid would have too many nodes or fewer than two along an
/// axis.
pub(crate) fn target_axes(
    step: f64,
    (lat_lo, lat_hi): (f64, f64),
    (lon_lo, lon_hi): (f64, f64),
    all_round: bool,
) -> Result<(Vec<f64>, Vec<f64>, f64)> {
    let (lon_nodes, step_lon) = if all_round {
        let n = (360.0 / step).round().max(1.0) as usize;
        let s = 360.0 / n as f64;
        ((0..n).map(|k| -180.0 + k as f64 * s).collect(), s)
    } else {
        (nodes(lon_lo, lon_hi, step), step)
    };
    let lat_nodes = nodes(lat_lo, lat_hi, step);
    let cells = lon_nodes.len().saturating_mul(lat_nodes.len());
    if cells > MAX_NODES || lon_nodes.len() < 2 || lat_nodes.len() < 2 {
        return Err(Error::invalid(
            "resolution",
            format!(
                "{step} degrees gives {} x {} nodes over latitudes {lat_lo}..{lat_hi} and longitudes {lon_lo}..{lon_hi}; expected 2 to {MAX_NODES} in all, at least 2 along each",
                lat_nodes.len(),
                lon_nodes.len()
            ),
        ));
    }
    Ok((lon_nodes, lat_nodes, step_lon))
}

/// Nodes `lo + k·step` from `lo` to at most `hi`.
fn nodes(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    (0..n).map(|k| lo + k as f64 * step).collect()
}

/// The regular grid triangles are drawn into.
struct Target {
    lon0: f64,
    lat0: f64,
    step_lon: f64,
    step_lat: f64,
    nx: usize,
    ny: usize,
    all_round: bool,
}

impl Target {
    /// Sets every node inside the triangle `corners` (position, value) that no triangle has set
    /// yet to the value linear over it; a triangle with a missing corner sets its nodes missing.
    fn fill(&self, corners: [([f64; 2], f64); 3], out: &mut [f64], written: &mut [bool]) {
        let [(a, _), (b, _), (c, _)] = corners;
        if [a, b, c]
            .iter()
            .any(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return;
        }
        // Within half a turn of the first corner; wider triangles (a pole, a fold) are left out.
        let near = |p: [f64; 2]| [p[0] - 360.0 * ((p[0] - a[0]) / 360.0).round(), p[1]];
        let (b, c) = (near(b), near(c));
        let (west, east) = finite_range(&[a[0], b[0], c[0]]);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if east - west > 180.0 || area == 0.0 {
            return;
        }
        let triangle = [(a, corners[0].1), (b, corners[1].1), (c, corners[2].1)];
        // All round, a triangle is drawn at every turn that meets [-180, 180): unwrapped
        // longitudes lie within a turn or two of it.
        let shifts: &[f64] = if self.all_round {
            &[-720.0, -360.0, 0.0, 360.0, 720.0]
        } else {
            &[0.0]
        };
        let (south, north) = finite_range(&[a[1], b[1], c[1]]);
        for &shift in shifts {
            let lon_range = [west + shift, east + shift];
            let Some(is) = span_of(lon_range, self.lon0, self.step_lon, self.nx) else {
                continue;
            };
            let Some(js) = span_of([south, north], self.lat0, self.step_lat, self.ny) else {
                continue;
            };
            for j in js.0..=js.1 {
                let y = self.lat0 + j as f64 * self.step_lat;
                for i in is.0..=is.1 {
                    let x = self.lon0 + i as f64 * self.step_lon - shift;
                    let k = j * self.nx + i;
                    if written[k] {
                        continue;
                    }
                    if let Some(v) = linear_in(&triangle, area, [x, y]) {
                        out[k] = v;
                        written[k] = true;
                    }
                }
            }
        }
    }
}

/// The first and last node index within `[lo, hi]` of nodes `first + k·step`, `k < n`.
pub(crate) fn span_of(
    [lo, hi]: [f64; 2],
    first: f64,
    step: f64,
    n: usize,
) -> Option<(usize, usize)> {
    let a = ((lo - first) / step - 1e-9).ceil().max(0.0);
    let b = ((hi - first) / step + 1e-9).floor().min(n as f64 - 1.0);
    (a <= b).then_some((a as usize, b as usize))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sheared, rotated grid: every regular node inside it takes a field linear in longitude
    /// and latitude exactly, nodes outside it are missing, and the default step is the median
    /// cell edge in degrees of arc.
    #[test]
    fn a_linear_field_is_regridded_exactly_inside_the_grid() {
        let (ny, nx) = (20, 30);
        let th = 30f64.to_radians();
        let mut lat = Vec::new();
        let mut lon = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let (x, y) = (0.5 * i as f64, 0.5 * j as f64);
                lon.push(10.0 + x * th.cos() - y * th.sin());
                lat.push(40.0 + x * th.sin() + y * th.cos());
            }
        }
        let f = |lon: f64, lat: f64| 0.1 * lat + 0.05 * lon;
        let data: Vec<f64> = lon.iter().zip(&lat).map(|(o, a)| f(*o, *a)).collect();
        let grid = Curvilinear {
            shape: [ny, nx],
            lat: &lat,
            lon: &lon,
        };
        let r = regrid(&grid, &data, None).unwrap();
        // Edges 0.5 degrees long in (longitude, latitude), half their longitude shrunk by
        // cos(latitude) on the sphere: between the shortest and the longest arc (at 40-51°N, the
        // x edges 0.39-0.40 degrees of arc, the y edges 0.46-0.47).
        assert!(r.step > 0.385 && r.step < 0.475, "step {}", r.step);
        let (mut inside, mut outside) = (0, 0);
        for (j, y) in r.lat.iter().enumerate() {
            for (i, x) in r.lon.iter().enumerate() {
                let v = r.data[j * r.lon.len() + i];
                // Back into the grid's (x, y) to see whether the node is inside it.
                let (dx, dy) = (x - 10.0, y - 40.0);
                let (gx, gy) = (
                    dx * th.cos() + dy * th.sin(),
                    -dx * th.sin() + dy * th.cos(),
                );
                let margin = 1e-9;
                let within = gx >= -margin
                    && gx <= 0.5 * (nx - 1) as f64 + margin
                    && gy >= -margin
                    && gy <= 0.5 * (ny - 1) as f64 + margin;
                if within {
                    inside += 1;
                    assert!((v - f(*x, *y)).abs() < 1e-12, "{x} {y}: {v}");
                } else if gx < -1e-6 || gy < -1e-6 || gx > 0.5 * (nx - 1) as f64 + 1e-6 {
                    outside += 1;
                    assert!(v.is_nan(), "{x} {y} outside: {v}");
                }
            }
        }
        assert!(inside > 300 && outside > 100, "{inside} {outside}");
    }

    /// A grid all round the globe stored in [-180, 180) from -80, so its rows jump at the
    /// antimeridian: the regular grid goes all round from -180 and every node between its
    /// latitudes has a value.
    #[test]
    fn a_global_grid_regrids_all_round() {
        let (ny, nx) = (10, 144);
        let mut lat = Vec::new();
        let mut lon = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                lat.push(-45.0 + 10.0 * j as f64);
                // Stored in [-180, 180): the row jumps at the antimeridian.
                lon.push((2.5 * i as f64 + 100.0 + 180.0).rem_euclid(360.0) - 180.0);
            }
        }
        let data: Vec<f64> = lat.iter().map(|a| a * 2.0).collect();
        let grid = Curvilinear {
            shape: [ny, nx],
            lat: &lat,
            lon: &lon,
        };
        let r = regrid(&grid, &data, Some(2.5)).unwrap();
        assert_eq!(r.lon.len(), 144);
        assert_eq!(r.lon[0], -180.0);
        let missing = r.data.iter().filter(|v| v.is_nan()).count();
        assert_eq!(missing, 0, "{missing} of {} nodes missing", r.data.len());
        for (j, y) in r.lat.iter().enumerate() {
            assert!((r.data[j * 144 + 7] - 2.0 * y).abs() < 1e-9);
        }
    }
}
