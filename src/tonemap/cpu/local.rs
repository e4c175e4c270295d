//! The local operators' f64 references: Reinhard's dodging-and-burning and Durand & Dorsey's
//! bilateral base/detail split, each as the accelerated algorithm the GPU runs.

use rayon::prelude::*;

use super::exact::bilateral_base;
use super::{Filters, LogLuminanceStats, Scene};
use crate::tonemap::params::{
    blur_sigma, durand_sigma_pixels, gaussian_radius, grid_sigma, reinhard_level, DurandGrid,
    DURAND_MIN_LOG_WEIGHT,
};

/// Reinhard's Gaussians by normalised convolution, sum(w L m) / sum(w m) with m = 0 at missing
/// pixels and outside the image, on a pyramid of (L m, m) pairs: level k has cells of 2^k
/// pixels, each the mean of four cells of level k - 1. Scale i's Gaussian (sigma_i pixels) is
/// blurred separably on level [`reinhard_level`] with [`grid_sigma`] cells and read back
/// bilinearly (level 0: the image itself, exactly the full-resolution blur). One scale at a
/// time, each pixel's V handed on as it is computed; the coarse levels blur through two
/// buffers kept from scale to scale: fresh memory costs a page fault per 4 KiB, which on the
/// machines we measure cost more than the blurs themselves.
struct ReinhardBlurs {
    width: usize,
    height: usize,
    pyramid: Vec<(usize, usize, Vec<[f64; 2]>)>,
    across: Vec<[f64; 2]>,
    blurred: Vec<[f64; 2]>,
}

impl ReinhardBlurs {
    fn new(scaled: &[f64], mask: &[f64], width: usize, height: usize, deepest: u32) -> Self {
        let mut pyramid: Vec<(usize, usize, Vec<[f64; 2]>)> = vec![(
            width,
            height,
            scaled
                .par_iter()
                .zip(mask)
                .map(|(v, m)| if *m > 0.0 { [v * m, *m] } else { [0.0, 0.0] })
                .collect(),
        )];
        for _ in 0..deepest {
            let (pw, ph, prev) = pyramid.last().expect("level 0");
            let (w, h) = (pw.div_ceil(2), ph.div_ceil(2));
            let next = (0..w * h)
                .into_par_iter()
                .map(|c| {
                    let (cx, cy) = (c % w, c / w);
                    let mut acc = [0.0, 0.0];
                    for (sx, sy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (x, y) = (2 * cx + sx, 2 * cy + sy);
                        if x < *pw && y < *ph {
                            let v = prev[y * pw + x];
                            acc[0] += 0.25 * v[0];
                            acc[1] += 0.25 * v[1];
                        }
                    }
                    acc
                })
                .collect();
            pyramid.push((w, h, next));
        }
        ReinhardBlurs {
            width,
            height,
            pyramid,
            across: Vec::new(),
            blurred: Vec::new(),
        }
    }

    /// V per pixel of the Gaussian of `sigma` pixels blurred on pyramid level `k`, handed with
    /// the pixel's entry of `pixels` to `take` (in the same pass that computes it: no plane of
    /// V is written).
    fn scale_into<P: Send>(
        &mut self,
        sigma: f64,
        k: u32,
        pixels: &mut [P],
        take: impl Fn(&mut P, f64) + Sync,
    ) {
        let cell = 1u32 << k;
        let sigma_cells = grid_sigma(sigma, cell);
        let radius = gaussian_radius(sigma_cells) as isize;
        let weights: Vec<f64> = (-radius..=radius)
            .map(|t| (-((t * t) as f64) / (2.0 * sigma_cells * sigma_cells)).exp())
            .collect();
        let pixels = &mut pixels[..self.width * self.height];
        if k == 0 {
            self.take_full_resolution(&weights, pixels, take);
        } else {
            self.take_coarse(k, &weights, pixels, take);
        }
    }

    /// [`ReinhardBlurs::scale_into`] on level 0, the image's own grid, where the bilinear read
    /// is the cell itself: a band of rows is blurred across (with the radius's rows either
    /// side) and down, and taken at once, so no plane is written.
    fn take_full_resolution<P: Send>(
        &self,
        weights: &[f64],
        pixels: &mut [P],
        take: impl Fn(&mut P, f64) + Sync,
    ) {
        let (width, height) = (self.width, self.height);
        let plane = &self.pyramid[0].2;
        let radius = weights.len() / 2;
        pixels
            .par_chunks_mut(width.max(1) * BAND_ROWS)
            .enumerate()
            .for_each_init(
                || (Vec::new(), Vec::new(), vec![[0.0, 0.0]; width]),
                |(padded, band, blurred), (b, rows)| {
                    let first = b * BAND_ROWS;
                    let last = first + rows.len() / width.max(1);
                    let top = first.saturating_sub(radius);
                    let bottom = (last + radius).min(height);
                    band.resize((bottom - top) * width, [0.0, 0.0]);
                    for (y, across) in (top..bottom).zip(band.chunks_mut(width.max(1))) {
                        let src_row = &plane[y * width..(y + 1) * width];
                        blur_row_across(src_row, weights, padded, across);
                    }
                    // The band's rows are the image's rows top..bottom, every row a tap of
                    // first..last can reach: the same taps in the same order.
                    let band_height = bottom - top;
                    for (y, row) in (first..last).zip(rows.chunks_mut(width.max(1))) {
                        let at = y - top;
                        blur_row_down(band, width, band_height, weights, at, blurred);
                        for (pixel, &pair) in row.iter_mut().zip(blurred.iter()) {
                            take(pixel, quotient(pair));
                        }
                    }
                },
            );
    }

    /// [`ReinhardBlurs::scale_into`] on a coarser level `k`: blurred there through the two
    /// kept buffers, then read back bilinearly row by row ([`BilinearReads::along_rows`]).
    fn take_coarse<P: Send>(
        &mut self,
        k: u32,
        weights: &[f64],
        pixels: &mut [P],
        take: impl Fn(&mut P, f64) + Sync,
    ) {
        let (w, h, plane) = &self.pyramid[k as usize];
        let (w, h) = (*w, *h);
        let width = self.width;
        self.across.resize(w * h, [0.0, 0.0]);
        blur_pairs_into(plane, w, h, weights, true, &mut self.across[..w * h]);
        self.blurred.resize(w * h, [0.0, 0.0]);
        let (across, blurred) = (&self.across[..w * h], &mut self.blurred[..w * h]);
        blur_pairs_into(across, w, h, weights, false, blurred);
        let reads = BilinearReads::new(1 << k, w as u32, h as u32, width, self.height);
        let across = &mut self.across;
        reads.along_rows(blurred, across);
        let across = &*across;
        pixels
            .par_chunks_mut(width.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                let (top, bottom, fy) = reads.rows_of(across, y);
                for ((pixel, t), b) in row.iter_mut().zip(top).zip(bottom) {
                    take(
                        pixel,
                        quotient([0, 1].map(|c| t[c] * (1.0 - fy) + b[c] * fy)),
                    );
                }
            });
    }
}

/// V of a blurred (sum w L m, sum w m) pair: the normalised convolution, 0 where no present
/// pixel is within reach.
fn quotient([num, den]: [f64; 2]) -> f64 {
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}

/// Rows a task of a full-resolution scale blurs and takes at once: its horizontal blurs cover
/// the radius's rows either side too (at most 8 for the default scales, an eighth more work at
/// each edge), and its band of across-blurred rows (about 1 MB at 768 pixels wide) stays in
/// the core's cache for the vertical blur.
const BAND_ROWS: usize = 64;

/// Reinhard's local operator's parameters (`Operator::ReinhardLocal`).
pub(super) struct ReinhardLocal {
    pub key: f64,
    pub alpha1: f64,
    pub ratio: f64,
    pub phi: f64,
    pub epsilon: f64,
    pub scales: u32,
}

/// Reinhard 2002 automatic dodging-and-burning: per pixel, the largest scale s_m at which the
/// centre-surround activity |V1 - V2| / (2^phi a / s^2 + V1) stays below epsilon (scanning up
/// from s = 1 and stopping at the first failure), then L_d = L / (1 + V1(s_m)). The Gaussians
/// are blurred on the pyramid ([`reinhard_blurs`]) or at full resolution (`Filters::Exact`).
pub(super) fn reinhard_local(
    scene: &Scene,
    stats: &LogLuminanceStats,
    p: &ReinhardLocal,
    filters: Filters,
) -> Vec<f64> {
    let scaled: Vec<f64> = scene
        .lum
        .par_iter()
        .map(|&l| {
            if l.is_finite() && l > 0.0 {
                p.key * (l.ln() - stats.mean_log).exp()
            } else {
                0.0
            }
        })
        .collect();
    let mask: Vec<f64> = scene
        .lum
        .par_iter()
        .map(|l| if l.is_nan() { 0.0 } else { 1.0 })
        .collect();
    let sigmas: Vec<f64> = (0..=p.scales)
        .map(|i| blur_sigma(p.alpha1, p.ratio, i))
        .collect();
    let level_of = match filters {
        Filters::Accelerated => reinhard_level,
        Filters::Exact => |_| 0,
    };
    let levels: Vec<u32> = sigmas.iter().map(|&s| level_of(s)).collect();
    let deepest = levels.iter().copied().max().unwrap_or(0);
    let mut blurs = ReinhardBlurs::new(&scaled, &mask, scene.width, scene.height, deepest);
    let sharpness = p.phi.exp2() * p.key;
    let mut scans: Vec<Scan> = mask
        .par_iter()
        .map(|&m| Scan {
            previous: 0.0,
            chosen: 0.0,
            settled: m == 0.0,
        })
        .collect();
    blurs.scale_into(sigmas[0], levels[0], &mut scans, |scan, v| {
        scan.previous = v;
        scan.chosen = v;
    });
    for k in 0..p.scales as usize {
        // Once every pixel has stopped, the larger scales change nothing.
        if scans.par_iter().all(|scan| scan.settled) {
            break;
        }
        let s = p.ratio.powi(k as i32);
        let s2 = s * s;
        blurs.scale_into(sigmas[k + 1], levels[k + 1], &mut scans, |scan, v2| {
            let v1 = std::mem::replace(&mut scan.previous, v2);
            if scan.settled {
                return;
            }
            let activity = (v1 - v2) / (sharpness / s2 + v1);
            if activity.abs() >= p.epsilon {
                scan.settled = true;
            } else {
                scan.chosen = v1;
            }
        });
    }
    scans
        .par_iter()
        .zip(&scaled)
        .zip(&mask)
        .map(|((scan, &l), &m)| {
            if m == 0.0 {
                f64::NAN
            } else {
                l / (1.0 + scan.chosen)
            }
        })
        .collect()
}

/// One pixel's scan up the scales of [`reinhard_local`]: V1 of the scale before, V1 of the last
/// scale whose activity stayed below epsilon, and whether the scan has stopped (missing pixels
/// from the start).
struct Scan {
    previous: f64,
    chosen: f64,
    settled: bool,
}

/// Durand & Dorsey 2002: log10 luminance l (missing and black pixels have weight 0) is split
/// into a base, its bilateral filter, and the detail l - base. The base is compressed so that
/// its range becomes log10(contrast) (never expanded) with its maximum at 1; the detail is kept.
/// The bilateral filter is their piecewise-linear acceleration ([`grid_base`]) or the
/// brute-force sum (`Filters::Exact`).
pub(super) fn durand(
    scene: &Scene,
    contrast: f64,
    sigma_spatial: f64,
    sigma_range: f64,
    filters: Filters,
) -> Vec<f64> {
    let (width, height) = (scene.width, scene.height);
    let log_l: Vec<f64> = scene
        .lum
        .par_iter()
        .map(|&l| {
            if l.is_finite() && l > 0.0 {
                l.log10()
            } else {
                f64::NAN
            }
        })
        .collect();
    let base = match filters {
        Filters::Accelerated => grid_base(&log_l, width, height, sigma_spatial, sigma_range),
        Filters::Exact => {
            let sigma_px = durand_sigma_pixels(sigma_spatial, width as u32, height as u32);
            bilateral_base(&log_l, width, height, sigma_px, sigma_range)
        }
    };
    let finite = base.iter().copied().filter(|b| b.is_finite());
    let base_max = finite.clone().fold(f64::NEG_INFINITY, f64::max);
    let base_min = finite.fold(f64::INFINITY, f64::min);
    let range = base_max - base_min;
    let compression = if range > 0.0 {
        (contrast.log10() / range).min(1.0)
    } else {
        1.0
    };
    scene
        .lum
        .par_iter()
        .zip(base.par_iter().zip(&log_l))
        .map(|(&l, (&b, &ll))| {
            if l.is_nan() {
                f64::NAN
            } else if b.is_finite() {
                10f64.powf((b - base_max) * compression + (ll - b))
            } else {
                0.0
            }
        })
        .collect()
}

/// Durand & Dorsey's piecewise-linear acceleration of the bilateral filter ([`DurandGrid`]):
/// per intensity level, every pixel's range weight (from its own l) and weighted l are summed
/// onto the grid's cells and blurred there; each pixel interpolates its two levels (bilinear on
/// the grid, linear in l). NaN where l is NaN.
fn grid_base(
    log_l: &[f64],
    width: usize,
    height: usize,
    sigma_spatial: f64,
    sigma_range: f64,
) -> Vec<f64> {
    let finite_l = log_l.iter().copied().filter(|l| l.is_finite());
    let l_max = finite_l.clone().fold(f64::NEG_INFINITY, f64::max);
    let l_min = finite_l.fold(f64::INFINITY, f64::min);
    let grid = DurandGrid::new(
        width as u32,
        height as u32,
        sigma_spatial,
        sigma_range,
        l_min,
        l_max,
    );
    let levels = durand_levels(log_l, width, height, &grid, sigma_range);
    let reads = BilinearReads::on_grid(&grid, width, height);
    (0..width * height)
        .into_par_iter()
        .map(|p| {
            let l = log_l[p];
            if l.is_nan() {
                return f64::NAN;
            }
            let (j, f) = grid.bracket(l);
            let at = |level: u32| {
                let plane = &levels[level as usize];
                let [num, den] = reads.at(plane, p % width, p / width);
                num / den
            };
            (1.0 - f) * at(j) + f * at(j + 1)
        })
        .collect()
}

/// Durand's grid, blurred per level: `levels[j][cell]` = (sum w l, sum w) over the cell's valid
/// pixels, each with its own range weight w = exp(-(l - i_j)^2 / 2 sigma_r^2) (floored at
/// e^[`DURAND_MIN_LOG_WEIGHT`]), then blurred by the grid's Gaussian. Weighting each pixel by
/// its own l (rather than the cell's mean) keeps a highlight smaller than a cell at its own
/// intensity, so the base does not depend on where the highlight falls in its cell.
fn durand_levels(
    log_l: &[f64],
    width: usize,
    height: usize,
    grid: &DurandGrid,
    sigma_range: f64,
) -> Vec<Vec<[f64; 2]>> {
    let z = grid.cell as usize;
    let (gw, gh) = (grid.grid_width as usize, grid.grid_height as usize);
    let radius = grid.radius as isize;
    let spatial: Vec<f64> = (-radius..=radius)
        .map(|k| (-((k * k) as f64) / (2.0 * grid.sigma_cells * grid.sigma_cells)).exp())
        .collect();
    (0..grid.levels)
        .into_par_iter()
        .map(|j| {
            let level = grid.first_level + j as f64 * grid.level_step;
            let weighted: Vec<[f64; 2]> = (0..gw * gh)
                .map(|c| {
                    let (cx, cy) = (c % gw, c / gw);
                    let mut acc = [0.0, 0.0];
                    for y in cy * z..((cy + 1) * z).min(height) {
                        for x in cx * z..((cx + 1) * z).min(width) {
                            let l = log_l[y * width + x];
                            if !l.is_nan() {
                                let d = (l - level) / sigma_range;
                                let w = (-0.5 * d * d).max(DURAND_MIN_LOG_WEIGHT).exp();
                                acc[0] += w * l;
                                acc[1] += w;
                            }
                        }
                    }
                    acc
                })
                .collect();
            let across = blur_pairs(&weighted, gw, gh, &spatial, true);
            blur_pairs(&across, gw, gh, &spatial, false)
        })
        .collect()
}

/// One direction of a separable blur of (value, weight) pairs on a `width` x `height` grid with
/// the taps `weights` (offsets -r..=r); taps outside the grid are left out.
fn blur_pairs(
    src: &[[f64; 2]],
    width: usize,
    height: usize,
    weights: &[f64],
    horizontal: bool,
) -> Vec<[f64; 2]> {
    let mut out = vec![[0.0, 0.0]; width * height];
    blur_pairs_into(src, width, height, weights, horizontal, &mut out);
    out
}

/// [`blur_pairs`] into `out` (`width` x `height` pairs, overwritten).
fn blur_pairs_into(
    src: &[[f64; 2]],
    width: usize,
    height: usize,
    weights: &[f64],
    horizontal: bool,
    out: &mut [[f64; 2]],
) {
    out.par_chunks_mut(width.max(1))
        .enumerate()
        .for_each_init(Vec::new, |padded, (y, row)| {
            if horizontal {
                blur_row_across(&src[y * width..(y + 1) * width], weights, padded, row);
            } else {
                blur_row_down(src, width, height, weights, y, row);
            }
        });
}

/// One row of the horizontal blur of [`blur_pairs`]: `src_row` blurred into `row`; `padded` is
/// the caller's, reused from row to row. Each output adds its taps in order from -r, as pixel
/// by pixel, but four taps a pass over the row.
fn blur_row_across(
    src_row: &[[f64; 2]],
    weights: &[f64],
    padded: &mut Vec<[f64; 2]>,
    row: &mut [[f64; 2]],
) {
    // The row between `radius` zero pairs: a tap beyond the edge adds w · 0 = +0, which leaves
    // every sum bit for bit as leaving the tap out does (x + 0 = x for every x but -0, and the
    // sums start at +0 and never become -0: in round-to-nearest +0 + -0 and x - x are +0).
    let (width, radius) = (src_row.len(), weights.len() / 2);
    padded.clear();
    padded.resize(width + 2 * radius, [0.0, 0.0]);
    padded[radius..radius + width].copy_from_slice(src_row);
    let taps: Vec<_> = (0..weights.len())
        .map(|t| (&padded[t..t + width], weights[t]))
        .collect();
    add_taps(row, &taps);
}

/// Row `y` of the vertical blur of [`blur_pairs`] of the `width` x `height` grid `src`, into
/// `row`: the rows within reach, in order from -r, four a pass.
fn blur_row_down(
    src: &[[f64; 2]],
    width: usize,
    height: usize,
    weights: &[f64],
    y: usize,
    row: &mut [[f64; 2]],
) {
    let radius = weights.len() / 2;
    let taps: Vec<_> = (0..weights.len())
        .filter_map(|t| {
            let sy = (y + t).checked_sub(radius).filter(|&sy| sy < height)?;
            Some((&src[sy * width..(sy + 1) * width], weights[t]))
        })
        .collect();
    add_taps(row, &taps);
}

/// acc = sum of w · src over `taps`, in their order, pair by pair: four taps a pass over the
/// row (one load and store of the accumulator for four terms), the last one to three in one
/// more pass; the same additions in the same order as tap by tap.
fn add_taps(acc: &mut [[f64; 2]], taps: &[(&[[f64; 2]], f64)]) {
    let mut fours = taps.chunks_exact(4);
    let mut first = true;
    for four in &mut fours {
        add_pass(acc, [four[0], four[1], four[2], four[3]], first);
        first = false;
    }
    match *fours.remainder() {
        [] if first => acc.fill([0.0, 0.0]),
        [] => {}
        [a] => add_pass(acc, [a], first),
        [a, b] => add_pass(acc, [a, b], first),
        [a, b, c] => add_pass(acc, [a, b, c], first),
        _ => unreachable!("chunks_exact(4) leaves at most three"),
    }
}

/// acc = (acc or +0 on the `first` pass) + w_1 src_1 + ... + w_N src_N, in that order.
fn add_pass<const N: usize>(acc: &mut [[f64; 2]], taps: [(&[[f64; 2]], f64); N], first: bool) {
    let n = acc.len();
    let taps = taps.map(|(src, w)| (&src[..n], w));
    for (i, a) in acc.iter_mut().enumerate() {
        for c in 0..2 {
            let mut sum = if first { 0.0 } else { a[c] };
            for (src, w) in &taps {
                sum += w * src[i][c];
            }
            a[c] = sum;
        }
    }
}

/// Bilinear reads at full-resolution pixels of pairs stored on a grid of `cell`-pixel cells
/// (`grid_width` x `grid_height`): cell c's centre is pixel (c + 0.5) cell - 0.5; outside the
/// outermost centres the edge cells are used. Each column's and row's two cells and weight are
/// found once, not at every pixel.
struct BilinearReads {
    grid_width: usize,
    grid_height: usize,
    columns: Vec<(usize, usize, f64)>,
    rows: Vec<(usize, usize, f64)>,
}

impl BilinearReads {
    fn new(cell: u32, grid_width: u32, grid_height: u32, width: usize, height: usize) -> Self {
        let axis = |p: usize, n: u32| -> (usize, usize, f64) {
            let u = ((p as f64 + 0.5) / cell as f64 - 0.5).clamp(0.0, (n - 1) as f64);
            let i0 = u.floor() as usize;
            let i1 = (i0 + 1).min(n as usize - 1);
            (i0, i1, u - i0 as f64)
        };
        BilinearReads {
            grid_width: grid_width as usize,
            grid_height: grid_height as usize,
            columns: (0..width).map(|x| axis(x, grid_width)).collect(),
            rows: (0..height).map(|y| axis(y, grid_height)).collect(),
        }
    }

    fn on_grid(grid: &DurandGrid, width: usize, height: usize) -> Self {
        Self::new(grid.cell, grid.grid_width, grid.grid_height, width, height)
    }

    /// The first half of every read: each grid row of `plane` interpolated along x at every
    /// pixel column, into `out` (grid rows x width pairs). A pixel row then blends two of these
    /// rows ([`BilinearReads::rows_of`]), which gives [`BilinearReads::at`] bit for bit: the
    /// same products and sums in the same order, each along-row value found once for the
    /// `cell` pixel rows that use it.
    fn along_rows(&self, plane: &[[f64; 2]], out: &mut Vec<[f64; 2]>) {
        let width = self.columns.len();
        out.resize(self.grid_height * width, [0.0, 0.0]);
        out.par_chunks_mut(width.max(1))
            .zip(plane.par_chunks(self.grid_width))
            .for_each(|(row, grid_row)| {
                for (o, &(x0, x1, fx)) in row.iter_mut().zip(&self.columns) {
                    *o = [0, 1].map(|c| grid_row[x0][c] * (1.0 - fx) + grid_row[x1][c] * fx);
                }
            });
    }

    /// Pixel row `y`'s two along-row interpolations from [`BilinearReads::along_rows`] (upper
    /// and lower grid row) and the weight of the lower one.
    fn rows_of<'p>(
        &self,
        along: &'p [[f64; 2]],
        y: usize,
    ) -> (&'p [[f64; 2]], &'p [[f64; 2]], f64) {
        let width = self.columns.len();
        let (y0, y1, fy) = self.rows[y];
        (
            &along[y0 * width..][..width],
            &along[y1 * width..][..width],
            fy,
        )
    }

    /// The pair at pixel (x, y) of `plane`.
    fn at(&self, plane: &[[f64; 2]], x: usize, y: usize) -> [f64; 2] {
        let (x0, x1, fx) = self.columns[x];
        let (y0, y1, fy) = self.rows[y];
        let at = |cx: usize, cy: usize| plane[cy * self.grid_width + cx];
        [0, 1].map(|k| {
            let top = at(x0, y0)[k] * (1.0 - fx) + at(x1, y0)[k] * fx;
            let bottom = at(x0, y1)[k] * (1.0 - fx) + at(x1, y1)[k] * fx;
            top * (1.0 - fy) + bottom * fy
        })
    }
}
