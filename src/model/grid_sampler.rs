//! A grid's value at any point of its axes ([`GridSampler`]), for views that place their pixels
//! by coordinate rather than by node index: maps on uneven axes (Gaussian latitudes, refined
//! ocean grids, pressure levels) and maps in a projection. Nodes sit at their coordinates on
//! any rectilinear axis; between nodes the value is bilinear in each axis's coordinate over the
//! valid corners, a point is missing where its nearest node is (the rule the GPU data pass
//! applies on even axes, so both routes agree), and each end node covers half its end spacing
//! beyond it. Longitudes that close the circle interpolate from the last node on to the first.

use super::grid::{CoordKind, Grid, GridCoords};

/// One axis: its coordinates (increasing), whether it closes the circle (longitudes whose
/// bounds span 360°), and its bounds (the file's cell edges, else half end spacings).
#[derive(Clone, Debug)]
struct Axis<'a> {
    values: &'a [f64],
    wraps: bool,
    lo: f64,
    hi: f64,
}

impl<'a> Axis<'a> {
    /// The axis of `coords`: its cell edges where the file gives them (enclosing the nodes),
    /// else half an end spacing beyond the end nodes; longitudes may close the circle,
    /// latitudes end at the poles.
    fn new(coords: &'a GridCoords) -> Axis<'a> {
        let (values, kind) = (&coords.values[..], coords.kind);
        let longitude = kind == CoordKind::Longitude;
        let n = values.len();
        let (first, last) = (values[0], values[n - 1]);
        let (h0, h1) = if n > 1 {
            (values[1] - first, last - values[n - 2])
        } else {
            (1.0, 1.0)
        };
        let (mut lo, mut hi) = coords
            .cell_edges()
            .unwrap_or((first - 0.5 * h0, last + 0.5 * h1));
        let wraps = longitude && n > 2 && (hi - lo - 360.0).abs() <= 1e-3 * h0.min(h1);
        if kind == CoordKind::Latitude {
            (lo, hi) = (lo.max(-90.0), hi.min(90.0));
        }
        Axis {
            values,
            wraps,
            lo,
            hi,
        }
    }

    /// The two nodes around `c` and the weight of the second (0 on the first node); `None`
    /// beyond the axis's bounds. A longitude is taken a turn either way to fall on the axis.
    /// Evenly spaced nodes over the bounds that resolve the finest spacing: at least as many as
    /// the axis has, at most `max`.
    fn resolving(&self, max: usize) -> usize {
        let finest = self
            .values
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        if finest.is_finite() && finest > 0.0 {
            (((self.hi - self.lo) / finest).round() as usize).clamp(self.values.len(), max)
        } else {
            self.values.len()
        }
    }

    fn locate(&self, c: f64) -> Option<(usize, usize, f64)> {
        let n = self.values.len();
        let c = if self.wraps {
            self.lo + (c - self.lo).rem_euclid(360.0)
        } else if self.lo - 360.0 <= c && c <= self.hi - 360.0 {
            c + 360.0
        } else if self.lo + 360.0 <= c && c <= self.hi + 360.0 {
            c - 360.0
        } else {
            c
        };
        if !(self.lo..=self.hi).contains(&c) {
            return None;
        }
        let v = self.values;
        if n == 1 {
            return Some((0, 0, 0.0));
        }
        if c <= v[0] {
            // Before the first node: on a closed circle, between the last node and the first.
            return Some(if self.wraps {
                let gap = v[0] + 360.0 - v[n - 1];
                (n - 1, 0, (c + 360.0 - v[n - 1]) / gap)
            } else {
                (0, 0, 0.0)
            });
        }
        if c >= v[n - 1] {
            return Some(if self.wraps {
                let gap = v[0] + 360.0 - v[n - 1];
                (n - 1, 0, (c - v[n - 1]) / gap)
            } else {
                (n - 1, n - 1, 0.0)
            });
        }
        let past = v.partition_point(|&x| x <= c);
        let i = past - 1;
        Some((i, i + 1, (c - v[i]) / (v[i + 1] - v[i])))
    }
}

/// A grid's properties at any point of its axes (see the module notes).
#[derive(Clone, Debug)]
pub struct GridSampler<'a> {
    grid: &'a Grid,
    x: Axis<'a>,
    y: Axis<'a>,
}

impl<'a> GridSampler<'a> {
    pub fn new(grid: &'a Grid) -> GridSampler<'a> {
        GridSampler {
            grid,
            x: Axis::new(grid.x()),
            y: Axis::new(grid.y()),
        }
    }

    /// The axes' bounds: the file's outer cell edges, else half an end spacing beyond the end
    /// nodes: [x_lo, x_hi, y_lo, y_hi].
    pub fn bounds(&self) -> [f64; 4] {
        [self.x.lo, self.x.hi, self.y.lo, self.y.hi]
    }

    /// Node counts along x and y that resolve each axis's finest spacing over its bounds (at
    /// least the grid's, at most `max`): the size of [`Self::evenly_spaced`]'s grid.
    pub fn resolving_counts(&self, max: usize) -> (usize, usize) {
        (self.x.resolving(max), self.y.resolving(max))
    }

    /// Whether the x axis is longitudes closing the circle.
    pub fn wraps(&self) -> bool {
        self.x.wraps
    }

    /// Property `index`'s value at (`x`, `y`) in the axes' coordinates; NaN where missing.
    pub fn value_at(&self, index: usize, x: f64, y: f64) -> f64 {
        let (Some((i0, i1, fx)), Some((j0, j1, fy))) = (self.x.locate(x), self.y.locate(y)) else {
            return f64::NAN;
        };
        let values = self.grid.property_at(index).1;
        let nx = self.grid.nx();
        let at = |i: usize, j: usize| values[j * nx + i];
        let near = at(
            if fx >= 0.5 { i1 } else { i0 },
            if fy >= 0.5 { j1 } else { j0 },
        );
        if !near.is_finite() {
            return f64::NAN;
        }
        let (mut sum, mut weights) = (0.0, 0.0);
        for (i, wx) in [(i0, 1.0 - fx), (i1, fx)] {
            for (j, wy) in [(j0, 1.0 - fy), (j1, fy)] {
                let (w, v) = (wx * wy, at(i, j));
                if w > 0.0 && v.is_finite() {
                    sum += w * v;
                    weights += w;
                }
            }
        }
        if weights == 1.0 {
            sum
        } else {
            sum / weights
        }
    }

    /// The grid on evenly spaced axes over the same bounds, at the finest node spacing of each
    /// axis (at most `max_nodes` along either): what views that place nodes by index draw for
    /// a grid on uneven axes. Every property is sampled; the placement (rotated pole, units)
    /// is kept.
    pub fn evenly_spaced(&self, max_nodes: usize) -> crate::Result<Grid> {
        let axis = |a: &Axis, coords: &super::GridCoords| {
            let n = a.resolving(max_nodes);
            let step = (a.hi - a.lo) / n as f64;
            super::GridCoords {
                values: (0..n).map(|k| a.lo + (k as f64 + 0.5) * step).collect(),
                ..coords.clone()
            }
        };
        let (x, y) = (axis(&self.x, self.grid.x()), axis(&self.y, self.grid.y()));
        let names = self.grid.property_names();
        let props = names
            .iter()
            .enumerate()
            .map(|(p, name)| {
                let values = y
                    .values
                    .iter()
                    .flat_map(|&yv| x.values.iter().map(move |&xv| (xv, yv)))
                    .map(|(xv, yv)| self.value_at(p, xv, yv))
                    .collect();
                (name.to_string(), values)
            })
            .collect();
        let mut grid = Grid::with_coords(self.grid.name(), x, y, props, None)?;
        for (p, name) in names.iter().enumerate() {
            grid.set_units(name, self.grid.units(p))?;
        }
        grid.keep_placement_of(self.grid);
        Ok(grid)
    }
}

/// Whether both axes of `grid` are evenly spaced (within 1e-3 of a spacing) with their cell
/// edges, where the file gives them, half a spacing beyond the end nodes: the views that place
/// nodes by index draw such grids as they are.
pub fn evenly_spaced(grid: &Grid) -> bool {
    use super::map_frame::MapAxis;
    let even = |c: &GridCoords| {
        let Some(edges) = c.cell_edges() else {
            return MapAxis::of_coords(c).is_some();
        };
        let (n, h) = (c.values.len(), c.spacing());
        let half = (c.values[0] - 0.5 * h, c.values[n - 1] + 0.5 * h);
        let tol = 1e-3 * h.abs();
        MapAxis::of_coords(c).is_some()
            && (edges.0 - half.0).abs() <= tol
            && (edges.1 - half.1).abs() <= tol
    };
    even(grid.x()) && even(grid.y())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(xs: Vec<f64>, ys: Vec<f64>, f: impl Fn(f64, f64) -> f64) -> Grid {
        let kinds = [CoordKind::Longitude, CoordKind::Latitude];
        super::super::grid::test_grid((xs, ys), kinds, f)
    }

    #[test]
    fn a_field_linear_in_the_coordinates_is_reproduced_on_uneven_axes() {
        let ys = vec![-80.0, -50.0, -20.0, -5.0, 0.0, 3.0, 10.0, 45.0, 85.0];
        let g = grid(vec![0.0, 10.0, 30.0, 35.0], ys, |x, y| 2.0 * x - 3.0 * y);
        let s = GridSampler::new(&g);
        for (x, y) in [(0.0, -80.0), (12.5, -7.25), (33.0, 44.0), (35.0, 85.0)] {
            assert!((s.value_at(0, x, y) - (2.0 * x - 3.0 * y)).abs() < 1e-12);
        }
        // Beyond the end nodes by under half a spacing: the end value; further: missing.
        assert_eq!(s.value_at(0, 35.0, 87.0), 70.0 - 255.0);
        assert!(s.value_at(0, 35.0, 91.0).is_nan());
        assert!(s.value_at(0, -6.0, 0.0).is_nan());
        // Latitudes end at the poles.
        assert_eq!(s.bounds(), [-5.0, 37.5, -90.0, 90.0]);
    }

    #[test]
    fn closed_longitudes_interpolate_across_the_seam_and_missing_nodes_do_not_leak() {
        let xs: Vec<f64> = (0..36).map(|i| i as f64 * 10.0).collect();
        let g = grid(
            xs,
            vec![0.0, 10.0],
            |x, _| if x == 20.0 { f64::NAN } else { x },
        );
        let s = GridSampler::new(&g);
        assert!(s.wraps());
        // Between 350° and 360° = 0°, from either side of the dateline.
        assert!((s.value_at(0, 355.0, 0.0) - 175.0).abs() < 1e-12);
        assert!((s.value_at(0, -5.0, 0.0) - 175.0).abs() < 1e-12);
        // Next to the missing node at 20°: its neighbour's value alone; nearest it: missing.
        assert_eq!(s.value_at(0, 12.0, 0.0), 10.0);
        assert!(s.value_at(0, 16.0, 0.0).is_nan());
    }

    #[test]
    fn cell_edges_from_the_file_bound_the_axis() {
        let kinds = [CoordKind::Plain, CoordKind::Latitude];
        let g = super::super::grid::test_grid(
            (vec![0.0, 1.0, 2.0, 3.0], vec![0.0, 1.0]),
            kinds,
            |x, _| x,
        );
        let with_edges = |edges| {
            let x = GridCoords {
                edges: Some(edges),
                ..g.x().clone()
            };
            let props = vec![("v".to_string(), g.property_at(0).1.to_vec())];
            Grid::with_coords("g", x, g.y().clone(), props, None).unwrap()
        };
        assert!(evenly_spaced(&g));
        // Even nodes 0..3 whose file gives cells from -0.5 to 4.0: the last cell is a whole
        // spacing wide, so the grid is not drawn by index and the sampler reaches 4.0.
        let wide = with_edges((-0.5, 4.0));
        assert!(!evenly_spaced(&wide));
        let s = GridSampler::new(&wide);
        assert_eq!(s.bounds()[..2], [-0.5, 4.0]);
        assert_eq!(s.value_at(0, 3.9, 0.0), 3.0);
        assert!(s.value_at(0, 4.1, 0.0).is_nan());
        // Edges at half a spacing are what the even route draws; edges that leave a node
        // outside are not cells of these nodes and are not used.
        assert!(evenly_spaced(&with_edges((-0.5, 3.5))));
        let wrong = with_edges((0.5, 3.5));
        assert!(evenly_spaced(&wrong));
        assert_eq!(GridSampler::new(&wrong).bounds()[..2], [-0.5, 3.5]);
    }

    #[test]
    fn uneven_axes_resample_to_the_finest_spacing() {
        let g = grid(vec![0.0, 1.0, 3.0, 7.0], vec![0.0, 2.0], |x, y| x + y);
        assert!(!evenly_spaced(&g));
        let even = GridSampler::new(&g).evenly_spaced(4096).unwrap();
        assert!(evenly_spaced(&even));
        // Bounds -0.5 to 9 (half the end spacings) at the finest spacing 1: 10 nodes.
        assert_eq!((even.nx(), even.ny()), (10, 2));
        assert!((even.x().values[0] + 0.025).abs() < 1e-12);
        let v = even.property("v").unwrap();
        for (k, &x) in even.x().values.iter().enumerate() {
            assert!((v[k] - x.clamp(0.0, 7.0)).abs() < 1e-12, "{k}");
        }
    }
}
