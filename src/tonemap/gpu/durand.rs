//! Durand and Dorsey's bilateral operator on a bilateral grid
//! (`shaders/tonemap/durand_bilateral.wgsl`): the splat, the blurs, the base layer with its
//! range, and the recombination.

use super::buffers::BufferCache;
use super::recording::Recording;
use super::{bands, DurandGrid, GpuToneMapper, ToneMapCall, ToneMapParams};
use crate::error::Result;

impl GpuToneMapper {
    /// Durand and Dorsey's bilateral filter on a bilateral grid: the grid (splat and blurs),
    /// then per band the base layer, its range, and the recombination.
    pub(super) fn record_durand(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        grid: &DurandGrid,
        call: &ToneMapCall<'_>,
    ) -> Result<()> {
        let ctx = &*self.ctx;
        let durand = ToneMapParams {
            cell: grid.cell,
            grid_width: grid.grid_width,
            grid_height: grid.grid_height,
            levels: grid.levels,
            first_level: grid.first_level as f32,
            level_step: grid.level_step as f32,
            sigma: grid.sigma_cells as f32,
            radius: grid.radius,
            ..call.base
        };
        let px_bytes = (rec.width * rec.height) as u64 * 16;
        let planes = grid.cells() as u64 * grid.levels as u64 * 8;
        let buffers = DurandBuffers {
            layers: cache.scratch(ctx, "durand layers", px_bytes),
            tmp: cache.scratch(ctx, "durand tmp", planes),
            levels: cache.scratch(ctx, "durand levels", planes),
            range: cache.scratch(ctx, "durand base range", 16),
        };
        self.record_durand_grid(rec, grid, &durand, &call.image, &buffers)?;
        self.record_durand_layers(rec, &durand, call, &buffers)
    }

    /// The bilateral grid: the splat of the image's log luminance in bands of grid rows, then
    /// the blur along x and along y.
    fn record_durand_grid(
        &self,
        rec: &mut Recording<'_>,
        grid: &DurandGrid,
        durand: &ToneMapParams,
        image: &wgpu::Buffer,
        buffers: &DurandBuffers,
    ) -> Result<()> {
        let (w, h) = (rec.width, rec.height);
        let u = self.uniform(durand);
        // The splat reads `cell` pixel rows per grid row: bands of grid rows whose
        // pixel rows fit one window.
        let row_bytes = w as u64 * 16;
        let align = self.align();
        let limit = self.window_limit;
        let grid_rows = bands::band_rows(grid.grid_height, 1, "durand splat", |r| {
            (r as u64 * grid.cell as u64 + bands::row_step(row_bytes, align) as u64) * row_bytes
                <= limit
        })?;
        for band in bands::split(grid.grid_height, grid_rows) {
            let rows = bands::window(
                0,
                row_bytes,
                band.first * grid.cell,
                (band.end() * grid.cell).min(h),
                align,
            );
            let u = self.uniform(&ToneMapParams {
                band_first: band.first,
                band_rows: band.rows,
                window_first: rows.first_row,
                ..*durand
            });
            rec.window(1, rows);
            rec.items(
                grid.grid_width * band.rows,
                DURAND_SHADER,
                "grid_splat",
                &[(0, &u), (1, image), (17, &buffers.levels)],
            )?;
        }
        let items = grid.cells() * grid.levels;
        rec.items(
            items,
            DURAND_SHADER,
            "grid_blur_x",
            &[(0, &u), (17, &buffers.levels), (16, &buffers.tmp)],
        )?;
        rec.items(
            items,
            DURAND_SHADER,
            "grid_blur_y",
            &[(0, &u), (16, &buffers.tmp), (17, &buffers.levels)],
        )
    }

    /// Per band the base layer sliced from the grid and its partial range, the range combined,
    /// then per band the recombination of base and detail.
    fn record_durand_layers(
        &self,
        rec: &mut Recording<'_>,
        durand: &ToneMapParams,
        call: &ToneMapCall<'_>,
        buffers: &DurandBuffers,
    ) -> Result<()> {
        let plan = call.plan;
        let (image, layers, range) = (&call.image, &buffers.layers, &buffers.range);
        for (b, &band) in plan.bands.iter().enumerate() {
            let u = self.band_uniform(durand, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(12, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                DURAND_SHADER,
                "base",
                &[(0, &u), (1, image), (12, layers), (17, &buffers.levels)],
            )?;
            rec.window(12, plan.pixel_window(band, 16))
                .window(6, plan.partials_window(b));
            rec.dispatch(
                DURAND_SHADER,
                "range_partial",
                &[(0, &u), (6, &call.partials), (12, layers)],
                (plan.groups, 1),
            )?;
        }
        rec.single(
            DURAND_SHADER,
            "range_finish",
            &[(6, &call.partials), (13, range)],
        )?;
        for &band in &plan.bands {
            let u = self.band_uniform(durand, band);
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16))
                .window(12, plan.pixel_window(band, 16));
            rec.pixels(
                band,
                DURAND_SHADER,
                "apply",
                &[
                    (0, &u),
                    (1, image),
                    (2, &call.output),
                    (12, layers),
                    (13, range),
                ],
            )?;
        }
        Ok(())
    }
}
/// The shader file of Durand and Dorsey's bilateral operator.
const DURAND_SHADER: &str = "tonemap/durand_bilateral.wgsl";

/// The scratch buffers of Durand's operator: base and detail layers, the grid blurred along x
/// (`tmp`), the grid as splatted and then blurred (its levels), and the base layer's range.
struct DurandBuffers {
    layers: wgpu::Buffer,
    tmp: wgpu::Buffer,
    levels: wgpu::Buffer,
    range: wgpu::Buffer,
}
