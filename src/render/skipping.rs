//! Empty-space skipping for the in-core ray caster. The volume is read once into a coarse grid
//! of cells of 4³ or 8³ voxels ([`cell_edge`]) holding the finite value range of each cell's footprint (its
//! voxels and a one-voxel apron: everything a sample inside it interpolates). Against the
//! render's transfer function each cell is empty — every value it can interpolate to has zero
//! emission and extinction, or it holds only missing data — or not; a transfer-function change
//! re-classifies the ranges without reading the volume again. The GPU gets, per cell, the
//! Chebyshev distance in cells to the nearest cell that is not empty, so one lookup tells how
//! large a block of empty cells surrounds a sample and the march jumps to that block's exit in
//! one loop iteration (`skip_empty` in shaders/volume.wgsl). The jump lands on the march's own
//! segment grid, so the image is the one without skipping.

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::model::bricks::{empty_ranges, BrickLayout, BrickRange, BrickedVolume};
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Volume, VolumeStats};
use std::sync::Arc;

/// Voxels per cell edge of the skip grid for a volume of `dims`: small enough to follow a
/// shell's curvature, large enough that the grid is classified in milliseconds. 4 voxels up to
/// 384 per axis (at most 96³ cells), 8 beyond (measured on the mantle at 257³: 4-voxel cells
/// skip about 10 % more of the time than 8-voxel ones; `hdrvis bench skipping`).
pub(crate) fn cell_edge(dims: [usize; 3]) -> usize {
    if dims.iter().all(|&d| d <= 384) {
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
}

impl CellRanges {
    pub(crate) fn of(volume: Arc<Volume>) -> Result<CellRanges> {
        let b = BrickedVolume::cells(volume.clone(), cell_edge(volume.dims))?;
        Ok(CellRanges {
            layout: b.layout,
            ranges: b.ranges,
            stats: b.stats,
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

/// A classified skip grid on the GPU.
pub(crate) struct SkipGrid {
    pub grid: [usize; 3],
    /// Voxels per cell edge.
    pub edge: usize,
    pub empty: usize,
    view: wgpu::TextureView,
}

impl SkipGrid {
    pub(crate) fn new(ctx: &GpuContext, cells: &CellRanges, tf: &ResolvedTransfer) -> SkipGrid {
        let grid = cells.layout.grid;
        let empty = cells.empty_cells(tf);
        let distance = chebyshev_distance(&empty, grid);
        let texture = ctx.r32f_texture_3d("skip grid", grid.map(|g| g as u32));
        ctx.queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&distance),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(grid[0] as u32 * 4),
                rows_per_image: Some(grid[1] as u32),
            },
            wgpu::Extent3d {
                width: grid[0] as u32,
                height: grid[1] as u32,
                depth_or_array_layers: grid[2] as u32,
            },
        );
        SkipGrid {
            grid,
            edge: cells.edge(),
            empty: empty.iter().filter(|&&e| e).count(),
            view: texture.create_view(&Default::default()),
        }
    }

    pub(crate) fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    pub(crate) fn cells(&self) -> usize {
        self.grid.iter().product()
    }

    pub(crate) fn empty_fraction(&self) -> f64 {
        self.empty as f64 / self.cells().max(1) as f64
    }

    pub(crate) fn bytes(&self) -> u64 {
        self.cells() as u64 * 4
    }
}

/// Per cell, the Chebyshev (L∞) distance in cells to the nearest cell that is not empty: 0 for
/// those, and past the grid's largest extent where every cell is empty. Two raster passes with
/// the 26-neighbourhood at unit cost, exact for this metric.
pub(crate) fn chebyshev_distance(empty: &[bool], grid: [usize; 3]) -> Vec<f32> {
    let [nx, ny, nz] = grid;
    let far = (nx.max(ny).max(nz) + 1) as u32;
    // A one-cell border that is never updated (outside the volume nothing is "not empty"), so
    // neighbours need no bounds checks.
    let (px, py) = (nx + 2, ny + 2);
    let mut d = vec![far; px * py * (nz + 2)];
    let padded = |x: usize, y: usize, z: usize| (x + 1) + px * ((y + 1) + py * (z + 1));
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if !empty[x + nx * (y + ny * z)] {
                    d[padded(x, y, z)] = 0;
                }
            }
        }
    }
    // The 13 neighbours before a cell in raster order (x fastest); the pass back uses the others.
    let mut before = Vec::new();
    for dz in -1isize..=1 {
        for dy in -1isize..=1 {
            for dx in -1isize..=1 {
                if (dz, dy, dx) < (0, 0, 0) {
                    before.push(dx + px as isize * (dy + py as isize * dz));
                }
            }
        }
    }
    let cells: Vec<usize> = (0..nz)
        .flat_map(|z| (0..ny).flat_map(move |y| (0..nx).map(move |x| (x, y, z))))
        .map(|(x, y, z)| padded(x, y, z))
        .collect();
    let relax = |d: &mut Vec<u32>, i: usize, sign: isize| {
        let mut best = d[i];
        for &o in &before {
            best = best.min(d[(i as isize + sign * o) as usize] + 1);
        }
        d[i] = best.min(far);
    };
    for &i in &cells {
        relax(&mut d, i, 1);
    }
    for &i in cells.iter().rev() {
        relax(&mut d, i, -1);
    }
    cells.iter().map(|&i| d[i] as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distance by brute force: the nearest non-empty cell over the whole grid.
    fn brute(empty: &[bool], grid: [usize; 3]) -> Vec<f32> {
        let [nx, ny, nz] = grid;
        let far = (nx.max(ny).max(nz) + 1) as f32;
        (0..empty.len())
            .map(|i| {
                let p = [i % nx, (i / nx) % ny, i / (nx * ny)];
                let mut best = far;
                for (j, &e) in empty.iter().enumerate() {
                    if !e {
                        let q = [j % nx, (j / nx) % ny, j / (nx * ny)];
                        let d = (0..3).map(|a| p[a].abs_diff(q[a])).max().unwrap() as f32;
                        best = best.min(d);
                    }
                }
                best
            })
            .collect()
    }

    #[test]
    fn chebyshev_distance_matches_brute_force() {
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
        for empty in [sparse, single, vec![true; n], vec![false; n]] {
            assert_eq!(chebyshev_distance(&empty, grid), brute(&empty, grid));
        }
    }
}
