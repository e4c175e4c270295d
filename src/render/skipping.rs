//! Empty-space skipping for the in-core ray caster. The volume is read once into a coarse grid
//! of cells of [`CELL`]³ voxels holding the finite value range of each cell's footprint (its
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
use crate::model::bricks::{BrickLayout, BrickRange, BrickedVolume};
use crate::model::transfer::ResolvedTransfer;
use crate::model::{Volume, VolumeStats};
use std::sync::Arc;

/// Voxels per cell edge of the skip grid: small enough to follow a shell's curvature, large
/// enough that the grid (1/512 of the voxels) is classified in milliseconds.
pub(crate) const CELL: usize = 8;

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
        let b = BrickedVolume::from_volume(volume, CELL)?;
        Ok(CellRanges {
            layout: b.layout,
            ranges: b.ranges,
            stats: b.stats,
        })
    }

    pub(crate) fn count(&self) -> usize {
        self.ranges.len()
    }

    pub(crate) fn stats(&self) -> &VolumeStats {
        &self.stats
    }

    /// Which cells `tf` leaves empty.
    pub(crate) fn empty_cells(&self, tf: &ResolvedTransfer) -> Vec<bool> {
        self.ranges
            .iter()
            .map(|r| match r {
                None => true,
                Some([lo, hi]) => tf.is_transparent(*lo as f64, *hi as f64),
            })
            .collect()
    }
}

/// A classified skip grid on the GPU.
pub(crate) struct SkipGrid {
    pub grid: [usize; 3],
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
    let mut d: Vec<u32> = empty.iter().map(|&e| if e { far } else { 0 }).collect();
    let idx = |x: usize, y: usize, z: usize| x + nx * (y + ny * z);
    // Forward pass: neighbours earlier in raster order (13 of the 26); backward: the others.
    for forward in [true, false] {
        let order: Vec<usize> = if forward {
            (0..nx * ny * nz).collect()
        } else {
            (0..nx * ny * nz).rev().collect()
        };
        for i in order {
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            let mut best = d[i];
            for dz in -1i64..=1 {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let earlier = (dz, dy, dx) < (0, 0, 0);
                        if (dz, dy, dx) == (0, 0, 0) || earlier != forward {
                            continue;
                        }
                        let (qx, qy, qz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                        if qx < 0 || qy < 0 || qz < 0 {
                            continue;
                        }
                        let (qx, qy, qz) = (qx as usize, qy as usize, qz as usize);
                        if qx < nx && qy < ny && qz < nz {
                            best = best.min(d[idx(qx, qy, qz)] + 1);
                        }
                    }
                }
            }
            d[i] = best.min(far);
        }
    }
    d.into_iter().map(|v| v as f32).collect()
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
