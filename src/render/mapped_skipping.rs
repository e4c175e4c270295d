//! Empty-space skipping for the mapped ray caster (spherical shells and wedges, rectilinear
//! boxes). Its samples map through the axes to index space, so the skip grid is a grid of
//! world-space cells over the volume's bounding box instead: each cell holds the finite value
//! range of every voxel a sample inside it can interpolate — the index box spanned by the cell's
//! radius, latitude and longitude bounds (a box's: its x, y and z), widened to the trilinear
//! neighbours. The bounds are conservative (a cell's latitudes from the extremes of z / r over
//! it, its longitudes from its corners, all of them where it holds the polar axis), so a cell
//! called empty is empty, and the image with skipping is the one without it. Classification
//! under a transfer function, the per-octant extents and the GPU texture are the box's
//! ([`super::skipping`]); `skip_walk` in shaders/volume_mapped.wgsl jumps the march's walk to
//! where a ray leaves an empty cube of cells.

use super::cache::KeyBuilder;
use super::session::RenderSession;
use super::skipping::SkipGrid;
use super::VolumeRenderOptions;
use crate::error::Result;
use crate::model::bricks::{empty_ranges, BrickRange};
use crate::model::{CoordAxis, Geometry, SphericalGrid, Volume, VolumeStats};
use rayon::prelude::*;
use std::sync::Arc;

/// Cells per axis of the bounding box at most: as the box's skip grid (96³ cells).
const MAX_CELLS: usize = 96;
/// A cell's edge in voxel lengths at least.
const CELL_VOXELS: f64 = 1.0;
/// The share of the domain's cells that must be empty for skipping to pay: the walk over the
/// grid costs about a third of a plain march on lavapipe (`hdrvis bench skipping`: the mantle
/// shell with 28 % of its cells empty ran 0.6× as fast with it, the tomography model with 97 %
/// 4×).
pub(crate) const MIN_EMPTY_FRACTION: f64 = 0.5;
/// Voxels per edge of the blocks whose ranges answer a cell's query.
const BLOCK: usize = 2;

/// The value ranges of the world-space cells of a volume placed by coordinate axes.
pub(crate) struct WorldCells {
    /// Cells per axis over the bounding box, each of [`cell_size`].
    pub grid: [usize; 3],
    pub ranges: Vec<BrickRange>,
    /// Cells where no sample can lie in the domain (which the march clips analytically).
    pub outside: usize,
    /// The volume's statistics (transfer functions resolve on them).
    pub stats: VolumeStats,
}

impl WorldCells {
    /// The cells of `volume` (spherical or rectilinear; a regular box as even axes).
    pub(crate) fn of(volume: &Volume) -> WorldCells {
        let bounds = volume.bounds();
        let voxel = volume.voxel_length();
        let extent = [0, 1, 2].map(|a| bounds.hi[a] - bounds.lo[a]);
        let grid =
            extent.map(|e| ((e / (CELL_VOXELS * voxel)).ceil() as usize).clamp(1, MAX_CELLS));
        let size = cell_size(volume, grid);
        let blocks = BlockRanges::of(volume);
        let index_box = |c: [usize; 3]| {
            let lo = [0, 1, 2].map(|a| bounds.lo[a] + c[a] as f64 * size[a]);
            let hi = [0, 1, 2].map(|a| lo[a] + size[a]);
            cell_index_box(volume, lo, hi)
        };
        let [nx, ny, nz] = grid;
        let cells: Vec<Option<BrickRange>> = (0..nx * ny * nz)
            .into_par_iter()
            .map(|i| {
                let c = [i % nx, (i / nx) % ny, i / (nx * ny)];
                index_box(c).map(|b| blocks.range(b))
            })
            .collect();
        WorldCells {
            grid,
            outside: cells.iter().filter(|c| c.is_none()).count(),
            ranges: cells.into_iter().map(Option::flatten).collect(),
            stats: volume.stats(),
        }
    }

    pub(crate) fn count(&self) -> usize {
        self.ranges.len()
    }
}

impl RenderSession {
    /// The world-space cells of a volume the mapped ray caster renders, read once per volume.
    fn world_cells(&self, volume: &Arc<Volume>) -> Result<Arc<WorldCells>> {
        let key = KeyBuilder::new("world cells")
            .u64(self.volume_key(volume))
            .finish();
        self.stage_with(
            "world-cells",
            key,
            false,
            |c: &WorldCells| c.count() as u64 * 12,
            |_, _| {},
            || {
                let c = WorldCells::of(volume);
                let [x, y, z] = c.grid;
                Ok((c, format!("{x}x{y}x{z} world cells")))
            },
        )
    }

    /// The mapped ray caster's skip grid of `volume` under the options' transfer function,
    /// cached per function.
    pub(crate) fn mapped_skip_grid(
        &self,
        volume: &Arc<Volume>,
        opts: &VolumeRenderOptions,
    ) -> Result<Arc<SkipGrid>> {
        let cells = self.world_cells(volume)?;
        self.skip_grid_stage("mapped skip grid", volume, opts, &cells.stats, |ctx, tf| {
            let empty = empty_ranges(&cells.ranges, tf);
            let mut g = SkipGrid::from_empty(ctx, &empty, cells.grid, 1, cells.grid);
            g.outside = cells.outside;
            let detail = format!(
                "{} of {} world cells in the domain empty",
                g.empty - g.outside,
                g.cells() - g.outside
            );
            (g, detail)
        })
    }
}

/// The edges of the cells of a `grid` over `volume`'s bounding box (from its lower corner).
pub(crate) fn cell_size(volume: &Volume, grid: [usize; 3]) -> [f64; 3] {
    let b = volume.bounds();
    [0, 1, 2].map(|a| (b.hi[a] - b.lo[a]) / grid[a] as f64)
}

/// Inclusive voxel index ranges along the volume's three axes.
type IndexBox = [[usize; 2]; 3];

/// The voxels a sample inside the world box `[lo, hi]` can interpolate, or `None` where no
/// sample can lie in the domain there.
fn cell_index_box(volume: &Volume, lo: [f64; 3], hi: [f64; 3]) -> Option<IndexBox> {
    let axes;
    let boxed: &[CoordAxis; 3] = match &volume.geometry {
        Geometry::Spherical(g) => return spherical_index_box(g, volume.dims, lo, hi),
        Geometry::Rectilinear(a) => a,
        Geometry::Regular => {
            axes = [0, 1, 2].map(|a| {
                CoordAxis::uniform_cells(volume.origin[a], volume.spacing[a], volume.dims[a])
            });
            &axes
        }
    };
    let mut b = [[0; 2]; 3];
    for a in 0..3 {
        b[a] = index_range(&boxed[a], lo[a], hi[a], volume.dims[a]);
    }
    Some(b)
}

/// The voxels along `axis` (of `n`) that trilinear samples at coordinates in `[x0, x1]` read:
/// from the floor of the lower fractional index to the one above the upper's, clamped, and one
/// more each way for the shader's f32 rounding of a sample's index.
fn index_range(axis: &CoordAxis, x0: f64, x1: f64, n: usize) -> [usize; 2] {
    let (f0, f1) = (axis.fractional_index(x0), axis.fractional_index(x1));
    let clamp = |f: f64| f.clamp(0.0, (n - 1) as f64) as usize;
    [
        clamp(f0.min(f1).floor() - 1.0),
        clamp(f0.max(f1).floor() + 2.0),
    ]
}

/// [`cell_index_box`] of a shell or wedge: the cell's radii (nearest and farthest point),
/// latitudes (extremes of z / r) and longitudes (its corners', or all where it holds the polar
/// axis) through the grid's axes; all longitudes where the range crosses a closed circle's seam.
fn spherical_index_box(
    g: &SphericalGrid,
    dims: [usize; 3],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Option<IndexBox> {
    let near = [0, 1, 2].map(|a| 0.0f64.clamp(lo[a], hi[a]));
    let far = [0, 1, 2].map(|a| lo[a].abs().max(hi[a].abs()));
    let (r0, r1) = (norm(near), norm(far));
    if r0 > g.radius.hi || r1 < g.radius.lo {
        return None;
    }
    let (r0, r1) = (r0.max(g.radius.lo), r1.min(g.radius.hi));
    let mut b = [[0; 2]; 3];
    b[g.axis_of[0]] = index_range(&g.radius, r0, r1, dims[g.axis_of[0]]);
    let lat_axis = dims[g.axis_of[1]];
    let lon_axis = dims[g.axis_of[2]];
    let all = |n: usize| [0, n - 1];
    if r0 <= 0.0 {
        b[g.axis_of[1]] = all(lat_axis);
        b[g.axis_of[2]] = all(lon_axis);
        return Some(b);
    }
    let sin_lo = if lo[2] >= 0.0 { lo[2] / r1 } else { lo[2] / r0 };
    let sin_hi = if hi[2] >= 0.0 { hi[2] / r0 } else { hi[2] / r1 };
    let lat = |s: f64| s.clamp(-1.0, 1.0).asin().to_degrees();
    let (lat0, lat1) = (
        lat(sin_lo).max(g.latitude.lo),
        lat(sin_hi).min(g.latitude.hi),
    );
    if lat0 > lat1 {
        return None;
    }
    b[g.axis_of[1]] = index_range(&g.latitude, lat0, lat1, lat_axis);
    b[g.axis_of[2]] = match longitude_span(lo, hi) {
        None => all(lon_axis),
        Some((west, east)) => lon_index_range(g, west, east, lon_axis)?,
    };
    Some(b)
}

/// The longitude voxels that samples between `west` and `east` (less than a turn apart) read,
/// moved into the domain's turn as the shader wraps them: a closed circle's whole axis where
/// they reach past its first or last centre (the seam); a wedge's voxels of the part of them
/// inside it, `None` where none is.
fn lon_index_range(g: &SphericalGrid, west: f64, east: f64, n: usize) -> Option<[usize; 2]> {
    let lon = &g.longitude;
    let w = lon.lo + (west - lon.lo).rem_euclid(360.0);
    let e = w + (east - west);
    if g.lon_wraps {
        let first = lon.centres[0].min(lon.centres[n - 1]);
        let last = lon.centres[0].max(lon.centres[n - 1]);
        return Some(if w < first || e > last {
            [0, n - 1]
        } else {
            index_range(lon, w, e, n)
        });
    }
    // The part from w eastward, and the part that comes round past the domain's start.
    let pieces = [(w, e.min(lon.hi)), (lon.lo, (e - 360.0).min(lon.hi))];
    pieces
        .into_iter()
        .filter(|(a, b)| a <= b && *a <= lon.hi)
        .map(|(a, b)| index_range(lon, a, b, n))
        .reduce(|x, y| [x[0].min(y[0]), x[1].max(y[1])])
}

/// The longitudes (degrees east, `west <= east`, less than half a turn apart) of the box's
/// projection on the equatorial plane, or `None` where it holds the polar axis.
fn longitude_span(lo: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
    if lo[0] <= 0.0 && hi[0] >= 0.0 && lo[1] <= 0.0 && hi[1] >= 0.0 {
        return None;
    }
    let centre = (0.5 * (lo[1] + hi[1]))
        .atan2(0.5 * (lo[0] + hi[0]))
        .to_degrees();
    let (mut d0, mut d1) = (f64::INFINITY, f64::NEG_INFINITY);
    for (x, y) in [
        (lo[0], lo[1]),
        (hi[0], lo[1]),
        (lo[0], hi[1]),
        (hi[0], hi[1]),
    ] {
        let d = (y.atan2(x).to_degrees() - centre + 180.0).rem_euclid(360.0) - 180.0;
        (d0, d1) = (d0.min(d), d1.max(d));
    }
    Some((centre + d0, centre + d1))
}

fn norm(p: [f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

/// Finite value ranges of blocks of [`BLOCK`]³ voxels, for range queries over index boxes.
struct BlockRanges {
    grid: [usize; 3],
    ranges: Vec<BrickRange>,
}

impl BlockRanges {
    fn of(volume: &Volume) -> BlockRanges {
        let grid = volume.dims.map(|d| d.div_ceil(BLOCK));
        let [gx, gy, gz] = grid;
        let ranges = (0..gx * gy * gz)
            .into_par_iter()
            .map(|i| {
                let c = [i % gx, (i / gx) % gy, i / (gx * gy)];
                let b =
                    [0, 1, 2].map(|a| [c[a] * BLOCK, ((c[a] + 1) * BLOCK).min(volume.dims[a]) - 1]);
                voxel_range(volume, b)
            })
            .collect();
        BlockRanges { grid, ranges }
    }

    /// The finite range over the blocks that hold any voxel of `b`.
    fn range(&self, b: IndexBox) -> BrickRange {
        let blocks = b.map(|[i0, i1]| [i0 / BLOCK, i1 / BLOCK]);
        let mut out: BrickRange = None;
        for z in blocks[2][0]..=blocks[2][1] {
            for y in blocks[1][0]..=blocks[1][1] {
                for x in blocks[0][0]..=blocks[0][1] {
                    let r = self.ranges[(z * self.grid[1] + y) * self.grid[0] + x];
                    out = union(out, r);
                }
            }
        }
        out
    }
}

fn union(a: BrickRange, b: BrickRange) -> BrickRange {
    match (a, b) {
        (Some([a0, a1]), Some([b0, b1])) => Some([a0.min(b0), a1.max(b1)]),
        (x, None) | (None, x) => x,
    }
}

/// The finite range of the voxels of the index box `b` (`None`: all missing).
fn voxel_range(volume: &Volume, b: IndexBox) -> BrickRange {
    let mut out: BrickRange = None;
    for k in b[2][0]..=b[2][1] {
        for j in b[1][0]..=b[1][1] {
            let row = volume.index(b[0][0], j, k);
            for &v in &volume.data[row..=row + (b[0][1] - b[0][0])] {
                if v.is_finite() {
                    out = union(out, Some([v, v]));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Geometry;

    /// A wedge and a whole shell of pseudo-random values (with missing voxels), on CF-ordered
    /// axes: at thousands of points in every cell, the sample the f64 reference interpolates is
    /// missing or within the cell's range; and cells outside the domain hold nothing.
    #[test]
    fn every_sample_in_a_cell_lies_in_its_range() {
        for (lat, lon, wraps) in [
            ([-30.0, 60.0], [100.0, 200.0], false),
            ([-90.0, 90.0], [-180.0, 180.0], true),
        ] {
            let v = random_shell(lat, lon, wraps);
            let cells = WorldCells::of(&v);
            let [nx, ny, _] = cells.grid;
            let (lo, size) = (v.bounds().lo, cell_size(&v, cells.grid));
            let mut checked = 0;
            let mut seed = 7u64;
            for (i, range) in cells.ranges.iter().enumerate() {
                let c = [i % nx, (i / nx) % ny, i / (nx * ny)];
                for _ in 0..300 {
                    let p = [0, 1, 2].map(|a| lo[a] + (c[a] as f64 + unit(&mut seed)) * size[a]);
                    let Geometry::Spherical(g) = &v.geometry else {
                        unreachable!()
                    };
                    if !g.contains(p) {
                        continue;
                    }
                    let s = v.sample_world(p);
                    if !s.is_finite() {
                        continue;
                    }
                    let [lo, hi] = range.unwrap_or_else(|| panic!("cell {c:?} at {p:?}: {s}"));
                    assert!(
                        s >= lo as f64 - 1e-6 && s <= hi as f64 + 1e-6,
                        "cell {c:?} at {p:?}: {s} outside [{lo}, {hi}]"
                    );
                    checked += 1;
                }
            }
            assert!(checked > 10_000, "{checked}");
            assert!(cells.ranges.iter().any(Option::is_none));
        }
    }

    fn unit(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Values on (lon, lat, depth) memory order: x longitude, y latitude, z radius.
    fn random_shell(lat: [f64; 2], lon: [f64; 2], wraps: bool) -> Volume {
        let (nr, nlat, nlon) = (9usize, 13usize, 17usize);
        let even = |a: f64, b: f64, n: usize, cells: bool| {
            let step = (b - a) / if cells { n as f64 } else { (n - 1) as f64 };
            let off = if cells { 0.5 } else { 0.0 };
            let c: Vec<f64> = (0..n).map(|i| a + (i as f64 + off) * step).collect();
            CoordAxis::new(c, Some((a, b)), "axis").unwrap()
        };
        let g = SphericalGrid {
            axis_of: [2, 1, 0],
            radius: even(0.5, 1.0, nr, false),
            latitude: even(lat[0], lat[1], nlat, !wraps),
            longitude: even(lon[0], lon[1], nlon, true),
            lon_wraps: wraps,
            planet_radius: 1.0,
            length_unit: "1".into(),
            vertical: "radius".into(),
            rotated_pole: None,
        };
        let mut seed = 3u64;
        let data: Vec<f32> = (0..nr * nlat * nlon)
            .map(|i| {
                let v = unit(&mut seed);
                if i % 23 == 0 {
                    f32::NAN
                } else {
                    (10.0 * v) as f32
                }
            })
            .collect();
        Volume::new("shell", [nlon, nlat, nr], [1.0; 3], [0.0; 3], data)
            .unwrap()
            .with_geometry(Geometry::Spherical(Box::new(g)))
            .unwrap()
    }
}
