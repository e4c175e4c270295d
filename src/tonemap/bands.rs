//! Bands of rows and the buffer windows they bind, for images larger than one storage binding.
//! A buffer may be far larger than what one binding may span (lavapipe: 2047 MiB buffers,
//! 128 MiB bindings; a 4096² RGBA f32 image is 256 MiB), so the tone-mapping passes run over
//! bands of rows and bind, per band, a window (offset and size) of each large buffer. Window
//! offsets must be multiples of the adapter's `min_storage_buffer_offset_alignment`, so a band
//! whose window starts at its own first row has a row count that keeps that alignment, and a
//! window that must start earlier (a halo) starts at the nearest aligned row before it. Pure
//! arithmetic, tested here; `gpu/` records the dispatches.

use crate::error::{Error, Result};

/// Rows [first, first + rows) of an item grid (pixels, or cells of a pyramid level or grid).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Band {
    pub first: u32,
    pub rows: u32,
}

impl Band {
    pub(crate) fn end(&self) -> u32 {
        self.first + self.rows
    }
}

/// A byte range of a buffer to bind, and the first row it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Window {
    pub offset: u64,
    pub size: u64,
    pub first_row: u32,
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// The smallest row count r such that r rows of `row_bytes` are a multiple of `align` bytes:
/// bands that are multiples of it keep every window start aligned.
pub(crate) fn row_step(row_bytes: u64, align: u64) -> u32 {
    (align / gcd(row_bytes.max(1), align)).max(1) as u32
}

/// The window of rows [first, end) of a plane of `row_bytes` rows that starts at byte `base`
/// (itself a multiple of `align`): started at the last row at or before `first` whose offset
/// is aligned.
pub(crate) fn window(base: u64, row_bytes: u64, first: u32, end: u32, align: u64) -> Window {
    debug_assert_eq!(base % align, 0, "plane bases are aligned");
    let step = row_step(row_bytes, align);
    let start = first - first % step;
    Window {
        offset: base + start as u64 * row_bytes,
        size: (end.max(start + 1) - start) as u64 * row_bytes,
        first_row: start,
    }
}

/// Splits `total` rows into bands of `rows` (the last one shorter).
pub(crate) fn split(total: u32, rows: u32) -> Vec<Band> {
    let rows = rows.max(1);
    (0..total.div_ceil(rows))
        .map(|b| {
            let first = b * rows;
            Band {
                first,
                rows: rows.min(total - first),
            }
        })
        .collect()
}

/// The most rows per band, a multiple of `step` unless one band holds all `total` rows, for
/// which `fits(rows)` holds (`fits` must be monotone: fewer rows never need more memory).
/// `what` names the pass in the error when not even `step` rows fit.
pub(crate) fn band_rows(
    total: u32,
    step: u32,
    what: &str,
    fits: impl Fn(u32) -> bool,
) -> Result<u32> {
    if fits(total) {
        return Ok(total);
    }
    let step = step.max(1);
    if step >= total || !fits(step) {
        return Err(Error::invalid(
            "image",
            format!(
                "{what}: {step} row(s) do not fit in one storage binding of this adapter; tone-map a narrower image"
            ),
        ));
    }
    // Largest k with fits(k·step), k·step < total.
    let (mut lo, mut hi) = (1u32, (total - 1) / step);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if fits(mid * step) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    Ok(lo * step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_start_aligned_and_cover_the_rows() {
        for (row_bytes, first, end) in [(16 * 300u64, 37u32, 90u32), (8 * 17, 5, 6), (8 * 64, 0, 3)]
        {
            let w = window(1024, row_bytes, first, end, 256);
            assert_eq!(w.offset % 256, 0);
            assert!(w.first_row <= first);
            assert_eq!(w.offset, 1024 + w.first_row as u64 * row_bytes);
            assert_eq!(w.size, (end - w.first_row) as u64 * row_bytes);
            assert!(first - w.first_row < row_step(row_bytes, 256));
        }
        assert_eq!(row_step(16 * 300, 256), 4);
        assert_eq!(row_step(8 * 17, 256), 32);
        assert_eq!(row_step(4096 * 16, 256), 1);
    }

    #[test]
    fn bands_cover_every_row_once_and_fit() {
        let bands = split(100, 32);
        assert_eq!(bands.len(), 4);
        assert_eq!(bands[3], Band { first: 96, rows: 4 });
        assert_eq!(bands.iter().map(|b| b.rows).sum::<u32>(), 100);
        // 1000 rows of 64 bytes under a 10 000-byte binding: 156 rows, rounded down to 8s.
        let rows = band_rows(1000, 8, "test", |r| r as u64 * 64 <= 10_000).unwrap();
        assert_eq!(rows, 152);
        assert_eq!(band_rows(10, 4, "test", |_| true).unwrap(), 10);
        assert!(band_rows(1000, 8, "test", |r| r < 8).is_err());
    }
}
