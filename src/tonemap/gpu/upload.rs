//! The image's way to the GPU: one parallel pass copies the pixels into the mapped upload
//! buffer and scans them (luminance range, values below what GPUs keep), lifting an image with
//! tiny values by a power of two taken off the exposure.

use crate::error::Result;
use crate::gpu::transfer::UploadBuffer;
use crate::gpu::GpuContext;
use rayon::prelude::*;

/// Smallest component magnitude passed to the shaders unchanged: below it (denormals
/// included), a Rec. 709 weighted sum can reach the denormal range, which GPUs may flush to
/// zero (lavapipe does).
const TINY: f32 = 7.7e-34; // about 2^-110

/// What one pass over the pixels learns: whether finite non-zero components below [`TINY`]
/// occur, the largest finite component magnitude, and (when asked) the smallest and largest
/// positive finite Rec. 709 luminance, in f64 as the CPU reference computes it.
#[derive(Clone, Copy, Debug)]
struct PixelScan {
    tiny: bool,
    largest: f32,
    luminance: (f64, f64),
}

impl PixelScan {
    const EMPTY: PixelScan = PixelScan {
        tiny: false,
        largest: 0.0,
        luminance: (f64::INFINITY, 0.0),
    };

    fn of(chunk: &[[f32; 4]], with_luminance: bool) -> PixelScan {
        let mut scan = PixelScan::EMPTY;
        for p in chunk {
            for &v in &p[..3] {
                let a = v.abs();
                if a.is_finite() {
                    scan.tiny |= a != 0.0 && a < TINY;
                    scan.largest = scan.largest.max(a);
                }
            }
            if with_luminance && p.iter().all(|v| v.is_finite()) {
                let y = 0.2126 * (p[0] as f64).max(0.0)
                    + 0.7152 * (p[1] as f64).max(0.0)
                    + 0.0722 * (p[2] as f64).max(0.0);
                if y > 0.0 {
                    scan.luminance = (scan.luminance.0.min(y), scan.luminance.1.max(y));
                }
            }
        }
        scan
    }

    fn merge(self, o: PixelScan) -> PixelScan {
        PixelScan {
            tiny: self.tiny | o.tiny,
            largest: self.largest.max(o.largest),
            luminance: (
                self.luminance.0.min(o.luminance.0),
                self.luminance.1.max(o.luminance.1),
            ),
        }
    }

    fn of_all(pixels: &[[f32; 4]], with_luminance: bool) -> PixelScan {
        pixels
            .par_chunks(SCAN_CHUNK)
            .map(|c| PixelScan::of(c, with_luminance))
            .reduce(|| PixelScan::EMPTY, PixelScan::merge)
    }

    /// log10 of the luminance range, when any pixel is lit.
    fn log10_luminance(&self) -> Option<(f64, f64)> {
        let (lo, hi) = self.luminance;
        (hi > 0.0).then(|| (lo.log10(), hi.log10()))
    }

    /// Stops k to lift the image by (×2^k, taken off the exposure: exact, as a power of two, no
    /// overflow by construction, and invisible in the result since the shaders apply exposure
    /// to ln L after the weighted sum) when it holds tiny values and has headroom below
    /// f32::MAX.
    fn lift(&self) -> Option<i32> {
        if !self.tiny {
            return None;
        }
        let headroom = (f32::MAX / self.largest.max(f32::MIN_POSITIVE))
            .log2()
            .floor() as i32
            - 2;
        Some(headroom.clamp(0, 96)).filter(|&k| k > 0)
    }
}

/// Pixels per chunk of the parallel scans and copies (256 KiB: stays in cache between the
/// copy and the scan of the same chunk).
const SCAN_CHUNK: usize = 1 << 14;

/// When `pixels` hold finite non-zero values below [`TINY`], a copy multiplied by 2^k and the
/// k (stops) to take off the exposure: what [`upload_image`] does, as one function for tests.
#[cfg(test)]
fn lift_tiny_values(pixels: &[[f32; 4]]) -> Option<(Vec<[f32; 4]>, i32)> {
    let k = PixelScan::of_all(pixels, false).lift()?;
    Some((lift_by(pixels, k), k))
}

fn lift_by(pixels: &[[f32; 4]], k: i32) -> Vec<[f32; 4]> {
    let gain = 2f32.powi(k);
    pixels
        .par_iter()
        .map(|p| [p[0] * gain, p[1] * gain, p[2] * gain, p[3]])
        .collect()
}

/// A disjoint piece of a write-only mapping, handed to a worker thread.
struct Piece<'a>(wgpu::WriteOnly<'a, [u8]>);

// SAFETY: a `WriteOnly<[u8]>` is exclusive, write-only access to its bytes, like `&mut [u8]`,
// which is Send; wgpu implements Send for `WriteOnly<T>` with sized `T` only. The pieces come
// from `split_at`, so no two threads reach the same byte.
unsafe impl Send for Piece<'_> {}

/// What [`upload_image`] learnt about the image on its way to the GPU.
pub(super) struct UploadScan {
    /// Stops the upload was lifted by ([`PixelScan::lift`]); taken off the exposure.
    pub(super) lift_ev: i32,
    /// log10 of the smallest and largest positive Rec. 709 luminance of the uploaded values
    /// (when asked for).
    pub(super) log10_luminance: Option<(f64, f64)>,
}

/// Writes `pixels` into `target` (lifted by 2^k when they hold values the GPU would flush) and
/// reports the luminance range when `wants_range`. One parallel pass copies each chunk and
/// scans it while it is in cache; only an image with tiny values is written a second time.
pub(super) fn upload_image(
    ctx: &GpuContext,
    target: &UploadBuffer,
    pixels: &[[f32; 4]],
    wants_range: bool,
) -> Result<UploadScan> {
    let mut scan = PixelScan::EMPTY;
    target.write_with(ctx, std::mem::size_of_val(pixels) as u64, |mut dst| {
        let mut pieces = Vec::with_capacity(pixels.len().div_ceil(SCAN_CHUNK));
        for src in pixels.chunks(SCAN_CHUNK) {
            let (head, rest) = dst.split_at(std::mem::size_of_val(src));
            pieces.push((Piece(head), src));
            dst = rest;
        }
        scan = pieces
            .into_par_iter()
            .map(|(Piece(mut d), s)| {
                d.copy_from_slice(bytemuck::cast_slice(s));
                PixelScan::of(s, wants_range)
            })
            .reduce(|| PixelScan::EMPTY, PixelScan::merge);
    })?;
    let Some(k) = scan.lift() else {
        return Ok(UploadScan {
            lift_ev: 0,
            log10_luminance: if wants_range {
                scan.log10_luminance()
            } else {
                None
            },
        });
    };
    let lifted = lift_by(pixels, k);
    target.write(ctx, bytemuck::cast_slice(&lifted))?;
    Ok(UploadScan {
        lift_ev: k,
        log10_luminance: if wants_range {
            PixelScan::of_all(&lifted, true).log10_luminance()
        } else {
            None
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn tiny_values_are_lifted_exactly() {
        assert!(lift_tiny_values(&[[1e-3, 1.0, 1e30, 1.0]]).is_none());
        let (lifted, k) = lift_tiny_values(&[[1e-40, 0.0, 1e-3, 0.5], [f32::NAN; 4]]).unwrap();
        assert!(k > 0);
        assert_eq!(lifted[0][0] as f64, 1e-40f32 as f64 * 2f64.powi(k));
        assert_eq!(lifted[0][3], 0.5);
        assert!(lifted[1][0].is_nan());
    }
}
