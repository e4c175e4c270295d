//! Log–log scatter charts for benchmark reports (error against time), drawn with `plotters` into
//! an RGB buffer and written as PNG. Text uses DejaVu Sans, embedded by the `dejavu` crate,
//! registered with plotters' pure-Rust `ab_glyph` backend, so no system font or C library is needed.

use crate::error::{Error, Result};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// One named group of points, each with a label drawn beside it.
pub(crate) struct Series {
    pub name: String,
    /// (x, y, label); points with a non-positive or non-finite coordinate cannot sit on log
    /// axes and are left out.
    pub points: Vec<(f64, f64, String)>,
}

const FONT: &str = "hdrvis-sans";

fn register_font() -> Result<()> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            "chart",
            "the embedded chart font failed to load",
        ))
    }
}

fn plot_err(e: impl std::fmt::Display) -> Error {
    Error::invalid("chart", format!("drawing failed: {e}"))
}

/// Draws `series` on log–log axes and returns the RGB8 pixels (row-major, `width`×`height`).
pub(crate) fn log_log_chart(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
    width: u32,
    height: u32,
) -> Result<Vec<u8>> {
    register_font()?;
    let usable = |x: f64, y: f64| x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0;
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| (p.0, p.1)))
        .filter(|&(x, y)| usable(x, y))
        .collect();
    if pts.is_empty() {
        return Err(Error::invalid(
            "chart",
            "no point with a positive time and error to draw",
        ));
    }
    let (x0, x1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.0), hi.max(p.0))
    });
    let (y0, y1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.1), hi.max(p.1))
    });
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, (FONT, 20))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(
                // Room on the right for the labels of the slowest points.
                ((x0 / 2.0)..(x1 * 6.0)).log_scale(),
                ((y0 / 10.0)..(y1 * 10.0)).log_scale(),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .label_style((FONT, 14))
            .x_label_formatter(&|v| {
                if *v >= 10.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v:.2}")
                }
            })
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(plot_err)?;
        for (i, s) in series.iter().enumerate() {
            let colour = Palette99::pick(i).to_rgba();
            let points: Vec<_> = s
                .points
                .iter()
                .filter(|p| usable(p.0, p.1))
                .cloned()
                .collect();
            chart
                .draw_series(
                    points
                        .iter()
                        .map(|p| Circle::new((p.0, p.1), 5, colour.filled())),
                )
                .map_err(plot_err)?
                .label(s.name.clone())
                .legend(move |(x, y)| Circle::new((x, y), 5, colour.filled()));
            chart
                .draw_series(points.iter().map(|p| {
                    Text::new(
                        format!(" {}", p.2),
                        (p.0, p.1),
                        (FONT, 13).into_font().color(&BLACK),
                    )
                }))
                .map_err(plot_err)?;
        }
        chart
            .configure_series_labels()
            .label_font((FONT, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(buf)
}

/// Writes RGB8 pixels as a PNG (atomically).
pub(crate) fn write_rgb_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<()> {
    crate::io::write_atomic(path, |w| {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(w)
            .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
            .map_err(|e| Error::format(path, format!("cannot encode PNG: {e}")))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_land_where_log_axes_put_them() {
        // Two series far apart: the left-bottom and right-top quarters of the plot get ink of
        // different colours, the empty quarters only grid lines.
        let series = vec![
            Series {
                name: "a".into(),
                points: vec![(1.0, 1e-6, "fast".into())],
            },
            Series {
                name: "b".into(),
                points: vec![(100.0, 1e-1, "slow".into()), (0.0, 1.0, "dropped".into())],
            },
        ];
        let (w, h) = (400u32, 300u32);
        let rgb = log_log_chart("t", "ms", "err", &series, w, h).unwrap();
        assert_eq!(rgb.len(), (w * h * 3) as usize);
        let colour_at = |c: [u8; 3], x0: u32, x1: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let i = ((y * w + x) * 3) as usize;
                    rgb[i..i + 3] == c
                })
                .count()
        };
        let a = Palette99::pick(0).to_rgba();
        let b = Palette99::pick(1).to_rgba();
        let (ca, cb) = ([a.0, a.1, a.2], [b.0, b.1, b.2]);
        assert!(
            colour_at(ca, 0, w / 2, h / 2, h) > 20,
            "series a bottom-left"
        );
        assert!(colour_at(cb, w / 2, w, 0, h / 2) > 20, "series b top-right");
        assert_eq!(colour_at(ca, w / 2, w - 120, h / 2, h), 0);
    }

    #[test]
    fn nothing_to_draw_is_an_error() {
        let s = vec![Series {
            name: "x".into(),
            points: vec![(1.0, 0.0, "exact".into())],
        }];
        assert!(log_log_chart("t", "x", "y", &s, 100, 100).is_err());
    }
}
