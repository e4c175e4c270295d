//! Reinhard's dodging and burning (`shaders/tonemap/reinhard_local.wgsl`): the plan of its
//! scales on pyramid levels, and the passes: the pyramid, each scale's blurs, the scale
//! selection.

use super::buffers::BufferCache;
use super::recording::Recording;
use super::{bands, Band, GpuToneMapper, ToneMapCall, ToneMapParams};
use crate::error::Result;
use crate::tonemap::params::{blur_sigma, gaussian_radius, grid_sigma, reinhard_level};

impl GpuToneMapper {
    /// Reinhard's dodging and burning after the statistics: the pyramid, the coarse scales'
    /// horizontal blurs, and per pixel band the fine scales' horizontal blurs and the coarse
    /// scales' vertical blurs of the rows that band reads, then the scale selection (which
    /// does the fine scales' vertical blurs). Pyramid levels alternate between two buffers (a
    /// downsample reads one and writes the other); a coarse scale's horizontal blur is kept
    /// whole; what the band's passes read is copied into textures (one band: the whole image).
    pub(super) fn record_reinhard(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        r: &ReinhardPlan,
        call: &ToneMapCall<'_>,
    ) -> Result<()> {
        let ctx = &*self.ctx;
        let offsets = r.pyramid_offsets(self.align());
        let parity_bytes = |p: u32| {
            (0..=r.deepest)
                .filter(|k| k % 2 == p)
                .map(|k| offsets[k as usize] + r.level_bytes(k))
                .max()
                .unwrap_or(16)
        };
        let pyramid = [
            cache.scratch(ctx, "reinhard pyramid even", parity_bytes(0)),
            cache.scratch(ctx, "reinhard pyramid odd", parity_bytes(1)),
        ];
        let tmp: Vec<wgpu::Buffer> = r
            .coarse()
            .map(|(i, k)| cache.scratch(ctx, TMP_LABELS[i], r.level_bytes(k)))
            .collect();
        let taps = (0..r.levels.len())
            .map(|i| self.blur_taps(r.sigma_cells[i], r.radius[i]))
            .collect();
        let buffers = ReinhardBuffers {
            offsets,
            pyramid,
            tmp,
            taps,
            fine_taps: self.fine_taps(r),
        };
        self.record_reinhard_pyramid(rec, r, call, &buffers)?;
        self.record_reinhard_blur_x(rec, r, &call.base, &buffers)?;
        self.record_reinhard_scales(rec, cache, r, call, &buffers)
    }

    /// Level 0 of the pyramid (the pixels' (L m, m)) per pixel band, then each deeper level
    /// downsampled from the one above in bands that keep both windows within the limit.
    fn record_reinhard_pyramid(
        &self,
        rec: &mut Recording<'_>,
        r: &ReinhardPlan,
        call: &ToneMapCall<'_>,
        buffers: &ReinhardBuffers,
    ) -> Result<()> {
        let (plan, base, offsets) = (call.plan, &call.base, &buffers.offsets);
        let align = self.align();
        let limit = self.window_limit;
        // Level 0: the pixels' (L m, m).
        let level0 = ToneMapParams {
            out_stride: r.level_pitch(0),
            ..*base
        };
        for &band in &plan.bands {
            let u = self.band_uniform(&level0, band);
            rec.window(1, plan.pixel_window(band, 16)).window(
                10,
                bands::window(
                    offsets[0],
                    r.level_pitch(0) as u64 * 8,
                    band.first,
                    band.end(),
                    align,
                ),
            );
            rec.pixels(
                band,
                REINHARD_SHADER,
                "prepare",
                &[
                    (0, &u),
                    (1, &call.image),
                    (3, &call.stats),
                    (10, buffers.level(0)),
                ],
            )?;
        }
        for k in 1..=r.deepest {
            let (gw, gh) = r.level_size(k);
            let sh = r.level_size(k - 1).1;
            let (row, src_row) = (gw as u64 * 8, r.level_pitch(k - 1) as u64 * 8);
            let rows =
                bands::band_rows(gh, bands::row_step(row, align), "reinhard pyramid", |n| {
                    n as u64 * row <= limit
                        && (2 * n as u64 + bands::row_step(src_row, align) as u64) * src_row
                            <= limit
                })?;
            for band in bands::split(gh, rows) {
                let src = bands::window(
                    offsets[k as usize - 1],
                    src_row,
                    2 * band.first,
                    (2 * band.end()).min(sh),
                    align,
                );
                let u = self.uniform(&ToneMapParams {
                    band_first: band.first,
                    band_rows: band.rows,
                    window_first: src.first_row,
                    in_stride: r.level_pitch(k - 1),
                    ..r.level_params(base, k)
                });
                rec.window(8, src).window(
                    9,
                    bands::window(offsets[k as usize], row, band.first, band.end(), align),
                );
                rec.items(
                    gw * band.rows,
                    REINHARD_SHADER,
                    "downsample",
                    &[(0, &u), (8, buffers.level(k - 1)), (9, buffers.level(k))],
                )?;
            }
        }
        Ok(())
    }

    /// Each coarse scale's horizontal blur, whole, on its level (the fine scales' are computed
    /// per pixel band, [`Self::record_reinhard_fine_x`]).
    fn record_reinhard_blur_x(
        &self,
        rec: &mut Recording<'_>,
        r: &ReinhardPlan,
        base: &ToneMapParams,
        buffers: &ReinhardBuffers,
    ) -> Result<()> {
        let align = self.align();
        let limit = self.window_limit;
        for (i, k) in r.coarse() {
            let (gw, gh) = r.level_size(k);
            let row = gw as u64 * 8;
            let rows = bands::band_rows(gh, bands::row_step(row, align), "reinhard blur", |n| {
                n as u64 * row <= limit
            })?;
            let blur = ToneMapParams {
                radius: r.radius[i],
                out_stride: gw,
                ..r.level_params(base, k)
            };
            for band in bands::split(gh, rows) {
                let input = bands::window(
                    buffers.offsets[k as usize],
                    row,
                    band.first,
                    band.end(),
                    align,
                );
                let u = self.uniform(&ToneMapParams {
                    band_first: band.first,
                    band_rows: band.rows,
                    window_first: input.first_row,
                    ..blur
                });
                rec.window(8, input)
                    .window(9, bands::window(0, row, band.first, band.end(), align));
                rec.items(
                    gw.div_ceil(BLUR_RUN) * band.rows,
                    REINHARD_SHADER,
                    "blur_x",
                    &[
                        (0, &u),
                        (8, buffers.level(k)),
                        (9, &buffers.tmp[i - r.fine]),
                        (19, &buffers.taps[i]),
                    ],
                )?;
            }
        }
        Ok(())
    }

    /// The horizontal blurs of the fine scales (on level 0) for the rows a pixel band's
    /// vertical blurs read, `fine_rows`, into the band's fine buffer: row by row, one plane
    /// per fine scale. They read those rows of level 0 from a texture, a copy of them.
    #[allow(clippy::too_many_arguments)]
    fn record_reinhard_fine_x(
        &self,
        rec: &mut Recording<'_>,
        r: &ReinhardPlan,
        base: &ToneMapParams,
        buffers: &ReinhardBuffers,
        fine: &wgpu::Buffer,
        level0: &wgpu::Texture,
        fine_rows: Band,
    ) -> Result<()> {
        let align = self.align();
        r.copy_rows(
            rec,
            (
                buffers.level(0),
                buffers.offsets[0] + fine_rows.first as u64 * r.level_pitch(0) as u64 * 8,
            ),
            level0,
            r.level_pitch(0),
            (r.width, fine_rows.rows),
        );
        for i in 0..r.fine {
            let u = self.uniform(&ToneMapParams {
                radius: r.radius[i],
                band_first: fine_rows.first,
                band_rows: fine_rows.rows,
                out_stride: r.fine_row_len(),
                dst_offset: i as u32 * r.fine_pitch(),
                ..r.level_params(base, 0)
            });
            rec.window(9, r.fine_window(fine_rows.rows, align))
                .texture(13, level0);
            rec.items(
                r.width.div_ceil(BLUR_RUN) * fine_rows.rows,
                REINHARD_SHADER,
                "fine_x",
                &[(0, &u), (9, fine), (19, &buffers.taps[i])],
            )?;
        }
        Ok(())
    }

    /// Per pixel band: the fine scales' horizontal blurs of the rows the band reads, the
    /// vertical blur of the rows of every coarse scale the band reads into one band-sized
    /// buffer, then the scale selection over them.
    fn record_reinhard_scales(
        &self,
        rec: &mut Recording<'_>,
        cache: &mut BufferCache,
        r: &ReinhardPlan,
        call: &ToneMapCall<'_>,
        buffers: &ReinhardBuffers,
    ) -> Result<()> {
        let (plan, base) = (call.plan, &call.base);
        let band_planes: Vec<Vec<Band>> = plan.bands.iter().map(|&b| r.planes_for(b)).collect();
        let coarse_rows = band_planes.iter().map(|planes| r.planes_rows(planes)).max();
        let coarse_rows = coarse_rows.unwrap_or(0);
        let blurred = cache.scratch(
            &self.ctx,
            "reinhard blurred",
            coarse_rows as u64 * r.coarse_pitch() as u64 * 8,
        );
        let coarse = cache.texture(
            &self.ctx,
            "reinhard coarse texture",
            wgpu::TextureFormat::Rg32Float,
            (r.coarse_width(), coarse_rows),
        );
        let fine_rows = plan.bands.iter().map(|&b| r.fine_rows(b).rows).max();
        let fine = cache.scratch(
            &self.ctx,
            "reinhard fine",
            fine_rows.unwrap_or(0) as u64 * r.fine_row_len() as u64 * 8,
        );
        let texture = cache.texture(
            &self.ctx,
            "reinhard fine texture",
            wgpu::TextureFormat::Rg32Float,
            (r.width, fine_rows.unwrap_or(0) * r.fine as u32),
        );
        let level0 = cache.texture(
            &self.ctx,
            "reinhard level-0 texture",
            wgpu::TextureFormat::Rg32Float,
            (r.width, fine_rows.unwrap_or(0)),
        );
        for (&band, planes) in plan.bands.iter().zip(&band_planes) {
            let fine_rows = r.fine_rows(band);
            self.record_reinhard_fine_x(rec, r, base, buffers, &fine, &level0, fine_rows)?;
            r.copy_rows(
                rec,
                (&fine, 0),
                &texture,
                r.fine_pitch(),
                (r.width, fine_rows.rows * r.fine as u32),
            );
            let mut table = [[0u32; 4]; 17];
            for (i, entry) in table.iter_mut().enumerate().take(r.fine) {
                let scale = r.ratio.powi(i as i32) as f32;
                *entry = [r.radius[i], 0, scale.to_bits(), 0];
            }
            self.record_reinhard_coarse_y(rec, r, base, buffers, &blurred, planes, &mut table)?;
            r.copy_rows(
                rec,
                (&blurred, 0),
                &coarse,
                r.coarse_pitch(),
                (r.coarse_width(), r.planes_rows(planes)),
            );
            let table_buffer = self.uniform_bytes("reinhard scales", bytemuck::cast_slice(&table));
            let u = self.band_uniform(
                &ToneMapParams {
                    levels: r.levels.len() as u32,
                    fine_scales: r.fine as u32,
                    window_first: fine_rows.first,
                    ..*base
                },
                band,
            );
            rec.window(1, plan.pixel_window(band, 16))
                .window(2, plan.pixel_window(band, 16))
                .texture(11, &coarse)
                .texture(12, &texture);
            rec.items(
                r.width * band.rows.div_ceil(BLUR_RUN),
                REINHARD_SHADER,
                "apply",
                &[
                    (0, &u),
                    (1, &call.image),
                    (2, &call.output),
                    (3, &call.stats),
                    (18, &table_buffer),
                    (20, &buffers.fine_taps),
                ],
            )?;
        }
        Ok(())
    }

    /// The vertical blurs of the rows of each coarse scale that a pixel band reads (`planes`),
    /// one after another in `blurred` (rows of `coarse_pitch` cells), and their entries in the
    /// apply pass's table: (first texture row, level, scale, first level row).
    #[allow(clippy::too_many_arguments)]
    fn record_reinhard_coarse_y(
        &self,
        rec: &mut Recording<'_>,
        r: &ReinhardPlan,
        base: &ToneMapParams,
        buffers: &ReinhardBuffers,
        blurred: &wgpu::Buffer,
        planes: &[Band],
        table: &mut [[u32; 4]; 17],
    ) -> Result<()> {
        let align = self.align();
        let mut at = 0u32;
        for ((i, k), rows) in r.coarse().zip(planes) {
            let (gw, gh) = r.level_size(k);
            let halo = bands::window(
                0,
                gw as u64 * 8,
                rows.first.saturating_sub(r.radius[i]),
                (rows.end() + r.radius[i]).min(gh),
                align,
            );
            let u = self.uniform(&ToneMapParams {
                radius: r.radius[i],
                band_first: rows.first,
                band_rows: rows.rows,
                window_first: halo.first_row,
                out_stride: r.coarse_pitch(),
                dst_offset: at * r.coarse_pitch(),
                ..r.level_params(base, k)
            });
            rec.window(8, halo);
            rec.items(
                gw * rows.rows.div_ceil(BLUR_RUN),
                REINHARD_SHADER,
                "blur_y",
                &[
                    (0, &u),
                    (8, &buffers.tmp[i - r.fine]),
                    (9, blurred),
                    (19, &buffers.taps[i]),
                ],
            )?;
            let scale = r.ratio.powi(i as i32) as f32;
            table[i] = [at, k, scale.to_bits(), rows.first];
            at += rows.rows;
        }
        Ok(())
    }
}
impl GpuToneMapper {
    /// A blur's Gaussian taps exp(−k² / 2σ²) for k = 0..=radius (at most [`MAX_TAPS`]), computed
    /// once in f64 as the CPU reference computes them, as the shader's uniform array.
    fn blur_taps(&self, sigma: f64, radius: u32) -> wgpu::Buffer {
        let mut taps = [0f32; MAX_TAPS];
        gaussian_taps(
            sigma,
            &mut taps[..=radius.min(MAX_TAPS as u32 - 1) as usize],
        );
        self.uniform_bytes("reinhard taps", bytemuck::cast_slice(&taps))
    }

    /// The fine scales' Gaussian taps, [`FINE_TAPS`] per scale, for the apply pass's vertical
    /// blurs (the same values as [`Self::blur_taps`]).
    fn fine_taps(&self, r: &ReinhardPlan) -> wgpu::Buffer {
        let mut taps = [0f32; FINE_TAPS * 17];
        for (i, scale) in taps.chunks_mut(FINE_TAPS).enumerate().take(r.fine) {
            let radius = r.radius[i] as usize;
            debug_assert!(radius < FINE_TAPS, "fine scales have radius <= 10");
            gaussian_taps(r.sigma_cells[i], &mut scale[..=radius.min(FINE_TAPS - 1)]);
        }
        self.uniform_bytes("reinhard fine taps", bytemuck::cast_slice(&taps))
    }
}

/// Fills `taps` with a Gaussian's taps exp(−k² / 2σ²) for k = 0, 1, …, computed in f64 as the
/// CPU reference computes them.
fn gaussian_taps(sigma: f64, taps: &mut [f32]) {
    for (k, tap) in taps.iter_mut().enumerate() {
        let k = k as f64;
        *tap = (-k * k / (2.0 * sigma * sigma)).exp() as f32;
    }
}

/// Cells a stored row holds so that it is a whole number of the 256-byte rows a copy into a
/// texture takes (8-byte cells).
fn texture_pitch(cells: u32) -> u32 {
    cells.next_multiple_of(32)
}

/// Cells each lane of a blur pass computes (`RUN` in the shader).
const BLUR_RUN: u32 = 8;

/// Taps each fine scale has in the apply pass's table (`fine_taps` in the shader): radius at
/// most 15, and a fine scale's sigma is under 2 `REINHARD_MIN_LEVEL_SIGMA` pixels (radius 10).
const FINE_TAPS: usize = 16;

/// Taps a blur's uniform holds (`MAX_TAPS` in the shader): radius at most 127.
const MAX_TAPS: usize = 128;

/// The shader file of Reinhard's dodging and burning.
const REINHARD_SHADER: &str = "tonemap/reinhard_local.wgsl";

/// Reinhard's pyramid, its levels alternating between two buffers at `offsets`, and each
/// scale's horizontal blur.
struct ReinhardBuffers {
    offsets: Vec<u64>,
    pyramid: [wgpu::Buffer; 2],
    /// Each coarse scale's horizontal blur (scale `fine + j` in `tmp[j]`).
    tmp: Vec<wgpu::Buffer>,
    /// Each scale's Gaussian taps (binding 19 of its blurs).
    taps: Vec<wgpu::Buffer>,
    /// The fine scales' taps (binding 20 of the apply pass).
    fine_taps: wgpu::Buffer,
}

impl ReinhardBuffers {
    /// The buffer holding pyramid level k.
    fn level(&self, k: u32) -> &wgpu::Buffer {
        &self.pyramid[(k % 2) as usize]
    }
}

/// Labels of the per-scale horizontal-blur buffers of Reinhard's operator (at most 17 scales).
const TMP_LABELS: [&str; 17] = [
    "reinhard blur 0",
    "reinhard blur 1",
    "reinhard blur 2",
    "reinhard blur 3",
    "reinhard blur 4",
    "reinhard blur 5",
    "reinhard blur 6",
    "reinhard blur 7",
    "reinhard blur 8",
    "reinhard blur 9",
    "reinhard blur 10",
    "reinhard blur 11",
    "reinhard blur 12",
    "reinhard blur 13",
    "reinhard blur 14",
    "reinhard blur 15",
    "reinhard blur 16",
];

/// Reinhard's scales on their pyramid levels (params.rs: `blur_sigma`, `reinhard_level`,
/// `grid_sigma`) for one image size.
pub(super) struct ReinhardPlan {
    width: u32,
    height: u32,
    ratio: f64,
    /// Pyramid level of each scale.
    levels: Vec<u32>,
    sigma_cells: Vec<f64>,
    radius: Vec<u32>,
    deepest: u32,
    /// How many scales are blurred on level 0 (the first ones: levels grow with the scale).
    fine: usize,
    /// The largest radius of a fine scale's blur: the rows above and below a pixel band that
    /// its vertical blurs read.
    fine_radius: u32,
}

impl ReinhardPlan {
    pub(super) fn new(width: u32, height: u32, alpha1: f64, ratio: f64, scales: u32) -> Self {
        let sigmas: Vec<f64> = (0..=scales).map(|i| blur_sigma(alpha1, ratio, i)).collect();
        let levels: Vec<u32> = sigmas.iter().map(|&s| reinhard_level(s)).collect();
        let sigma_cells: Vec<f64> = sigmas
            .iter()
            .zip(&levels)
            .map(|(&s, &k)| grid_sigma(s, 1 << k))
            .collect();
        let radius: Vec<u32> = sigma_cells.iter().map(|&s| gaussian_radius(s)).collect();
        let fine = levels.iter().take_while(|&&k| k == 0).count();
        ReinhardPlan {
            width,
            height,
            ratio,
            fine_radius: radius[..fine].iter().copied().max().unwrap_or(0),
            fine,
            radius,
            deepest: levels.iter().copied().max().unwrap_or(0),
            levels,
            sigma_cells,
        }
    }

    /// The coarse scales (blurred on levels 1 and deeper) with their levels.
    fn coarse(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        self.levels.iter().copied().enumerate().skip(self.fine)
    }

    /// The pixel rows whose fine horizontal blurs a band's vertical blurs read.
    fn fine_rows(&self, band: Band) -> Band {
        let first = band.first.saturating_sub(self.fine_radius);
        let end = (band.end() + self.fine_radius).min(self.height);
        Band {
            first,
            rows: end - first,
        }
    }

    /// Elements in one plane's row of a band's fine buffer: the image's width, padded for the
    /// copy into a texture.
    fn fine_pitch(&self) -> u32 {
        texture_pitch(self.width)
    }

    /// Elements in one row of a band's fine buffer: a plane per fine scale.
    fn fine_row_len(&self) -> u32 {
        self.fine as u32 * self.fine_pitch()
    }

    /// Copies `size` texels of (L m, m) pairs from `buffer` at `offset` (rows of `pitch` pairs)
    /// into a texture: rows of level 0 for the fine horizontal blurs, or for the apply pass the
    /// fine horizontal blurs (texture row j is plane j % fine of pixel row j / fine) or the
    /// coarse scales' rows. On Mesa's CPU rasterizers a texel fetch gathers the lanes' values
    /// in vector code, where a storage-buffer load at a per-lane index runs one lane at a time.
    fn copy_rows(
        &self,
        rec: &mut Recording<'_>,
        (buffer, offset): (&wgpu::Buffer, u64),
        texture: &wgpu::Texture,
        pitch: u32,
        (width, height): (u32, u32),
    ) {
        if width == 0 || height == 0 {
            return;
        }
        rec.encoder.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset,
                    bytes_per_row: Some(pitch * 8),
                    rows_per_image: None,
                },
            },
            texture.as_image_copy(),
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
    }

    /// The first `rows` rows of a band's fine buffer (at least one element, as a binding).
    fn fine_window(&self, rows: u32, align: u64) -> bands::Window {
        let row = (self.fine_row_len() as u64 * 8).max(8);
        bands::window(0, row, 0, rows.max(1), align)
    }

    /// `base` on the cells of pyramid level k (2^k pixels a side).
    fn level_params(&self, base: &ToneMapParams, k: u32) -> ToneMapParams {
        let cell = 1u32 << k;
        ToneMapParams {
            cell,
            grid_width: self.width.div_ceil(cell),
            grid_height: self.height.div_ceil(cell),
            ..*base
        }
    }

    fn level_size(&self, k: u32) -> (u32, u32) {
        (self.width.div_ceil(1 << k), self.height.div_ceil(1 << k))
    }

    /// Cells in one row of pyramid level k as stored: level 0's rows are padded to the
    /// 256-byte rows a copy into a texture takes (the fine blurs read it as one).
    fn level_pitch(&self, k: u32) -> u32 {
        match k {
            0 => texture_pitch(self.width),
            _ => self.level_size(k).0,
        }
    }

    fn level_bytes(&self, k: u32) -> u64 {
        self.level_pitch(k) as u64 * self.level_size(k).1 as u64 * 8
    }

    /// Byte offset of each level in its parity's buffer (aligned, so windows can start there).
    fn pyramid_offsets(&self, align: u64) -> Vec<u64> {
        let mut next = [0u64; 2];
        (0..=self.deepest)
            .map(|k| {
                let p = (k % 2) as usize;
                let here = next[p];
                next[p] = (here + self.level_bytes(k)).next_multiple_of(align);
                here
            })
            .collect()
    }

    /// The cell rows of level k that the bilinear read of pixel row y touches (as the apply
    /// pass: cell centres at (c + 0.5)·2^k − 0.5, clamped to the outermost).
    fn cell_rows(&self, k: u32, y: u32) -> (u32, u32) {
        if k == 0 {
            return (y, y);
        }
        let gh = self.level_size(k).1;
        let cell = (1u32 << k) as f64;
        let v = ((y as f64 + 0.5) / cell - 0.5).clamp(0.0, (gh - 1) as f64);
        let y0 = v.floor() as u32;
        (y0, (y0 + 1).min(gh - 1))
    }

    /// Per coarse scale, the rows of its level that pixel rows `band` read.
    fn planes_for(&self, band: Band) -> Vec<Band> {
        self.coarse()
            .map(|(_, k)| {
                let first = self.cell_rows(k, band.first).0;
                let last = self.cell_rows(k, band.end() - 1).1;
                Band {
                    first,
                    rows: last - first + 1,
                }
            })
            .collect()
    }

    /// Rows of the coarse scales' planes that a band reads, all together.
    fn planes_rows(&self, planes: &[Band]) -> u32 {
        planes.iter().map(|p| p.rows).sum()
    }

    /// Cells in the widest coarse level (level 1, or the first coarse scale's), 0 without
    /// coarse scales.
    fn coarse_width(&self) -> u32 {
        self.coarse()
            .map(|(_, k)| self.level_size(k).0)
            .max()
            .unwrap_or(0)
    }

    /// Cells in one row of the coarse planes' buffer: the widest coarse level's, padded for the
    /// copy into a texture.
    fn coarse_pitch(&self) -> u32 {
        texture_pitch(self.coarse_width().max(1))
    }

    /// Whether a band of `rows` pixel rows keeps Reinhard's windows within `limit` and its
    /// textures within `max_texture` a side: level 0 of the pyramid, the band's rows of every
    /// coarse scale and each coarse vertical blur's input (the band's rows plus the blur's
    /// radius on both sides), and the fine blurs of the band's rows and halo.
    pub(super) fn band_fits(&self, rows: u32, limit: u64, align: u64, max_texture: u32) -> bool {
        let rows = rows.min(self.height);
        let worst = Band {
            first: (self.height - rows) / 2,
            rows,
        };
        let planes = self.planes_for(worst);
        let halo_fits = planes.iter().zip(self.coarse()).all(|(p, (i, k))| {
            let row = self.level_size(k).0 as u64 * 8;
            let r = self.radius[i] as u64;
            (p.rows as u64 + 2 * r + bands::row_step(row, align) as u64) * row <= limit
        });
        // The fine blurs' output (every fine plane of a row), and the textures their input
        // and output are read from.
        let fine = self.fine_rows(worst).rows as u64;
        let level0 = self.level_pitch(0) as u64 * 8;
        let fine_fits = fine * self.fine_row_len() as u64 * 8 <= limit
            && fine * self.fine as u64 <= max_texture as u64
            && self.width <= max_texture;
        let coarse_rows = self.planes_rows(&planes);
        rows as u64 * level0 <= limit
            && coarse_rows as u64 * self.coarse_pitch() as u64 * 8 <= limit
            && coarse_rows <= max_texture
            && halo_fits
            && fine_fits
    }
}
