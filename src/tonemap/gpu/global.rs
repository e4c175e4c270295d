//! The global operators' passes (`shaders/tonemap/global.wgsl`), with Ward's histogram and its
//! capped CDF first (`shaders/tonemap/ward_histogram.wgsl`).

use super::buffers::BufferCache;
use super::recording::Recording;
use super::{GpuToneMapper, Operator, ToneMapCall};
use crate::error::Result;

impl GpuToneMapper {
    /// The global operators after the statistics (Ward's histogram and its capped CDF first):
    /// one pass per band.
    pub(super) fn record_global(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        op: &Operator,
        call: &ToneMapCall<'_>,
    ) -> Result<()> {
        let ctx = &*self.ctx;
        let (plan, base) = (call.plan, &call.base);
        let (image, stats) = (&call.image, &call.stats);
        let cdf = cache.scratch(ctx, "ward cdf", 257 * 4);
        if let Operator::WardHistogram { .. } = op {
            let counts = cache.scratch(ctx, "ward counts", 256 * 4);
            rec.encoder.clear_buffer(&counts, 0, None);
            let file = "tonemap/ward_histogram.wgsl";
            for &band in &plan.bands {
                let u = self.band_uniform(base, band);
                rec.window(1, plan.pixel_window(band, 16));
                rec.dispatch(
                    file,
                    "histogram",
                    &[(0, &u), (1, image), (3, stats), (5, &counts)],
                    (plan.groups, 1),
                )?;
            }
            let params = self.uniform(base);
            rec.single(
                file,
                "ceiling_cdf",
                &[(0, &params), (3, stats), (4, &cdf), (5, &counts)],
            )?;
        }
        for &band in &plan.bands {
            let u = self.band_uniform(base, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                "tonemap/global.wgsl",
                "apply_global",
                &[
                    (0, &u),
                    (1, image),
                    (2, &call.output),
                    (3, stats),
                    (4, &cdf),
                ],
            )?;
        }
        Ok(())
    }
}
