//! Cells for columns that come with their centres only (CAM-SE's `ncol`, station-like data): the
//! spherical Delaunay triangulation of the centres. Stereographic projection from one of the
//! centres maps circles on the sphere to circles (or lines) in the plane and keeps which points
//! lie inside them, so the plane's Delaunay triangulation of the other centres (the `spade`
//! crate) is the sphere's, less the triangles at the projection point; those are that point
//! with each edge of the plane's convex hull. Triangles with an edge over eight times the median
//! edge are dropped: they span the empty side of a regional set of points, not data.

use crate::model::vec3::{cross, dot, tangent_basis};
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

/// One projected centre and the index of the column it came from.
struct Column {
    at: Point2<f64>,
    id: usize,
}

impl HasPosition for Column {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.at
    }
}

fn unit(lon: f64, lat: f64) -> [f64; 3] {
    let (lo, la) = (lon.to_radians(), lat.to_radians());
    [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
}

/// Whether every finite point lies on one great circle (within 1e-9 of its plane), as a
/// section's path does: such points make no cells.
pub(crate) fn on_one_great_circle(lon: &[f64], lat: &[f64]) -> bool {
    let points: Vec<[f64; 3]> = (0..lon.len())
        .filter(|&i| lon[i].is_finite() && lat[i].is_finite())
        .map(|i| unit(lon[i], lat[i]))
        .collect();
    let Some(&a) = points.first() else {
        return true;
    };
    // The plane through the origin, the first point and the point farthest from its line.
    let normal = points
        .iter()
        .map(|&p| cross(a, p))
        .max_by(|x, y| dot(*x, *x).total_cmp(&dot(*y, *y)))
        .unwrap_or([0.0; 3]);
    let n = dot(normal, normal).sqrt();
    n < 1e-12 || points.iter().all(|&p| (dot(p, normal) / n).abs() < 1e-9)
}

/// The spherical Delaunay triangles of the points (longitude, latitude in degrees), as node
/// indices; points repeated or not finite take no part.
pub(crate) fn triangulate(lon: &[f64], lat: &[f64]) -> Result<Vec<[usize; 3]>, String> {
    let finite: Vec<usize> = (0..lon.len())
        .filter(|&i| lon[i].is_finite() && lat[i].is_finite())
        .collect();
    let Some(&pole) = finite.first() else {
        return Err("no column has a finite position".into());
    };
    let p = unit(lon[pole], lat[pole]);
    let (e1, e2) = tangent_basis(p);
    let columns: Vec<Column> = finite[1..]
        .iter()
        .filter_map(|&i| {
            let q = unit(lon[i], lat[i]);
            let d = 1.0 - dot(q, p);
            (d > 1e-12).then(|| Column {
                at: Point2::new(dot(q, e1) / d, dot(q, e2) / d),
                id: i,
            })
        })
        .collect();
    let plane = DelaunayTriangulation::<Column>::bulk_load(columns)
        .map_err(|e| format!("the columns cannot be triangulated: {e}"))?;
    let mut out: Vec<[usize; 3]> = plane
        .inner_faces()
        .map(|f| f.vertices().map(|v| v.data().id))
        .collect();
    out.extend(plane.convex_hull().map(|e| {
        let [a, b] = e.vertices().map(|v| v.data().id);
        [pole, b, a]
    }));
    if out.is_empty() {
        return Err(format!(
            "{} columns on one great circle make no cells",
            finite.len()
        ));
    }
    Ok(drop_long(out, lon, lat))
}

/// The triangles without those having an edge over eight times the median edge.
fn drop_long(tris: Vec<[usize; 3]>, lon: &[f64], lat: &[f64]) -> Vec<[usize; 3]> {
    let edge = |a: usize, b: usize| {
        dot(unit(lon[a], lat[a]), unit(lon[b], lat[b]))
            .clamp(-1.0, 1.0)
            .acos()
    };
    let longest: Vec<f64> = tris
        .iter()
        .map(|t| edge(t[0], t[1]).max(edge(t[1], t[2])).max(edge(t[2], t[0])))
        .collect();
    let mut sorted = longest.clone();
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
    tris.into_iter()
        .zip(longest)
        .filter(|(_, l)| *l <= 8.0 * median)
        .map(|(t, _)| t)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The octahedron's six vertices: eight triangles, the sphere's Delaunay triangulation.
    #[test]
    fn the_octahedron_triangulates_into_its_eight_faces() {
        let lon = [0.0, 90.0, 180.0, -90.0, 0.0, 0.0];
        let lat = [0.0, 0.0, 0.0, 0.0, 90.0, -90.0];
        let mut tris = triangulate(&lon, &lat).unwrap();
        assert_eq!(tris.len(), 8, "{tris:?}");
        for t in &mut tris {
            t.sort_unstable();
            // Each face has a pole (4 or 5) and two neighbouring equator points.
            assert!(t[2] >= 4 && t[1] < 4, "{t:?}");
        }
        tris.sort_unstable();
        tris.dedup();
        assert_eq!(tris.len(), 8);
        assert!(!on_one_great_circle(&lon, &lat));
        // A section's path along a meridian and along the equator.
        assert!(on_one_great_circle(
            &[30.0; 5],
            &[-60.0, -10.0, 0.0, 20.0, 70.0]
        ));
        assert!(on_one_great_circle(&[0.0, 40.0, 170.0, 250.0], &[0.0; 4]));
    }
}
