//! Okada's published check lists, the field equations and boundary conditions checked
//! numerically, the placement of faults in project coordinates, and segment tables.

use std::path::Path;

use super::kernel::*;
use super::*;

/// Okada (1985) Table 2 uses lambda = mu: alpha = 2/3.
const ALPHA: f64 = 2.0 / 3.0;

fn rect(depth: f64, dip_deg: f64, slip: [f64; 3]) -> OkadaRectangle {
    OkadaRectangle {
        length: 3.0,
        width: 2.0,
        depth,
        dip_deg,
        strike_slip: slip[0],
        dip_slip: slip[1],
        tensile: slip[2],
    }
}

const UNIT_SLIPS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Asserts a value printed to 4 significant digits (half a unit of the last digit), and
/// exact zeros where the table prints 0.
fn assert_printed(got: f64, printed: f64, what: &str) {
    if printed == 0.0 {
        assert!(got.abs() <= 1e-15, "{what}: got {got:e}, table prints 0");
    } else {
        let last_digit = 10f64.powf(printed.abs().log10().floor() - 3.0);
        assert!(
            (got - printed).abs() <= 0.5 * last_digit * (1.0 + 1e-9),
            "{what}: got {got:.6e}, table prints {printed:.3e}"
        );
    }
}

fn check_table_case(case: &str, x: f64, y: f64, depth: f64, dip: f64, table: [[f64; 3]; 3]) {
    for (slip, printed) in UNIT_SLIPS.iter().zip(table) {
        let u = rect(depth, dip, *slip)
            .surface_displacement(ALPHA, x, y)
            .unwrap();
        for k in 0..3 {
            assert_printed(
                u[k],
                printed[k],
                &format!("{case} slip {slip:?} component {k}"),
            );
        }
    }
}

/// Okada (1985), "Surface deformation due to shear and tensile faults in a half-space",
/// Table 2, case 2.
#[test]
fn okada85_table2_case2() {
    check_table_case(
        "case 2",
        2.0,
        3.0,
        4.0,
        70.0,
        [
            [-8.689e-3, -4.298e-3, -2.747e-3],
            [-4.682e-3, -3.527e-2, -3.564e-2],
            [-2.660e-4, 1.056e-2, 3.214e-3],
        ],
    );
}

/// Okada (1985) Table 2, case 3: the point lies on the extension of the fault's end edge.
#[test]
fn okada85_table2_case3() {
    check_table_case(
        "case 3",
        0.0,
        0.0,
        4.0,
        90.0,
        [
            [0.0, 5.253e-3, 0.0],
            [0.0, 0.0, 0.0],
            [1.223e-2, 0.0, -1.606e-2],
        ],
    );
}

/// Okada (1985) Table 2, case 4: the vertical fault of case 3 dipping the other way, dip
/// -90, with R + eta = 0 at two corners. validation.md gives d = 6, the depth of the fault's
/// bottom edge; with a negative dip Okada's origin corner (eta = 0) is the fault's top, and
/// eta grows downwards, so `depth` is 6 - W = 4 (the fault spans depths 4 to 6). The same
/// numbers come from the fault of dip +90 with its origin at depth 6 and the strike- and
/// dip-slip reversed, which is the plane seen from its other side.
#[test]
fn okada85_table2_case4() {
    let table = [
        [0.0, -1.303e-3, 0.0],
        [0.0, 0.0, 0.0],
        [3.507e-3, 0.0, -7.740e-3],
    ];
    check_table_case("case 4", 0.0, 0.0, 4.0, -90.0, table);
    for (slip, printed) in UNIT_SLIPS.iter().zip(table) {
        let other_side = rect(6.0, 90.0, [-slip[0], -slip[1], slip[2]]);
        let u = other_side.surface_displacement(ALPHA, 0.0, 0.0).unwrap();
        for k in 0..3 {
            assert_printed(
                u[k],
                printed[k],
                &format!("case 4 seen from dip +90, {slip:?} {k}"),
            );
        }
    }
}

/// Higher-precision values of Table 2 case 2 (validation.md), quoted digit for digit.
#[test]
#[allow(clippy::excessive_precision)]
fn okada85_case2_high_precision() {
    let expected = [
        [
            -8.6891650042561549e-3,
            -4.2975821897415613e-3,
            -2.7474058276388967e-3,
        ],
        [
            -4.6823487628354045e-3,
            -3.5267267968718020e-2,
            -3.5638557673268470e-2,
        ],
        [
            -2.6599600964428191e-4,
            1.0564074876983659e-2,
            3.2141931142207676e-3,
        ],
    ];
    for (slip, want) in UNIT_SLIPS.iter().zip(expected) {
        let got = rect(4.0, 70.0, *slip)
            .surface_displacement(ALPHA, 2.0, 3.0)
            .unwrap();
        for k in 0..3 {
            let relative = ((got[k] - want[k]) / want[k]).abs();
            assert!(
                relative <= 1e-9,
                "slip {slip:?} component {k}: {got:?} vs {want:?}"
            );
        }
    }
}

/// Observation points spread around and above the fault for the comparisons below.
fn sample_points() -> Vec<(f64, f64)> {
    let mut points = Vec::new();
    for &x in &[-7.5, -2.0, 0.0, 0.7, 1.5, 3.0, 4.2, 11.0] {
        for &y in &[-9.0, -3.3, -1.0, 0.0, 0.4, 1.2, 2.9, 6.0] {
            points.push((x, y));
        }
    }
    points
}

/// Okada (1992) at z = 0 must reproduce Okada (1985) (the 1992 paper's own consistency
/// requirement), for every slip type, positive, negative and vertical dips.
#[test]
fn okada92_at_surface_equals_okada85() {
    let mut compared = 0;
    for &(depth, dip) in &[
        (4.0, 70.0),
        (4.0, 90.0),
        (6.0, -90.0),
        (3.0, 30.0),
        (2.5, 0.0),
        (5.0, -40.0),
        (4.0, 89.9),
    ] {
        for alpha in [ALPHA, 0.55, 0.9] {
            for slip in UNIT_SLIPS {
                let source = rect(depth, dip, slip);
                for (x, y) in sample_points() {
                    let surface = source.surface_displacement(alpha, x, y).unwrap();
                    let internal = source.displacement(alpha, x, y, 0.0).unwrap();
                    // Near vertical both forms lose digits to their 1/cos^2(dip) terms,
                    // and differently.
                    let tolerance = if dip == 89.9 { 1e-7 } else { 1e-11 };
                    let scale = surface.iter().fold(1e-3_f64, |m, v| m.max(v.abs()));
                    for k in 0..3 {
                        assert!(
                            (surface[k] - internal[k]).abs() <= tolerance * scale,
                            "dip {dip} alpha {alpha} slip {slip:?} at ({x}, {y}): {surface:?} vs {internal:?}"
                        );
                    }
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 7 * 3 * 3 * 64);
}

/// Second differences of the 1992 field at depth, for the equilibrium test below.
#[allow(clippy::needless_range_loop)] // tensor indices read best as indices
fn navier_residual(source: &OkadaRectangle, alpha: f64, point: [f64; 3], h: f64) -> (f64, f64) {
    let u = |offset: [f64; 3]| {
        source
            .displacement(
                alpha,
                point[0] + offset[0],
                point[1] + offset[1],
                point[2] + offset[2],
            )
            .unwrap()
    };
    let step = |axis: usize, amount: f64| {
        let mut offset = [0.0; 3];
        offset[axis] = amount;
        offset
    };
    let centre = u([0.0; 3]);
    // second[i][j][k]: d^2 u_k / dx_i dx_j
    let mut second = [[[0.0; 3]; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let value = if i == j {
                let (plus, minus) = (u(step(i, h)), u(step(i, -h)));
                [0, 1, 2].map(|k| (plus[k] - 2.0 * centre[k] + minus[k]) / (h * h))
            } else {
                let corner = |si: f64, sj: f64| {
                    let mut offset = step(i, si * h);
                    offset[j] = sj * h;
                    u(offset)
                };
                let (pp, pm, mp, mm) = (
                    corner(1.0, 1.0),
                    corner(1.0, -1.0),
                    corner(-1.0, 1.0),
                    corner(-1.0, -1.0),
                );
                [0, 1, 2].map(|k| (pp[k] - pm[k] - mp[k] + mm[k]) / (4.0 * h * h))
            };
            second[i][j] = value;
        }
    }
    let mu_ratio = (1.0 - alpha) / alpha;
    let (mut worst, mut size) = (0.0_f64, 0.0_f64);
    for k in 0..3 {
        let laplacian: f64 = (0..3).map(|i| second[i][i][k]).sum();
        let grad_div: f64 = (0..3).map(|j| second[k][j][j]).sum();
        // mu lap u + (lambda + mu) grad div u = 0, divided by (lambda + mu).
        worst = worst.max((mu_ratio * laplacian + grad_div).abs());
        size = size.max((mu_ratio * laplacian).abs()).max(grad_div.abs());
    }
    (worst, size)
}

/// The 1992 field satisfies Navier's equilibrium equation inside the half-space (a check of
/// every term, including the depth terms u^C that vanish at z = 0).
#[test]
fn okada92_satisfies_navier_equation() {
    let points = [
        [1.0, -2.0, -1.5],
        [4.0, 2.5, -3.0],
        [-1.5, 0.5, -6.0],
        [1.5, 3.0, -0.5],
    ];
    for (depth, dip) in [
        (4.0, 70.0),
        (3.0, 30.0),
        (4.0, 90.0),
        (5.0, -40.0),
        (2.5, 0.0),
    ] {
        for alpha in [ALPHA, 0.55] {
            for slip in UNIT_SLIPS {
                let source = rect(depth, dip, slip);
                for point in points {
                    let (residual, size) = navier_residual(&source, alpha, point, 2.5e-3);
                    assert!(
                        residual <= 1e-4 * size,
                        "dip {dip} slip {slip:?} at {point:?}: residual {residual:e}, terms {size:e}"
                    );
                }
            }
        }
    }
}

/// The free surface carries no traction: sigma_xz = sigma_yz = sigma_zz = 0 at z = 0,
/// with z-derivatives from a fourth-order one-sided difference.
#[test]
fn okada92_free_surface_is_traction_free() {
    let h = 2.5e-3;
    for (depth, dip) in [(4.0, 70.0), (3.0, 30.0), (4.0, 90.0), (5.0, -40.0)] {
        let alpha = ALPHA;
        let lambda_over_mu = {
            let poisson = 1.0 - 0.5 / alpha;
            2.0 * poisson / (1.0 - 2.0 * poisson)
        };
        for slip in UNIT_SLIPS {
            let source = rect(depth, dip, slip);
            for (x, y) in [(1.0, -2.0), (4.0, 2.5), (-1.5, 0.5), (2.0, 3.0)] {
                let u = |dx: f64, dy: f64, z: f64| {
                    source.displacement(alpha, x + dx, y + dy, z).unwrap()
                };
                let d_dz: [f64; 3] = {
                    let f = [0.0, 1.0, 2.0, 3.0, 4.0].map(|n| u(0.0, 0.0, -n * h));
                    [0, 1, 2].map(|k| {
                        (25.0 * f[0][k] - 48.0 * f[1][k] + 36.0 * f[2][k] - 16.0 * f[3][k]
                            + 3.0 * f[4][k])
                            / (12.0 * h)
                    })
                };
                let central = |dx: f64, dy: f64| {
                    let (plus, minus) = (u(dx * h, dy * h, 0.0), u(-dx * h, -dy * h, 0.0));
                    [0, 1, 2].map(|k| (plus[k] - minus[k]) / (2.0 * h))
                };
                let (d_dx, d_dy) = (central(1.0, 0.0), central(0.0, 1.0));
                let divergence = d_dx[0] + d_dy[1] + d_dz[2];
                let tractions = [
                    d_dz[0] + d_dx[2],
                    d_dz[1] + d_dy[2],
                    lambda_over_mu * divergence + 2.0 * d_dz[2],
                ];
                let size = d_dx
                    .iter()
                    .chain(&d_dy)
                    .chain(&d_dz)
                    .fold(0.0_f64, |m, v| m.max(v.abs()));
                for traction in tractions {
                    assert!(
                        traction.abs() <= 1e-5 * size,
                        "dip {dip} slip {slip:?} at ({x}, {y}): tractions {tractions:?}, gradient {size:e}"
                    );
                }
            }
        }
    }
}

/// Across the fault the displacement jumps by the slip vector: hanging wall (the side the
/// normal (0, -sin, cos) points to) minus foot wall = U1 strike + U2 up-dip + U3 normal.
#[test]
fn okada92_jump_across_fault_is_the_slip() {
    let slip = [0.7, -1.3, 0.4];
    for (depth, dip) in [(4.0, 70.0), (3.0, 30.0), (4.0, 90.0), (5.0, -40.0)] {
        let source = rect(depth, dip, slip);
        let (sin, cos) = dip_sin_cos(dip);
        let up_dip = [0.0, cos, sin];
        let normal = [0.0, -sin, cos];
        let expected = [0, 1, 2].map(|k| {
            slip[1] * up_dip[k] + slip[2] * normal[k] + if k == 0 { slip[0] } else { 0.0 }
        });
        for (along, up) in [(1.5, 1.0), (0.4, 0.3), (2.7, 1.8)] {
            let on_fault = [along, up * cos, -(depth - up * sin)];
            let side = |sign: f64| {
                let e = sign * 1e-7;
                source
                    .displacement(
                        ALPHA,
                        on_fault[0],
                        on_fault[1] + e * normal[1],
                        on_fault[2] + e * normal[2],
                    )
                    .unwrap()
            };
            let (hanging, foot) = (side(1.0), side(-1.0));
            for k in 0..3 {
                assert!(
                    (hanging[k] - foot[k] - expected[k]).abs() <= 1e-6,
                    "dip {dip} at ({along}, {up}): jump {:?}, slip vector {expected:?}",
                    [0, 1, 2].map(|i| hanging[i] - foot[i])
                );
            }
        }
    }
}

/// On the extension of an edge line (R + xi = 0 or R + eta = 0 for the real source) the
/// limit rules must give the limit of the neighbouring values; an edge itself is an error.
#[test]
fn okada92_is_continuous_across_singular_lines() {
    for (depth, dip) in [(4.0, 70.0), (4.0, 90.0), (5.0, -40.0), (3.0, 30.0)] {
        let source = rect(depth, dip, [0.6, 0.8, 0.5]);
        let (sin, cos) = dip_sin_cos(dip);
        // Below the corner along the end edge (eta < 0), and beyond the bottom edge along
        // strike (xi < 0).
        let lines = [
            [0.0, -1.5 * cos, -(depth + 1.5 * sin)],
            [-1.2, 0.0, -depth],
            [4.5, 0.0, -depth],
        ];
        for point in lines {
            let on_line = source
                .displacement(ALPHA, point[0], point[1], point[2])
                .unwrap();
            let nearby = source
                .displacement(ALPHA, point[0] + 1e-5, point[1] + 1e-5, point[2] - 1e-5)
                .unwrap();
            for k in 0..3 {
                assert!(
                    (on_line[k] - nearby[k]).abs()
                        <= 1e-4 * on_line.iter().fold(1e-3, |m: f64, v| m.max(v.abs())),
                    "dip {dip} at {point:?}: {on_line:?} vs {nearby:?}"
                );
            }
        }
        let corner = source.displacement(ALPHA, 0.0, 0.0, -depth);
        assert!(matches!(corner, Err(Error::Invalid { .. })));
        let on_bottom_edge = source.displacement(ALPHA, 1.0, 0.0, -depth);
        assert!(on_bottom_edge.is_err());
    }
}

#[test]
fn okada_frame_rejects_bad_input() {
    let good = rect(4.0, 70.0, [1.0, 0.0, 0.0]);
    assert!(good.surface_displacement(0.2, 1.0, 1.0).is_err());
    assert!(good.displacement(ALPHA, 1.0, 1.0, 0.5).is_err());
    assert!(good.surface_displacement(ALPHA, f64::NAN, 1.0).is_err());
    let breaking = rect(1.0, 70.0, [1.0, 0.0, 0.0]);
    let error = breaking.surface_displacement(ALPHA, 1.0, 1.0).unwrap_err();
    assert!(error.to_string().starts_with("depth:"), "{error}");
    assert!(rect(4.0, 91.0, [1.0, 0.0, 0.0])
        .surface_displacement(ALPHA, 1.0, 1.0)
        .is_err());
}

// ---- project coordinates ----

fn vertical_strike_slip() -> FaultSegment {
    FaultSegment {
        strike_deg: 0.0,
        dip_deg: 90.0,
        rake_deg: 0.0,
        slip_m: 1.0,
        length_m: 20e3,
        width_m: 10e3,
        depth_m: 10e3,
        depth_ref: DepthRef::Centroid,
        opening_m: 0.0,
        x_m: 0.0,
        y_m: 0.0,
    }
}

fn at(segments: &[FaultSegment], x: f64, y: f64, z: f64) -> [f64; 3] {
    displacement_at(segments, &Elastic::default(), x, y, z).unwrap()
}

/// A vertical left-lateral fault along north: mirroring across the fault plane reverses
/// the slip, so u_north and u_up are odd and u_east even in x; mirroring across the plane
/// through its centre perpendicular to strike does the same with y and the roles swapped.
#[test]
fn vertical_strike_slip_symmetries() {
    let fault = [vertical_strike_slip()];
    for z in [0.0, -3e3] {
        for (x, y) in [(1e3, 2e3), (7e3, -15e3), (25e3, 4e3), (3e3, 30e3)] {
            let u = at(&fault, x, y, z);
            let mirror_x = at(&fault, -x, y, z);
            let mirror_y = at(&fault, x, -y, z);
            let tolerance = 1e-12 * u.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            assert!(
                (u[1] + mirror_x[1]).abs() <= tolerance,
                "u_north odd in x: {u:?} {mirror_x:?}"
            );
            assert!((u[0] - mirror_x[0]).abs() <= tolerance, "u_east even in x");
            assert!((u[2] + mirror_x[2]).abs() <= tolerance, "u_up odd in x");
            assert!((u[1] - mirror_y[1]).abs() <= tolerance, "u_north even in y");
            assert!((u[0] + mirror_y[0]).abs() <= tolerance, "u_east odd in y");
            assert!((u[2] + mirror_y[2]).abs() <= tolerance, "u_up odd in y");
        }
    }
    // Left-lateral: seen from the west side, the east side moves north (to the left).
    let east_side = at(&fault, 1e3, 0.0, 0.0);
    assert!(east_side[1] > 0.0, "{east_side:?}");
}

/// Turning the fault and the observation point together by the same angle turns the
/// displacement with them.
#[test]
fn rotation_moves_the_field_with_the_fault() {
    let base = FaultSegment {
        strike_deg: 30.0,
        dip_deg: 50.0,
        rake_deg: 40.0,
        opening_m: 0.3,
        ..vertical_strike_slip()
    };
    let clockwise = |angle: f64, v: [f64; 2]| {
        let (sin, cos) = angle.to_radians().sin_cos();
        [v[0] * cos + v[1] * sin, -v[0] * sin + v[1] * cos]
    };
    for angle in [90.0, 37.0, -120.0] {
        let turned = FaultSegment {
            strike_deg: base.strike_deg + angle,
            ..base
        };
        for (point, z) in [([7e3, -3e3], 0.0), ([-12e3, 5e3], 0.0), ([2e3, 9e3], -4e3)] {
            let u = at(&[base], point[0], point[1], z);
            let p = clockwise(angle, point);
            let v = at(&[turned], p[0], p[1], z);
            let expected = clockwise(angle, [u[0], u[1]]);
            let tolerance = 1e-12 * u.iter().fold(0.0_f64, |m, w| m.max(w.abs()));
            assert!(
                (v[0] - expected[0]).abs() <= tolerance,
                "angle {angle}: {v:?} vs {expected:?}"
            );
            assert!(
                (v[1] - expected[1]).abs() <= tolerance,
                "angle {angle}: {v:?} vs {expected:?}"
            );
            assert!(
                (v[2] - u[2]).abs() <= tolerance,
                "angle {angle}: {v:?} vs {u:?}"
            );
        }
    }
}

/// Top, centroid and bottom references describe the same fault when the depths differ by
/// half and whole the fault's vertical extent; a shift of (x_m, y_m) shifts the field.
#[test]
fn depth_reference_and_position_are_consistent() {
    let centroid = FaultSegment {
        strike_deg: 75.0,
        dip_deg: 35.0,
        rake_deg: 120.0,
        depth_m: 12e3,
        ..vertical_strike_slip()
    };
    let half_height = 0.5 * centroid.width_m * 35f64.to_radians().sin();
    let top = FaultSegment {
        depth_ref: DepthRef::Top,
        depth_m: 12e3 - half_height,
        ..centroid
    };
    let bottom = FaultSegment {
        depth_ref: DepthRef::Bottom,
        depth_m: 12e3 + half_height,
        ..centroid
    };
    assert!((top.top_depth_m() - (12e3 - half_height)).abs() < 1e-9);
    assert!((bottom.bottom_depth_m() - (12e3 + half_height)).abs() < 1e-9);
    let shifted = FaultSegment {
        x_m: 4e3,
        y_m: -6e3,
        ..centroid
    };
    for (x, y, z) in [(3e3, 4e3, 0.0), (-8e3, 1e3, 0.0), (5e3, -2e3, -2e3)] {
        let reference = at(&[centroid], x, y, z);
        let tolerance = 1e-12 * reference.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for other in [top, bottom] {
            let u = at(&[other], x, y, z);
            for k in 0..3 {
                assert!(
                    (u[k] - reference[k]).abs() <= tolerance,
                    "{:?}: {u:?} vs {reference:?}",
                    other.depth_ref
                );
            }
        }
        let moved = at(&[shifted], x + 4e3, y - 6e3, z);
        for k in 0..3 {
            assert!((moved[k] - reference[k]).abs() <= tolerance);
        }
    }
    // A deeper reference point with the same number puts the fault deeper.
    let same_number_top = FaultSegment {
        depth_ref: DepthRef::Top,
        ..centroid
    };
    assert!(same_number_top.centroid_depth_m() > centroid.centroid_depth_m());
}

/// Two halves laid end to end displace the ground like the whole fault (linearity of the
/// solution and the Chinnery sum).
#[test]
fn segments_superpose() {
    let whole = FaultSegment {
        strike_deg: 30.0,
        dip_deg: 60.0,
        rake_deg: -70.0,
        length_m: 40e3,
        ..vertical_strike_slip()
    };
    let (sin, cos) = 30f64.to_radians().sin_cos();
    let half = |sign: f64| FaultSegment {
        length_m: 20e3,
        x_m: sign * 10e3 * sin,
        y_m: sign * 10e3 * cos,
        ..whole
    };
    let halves = [half(-1.0), half(1.0)];
    for (x, y, z) in [(5e3, 5e3, 0.0), (-30e3, 12e3, 0.0), (8e3, -3e3, -5e3)] {
        let one = at(&[whole], x, y, z);
        let two = at(&halves, x, y, z);
        let tolerance = 1e-10 * one.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for k in 0..3 {
            assert!((one[k] - two[k]).abs() <= tolerance, "{one:?} vs {two:?}");
        }
    }
}

/// A negative dip is the same plane as strike + 180, |dip|, rake + 180.
#[test]
fn negative_dip_is_the_reversed_plane() {
    let negative = FaultSegment {
        strike_deg: 20.0,
        dip_deg: -35.0,
        rake_deg: 50.0,
        opening_m: 0.2,
        ..vertical_strike_slip()
    };
    let positive = FaultSegment {
        strike_deg: 200.0,
        dip_deg: 35.0,
        rake_deg: 230.0,
        ..negative
    };
    for (x, y, z) in [(5e3, 5e3, 0.0), (-9e3, 2e3, 0.0), (3e3, -4e3, -6e3)] {
        let a = at(&[negative], x, y, z);
        let b = at(&[positive], x, y, z);
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= 1e-12 * b[k].abs().max(1e-3));
        }
    }
}

/// A shallow thrust lifts the ground above its hanging wall; the paper's case II, a normal
/// fault, lets the ground subside above it and stretches it east-west.
#[test]
fn thrust_uplifts_and_normal_fault_subsides() {
    let thrust = FaultSegment {
        rake_deg: 90.0,
        dip_deg: 30.0,
        depth_m: 1e3,
        depth_ref: DepthRef::Top,
        ..vertical_strike_slip()
    };
    assert!(at(&[thrust], 0.0, 0.0, 0.0)[2] > 0.0);

    let n = 101;
    let field = surface_field(
        &[FaultSegment::paper_case_ii()],
        &Elastic::default(),
        1000e3,
        n,
        &mut |_| Ok(()),
    )
    .unwrap();
    let extreme = |values: &[f64], lower: bool| {
        let mut best = 0;
        for (index, &value) in values.iter().enumerate() {
            if (lower && value < values[best]) || (!lower && value > values[best]) {
                best = index;
            }
        }
        (values[best], field.x[best % n], field.y[best / n])
    };
    let (lowest, lowest_x, lowest_y) = extreme(&field.uz, true);
    let (highest, highest_x, _) = extreme(&field.uz, false);
    // The fault strikes north and dips east: its up-dip edge lies 24.9 km west of the
    // centroid, its down-dip edge 24.9 km east. The hanging wall slides 10 m down-dip,
    // mostly eastwards: it pulls away from the up-dip edge (subsidence there) and pushes
    // into the rock beyond the down-dip edge (uplift there).
    assert!(lowest < -0.5 && lowest > -10.0, "uz minimum {lowest}");
    assert!(
        (-60e3..0.0).contains(&lowest_x) && lowest_y == 0.0,
        "minimum at ({lowest_x}, {lowest_y})"
    );
    assert!(
        highest > 0.0 && highest_x > 0.0,
        "uz maximum {highest} at x {highest_x}"
    );
    let (east_most, _, _) = extreme(&field.ux, false);
    assert!(
        east_most > 0.5 && east_most < 10.0,
        "ux maximum {east_most}"
    );
    // Pure dip slip on a fault centred on y = 0 along north: mirror symmetry in y.
    for j in 0..n {
        for i in 0..n {
            let (here, mirror) = (j * n + i, (n - 1 - j) * n + i);
            let scale = 1e-12 * lowest.abs();
            assert!((field.uz[here] - field.uz[mirror]).abs() <= scale);
            assert!((field.ux[here] - field.ux[mirror]).abs() <= scale);
            assert!((field.uy[here] + field.uy[mirror]).abs() <= scale);
        }
    }
}

#[test]
fn surface_field_matches_pointwise_values() {
    let segments = [
        FaultSegment::paper_case_ii(),
        FaultSegment {
            x_m: 80e3,
            strike_deg: 45.0,
            rake_deg: 30.0,
            ..FaultSegment::paper_case_ii()
        },
    ];
    let field = surface_field(&segments, &Elastic::default(), 400e3, 9, &mut |_| Ok(())).unwrap();
    assert_eq!((field.nx(), field.ny(), field.uz.len()), (9, 9, 81));
    assert_eq!((field.x[0], field.x[8], field.y[4]), (-200e3, 200e3, 0.0));
    for (j, &y) in field.y.iter().enumerate() {
        for (i, &x) in field.x.iter().enumerate() {
            let u = at(&segments, x, y, 0.0);
            let index = j * 9 + i;
            assert_eq!([field.ux[index], field.uy[index], field.uz[index]], u);
        }
    }
    assert!(surface_field(&segments, &Elastic::default(), 0.0, 9, &mut |_| Ok(())).is_err());
    assert!(surface_field(&segments, &Elastic::default(), 1e3, 1, &mut |_| Ok(())).is_err());
}

/// The grid is computed in bands of rows with the progress reported after each: every node of
/// a grid whose side is no multiple of the band still equals the point solution, the reported
/// fractions rise to 1, and a progress that fails (a deadline) stops the grid there.
#[test]
fn a_grid_reports_progress_by_bands_and_stops_when_told() {
    let segments = [FaultSegment::paper_case_ii()];
    let n = 70;
    let mut seen = Vec::new();
    let field = surface_field(&segments, &Elastic::default(), 600e3, n, &mut |f| {
        seen.push(f);
        Ok(())
    })
    .unwrap();
    for (j, &y) in field.y.iter().enumerate() {
        for (i, &x) in field.x.iter().enumerate() {
            assert_eq!(field.uz[j * n + i], at(&segments, x, y, 0.0)[2]);
        }
    }
    assert_eq!(seen.len(), 24);
    assert!(seen.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(seen.last(), Some(&1.0));
    let mut calls = 0;
    let stopped = surface_field(&segments, &Elastic::default(), 600e3, n, &mut |_| {
        calls += 1;
        if calls == 3 {
            Err(crate::Error::invalid("timeout", "past the deadline"))
        } else {
            Ok(())
        }
    });
    assert!(stopped
        .unwrap_err()
        .to_string()
        .contains("past the deadline"));
    assert_eq!(calls, 3);
}

#[test]
fn elastic_constants() {
    assert_eq!(Elastic::default().alpha(), 2.0 / 3.0);
    let lame = Elastic::from_lame(30e9, 30e9).unwrap();
    assert!((lame.poisson() - 0.25).abs() < 1e-15);
    let soft = Elastic::from_lame(60e9, 30e9).unwrap();
    assert!((soft.poisson() - 1.0 / 3.0).abs() < 1e-15);
    assert!((soft.alpha() - 0.75).abs() < 1e-15);
    assert!(Elastic::from_poisson(0.6).is_err());
    assert!(Elastic::from_lame(1.0, 0.0).is_err());
    assert!(Elastic::from_lame(-1.0, 1.0).is_err());
}

#[test]
fn validate_names_field_and_range() {
    let message = |segment: FaultSegment| segment.validate().unwrap_err().to_string();
    let good = FaultSegment::paper_case_ii();
    assert!(good.validate().is_ok());
    assert!((good.top_depth_m() - (50e3 - 25e3 * 6f64.to_radians().sin())).abs() < 1e-9);
    let steep = message(FaultSegment {
        dip_deg: 95.0,
        ..good
    });
    assert!(
        steep.starts_with("dip_deg:") && steep.contains("[-90, 90]"),
        "{steep}"
    );
    let flat = message(FaultSegment {
        width_m: 0.0,
        ..good
    });
    assert!(
        flat.starts_with("width_m:") && flat.contains("> 0"),
        "{flat}"
    );
    let short = message(FaultSegment {
        length_m: -1.0,
        ..good
    });
    assert!(short.starts_with("length_m:"), "{short}");
    let missing = message(FaultSegment {
        slip_m: f64::NAN,
        ..good
    });
    assert!(
        missing.starts_with("slip_m:") && missing.contains("finite"),
        "{missing}"
    );
    let breaking = message(FaultSegment {
        depth_m: 2e3,
        ..good
    });
    assert!(
        breaking.starts_with("depth_m:") && breaking.contains("2613"),
        "{breaking}"
    );
    let at_surface = FaultSegment {
        depth_m: 0.0,
        depth_ref: DepthRef::Top,
        ..good
    };
    assert!(message(at_surface).starts_with("depth_m:"));
    let error =
        displacement_at(&[good, at_surface], &Elastic::default(), 0.0, 0.0, 0.0).unwrap_err();
    assert!(
        error.to_string().starts_with("segment 1 depth_m:"),
        "{error}"
    );
}

#[test]
fn parses_segment_tables() {
    let path = Path::new("faults.txt");
    let text = "# two segments of a normal fault\n\
                \n\
                slip_m strike_deg dip_deg rake_deg length_m width_m depth_m x_m y_m opening_m depth_ref\n\
                10 0 6 -90 100e3 50e3 50e3 0 0 0 centroid   # case II\n\
                2.5 45 60 180 20e3 10e3 1e3 -5e3 7e3 0.1 TOP\n";
    let segments = parse_segment_table(text, path).unwrap();
    assert_eq!(segments.len(), 2);
    assert_eq!(segments[0], FaultSegment::paper_case_ii());
    let second = segments[1];
    assert_eq!(
        (
            second.slip_m,
            second.strike_deg,
            second.dip_deg,
            second.rake_deg,
            second.x_m,
            second.y_m
        ),
        (2.5, 45.0, 60.0, 180.0, -5e3, 7e3)
    );
    assert_eq!((second.opening_m, second.depth_ref), (0.1, DepthRef::Top));

    let minimal = "x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m\n0 0 5e3 10 80 0 4e3 2e3 1\n";
    let parsed = parse_segment_table(minimal, path).unwrap();
    assert_eq!(
        (parsed[0].opening_m, parsed[0].depth_ref),
        (0.0, DepthRef::Centroid)
    );
}

#[test]
fn segment_table_errors_name_path_line_and_column() {
    let path = Path::new("dir/faults.txt");
    let header = "x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m\n";
    let error = |text: &str| parse_segment_table(text, path).unwrap_err().to_string();

    let bad_number = error(&format!(
        "{header}# comment\n0 0 5e3 10 eighty 0 4e3 2e3 1\n"
    ));
    assert_eq!(
        bad_number,
        "dir/faults.txt: line 3, column 5 (dip_deg): expected a number, found 'eighty'"
    );
    let out_of_range = error(&format!("{header}0 0 5e3 10 95 0 4e3 2e3 1\n"));
    assert!(
        out_of_range
            .starts_with("dir/faults.txt: line 2, column 5 (dip_deg): must lie in [-90, 90]"),
        "{out_of_range}"
    );
    let too_shallow = error(&format!("{header}0 0 5e2 10 80 0 4e3 2e3 1\n"));
    assert!(
        too_shallow.starts_with("dir/faults.txt: line 2, column 3 (depth_m):"),
        "{too_shallow}"
    );
    let short_row = error(&format!("{header}0 0 5e3 10 80\n"));
    assert!(
        short_row.contains("line 2: expected 9 values"),
        "{short_row}"
    );
    let unknown = error("x_m y_m depth_km\n");
    assert!(
        unknown.contains("line 1, column 3: unknown column 'depth_km'"),
        "{unknown}"
    );
    let missing = error("x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m\n");
    assert!(
        missing.contains("lacks the required column 'slip_m'"),
        "{missing}"
    );
    let twice = error("x_m x_m\n");
    assert!(
        twice.contains("column 2: column 'x_m' appears twice"),
        "{twice}"
    );
    assert!(error("# nothing\n").contains("no header line"));
    assert!(error(header).contains("no fault segments"));
    let bad_ref = error("x_m y_m depth_m strike_deg dip_deg rake_deg length_m width_m slip_m depth_ref\n0 0 5e3 10 80 0 4e3 2e3 1 middle\n");
    assert!(
        bad_ref.contains("line 2, column 10 (depth_ref): expected top, centroid or bottom"),
        "{bad_ref}"
    );
}
