//! Reference values are the closed forms of linear shallow-water theory: c = sqrt(g h), the
//! Hankel-transform solution for a 2-D Gaussian, Lamb's step transmission T = 2 c1 / (c1 + c2),
//! Green's law and Merian's seiche periods.

use super::bathymetry::degree_spacing_to_metres;
use super::*;

const G: f64 = 9.81;

fn flat(nx: usize, ny: usize, spacing_m: f64, depth_m: f64) -> Bathymetry {
    Bathymetry {
        nx,
        ny,
        dx_m: spacing_m,
        dy_m: spacing_m,
        depth_m: vec![depth_m; nx * ny],
    }
}

fn options(duration_s: f64, boundary: Boundary) -> TsunamiOptions {
    TsunamiOptions {
        duration_s,
        boundary,
        ..TsunamiOptions::default()
    }
}

fn run(bathy: &Bathymetry, eta0: &[f64], opts: &TsunamiOptions) -> TsunamiResult {
    simulate(bathy, eta0, opts, &mut |_| Ok(())).expect("valid run")
}

/// Gaussian hump of amplitude `amplitude`, replicated over every row, centred at `centre_m`.
fn hump_1d(bathy: &Bathymetry, centre_m: f64, sigma_m: f64, amplitude: f64) -> Vec<f64> {
    (0..bathy.nx * bathy.ny)
        .map(|k| {
            let x = ((k % bathy.nx) as f64 + 0.5) * bathy.dx_m;
            amplitude * (-(x - centre_m).powi(2) / (2.0 * sigma_m * sigma_m)).exp()
        })
        .collect()
}

/// Position of the largest value of `row` within cells `range`, refined by a parabola
/// through the maximum and its two neighbours.
fn peak_position_m(row: &[f64], range: std::ops::Range<usize>, dx: f64) -> f64 {
    let k = range
        .clone()
        .max_by(|&a, &b| row[a].total_cmp(&row[b]))
        .unwrap();
    let (left, mid, right) = (row[k - 1], row[k], row[k + 1]);
    let shift = 0.5 * (left - right) / (left - 2.0 * mid + right);
    (k as f64 + 0.5 + shift) * dx
}

#[test]
fn hump_splits_into_halves_travelling_at_the_long_wave_speed() {
    // validation.md case 1: c = sqrt(g h) = 198.091 m/s for h = 4000 m.
    let c = (G * 4000.0_f64).sqrt();
    assert!((c - 198.091).abs() < 1e-3);
    let dx = 2000.0;
    let bathy = flat(500, 3, dx, 4000.0);
    let centre = 500_000.0;
    let eta0 = hump_1d(&bathy, centre, 20_000.0, 1.0);
    let positions = [600.0, 1500.0].map(|t| {
        let result = run(&bathy, &eta0, &options(t, Boundary::Reflective));
        let row = &result.final_eta[bathy.nx..2 * bathy.nx];
        let right = peak_position_m(row, 251..499, dx) - centre;
        let left = centre - peak_position_m(row, 1..249, dx);
        // Each half carries half the initial amplitude.
        assert!((row.iter().cloned().fold(0.0, f64::max) - 0.5).abs() < 0.01);
        (right, left)
    });
    let speed_right = (positions[1].0 - positions[0].0) / 900.0;
    let speed_left = (positions[1].1 - positions[0].1) / 900.0;
    for speed in [speed_right, speed_left] {
        assert!((speed / c - 1.0).abs() < 0.01, "speed {speed} m/s vs {c}");
    }
}

#[test]
fn arrival_times_advance_at_the_long_wave_speed() {
    let c = (G * 4000.0_f64).sqrt();
    let dx = 1000.0;
    let bathy = flat(800, 1, dx, 4000.0);
    let eta0 = hump_1d(&bathy, 100_000.0, 20_000.0, 1.0);
    let result = run(&bathy, &eta0, &options(1800.0, Boundary::Reflective));
    let near = result.arrival_time_s[300];
    let far = result.arrival_time_s[500];
    let expected = 200_000.0 / c;
    assert!(((far - near) / expected - 1.0).abs() < 0.01, "{near} {far}");
    // Cells the wave has not reached report NaN; the hump itself arrives at t = 0.
    assert!(result.arrival_time_s[799].is_nan());
    assert_eq!(result.arrival_time_s[100], 0.0);
}

/// eta at the centre and 200 km east of it for the 2-D Gaussian on a grid of spacing `dx`.
fn gaussian_2d(dx: f64, time_s: f64, offset_cells: usize) -> f64 {
    let half_width = 280_000.0;
    let half = (half_width / dx).round() as usize;
    let n = 2 * half + 1;
    let bathy = flat(n, n, dx, 4000.0);
    let sigma = 20_000.0;
    let eta0: Vec<f64> = (0..n * n)
        .map(|k| {
            let x = (k % n) as f64 - half as f64;
            let y = (k / n) as f64 - half as f64;
            let r2 = (x * x + y * y) * dx * dx;
            (-r2 / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let result = run(&bathy, &eta0, &options(time_s, Boundary::Open));
    let centre = half * n + half;
    let e = &result.final_eta;
    let k = offset_cells;
    0.25 * (e[centre + k] + e[centre - k] + e[centre + k * n] + e[centre - k * n])
}

#[test]
fn radial_gaussian_matches_the_hankel_solution_with_second_order_convergence() {
    // validation.md case 2: A = 1 m, sigma = 20 km, h = 4000 m.
    let at_centre = -0.183693;
    let at_200_km = 0.089639;
    let t_front = 200_000.0 / (G * 4000.0_f64).sqrt();
    assert!((t_front - 1009.64).abs() < 0.01);
    let spacings = [4000.0, 2000.0, 1000.0];
    let errors: Vec<f64> = spacings
        .iter()
        .map(|&dx| {
            let centre = gaussian_2d(dx, 300.0, 0);
            let ring = gaussian_2d(dx, t_front, (200_000.0 / dx) as usize);
            eprintln!("dx {dx}: eta(0, 300 s) = {centre:.6}, eta(200 km, front) = {ring:.6}");
            if dx <= 2000.0 {
                assert!((centre / at_centre - 1.0).abs() < 0.02, "{centre}");
                assert!((ring / at_200_km - 1.0).abs() < 0.02, "{ring}");
            }
            (centre - at_centre).abs() + (ring - at_200_km).abs()
        })
        .collect();
    for pair in errors.windows(2) {
        let order = (pair[0] / pair[1]).log2();
        eprintln!("errors {pair:?}: observed order {order:.3}");
        assert!(order > 1.6, "observed order {order}");
    }
}

fn uneven_basin() -> (Bathymetry, Vec<f64>) {
    let (nx, ny) = (60, 40);
    let mut bathy = flat(nx, ny, 5000.0, 0.0);
    for j in 0..ny {
        for i in 0..nx {
            let (u, v) = (i as f64 / nx as f64, j as f64 / ny as f64);
            let island = (u - 0.6).powi(2) + (v - 0.5).powi(2) < 0.01;
            bathy.depth_m[j * nx + i] = if island {
                -30.0
            } else {
                50.0 + 3000.0 * u * (1.0 + (6.0 * v).sin()).max(0.1)
            };
        }
    }
    let eta0 = (0..nx * ny)
        .map(|k| {
            let (i, j) = ((k % nx) as f64, (k / nx) as f64);
            2.0 * (-((i - 20.0).powi(2) + (j - 15.0).powi(2)) / 18.0).exp()
        })
        .collect();
    (bathy, eta0)
}

#[test]
fn reflective_basin_conserves_volume_to_rounding() {
    // validation.md case 1: the flux form conserves mass exactly.
    let (bathy, eta0) = uneven_basin();
    let volume = |eta: &[f64]| {
        eta.iter()
            .zip(&bathy.depth_m)
            .filter(|(_, &d)| d > 0.0)
            .map(|(e, _)| e * bathy.dx_m * bathy.dy_m)
            .sum::<f64>()
    };
    let initial = volume(&eta0);
    for nonlinear in [false, true] {
        let opts = TsunamiOptions {
            nonlinear,
            ..options(3000.0, Boundary::Reflective)
        };
        let result = run(&bathy, &eta0, &opts);
        assert!(result.steps > 200);
        let drift = (volume(&result.final_eta) - initial).abs() / initial;
        assert!(
            drift < 1e-12,
            "nonlinear {nonlinear}: relative drift {drift:e}"
        );
        // The wave has actually moved.
        assert!(result.final_eta[15 * 60 + 20] < 1.0);
    }
}

#[test]
fn open_edges_let_the_wave_leave() {
    let n = 101;
    let bathy = flat(n, n, 2000.0, 4000.0);
    let eta0: Vec<f64> = (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f64 - 50.0, (k / n) as f64 - 50.0);
            (-(x * x + y * y) * 4.0e6 / (2.0 * 4.0e8)).exp()
        })
        .collect();
    let left_over = |boundary| {
        let result = run(&bathy, &eta0, &options(2000.0, boundary));
        result.final_eta.iter().fold(0.0_f64, |m, e| m.max(e.abs()))
    };
    let open = left_over(Boundary::Open);
    let closed = left_over(Boundary::Reflective);
    eprintln!("largest |eta| left after 2000 s: open {open}, reflective {closed}");
    assert!(open < 0.03, "{open}");
    assert!(closed > 0.1, "{closed}");
}

#[test]
fn step_shelf_transmits_lambs_amplitude() {
    // validation.md case 3: T = 2 c1 / (c1 + c2) = 1.63451 for 4000 m -> 200 m.
    let (c1, c2) = ((G * 4000.0_f64).sqrt(), (G * 200.0_f64).sqrt());
    let transmission = 2.0 * c1 / (c1 + c2);
    assert!((transmission - 1.63451).abs() < 1e-5);
    let dx = 500.0;
    let nx = 1100;
    let step = 800; // cells, 400 km
    let mut bathy = flat(nx, 1, dx, 4000.0);
    bathy.depth_m[step..].fill(200.0);
    // The right-going half of the split hump (amplitude 0.5) is the incident wave.
    let eta0 = hump_1d(&bathy, 200_000.0, 20_000.0, 1.0);
    let result = run(&bathy, &eta0, &options(2000.0, Boundary::Reflective));
    let on_shelf = result.final_eta[step + 20..]
        .iter()
        .fold(0.0_f64, |m, &e| m.max(e));
    let measured = on_shelf / 0.5;
    eprintln!("step shelf transmission {measured:.5} vs {transmission:.5}");
    assert!((measured / transmission - 1.0).abs() < 0.02);
}

#[test]
fn gentle_slope_follows_greens_law() {
    // validation.md case 4: A2 / A1 = (h1 / h2)^(1/4) = 2.11474 for 4000 m -> 200 m.
    let greens = (4000.0_f64 / 200.0).powf(0.25);
    assert!((greens - 2.11474).abs() < 1e-5);
    let dx = 250.0;
    let (deep_end, slope_end, nx) = (1200, 2800, 3200); // 300 km, 700 km, 800 km
    let mut bathy = flat(nx, 1, dx, 4000.0);
    for i in deep_end..nx {
        let s = ((i - deep_end) as f64 / (slope_end - deep_end) as f64).min(1.0);
        bathy.depth_m[i] = 4000.0 + (200.0 - 4000.0) * s;
    }
    let eta0 = hump_1d(&bathy, 150_000.0, 10_000.0, 1.0);
    let c_deep = (G * 4000.0_f64).sqrt();
    // Travel time to the foot of the slope: flat part, then integral of dx / sqrt(g h) on
    // the linear slope, 2 L / (sqrt(g) (sqrt(h1) + sqrt(h2))).
    let slope_length = (slope_end - deep_end) as f64 * dx;
    let t_slope = 2.0 * slope_length / (G.sqrt() * (4000.0_f64.sqrt() + 200.0_f64.sqrt()));
    let duration = 150_000.0 / c_deep + t_slope + 200.0;
    let result = run(&bathy, &eta0, &options(duration, Boundary::Reflective));
    let at_foot = result.max_abs_eta[slope_end - 4..slope_end + 4]
        .iter()
        .fold(0.0_f64, |m, &e| m.max(e));
    let measured = at_foot / 0.5;
    eprintln!("Green's law ratio {measured:.5} vs {greens:.5}");
    assert!((measured / greens - 1.0).abs() < 0.05);
}

#[test]
fn closed_basin_seiches_with_merians_period() {
    // validation.md case 5: T_n = 2 L / (n sqrt(g h)).
    let (nx, dx, h) = (100, 1000.0, 50.0);
    let length = nx as f64 * dx;
    let bathy = flat(nx, 1, dx, h);
    for mode in [1.0, 2.0] {
        let period = 2.0 * length / (mode * (G * h).sqrt());
        let eta0: Vec<f64> = (0..nx)
            .map(|i| (mode * std::f64::consts::PI * (i as f64 + 0.5) / nx as f64).cos())
            .collect();
        let half = run(&bathy, &eta0, &options(0.5 * period, Boundary::Reflective));
        let full = run(&bathy, &eta0, &options(period, Boundary::Reflective));
        for ((e0, e_half), e_full) in eta0.iter().zip(&half.final_eta).zip(&full.final_eta) {
            assert!(
                (e_half + e0).abs() < 0.005,
                "mode {mode}: {e_half} vs {}",
                -e0
            );
            assert!((e_full - e0).abs() < 0.005, "mode {mode}: {e_full} vs {e0}");
        }
    }
}

#[test]
fn nonlinear_terms_vanish_for_small_waves_and_friction_damps() {
    let bathy = flat(400, 1, 1000.0, 50.0);
    let eta0 = hump_1d(&bathy, 100_000.0, 10_000.0, 0.01);
    let linear = run(&bathy, &eta0, &options(2000.0, Boundary::Reflective));
    let smooth = TsunamiOptions {
        nonlinear: true,
        manning_n: 0.0,
        ..options(2000.0, Boundary::Reflective)
    };
    let nonlinear = run(&bathy, &eta0, &smooth);
    let largest_difference = linear
        .final_eta
        .iter()
        .zip(&nonlinear.final_eta)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(largest_difference < 1e-3 * 0.01, "{largest_difference}");

    // Manning friction decelerates by g n^2 u^2 / h^(4/3): here (u ~ 0.25 m/s, h = 10 m)
    // that removes some 20 % of the speed within 2000 s.
    let shallow = flat(200, 1, 500.0, 10.0);
    let big = hump_1d(&shallow, 50_000.0, 5_000.0, 1.0);
    let rough = TsunamiOptions {
        manning_n: 0.03,
        ..smooth.clone()
    };
    let peak = |opts: &TsunamiOptions| {
        run(&shallow, &big, opts)
            .final_eta
            .iter()
            .fold(0.0_f64, |m, &e| m.max(e))
    };
    let (frictionless, damped) = (peak(&smooth), peak(&rough));
    assert!(
        frictionless > 0.4 && damped < 0.9 * frictionless,
        "{frictionless} {damped}"
    );
}

#[test]
fn bad_input_is_rejected_with_the_field_named() {
    let bathy = flat(20, 10, 1000.0, 4000.0);
    let eta0 = vec![0.0; 200];
    let limit = bathy.cfl_limit_s(G);
    assert!((limit - 1000.0 / (2.0 * G * 4000.0_f64).sqrt()).abs() < 1e-12);
    let field = |result: Result<TsunamiResult>| match result {
        Err(Error::Invalid { field, msg }) => (field, msg),
        other => panic!("expected an invalid-parameter error, got {other:?}"),
    };
    let too_long = TsunamiOptions {
        dt_s: Some(1.01 * limit),
        ..options(100.0, Boundary::Open)
    };
    let (name, msg) = field(simulate(&bathy, &eta0, &too_long, &mut |_| Ok(())));
    assert_eq!(name, "dt");
    assert!(msg.contains(&format!("{limit:.6}")), "{msg}");
    let at_limit = TsunamiOptions {
        dt_s: Some(limit),
        ..too_long.clone()
    };
    assert!(simulate(&bathy, &eta0, &at_limit, &mut |_| Ok(())).is_ok());

    let short = vec![0.0; 199];
    let opts = options(100.0, Boundary::Open);
    assert_eq!(
        field(simulate(&bathy, &short, &opts, &mut |_| Ok(()))).0,
        "eta0"
    );
    let mut nan_eta = eta0.clone();
    nan_eta[3] = f64::INFINITY;
    assert_eq!(
        field(simulate(&bathy, &nan_eta, &opts, &mut |_| Ok(()))).0,
        "eta0"
    );
    let mut holed = bathy.clone();
    holed.depth_m[7] = f64::NAN;
    assert_eq!(
        field(simulate(&holed, &eta0, &opts, &mut |_| Ok(()))).0,
        "depth_m"
    );
    let mut short_depth = bathy.clone();
    short_depth.depth_m.pop();
    assert_eq!(
        field(simulate(&short_depth, &eta0, &opts, &mut |_| Ok(()))).0,
        "depth_m"
    );
    let dry = flat(20, 10, 1000.0, -5.0);
    assert_eq!(
        field(simulate(&dry, &eta0, &opts, &mut |_| Ok(()))).0,
        "depth_m"
    );
    for (name, bad) in [
        ("duration_s", options(0.0, Boundary::Open)),
        ("duration_s", options(f64::NAN, Boundary::Open)),
        (
            "g",
            TsunamiOptions {
                g: -1.0,
                ..opts.clone()
            },
        ),
        (
            "manning_n",
            TsunamiOptions {
                manning_n: -0.1,
                ..opts.clone()
            },
        ),
        (
            "dt",
            TsunamiOptions {
                dt_s: Some(0.0),
                ..opts.clone()
            },
        ),
    ] {
        assert_eq!(
            field(simulate(&bathy, &eta0, &bad, &mut |_| Ok(()))).0,
            name
        );
    }
}

#[test]
fn progress_reaches_one_and_the_step_ends_on_the_duration() {
    let bathy = flat(10, 10, 1000.0, 100.0);
    let mut reports = Vec::new();
    let opts = TsunamiOptions {
        dt_s: Some(7.0),
        ..options(100.0, Boundary::Open)
    };
    let result = simulate(&bathy, &[0.0; 100], &opts, &mut |f| {
        reports.push(f);
        Ok(())
    })
    .unwrap();
    assert_eq!(result.steps, 15);
    assert!((result.dt_s * 15.0 - 100.0).abs() < 1e-12);
    assert_eq!(reports.last(), Some(&1.0));
    assert!(reports.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn elevation_grids_become_depths_and_degrees_become_metres() {
    let bathy = bathymetry_from_elevation(&[120.0, -35.0, 0.0, -4000.0], 2, 2, 10.0, 20.0).unwrap();
    assert_eq!(bathy.depth_m, vec![-120.0, 35.0, -0.0, 4000.0]);
    assert!(bathymetry_from_elevation(&[1.0, f64::NAN], 2, 1, 1.0, 1.0).is_err());
    assert!(bathymetry_from_elevation(&[1.0, 2.0], 3, 1, 1.0, 1.0).is_err());

    // One degree of a great circle on a 6371 km sphere is 111.19493 km.
    let (dx, dy) = degree_spacing_to_metres(1.0, 1.0, 60.0).unwrap();
    assert!((dy - 111_194.93).abs() < 0.01, "{dy}");
    assert!((dx - 0.5 * 111_194.93).abs() < 0.01, "{dx}");
    assert!(degree_spacing_to_metres(1.0, 1.0, 90.0).is_err());

    let longitude: Vec<f64> = (0..5).map(|k| -126.0 + 0.5 * k as f64).collect();
    let latitude: Vec<f64> = (0..3).map(|k| 50.0 - 1.0 * k as f64).collect();
    let (dx, dy) = grid_spacing_from_lonlat(&longitude, &latitude).unwrap();
    assert!((dy - 111_194.93).abs() < 0.01);
    assert!((dx - 0.5 * 111_194.93 * 49.0_f64.to_radians().cos()).abs() < 0.01);
    assert!(grid_spacing_from_lonlat(&[1.0, 2.0, 4.0], &latitude).is_err());
}

#[test]
fn synthetic_basin_has_shelves_plain_trench_and_a_source_over_the_trench() {
    let n = 200;
    let bathy = synthetic_south_china_sea(n, SOUTH_CHINA_SEA_EXTENT_M);
    bathy.validate().unwrap();
    let count = |pred: &dyn Fn(f64) -> bool| bathy.depth_m.iter().filter(|&&d| pred(d)).count();
    let cells = (n * n) as f64;
    let land = count(&|d| d <= 0.0) as f64 / cells;
    let shelf = count(&|d| d > 0.0 && d <= 200.0) as f64 / cells;
    let plain = count(&|d| (3700.0..=4300.0).contains(&d)) as f64 / cells;
    assert!((0.1..0.5).contains(&land), "land {land}");
    assert!(shelf > 0.05, "shelf {shelf}");
    assert!(plain > 0.2, "plain {plain}");
    assert!(bathy.max_depth_m() > 5000.0);

    let source = manila_trench_source();
    assert_eq!(
        (source.strike_deg, source.dip_deg, source.rake_deg),
        (350.0, 20.0, 90.0)
    );
    assert!((source.top_depth_m() - 5000.0).abs() < 1e-9);
    let cell = |x: f64, y: f64| {
        let d = SOUTH_CHINA_SEA_EXTENT_M / n as f64;
        bathy.depth_m[(y / d) as usize * n + (x / d) as usize]
    };
    // The trench axis lies up dip of the plane's centre, deeper than the plain.
    let back = 0.5 * source.width_m * source.dip_deg.to_radians().cos();
    let azimuth = (source.strike_deg + 90.0).to_radians();
    let axis = (
        source.x_m - back * azimuth.sin(),
        source.y_m - back * azimuth.cos(),
    );
    assert!(cell(axis.0, axis.1) > 5000.0, "{}", cell(axis.0, axis.1));
    // The centre lies under the forearc slope, still well offshore.
    assert!(cell(source.x_m, source.y_m) > 1000.0);

    // A short run from an uplift over the source stays finite and spreads.
    let small = synthetic_south_china_sea(100, SOUTH_CHINA_SEA_EXTENT_M);
    let d = small.dx_m;
    let eta0: Vec<f64> = (0..100 * 100)
        .map(|k| {
            let x = ((k % 100) as f64 + 0.5) * d - source.x_m;
            let y = ((k / 100) as f64 + 0.5) * d - source.y_m;
            (-(x * x + y * y) / (2.0 * 4.0e4_f64.powi(2))).exp()
        })
        .collect();
    let result = run(&small, &eta0, &options(1200.0, Boundary::Open));
    assert!(result.final_eta.iter().all(|e| e.is_finite()));
    let reached = result
        .arrival_time_s
        .iter()
        .filter(|t| t.is_finite())
        .count();
    assert!(reached > 200, "{reached}");
    assert!(result
        .final_eta
        .iter()
        .zip(&small.depth_m)
        .all(|(&e, &h)| h > 0.0 || e == 0.0));
}
