//! The values that samples inside the cells of a coarse grid can interpolate, for empty-space
//! skipping. A sample interpolates the 2×2×2 voxels around it (its stencil, clamped at the
//! volume's faces) and is missing when any of them is. So a cell in which every stencil a
//! sample can use holds a missing voxel contributes nothing whatever the transfer function, and
//! only voxels of stencils without a missing voxel reach a sample's value. At the edge of
//! missing data (outside a shell, below topography) this leaves the cells that hold only broken
//! stencils empty, where the finite values of a cell's footprint would not.

use super::bricks::{BrickLayout, BrickRange};
use super::Volume;
use rayon::prelude::*;

/// Per cell of `layout` (x fastest), the range of the voxels that belong to a stencil without a
/// missing voxel (the stencils of samples inside the cell decide whether there is one; the
/// range may take in a few more voxels of the cell's footprint, which only widens it), or
/// `None` when no sample inside the cell can be anything but missing.
pub(crate) fn stencil_ranges(volume: &Volume, layout: &BrickLayout) -> Vec<BrickRange> {
    (0..layout.grid[2])
        .into_par_iter()
        .flat_map_iter(|cz| CellLayer::new(volume, layout, cz).ranges())
        .collect()
}

/// Stencils are indexed along each axis by b in 0..=n: stencil b holds voxels b - 1 and b,
/// both clamped to 0..n (so b = 0 and b = n are the faces' one-voxel stencils). Samples at
/// voxel coordinates [b - 0.5, b + 0.5) use stencil b.
fn stencil_voxels(b: usize, n: usize) -> [usize; 2] {
    [b.saturating_sub(1), b.min(n - 1)]
}

/// Along a row of n voxels' finiteness, the n + 1 stencils' (stencil_voxels): out[b] is
/// finite[b - 1] and finite[b], clamped at the ends.
fn pairs_and(finite: &[bool], out: &mut [bool]) {
    let n = finite.len();
    out[0] = finite[0];
    out[n] = finite[n - 1];
    and_into(&mut out[1..n], &finite[..n - 1], &finite[1..]);
}

fn and_into(out: &mut [bool], a: &[bool], b: &[bool]) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = x & y;
    }
}

fn or_into(out: &mut [bool], a: &[bool], b: &[bool]) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = x | y;
    }
}

/// One layer of cells (z index `cz`): which stencils of the layer are whole, and which voxels
/// of its footprint belong to one.
struct CellLayer<'a> {
    volume: &'a Volume,
    layout: &'a BrickLayout,
    cz: usize,
    /// The layer's voxel slices (its footprint in z): z_lo..z_hi.
    z_lo: usize,
    z_hi: usize,
    /// The stencils of the layer's samples in z: b_lo..b_hi.
    b_lo: usize,
    b_hi: usize,
    /// Whole stencils, (b_z - b_lo, b_y, b_x) with b_y in 0..=ny, b_x in 0..=nx.
    whole: Vec<bool>,
    /// Voxels of the footprint in a whole stencil of the layer, (z - z_lo, y, x).
    in_whole: Vec<bool>,
}

impl<'a> CellLayer<'a> {
    fn new(volume: &'a Volume, layout: &'a BrickLayout, cz: usize) -> CellLayer<'a> {
        let e = layout.brick;
        let nz = layout.dims[2];
        let mut layer = CellLayer {
            volume,
            layout,
            cz,
            z_lo: (cz * e).saturating_sub(1),
            z_hi: ((cz + 1) * e + 1).min(nz),
            b_lo: cz * e,
            b_hi: ((cz + 1) * e).min(nz) + 1,
            whole: Vec::new(),
            in_whole: Vec::new(),
        };
        layer.whole = layer.whole_stencils();
        layer.in_whole = layer.voxels_in_whole_stencils();
        layer
    }

    /// A stencil is whole when its eight voxels are finite: an AND over the two voxels of each
    /// axis in turn, a row at a time.
    fn whole_stencils(&self) -> Vec<bool> {
        let [nx, ny, nz] = self.layout.dims;
        let (sx, sy) = (nx + 1, ny + 1);
        let slices = self.z_hi - self.z_lo;
        let data = &self.volume.data[nx * ny * self.z_lo..nx * ny * self.z_hi];
        let mut along_x = vec![false; slices * ny * sx];
        let mut finite = vec![false; nx];
        for (row, out) in data.chunks_exact(nx).zip(along_x.chunks_exact_mut(sx)) {
            for (f, v) in finite.iter_mut().zip(row) {
                *f = v.is_finite();
            }
            pairs_and(&finite, out);
        }
        let mut along_xy = vec![false; slices * sy * sx];
        for (plane, out) in along_x
            .chunks_exact(ny * sx)
            .zip(along_xy.chunks_exact_mut(sy * sx))
        {
            for (by, row) in out.chunks_exact_mut(sx).enumerate() {
                let [a, c] = stencil_voxels(by, ny);
                and_into(row, &plane[a * sx..][..sx], &plane[c * sx..][..sx]);
            }
        }
        let plane = sy * sx;
        let mut whole = vec![false; (self.b_hi - self.b_lo) * plane];
        for (bz, out) in (self.b_lo..self.b_hi).zip(whole.chunks_exact_mut(plane)) {
            let [a, c] = stencil_voxels(bz, nz).map(|z| z - self.z_lo);
            and_into(
                out,
                &along_xy[a * plane..][..plane],
                &along_xy[c * plane..][..plane],
            );
        }
        whole
    }

    /// A voxel v belongs to stencils v and v + 1 along each axis: an OR over those in turn (in
    /// z only over the layer's own stencils), a row at a time.
    fn voxels_in_whole_stencils(&self) -> Vec<bool> {
        let [nx, ny, _] = self.layout.dims;
        let (sx, sy) = (nx + 1, ny + 1);
        let plane = sy * sx;
        let slices = self.z_hi - self.z_lo;
        let none = vec![false; plane];
        let stencils = |bz: usize| -> &[bool] {
            if (self.b_lo..self.b_hi).contains(&bz) {
                &self.whole[(bz - self.b_lo) * plane..][..plane]
            } else {
                &none
            }
        };
        let mut along_z = vec![false; slices * plane];
        for (z, out) in along_z.chunks_exact_mut(plane).enumerate() {
            let v = z + self.z_lo;
            or_into(out, stencils(v), stencils(v + 1));
        }
        let mut along_zy = vec![false; slices * ny * sx];
        for (src, out) in along_z
            .chunks_exact(plane)
            .zip(along_zy.chunks_exact_mut(ny * sx))
        {
            for (y, row) in out.chunks_exact_mut(sx).enumerate() {
                or_into(row, &src[y * sx..][..sx], &src[(y + 1) * sx..][..sx]);
            }
        }
        let mut voxels = vec![false; slices * ny * nx];
        for (src, out) in along_zy.chunks_exact(sx).zip(voxels.chunks_exact_mut(nx)) {
            or_into(out, &src[..nx], &src[1..]);
        }
        voxels
    }

    /// The ranges of the layer's cells, x fastest.
    fn ranges(&self) -> Vec<BrickRange> {
        let grid = self.layout.grid;
        (0..grid[0] * grid[1])
            .map(|i| self.cell_range([i % grid[0], i / grid[0], self.cz]))
            .collect()
    }

    fn cell_range(&self, c: [usize; 3]) -> BrickRange {
        let [nx, ny, _] = self.layout.dims;
        let (sx, sy) = (nx + 1, ny + 1);
        let e = self.layout.brick;
        // Samples inside the cell use stencils c·e ..= (c + 1)·e along x and y.
        let bx = c[0] * e..=((c[0] + 1) * e).min(nx);
        let by = c[1] * e..=((c[1] + 1) * e).min(ny);
        let any_whole = (0..self.b_hi - self.b_lo).any(|z| {
            by.clone()
                .any(|y| bx.clone().any(|x| self.whole[x + sx * (y + sy * z)]))
        });
        if !any_whole {
            return None;
        }
        let (lo, hi) = self.layout.footprint(c);
        let mut range: BrickRange = None;
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                let row = nx * (y + ny * (z - self.z_lo));
                let voxel_row = nx * (y + ny * z);
                for x in lo[0]..hi[0] {
                    if self.in_whole[row + x] {
                        let v = self.volume.data[voxel_row + x];
                        range = Some(match range {
                            None => [v, v],
                            Some([a, b]) => [a.min(v), b.max(v)],
                        });
                    }
                }
            }
        }
        range
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ranges by brute force: every stencil the samples inside each cell use, and the
    /// values of those without a missing voxel.
    fn brute(volume: &Volume, layout: &BrickLayout) -> Vec<BrickRange> {
        let [nx, ny, nz] = layout.dims;
        let e = layout.brick;
        let at = |x: usize, y: usize, z: usize| volume.data[x + nx * (y + ny * z)];
        let mut ranges = vec![None; layout.count()];
        for (id, range) in ranges.iter_mut().enumerate() {
            let g = layout.grid;
            let c = [id % g[0], (id / g[0]) % g[1], id / (g[0] * g[1])];
            // Stencil b is used by samples at [b - 0.5, b + 0.5): those of the cell, per axis.
            let stencils = |a: usize| {
                let n = layout.dims[a];
                c[a] * e..=((c[a] + 1) * e).min(n)
            };
            let mut r: BrickRange = None;
            for bz in stencils(2) {
                for by in stencils(1) {
                    for bx in stencils(0) {
                        let xs = stencil_voxels(bx, nx);
                        let ys = stencil_voxels(by, ny);
                        let zs = stencil_voxels(bz, nz);
                        let vals: Vec<f32> = zs
                            .iter()
                            .flat_map(|&z| ys.iter().flat_map(move |&y| xs.map(|x| (x, y, z))))
                            .map(|(x, y, z)| at(x, y, z))
                            .collect();
                        if vals.iter().all(|v| v.is_finite()) {
                            for v in vals {
                                r = Some(match r {
                                    None => [v, v],
                                    Some([a, b]) => [a.min(v), b.max(v)],
                                });
                            }
                        }
                    }
                }
            }
            *range = r;
        }
        ranges
    }

    #[test]
    fn stencil_ranges_cover_exactly_the_cells_with_a_whole_stencil() {
        let dims = [11, 9, 10];
        let mut seed = 99u64;
        let data: Vec<f32> = (0..dims.iter().product::<usize>())
            .map(|i| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                // A ball of finite values with scattered holes, missing outside.
                let (x, y, z) = (i % 11, (i / 11) % 9, i / 99);
                let r2 =
                    (x as f32 - 4.0).powi(2) + (y as f32 - 4.5).powi(2) + (z as f32 - 5.0).powi(2);
                if r2 > 16.0 || (seed >> 33).is_multiple_of(13) {
                    f32::NAN
                } else {
                    (seed >> 40) as f32 / 1e4
                }
            })
            .collect();
        let volume = Volume::new("ball", dims, [1.0; 3], [0.0; 3], data).unwrap();
        for edge in [2, 4] {
            let layout = BrickLayout {
                dims,
                brick: edge,
                grid: dims.map(|d| d.div_ceil(edge)),
            };
            let fast = stencil_ranges(&volume, &layout);
            let exact = brute(&volume, &layout);
            for (f, e) in fast.iter().zip(&exact) {
                match (f, e) {
                    (None, None) => {}
                    // The range may take in more voxels than the cell's stencils, never fewer.
                    (Some([a, b]), Some([c, d])) => assert!(a <= c && b >= d, "{f:?} {e:?}"),
                    _ => panic!("emptiness differs: {f:?} against {e:?}"),
                }
            }
            assert!(exact.iter().any(Option::is_none) && exact.iter().any(Option::is_some));
            // Cells with finite voxels in their footprint but only broken stencils: empty here,
            // not by their footprint's finite values.
            let broken = (0..layout.count()).filter(|&id| {
                let g = layout.grid;
                let (lo, hi) =
                    layout.footprint([id % g[0], (id / g[0]) % g[1], id / (g[0] * g[1])]);
                let finite = (lo[2]..hi[2]).any(|z| {
                    (lo[1]..hi[1]).any(|y| {
                        (lo[0]..hi[0])
                            .any(|x| volume.data[x + dims[0] * (y + dims[1] * z)].is_finite())
                    })
                });
                finite && fast[id].is_none()
            });
            assert!(broken.count() > 0);
        }
    }
}
