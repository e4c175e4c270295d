//! One colour range for a time series: the range of a NetCDF variable over the steps of its CF
//! time axis (or of a MintPy time series over its dates) that a movie shows, computed once before its frames are drawn, so that every frame
//! maps the same value to the same colour. The steps are read one at a time (only their
//! hyperslabs); missing values are left out. As xarray's plots do with `robust=True`, the range
//! may be the 2nd and 98th percentiles instead of the extremes (numpy's linear interpolation
//! between order statistics), and it may be made symmetric about a centre for diverging maps.

use std::path::Path;

use super::select::{time_axis, Selection};
use super::{mintpy, netcdf};
use crate::error::{Error, Result};

/// What [`series_range`] computes over.
#[derive(Clone, Debug, Default)]
pub struct SeriesOptions {
    /// The variable (default: the first data variable with a CF time axis).
    pub variable: Option<String>,
    /// Positions along the time axis (default: every step).
    pub steps: Option<Vec<i64>>,
    /// The 2nd and 98th percentiles instead of the minimum and maximum.
    pub robust: bool,
    /// Widen the range to be symmetric about this value.
    pub centre: Option<f64>,
}

/// The range `[lo, hi]` of the variable over the chosen steps (see the module documentation).
pub fn series_range(path: &Path, opts: &SeriesOptions) -> Result<[f64; 2]> {
    let series = Series::open(path, opts.variable.as_deref())?;
    let n = series.steps;
    let field = format!(
        "{}: variable '{}', dimension '{}'",
        path.display(),
        series.variable,
        series.dim
    );
    let steps: Vec<usize> = match &opts.steps {
        None => (0..n).collect(),
        Some(s) if s.is_empty() => return Err(Error::invalid(field, "steps is empty")),
        Some(s) => s
            .iter()
            .map(|&i| {
                usize::try_from(i).ok().filter(|&i| i < n).ok_or_else(|| {
                    Error::invalid(
                        field.clone(),
                        format!("step {i} is out of range; expected 0..={}", n as i64 - 1),
                    )
                })
            })
            .collect::<Result<_>>()?,
    };
    let mut values = Vec::new();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &step in &steps {
        for &v in series
            .read_step(path, step)?
            .iter()
            .filter(|v| v.is_finite())
        {
            (lo, hi) = (lo.min(v), hi.max(v));
            if opts.robust {
                values.push(v);
            }
        }
    }
    if lo > hi {
        return Err(Error::format(
            path,
            format!(
                "variable '{}' is missing everywhere in the {} chosen steps",
                series.variable,
                steps.len()
            ),
        ));
    }
    if opts.robust {
        values.sort_by(f64::total_cmp);
        (lo, hi) = (percentile(&values, 2.0), percentile(&values, 98.0));
    }
    Ok(match opts.centre {
        Some(c) => {
            let h = (lo - c).abs().max((hi - c).abs());
            [c - h, c + h]
        }
        None => [lo, hi],
    })
}

/// A variable with a time axis, whichever file holds it: a NetCDF variable's CF time axis, or a
/// MintPy time series' `date` list.
struct Series {
    /// The variable's name, for messages.
    variable: String,
    dim: String,
    steps: usize,
    reader: StepReader,
}

/// How one step is read.
enum StepReader {
    /// A hyperslab: the variable's rank and the time axis' position among its dimensions.
    NetCdf { rank: usize, t: usize },
    /// A selection on the `time` axis of the dataset named by the caller (else the default).
    MintPy { dataset: Option<String> },
}

impl Series {
    fn open(path: &Path, var: Option<&str>) -> Result<Series> {
        if super::Format::of(path)? == super::Format::Hdf5 {
            if let Some(product) = mintpy::open(path)? {
                let steps = mintpy::time_steps(path, &product, var)?.len();
                return Ok(Series {
                    variable: var.unwrap_or("timeseries").to_string(),
                    dim: "time".into(),
                    steps,
                    reader: StepReader::MintPy {
                        dataset: var.map(str::to_string),
                    },
                });
            }
        }
        let axis = time_axis(path, var)?;
        let dims = netcdf::dims_in(&netcdf::list_variables(path)?, &axis.variable);
        let t = dims
            .iter()
            .position(|(d, _)| *d == axis.dim)
            .expect("the time axis is one of the variable's dimensions");
        Ok(Series {
            steps: axis.dates.len(),
            reader: StepReader::NetCdf {
                rank: dims.len(),
                t,
            },
            variable: axis.variable,
            dim: axis.dim,
        })
    }

    /// The values of one step (only its hyperslab is read).
    fn read_step(&self, path: &Path, step: usize) -> Result<Vec<f64>> {
        match &self.reader {
            StepReader::NetCdf { rank, t } => {
                let mut picks = vec![None; *rank];
                picks[*t] = Some(step);
                Ok(netcdf::read_variable_picked(path, &self.variable, &picks)?.data)
            }
            StepReader::MintPy { dataset } => {
                let sel = Selection {
                    index: vec![(self.dim.clone(), step as i64)],
                    at: Vec::new(),
                };
                Ok(super::read_array_sel(path, dataset.as_deref(), None, &sel)?.data)
            }
        }
    }
}

/// The `p`th percentile of sorted `v`, linear between the order statistics around
/// `p / 100 · (len − 1)` (numpy's default).
fn percentile(v: &[f64], p: f64) -> f64 {
    let x = p / 100.0 * (v.len() - 1) as f64;
    let (i, w) = (x.floor() as usize, x - x.floor());
    match v.get(i + 1) {
        Some(&next) => v[i] + w * (next - v[i]),
        None => v[i],
    }
}

#[cfg(test)]
mod tests {
    use super::percentile;

    /// numpy.percentile([1, 2, 3, 4], [2, 50, 98]) = [1.06, 2.5, 3.94].
    #[test]
    fn percentiles_interpolate_as_numpy() {
        let v = [1.0, 2.0, 3.0, 4.0];
        for (p, want) in [
            (2.0, 1.06),
            (50.0, 2.5),
            (98.0, 3.94),
            (100.0, 4.0),
            (0.0, 1.0),
        ] {
            assert!((percentile(&v, p) - want).abs() < 1e-12, "{p}");
        }
    }
}
