//! Synthetic mantle-convection temperature in a spherical shell, standing in for case III of
//! Yuan et al. (2008), whose 513^3 volume was resampled from a spherical convection code. The
//! field starts from the CitcomS benchmark initial condition of Zhong et al. (2008): the
//! conductive profile of the shell 0.55 <= r <= 1 plus eps (cos m phi + sin m phi) P_lm(cos theta)
//! sin(pi (r - r_b) / (r_t - r_b)). On top come error-function thermal boundary layers whose
//! thickness follows from a Rayleigh number, hot plumes rising from the core-mantle boundary and
//! cold slabs sinking from the surface, placed by a seeded generator. The field is built on a
//! spherical (r, theta, phi) grid and resampled trilinearly in (r, theta, phi) onto an N^3 box
//! [-1, 1]^3, as the paper did. Voxels outside the shell are NaN, the renderer's missing value.
//!
//! Coordinates: x = r sin(theta) cos(phi), y = r sin(theta) sin(phi), z = r cos(theta); theta is
//! colatitude from +z, phi is longitude from +x towards +y.

//!
//! The rooms: `options` (what to generate and its checks), `spherical` (the grid of (r, theta,
//! phi) nodes and its interpolation), `temperature` (the conductive profile, boundary layers,
//! plumes and slabs that fill it); this file builds the grid and resamples it onto the box.

mod options;
mod spherical;
mod temperature;
#[cfg(test)]
mod tests;

use rayon::prelude::*;
use std::f64::consts::PI;

use crate::error::{Error, Result};
pub use options::{MantleField, MantleFields, MantleOptions, SphericalResolution};
use spherical::{node_radius, row_weights, PhiCell, SphericalGrid};
use temperature::{conductive_temperature, BoundaryLayers, Features, Model};

/// Core-mantle boundary radius of the non-dimensional shell (Zhong et al. 2008).
pub(crate) const INNER_RADIUS: f64 = 0.55;
/// Surface radius of the non-dimensional shell.
pub(crate) const OUTER_RADIUS: f64 = 1.0;
/// Below about this Rayleigh number a shell does not convect, and the local Rayleigh number of a
/// thermal boundary layer stays near it while the layer is stable (Howard 1966); both are of
/// order 10^3, so one constant serves both.
pub(crate) const CRITICAL_RAYLEIGH: f64 = 1.0e3;

const SHELL_THICKNESS: f64 = OUTER_RADIUS - INNER_RADIUS;
pub(crate) const MAX_N: usize = 2048;
const MAX_AXIS_NODES: usize = 16384;
const MAX_DEGREE: usize = 64;
pub(crate) const MAX_FEATURES: usize = 10_000;
const MAX_RAYLEIGH: f64 = 1.0e12;
/// Plumes and slabs need a size even when the shell is conductive; they take the one of this
/// Rayleigh number then.
const FEATURE_RAYLEIGH_WITHOUT_CONVECTION: f64 = 1.0e6;
/// Share of the progress bar given to building the spherical grid; resampling is the rest.
const SPHERICAL_PROGRESS_SHARE: f64 = 0.3;
const PROGRESS_STEPS: usize = 32;

/// The generated Cartesian volume: n^3 cells over [-1, 1]^3, index (k n + j) n + i with i along
/// x, j along y, k along z, cell centres at -1 + (i + 0.5) 2/n. Cells whose centre lies outside
/// the shell hold NaN. A field not requested in `MantleOptions::fields` is an empty vector.
#[derive(Clone, Debug, PartialEq)]
pub struct MantleVolume {
    pub n: usize,
    pub temperature: Vec<f32>,
    pub fluctuation: Vec<f32>,
    pub viscosity: Vec<f32>,
    /// The spherical grid the volume was resampled from.
    pub spherical: SphericalResolution,
}

impl MantleVolume {
    /// The field's voxels, or `None` when it was not generated.
    pub fn field(&self, field: MantleField) -> Option<&[f32]> {
        let values = match field {
            MantleField::Temperature => &self.temperature,
            MantleField::Fluctuation => &self.fluctuation,
            MantleField::Viscosity => &self.viscosity,
        };
        (!values.is_empty()).then_some(values.as_slice())
    }

    /// Centre of cell `index` along any axis.
    pub(crate) fn cell_centre(n: usize, index: usize) -> f64 {
        -1.0 + (index as f64 + 0.5) * (2.0 / n as f64)
    }
}

/// Builds the temperature and its radial mean on the spherical grid, without the Cartesian
/// resampling; `opts.fields` and `opts.n` (beyond choosing the default resolution) play no part.
#[cfg(test)]
pub(crate) fn spherical_field(opts: &MantleOptions) -> Result<SphericalGrid> {
    opts.validate()?;
    build_spherical(opts, &mut |_| Ok(()))
}

fn build_spherical(
    opts: &MantleOptions,
    progress: &mut dyn FnMut(f64) -> Result<()>,
) -> Result<SphericalGrid> {
    let res = opts.spherical_resolution();
    let radii: Vec<f64> = (0..res.radial).map(|ir| node_radius(&res, ir)).collect();
    let convecting = opts.rayleigh > CRITICAL_RAYLEIGH;
    let layers = BoundaryLayers::for_rayleigh(if convecting {
        opts.rayleigh
    } else {
        FEATURE_RAYLEIGH_WITHOUT_CONVECTION
    });
    let profile = radii
        .iter()
        .map(|&r| {
            if convecting {
                layers.temperature(r)
            } else {
                conductive_temperature(r)
            }
        })
        .collect();
    let bump = radii
        .iter()
        .enumerate()
        .map(|(ir, &r)| {
            // sin(pi) is 1.2e-16, not 0: keep the boundary values exact.
            if ir == 0 || ir + 1 == res.radial {
                0.0
            } else {
                opts.epsilon * (PI * (r - INNER_RADIUS) / SHELL_THICKNESS).sin()
            }
        })
        .collect();
    let phis: Vec<f64> = (0..res.phi).map(|ip| ip as f64 * res.phi_step()).collect();
    let m = opts.order as f64;
    let finest_width = res
        .radial_step()
        .max(OUTER_RADIUS * res.theta_step())
        .max(OUTER_RADIUS * res.phi_step());
    let model = Model {
        res,
        profile,
        bump,
        azimuth: phis
            .iter()
            .map(|&p| (m * p).cos() + (m * p).sin())
            .collect(),
        cos_phi: phis.iter().map(|p| p.cos()).collect(),
        sin_phi: phis.iter().map(|p| p.sin()).collect(),
        features: Features::place(opts, &layers, finest_width),
        layers,
        radii,
        opts,
    };

    let mut temperature = allocate(res.nodes(), "spherical grid")?;
    let row_len = res.phi * res.radial;
    let weights = row_weights(&res);
    let mut shell_sums = vec![0.0; res.radial];
    let rows_per_step = res.theta.div_ceil(PROGRESS_STEPS).max(1);
    for (step, rows) in temperature.chunks_mut(rows_per_step * row_len).enumerate() {
        let first_row = step * rows_per_step;
        let row_sums: Vec<Vec<f64>> = rows
            .par_chunks_mut(row_len)
            .enumerate()
            .map(|(offset, row)| model.fill_row(first_row + offset, row))
            .collect();
        // Summed in row order so that the mean does not depend on thread scheduling.
        for (offset, sums) in row_sums.iter().enumerate() {
            let weight = weights[first_row + offset];
            for (total, sum) in shell_sums.iter_mut().zip(sums) {
                *total += weight * sum;
            }
        }
        progress(((first_row + row_sums.len()) as f64 / res.theta as f64).min(1.0))?;
    }
    let weight_total: f64 = weights.iter().sum::<f64>() * res.phi as f64;
    let radial_mean = shell_sums.iter().map(|s| s / weight_total).collect();
    Ok(SphericalGrid {
        resolution: res,
        temperature,
        radial_mean,
        viscosity_contrast: opts.viscosity_contrast,
    })
}

fn allocate(len: usize, what: &str) -> Result<Vec<f32>> {
    let mut values = Vec::new();
    values.try_reserve_exact(len).map_err(|_| {
        Error::invalid(
            "n",
            format!(
                "cannot allocate {:.0} MiB for the {what}; lower n or the resolution",
                len as f64 * 4.0 / (1024.0 * 1024.0)
            ),
        )
    })?;
    values.resize(len, 0.0);
    Ok(values)
}

/// Longitude cell and cylindrical radius of one (i, j) column of the Cartesian box, shared by
/// all its z cells.
struct BoxColumn {
    rho: f64,
    phi: PhiCell,
}

/// Cells per side of the blocks the resampling walks through, and z slices per parallel task.
const TILE: usize = 16;
const SLAB_DEPTH: usize = TILE;

/// `SLAB_DEPTH` consecutive z slices (fewer in the last slab) of each requested output.
struct SlabOutputs<'a> {
    first_k: usize,
    depth: usize,
    temperature: Option<&'a mut [f32]>,
    fluctuation: Option<&'a mut [f32]>,
    viscosity: Option<&'a mut [f32]>,
}

fn slabs(values: &mut [f32], len: usize, wanted: bool, n: usize) -> Vec<Option<&mut [f32]>> {
    if wanted {
        values.chunks_mut(len).map(Some).collect()
    } else {
        (0..n.div_ceil(SLAB_DEPTH)).map(|_| None).collect()
    }
}

/// Builds the spherical grid and resamples the requested fields onto the n^3 box. `progress`
/// receives fractions from 0 to 1 on the calling thread. Memory: 4 bytes per spherical node
/// (`SphericalResolution::nodes`) plus 4 n^3 bytes per requested field; for n = 513 that is
/// 612 MB + 540 MB per field.
pub fn generate(
    opts: &MantleOptions,
    progress: &mut dyn FnMut(f64) -> Result<()>,
) -> Result<MantleVolume> {
    opts.validate()?;
    progress(0.0)?;
    let grid = build_spherical(opts, &mut |f| progress(f * SPHERICAL_PROGRESS_SHARE))?;
    let n = opts.n;
    let cells = n * n * n;
    let fields = opts.fields;
    let mut outputs = [Vec::new(), Vec::new(), Vec::new()];
    for (output, field) in outputs.iter_mut().zip(MantleField::ALL) {
        if fields.contains(field) {
            *output = allocate(cells, field.name())?;
        }
    }
    let [mut temperature, mut fluctuation, mut viscosity] = outputs;

    let columns: Vec<BoxColumn> = (0..n * n)
        .map(|c| {
            let x = MantleVolume::cell_centre(n, c % n);
            let y = MantleVolume::cell_centre(n, c / n);
            BoxColumn {
                rho: x.hypot(y),
                phi: grid.phi_cell(y.atan2(x)),
            }
        })
        .collect();
    let slab_len = SLAB_DEPTH * n * n;
    let mut work: Vec<SlabOutputs> = slabs(&mut temperature, slab_len, fields.temperature, n)
        .into_iter()
        .zip(slabs(&mut fluctuation, slab_len, fields.fluctuation, n))
        .zip(slabs(&mut viscosity, slab_len, fields.viscosity, n))
        .enumerate()
        .map(
            |(slab, ((temperature, fluctuation), viscosity))| SlabOutputs {
                first_k: slab * SLAB_DEPTH,
                depth: SLAB_DEPTH.min(n - slab * SLAB_DEPTH),
                temperature,
                fluctuation,
                viscosity,
            },
        )
        .collect();
    let slab_count = work.len();
    let slabs_per_step = rayon::current_num_threads().max(1);
    let mut done = 0;
    for batch in work.chunks_mut(slabs_per_step) {
        batch
            .par_iter_mut()
            .for_each(|slab| resample_slab(&grid, &columns, n, slab));
        done += batch.len();
        progress(
            SPHERICAL_PROGRESS_SHARE
                + (1.0 - SPHERICAL_PROGRESS_SHARE) * done as f64 / slab_count as f64,
        )?;
    }
    drop(work);
    Ok(MantleVolume {
        n,
        temperature,
        fluctuation,
        viscosity,
        spherical: grid.resolution,
    })
}

/// The mantle on its own spherical grid, as a convection code would write it: node radii in km
/// (the surface at Earth's radius, the core-mantle boundary at 0.55 of it), latitudes from the
/// South Pole to the North Pole inclusive, longitudes all round; and the requested fields on
/// that grid, longitude fastest, then latitude, then radius (the C order of a NetCDF variable on
/// (radius, latitude, longitude)).
#[derive(Clone, Debug)]
pub(crate) struct NativeMantle {
    pub geometry: crate::model::SphericalGrid,
    /// Voxel counts (longitudes, latitudes, radii).
    pub dims: [usize; 3],
    pub fields: Vec<(MantleField, Vec<f32>)>,
}

impl NativeMantle {
    /// One field as a spherical volume (`None` when it was not generated).
    pub fn volume(&self, field: MantleField, seed: u64) -> Result<Option<crate::model::Volume>> {
        let Some((_, data)) = self.fields.iter().find(|(f, _)| *f == field) else {
            return Ok(None);
        };
        let [nlon, nlat, nr] = self.dims;
        let mut v = crate::model::Volume::new(
            format!(
                "mantle-{} {nr}x{nlat}x{nlon} (r, lat, lon) seed={seed}",
                field.name()
            ),
            self.dims,
            [1.0; 3],
            [0.0; 3],
            data.clone(),
        )?
        .with_geometry(crate::model::Geometry::Spherical(Box::new(
            self.geometry.clone(),
        )))?;
        v.units = "non-dimensional".into();
        Ok(Some(v))
    }
}

/// Builds the spherical grid and returns the requested fields on it, with no Cartesian
/// resampling (`opts.n` only picks the default resolution). Memory: 4 bytes per node for the
/// grid and for each field.
pub(crate) fn generate_native(
    opts: &MantleOptions,
    progress: &mut dyn FnMut(f64) -> Result<()>,
) -> Result<NativeMantle> {
    use crate::model::{CoordAxis, SphericalGrid as Shell};
    opts.validate()?;
    progress(0.0)?;
    let grid = build_spherical(opts, &mut |f| progress(0.8 * f))?;
    let res = grid.resolution;
    let km = crate::datasets::cf::EARTH_RADIUS_KM;
    let radii: Vec<f64> = (0..res.radial)
        .map(|ir| km * node_radius(&res, ir))
        .collect();
    // Colatitude row it is latitude 90 - it·dθ; latitudes are stored rising.
    let latitudes: Vec<f64> = (0..res.theta)
        .map(|j| -90.0 + j as f64 * 180.0 / (res.theta - 1) as f64)
        .collect();
    let step = 360.0 / res.phi as f64;
    let longitudes: Vec<f64> = (0..res.phi).map(|ip| ip as f64 * step).collect();
    let geometry = Shell {
        axis_of: [2, 1, 0],
        radius: CoordAxis::new(radii, None, "radius")?,
        latitude: CoordAxis::new(latitudes, None, "latitude")?,
        longitude: CoordAxis {
            centres: longitudes,
            lo: -0.5 * step,
            hi: 360.0 - 0.5 * step,
        },
        lon_wraps: true,
        planet_radius: km,
        length_unit: "km".into(),
        vertical: "radius".into(),
        rotated_pole: None,
    };
    let layer = res.theta * res.phi;
    let mut fields = Vec::new();
    for field in MantleField::ALL {
        if !opts.fields.contains(field) {
            continue;
        }
        let mut data = allocate(res.nodes(), field.name())?;
        data.par_chunks_mut(layer)
            .enumerate()
            .for_each(|(ir, shell)| {
                let mean = grid.radial_mean[ir];
                for (j, row) in shell.chunks_mut(res.phi).enumerate() {
                    let it = res.theta - 1 - j;
                    for (ip, out) in row.iter_mut().enumerate() {
                        let t = grid.temperature[(it * res.phi + ip) * res.radial + ir] as f64;
                        *out = grid.derive(field, t, mean) as f32;
                    }
                }
            });
        fields.push((field, data));
    }
    progress(1.0)?;
    Ok(NativeMantle {
        geometry,
        dims: [res.phi, res.theta, res.radial],
        fields,
    })
}

/// Resamples one slab tile by tile: a 16^3 block of cells reads a compact patch of the
/// spherical grid, where a whole slice at a time would stream most of the grid through the
/// cache for every slice.
fn resample_slab(grid: &SphericalGrid, columns: &[BoxColumn], n: usize, out: &mut SlabOutputs) {
    let log_contrast = grid.viscosity_contrast.ln();
    for j0 in (0..n).step_by(TILE) {
        for i0 in (0..n).step_by(TILE) {
            for dk in 0..out.depth {
                let z = MantleVolume::cell_centre(n, out.first_k + dk);
                for j in j0..(j0 + TILE).min(n) {
                    for i in i0..(i0 + TILE).min(n) {
                        let column = &columns[j * n + i];
                        let cell = (dk * n + j) * n + i;
                        let (temperature, fluctuation, viscosity) =
                            match grid.interpolate(column.rho, z, &column.phi) {
                                Some((t, mean)) => (
                                    t as f32,
                                    (t - mean) as f32,
                                    ((0.5 - t) * log_contrast).exp() as f32,
                                ),
                                None => (f32::NAN, f32::NAN, f32::NAN),
                            };
                        if let Some(values) = out.temperature.as_deref_mut() {
                            values[cell] = temperature;
                        }
                        if let Some(values) = out.fluctuation.as_deref_mut() {
                            values[cell] = fluctuation;
                        }
                        if let Some(values) = out.viscosity.as_deref_mut() {
                            values[cell] = viscosity;
                        }
                    }
                }
            }
        }
    }
}
