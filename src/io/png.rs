//! PNG display views of HDR images: a plain exposure (× 2^EV) followed by the sRGB curve, 8-bit
//! or 16-bit (`HdrImage::to_srgb8`, `HdrImage::to_srgb16`), composited over the image's own
//! background (colour is premultiplied, so RGB is final). Real tone-mapping operators feed the
//! same writer with display-referred values.

use crate::error::{Error, Result};
use crate::model::HdrImage;
use std::path::Path;

/// Writes display-referred linear values (clamped to [0, 1]) as an sRGB PNG.
pub fn write_display_png(image: &HdrImage, path: &Path, sixteen_bit: bool) -> Result<()> {
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Err(Error::invalid("image", "cannot write an empty image"));
    }
    crate::io::write_atomic(path, |writer| {
        let encoder = image::codecs::png::PngEncoder::new(writer);
        use image::ImageEncoder;
        let result = if sixteen_bit {
            let bytes: Vec<u8> = image
                .to_srgb16()
                .into_iter()
                .flatten()
                .flat_map(u16::to_be_bytes)
                .collect();
            encoder.write_image(&bytes, w, h, image::ExtendedColorType::Rgb16)
        } else {
            let bytes = image.to_srgb8().into_flattened();
            encoder.write_image(&bytes, w, h, image::ExtendedColorType::Rgb8)
        };
        result.map_err(|e| Error::format(path, format!("cannot encode PNG: {e}")))
    })
}

/// The plain view: linear values × 2^EV, then sRGB.
pub fn write_exposed_png(image: &HdrImage, path: &Path, exposure_ev: f64) -> Result<()> {
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
