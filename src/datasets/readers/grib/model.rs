//! The GRIB reader's own model: a message's description (parameter, level, times, grid), the
//! variables the messages make, and the Gaussian latitudes both editions' grids need.

use crate::datasets::readers::variables::NcAttribute;

/// A parameter's variable name, long name and units.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Param {
    pub name: String,
    pub long_name: String,
    pub units: Option<String>,
}

/// A level: ecCodes' `typeOfLevel`, its value (hPa for pressure) and unit.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Level {
    pub type_name: String,
    pub value: Option<f64>,
    pub units: Option<String>,
}

/// A grid's node positions in the order of the message's values (rows of `ni` points).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct GridInfo {
    /// ecCodes' `gridType`: regular_ll, regular_gg, reduced_gg, rotated_ll, lambert,
    /// polar_stereographic, mercator.
    pub kind: String,
    pub ni: usize,
    pub nj: usize,
    /// Latitude and longitude of every node, `nj` rows of `ni`.
    pub lats: Vec<f64>,
    pub lons: Vec<f64>,
    /// The message scans rows in alternating directions; nodes (and values when read) are
    /// turned to run one way.
    pub alternate_rows: bool,
    /// A reduced (quasi-regular) Gaussian grid's points in each row as the message stores them
    /// (its `pl` list): the nodes are the regular grid of `ni` = the longest row's points, and
    /// values are interpolated along each row onto them when read ([`GridInfo::fill_rows`]).
    pub row_points: Option<Vec<usize>>,
}

/// The most rows a Gaussian grid may have between a pole and the equator: regular Gaussian
/// grids in archives go to N2560 (ERA5's is N320); the latitudes take O(N²) work to find.
pub(crate) const MAX_GAUSSIAN_N: usize = 4096;

/// Refuses a grid of `ni` × `nj` points that cannot be meant (none, or more than memory holds
/// for its values and the latitude and longitude of every node) before anything is allocated.
pub(crate) fn check_grid(ni: usize, nj: usize) -> Result<(), String> {
    let points = ni
        .checked_mul(nj)
        .filter(|&p| p > 0)
        .ok_or_else(|| format!("a grid of {ni} × {nj} points"))?;
    crate::model::volume::check_allocation(points as u64 * 8 * 4, "GRIB grid")
        .map_err(|e| format!("a grid of {ni} × {nj} points: {e}"))
}

impl GridInfo {
    /// A grid of `lats` rows by `lons` columns.
    pub(crate) fn regular(kind: &str, lats: Vec<f64>, lons: Vec<f64>) -> GridInfo {
        let (ni, nj) = (lons.len(), lats.len());
        GridInfo {
            kind: kind.to_string(),
            ni,
            nj,
            lats: lats
                .iter()
                .flat_map(|&la| std::iter::repeat_n(la, ni))
                .collect(),
            lons: (0..nj).flat_map(|_| lons.iter().copied()).collect(),
            alternate_rows: false,
            row_points: None,
        }
    }

    /// A global reduced Gaussian grid with rows at `lats` of `row_points` points each, every
    /// row from 0° (the first and last longitudes the message gives, `lo1` and `lo2`, must say
    /// so; a regional grid is refused): its nodes are the regular grid of the longest row's
    /// points, the grid cdo's `setgridtype,regular` makes of it.
    pub(crate) fn reduced(
        lats: Vec<f64>,
        row_points: Vec<usize>,
        (lo1, lo2): (f64, f64),
    ) -> Result<GridInfo, String> {
        if row_points.len() != lats.len() || row_points.contains(&0) {
            return Err(format!(
                "a reduced grid of {} rows with {} row lengths (some empty or missing)",
                lats.len(),
                row_points.len()
            ));
        }
        let ni = row_points.iter().copied().max().unwrap_or(0);
        if lo1 != 0.0 || (lo2 - (360.0 - 360.0 / ni as f64)).abs() > 1e-3 {
            return Err(format!(
                "a reduced grid over longitudes {lo1}° to {lo2}° is not read (global ones are)"
            ));
        }
        check_grid(ni, lats.len())?;
        let lons = (0..ni).map(|i| i as f64 * 360.0 / ni as f64).collect();
        let mut grid = GridInfo::regular("reduced_gg", lats, lons);
        grid.row_points = Some(row_points);
        Ok(grid)
    }

    /// How many values the message stores: a reduced grid's rows' points, else every node.
    pub(crate) fn stored_points(&self) -> usize {
        match &self.row_points {
            Some(pl) => pl.iter().sum(),
            None => self.ni * self.nj,
        }
    }

    /// A reduced grid's stored values (rows of `row_points`) on the grid's `ni` longitudes:
    /// linear along each row between its two nearest points, around the circle; a node on a
    /// stored point takes its value exactly, and a node next to a missing point is missing.
    /// Other grids' values are returned as they are.
    pub(crate) fn fill_rows(&self, stored: Vec<f64>) -> Vec<f64> {
        let Some(pl) = &self.row_points else {
            return stored;
        };
        let ni = self.ni;
        let mut out = Vec::with_capacity(ni * self.nj);
        let mut start = 0;
        for &n in pl {
            let row = &stored[start..start + n];
            start += n;
            out.extend((0..ni).map(|i| {
                // Node i at i·360/ni lies between stored points k and k + 1 (of n).
                let (k, rest) = ((i * n) / ni, (i * n) % ni);
                if rest == 0 {
                    return row[k];
                }
                let t = rest as f64 / ni as f64;
                (1.0 - t) * row[k] + t * row[(k + 1) % n]
            }));
        }
        out
    }

    /// This grid's rotated coordinates turned to true ones, for a grid whose southern pole of
    /// rotation is at (`south_lat`, `south_lon`).
    pub(crate) fn rotated(mut self, south_lat: f64, south_lon: f64) -> Result<GridInfo, String> {
        let pole = crate::model::RotatedPole::new(-south_lat, south_lon + 180.0, 0.0)
            .map_err(|e| e.to_string())?;
        for (la, lo) in self.lats.iter_mut().zip(self.lons.iter_mut()) {
            (*la, *lo) = pole.to_true(*la, *lo);
        }
        Ok(self)
    }

    /// Longitudes of a grid whose rows cross the 0° meridian eastward (first point 350°, last
    /// 19°) written as ecCodes gives them: increasing through the seam from negative values
    /// (−10° … 19°), not back from 359.9° to 0° nor on past 360°.
    pub(crate) fn across_the_seam(mut self) -> GridInfo {
        let ni = self.ni;
        for row in self.lons.chunks_mut(ni.max(1)) {
            if let Some(drop) = row.windows(2).position(|w| w[1] < w[0] - 180.0) {
                row[..=drop].iter_mut().for_each(|l| *l -= 360.0);
            } else if row.first().is_some_and(|&l| l >= 180.0)
                && row.last().is_some_and(|&l| l > 360.0)
            {
                row.iter_mut().for_each(|l| *l -= 360.0);
            }
        }
        self
    }

    /// A grid scanned in rows of alternating direction (GRIB2 flag table 3.4, bit 4: a
    /// boustrophedon) turned to run one way, as cfgrib turns it, when that makes it
    /// rectilinear; its values are turned alike when read ([`turn_alternate_rows`]).
    pub(crate) fn rows_one_way(self) -> GridInfo {
        if self.ni < 2 || self.nj < 2 || self.is_rectilinear() {
            return self;
        }
        let mut turned = self.clone();
        turn_alternate_rows(&mut turned.lats, self.ni);
        turn_alternate_rows(&mut turned.lons, self.ni);
        if turned.is_rectilinear() {
            turned.alternate_rows = true;
            turned
        } else {
            self
        }
    }

    /// Whether every row has one latitude and every row the same longitudes: then the grid has
    /// one-dimensional coordinates.
    pub(crate) fn is_rectilinear(&self) -> bool {
        (0..self.nj).all(|j| {
            let row = j * self.ni;
            (0..self.ni)
                .all(|i| self.lats[row + i] == self.lats[row] && self.lons[row + i] == self.lons[i])
        })
    }
}

/// Every second row of `values` (rows of `ni`) reversed.
pub(crate) fn turn_alternate_rows(values: &mut [f64], ni: usize) {
    values
        .chunks_mut(ni)
        .skip(1)
        .step_by(2)
        .for_each(<[f64]>::reverse);
}

/// One message's description; its values are decoded when read.
#[derive(Clone, Debug)]
pub(crate) struct GribField {
    pub edition: u8,
    pub param: Param,
    pub level: Level,
    /// Reference time, "YYYY-MM-DD hh:mm:ss" (UTC).
    pub reference: String,
    pub step_hours: f64,
    /// ecCodes' `stepType`: "instant", or the statistic over the interval ending at the step
    /// ("avg", "accum", "max", "min").
    pub step_type: String,
    /// Ensemble member (perturbation number), for ensemble products.
    pub number: Option<i64>,
    pub grid: GridInfo,
    /// ecCodes' `packingType`.
    pub packing: String,
    pub centre: u16,
    /// The vertical coordinate parameters of a model-level message (GRIB's PV array): the
    /// hybrid A (Pa) then B coefficients of the N + 1 half levels; empty when the message has
    /// none.
    pub pv: Vec<f64>,
}

/// Where a message lies in its file.
#[derive(Clone, Debug)]
pub(crate) struct Located {
    pub offset: usize,
    pub length: usize,
    /// Which field of the message (GRIB2 messages may hold several).
    pub sub: usize,
    pub field: GribField,
}

/// The latitudes of a Gaussian grid with `n` rows between a pole and the equator, north to
/// south: the zeros of the Legendre polynomial P₂ₙ(sin φ), by Newton's method from the
/// asymptotic first guess (to 1e-14 in sin φ).
pub(crate) fn gaussian_latitudes(n: usize) -> Vec<f64> {
    let rows = 2 * n;
    let mut lats = Vec::with_capacity(rows);
    for k in 1..=rows {
        // First guess: cos(π(k − 1/4)/(2n + 1/2)).
        let mut x = (std::f64::consts::PI * (k as f64 - 0.25) / (rows as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(rows, x);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        lats.push(x.asin().to_degrees());
    }
    lats
}

/// The rows of a Gaussian grid with `n` latitudes between a pole and the equator, from `first`
/// to `last` (which the message gives to a millidegree).
pub(crate) fn gaussian_rows(
    n: usize,
    first: f64,
    last: f64,
    rows: usize,
) -> Result<Vec<f64>, String> {
    let all = gaussian_latitudes(n);
    let near = |lat: f64| all.iter().position(|&l| (l - lat).abs() < 2e-3);
    let (Some(a), Some(b)) = (near(first), near(last)) else {
        return Err(format!("a Gaussian grid N{n} whose first and last rows ({first}°, {last}°) are not among its latitudes"));
    };
    let picked: Vec<f64> = if a <= b {
        all[a..=b].to_vec()
    } else {
        all[b..=a].iter().rev().copied().collect()
    };
    if picked.len() != rows {
        return Err(format!(
            "a Gaussian grid of {rows} rows where its first and last latitude span {}",
            picked.len()
        ));
    }
    Ok(picked)
}

/// Pₙ(x) and its derivative, by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        (p0, p1) = (p1, p2);
    }
    let dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, dp)
}

/// One variable of the presented dataset.
#[derive(Clone, Debug)]
pub(crate) struct GribVariable {
    pub name: String,
    pub dims: Vec<(String, usize)>,
    pub attributes: Vec<(String, NcAttribute)>,
    pub content: Content,
}

/// What a variable's values are: stored (coordinates) or decoded from messages.
#[derive(Clone, Debug)]
pub(crate) enum Content {
    Stored(Vec<f64>),
    /// The message (index into [`GribIndex::messages`]) of each combination of the variable's
    /// dimensions before the grid's two, in C order; `None` where no message holds it.
    Messages(Vec<Option<usize>>),
    /// As `Messages`, each value v read as e^v: surface pressure (Pa) from ECMWF's logarithm
    /// of it (`lnsp`), for the pressure of model levels.
    ExpOfMessages(Vec<Option<usize>>),
}

/// The file's messages and the variables they make.
#[derive(Debug)]
pub(crate) struct GribIndex {
    pub messages: Vec<Located>,
    pub variables: Vec<GribVariable>,
    pub globals: Vec<(String, NcAttribute)>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_latitudes_match_the_published_n32_rows() {
        // The N32 Gaussian grid as ecCodes gives it (codes_get_gaussian_latitudes(32)): first
        // rows 87.863799°, 85.096527°, 82.312913°, the row nearest the equator 1.395307°.
        let lats = gaussian_latitudes(32);
        assert_eq!(lats.len(), 64);
        for (got, want) in lats.iter().zip([87.863799, 85.096527, 82.312913]) {
            assert!((got - want).abs() < 1e-6, "{got} vs {want}");
        }
        assert!((lats[31] - 1.395307).abs() < 1e-6, "{}", lats[31]);
        assert!((lats[31] + lats[32]).abs() < 1e-12);
    }

    #[test]
    fn reduced_rows_are_filled_linearly_around_the_circle() {
        let grid = GridInfo::reduced(vec![45.0, -45.0], vec![4, 2], (0.0, 270.0)).unwrap();
        assert_eq!((grid.ni, grid.nj, grid.stored_points()), (4, 2, 6));
        assert_eq!(grid.lons[..4], [0.0, 90.0, 180.0, 270.0]);
        // The second row's points at 0° and 180°: 90° and 270° lie halfway, around the circle.
        let filled = grid.fill_rows(vec![1.0, 2.0, 3.0, 4.0, 10.0, 20.0]);
        assert_eq!(filled, [1.0, 2.0, 3.0, 4.0, 10.0, 15.0, 20.0, 15.0]);
        let holed = grid.fill_rows(vec![1.0, 2.0, 3.0, 4.0, f64::NAN, 20.0]);
        assert!(holed[4].is_nan() && holed[5].is_nan() && holed[7].is_nan());
        assert_eq!(holed[6], 20.0);
        assert!(GridInfo::reduced(vec![0.0], vec![0], (0.0, 0.0)).is_err());
    }
}
