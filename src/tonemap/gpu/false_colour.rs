//! The false-colour view of log10 luminance through turbo with its legend strip
//! (`shaders/tonemap/false_colour.wgsl`), the GPU twin of
//! [`crate::tonemap::cpu::false_colour_log10`].

use super::upload::upload_image;
use super::{GpuToneMapper, Specialisation, ToneMapParams, DISPLAY_REFERRED};
use crate::error::Result;
use crate::model::HdrImage;
use crate::tonemap::cpu::{false_colour_decades, legend_height, turbo_lut};
use crate::tonemap::StageClock;

impl GpuToneMapper {
    /// False-colour view of log10 luminance (after `exposure_ev`) through turbo, over the whole
    /// decades `decades` or those spanning the image, with the legend strip along the bottom;
    /// the GPU twin of [`crate::tonemap::cpu::false_colour_log10`] (same metadata keys).
    pub fn false_colour(
        &self,
        img: &HdrImage,
        exposure_ev: f64,
        decades: Option<(f64, f64)>,
    ) -> Result<HdrImage> {
        crate::tonemap::check_ev("exposure_ev", exposure_ev)?;
        self.check_image(img)?;
        let (low, high) = false_colour_decades(img, exposure_ev, decades)?;
        let (w, h) = (img.width, img.height);
        let px_bytes = w as u64 * h as u64 * 16;
        let ctx = &*self.ctx;
        let mut cache = self.buffers.lock().expect("tone-mapping buffers poisoned");
        let scan = upload_image(ctx, cache.image(ctx, px_bytes), &img.pixels, false)?;
        let image = cache.image(ctx, px_bytes).buffer.clone();
        let output = cache.output(ctx, px_bytes).buffer.clone();
        let device = &ctx.device;
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let base = ToneMapParams {
            width: w,
            height: h,
            exposure_ev: (exposure_ev - scan.lift_ev as f64) as f32,
            ld_min: low as f32,
            ld_max: high as f32,
            radius: legend_height(h),
            ..Default::default()
        };
        let lut = self.storage_init("turbo lut", bytemuck::cast_slice(&turbo_lut()));
        let plan = self.plan(w, h, |_| true)?;
        let mut rec = self.record(w, h, Specialisation::default());
        for &band in &plan.bands {
            let u = self.band_uniform(&base, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                "tonemap/false_colour.wgsl",
                "false_colour",
                &[(0, &u), (1, &image), (2, &output), (14, &lut)],
            )?;
        }
        let pixels = rec.finish(
            cache.output(ctx, px_bytes),
            validation,
            oom,
            &StageClock::start(),
        )?;
        drop(cache);
        let mut out = HdrImage::from_pixels(w, h, pixels);
        out.metadata = img.metadata.clone();
        out.set_meta("false_colour.log10_min", format!("{low}"));
        out.set_meta("false_colour.log10_max", format!("{high}"));
        crate::tonemap::cpu::false_colour_bar(low, high).record(&mut out);
        out.set_meta("transfer", "display-linear");
        out.set_meta(DISPLAY_REFERRED, "1");
        Ok(out)
    }
}
