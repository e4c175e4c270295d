//! Contour lines of a grid's property by marching squares ([`contour_lines`]): on each cell
//! whose four corners are valid, a level crosses an edge where its two ends lie on either side
//! (a corner equal to the level counts as above), at the point linear interpolation along the
//! edge puts it, in the grid's coordinates (uneven axes included); a saddle cell (opposite
//! corners on one side) joins its crossings as the mean of its corners says, as matplotlib's
//! contourpy does by default. The cell pieces are joined into polylines through the edges they
//! share, closed where a line comes back to its start. Longitudes that close the circle
//! contour across the seam (the last column's cells reach the first column, 360° on).

use super::grid::{CoordKind, Grid};
use std::collections::HashMap;

/// One contour line: its level and its points in the grid's (x, y) coordinates, the first
/// repeated at the end when it is closed.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourLine {
    pub level: f64,
    pub points: Vec<[f64; 2]>,
}

impl ContourLine {
    /// Whether the line comes back to its start (a line round a closed circle of longitudes
    /// comes back a turn on).
    pub fn closed(&self) -> bool {
        match (self.points.first(), self.points.last()) {
            (Some(a), Some(b)) if self.points.len() > 2 => {
                a[1] == b[1] && ((a[0] - b[0]) / 360.0).fract() == 0.0
            }
            _ => false,
        }
    }
}

/// Round levels for about `count` lines over `range`: of the steps 1, 2, 2.5 or 5 × 10ⁿ, the
/// one whose multiples strictly inside the range come nearest `count` in number (the coarser on
/// a tie).
pub fn contour_levels((lo, hi): (f64, f64), count: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite() && hi > lo) || count == 0 {
        return Vec::new();
    }
    let e0 = ((hi - lo) / count as f64).log10().floor() as i32;
    let mut best: Vec<f64> = Vec::new();
    for e in e0 - 1..=e0 + 1 {
        for m in [1.0, 2.0, 2.5, 5.0] {
            let levels = multiples(lo, hi, m, e);
            let off = |n: usize| n.abs_diff(count);
            if best.is_empty() || off(levels.len()) <= off(best.len()) {
                best = levels;
            }
        }
    }
    best
}

/// The multiples of m × 10ᵉ strictly inside (lo, hi), each k·m scaled by the power of ten in
/// one rounding, so a level reads as it prints (0.6, not 0.6000000000000001).
fn multiples(lo: f64, hi: f64, m: f64, e: i32) -> Vec<f64> {
    let step = m * 10f64.powi(e);
    let level = |k: i64| {
        if e < 0 {
            k as f64 * m / 10f64.powi(-e)
        } else {
            k as f64 * m * 10f64.powi(e)
        }
    };
    let first = (lo / step).floor() as i64 + 1;
    (first..)
        .map(level)
        .take_while(|&v| v < hi)
        .filter(|&v| v > lo)
        .take(10_000)
        .collect()
}

/// Which edge of the grid a crossing lies on: along x from node (i, j) (`false`) or along y
/// from it (`true`).
type EdgeId = (usize, usize, bool);

/// The contour lines of property `index` of `grid` at each of `levels` (see the module notes).
pub fn contour_lines(grid: &Grid, index: usize, levels: &[f64]) -> Vec<ContourLine> {
    let (nx, ny) = (grid.nx(), grid.ny());
    if nx < 2 || ny < 2 {
        return Vec::new();
    }
    let values = grid.property_at(index).1;
    let xs = &grid.x().values;
    let ys = &grid.y().values;
    let wraps = grid.x().kind == CoordKind::Longitude && {
        let (h0, h1) = (xs[1] - xs[0], xs[nx - 1] - xs[nx - 2]);
        (xs[nx - 1] - xs[0] + 0.5 * (h0 + h1) - 360.0).abs() <= 1e-3 * h0.min(h1)
    };
    let columns = if wraps { nx } else { nx - 1 };
    // Node i's x, the first column again 360° on past the last.
    let x_at = |i: usize| if i == nx { xs[0] + 360.0 } else { xs[i] };
    let v_at = |i: usize, j: usize| values[j * nx + i % nx];
    let mut lines = Vec::new();
    for &level in levels {
        let mut pieces: Vec<[EdgeId; 2]> = Vec::new();
        let mut points: HashMap<EdgeId, [f64; 2]> = HashMap::new();
        for j in 0..ny - 1 {
            for i in 0..columns {
                let c = [
                    v_at(i, j),
                    v_at(i + 1, j),
                    v_at(i + 1, j + 1),
                    v_at(i, j + 1),
                ];
                if c.iter().any(|v| !v.is_finite()) {
                    continue;
                }
                cell_pieces(level, c, (i, j), &mut pieces);
            }
        }
        for piece in &pieces {
            for &(i, j, along_y) in piece {
                points.entry((i, j, along_y)).or_insert_with(|| {
                    let (a, b, p, q) = if along_y {
                        (
                            v_at(i, j),
                            v_at(i, j + 1),
                            [x_at(i), ys[j]],
                            [x_at(i), ys[j + 1]],
                        )
                    } else {
                        (
                            v_at(i, j),
                            v_at(i + 1, j),
                            [x_at(i), ys[j]],
                            [x_at(i + 1), ys[j]],
                        )
                    };
                    let t = (level - a) / (b - a);
                    [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]
                });
            }
        }
        // The seam's edges: column nx is column 0 a turn on, one edge with two names.
        let canon = |e: EdgeId| if e.0 == nx && e.2 { (0, e.1, true) } else { e };
        for chain in join(&pieces, canon) {
            let mut points: Vec<[f64; 2]> = chain.iter().map(|e| points[e]).collect();
            if wraps {
                // A line across the seam runs on past it rather than jumping back a turn.
                for k in 1..points.len() {
                    let prev = points[k - 1][0];
                    points[k][0] += 360.0 * ((prev - points[k][0]) / 360.0).round();
                }
            }
            lines.push(ContourLine { level, points });
        }
    }
    lines
}

/// The pieces a level leaves in the cell whose lower-left node is (i, j) and whose corners
/// (counter-clockwise from it) hold `c`: pairs of the edges each piece joins.
fn cell_pieces(level: f64, c: [f64; 4], (i, j): (usize, usize), out: &mut Vec<[EdgeId; 2]>) {
    // Edges counter-clockwise from the bottom: bottom, right, top, left.
    let edges = [
        (i, j, false),
        (i + 1, j, true),
        (i, j + 1, false),
        (i, j, true),
    ];
    let above: Vec<bool> = c.iter().map(|&v| v >= level).collect();
    let case = above
        .iter()
        .enumerate()
        .fold(0u8, |acc, (k, &a)| acc | ((a as u8) << k));
    let mut pair = |a: usize, b: usize| out.push([edges[a], edges[b]]);
    match case {
        0 | 15 => {}
        // One corner apart from the rest: the edges either side of it.
        1 | 14 => pair(3, 0),
        2 | 13 => pair(0, 1),
        4 | 11 => pair(1, 2),
        8 | 7 => pair(2, 3),
        // Two neighbouring corners: the line crosses the cell.
        3 | 12 => pair(3, 1),
        6 | 9 => pair(0, 2),
        // Saddles: the corners that agree with the cell's mean are joined through its middle.
        5 | 10 => {
            let centre_above = c.iter().sum::<f64>() / 4.0 >= level;
            let first_above = above[0];
            if centre_above == first_above {
                // Corners 0 and 2 joined: the line cuts off corners 1 and 3.
                pair(0, 1);
                pair(2, 3);
            } else {
                pair(3, 0);
                pair(1, 2);
            }
        }
        _ => unreachable!("four corners make 16 cases"),
    }
}

/// The pieces joined end to end through the edges they share (after `canon`), each chain as
/// the list of its edges; a chain that comes back to its start repeats it at the end.
fn join(pieces: &[[EdgeId; 2]], canon: impl Fn(EdgeId) -> EdgeId) -> Vec<Vec<EdgeId>> {
    let mut at: HashMap<EdgeId, Vec<usize>> = HashMap::new();
    for (k, p) in pieces.iter().enumerate() {
        for &e in p {
            at.entry(canon(e)).or_default().push(k);
        }
    }
    let mut used = vec![false; pieces.len()];
    let mut chains = Vec::new();
    // Open chains first, from their ends (edges with one piece), then the closed loops.
    let ends: Vec<usize> = (0..pieces.len())
        .filter(|&k| pieces[k].iter().any(|&e| at[&canon(e)].len() == 1))
        .collect();
    for start in ends.into_iter().chain(0..pieces.len()) {
        if used[start] {
            continue;
        }
        let p = pieces[start];
        let first = if at[&canon(p[0])].len() == 1 || at[&canon(p[1])].len() > 1 {
            p[0]
        } else {
            p[1]
        };
        let mut chain = vec![first];
        let (mut piece, mut edge) = (start, first);
        loop {
            used[piece] = true;
            let [a, b] = pieces[piece];
            edge = if canon(a) == canon(edge) { b } else { a };
            chain.push(edge);
            match at[&canon(edge)].iter().find(|&&q| !used[q]) {
                Some(&q) => piece = q,
                None => break,
            }
        }
        if chain.len() > 2 && canon(chain[0]) == canon(chain[chain.len() - 1]) {
            let n = chain.len();
            chain[n - 1] = chain[0];
        }
        chains.push(chain);
    }
    chains
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(xs: Vec<f64>, ys: Vec<f64>, f: impl Fn(f64, f64) -> f64) -> Grid {
        super::super::grid::test_grid((xs, ys), [CoordKind::Plain; 2], f)
    }

    #[test]
    fn a_plane_gives_one_straight_line_through_the_exact_points() {
        let xs: Vec<f64> = (0..11).map(|i| i as f64).collect();
        let ys = vec![0.0, 0.5, 2.0, 3.0, 7.0];
        let g = grid(xs, ys, |x, y| x + 2.0 * y);
        let lines = contour_lines(&g, 0, &[6.3]);
        assert_eq!(lines.len(), 1);
        let l = &lines[0];
        assert!(!l.closed());
        for p in &l.points {
            assert!((p[0] + 2.0 * p[1] - 6.3).abs() < 1e-12, "{p:?}");
        }
        // From edge to edge of the grid.
        let ends = [l.points[0], l.points[l.points.len() - 1]];
        assert!(ends.iter().any(|p| p[1] == 0.0) && ends.iter().any(|p| p[0] == 0.0));
    }

    #[test]
    fn circles_close_and_lie_on_the_level_set_to_second_order() {
        let n = 81;
        let xs: Vec<f64> = (0..n)
            .map(|i| -2.0 + 4.0 * i as f64 / (n - 1) as f64)
            .collect();
        let g = grid(xs.clone(), xs, |x, y| x * x + y * y);
        for r in [0.5f64, 1.0, 1.7] {
            let lines = contour_lines(&g, 0, &[r * r]);
            assert_eq!(lines.len(), 1, "r = {r}");
            assert!(lines[0].closed());
            let h = 0.05;
            for p in &lines[0].points {
                let d = (p[0].hypot(p[1]) - r).abs();
                assert!(d < h * h / r, "r = {r}: {p:?} off by {d}");
            }
        }
    }

    #[test]
    fn missing_cells_break_lines_and_saddles_follow_the_cell_mean() {
        let xs: Vec<f64> = (0..5).map(|i| i as f64).collect();
        let g = grid(
            xs.clone(),
            xs.clone(),
            |x, _| if x == 2.0 { f64::NAN } else { x },
        );
        // The level 1.5 runs between columns 1 and 2, whose cells all touch a missing node.
        assert!(contour_lines(&g, 0, &[1.5]).is_empty());
        assert_eq!(contour_lines(&g, 0, &[0.5]).len(), 1);
        // A saddle: corners (0,0) and (1,1) high, mean above the level: joined through the middle.
        let s = grid(vec![0.0, 1.0], vec![0.0, 1.0], |x, y| {
            if x == y {
                1.0
            } else {
                0.0
            }
        });
        let lines = contour_lines(&s, 0, &[0.4]);
        assert_eq!(lines.len(), 2);
        for l in &lines {
            // Each cuts off a low corner, (1, 0) or (0, 1).
            let mid = [
                0.5 * (l.points[0][0] + l.points[1][0]),
                0.5 * (l.points[0][1] + l.points[1][1]),
            ];
            assert!((mid[0] - mid[1]).abs() > 0.5, "{l:?}");
        }
    }

    #[test]
    fn closed_longitudes_contour_across_the_seam_in_one_line() {
        let xs: Vec<f64> = (0..36).map(|i| -175.0 + 10.0 * i as f64).collect();
        let ys: Vec<f64> = (0..9).map(|j| -40.0 + 10.0 * j as f64).collect();
        // Low about the equator: one level line north of it and one south, each all round.
        let g = super::super::grid::test_grid(
            (xs, ys),
            [CoordKind::Longitude, CoordKind::Latitude],
            |x, y| (y / 20.0).powi(2) + 0.01 * x.to_radians().cos(),
        );
        let lines = contour_lines(&g, 0, &[1.0]);
        assert_eq!(lines.len(), 2, "north and south");
        for l in &lines {
            assert!(l.closed(), "{l:?}");
            let span = l
                .points
                .iter()
                .map(|p| p[0])
                .fold(f64::NEG_INFINITY, f64::max)
                - l.points.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
            assert!((span - 360.0).abs() < 1e-9, "{span}");
        }
    }

    #[test]
    fn round_levels_fall_inside_the_range() {
        assert_eq!(contour_levels((0.0, 10.0), 4), vec![2.0, 4.0, 6.0, 8.0]);
        assert_eq!(
            contour_levels((-0.95, 0.95), 9),
            vec![-0.8, -0.6, -0.4, -0.2, 0.0, 0.2, 0.4, 0.6, 0.8]
        );
        assert!(contour_levels((1.0, 1.0), 5).is_empty());
    }
}
