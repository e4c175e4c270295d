//! Bricked volumes for large data: the voxel grid cut into cubic bricks of B³ voxels, each stored
//! with a one-voxel apron (B + 2 per side) so trilinear sampling inside a brick never needs a
//! neighbour, plus per-brick value ranges over that apron-extended footprint. The index (ranges
//! and statistics) is built by streaming the source in z-slabs, so a volume larger than memory is
//! never held at once; brick data are read on demand from a [`VoxelSource`] (an in-memory volume,
//! a `.npy` read by positioned reads, NetCDF hyperslabs). Also here: which bricks a transfer function leaves
//! empty, the front-to-back visibility order of bricks for a camera, and the 2× downsampled level.

use super::transfer::ResolvedTransfer;
use super::volume::{check_allocation, Volume, VolumeStats};
use crate::error::{Error, Result};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Brick edges the renderer accepts: powers of two, so voxel → brick is an exact scaling.
pub(crate) const BRICK_SIZES: &[usize] = &[8, 16, 32, 64, 128];
/// Default brick edge in voxels: fine enough for empty-space skipping, with a 27 % apron overhead.
pub(crate) const DEFAULT_BRICK: usize = 32;

/// Where voxels come from. `read_box` fills `out` (x fastest, then y, then z) with the voxels
/// `lo .. lo + size`, which lie inside the volume.
pub trait VoxelSource: Send + Sync {
    /// Voxel counts (nx, ny, nz).
    fn dims(&self) -> [usize; 3];
    fn read_box(&self, lo: [usize; 3], size: [usize; 3], out: &mut [f32]) -> Result<()>;
    /// What the source is, for messages.
    fn describe(&self) -> String;
}

/// A volume in memory as a voxel source.
pub(crate) struct MemorySource(pub Arc<Volume>);

impl VoxelSource for MemorySource {
    fn dims(&self) -> [usize; 3] {
        self.0.dims
    }

    fn read_box(&self, lo: [usize; 3], size: [usize; 3], out: &mut [f32]) -> Result<()> {
        let v = &self.0;
        let mut o = 0;
        for k in lo[2]..lo[2] + size[2] {
            for j in lo[1]..lo[1] + size[1] {
                let start = v.index(lo[0], j, k);
                out[o..o + size[0]].copy_from_slice(&v.data[start..start + size[0]]);
                o += size[0];
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("{} (in memory)", self.0.name)
    }
}

/// How a volume of `dims` voxels is cut into bricks of `brick` voxels per side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BrickLayout {
    pub dims: [usize; 3],
    pub brick: usize,
    /// Bricks per axis.
    pub grid: [usize; 3],
}

impl BrickLayout {
    pub fn new(dims: [usize; 3], brick: usize) -> Result<BrickLayout> {
        if !BRICK_SIZES.contains(&brick) {
            return Err(Error::invalid(
                "brick",
                format!("expected one of {BRICK_SIZES:?} voxels, got {brick}"),
            ));
        }
        Ok(BrickLayout {
            dims,
            brick,
            grid: dims.map(|d| d.div_ceil(brick)),
        })
    }

    pub fn count(&self) -> usize {
        self.grid.iter().product()
    }

    /// Voxels per side of a stored brick: the brick and its one-voxel apron.
    pub(crate) fn stored_edge(&self) -> usize {
        self.brick + 2
    }

    /// Bytes of one stored brick (f32).
    pub fn stored_bytes(&self) -> u64 {
        (self.stored_edge() as u64).pow(3) * 4
    }

    pub(crate) fn coords(&self, id: usize) -> [usize; 3] {
        [
            id % self.grid[0],
            (id / self.grid[0]) % self.grid[1],
            id / (self.grid[0] * self.grid[1]),
        ]
    }

    pub fn id(&self, c: [usize; 3]) -> usize {
        c[0] + self.grid[0] * (c[1] + self.grid[1] * c[2])
    }

    /// The voxels a sample inside brick `c` can touch: its interior and a one-voxel apron,
    /// clipped to the volume, as (lo, hi exclusive).
    pub(crate) fn footprint(&self, c: [usize; 3]) -> ([usize; 3], [usize; 3]) {
        let lo = [0, 1, 2].map(|a| (c[a] * self.brick).saturating_sub(1));
        let hi = [0, 1, 2].map(|a| ((c[a] + 1) * self.brick + 1).min(self.dims[a]));
        (lo, hi)
    }
}

/// The finite value range of a brick's footprint; `None` when every voxel there is missing.
pub(crate) type BrickRange = Option<[f32; 2]>;

/// Which of `ranges` `tf` leaves empty: every value their footprint can interpolate to has zero
/// emission and zero extinction, or every voxel there is missing. Skipping them changes no
/// sample's contribution.
pub(crate) fn empty_ranges(ranges: &[BrickRange], tf: &ResolvedTransfer) -> Vec<bool> {
    let transparency = tf.transparency();
    // In parallel: a fine skip grid has millions of cells, classified again on every transfer
    // function change.
    ranges
        .par_iter()
        .map(|r| match r {
            None => true,
            Some([lo, hi]) => transparency.covers(*lo as f64, *hi as f64),
        })
        .collect()
}

/// A volume as bricks: geometry, statistics and per-brick ranges, with voxels read on demand.
pub struct BrickedVolume {
    pub name: String,
    pub units: String,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    pub stats: VolumeStats,
    pub layout: BrickLayout,
    pub ranges: Vec<BrickRange>,
    source: Arc<dyn VoxelSource>,
    bricks_read: AtomicU64,
}

impl std::fmt::Debug for BrickedVolume {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "BrickedVolume({} {:?}, {} bricks of {}³, {})",
            self.name,
            self.dims,
            self.layout.count(),
            self.layout.brick,
            self.source.describe()
        )
    }
}

impl BrickedVolume {
    /// Builds the brick index of `source` by streaming it in slabs of one brick layer (plus the
    /// apron) at a time: per-brick ranges and the volume statistics, never the whole volume.
    pub(crate) fn build(
        name: impl Into<String>,
        source: Arc<dyn VoxelSource>,
        spacing: [f64; 3],
        origin: [f64; 3],
        brick: usize,
    ) -> Result<BrickedVolume> {
        let dims = source.dims();
        super::volume::check_shape(&dims, "dims")?;
        let layout = BrickLayout::new(dims, brick)?;
        Self::index(name.into(), source, spacing, origin, layout)
    }

    /// Streams `source` once for the per-brick ranges of `layout` and the volume statistics.
    fn index(
        name: String,
        source: Arc<dyn VoxelSource>,
        spacing: [f64; 3],
        origin: [f64; 3],
        layout: BrickLayout,
    ) -> Result<BrickedVolume> {
        use rayon::prelude::*;
        let dims = layout.dims;
        let brick = layout.brick;
        let [nx, ny, nz] = dims;
        let slice = nx * ny;
        let slab_slices = (brick + 2).min(nz);
        check_allocation((slice * slab_slices * 4) as u64, "brick index slab")?;
        let mut slab = vec![0f32; slice * slab_slices];
        let mut ranges = vec![None; layout.count()];
        let mut stats = VolumeStats::EMPTY;
        for bz in 0..layout.grid[2] {
            let z_lo = (bz * brick).saturating_sub(1);
            let z_hi = ((bz + 1) * brick + 1).min(nz);
            let buf = &mut slab[..slice * (z_hi - z_lo)];
            source.read_box([0, 0, z_lo], [nx, ny, z_hi - z_lo], buf)?;
            let buf = &*buf;
            // Statistics over this layer's own slices only, so each voxel counts once.
            let own = (bz * brick - z_lo) * slice..(((bz + 1) * brick).min(nz) - z_lo) * slice;
            stats = stats.merge(VolumeStats::of_values_par(&buf[own]));
            let layer: Vec<(usize, BrickRange)> = (0..layout.grid[0] * layout.grid[1])
                .into_par_iter()
                .map(|i| {
                    let c = [i % layout.grid[0], i / layout.grid[0], bz];
                    let (lo, hi) = layout.footprint(c);
                    let mut r: BrickRange = None;
                    for k in lo[2]..hi[2] {
                        for j in lo[1]..hi[1] {
                            let row = (k - z_lo) * slice + j * nx;
                            for &v in &buf[row + lo[0]..row + hi[0]] {
                                if v.is_finite() {
                                    r = Some(match r {
                                        None => [v, v],
                                        Some([a, b]) => [a.min(v), b.max(v)],
                                    });
                                }
                            }
                        }
                    }
                    (layout.id(c), r)
                })
                .collect();
            for (id, r) in layer {
                ranges[id] = r;
            }
        }
        Ok(BrickedVolume {
            name,
            units: String::new(),
            dims,
            spacing,
            origin,
            stats,
            layout,
            ranges,
            source,
            bricks_read: AtomicU64::new(0),
        })
    }

    /// Bricks an in-memory volume (its data are shared, not copied).
    pub fn from_volume(volume: Arc<Volume>, brick: usize) -> Result<BrickedVolume> {
        let (name, spacing, origin, units) = (
            volume.name.clone(),
            volume.spacing,
            volume.origin,
            volume.units.clone(),
        );
        let mut b =
            BrickedVolume::build(name, Arc::new(MemorySource(volume)), spacing, origin, brick)?;
        b.units = units;
        Ok(b)
    }

    pub fn source(&self) -> &Arc<dyn VoxelSource> {
        &self.source
    }

    /// Voxel bytes as f32.
    pub fn bytes(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product::<u64>() * 4
    }

    pub fn bounds(&self) -> super::Aabb {
        let hi = [0, 1, 2].map(|a| self.origin[a] + self.dims[a] as f64 * self.spacing[a]);
        super::Aabb {
            lo: self.origin,
            hi,
        }
    }

    /// How many bricks have been read from the source so far (tests check that a transfer
    /// function change re-reads nothing).
    pub fn bricks_read(&self) -> u64 {
        self.bricks_read.load(Ordering::Relaxed)
    }

    /// Stored brick `id`: (B + 2)³ voxels starting one voxel before the brick's corner, with
    /// indices outside the volume clamped to its edge (as clamp-to-edge sampling sees them).
    pub(crate) fn read_brick(&self, id: usize, out: &mut Vec<f32>) -> Result<()> {
        let l = &self.layout;
        let e = l.stored_edge();
        let c = l.coords(id);
        let (lo, hi) = l.footprint(c);
        let size = [0, 1, 2].map(|a| hi[a] - lo[a]);
        let mut boxed = vec![0f32; size.iter().product()];
        self.source.read_box(lo, size, &mut boxed)?;
        out.clear();
        out.resize(e * e * e, 0.0);
        // Per axis, the index into the read box of each stored voxel (clamped to the volume).
        let map = |a: usize| -> Vec<usize> {
            let start = (c[a] * l.brick) as i64 - 1;
            (0..e)
                .map(|i| (start + i as i64).clamp(0, self.dims[a] as i64 - 1) as usize - lo[a])
                .collect()
        };
        let (mx, my, mz) = (map(0), map(1), map(2));
        for (k, &bk) in mz.iter().enumerate() {
            for (j, &bj) in my.iter().enumerate() {
                let row = &boxed[(bk * size[1] + bj) * size[0]..][..size[0]];
                let dst = &mut out[(k * e + j) * e..][..e];
                for (d, &bi) in dst.iter_mut().zip(&mx) {
                    *d = row[bi];
                }
            }
        }
        self.bricks_read.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    /// Which bricks `tf` leaves empty (see [`empty_ranges`]).
    pub(crate) fn empty_bricks(&self, tf: &ResolvedTransfer) -> Vec<bool> {
        empty_ranges(&self.ranges, tf)
    }

    /// The volume averaged over 2×2×2 voxels (missing voxels left out of the mean; all missing
    /// gives missing), over the same bounds: the quick-look level. Streams the source by slabs.
    pub fn downsampled(&self) -> Result<Volume> {
        use rayon::prelude::*;
        let [nx, ny, nz] = self.dims;
        let cd = self.dims.map(|d| d.div_ceil(2));
        check_allocation((cd.iter().product::<usize>() * 4) as u64, "level 1")?;
        let mut data = vec![0f32; cd.iter().product()];
        let mut slab = vec![0f32; nx * ny * 2];
        for (ck, out) in data.chunks_mut(cd[0] * cd[1]).enumerate() {
            let z0 = 2 * ck;
            let count = (nz - z0).min(2);
            let buf = &mut slab[..nx * ny * count];
            self.source.read_box([0, 0, z0], [nx, ny, count], buf)?;
            let buf = &*buf;
            out.par_chunks_mut(cd[0]).enumerate().for_each(|(cj, row)| {
                for (ci, o) in row.iter_mut().enumerate() {
                    let (mut sum, mut n) = (0f64, 0u32);
                    for k in 0..count {
                        for j in 2 * cj..(2 * cj + 2).min(ny) {
                            for i in 2 * ci..(2 * ci + 2).min(nx) {
                                let v = buf[(k * ny + j) * nx + i];
                                if v.is_finite() {
                                    sum += v as f64;
                                    n += 1;
                                }
                            }
                        }
                    }
                    *o = if n > 0 {
                        (sum / n as f64) as f32
                    } else {
                        f32::NAN
                    };
                }
            });
        }
        let spacing = [0, 1, 2].map(|a| self.spacing[a] * self.dims[a] as f64 / cd[a] as f64);
        let mut v = Volume::new(
            format!("{} (level 1)", self.name),
            cd,
            spacing,
            self.origin,
            data,
        )?;
        v.units = self.units.clone();
        Ok(v)
    }
}

/// Front-to-back order of the bricks for rays that start at `eye` (perspective) or travel along
/// `dir` (orthographic), positions in voxel units from the volume's lower corner. Along any ray,
/// each axis coordinate moves monotonically away from where the ray starts, so the per-axis
/// brick distance from the start never decreases; sorting by its sum puts every brick a ray
/// meets before every brick it meets later. (The renderer also recovers, by extra passes, from
/// the rare ray that starts within rounding of a brick face and so disagrees with this order.)
pub(crate) fn visibility_order(
    layout: &BrickLayout,
    eye: Option<[f64; 3]>,
    dir: [f64; 3],
) -> Vec<u32> {
    let b = layout.brick as f64;
    let key = |c: [usize; 3]| -> u64 {
        (0..3)
            .map(|a| {
                let ci = c[a] as i64;
                match eye {
                    Some(e) => {
                        let ei = (e[a] / b).floor() as i64;
                        (ci - ei).unsigned_abs()
                    }
                    None if dir[a] > 0.0 => ci as u64,
                    None if dir[a] < 0.0 => (layout.grid[a] as i64 - 1 - ci) as u64,
                    None => 0,
                }
            })
            .sum()
    };
    let mut order: Vec<(u64, u32)> = (0..layout.count())
        .map(|id| (key(layout.coords(id)), id as u32))
        .collect();
    order.sort_unstable();
    order.into_iter().map(|(_, id)| id).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(dims: [usize; 3]) -> Arc<Volume> {
        Arc::new(
            Volume::from_fn("ramp", dims, |x, y, z| {
                if (x - 3.5).abs() < 0.1 && (y - 2.5).abs() < 0.1 && (z - 9.5).abs() < 0.1 {
                    f64::NAN
                } else {
                    x + 100.0 * y - 0.5 * z * z
                }
            })
            .unwrap(),
        )
    }

    #[test]
    fn ranges_and_stats_match_a_direct_scan() {
        let vol = ramp([37, 20, 19]);
        let b = BrickedVolume::from_volume(vol.clone(), 8).unwrap();
        assert_eq!(b.layout.grid, [5, 3, 3]);
        assert_eq!(b.stats, vol.stats());
        for id in 0..b.layout.count() {
            let (lo, hi) = b.layout.footprint(b.layout.coords(id));
            let mut r: Option<[f32; 2]> = None;
            for k in lo[2]..hi[2] {
                for j in lo[1]..hi[1] {
                    for i in lo[0]..hi[0] {
                        let v = vol.data[vol.index(i, j, k)];
                        if v.is_finite() {
                            r = Some(r.map_or([v, v], |[a, c]| [a.min(v), c.max(v)]));
                        }
                    }
                }
            }
            assert_eq!(b.ranges[id], r, "brick {id}");
        }
    }

    #[test]
    fn stored_bricks_hold_the_apron_clamped_to_the_edge() {
        let vol = ramp([37, 20, 19]);
        let b = BrickedVolume::from_volume(vol.clone(), 8).unwrap();
        let mut out = Vec::new();
        for id in [0, 7, b.layout.count() - 1] {
            b.read_brick(id, &mut out).unwrap();
            let c = b.layout.coords(id);
            let e = 10;
            for k in 0..e {
                for j in 0..e {
                    for i in 0..e {
                        let g = |a: usize, l: usize| (c[a] * 8 + l) as i64 - 1;
                        let want = vol.voxel_clamped(g(0, i), g(1, j), g(2, k));
                        let got = out[(k * e + j) * e + i];
                        assert!(got == want || (got.is_nan() && want.is_nan()));
                    }
                }
            }
        }
        assert_eq!(b.bricks_read(), 3);
    }

    #[test]
    fn visibility_order_respects_every_ray() {
        // March many rays in f64 through a 5x4x3 grid and check that the bricks they meet appear
        // in increasing order positions.
        let layout = BrickLayout::new([40, 32, 24], 8).unwrap();
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..200 {
            let inside = case % 2 == 0;
            let eye = if inside {
                [rnd() * 40.0, rnd() * 32.0, rnd() * 24.0]
            } else {
                [-30.0 + 100.0 * rnd(), -30.0 + 92.0 * rnd(), 60.0]
            };
            let order = visibility_order(&layout, Some(eye), [0.0; 3]);
            let mut pos = vec![0usize; layout.count()];
            for (i, &id) in order.iter().enumerate() {
                pos[id as usize] = i;
            }
            for _ in 0..50 {
                let target = [rnd() * 40.0, rnd() * 32.0, rnd() * 24.0];
                let d = [0, 1, 2].map(|a| target[a] - eye[a]);
                let mut last = None::<usize>;
                for s in 0..4000 {
                    let t = s as f64 / 1000.0;
                    let p = [0, 1, 2].map(|a| eye[a] + d[a] * t);
                    if (0..3).any(|a| p[a] < 0.0 || p[a] >= layout.dims[a] as f64) {
                        continue;
                    }
                    let id = layout.id([0, 1, 2].map(|a| (p[a] / 8.0) as usize));
                    if let Some(l) = last {
                        assert!(pos[id] >= pos[l], "case {case}: ray order violated");
                    }
                    last = Some(id);
                }
            }
        }
    }

    #[test]
    fn level_one_is_the_mean_of_each_2x2x2_block() {
        let vol = ramp([7, 6, 5]);
        let b = BrickedVolume::from_volume(vol.clone(), 8).unwrap();
        let l1 = b.downsampled().unwrap();
        assert_eq!(l1.dims, [4, 3, 3]);
        assert_eq!(l1.bounds(), vol.bounds());
        // The corner block (all finite): the plain mean.
        let m: f64 = (0..8)
            .map(|c| vol.data[vol.index(c & 1, (c >> 1) & 1, c >> 2)] as f64)
            .sum::<f64>()
            / 8.0;
        assert!((l1.data[0] as f64 - m).abs() < 1e-4 * m.abs().max(1.0));
        // The last x block holds one voxel column (7 is odd): the mean of 4.
        let last = l1.index(3, 0, 0);
        let m4: f64 = (0..4)
            .map(|c| vol.data[vol.index(6, c & 1, c >> 1)] as f64)
            .sum::<f64>()
            / 4.0;
        assert!((l1.data[last] as f64 - m4).abs() < 1e-4 * m4.abs().max(1.0));
    }
}
