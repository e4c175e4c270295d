//! Figures: colour ranges on surfaces (`domain`, `centre`, the colour bar's extend triangles),
//! checked pixel by pixel against the colour maps themselves.

use crate::common::{at_nodes, backends, renderer};
use hdrvis::model::colormap::srgb_to_linear;
use hdrvis::model::{Grid, HdrImage};
use hdrvis::render::surface::{legend, FringeMode, SurfaceOptions, SurfaceRenderer};

fn direct(colormap: &str) -> SurfaceOptions {
    SurfaceOptions {
        mode: FringeMode::Direct,
        colormap: Some(colormap.into()),
        ..Default::default()
    }
}

/// A colour map's linear colour at t, straight from `colorgrad` (the maps' source).
fn reference(map: impl colorgrad::Gradient, t: f64) -> [f32; 3] {
    let c = map.at(t as f32);
    [c.r, c.g, c.b].map(|v| srgb_to_linear(v.clamp(0.0, 1.0) as f64) as f32)
}

/// Map view at one pixel per node: row r shows grid row ny − 1 − r; one row suffices here.
fn pixel(img: &HdrImage, i: usize) -> [f32; 4] {
    img.pixels[i]
}

fn close(a: [f32; 4], b: [f32; 3], tol: f32) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
}

/// With a domain, a field and the same field with its lower half missing give one value one
/// colour (without a domain they do not: the range moved); values beyond the domain take the end
/// colours.
#[test]
fn a_domain_gives_one_value_one_colour_whatever_is_missing() {
    let (nx, ny) = (64usize, 4usize);
    let d = |i: usize| -3.0 + 6.0 * i as f64 / (nx - 1) as f64;
    let whole = Grid::from_fn("d", nx, ny, |i, _| d(i)).unwrap();
    let part = Grid::from_fn("d", nx, ny, |i, _| if i < 24 { f64::NAN } else { d(i) }).unwrap();
    let r = SurfaceRenderer::new(renderer(backends()[0]).context().clone());
    let fixed = SurfaceOptions {
        domain: Some((-2.0, 2.0)),
        ..direct("viridis")
    };
    let a = r
        .render(&whole, &at_nodes(&whole, &fixed))
        .unwrap()
        .remove(0);
    let b = r.render(&part, &at_nodes(&part, &fixed)).unwrap().remove(0);
    for i in 24..nx {
        let (p, q) = (pixel(&a, i), pixel(&b, i));
        assert!(close(p, [q[0], q[1], q[2]], 1e-6), "{i}: {p:?} {q:?}");
        // The colour is the map's at (d − lo) / (hi − lo), clipped to [0, 1].
        let t = ((d(i) + 2.0) / 4.0).clamp(0.0, 1.0);
        let expect = reference(colorgrad::preset::viridis(), t);
        assert!(close(p, expect, 2e-3), "{i}: {p:?} {expect:?}");
    }
    let free_a = r
        .render(&whole, &at_nodes(&whole, &direct("viridis")))
        .unwrap()
        .remove(0);
    let free_b = r
        .render(&part, &at_nodes(&part, &direct("viridis")))
        .unwrap()
        .remove(0);
    let (p, q) = (pixel(&free_a, 40), pixel(&free_b, 40));
    assert!(!close(p, [q[0], q[1], q[2]], 1e-2), "{p:?} {q:?}");
}

/// `centre: 0` puts the middle colour of a diverging map at 0 for data from −4 to 12: the range
/// becomes −12…12, which the recorded colour bar spans with no end clipped; with a domain of
/// [−2, 2] about the same centre both ends clip.
#[test]
fn centre_zero_puts_the_middle_colour_at_zero() {
    let nx = 65usize;
    let g = Grid::from_fn("v", nx, 2, |i, _| 0.25 * (i as f64 - 16.0)).unwrap();
    let r = SurfaceRenderer::new(renderer(backends()[0]).context().clone());
    let centred = SurfaceOptions {
        centre: Some(0.0),
        ..direct("rd_bu")
    };
    let img = r.render(&g, &at_nodes(&g, &centred)).unwrap().remove(0);
    let middle = reference(colorgrad::preset::rd_bu(), 0.5);
    assert!(
        close(pixel(&img, 16), middle, 2e-3),
        "{:?} {middle:?}",
        pixel(&img, 16)
    );
    // d = 12 at the right end is the map's high end; d = −4 sits at t = 8/24.
    let high = reference(colorgrad::preset::rd_bu(), 1.0);
    assert!(close(pixel(&img, 64), high, 2e-3));
    let t = reference(colorgrad::preset::rd_bu(), 8.0 / 24.0);
    assert!(close(pixel(&img, 0), t, 2e-3));
    assert_eq!(img.meta("legend_domain"), Some("-12 12"));
    assert_eq!(img.meta("legend_extend"), Some("neither"));
    let uncentred = r
        .render(&g, &at_nodes(&g, &direct("rd_bu")))
        .unwrap()
        .remove(0);
    assert!(!close(pixel(&uncentred, 16), middle, 2e-2));
    let clipped = SurfaceOptions {
        domain: Some((-2.0, 2.0)),
        centre: Some(0.0),
        ..direct("rd_bu")
    };
    let img = r.render(&g, &at_nodes(&g, &clipped)).unwrap().remove(0);
    assert_eq!(img.meta("legend_extend"), Some("both"));
    // The bar's ends are the domain itself (round, so its end ticks are drawn).
    assert_eq!(img.meta("legend_domain"), Some("-2 2"));
}

/// The legend's colour bar (that of `surface_colorbar`) has a triangle at each end that clips, in
/// the end colour, with clear corners beside it; none where the data stay inside.
#[test]
fn colour_bar_draws_extend_triangles_only_where_data_clip() {
    let g = Grid::from_fn("d", 32, 2, |i, _| -2.0 + 4.0 * i as f64 / 31.0).unwrap();
    let viridis = |t| reference(colorgrad::preset::viridis(), t);
    let bar_of = |domain: Option<(f64, f64)>| {
        let o = SurfaceOptions {
            domain,
            ..direct("viridis")
        };
        legend(&g, &o, 128).unwrap()
    };
    let at = |img: &HdrImage, x: u32, y: u32| img.pixels[(y * img.width + x) as usize];
    // 128 × 16 bar: triangles 16 long, apex at the bar's middle row.
    let both = bar_of(Some((-1.0, 1.0)));
    assert_eq!(both.meta("legend_extend"), Some("both"));
    assert!(close(at(&both, 8, 8), viridis(0.0), 1e-6));
    assert!(close(at(&both, 119, 8), viridis(1.0), 1e-6));
    for (x, y) in [(1, 0), (1, 15), (126, 0), (126, 15)] {
        assert_eq!(
            at(&both, x, y),
            [1.0, 1.0, 1.0, 1.0],
            "corner ({x}, {y}) left white"
        );
    }
    // The colours run over [16, 112): the first column at t = 0.5 / 96.
    assert!(close(at(&both, 16, 0), viridis(0.5 / 96.0), 2e-3));
    let high = bar_of(Some((-3.0, 1.0)));
    assert_eq!(high.meta("legend_extend"), Some("max"));
    assert!(close(at(&high, 0, 0), viridis(0.5 / 112.0), 2e-3));
    assert_eq!(at(&high, 126, 0), [1.0, 1.0, 1.0, 1.0]);
    let inside = bar_of(Some((-3.0, 3.0)));
    assert_eq!(inside.meta("legend_extend"), Some("neither"));
    assert!(close(at(&inside, 0, 0), viridis(0.5 / 128.0), 2e-3));
    assert!(close(at(&inside, 127, 15), viridis(127.5 / 128.0), 2e-3));
}

/// Bad ranges are one-line errors naming the option, and a script writes nothing.
#[test]
fn bad_colour_ranges_are_one_line_errors() {
    let g = Grid::from_fn("d", 8, 2, |i, _| i as f64 - 1.0).unwrap();
    let check = |o: SurfaceOptions, needle: &str| {
        let e = legend(&g, &o, 64).unwrap_err().to_string();
        assert!(e.contains(needle) && !e.contains('\n'), "{needle}: {e}");
    };
    for (lo, hi) in [
        (1.0, 1.0),
        (2.0, -2.0),
        (f64::NAN, 1.0),
        (0.0, f64::INFINITY),
    ] {
        let o = SurfaceOptions {
            domain: Some((lo, hi)),
            ..direct("viridis")
        };
        check(o, "domain: expected [lo, hi] with finite lo < hi");
    }
    let o = SurfaceOptions {
        centre: Some(9.0),
        ..direct("viridis")
    };
    check(o, "centre: 9 lies outside the data of \"d\" ([-1, 6])");
    let o = SurfaceOptions {
        centre: Some(f64::NAN),
        ..direct("viridis")
    };
    check(o, "centre: expected a finite value");
    let o = SurfaceOptions {
        domain: Some((-1.0, 1.0)),
        ..Default::default()
    };
    check(o, "domain: cyclic colours follow the fringe phase");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("g.rhai"),
        r#"let g = load_grid(generate("okada", #{ n: 9 }));
           save_png(render_surface(g, #{ mode: "direct", property: "uz", domain: [3, -3] }), "x.png");"#,
    )
    .unwrap();
    let (code, _, err) = crate::cli::hdrvis(&["run", "g.rhai"], dir.path());
    assert_ne!(code, 0);
    assert!(
        err.contains("domain: expected [lo, hi] with finite lo < hi, got [3, -3]"),
        "{err}"
    );
    assert!(!dir.path().join("out/x.png").exists());
}

/// A framed map carries the colour bar, the fringe legend with ν and a scale bar in km in one
/// PNG: `legend: false` leaves bar and fringe legend out (a narrower, shorter figure), a larger
/// `font_size` makes a larger one, and options that would draw nothing are refused.
#[test]
fn framed_map_carries_legend_scale_bar_and_title() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny) = (160usize, 80usize);
    let lon: Vec<f64> = (0..nx).map(|i| 140.0 + 0.05 * i as f64).collect();
    let lat: Vec<f64> = (0..ny).map(|j| 35.0 + 0.05 * j as f64).collect();
    let eta: Vec<f64> = (0..nx * ny).map(|k| 0.02 * (k % nx) as f64 - 1.0).collect();
    hdrvis::datasets::netcdf::write_grid::<f64>(
        dir.path().join("sea.nc"),
        &[
            ("lat", &lat, "degrees_north"),
            ("lon", &lon, "degrees_east"),
        ],
        &[("eta", &eta, "m", "wave height")],
        &[],
    )
    .unwrap();
    let script = r#"
        let img = render_surface(load_grid("sea.nc"), #{ nu: 4.0, mode: "modulated", domain: [-0.5, 0.5], centre: 0.0, colormap: "rd_bu_r" });
        save_png(img, "full.png", #{ frame: true, title: "Wave height" });
        save_png(img, "bare.png", #{ frame: true, legend: false });
        save_png(img, "big.png", #{ frame: true, font_size: 30 });
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, out, err) = crate::cli::hdrvis(&["run", "s.rhai"], dir.path());
    assert_eq!(code, 0, "{out}\n{err}");
    let open = |n: &str| {
        image::open(dir.path().join("out").join(n))
            .unwrap()
            .to_rgb8()
    };
    let (full, bare, big) = (open("full.png"), open("bare.png"), open("big.png"));
    // The bar and its labels widen the figure; the legend line, title and larger type heighten it.
    assert!(
        full.width() > bare.width() + 20,
        "{} {}",
        full.width(),
        bare.width()
    );
    assert!(
        full.height() > bare.height(),
        "{} {}",
        full.height(),
        bare.height()
    );
    assert!(big.height() > full.height() + 40 && big.width() > full.width());
    let e = |source: &str, needle: &str| {
        std::fs::write(dir.path().join("bad.rhai"), source).unwrap();
        let (code, _, err) = crate::cli::hdrvis(&["run", "bad.rhai"], dir.path());
        assert_ne!(code, 0);
        assert!(err.contains(needle), "{err}");
        assert!(!dir.path().join("out/bad.png").exists());
    };
    let render = r#"let img = render_surface(load_grid("sea.nc"), #{ nu: 4.0 });"#;
    e(
        &format!(r#"{render} save_png(img, "bad.png", #{{ title: "T" }});"#),
        "title: a title is drawn on framed maps",
    );
    e(
        &format!(r#"{render} save_png(img, "bad.png", #{{ font_size: 20 }});"#),
        "font_size: no text is drawn",
    );
    e(
        &format!(r#"{render} save_png(img, "bad.png", #{{ frame: true, font_size: 1000 }});"#),
        "font_size: 1000",
    );
    e(
        r#"render_surface(load_grid("sea.nc"), #{ mode: "direct", centre: 7.0 });"#,
        "centre: 7 lies outside the data of \"eta\"",
    );
}
