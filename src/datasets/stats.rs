//! Statistics of an array's values for `hdrvis info`: counts, extremes, the smallest non-zero
//! magnitude, a count per decade of |v| and the smallest gap between distinct values. They
//! accumulate slab by slab ([`ValueStats::add`]), so an array larger than memory is described
//! exactly from reads of bounded size. The smallest gap needs the values in order: an array that
//! fits the memory budget is sorted whole; a larger one is sorted a range of values at a time,
//! the ranges cut from a histogram of the values' leading bits ([`GapBuckets`]) so that each
//! fits the budget, one more pass over the file per range.

use rayon::prelude::*;

use crate::error::Result;

/// Decades of |v| a finite non-zero f64 can fall in: 1e-324 .. 1e308.
const LOWEST_DECADE: i32 = -324;
const DECADES: usize = 633;
/// Leading bits of a value's order key that pick its [`GapBuckets`] bucket.
const BUCKET_BITS: u32 = 20;

/// Statistics of one array's values.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ValueStats {
    pub count: usize,
    pub finite: usize,
    pub nan: usize,
    pub infinite: usize,
    pub zeros: usize,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub min_abs_nonzero: Option<f64>,
    pub max_abs: Option<f64>,
    /// Smallest non-zero difference between two distinct finite values.
    pub min_gap: Option<f64>,
    /// Finite non-zero values per decade of |v|, from 1e-324 up.
    pub decades: Vec<usize>,
}

impl Default for ValueStats {
    fn default() -> Self {
        ValueStats {
            count: 0,
            finite: 0,
            nan: 0,
            infinite: 0,
            zeros: 0,
            min: None,
            max: None,
            min_abs_nonzero: None,
            max_abs: None,
            min_gap: None,
            decades: vec![0; DECADES],
        }
    }
}

/// The decade of a finite non-zero |v|: floor(log10 |v|).
pub(crate) fn decade_of(v: f64) -> i32 {
    v.abs().log10().floor() as i32
}

fn lesser(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

fn greater(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    }
}

impl ValueStats {
    /// The statistics of values held whole, the smallest gap from sorting them.
    pub(crate) fn of(values: &[f64]) -> Self {
        let mut stats = ValueStats::default();
        stats.add(values);
        let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        finite.par_sort_unstable_by(f64::total_cmp);
        stats.min_gap = min_gap_of_sorted(&finite);
        stats
    }

    /// Adds a slab's values to every statistic but the smallest gap.
    pub(crate) fn add(&mut self, values: &[f64]) {
        let part = values
            .par_chunks(1 << 16)
            .fold(ValueStats::default, |mut s, chunk| {
                chunk.iter().for_each(|&v| s.add_one(v));
                s
            })
            .reduce(ValueStats::default, ValueStats::merged);
        *self = std::mem::take(self).merged(part);
    }

    fn add_one(&mut self, v: f64) {
        self.count += 1;
        if v.is_nan() {
            self.nan += 1;
            return;
        }
        if v.is_infinite() {
            self.infinite += 1;
            return;
        }
        self.finite += 1;
        self.min = lesser(self.min, Some(v));
        self.max = greater(self.max, Some(v));
        if v == 0.0 {
            self.zeros += 1;
            return;
        }
        self.min_abs_nonzero = lesser(self.min_abs_nonzero, Some(v.abs()));
        self.max_abs = greater(self.max_abs, Some(v.abs()));
        self.decades[(decade_of(v) - LOWEST_DECADE) as usize] += 1;
    }

    fn merged(mut self, other: ValueStats) -> ValueStats {
        self.count += other.count;
        self.finite += other.finite;
        self.nan += other.nan;
        self.infinite += other.infinite;
        self.zeros += other.zeros;
        self.min = lesser(self.min, other.min);
        self.max = greater(self.max, other.max);
        self.min_abs_nonzero = lesser(self.min_abs_nonzero, other.min_abs_nonzero);
        self.max_abs = greater(self.max_abs, other.max_abs);
        self.min_gap = lesser(self.min_gap, other.min_gap);
        self.decades
            .iter_mut()
            .zip(&other.decades)
            .for_each(|(a, b)| *a += b);
        self
    }

    /// Finite non-zero values whose floor(log10 |v|) is `decade`.
    pub(crate) fn in_decade(&self, decade: i32) -> usize {
        usize::try_from(decade - LOWEST_DECADE)
            .ok()
            .and_then(|i| self.decades.get(i))
            .copied()
            .unwrap_or(0)
    }

    /// Eq. 1 with d = the smallest non-zero |v|; `None` when every value is 0 or missing.
    pub(crate) fn dynamic_range(&self) -> Option<f64> {
        Some((self.max? - self.min?) / self.min_abs_nonzero?)
    }

    /// Eq. 1 with d = the smallest gap between distinct values.
    pub(crate) fn dynamic_range_by_gap(&self) -> Option<f64> {
        Some((self.max? - self.min?) / self.min_gap?)
    }
}

/// The smallest non-zero difference between neighbours of finite values sorted ascending.
fn min_gap_of_sorted(sorted: &[f64]) -> Option<f64> {
    sorted
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .reduce(f64::min)
}

/// A key whose unsigned order is the values' order (`f64::total_cmp`).
fn order_key(v: f64) -> u64 {
    let bits = v.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

fn bucket_of(v: f64) -> usize {
    (order_key(v) >> (64 - BUCKET_BITS)) as usize
}

/// How many finite values fall in each bucket of leading order-key bits: each bucket holds a
/// contiguous range of values, so consecutive buckets can be sorted a group at a time.
pub(crate) struct GapBuckets(Vec<u64>);

impl GapBuckets {
    pub(crate) fn new() -> Self {
        GapBuckets(vec![0; 1 << BUCKET_BITS])
    }

    pub(crate) fn add(&mut self, values: &[f64]) {
        for &v in values.iter().filter(|v| v.is_finite()) {
            self.0[bucket_of(v)] += 1;
        }
    }

    /// Runs of consecutive buckets holding at most `budget` values each (bucket index ranges,
    /// end exclusive); a bucket that alone holds more is a run of its own.
    fn groups(&self, budget: u64) -> Vec<std::ops::Range<usize>> {
        let mut groups = Vec::new();
        let (mut start, mut held) = (0, 0u64);
        for (i, &n) in self.0.iter().enumerate() {
            if held > 0 && held + n > budget {
                groups.push(start..i);
                (start, held) = (i, 0);
            }
            held += n;
        }
        if held > 0 {
            groups.push(start..self.0.len());
        }
        groups
    }
}

/// What finding the smallest gap of a streamed array took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum GapPasses {
    /// This many more passes over the array, one per range of values.
    Passes(usize),
    /// One bucket of values holds more distinct values than the budget: the gap is not
    /// computed.
    TooDense { bucket_values: u64 },
}

/// The smallest gap between distinct finite values of an array seen through `each_slab`, which
/// hands every slab of the array to its argument once per call; `buckets` counts the array's
/// finite values and `budget` is how many values may be held at once.
pub(crate) fn streamed_min_gap(
    buckets: &GapBuckets,
    budget: u64,
    mut each_slab: impl FnMut(&mut dyn FnMut(&[f64])) -> Result<()>,
) -> Result<(Option<f64>, GapPasses)> {
    let budget = budget.max(2);
    let groups = buckets.groups(budget);
    let mut gap: Option<f64> = None;
    let mut previous: Option<f64> = None;
    for group in &groups {
        let held: u64 = buckets.0[group.clone()].iter().sum();
        let mut values = Vec::with_capacity(held.min(budget) as usize);
        let mut distinct_over = None;
        each_slab(&mut |slab| {
            if distinct_over.is_some() {
                return;
            }
            values.extend(
                slab.iter()
                    .copied()
                    .filter(|v| v.is_finite() && group.contains(&bucket_of(*v))),
            );
            // A bucket denser than the budget: only its distinct values are kept, which is
            // enough when it holds repeats; when even those exceed the budget, give up.
            if values.len() as u64 > budget {
                values.par_sort_unstable_by(f64::total_cmp);
                values.dedup_by(|a, b| a.total_cmp(b).is_eq());
                if values.len() as u64 > budget {
                    distinct_over = Some(held);
                }
            }
        })?;
        if let Some(bucket_values) = distinct_over {
            return Ok((None, GapPasses::TooDense { bucket_values }));
        }
        values.par_sort_unstable_by(f64::total_cmp);
        gap = lesser(gap, min_gap_of_sorted(&values));
        // The groups cover consecutive ranges of values: the last of one and the first of the
        // next are neighbours in the whole array's order.
        if let (Some(last), Some(&first)) = (previous, values.first()) {
            gap = lesser(gap, Some(first - last).filter(|d| *d > 0.0));
        }
        previous = values.last().copied().or(previous);
    }
    Ok((gap, GapPasses::Passes(groups.len())))
}

/// At most this many decade rows; smaller magnitudes are gathered into the first row.
const MAX_DECADE_ROWS: i32 = 40;
/// Widest histogram bar, in columns.
const BAR_WIDTH: usize = 60;

/// One row per decade of |v| from the smallest non-zero magnitude to the largest, bars scaled
/// to the fullest row; zeros get their own row.
pub(crate) fn histogram(stats: &ValueStats) -> String {
    use std::fmt::Write as _;
    let mut text = String::from("histogram of |v| (one row per decade):\n");
    let (Some(lo), Some(hi)) = (stats.min_abs_nonzero, stats.max_abs) else {
        text.push_str("  (no non-zero finite values)\n");
        return text;
    };
    let top = decade_of(hi);
    let lowest = decade_of(lo);
    let bottom = lowest.max(top - MAX_DECADE_ROWS + 1);
    let counts: Vec<usize> = (bottom..=top)
        .map(|d| {
            if d == bottom {
                (lowest..=bottom).map(|e| stats.in_decade(e)).sum()
            } else {
                stats.in_decade(d)
            }
        })
        .collect();
    let fullest = counts
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .max(stats.zeros)
        .max(1);
    let bar = |count: usize| {
        // Any non-empty row shows at least one mark, so sparse decades stay visible.
        let width = (count * BAR_WIDTH).div_ceil(fullest);
        "#".repeat(width)
    };
    if stats.zeros > 0 {
        let _ = writeln!(
            text,
            "  {:>21} | {:<BAR_WIDTH$} {}",
            "0",
            bar(stats.zeros),
            stats.zeros
        );
    }
    for (row, &count) in counts.iter().enumerate() {
        let decade = bottom + row as i32;
        let label = if row == 0 && decade > lowest {
            format!("< 1e{}", decade + 1)
        } else {
            format!("[1e{decade}, 1e{})", decade + 1)
        };
        let _ = writeln!(text, "  {label:>21} | {:<BAR_WIDTH$} {count}", bar(count));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_and_dynamic_range_of_a_small_volume() {
        // Values chosen so every number is known: min -2, max 1000, smallest |v| 1e-3,
        // D = 1002 / 1e-3 = 1.002e6; distinct sorted values -2, 0, 1e-3, 1, 1000: gap 1e-3.
        let data = [-2.0, 0.0, 1e-3, 1.0, 1000.0, f64::NAN, f64::INFINITY, 1.0];
        let s = ValueStats::of(&data);
        assert_eq!((s.min, s.max), (Some(-2.0), Some(1000.0)));
        assert_eq!((s.nan, s.infinite, s.zeros, s.finite), (1, 1, 1, 6));
        assert_eq!(s.min_abs_nonzero, Some(1e-3));
        assert_eq!(s.min_gap, Some(1e-3));
        assert_eq!((s.in_decade(-3), s.in_decade(0), s.in_decade(3)), (1, 3, 1));
        assert!((s.dynamic_range().unwrap() - 1.002e6).abs() < 1e-6);
    }

    /// Values over many decades, both signs, repeats, zeros of both signs, NaN and infinities.
    fn awkward_values(n: usize) -> Vec<f64> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        (0..n)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                match i % 97 {
                    0 => f64::NAN,
                    1 => f64::NEG_INFINITY,
                    2 => -0.0,
                    3 => 0.0,
                    4 => 12.5,
                    _ => (u - 0.3) * 10f64.powf(12.0 * u - 6.0),
                }
            })
            .collect()
    }

    #[test]
    fn streamed_statistics_equal_those_of_the_whole_array() {
        let values = awkward_values(200_003);
        let whole = ValueStats::of(&values);
        let mut streamed = ValueStats::default();
        let mut buckets = GapBuckets::new();
        for slab in values.chunks(7_919) {
            streamed.add(slab);
            buckets.add(slab);
        }
        // Budgets from one pass for everything to thousands of small ranges, all exact.
        for budget in [u64::MAX, 150_000, 10_000, 1_000] {
            let mut passes_run = 0;
            let (gap, passes) = streamed_min_gap(&buckets, budget, |visit| {
                passes_run += 1;
                values.chunks(7_919).for_each(&mut *visit);
                Ok(())
            })
            .unwrap();
            assert_eq!(gap, whole.min_gap, "budget {budget}");
            assert_eq!(passes, GapPasses::Passes(passes_run), "budget {budget}");
            if budget == u64::MAX {
                assert_eq!(passes_run, 1);
            }
            if budget == 10_000 {
                assert!(passes_run >= 19, "{passes_run} passes");
            }
        }
        streamed.min_gap = whole.min_gap;
        assert_eq!(streamed, whole);
        assert_eq!(histogram(&streamed), histogram(&whole));
    }

    #[test]
    fn a_range_too_dense_for_the_budget_is_named_not_guessed() {
        // The smallest gap of `values` streamed in slabs of 10 within a budget of 100 values.
        let streamed = |values: &[f64]| {
            let mut buckets = GapBuckets::new();
            buckets.add(values);
            streamed_min_gap(&buckets, 100, |visit| {
                values.chunks(10).for_each(&mut *visit);
                Ok(())
            })
            .unwrap()
        };
        // 1000 distinct values within one bucket (the same leading 20 bits).
        let values: Vec<f64> = (0..1000).map(|i| 1.0 + f64::from(i) * 1e-9).collect();
        let (gap, passes) = streamed(&values);
        assert_eq!(gap, None);
        assert_eq!(
            passes,
            GapPasses::TooDense {
                bucket_values: 1000
            }
        );
        // Repeats are not distinct: a dense bucket of few values still gives its gap.
        let repeats: Vec<f64> = (0..1000).map(|i| 1.0 + f64::from(i % 3) * 0.5e-9).collect();
        assert_eq!(streamed(&repeats).0, ValueStats::of(&repeats).min_gap);
    }

    #[test]
    fn order_keys_sort_as_the_values() {
        let mut v = vec![-1e300, -2.0, -1e-300, -0.0, 0.0, 5e-324, 1.0, 3.5, f64::MAX];
        let keys: Vec<u64> = v.iter().map(|&x| order_key(x)).collect();
        assert!(keys.windows(2).all(|w| w[0] < w[1]), "{keys:?}");
        v.reverse();
        assert!(v.windows(2).all(|w| bucket_of(w[0]) >= bucket_of(w[1])));
    }
}
