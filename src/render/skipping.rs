//! Empty-space skipping for the in-core ray caster. The volume is read once into a coarse grid of
//! cells of 2³, 4³ or 8³ voxels ([`cell_edge`]) holding the finite value range of each cell's
//! footprint (its voxels and a one-voxel apron: everything a sample inside it interpolates).
//! Against the render's transfer function each cell is empty — every value it can interpolate to
//! has zero emission and extinction, or it holds only missing data — or not; a transfer-function
//! change re-classifies the ranges without reading the volume again. The GPU gets, per cell and per
//! octant of ray directions, the edge of the largest cube of empty cells reaching from the cell
//! into that octant ([`octant_extents`]), so one lookup tells how much empty space lies ahead of a
//! sample and the march jumps to that cube's exit in one loop iteration (`skip_empty` in
//! shaders/volume.wgsl). The jump lands on the march's own segment grid, so the image is the one
//! without skipping.

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::bricks::{empty_ranges, BrickLayout, BrickRange};
use crate::model::stencil::stencil_ranges;
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Volume, VolumeStats};
use rayon::prelude::*;
use std::sync::Arc;

/// Voxels per cell edge of the skip grid for a volume of `dims`: small enough to follow a
/// shell's curvature and to start a ray's samples just in front of a wall, large enough that
/// the grid is classified in tens of milliseconds on every transfer-function change. 2 voxels
/// up to 320 per axis (at most 160³ cells), 4 up to 384, 8 beyond. Measured with `hdrvis bench
/// volume --quick --scenes opaque,sparse`: on the opaque wall 2-voxel cells take 14 % less time
/// than 4-voxel ones, on the sparse blobs 8 %; on the mantle at 257³ 4-voxel cells skip about
/// 10 % more of the time than 8-voxel ones (`hdrvis bench skipping`).
pub(crate) fn cell_edge(dims: [usize; 3]) -> usize {
    let largest = dims.iter().copied().max().unwrap_or(0);
    if largest <= 320 {
        2
    } else if largest <= 384 {
        4
    } else {
        8
    }
}

/// Skipping pays only when at least this fraction of the cells is empty: below it the lookup
/// each loop iteration costs more than the jumps save, and the plain march runs.
pub(crate) const MIN_EMPTY_FRACTION: f64 = 0.05;

/// The per-cell value ranges of a volume, read once per volume.
pub(crate) struct CellRanges {
    layout: BrickLayout,
    ranges: Vec<BrickRange>,
    /// The volume's statistics, gathered in the same read (transfer functions resolve on them).
    stats: VolumeStats,
    /// [`gradient_bound`] of the volume.
    gradient: Option<[f64; 3]>,
}

impl CellRanges {
    pub(crate) fn of(volume: Arc<Volume>) -> Result<CellRanges> {
        let edge = cell_edge(volume.dims);
        let layout = BrickLayout {
            dims: volume.dims,
            brick: edge,
            grid: volume.dims.map(|d| d.div_ceil(edge)),
        };
        let stats = volume.stats();
        Ok(CellRanges {
            ranges: stencil_ranges(&volume, &layout),
            layout,
            gradient: (stats.non_finite == 0).then(|| gradient_bound(&volume)),
            stats,
        })
    }

    pub(crate) fn count(&self) -> usize {
        self.ranges.len()
    }

    pub(crate) fn edge(&self) -> usize {
        self.layout.brick
    }

    pub(crate) fn stats(&self) -> &VolumeStats {
        &self.stats
    }

    /// Which cells `tf` leaves empty.
    pub(crate) fn empty_cells(&self, tf: &ResolvedTransfer) -> Vec<bool> {
        empty_ranges(&self.ranges, tf)
    }
}

/// Per axis, the largest difference between neighbouring voxels of a volume whose voxels are
/// all finite: a bound on the slope of its trilinear interpolant along that axis (inside a cell
/// the derivative along x interpolates the cell's four x-edge differences, and the clamped faces
/// are flat), so two samples whose positions differ by (dx, dy, dz) voxels differ in value by
/// at most the bound's dot product with (|dx|, |dy|, |dz|).
pub(crate) fn gradient_bound(volume: &Volume) -> [f64; 3] {
    let [nx, ny, nz] = volume.dims;
    let plane = nx * ny;
    let d = &volume.data;
    let diff = |m: &mut f64, a: &[f32], b: &[f32]| {
        for (&p, &q) in a.iter().zip(b) {
            *m = m.max((f64::from(q) - f64::from(p)).abs());
        }
    };
    (0..nz)
        .into_par_iter()
        .map(|z| {
            let mut m = [0.0f64; 3];
            let slice = &d[z * plane..][..plane];
            for y in 0..ny {
                let row = &slice[y * nx..][..nx];
                diff(&mut m[0], &row[..nx - 1], &row[1..]);
                if y + 1 < ny {
                    diff(&mut m[1], row, &slice[(y + 1) * nx..][..nx]);
                }
            }
            if z + 1 < nz {
                diff(&mut m[2], slice, &d[(z + 1) * plane..][..plane]);
            }
            m
        })
        .reduce(
            || [0.0; 3],
            |a, b| [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])],
        )
}

/// Skipping inside the cells that are not empty: after each sample the march goes on past the
/// samples that the slope bound proves transparent. A sample of value v lies `margin` below
/// the highest value of a transparent range at the bottom of the data's values (or above the
/// lowest of one at the top); the next n samples, each at most `change` further in value,
/// stay in that range while n · change + slack <= margin, so they composite exactly nothing and
/// the image is the one without the jump. Found per volume and transfer function; `None` where
/// some voxel is missing (the bound does not hold across a hole) or neither end of the values
/// is transparent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GradientSkip {
    /// [`gradient_bound`] of the volume.
    pub bound: [f64; 3],
    /// Every value from the data's minimum to `below` is transparent (-f32::MAX where none
    /// is).
    pub below: f64,
    /// Every value from `above` to the data's maximum is transparent (f32::MAX where none is).
    pub above: f64,
    /// What the values and the positions may be off by in f32 and through a texture unit's
    /// filter weights (8 fractional bits on many GPUs): 1e-5 of the largest magnitude and a
    /// hundredth of a voxel's change along each axis.
    pub slack: f64,
}

impl GradientSkip {
    /// The bounds under `tf` for a volume of these statistics and slope bound.
    pub(crate) fn new(
        stats: &VolumeStats,
        bound: [f64; 3],
        tf: &ResolvedTransfer,
    ) -> Option<GradientSkip> {
        let (min, max) = (stats.min, stats.max);
        if !(min.is_finite() && max.is_finite() && min < max) {
            return None;
        }
        let t = tf.transparency();
        // Bisection on the largest transparent [min, x] and the largest transparent [x, max]
        // (covers is monotone in each end); 64 halvings reach f64's resolution.
        let search = |mut lo: f64, mut hi: f64, transparent: &dyn Fn(f64) -> bool| {
            for _ in 0..64 {
                let mid = 0.5 * (lo + hi);
                if transparent(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lo
        };
        let below = if t.covers(min, min) {
            search(min, max, &|x| t.covers(min, x))
        } else {
            -f64::from(f32::MAX)
        };
        let above = if t.covers(max, max) {
            -search(-max, -min, &|x| t.covers(-x, max))
        } else {
            f64::from(f32::MAX)
        };
        // How far a sample at the far end of a transparent range could jump, in voxels: where
        // that is under MIN_GRADIENT_REACH the jumps stay short and the samples, which then wait
        // for each other's values, cost more than they save.
        let steepest = bound.iter().copied().fold(0.0, f64::max);
        let reach = (below - min).max(max - above) / steepest;
        if reach.is_nan() || reach < MIN_GRADIENT_REACH {
            return None;
        }
        Some(GradientSkip {
            bound,
            below,
            above,
            slack: 1e-5 * min.abs().max(max.abs()) + 1e-2 * bound.iter().sum::<f64>(),
        })
    }

    /// One line for the pass log: where it applies and the bound.
    pub(crate) fn describe(&self) -> String {
        let mut ranges = Vec::new();
        if self.below > -f64::from(f32::MAX) {
            ranges.push(format!("below {:.4e}", self.below));
        }
        if self.above < f64::from(f32::MAX) {
            ranges.push(format!("above {:.4e}", self.above));
        }
        let b = self.bound;
        format!(
            "gradient skip {} (change per voxel at most {:.3e}, {:.3e}, {:.3e})",
            ranges.join(" and "),
            b[0],
            b[1],
            b[2]
        )
    }
}

/// The least reach (voxels) at which [`GradientSkip`] pays.
const MIN_GRADIENT_REACH: f64 = 2.0;

/// A classified skip grid on the GPU.
pub(crate) struct SkipGrid {
    pub grid: [usize; 3],
    /// Voxels per cell edge.
    pub edge: usize,
    pub empty: usize,
    /// Empty cells outside the mapped ray caster's domain, which it clips analytically already,
    /// so that skipping them gains nothing (none for a box).
    pub outside: usize,
    /// The cells that are not empty, bounded by the slabs of [`HULL_DIRECTIONS`].
    hull: [[f32; 2]; 13],
    /// Skipping inside the cells that are not empty, where the volume and function allow it.
    pub gradient: Option<GradientSkip>,
    view: wgpu::TextureView,
}

/// The directions of the slabs that bound the cells that are not empty, in texture
/// coordinates: the axes, the face diagonals and the body diagonals (a 26-sided hull, which cuts
/// the corners and edges of the box that a shell or a mask leaves empty). Mirrored by the
/// shader's `hull_span`.
const HULL_DIRECTIONS: [[f32; 3]; 13] = [
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, 1.0, -1.0],
    [1.0, 1.0, 1.0],
    [1.0, 1.0, -1.0],
    [1.0, -1.0, 1.0],
    [1.0, -1.0, -1.0],
];

/// Per direction of [`HULL_DIRECTIONS`], the smallest and largest projection of the corners of
/// the cells that are not empty, in texture coordinates (a cell of `edge` voxels at c spans
/// c·edge/dims to (c + 1)·edge/dims, the last cut at 1). With every cell empty, an empty
/// interval (lowest above highest). Along a row of cells every direction's projection grows or
/// falls with x, so a row's extremes lie at its first and its last visible cell: only those two
/// are projected.
fn hull(empty: &[bool], grid: [usize; 3], edge: usize, dims: [usize; 3]) -> [[f32; 2]; 13] {
    let mut hull = [[f32::INFINITY, f32::NEG_INFINITY]; 13];
    let [nx, ny, nz] = grid;
    let project = |hull: &mut [[f32; 2]; 13], c: [usize; 3]| {
        let lo = [0, 1, 2].map(|a| (c[a] * edge) as f32 / dims[a] as f32);
        let hi = [0, 1, 2].map(|a| (((c[a] + 1) * edge).min(dims[a])) as f32 / dims[a] as f32);
        for (h, d) in hull.iter_mut().zip(&HULL_DIRECTIONS) {
            // The box's extreme projections: per axis the corner that lowers or raises it.
            let (mut low, mut high) = (0.0, 0.0);
            for a in 0..3 {
                let (p, q) = (d[a] * lo[a], d[a] * hi[a]);
                low += p.min(q);
                high += p.max(q);
            }
            h[0] = h[0].min(low);
            h[1] = h[1].max(high);
        }
    };
    for z in 0..nz {
        for y in 0..ny {
            let row = &empty[nx * (y + ny * z)..][..nx];
            if let (Some(first), Some(last)) =
                (row.iter().position(|&e| !e), row.iter().rposition(|&e| !e))
            {
                project(&mut hull, [first, y, z]);
                project(&mut hull, [last, y, z]);
            }
        }
    }
    hull
}

impl SkipGrid {
    pub(crate) fn new(ctx: &GpuContext, cells: &CellRanges, tf: &ResolvedTransfer) -> SkipGrid {
        let empty = cells.empty_cells(tf);
        let (grid, edge) = (cells.layout.grid, cells.edge());
        let mut g = Self::from_empty(ctx, &empty, grid, edge, cells.layout.dims);
        g.gradient = cells
            .gradient
            .and_then(|bound| GradientSkip::new(&cells.stats, bound, tf));
        g
    }

    /// The grid of `grid` cells marked `empty`, of `edge` voxels of a volume of `dims` (the
    /// mapped ray caster's world cells: edge 1 and `dims` the grid, for a hull it does not use).
    pub(crate) fn from_empty(
        ctx: &GpuContext,
        empty: &[bool],
        grid: [usize; 3],
        edge: usize,
        dims: [usize; 3],
    ) -> SkipGrid {
        let extents = octant_extents(empty, grid);
        let stacked = [grid[0], grid[1], grid[2] * 8];
        let texture = ctx.texture_3d(
            "skip grid",
            stacked.map(|g| g as u32),
            wgpu::TextureFormat::R8Unorm,
        );
        ctx.queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&extents),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(grid[0] as u32),
                rows_per_image: Some(grid[1] as u32),
            },
            wgpu::Extent3d {
                width: grid[0] as u32,
                height: grid[1] as u32,
                depth_or_array_layers: stacked[2] as u32,
            },
        );
        SkipGrid {
            grid,
            edge,
            hull: hull(empty, grid, edge, dims),
            empty: empty.iter().filter(|&&e| e).count(),
            outside: 0,
            gradient: None,
            view: texture.create_view(&Default::default()),
        }
    }

    /// The hull's slabs as the shader's `P.hull`: direction i's lowest and highest
    /// projection in `hull[i / 2]`, .xy for even i and .zw for odd.
    pub(crate) fn hull_params(&self) -> [[f32; 4]; 7] {
        let mut p = [[0.0; 4]; 7];
        for (i, h) in self.hull.iter().enumerate() {
            p[i / 2][2 * (i % 2)] = h[0];
            p[i / 2][2 * (i % 2) + 1] = h[1];
        }
        p
    }

    /// The shader's `P.skip` (voxels per cell, [`GradientSkip`]'s `below`, `above` and `slack`)
    /// and `P.gradient` (its bound per axis). Without a gradient skip the bounds lie beyond any
    /// value, so no sample's margin is positive.
    pub(crate) fn skip_params(&self) -> ([f32; 4], [f32; 4]) {
        let edge = self.edge as f32;
        match self.gradient {
            Some(g) => (
                [edge, g.below as f32, g.above as f32, g.slack as f32],
                [g.bound[0] as f32, g.bound[1] as f32, g.bound[2] as f32, 0.0],
            ),
            None => ([edge, -f32::MAX, f32::MAX, 0.0], [1.0, 1.0, 1.0, 0.0]),
        }
    }

    /// The `skip-grid` pass's line: the empty cells, and the gradient skip where it runs.
    pub(crate) fn describe(&self) -> String {
        let empty = format!("{} of {} cells empty", self.empty, self.cells());
        match self.gradient {
            Some(g) => format!("{empty}; {}", g.describe()),
            None => empty,
        }
    }

    pub(crate) fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    pub(crate) fn cells(&self) -> usize {
        self.grid.iter().product()
    }

    /// The share of empty cells among those rays can reach.
    pub(crate) fn empty_fraction(&self) -> f64 {
        (self.empty - self.outside) as f64 / (self.cells() - self.outside).max(1) as f64
    }

    pub(crate) fn bytes(&self) -> u64 {
        self.cells() as u64 * 8
    }
}

/// The largest extent [`octant_extents`] records: the grid's texels are bytes, and a cube of 255
/// cells (1020 voxels or more) is as good as unbounded for a jump.
const MAX_EXTENT: u32 = 255;

/// Per octant of directions and per cell, the edge in cells of the largest cube of empty cells
/// that has the cell at a corner and extends into that octant: 0 for a cell that is not empty.
/// Octant o = (x falls) + 2 (y falls) + 4 (z falls) fills cells o·n .. (o+1)·n of the result
/// (n cells in the grid, x fastest). Outside the grid counts as empty. A ray whose direction
/// lies in octant o jumps from a cell of extent d to where it leaves that cube: it moves away
/// from the cells behind it, so a cube that reaches only forwards is as large as the empty
/// space ahead allows, where a cube centred on the cell would stop at the space just left.
/// The octants are found in parallel ([`octant_pass`]).
pub(crate) fn octant_extents(empty: &[bool], grid: [usize; 3]) -> Vec<u8> {
    let n = grid.iter().product::<usize>();
    let mut out = vec![0u8; 8 * n];
    out.par_chunks_exact_mut(n.max(1))
        .enumerate()
        .for_each(|(octant, ext)| octant_pass(empty, grid, octant, ext));
    out
}

/// One octant of [`octant_extents`], in one pass from the cells ahead: a cube of edge m at c is
/// empty exactly when c is and the cubes of edge m - 1 at its seven forward neighbours are. The
/// pass runs on a copy of the grid mirrored so that "ahead" is +1 along every axis, with one
/// plane more on each axis's far side holding the unbounded extent (outside the grid), so each
/// cell takes the least of seven fixed offsets with no test at the edges.
fn octant_pass(empty: &[bool], grid: [usize; 3], octant: usize, ext: &mut [u8]) {
    let [nx, ny, nz] = grid;
    let (px, py) = (nx + 1, ny + 1);
    let plane = px * py;
    let mut padded = vec![MAX_EXTENT as u8; plane * (nz + 1)];
    let mirror = |c: usize, len: usize, axis: usize| {
        if octant & (1 << axis) != 0 {
            len - 1 - c
        } else {
            c
        }
    };
    let ahead = [1, px, px + 1, plane, plane + 1, plane + px, plane + px + 1];
    for w in (0..nz).rev() {
        for v in (0..ny).rev() {
            let row = nx * (mirror(v, ny, 1) + ny * mirror(w, nz, 2));
            let base = px * (v + py * w);
            for u in (0..nx).rev() {
                let i = row + mirror(u, nx, 0);
                let p = base + u;
                let e = if empty[i] {
                    ahead
                        .iter()
                        .map(|&o| padded[p + o])
                        .min()
                        .unwrap_or(0)
                        .saturating_add(1)
                } else {
                    0
                };
                padded[p] = e;
                ext[i] = e;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The extents by brute force: per octant and cell, the largest cube of empty cells (the
    /// parts inside the grid) reaching from the cell into the octant.
    fn brute(empty: &[bool], grid: [usize; 3]) -> Vec<u8> {
        let [nx, ny, nz] = grid;
        let n = empty.len();
        let mut out = vec![0u8; 8 * n];
        for octant in 0..8usize {
            for i in 0..n {
                let p = [i % nx, (i / nx) % ny, i / (nx * ny)];
                let cube_empty = |m: usize| {
                    (0..m * m * m).all(|j| {
                        let v = [j % m, (j / m) % m, j / (m * m)];
                        let c: Vec<Option<usize>> = (0..3)
                            .map(|a| {
                                if octant & (1 << a) != 0 {
                                    p[a].checked_sub(v[a])
                                } else {
                                    Some(p[a] + v[a]).filter(|&q| q < grid[a])
                                }
                            })
                            .collect();
                        match (c[0], c[1], c[2]) {
                            (Some(x), Some(y), Some(z)) => empty[x + nx * (y + ny * z)],
                            _ => true,
                        }
                    })
                };
                // A cube past the grid's largest extent adds only cells outside the grid.
                let beyond = nx.max(ny).max(nz) + 1;
                let mut m = 0;
                while m < beyond && cube_empty(m + 1) {
                    m += 1;
                }
                out[octant * n + i] = if m == beyond {
                    MAX_EXTENT as u8
                } else {
                    m as u8
                };
            }
        }
        out
    }

    #[test]
    fn octant_extents_match_brute_force() {
        let grid = [7, 5, 6];
        let n = grid.iter().product::<usize>();
        // A few patterns: a sparse pseudo-random set, a single cell, nothing, everything.
        let mut seed = 12345u64;
        let sparse: Vec<bool> = (0..n)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                !(seed >> 33).is_multiple_of(9)
            })
            .collect();
        let mut single = vec![true; n];
        single[3 + 7 * (2 + 5 * 4)] = false;
        for empty in [sparse, single, vec![false; n]] {
            assert_eq!(octant_extents(&empty, grid), brute(&empty, grid));
        }
        // Nothing visible: every cube is unbounded, up to the largest extent a byte records.
        assert!(octant_extents(&vec![true; n], grid)
            .iter()
            .all(|&e| u32::from(e) == MAX_EXTENT));
    }
}

#[cfg(test)]
mod gradient_tests {
    use super::*;
    use crate::model::{LutTransfer, TransferFunction};

    fn ramp(f: impl Fn(f64, f64, f64) -> f64 + Sync) -> Volume {
        Volume::from_fn("ramp", [9, 7, 5], f).unwrap()
    }

    fn tf(domain: [f64; 2], transparent_below: f64) -> TransferFunction {
        TransferFunction::Lut(LutTransfer {
            domain: Some(domain),
            transparent_below,
            ..Default::default()
        })
    }

    #[test]
    fn the_slope_bound_of_a_linear_field_is_its_gradient() {
        let v = ramp(|x, y, z| 2.0 * x - 3.0 * y + 0.5 * z);
        assert_eq!(gradient_bound(&v), [2.0, 3.0, 0.5]);
        // The largest step anywhere, not a typical one.
        let v = ramp(|x, _, _| if (x - 4.5).abs() < 0.1 { 10.0 } else { 0.0 });
        assert_eq!(gradient_bound(&v), [10.0, 0.0, 0.0]);
        // Missing voxels: no bound, so no gradient skip.
        let v = ramp(|x, _, _| if (x - 4.5).abs() < 0.1 { f64::NAN } else { x });
        assert!(CellRanges::of(Arc::new(v)).unwrap().gradient.is_none());
    }

    #[test]
    fn the_transparent_range_ends_within_a_table_entry_of_the_threshold() {
        let v = ramp(|x, _, _| x / 8.0);
        let stats = v.stats();
        let resolved = tf([0.0, 1.0], 0.6).resolve(&stats).unwrap();
        let g = GradientSkip::new(&stats, [1.0 / 8.0, 0.1, 0.1], &resolved).unwrap();
        // Transparent from the minimum to just below 0.6 (the table's entry there, less the
        // margins covers keeps), nothing at the top.
        let entry = 1.0 / (crate::model::transfer::LUT_SIZE - 1) as f64;
        assert!(g.below < 0.6 && g.below > 0.6 - 3.0 * entry, "{}", g.below);
        assert_eq!(g.above, f64::from(f32::MAX));
        assert!(resolved.eval(g.below).1 == 0.0 && resolved.eval(0.6 + entry).1 > 0.0);
        let slack = 1e-5 * stats.max + 1e-2 * (0.125 + 0.2);
        assert!((g.slack - slack).abs() < 1e-15, "{}", g.slack);
        assert!(g.describe().contains("below 5.99"), "{}", g.describe());
        // A slope that lets a sample at the minimum jump less than two voxels: no skip.
        assert!(GradientSkip::new(&stats, [0.4, 0.1, 0.1], &resolved).is_none());
        // Nothing transparent: no skip.
        let opaque = tf([0.0, 1.0], 0.0).resolve(&stats).unwrap();
        assert!(GradientSkip::new(&stats, [0.125, 0.1, 0.1], &opaque).is_none());
    }

    #[test]
    fn a_transparent_top_range_and_emission_absorption_s_zero() {
        let v = ramp(|x, _, _| x / 8.0);
        let stats = v.stats();
        // Nothing above 0.7: a top range from just above it.
        let top = ResolvedTransfer::from_functions(crate::model::Scale::Linear, [0.0, 1.0], |v| {
            if v > 0.7 {
                ([0.0; 3], 0.0)
            } else {
                ([1.0; 3], 1.0)
            }
        })
        .unwrap();
        let g = GradientSkip::new(&stats, [0.125, 0.0, 0.0], &top).unwrap();
        let entry = 1.0 / (crate::model::transfer::LUT_SIZE - 1) as f64;
        assert!(g.above > 0.7 && g.above < 0.7 + 3.0 * entry, "{}", g.above);
        assert_eq!(g.below, -f64::from(f32::MAX));
        assert!(g.describe().contains("above 7.0"), "{}", g.describe());
        // e·v and a·v leave only values at or below zero transparent.
        let v = ramp(|x, _, _| x - 4.0);
        let stats = v.stats();
        let ea = TransferFunction::EmissionAbsorption {
            emission: 1.0,
            absorption: 0.1,
        }
        .resolve(&stats)
        .unwrap();
        let g = GradientSkip::new(&stats, [1.0, 0.0, 0.0], &ea).unwrap();
        assert!(g.below <= 0.0 && g.below > -1e-9, "{}", g.below);
        assert_eq!(g.above, f64::from(f32::MAX));
    }
}
