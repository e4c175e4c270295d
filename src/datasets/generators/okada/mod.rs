//! Displacement of an elastic half-space by finite rectangular dislocations: Okada (1985,
//! BSSA 75, 1135-1154) at the free surface and Okada (1992, BSSA 82, 1018-1040, "DC3D") at depth,
//! with the papers' rules for their singular cases. Two layers: `OkadaRectangle` works in
//! Okada's own frame (x along strike, y perpendicular, z up, origin at the bottom-left corner of
//! the fault) and is what the published check lists test; [`FaultSegment`] places faults in
//! project coordinates (x east, y north, z up, metres) with strike, dip and rake, and
//! [`surface_field`] samples the surface displacement of a set of them on a grid for rendering
//! (the paper's case II: Yuan et al. 2008, section 3.2).

//!
//! The rooms: `kernel` (Okada's frame and the papers' formulas), `segment` (faults in project
//! coordinates and the elastic medium), `table` (segment tables read from text); this file
//! sums the segments at a point or over a grid.

mod kernel;
mod segment;
mod table;
#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::error::{Error, Result};
use segment::PreparedSegment;
pub use segment::{DepthRef, Elastic, FaultSegment};
pub use table::parse_segment_table;
/// Largest grid side accepted by [`surface_field`]; 8193^2 nodes already need 1.6 GB for the
/// three components.
pub(crate) const MAX_GRID_SIDE: usize = 8193;

/// Validates every segment, naming the segment's index in the error.
fn prepare_all(segments: &[FaultSegment], elastic: &Elastic) -> Result<Vec<PreparedSegment>> {
    segments
        .iter()
        .enumerate()
        .map(|(index, segment)| match segment.validate() {
            Ok(()) => Ok(segment.prepare(elastic)),
            Err(Error::Invalid { field, msg }) => {
                Err(Error::invalid(format!("segment {index} {field}"), msg))
            }
            Err(other) => Err(other),
        })
        .collect()
}

/// Displacement (east, north, up) in metres at (x, y, z), z <= 0, summed over the segments:
/// Okada (1985) at the surface, Okada (1992) below it.
pub(crate) fn displacement_at(
    segments: &[FaultSegment],
    elastic: &Elastic,
    x: f64,
    y: f64,
    z: f64,
) -> Result<[f64; 3]> {
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return Err(Error::invalid(
            "x/y/z",
            format!("observation point must be finite, got ({x}, {y}, {z})"),
        ));
    }
    if z > 0.0 {
        return Err(Error::invalid(
            "z",
            format!("must be <= 0 m (inside the half-space), got {z}"),
        ));
    }
    let prepared = prepare_all(segments, elastic)?;
    let mut total = [0.0; 3];
    for segment in &prepared {
        let u = if z == 0.0 {
            segment.surface(x, y)
        } else {
            segment.internal(x, y, z)?
        };
        for (sum, part) in total.iter_mut().zip(u) {
            *sum += part;
        }
    }
    Ok(total)
}

/// Surface displacement on a regular grid. `x` (east) and `y` (north) hold the node
/// coordinates along each axis; the components are row-major, index `j * nx + i` for node
/// (`x[i]`, `y[j]`).
#[derive(Clone, Debug, PartialEq)]
pub struct OkadaField {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub ux: Vec<f64>,
    pub uy: Vec<f64>,
    pub uz: Vec<f64>,
}

impl OkadaField {
    pub fn nx(&self) -> usize {
        self.x.len()
    }

    pub fn ny(&self) -> usize {
        self.y.len()
    }
}

/// Displacements at every (x[i], y[j], z), row by row (`result[j * x.len() + i]`), computed in
/// parallel in bands of rows with `progress` told the fraction done after each band, so a long
/// grid can be stopped (a script's deadline) and shows how far it is.
pub(crate) fn displacement_grid(
    segments: &[FaultSegment],
    elastic: &Elastic,
    x: &[f64],
    y: &[f64],
    z: f64,
    progress: &mut dyn FnMut(f64) -> Result<()>,
) -> Result<Vec<[f64; 3]>> {
    let band = y.len().div_ceil(PROGRESS_STEPS).max(1);
    let mut out = Vec::with_capacity(x.len() * y.len());
    for rows in y.chunks(band) {
        let part: Vec<Vec<[f64; 3]>> = rows
            .par_iter()
            .map(|&yj| {
                x.iter()
                    .map(|&xi| displacement_at(segments, elastic, xi, yj, z))
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        out.extend(part.into_iter().flatten());
        progress(out.len() as f64 / (x.len() * y.len()).max(1) as f64)?;
    }
    Ok(out)
}

/// How many times a grid reports its progress.
const PROGRESS_STEPS: usize = 32;

/// Surface displacement of the segments on a square of side `extent_m` centred on the origin,
/// `n` nodes per side (spacing `extent_m / (n - 1)`), computed in parallel over rows.
pub fn surface_field(
    segments: &[FaultSegment],
    elastic: &Elastic,
    extent_m: f64,
    n: usize,
    progress: &mut dyn FnMut(f64) -> Result<()>,
) -> Result<OkadaField> {
    if !(extent_m.is_finite() && extent_m > 0.0) {
        return Err(Error::invalid(
            "extent_m",
            format!("must be finite and > 0, got {extent_m}"),
        ));
    }
    if !(2..=MAX_GRID_SIDE).contains(&n) {
        return Err(Error::invalid(
            "n",
            format!("nodes per side must lie in [2, {MAX_GRID_SIDE}], got {n}"),
        ));
    }
    let prepared = prepare_all(segments, elastic)?;
    let spacing = extent_m / (n - 1) as f64;
    let axis: Vec<f64> = (0..n)
        .map(|i| -0.5 * extent_m + i as f64 * spacing)
        .collect();
    let mut ux = vec![0.0; n * n];
    let mut uy = vec![0.0; n * n];
    let mut uz = vec![0.0; n * n];
    // Bands of rows, so a caller's progress (and its deadline) is heard during a long grid.
    let band = n.div_ceil(PROGRESS_STEPS).max(1);
    for (b, ((bx, by), bz)) in ux
        .chunks_mut(band * n)
        .zip(uy.chunks_mut(band * n))
        .zip(uz.chunks_mut(band * n))
        .enumerate()
    {
        bx.par_chunks_mut(n)
            .zip(by.par_chunks_mut(n))
            .zip(bz.par_chunks_mut(n))
            .enumerate()
            .for_each(|(k, ((row_x, row_y), row_z))| {
                let north = axis[b * band + k];
                for (i, &east) in axis.iter().enumerate() {
                    let mut u = [0.0; 3];
                    for segment in &prepared {
                        let part = segment.surface(east, north);
                        u[0] += part[0];
                        u[1] += part[1];
                        u[2] += part[2];
                    }
                    row_x[i] = u[0];
                    row_y[i] = u[1];
                    row_z[i] = u[2];
                }
            });
        progress(((b + 1) * band).min(n) as f64 / n as f64)?;
    }
    Ok(OkadaField {
        x: axis.clone(),
        y: axis,
        ux,
        uy,
        uz,
    })
}
