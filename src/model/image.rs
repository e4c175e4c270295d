//! The HDR image: linear, unbounded f32 RGBA with premultiplied colour, as produced by the
//! renderers and consumed by exposure, tone mapping and the writers. Extra named channels (a
//! surface's data value, its fringe intensity) ride along so EXR output can keep them.

use crate::model::colormap::{encode_srgb16, encode_srgb8};

/// A linear high-dynamic-range RGBA image, rows top to bottom.
#[derive(Clone, Debug, Default)]
pub struct HdrImage {
    pub width: u32,
    pub height: u32,
    /// `width * height` pixels, row-major from the top-left corner.
    pub pixels: Vec<[f32; 4]>,
    /// Additional single-channel layers, each `width * height` long, written to EXR beside R, G, B, A.
    pub extra_channels: Vec<(String, Vec<f32>)>,
    /// Provenance recorded in EXR attributes: dataset, camera, transfer function, precision, adapter.
    pub metadata: Vec<(String, String)>,
}

impl HdrImage {
    pub fn new(width: u32, height: u32) -> Self {
        HdrImage {
            width,
            height,
            pixels: vec![[0.0; 4]; width as usize * height as usize],
            extra_channels: Vec::new(),
            metadata: Vec::new(),
        }
    }

    pub fn from_pixels(width: u32, height: u32, pixels: Vec<[f32; 4]>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize);
        HdrImage {
            width,
            height,
            pixels,
            extra_channels: Vec::new(),
            metadata: Vec::new(),
        }
    }

    pub fn pixel(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets or replaces a metadata entry.
    pub(crate) fn set_meta(&mut self, key: &str, value: impl Into<String>) {
        let value = value.into();
        match self.metadata.iter_mut().find(|(k, _)| k == key) {
            Some(entry) => entry.1 = value,
            None => self.metadata.push((key.to_string(), value)),
        }
    }

    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Rec. 709 luminance of every pixel.
    pub fn luminance(&self) -> Vec<f32> {
        self.pixels.iter().map(|p| rec709_luminance(*p)).collect()
    }

    /// 8-bit sRGB of a display-referred image, row-major: R, G, B of each pixel through
    /// [`encode_srgb8`] (clamped to [0, 1], missing values black), alpha dropped. The one
    /// conversion behind display PNGs and terminal pictures.
    pub(crate) fn to_srgb8(&self) -> Vec<[u8; 3]> {
        self.pixels
            .iter()
            .map(|p| [p[0], p[1], p[2]].map(|v| encode_srgb8(v as f64)))
            .collect()
    }

    /// As [`HdrImage::to_srgb8`], 16 bits deep (16-bit PNG).
    pub(crate) fn to_srgb16(&self) -> Vec<[u16; 3]> {
        self.pixels
            .iter()
            .map(|p| [p[0], p[1], p[2]].map(|v| encode_srgb16(v as f64)))
            .collect()
    }
}

/// Rec. 709 / sRGB-primaries relative luminance Y of a linear RGB triple.
pub(crate) fn rec709_luminance(p: [f32; 4]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_views_drop_alpha_and_blacken_missing_pixels() {
        let values = [0.0, 0.18, 0.5, 1.0, f32::NAN, f32::INFINITY, -1.0];
        let pixels = values.iter().map(|&v| [v, v, v, 0.5]).collect();
        let img = HdrImage::from_pixels(values.len() as u32, 1, pixels);
        assert_eq!(
            img.to_srgb8().iter().map(|p| p[0]).collect::<Vec<_>>(),
            [0, 118, 188, 255, 0, 0, 0]
        );
        assert_eq!(img.to_srgb16()[3], [65535; 3]);
        assert_eq!(img.to_srgb16()[2], [48192; 3]); // 0.735357 * 65535
    }
}
