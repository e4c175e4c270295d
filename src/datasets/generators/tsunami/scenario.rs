//! The demonstration scenario: a synthetic basin shaped like the South China Sea and a
//! Manila-trench thrust source over it.

use super::bathymetry::Bathymetry;
use super::SOUTH_CHINA_SEA_EXTENT_M;
use crate::datasets::okada::{DepthRef, FaultSegment};

/// A synthetic basin shaped like the South China Sea on an `n x n` grid covering
/// `extent_m x extent_m` (about `SOUTH_CHINA_SEA_EXTENT_M` is realistic): land along the north
/// (China), west (Indochina) and south (Borneo), the Luzon-Palawan arc on the east with the open
/// Luzon Strait north of it, shelves of 20-200 m (widest in the south-west, like the Sunda
/// shelf), a 4000 m abyssal plain with gentle relief, and a trench reaching 5300 m west of Luzon
/// along strike 350 degrees, like the Manila trench. Land cells carry negative depth (elevation).
/// All features scale with `extent_m`.
pub(crate) fn synthetic_south_china_sea(n: usize, extent_m: f64) -> Bathymetry {
    let n = n.max(2);
    let d = extent_m / n as f64;
    let mut depth_m = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            let v = (j as f64 + 0.5) / n as f64;
            depth_m.push(south_china_sea_depth(u, v));
        }
    }
    Bathymetry {
        nx: n,
        ny: n,
        dx_m: d,
        dy_m: d,
        depth_m,
    }
}

/// Depth at fractional position (u east, v north) in the unit square.
fn south_china_sea_depth(u: f64, v: f64) -> f64 {
    use std::f64::consts::TAU;
    let china = 0.86 + 0.03 * (TAU * 1.5 * u).sin() - v;
    let indochina = u - (0.10 + 0.04 * (TAU * 1.2 * v).sin());
    let borneo = v - (0.08 + 0.03 * (TAU * 2.0 * u).sin());
    let luzon_palawan = signed_distance_to_box(u, v, (0.90, 0.15), (1.5, 0.78));
    // Distance from the nearest coast, as a fraction of the extent; negative on land.
    let sea_distance = china.min(indochina).min(borneo).min(luzon_palawan);
    if sea_distance <= 0.0 {
        return -(10.0 + 3000.0 * (-sea_distance).min(0.5));
    }
    let sunda = (-((u - 0.15).powi(2) + (v - 0.10).powi(2)) / 0.03).exp();
    let shelf_width = 0.05 + 0.15 * sunda;
    let slope_width = 0.06;
    let mut depth = if sea_distance < shelf_width {
        20.0 + 180.0 * sea_distance / shelf_width
    } else {
        let s = ((sea_distance - shelf_width) / slope_width).min(1.0);
        let smooth = s * s * (3.0 - 2.0 * s);
        let relief = 150.0 * (TAU * 3.0 * u).sin() * (TAU * 2.5 * v).cos();
        200.0 + (3800.0 + relief - 200.0) * smooth
    };
    let (across, along) = manila_trench_coordinates(u, v);
    let trench = (-(across / 0.0125).powi(2)).exp() * (-(along / 0.2).powi(4)).exp();
    depth += (MANILA_TRENCH_AXIS_DEPTH_M - depth) * trench;
    depth
}

/// Signed distance from (u, v) to an axis-aligned box, negative inside.
fn signed_distance_to_box(u: f64, v: f64, lo: (f64, f64), hi: (f64, f64)) -> f64 {
    let cx = 0.5 * (lo.0 + hi.0);
    let cy = 0.5 * (lo.1 + hi.1);
    let qx = (u - cx).abs() - 0.5 * (hi.0 - lo.0);
    let qy = (v - cy).abs() - 0.5 * (hi.1 - lo.1);
    qx.max(0.0).hypot(qy.max(0.0)) + qx.max(qy).min(0.0)
}

const MANILA_TRENCH_AXIS_DEPTH_M: f64 = 5300.0;
/// Trench axis midpoint in the unit square and its strike, degrees clockwise from north.
const MANILA_TRENCH_AXIS_UV: (f64, f64) = (0.80, 0.55);
const MANILA_TRENCH_STRIKE_DEG: f64 = 350.0;

/// (distance across the trench towards the dip direction, distance along strike), unit square.
fn manila_trench_coordinates(u: f64, v: f64) -> (f64, f64) {
    let strike = MANILA_TRENCH_STRIKE_DEG.to_radians();
    let (du, dv) = (u - MANILA_TRENCH_AXIS_UV.0, v - MANILA_TRENCH_AXIS_UV.1);
    let along = du * strike.sin() + dv * strike.cos();
    let across = du * strike.cos() - dv * strike.sin();
    (across, along)
}

/// `fault` placed in a synthetic basin of side `extent_m` instead of `SOUTH_CHINA_SEA_EXTENT_M`:
/// the position scales, the fault's size does not.
pub(crate) fn scaled_to_extent(fault: FaultSegment, extent_m: f64) -> FaultSegment {
    let scale = extent_m / SOUTH_CHINA_SEA_EXTENT_M;
    FaultSegment {
        x_m: fault.x_m * scale,
        y_m: fault.y_m * scale,
        ..fault
    }
}

/// A Manila-trench megathrust for the synthetic basin of side `SOUTH_CHINA_SEA_EXTENT_M`:
/// strike 350, dip 20, rake 90 degrees, 8 m of slip on a 200 km x 80 km plane whose top edge
/// lies 5 km below the sea floor under the trench axis (so the centre is at 18.68 km depth),
/// dipping east under Luzon. Magnitude about Mw 8.4 for a rigidity of 40 GPa. Positions are
/// metres in the synthetic basin's frame (origin at its south-west corner, x east, y north), of
/// the plane's centre.
pub(crate) fn manila_trench_source() -> FaultSegment {
    let (strike_deg, dip_deg) = (MANILA_TRENCH_STRIKE_DEG, 20.0_f64);
    let (width_m, top_depth_m) = (80_000.0, 5_000.0);
    let dip = dip_deg.to_radians();
    // From the trench axis to the plane's centre, half the width down dip, horizontally
    // along the dip direction (strike + 90 degrees).
    let dip_azimuth = (strike_deg + 90.0).to_radians();
    let offset = 0.5 * width_m * dip.cos();
    let (axis_u, axis_v) = MANILA_TRENCH_AXIS_UV;
    FaultSegment {
        strike_deg,
        dip_deg,
        rake_deg: 90.0,
        slip_m: 8.0,
        length_m: 200_000.0,
        width_m,
        depth_m: top_depth_m + 0.5 * width_m * dip.sin(),
        depth_ref: DepthRef::Centroid,
        opening_m: 0.0,
        x_m: axis_u * SOUTH_CHINA_SEA_EXTENT_M + offset * dip_azimuth.sin(),
        y_m: axis_v * SOUTH_CHINA_SEA_EXTENT_M + offset * dip_azimuth.cos(),
    }
}
