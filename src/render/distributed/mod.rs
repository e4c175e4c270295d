//! Distributed volume rendering, sort-last: when a run is one of several ranks (`mpirun -n N
//! hdrvis run SCRIPT`, `srun`), every volume render is split over the ranks. The volume is cut
//! into N slabs of whole z-slices (the slowest axis, so a rank's part is one contiguous read of
//! a `.npy`/raw file read in place or one NetCDF hyperslab); rank r reads slab r and
//! [`GHOST`] slices on either side, ray-casts with the whole volume's rays and sample
//! positions, and composites exactly the segments whose midpoints lie in its slab (the `SLAB`
//! variant of shaders/volume.wgsl), so the split changes no sample. The partial images are
//! composited in visibility order ([`composite`]) onto rank 0, which finishes the pixels
//! (background, alpha) and hands the image to every rank, so every rank's script continues
//! with the same values.
//!
//! [`exchange`] carries the messages: MPI with `--features mpi` ([`mpi`]), or channels between
//! threads (tests, the default build).

pub mod composite;
pub mod exchange;
#[cfg(feature = "mpi")]
pub mod mpi;
mod session;

pub(crate) use composite::Scheme;
pub use exchange::{ChannelExchange, Exchange};

use super::{Precision, TfSampling, VolumeRenderOptions};
use crate::error::{Error, Result};
use crate::model::bricks::VoxelSource;
use crate::model::Volume;

/// Slices read past each side of a slab: the trilinear samples of midpoints in the slab reach
/// one slice beyond it, the central differences of shading one more.
pub(crate) const GHOST: usize = 2;

/// The part of a volume one rank renders: it composites the segments whose midpoints lie in
/// the slices `z0 .. z1` and reads `read_lo .. read_hi` (its slab plus the ghost slices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Slab {
    pub rank: usize,
    pub count: usize,
    pub z0: usize,
    pub z1: usize,
    pub read_lo: usize,
    pub read_hi: usize,
}

impl Slab {
    /// Slab `rank` of `count` near-equal slabs of a volume with `nz` slices; `name` is the
    /// volume's, for the message when there are more ranks than slices.
    pub fn new(nz: usize, rank: usize, count: usize, name: &str) -> Result<Slab> {
        if count > nz {
            return Err(Error::invalid(
                "ranks",
                format!(
                    "{count} ranks cannot share {name}: it has {nz} z-slices, so at most {nz} ranks can each render a slab; run with fewer ranks"
                ),
            ));
        }
        let z0 = rank * nz / count;
        let z1 = (rank + 1) * nz / count;
        Ok(Slab {
            rank,
            count,
            z0,
            z1,
            read_lo: z0.saturating_sub(GHOST),
            read_hi: (z1 + GHOST).min(nz),
        })
    }

    /// The shader's slab parameters (`Params.slab`): the z range of the midpoints this rank
    /// composites, in world units from the box's lower corner (open to infinity at the
    /// volume's faces, so rounding cannot lose a segment), the first slice read, the slice
    /// count. Neighbours compute their shared boundary from the same slice index, so every
    /// midpoint falls in exactly one slab.
    pub(crate) fn shader_params(&self, nz: usize, spacing_z: f64) -> [f32; 4] {
        let lo = if self.rank == 0 {
            -f32::MAX
        } else {
            (self.z0 as f64 * spacing_z) as f32
        };
        let hi = if self.rank + 1 == self.count {
            f32::MAX
        } else {
            (self.z1 as f64 * spacing_z) as f32
        };
        [lo, hi, self.read_lo as f32, nz as f32]
    }
}

/// The options a distributed render cannot honour, refused with what to do instead; more
/// ranks than the volume `name` has slices (`nz`).
pub(crate) fn check_options(
    name: &str,
    nz: usize,
    opts: &VolumeRenderOptions,
    ranks: usize,
) -> Result<()> {
    if !matches!(opts.precision, Precision::F32 | Precision::F32c) {
        return Err(Error::invalid(
            "precision",
            format!(
                "a render split over {ranks} ranks composites in f32 (the partial images join \
                 exactly only there); use precision \"f32\" or \"f32c\", or run on one rank"
            ),
        ));
    }
    if opts.tf_sampling != TfSampling::Point {
        return Err(Error::invalid(
            "tf_sampling",
            format!(
                "a render split over {ranks} ranks samples the transfer function at segment \
                 midpoints; use tf_sampling \"point\", or run on one rank"
            ),
        ));
    }
    if opts.missing == crate::model::Missing::Renormalise {
        return Err(Error::invalid(
            "missing",
            format!(
                "a render split over {ranks} ranks samples missing data strictly; use missing \
                 \"strict\", or run on one rank"
            ),
        ));
    }
    Slab::new(nz, 0, ranks, name).map(|_| ())
}

/// Where a volume lies and what it is called: what a slab read needs besides the voxels.
pub(crate) struct Placement<'a> {
    pub name: &'a str,
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
}

/// Reads a slab's slices (with its ghost slices) of `source` as a volume of its own, placed
/// where those slices lie in the whole volume.
pub(crate) fn read_slab(
    source: &dyn VoxelSource,
    place: &Placement,
    slab: &Slab,
) -> Result<Volume> {
    let [nx, ny, _] = source.dims();
    let count = slab.read_hi - slab.read_lo;
    crate::model::volume::check_allocation((nx * ny * count * 4) as u64, "slab")?;
    let mut data = vec![0f32; nx * ny * count];
    source.read_box([0, 0, slab.read_lo], [nx, ny, count], &mut data)?;
    let mut origin = place.origin;
    origin[2] += slab.read_lo as f64 * place.spacing[2];
    Volume::new(
        format!("{} (slab {} of {})", place.name, slab.rank + 1, slab.count),
        [nx, ny, count],
        place.spacing,
        origin,
        data,
    )
}

/// This process's peak resident memory (VmHWM of /proc/self/status), bytes; `None` where the
/// system does not report it.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn options_a_split_render_cannot_honour_are_refused_in_one_line() {
        use crate::model::{Aabb, Camera, Missing, TransferFunction};
        let bounds = Aabb {
            lo: [0.0; 3],
            hi: [8.0; 3],
        };
        let tf = TransferFunction::emission_absorption(1.0, 0.1).unwrap();
        let mut o = VolumeRenderOptions::new(Camera::axis(crate::model::Axis::Z, &bounds), tf);
        assert!(check_options("v", 8, &o, 2).is_ok());
        o.missing = Missing::Renormalise;
        let e = check_options("v", 8, &o, 2).unwrap_err().to_string();
        assert!(e.starts_with("missing: a render split over 2 ranks"), "{e}");
        assert!(!e.contains('\n'), "{e}");
        (o.missing, o.precision) = (Missing::Strict, Precision::F16);
        let e = check_options("v", 8, &o, 2).unwrap_err().to_string();
        assert!(e.starts_with("precision: "), "{e}");
    }

    #[test]
    fn slabs_cover_the_slices_once_and_their_boundaries_agree() {
        for (nz, n) in [(10, 3), (64, 4), (5, 5), (7, 2)] {
            let slabs: Vec<Slab> = (0..n).map(|r| Slab::new(nz, r, n, "v").unwrap()).collect();
            assert_eq!(slabs[0].z0, 0);
            assert_eq!(slabs[n - 1].z1, nz);
            for w in slabs.windows(2) {
                assert_eq!(w[0].z1, w[1].z0);
                let (a, b) = (w[0].shader_params(nz, 0.3), w[1].shader_params(nz, 0.3));
                assert_eq!(a[1], b[0]);
            }
            for s in &slabs {
                assert!(s.z1 > s.z0);
                assert_eq!(s.read_lo, s.z0.saturating_sub(GHOST));
                assert_eq!(s.read_hi, (s.z1 + GHOST).min(nz));
            }
        }
        let first = Slab::new(8, 0, 2, "v").unwrap().shader_params(8, 1.0);
        assert_eq!(
            [first[0], first[1], first[2], first[3]],
            [-f32::MAX, 4.0, 0.0, 8.0]
        );
        let err = Slab::new(3, 0, 4, "blobs").unwrap_err().to_string();
        assert!(
            err.contains("4 ranks cannot share blobs: it has 3 z-slices"),
            "{err}"
        );
    }

    #[test]
    fn a_slab_volume_holds_its_slices_and_ghosts_where_they_lie() {
        let data: Vec<f32> = (0..2 * 2 * 6).map(|i| i as f32).collect();
        let v =
            Arc::new(Volume::new("v", [2, 2, 6], [1.0, 1.0, 0.5], [0.0, 0.0, 1.0], data).unwrap());
        let slab = Slab::new(6, 2, 3, "v").unwrap();
        let place = Placement {
            name: "v",
            spacing: v.spacing,
            origin: v.origin,
        };
        let source = crate::model::bricks::MemorySource(v);
        let part = read_slab(&source, &place, &slab).unwrap();
        assert_eq!(part.dims, [2, 2, 4]);
        assert_eq!(part.origin[2], 1.0 + 2.0 * 0.5);
        assert_eq!(part.data[0], 8.0);
        assert_eq!(*part.data.last().unwrap(), 23.0);
    }
}
