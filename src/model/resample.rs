//! Resampling a volume placed by coordinate axes (a spherical shell or wedge, a rectilinear box)
//! onto a regular Cartesian box, the way the paper prepared its spherical data ("placing the
//! sphere in a box and doing a linear interpolation"): cubic voxels over the domain's bounding
//! box, each voxel centre interpolated trilinearly in the source's index space, and voxels whose
//! centre lies outside the domain (outside the shell, in the core, beyond a wedge) missing (NaN).

use super::geometry::Geometry;
use super::volume::{check_dims, Volume, MAX_DIM};
use crate::error::{Error, Result};

/// The shape of the regular box over `lo`..`hi` with `n` cubic voxels along the longest side:
/// voxel counts, the voxel's side, and the box's lower corner (the box is centred on the
/// domain's, so a shorter side is covered by whole voxels and overhangs it by under one voxel).
pub(crate) fn box_shape(lo: [f64; 3], hi: [f64; 3], n: usize) -> ([usize; 3], f64, [f64; 3]) {
    let size = [0, 1, 2].map(|a| hi[a] - lo[a]);
    let longest = size.iter().cloned().fold(0.0, f64::max);
    let h = longest / n as f64;
    // A hair below a whole count (rounding of the bounds) is that count.
    let dims = size.map(|s| ((s / h - 1e-9).ceil() as usize).clamp(1, n));
    let origin = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]) - 0.5 * dims[a] as f64 * h);
    (dims, h, origin)
}

/// `volume` resampled onto a regular box over its bounding box with `n` cubic voxels along the
/// longest side: values by [`Volume::sample_world`] at the voxel centres (trilinear in the
/// source's index space, longitude periodic), NaN outside a shell's or wedge's domain. Runs in
/// parallel over z-slabs.
pub fn resample_to_box(volume: &Volume, n: usize) -> Result<Volume> {
    if !(2..=MAX_DIM).contains(&n) {
        return Err(Error::invalid(
            "n",
            format!("{n} voxels along the longest side; expected 2 to {MAX_DIM}"),
        ));
    }
    let bounds = volume.bounds();
    let (dims, h, origin) = box_shape(bounds.lo, bounds.hi, n);
    check_dims(&dims, "resample n")?;
    let inside = |p: [f64; 3]| match &volume.geometry {
        Geometry::Spherical(g) => g.contains(p),
        Geometry::Regular | Geometry::Rectilinear(_) => {
            (0..3).all(|a| p[a] >= bounds.lo[a] && p[a] <= bounds.hi[a])
        }
    };
    let [nx, ny, _] = dims;
    let mut data = vec![f32::NAN; dims.iter().product()];
    use rayon::prelude::*;
    data.par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            let z = origin[2] + (k as f64 + 0.5) * h;
            for j in 0..ny {
                let y = origin[1] + (j as f64 + 0.5) * h;
                for (i, out) in slab[j * nx..(j + 1) * nx].iter_mut().enumerate() {
                    let p = [origin[0] + (i as f64 + 0.5) * h, y, z];
                    if inside(p) {
                        *out = volume.sample_world(p) as f32;
                    }
                }
            }
        });
    let [nx, ny, nz] = dims;
    let mut out = Volume::new(
        format!("{} resampled {nx}x{ny}x{nz}", volume.name),
        dims,
        [h; 3],
        origin,
        data,
    )?;
    out.units = volume.units.clone();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{CoordAxis, SphericalGrid};

    /// A global shell of radii 1..3 (uneven levels) holding its own radius at every node.
    fn radial_shell() -> Volume {
        let radii = vec![1.0, 1.4, 2.0, 2.5, 3.0];
        let grid = SphericalGrid {
            axis_of: [0, 1, 2],
            radius: CoordAxis::new(radii.clone(), None, "radius").unwrap(),
            latitude: CoordAxis::uniform_cells(-90.0, 10.0, 18),
            longitude: CoordAxis::uniform_cells(-180.0, 10.0, 36),
            lon_wraps: true,
            planet_radius: 3.0,
            length_unit: "km".into(),
            vertical: "radius".into(),
            rotated_pole: None,
        };
        let dims = [radii.len(), 18, 36];
        let data = (0..dims.iter().product::<usize>())
            .map(|i| radii[i % dims[0]] as f32)
            .collect();
        Volume::new("r", dims, [1.0; 3], [0.0; 3], data)
            .unwrap()
            .with_geometry(Geometry::Spherical(Box::new(grid)))
            .unwrap()
    }

    #[test]
    fn a_field_linear_in_radius_gives_the_radius_inside_the_shell_and_nan_outside() {
        let shell = radial_shell();
        let n = 24;
        let boxed = resample_to_box(&shell, n).unwrap();
        // The shell's box is [-3, 3]³: 24 cubic voxels of 0.25 a side.
        assert_eq!(boxed.dims, [n; 3]);
        assert!(boxed.is_regular());
        for a in 0..3 {
            assert!((boxed.spacing[a] - 0.25).abs() < 1e-12);
            assert!((boxed.origin[a] + 3.0).abs() < 1e-12);
        }
        let (mut inside, mut outside) = (0, 0);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = [i, j, k].map(|c| -3.0 + (c as f64 + 0.5) * 0.25);
                    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    let v = boxed.data[boxed.index(i, j, k)];
                    if (1.0..=3.0).contains(&r) {
                        inside += 1;
                        // Linear in radius between levels, and the same at every angle: exact
                        // up to f32 rounding.
                        assert!((v as f64 - r).abs() < 1e-5, "r {r}: {v}");
                    } else {
                        outside += 1;
                        assert!(v.is_nan(), "r {r}: {v}");
                    }
                }
            }
        }
        // The shell fills 4π/3·(27 − 1)/216 ≈ 50 % of the box.
        let share = inside as f64 / (inside + outside) as f64;
        assert!((share - 0.504).abs() < 0.02, "{share}");
    }

    #[test]
    fn a_wedge_gets_cubic_voxels_over_its_bounding_box() {
        let mut shell = radial_shell();
        if let Geometry::Spherical(g) = &mut shell.geometry {
            g.lon_wraps = false;
            g.longitude = CoordAxis::new(
                (0..36).map(|i| 0.5 + i as f64).collect(),
                Some((0.0, 36.0)),
                "lon",
            )
            .unwrap();
            g.latitude = CoordAxis::new(
                (0..18).map(|i| 0.5 + i as f64).collect(),
                Some((0.0, 18.0)),
                "lat",
            )
            .unwrap();
        }
        let b = shell.bounds();
        let boxed = resample_to_box(&shell, 40).unwrap();
        let h = boxed.spacing[0];
        let size = b.size();
        let longest = size.iter().cloned().fold(0.0, f64::max);
        assert!((h - longest / 40.0).abs() < 1e-12);
        for (a, &side) in size.iter().enumerate() {
            assert!(boxed.dims[a] as f64 * h >= side - 1e-9);
            assert!((boxed.dims[a] as f64 - 1.0) * h < side);
            assert!(boxed.origin[a] <= b.lo[a] + 1e-12);
        }
        assert_eq!(boxed.dims.iter().max(), Some(&40));
        // Inside the wedge, the radius; the corner beyond its longitudes is missing.
        let stats = boxed.stats();
        assert!(
            stats.min >= 1.0 - 1e-5 && stats.max <= 3.0 + 1e-5,
            "{stats:?}"
        );
        assert!(stats.non_finite > 0 && stats.finite > 0);
        assert!(resample_to_box(&shell, 1).is_err());
    }
}
