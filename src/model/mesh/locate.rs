//! Point location on a mesh ([`MeshIndex`]): which cell holds a point and the field's value
//! there, by the sampler's rules (`datasets::conventions::mesh::sample`): cell data take the
//! value of the first cell, in the file's order, whose closed ring holds the point; node data are
//! linear over the first of the cells' triangles that holds it. The spatial index is a regular
//! grid of buckets over the mesh's extent (all round when it reaches a pole or spans more than
//! half a turn), about one cell per bucket, each listing in cell order the cells whose ring's
//! bounding box meets it; a query tests the cells of its bucket whose box holds the point.
//! Building it visits each cell once. The sampler scatters cells onto a regular grid instead,
//! which costs less when the points are a grid's nodes; this index serves points anywhere (the
//! pixels of a globe).

use super::ring::{contains, linear_in, near, on_boundary, ring_into, triangles, Ring};
use super::{Extent, Location, Mesh};
use rayon::prelude::*;

/// Most buckets an index has (32 MiB of offsets).
const MAX_BUCKETS: usize = 1 << 23;
/// Cells per parallel chunk while building and points per chunk while locating.
const CHUNK: usize = 4096;
/// Bands of bucket rows an index is built in, in parallel.
const BANDS: usize = 16;

/// A bucket grid over a mesh's cells (see the module notes).
pub(crate) struct MeshIndex {
    /// The western edge of column 0 and the southern edge of row 0, in degrees.
    west: f64,
    south: f64,
    /// Bucket sizes in longitude and latitude (degrees).
    dlon: f64,
    dlat: f64,
    cols: usize,
    rows: usize,
    /// The columns go all round (cols · dlon = 360°), so column indices wrap.
    wrap: bool,
    /// Bucket `b`'s cells are `cells[start[b]..start[b + 1]]`.
    start: Vec<u32>,
    cells: Vec<u32>,
    /// Each cell's ring's box (west, east, south, north; longitudes unwrapped), rounded outwards
    /// to f32; NaN for a cell without a ring (a node at no finite position).
    boxes: Vec<[f32; 4]>,
}

impl MeshIndex {
    /// The index of `mesh`'s cells over its extent `ext` ([`Mesh::extent`]).
    pub(crate) fn new(mesh: &Mesh, ext: &Extent) -> MeshIndex {
        let wrap = ext.polar || ext.lon.1 - ext.lon.0 > 180.0;
        let (west, span) = if wrap {
            (-180.0, 360.0)
        } else {
            (ext.lon.0, (ext.lon.1 - ext.lon.0).max(1e-9))
        };
        let height = (ext.north - ext.south).max(1e-9);
        let area = span * height;
        let step = (area / mesh.faces().max(1) as f64)
            .sqrt()
            .max((area / MAX_BUCKETS as f64).sqrt());
        let cols = ((span / step).ceil() as usize).clamp(1, MAX_BUCKETS);
        let rows = ((height / step).ceil() as usize).clamp(1, MAX_BUCKETS / cols);
        let mut index = MeshIndex {
            west,
            south: ext.south,
            dlon: span / cols as f64,
            dlat: height / rows as f64,
            cols,
            rows,
            wrap,
            start: Vec::new(),
            cells: Vec::new(),
            boxes: ring_boxes(mesh),
        };
        // A counting sort of (bucket, cell) pairs per band of rows, the bands on every core (each
        // band's counts stay in cache), so each bucket lists its cells in order; then the bands
        // joined.
        let band = rows.div_ceil(BANDS);
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); rows.div_ceil(band)];
        for (f, b) in index.boxes.iter().enumerate() {
            if !b[0].is_nan() {
                let (r0, r1) = (index.row(b[2] as f64), index.row(b[3] as f64));
                for m in &mut members[r0 / band..=r1 / band] {
                    m.push(f as u32);
                }
            }
        }
        let parts: Vec<(Vec<u32>, Vec<u32>)> = members
            .par_iter()
            .enumerate()
            .map(|(b, m)| index.band(b * band..((b + 1) * band).min(rows), m))
            .collect();
        let mut start = Vec::with_capacity(cols * rows + 1);
        let mut cells = Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum());
        for (band_start, band_cells) in parts {
            let base = cells.len() as u32;
            start.extend(band_start.iter().map(|s| base + s));
            cells.extend_from_slice(&band_cells);
        }
        start.push(cells.len() as u32);
        (index.start, index.cells) = (start, cells);
        index
    }

    /// The buckets of the rows `rows`, which the cells `members` (in order) reach: each one's
    /// first entry (from 0) and the cells they list.
    fn band(&self, rows: std::ops::Range<usize>, members: &[u32]) -> (Vec<u32>, Vec<u32>) {
        let first = rows.start * self.cols;
        let mut counts = vec![0u32; rows.len() * self.cols];
        for &f in members {
            self.each_bucket(self.boxes[f as usize], &rows, |k| counts[k - first] += 1);
        }
        let mut total = 0u32;
        let start: Vec<u32> = counts
            .iter()
            .map(|c| {
                total += c;
                total - c
            })
            .collect();
        let mut next = start.clone();
        let mut cells = vec![0u32; total as usize];
        for &f in members {
            self.each_bucket(self.boxes[f as usize], &rows, |k| {
                cells[next[k - first] as usize] = f;
                next[k - first] += 1;
            });
        }
        (start, cells)
    }

    /// The column of longitude `x` (unbounded; the caller wraps or clamps it).
    fn column(&self, x: f64) -> i64 {
        if self.wrap {
            return ((x - self.west) / self.dlon).floor() as i64;
        }
        // Off a regional mesh's extent by whole turns: back onto it, the nearer way.
        let span = self.dlon * self.cols as f64;
        let mut u = (x - self.west).rem_euclid(360.0);
        if u > span + 0.5 * (360.0 - span) {
            u -= 360.0;
        }
        (u / self.dlon).floor() as i64
    }

    fn row(&self, y: f64) -> usize {
        (((y - self.south) / self.dlat).floor().max(0.0) as usize).min(self.rows - 1)
    }

    /// Calls `visit` with every bucket in `rows` that the box `b` meets.
    fn each_bucket(
        &self,
        [w, e, s, n]: [f32; 4],
        rows: &std::ops::Range<usize>,
        mut visit: impl FnMut(usize),
    ) {
        if w.is_nan() {
            return;
        }
        let r0 = self.row(s as f64).max(rows.start);
        let r1 = self.row(n as f64).min(rows.end - 1);
        if r0 > r1 {
            return;
        }
        let c0 = self.column(w as f64);
        let c1 = c0 + ((e as f64 - w as f64) / self.dlon).floor() as i64 + 1;
        let cols = self.cols as i64;
        let (c0, c1) = if self.wrap {
            if c1 - c0 + 1 >= cols {
                (0, cols - 1)
            } else {
                (c0, c1)
            }
        } else {
            (c0.clamp(0, cols - 1), c1.clamp(0, cols - 1))
        };
        for r in r0..=r1 {
            for c in c0..=c1 {
                visit(r * self.cols + c.rem_euclid(cols) as usize);
            }
        }
    }

    /// The bucket holding (`lon`, `lat`), or `None` off the mesh's extent.
    fn bucket(&self, lon: f64, lat: f64) -> Option<usize> {
        let top = self.south + self.dlat * self.rows as f64;
        if !(lat >= self.south && lat <= top && lon.is_finite()) {
            return None;
        }
        let c = self.column(lon);
        let c = if self.wrap {
            c.rem_euclid(self.cols as i64) as usize
        } else if c == self.cols as i64 {
            // On the extent's eastern edge.
            self.cols - 1
        } else if (0..self.cols as i64).contains(&c) {
            c as usize
        } else {
            return None;
        };
        Some(self.row(lat) * self.cols + c)
    }

    /// The cell holding the point (`lon`, `lat` in degrees) and `values`' value there (one per
    /// cell or node, as `mesh.location` says), or `None` outside every cell. `scratch` is reused
    /// from call to call: it keeps the rings of the cells tested last, which the next point,
    /// usually nearby, tests again.
    pub(crate) fn locate(
        &self,
        mesh: &Mesh,
        values: &[f64],
        [lon, lat]: [f64; 2],
        scratch: &mut Scratch,
    ) -> Option<(usize, f64)> {
        let b = self.bucket(lon, lat)?;
        for &c in &self.cells[self.start[b] as usize..self.start[b + 1] as usize] {
            let c = c as usize;
            let [w, e, s, n] = self.boxes[c].map(f64::from);
            if !(lat >= s && lat <= n) {
                continue;
            }
            // Every whole turn of longitude that puts the point in the box.
            let mut x = lon + 360.0 * ((w - lon) / 360.0).ceil();
            while x <= e {
                let Some(ring) = scratch.ring_of(mesh, c) else {
                    break;
                };
                if let Some(v) = value_in(mesh, values, c, ring, [x, lat]) {
                    return Some((c, v));
                }
                x += 360.0;
            }
        }
        None
    }

    /// [`Self::locate`]'s value at every point (NaN outside the mesh), on every core.
    pub(crate) fn values_at(&self, mesh: &Mesh, values: &[f64], points: &[[f64; 2]]) -> Vec<f64> {
        points
            .par_chunks(CHUNK)
            .flat_map_iter(|chunk| {
                let mut scratch = Scratch::default();
                chunk
                    .iter()
                    .map(|p| {
                        self.locate(mesh, values, *p, &mut scratch)
                            .map_or(f64::NAN, |(_, v)| v)
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    }
}

/// Rings [`Scratch`] keeps: more than a bucket's cells, so neighbouring points in one bucket
/// build none again.
const KEPT_RINGS: usize = 8;

/// What [`MeshIndex::locate`] reuses from call to call: the rings of the cells it tested last
/// (replaced oldest first).
#[derive(Default)]
pub(crate) struct Scratch {
    rings: [Ring; KEPT_RINGS],
    /// The cell of each ring (`None`: no ring yet, or its cell has none).
    cells: [Option<usize>; KEPT_RINGS],
    next: usize,
}

impl Scratch {
    /// Cell `c`'s ring, built unless kept; `None` when a node of it has no finite position.
    fn ring_of(&mut self, mesh: &Mesh, c: usize) -> Option<&Ring> {
        if let Some(k) = self.cells.iter().position(|&k| k == Some(c)) {
            return Some(&self.rings[k]);
        }
        let k = self.next;
        self.next = (k + 1) % KEPT_RINGS;
        self.cells[k] = ring_into(mesh, c, &mut self.rings[k]).then_some(c);
        self.cells[k].map(|_| &self.rings[k])
    }
}

/// The value at `p` if cell `c`, whose ring is `r`, holds it.
fn value_in(mesh: &Mesh, values: &[f64], c: usize, r: &Ring, p: [f64; 2]) -> Option<f64> {
    match mesh.location {
        Location::Faces => (contains(&r.points, p) || on_boundary(&r.points, p)).then(|| values[c]),
        Location::Nodes => triangles(r, values).iter().find_map(|t| {
            let [(a, _), (b, _), (c, _)] = *t;
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            (area != 0.0).then(|| linear_in(t, area, p)).flatten()
        }),
    }
}

/// The box of cell `f`'s ring without building it, for the plain cells that are most of every
/// mesh (no node at a pole, none unplaced, not round a pole): its nodes' longitudes unwrapped
/// one from the last as [`ring_into`] does, so the box is the ring's. `None` for other cells.
fn plain_box(mesh: &Mesh, f: usize) -> Option<[f64; 4]> {
    let ids = mesh.face(f);
    let (mut w, mut e, mut s, mut n) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let mut last: Option<f64> = None;
    for &k in ids {
        let (lon, lat) = (mesh.lon[k], mesh.lat[k]);
        if !lon.is_finite() || super::ring::at_a_pole(lat) {
            return None;
        }
        let l = last.map_or(lon, |p| near(lon, p));
        (w, e) = (w.min(l), e.max(l));
        (s, n) = (s.min(lat), n.max(lat));
        last = Some(l);
    }
    // A ring whose closing edge wraps goes round a pole: ring_into closes it along the pole.
    let first = mesh.lon[*ids.first()?];
    ((first - last?).abs() <= 180.0).then_some([w, e, s, n])
}

/// Every cell's ring's bounding box, rounded outwards to f32 (NaN where the cell has no ring).
fn ring_boxes(mesh: &Mesh) -> Vec<[f32; 4]> {
    (0..mesh.faces().div_ceil(CHUNK))
        .into_par_iter()
        .flat_map_iter(|c| {
            let mut r = Ring::default();
            (c * CHUNK..((c + 1) * CHUNK).min(mesh.faces()))
                .map(|f| {
                    let [w, e, s, n] = match plain_box(mesh, f) {
                        Some(b) => b,
                        None if ring_into(mesh, f, &mut r) => {
                            let (mut w, mut e) = (f64::MAX, f64::MIN);
                            let (mut s, mut n) = (f64::MAX, f64::MIN);
                            for p in &r.points {
                                (w, e) = (w.min(p[0]), e.max(p[0]));
                                (s, n) = (s.min(p[1]), n.max(p[1]));
                            }
                            [w, e, s, n]
                        }
                        None => return [f32::NAN; 4],
                    };
                    let down = |x: f64| (x as f32).next_down();
                    let up = |x: f64| (x as f32).next_up();
                    [down(w), up(e), down(s), up(n)]
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::mesh::test_mesh as mesh;

    /// A regional quad mesh of n × n one-degree cells from (lon0, 10°S), cell values k.
    fn quads(lon0: f64, n: usize) -> Mesh {
        let (mut lon, mut lat) = (Vec::new(), Vec::new());
        for j in 0..=n {
            for i in 0..=n {
                lon.push(lon0 + i as f64);
                lat.push(-10.0 + j as f64);
            }
        }
        let cells: Vec<Vec<usize>> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let a = j * (n + 1) + i;
                vec![a, a + 1, a + n + 2, a + n + 1]
            })
            .collect();
        let refs: Vec<&[usize]> = cells.iter().map(Vec::as_slice).collect();
        mesh(lon, lat, &refs, Location::Faces)
    }

    #[test]
    fn a_point_finds_its_cell_on_a_regional_mesh_across_the_antimeridian() {
        let m = quads(175.0, 10);
        let values: Vec<f64> = (0..100).map(f64::from).collect();
        let index = MeshIndex::new(&m, &m.extent().unwrap());
        assert!(!index.wrap);
        let mut r = Scratch::default();
        // Cell i + 10 j is [175 + i, 176 + i] × [−10 + j, −9 + j], whichever convention of
        // longitude the point comes in.
        for [lon, lat] in [
            [175.5, -9.5],
            [-175.5, -9.5],
            [-179.5, -5.5],
            [184.2, -0.1],
            [180.5, -3.5],
        ] {
            let (c, v) = index.locate(&m, &values, [lon, lat], &mut r).unwrap();
            assert_eq!(c as f64, v);
            let (i, j) = ((c % 10) as f64, (c / 10) as f64);
            let x = if lon < 0.0 { lon + 360.0 } else { lon };
            assert!(x >= 175.0 + i && x <= 176.0 + i, "{lon} {c}");
            assert!(lat >= -10.0 + j && lat <= -9.0 + j, "{lat} {c}");
        }
        // Off the mesh: west of it, north of it, far round the globe.
        for p in [[174.5, -5.0], [178.0, 0.5], [0.0, -5.0], [90.0, -5.0]] {
            assert!(index.locate(&m, &values, p, &mut r).is_none(), "{p:?}");
        }
    }

    #[test]
    fn a_shared_edge_goes_to_the_first_cell_and_the_mesh_is_closed() {
        let m = quads(0.0, 4);
        let values: Vec<f64> = (0..16).map(f64::from).collect();
        let index = MeshIndex::new(&m, &m.extent().unwrap());
        let mut r = Scratch::default();
        // On the edge between cells 0 and 1, and on the mesh's outer corner.
        assert_eq!(index.locate(&m, &values, [1.0, -9.5], &mut r).unwrap().0, 0);
        assert_eq!(
            index.locate(&m, &values, [4.0, -6.0], &mut r).unwrap().0,
            15
        );
    }

    #[test]
    fn node_data_are_linear_and_caps_hold_the_pole() {
        // A pentagon round the north pole at 80°N: a point at 85°N anywhere round is inside;
        // node data linear down from the pole (the ring's mean) on the trapezoids.
        let lon: Vec<f64> = (0..5).map(|k| 170.0 + 72.0 * k as f64).collect();
        let m = mesh(lon, vec![80.0; 5], &[&[0, 1, 2, 3, 4]], Location::Nodes);
        let index = MeshIndex::new(&m, &m.extent().unwrap());
        assert!(index.wrap);
        let mut r = Scratch::default();
        let values = [2.0; 5];
        for x in [-180.0, -91.0, 0.0, 45.0, 170.0, 359.0] {
            let (_, v) = index.locate(&m, &values, [x, 85.0], &mut r).unwrap();
            assert!((v - 2.0).abs() < 1e-12, "{x}: {v}");
            assert!(index.locate(&m, &values, [x, 75.0], &mut r).is_none());
        }
    }

    #[test]
    fn plain_boxes_are_the_rings_boxes_and_caps_build_their_rings() {
        let quads = quads(175.0, 6);
        let lon: Vec<f64> = (0..5).map(|k| 170.0 + 72.0 * k as f64).collect();
        let cap = mesh(lon, vec![80.0; 5], &[&[0, 1, 2, 3, 4]], Location::Faces);
        assert_eq!(plain_box(&cap, 0), None);
        let mut r = Ring::default();
        for f in 0..quads.faces() {
            assert!(ring_into(&quads, f, &mut r));
            let xs = r.points.iter().map(|p| p[0]);
            let ys = r.points.iter().map(|p| p[1]);
            let want = [
                xs.clone().fold(f64::MAX, f64::min),
                xs.fold(f64::MIN, f64::max),
                ys.clone().fold(f64::MAX, f64::min),
                ys.fold(f64::MIN, f64::max),
            ];
            assert_eq!(plain_box(&quads, f), Some(want), "cell {f}");
        }
    }

    #[test]
    fn every_point_of_a_grid_gets_what_the_sampler_gives() {
        // The gather and the scatter agree on a mesh of quads and on node data over triangles.
        let m = quads(-3.0, 12);
        let values: Vec<f64> = (0..144).map(|k| (k as f64 * 0.37).sin()).collect();
        let index = MeshIndex::new(&m, &m.extent().unwrap());
        let points: Vec<[f64; 2]> = (0..400)
            .map(|k| {
                [
                    -3.5 + (k % 20) as f64 * 0.71,
                    -10.3 + (k / 20) as f64 * 0.67,
                ]
            })
            .collect();
        let got = index.values_at(&m, &values, &points);
        let mut r = Ring::default();
        for (p, g) in points.iter().zip(&got) {
            let want = (0..m.faces()).find_map(|f| {
                ring_into(&m, f, &mut r);
                value_in(&m, &values, f, &r, *p)
            });
            match want {
                Some(w) => assert_eq!(*g, w, "{p:?}"),
                None => assert!(g.is_nan(), "{p:?}"),
            }
        }
    }
}
