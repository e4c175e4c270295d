//! PNG display views of HDR images: a plain exposure (× 2^EV) followed by the sRGB curve, 8-bit
//! or 16-bit (`HdrImage::to_srgb8`, `HdrImage::to_srgb16`), composited over the image's own
//! background (colour is premultiplied, so RGB is final). Real tone-mapping operators feed the
//! same writer with display-referred values.

use crate::error::{Error, Result};
use crate::model::HdrImage;
use std::path::Path;

/// Whether the PNG of `image` keeps its alpha: images that mark missing data transparent
/// (metadata `missing = transparent`, as surface renders do) and have such pixels.
fn keeps_alpha(image: &HdrImage) -> bool {
    image.meta("missing") == Some("transparent") && image.pixels.iter().any(|p| p[3] < 1.0)
}

/// How hard a PNG's deflate works. `Fast` (what hdrvis writes unless asked) took 0.73 s for a
/// 4096² tone-mapped picture where `Default` took 3.4 s and `Best` 9.5 s, for files 1.7× and
/// 2.0× smaller (docs/performance.md). All are lossless.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PngCompression {
    Fast,
    Default,
    Best,
}

impl PngCompression {
    pub fn parse(name: &str) -> Result<PngCompression> {
        match name.to_ascii_lowercase().as_str() {
            "fast" => Ok(PngCompression::Fast),
            "default" => Ok(PngCompression::Default),
            "best" => Ok(PngCompression::Best),
            _ => Err(Error::invalid(
                "compression",
                format!("unknown PNG compression {name:?}; known: fast, default, best"),
            )),
        }
    }
}

/// Writes display-referred linear values (clamped to [0, 1]) as an sRGB PNG: RGB, or RGBA (alpha
/// linear, as PNG defines it) when the image marks missing data transparent and has some.
pub fn write_display_png(image: &HdrImage, path: &Path, sixteen_bit: bool) -> Result<()> {
    write_display_png_with(image, path, sixteen_bit, PngCompression::Fast)
}

/// [`write_display_png`] with a chosen compression effort.
pub fn write_display_png_with(
    image: &HdrImage,
    path: &Path,
    sixteen_bit: bool,
    compression: PngCompression,
) -> Result<()> {
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Err(Error::invalid("image", "cannot write an empty image"));
    }
    let alpha = keeps_alpha(image);
    crate::io::write_atomic(path, |writer| {
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        let effort = match compression {
            PngCompression::Fast => CompressionType::Fast,
            PngCompression::Default => CompressionType::Default,
            PngCompression::Best => CompressionType::Best,
        };
        let encoder = PngEncoder::new_with_quality(writer, effort, FilterType::Adaptive);
        use image::ImageEncoder;
        let result = if sixteen_bit {
            let rgb = image.to_srgb16();
            let bytes: Vec<u8> = if alpha {
                rgb.iter()
                    .zip(&image.pixels)
                    .flat_map(|(c, p)| [c[0], c[1], c[2], quantise(p[3], 65535.0) as u16])
                    .flat_map(u16::to_be_bytes)
                    .collect()
            } else {
                rgb.into_iter()
                    .flatten()
                    .flat_map(u16::to_be_bytes)
                    .collect()
            };
            let colour = if alpha {
                image::ExtendedColorType::Rgba16
            } else {
                image::ExtendedColorType::Rgb16
            };
            encoder.write_image(&bytes, w, h, colour)
        } else if alpha {
            let bytes: Vec<u8> = image
                .to_srgb8()
                .iter()
                .zip(&image.pixels)
                .flat_map(|(c, p)| [c[0], c[1], c[2], quantise(p[3], 255.0) as u8])
                .collect();
            encoder.write_image(&bytes, w, h, image::ExtendedColorType::Rgba8)
        } else {
            let bytes = image.to_srgb8().into_flattened();
            encoder.write_image(&bytes, w, h, image::ExtendedColorType::Rgb8)
        };
        result.map_err(|e| Error::format(path, format!("cannot encode PNG: {e}")))
    })
}

/// A linear alpha in [0, 1] (NaN as 0) on a 0..=`top` integer scale.
fn quantise(alpha: f32, top: f32) -> f32 {
    let a = if alpha.is_nan() {
        0.0
    } else {
        alpha.clamp(0.0, 1.0)
    };
    (a * top + 0.5).floor()
}

/// The plain view: linear values × 2^EV, then sRGB.
pub(crate) fn write_exposed_png(image: &HdrImage, path: &Path, exposure_ev: f64) -> Result<()> {
    write_display_png(&exposed(image, exposure_ev)?, path, false)
}

/// The image with its colour × 2^EV (alpha kept): what the plain display view shows.
pub(crate) fn exposed(image: &HdrImage, exposure_ev: f64) -> Result<HdrImage> {
    if !exposure_ev.is_finite() {
        return Err(Error::invalid(
            "exposure",
            format!("expected a finite number of stops, got {exposure_ev}"),
        ));
    }
    let gain = 2f64.powf(exposure_ev) as f32;
    let mut view = image.clone();
    for p in &mut view.pixels {
        for c in p.iter_mut().take(3) {
            *c *= gain;
        }
    }
    Ok(view)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_written_and_decodable() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = HdrImage::new(2, 1);
        img.pixels[0] = [0.09, 0.09, 0.09, 1.0];
        let p = dir.path().join("v.png");
        write_exposed_png(&img, &p, 1.0).unwrap();
        let back = image::open(&p).unwrap().to_rgb8();
        assert_eq!(back.get_pixel(0, 0).0, [118, 118, 118]);
        assert_eq!(back.get_pixel(1, 0).0, [0, 0, 0]);
    }
}
