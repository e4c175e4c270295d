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

use crate::datasets::conventions::curvilinear::{span_of, target_axes, Regridded};
use crate::error::{Error, Result};
use crate::model::mesh::ring::{contains, linear_in, on_boundary, ring_into, triangles, Ring};
use crate::model::mesh::{Extent, Location, Mesh};
use rayon::prelude::*;

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
    let Extent {
        south,
        north,
        lon: (lo, hi),
        polar,
    } = mesh.extent()?;
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
    use crate::model::mesh::ring::ring;
    use crate::model::mesh::test_mesh as mesh;

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
