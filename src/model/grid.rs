//! The surface model: a 2-D field on a regular grid with x/y (or lon/lat) node coordinates and
//! their units, one or more named properties of the same shape and an optional elevation for
//! relief. Coordinates are stored increasing (rows and columns of a file stored north-to-south or
//! east-to-west are flipped on construction), so image rows map to grid rows the same way for every
//! source. NaN marks a missing value. An axis knows whether it is a longitude, a latitude or a
//! depth ([`CoordKind`], from the file's CF attributes); a grid with longitude along x and latitude
//! along y is geographic, and its map keeps the equirectangular aspect of [`Grid::map_aspect`]. A
//! grid whose y is a depth is drawn with y increasing downward ([`Grid::y_down`]), the one place
//! every drawer of a grid's axes takes the vertical direction from. Each
//! grid gets a unique identity on construction, which the
//! surface renderer uses to key its cached data passes; the fields are private so that identity
//! cannot go stale.

use crate::error::{Error, Result};
use std::sync::atomic::{AtomicU64, Ordering};

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// A fresh identity for something the renderers cache results of (grids, mesh fields): one
/// sequence, so no two things drawn share one.
pub(crate) fn next_id() -> u64 {
    NEXT_ID.fetch_add(1, Ordering::Relaxed)
}

/// What a grid axis measures: plain coordinates, degrees of longitude or latitude, or a depth (a
/// vertical coordinate positive downward, CF's `positive: "down"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CoordKind {
    #[default]
    Plain,
    Longitude,
    Latitude,
    Depth,
}

/// One grid axis: node coordinates (increasing), the axis name, its units and what it measures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridCoords {
    pub name: String,
    pub units: String,
    pub values: Vec<f64>,
    pub kind: CoordKind,
    /// The outer edges of the end cells, as a file's CF `bounds` give them; `None`: half an
    /// end spacing beyond the end nodes.
    pub edges: Option<(f64, f64)>,
}

/// Metres per unit of a length unit as files write it (m, km, cm, mm, and their spellings);
/// `None` for anything else.
pub(crate) fn metres_per_unit(units: &str) -> Option<f64> {
    match units.trim().to_ascii_lowercase().as_str() {
        "m" | "meter" | "meters" | "metre" | "metres" => Some(1.0),
        "km" | "kilometer" | "kilometers" | "kilometre" | "kilometres" => Some(1e3),
        "cm" | "centimeter" | "centimeters" | "centimetre" | "centimetres" => Some(1e-2),
        "mm" | "millimeter" | "millimeters" | "millimetre" | "millimetres" => Some(1e-3),
        _ => None,
    }
}

impl GridCoords {
    /// Node indices 0, 1, ... as coordinates (for files without coordinate arrays).
    pub fn index(name: &str, n: usize) -> GridCoords {
        GridCoords {
            name: name.to_string(),
            units: "node".to_string(),
            values: (0..n).map(|i| i as f64).collect(),
            kind: CoordKind::Plain,
            edges: None,
        }
    }

    /// The file's outer cell edges when they enclose the nodes (bounds that leave a node
    /// outside are not this axis's cells).
    pub fn cell_edges(&self) -> Option<(f64, f64)> {
        let (first, last) = (*self.values.first()?, *self.values.last()?);
        self.edges.filter(|&(lo, hi)| lo <= first && last <= hi)
    }

    /// Mean node spacing (positive).
    pub fn spacing(&self) -> f64 {
        let n = self.values.len();
        if n < 2 {
            1.0
        } else {
            (self.values[n - 1] - self.values[0]) / (n - 1) as f64
        }
    }
}

/// A 2-D field on a regular grid. Values are row-major, index `j * nx + i` for node
/// (`x[i]`, `y[j]`), with x and y increasing.
#[derive(Clone, Debug)]
pub struct Grid {
    id: u64,
    name: String,
    nx: usize,
    ny: usize,
    x: GridCoords,
    y: GridCoords,
    properties: Vec<(String, Vec<f64>)>,
    units: Vec<String>,
    /// Each property's CF `long_name` (empty when the file gives none).
    long_names: Vec<String>,
    elevation: Option<Vec<f64>>,
    /// The radar wavelength (m) of an InSAR product, so a fringe legend can say λ/2.
    wavelength: Option<f64>,
    /// Longitude and latitude along x and y are on a rotated sphere (CF
    /// `rotated_latitude_longitude`): the globe and coastlines place them at their true positions.
    rotated_pole: Option<super::RotatedPole>,
}

impl PartialEq for Grid {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id
    }
}

fn check_axis(axis: &GridCoords, n: usize, which: &str) -> Result<()> {
    if axis.values.len() != n {
        return Err(Error::invalid(
            which,
            format!(
                "{} has {} coordinates but the grid has {n} nodes along it",
                axis.name,
                axis.values.len()
            ),
        ));
    }
    if axis.values.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            which,
            format!("{} coordinates must be finite", axis.name),
        ));
    }
    let inc = axis.values.windows(2).all(|w| w[1] > w[0]);
    let dec = axis.values.windows(2).all(|w| w[1] < w[0]);
    if !(inc || dec) {
        return Err(Error::invalid(
            which,
            format!("{} coordinates must be strictly monotonic", axis.name),
        ));
    }
    if axis.kind == CoordKind::Latitude {
        if let Some(bad) = axis.values.iter().find(|v| v.abs() > 90.0) {
            return Err(Error::invalid(
                which,
                format!(
                    "latitude {} is {bad} degrees; expected values in [-90, 90]",
                    axis.name
                ),
            ));
        }
    }
    Ok(())
}

impl Grid {
    /// A grid from named properties, each `ny * nx` values row-major. `shapes` of the properties
    /// are checked against `[ny, nx]`; a mismatch names the property and both shapes.
    pub fn from_arrays(
        name: &str,
        nx: usize,
        ny: usize,
        properties: Vec<(String, Vec<f64>)>,
    ) -> Result<Grid> {
        Grid::with_coords(
            name,
            GridCoords::index("x", nx),
            GridCoords::index("y", ny),
            properties,
            None,
        )
    }

    /// The full constructor: coordinates (increasing or decreasing; stored increasing),
    /// properties and an optional elevation, all validated.
    pub fn with_coords(
        name: &str,
        x: GridCoords,
        y: GridCoords,
        properties: Vec<(String, Vec<f64>)>,
        elevation: Option<Vec<f64>>,
    ) -> Result<Grid> {
        let (nx, ny) = (x.values.len(), y.values.len());
        if nx < 1 || ny < 1 {
            return Err(Error::invalid("grid", "a grid needs at least one node"));
        }
        if nx > 16384 || ny > 16384 {
            return Err(Error::invalid(
                "grid",
                format!("{nx}x{ny} nodes: at most 16384 per side"),
            ));
        }
        check_axis(&x, nx, "x")?;
        check_axis(&y, ny, "y")?;
        if properties.is_empty() {
            return Err(Error::invalid("grid", "a grid needs at least one property"));
        }
        for (i, (n, v)) in properties.iter().enumerate() {
            if v.len() != nx * ny {
                return Err(Error::invalid(
                    "grid",
                    format!(
                        "property {n:?} has {} values but the grid is {ny}x{nx} (ny x nx) = {} nodes{}",
                        v.len(),
                        nx * ny,
                        properties
                            .first()
                            .filter(|_| i > 0)
                            .map(|(f, _)| format!(" like {f:?}"))
                            .unwrap_or_default()
                    ),
                ));
            }
            if properties[..i].iter().any(|(m, _)| m == n) {
                return Err(Error::invalid(
                    "grid",
                    format!("property {n:?} appears twice"),
                ));
            }
        }
        if let Some(e) = &elevation {
            if e.len() != nx * ny {
                return Err(Error::invalid(
                    "elevation",
                    format!(
                        "{} values but the grid is {ny}x{nx} (ny x nx) = {} nodes",
                        e.len(),
                        nx * ny
                    ),
                ));
            }
        }
        let units = vec![String::new(); properties.len()];
        let long_names = units.clone();
        let mut g = Grid {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            name: name.to_string(),
            nx,
            ny,
            x,
            y,
            properties,
            units,
            long_names,
            elevation,
            wavelength: None,
            rotated_pole: None,
        };
        g.make_increasing();
        Ok(g)
    }

    fn make_increasing(&mut self) {
        let (nx, ny) = (self.nx, self.ny);
        let flip_x = nx > 1 && self.x.values[1] < self.x.values[0];
        let flip_y = ny > 1 && self.y.values[1] < self.y.values[0];
        if !(flip_x || flip_y) {
            return;
        }
        let remap = |v: &mut Vec<f64>| {
            let old = v.clone();
            for j in 0..ny {
                let sj = if flip_y { ny - 1 - j } else { j };
                for i in 0..nx {
                    let si = if flip_x { nx - 1 - i } else { i };
                    v[j * nx + i] = old[sj * nx + si];
                }
            }
        };
        for (_, v) in &mut self.properties {
            remap(v);
        }
        if let Some(e) = &mut self.elevation {
            remap(e);
        }
        if flip_x {
            self.x.values.reverse();
        }
        if flip_y {
            self.y.values.reverse();
        }
    }

    /// A geographic grid: longitudes `lon` (degrees east) along x, latitudes `lat` (degrees
    /// north, within ±90) along y, properties `lat.len() * lon.len()` values row-major.
    pub fn from_lon_lat(
        name: &str,
        lon: Vec<f64>,
        lat: Vec<f64>,
        properties: Vec<(String, Vec<f64>)>,
    ) -> Result<Grid> {
        let axis = |name: &str, units: &str, values, kind| GridCoords {
            name: name.to_string(),
            units: units.to_string(),
            values,
            kind,
            edges: None,
        };
        Grid::with_coords(
            name,
            axis("lon", "degrees_east", lon, CoordKind::Longitude),
            axis("lat", "degrees_north", lat, CoordKind::Latitude),
            properties,
            None,
        )
    }

    /// A grid from one generated or computed field, for tests and generators.
    pub fn from_fn(
        name: &str,
        nx: usize,
        ny: usize,
        f: impl Fn(usize, usize) -> f64,
    ) -> Result<Grid> {
        let mut v = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                v.push(f(i, j));
            }
        }
        Grid::from_arrays(name, nx, ny, vec![(name.to_string(), v)])
    }

    pub fn id(&self) -> u64 {
        self.id
    }
    /// Bytes held by the property and elevation arrays.
    pub fn bytes(&self) -> u64 {
        let values = self.properties.iter().map(|(_, v)| v.len()).sum::<usize>()
            + self.elevation.as_ref().map_or(0, |e| e.len());
        values as u64 * 8
    }
    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn nx(&self) -> usize {
        self.nx
    }
    pub fn ny(&self) -> usize {
        self.ny
    }
    pub fn x(&self) -> &GridCoords {
        &self.x
    }
    pub fn y(&self) -> &GridCoords {
        &self.y
    }
    /// Whether the y axis is drawn increasing downward (its first node at the top of a map): a
    /// depth axis is, every other axis increases upward. Every view that draws the grid's axes
    /// takes the direction from here.
    pub fn y_down(&self) -> bool {
        self.y.kind == CoordKind::Depth
    }

    /// Whether x is a longitude and y a latitude (from the file's CF attributes).
    pub fn is_geographic(&self) -> bool {
        self.x.kind == CoordKind::Longitude && self.y.kind == CoordKind::Latitude
    }

    /// Width over height of the map of a geographic grid: equirectangular with the scale of the
    /// map's central latitude, so one degree of longitude is cos(lat_c) times one degree of
    /// latitude: (lon extent · cos lat_c) / lat extent, the extents reaching half a node spacing
    /// beyond the first and last nodes (the map's edges; pixel centres sit on nodes). `None` for
    /// other grids, whose map has one pixel per node.
    pub fn map_aspect(&self) -> Option<f64> {
        if !self.is_geographic() {
            return None;
        }
        let extent = |c: &GridCoords| {
            let step = c.spacing();
            let (first, last) = (c.values[0], c.values[c.values.len() - 1]);
            (first - step / 2.0, last + step / 2.0)
        };
        let (lon_lo, lon_hi) = extent(&self.x);
        let (lat_lo, lat_hi) = extent(&self.y);
        // A single node has no spacing: one degree stands in for it.
        let span = |lo: f64, hi: f64| if hi > lo { hi - lo } else { 1.0 };
        let lat_c = (0.5 * (lat_lo + lat_hi)).clamp(-90.0, 90.0).to_radians();
        Some(span(lon_lo, lon_hi) * lat_c.cos().max(1e-6) / span(lat_lo, lat_hi))
    }

    pub fn elevation(&self) -> Option<&[f64]> {
        self.elevation.as_deref()
    }
    pub fn property_names(&self) -> Vec<&str> {
        self.properties.iter().map(|(n, _)| n.as_str()).collect()
    }

    /// Index of a property; an unknown name is an error listing the known ones.
    pub(crate) fn property_index(&self, name: &str) -> Result<usize> {
        self.properties
            .iter()
            .position(|(n, _)| n == name)
            .ok_or_else(|| {
                Error::invalid(
                    "property",
                    format!(
                        "grid {:?} has no property {name:?}; known: {}",
                        self.name,
                        self.property_names().join(", ")
                    ),
                )
            })
    }

    /// The values of a property; an unknown name is an error listing the known ones.
    pub fn property(&self, name: &str) -> Result<&[f64]> {
        Ok(&self.properties[self.property_index(name)?].1)
    }

    pub fn property_at(&self, index: usize) -> (&str, &[f64]) {
        let (n, v) = &self.properties[index];
        (n, v)
    }

    pub fn units(&self, index: usize) -> &str {
        &self.units[index]
    }

    /// Sets the units of a property (a new identity is not needed: units do not change pixels).
    pub fn set_units(&mut self, name: &str, units: &str) -> Result<()> {
        let i = self.property_index(name)?;
        self.units[i] = units.to_string();
        Ok(())
    }

    /// Renames the grid (a name changes no pixel).
    pub(crate) fn set_name(&mut self, name: &str) {
        self.name = name.to_string();
    }

    /// A property's descriptive name (CF `long_name`), empty when the file gives none.
    pub fn long_name(&self, index: usize) -> &str {
        &self.long_names[index]
    }

    /// Sets a property's descriptive name; like units, it changes no pixel.
    pub fn set_long_name(&mut self, name: &str, long_name: &str) -> Result<()> {
        let i = self.property_index(name)?;
        self.long_names[i] = long_name.to_string();
        Ok(())
    }

    /// The radar wavelength in metres of an InSAR product (MintPy's `WAVELENGTH`), if known.
    pub fn wavelength(&self) -> Option<f64> {
        self.wavelength
    }

    /// Sets the radar wavelength (m); like units, it changes no pixel, so the identity stays.
    pub(crate) fn set_wavelength(&mut self, metres: Option<f64>) {
        self.wavelength = metres.filter(|w| w.is_finite() && *w > 0.0);
    }

    /// The rotated pole of a grid whose longitudes and latitudes are on a rotated sphere.
    pub fn rotated_pole(&self) -> Option<&super::RotatedPole> {
        self.rotated_pole.as_ref()
    }

    /// Places the grid's longitudes and latitudes on the sphere rotated by `pole` (`None`: true
    /// ones); the grid gets a new identity, since a globe shows it elsewhere.
    pub(crate) fn set_rotated_pole(&mut self, pole: Option<super::RotatedPole>) {
        if self.rotated_pole != pole {
            self.rotated_pole = pole;
            self.id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Takes over what places `other` and its values without being a coordinate or a property
    /// (its rotated pole, its radar wavelength): for a grid derived from `other`.
    pub(crate) fn keep_placement_of(&mut self, other: &Grid) {
        self.set_rotated_pole(other.rotated_pole);
        self.wavelength = other.wavelength;
    }

    /// A grid named `name` of `properties` (name, values, units) on this grid's axes, with its
    /// elevation and placement: for a grid derived from this one.
    pub(crate) fn derived(
        &self,
        name: &str,
        properties: Vec<(String, Vec<f64>, String)>,
    ) -> Result<Grid> {
        let units: Vec<(String, String)> = properties
            .iter()
            .map(|p| (p.0.clone(), p.2.clone()))
            .collect();
        let mut out = Grid::with_coords(
            name,
            self.x.clone(),
            self.y.clone(),
            properties.into_iter().map(|(n, v, _)| (n, v)).collect(),
            self.elevation.clone(),
        )?;
        for (n, u) in units {
            out.set_units(&n, &u)?;
        }
        out.keep_placement_of(self);
        Ok(out)
    }

    /// Adds (or replaces) the elevation; the grid gets a new identity.
    pub fn with_elevation(mut self, elevation: Vec<f64>) -> Result<Grid> {
        if elevation.len() != self.nx * self.ny {
            return Err(Error::invalid(
                "elevation",
                format!(
                    "{} values but the grid is {}x{} (ny x nx)",
                    elevation.len(),
                    self.ny,
                    self.nx
                ),
            ));
        }
        self.elevation = Some(elevation);
        self.id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        Ok(self)
    }

    /// Finite minimum and maximum of a property (None when every value is missing).
    pub fn range(&self, index: usize) -> Option<(f64, f64)> {
        let v = &self.properties[index].1;
        let mut r: Option<(f64, f64)> = None;
        for &x in v.iter().filter(|x| x.is_finite()) {
            r = Some(match r {
                None => (x, x),
                Some((a, b)) => (a.min(x), b.max(x)),
            });
        }
        r
    }
}

/// A grid `v` of `f(x, y)` on the axes `xs` and `ys` of kinds `kinds` (for tests): longitudes
/// and latitudes in degrees, other axes in metres.
#[cfg(test)]
pub(crate) fn test_grid(
    (xs, ys): (Vec<f64>, Vec<f64>),
    kinds: [CoordKind; 2],
    f: impl Fn(f64, f64) -> f64,
) -> Grid {
    let values = ys
        .iter()
        .flat_map(|&y| xs.iter().map(move |&x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect();
    let axis = |values, kind| {
        let units = match kind {
            CoordKind::Longitude => "degrees_east",
            CoordKind::Latitude => "degrees_north",
            _ => "m",
        };
        GridCoords {
            name: "a".into(),
            units: units.into(),
            values,
            kind,
            edges: None,
        }
    };
    Grid::with_coords(
        "g",
        axis(xs, kinds[0]),
        axis(ys, kinds[1]),
        vec![("v".into(), values)],
        None,
    )
    .expect("a valid test grid")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatched_shapes_and_unknown_names_are_errors() {
        let e = Grid::from_arrays(
            "g",
            3,
            2,
            vec![("a".into(), vec![0.0; 6]), ("b".into(), vec![0.0; 5])],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("\"b\"") && e.contains("5 values"), "{e}");
        let g = Grid::from_arrays("g", 3, 2, vec![("a".into(), vec![0.0; 6])]).unwrap();
        let e = g.property("zz").unwrap_err().to_string();
        assert!(e.contains("zz") && e.contains("known: a"), "{e}");
    }

    #[test]
    fn decreasing_coordinates_are_flipped() {
        let x = GridCoords {
            name: "lon".into(),
            units: "deg".into(),
            values: vec![2.0, 1.0],
            kind: CoordKind::Longitude,
            edges: None,
        };
        let y = GridCoords {
            name: "lat".into(),
            units: "deg".into(),
            values: vec![5.0, 4.0],
            kind: CoordKind::Latitude,
            edges: None,
        };
        let g = Grid::with_coords(
            "g",
            x,
            y,
            vec![("v".into(), vec![1.0, 2.0, 3.0, 4.0])],
            None,
        )
        .unwrap();
        assert_eq!(g.x().values, vec![1.0, 2.0]);
        assert_eq!(g.property("v").unwrap(), &[4.0, 3.0, 2.0, 1.0]);
        assert!(g.is_geographic());
    }

    #[test]
    fn geographic_map_aspect_uses_the_central_latitude() {
        // Nodes on 1° cell centres: the map's edges are lat 30..60 and lon 0..90.
        let lon: Vec<f64> = (0..90).map(|i| 0.5 + i as f64).collect();
        let lat: Vec<f64> = (0..30).map(|j| 30.5 + j as f64).collect();
        let g = Grid::from_lon_lat("g", lon, lat, vec![("v".into(), vec![0.0; 2700])]).unwrap();
        let expect = 90.0 * 45f64.to_radians().cos() / 30.0;
        assert!((g.map_aspect().unwrap() - expect).abs() < 1e-12);
        let plain = Grid::from_fn("p", 90, 30, |_, _| 0.0).unwrap();
        assert_eq!(plain.map_aspect(), None);
        let e = Grid::from_lon_lat(
            "g",
            vec![0.0, 1.0],
            vec![89.0, 91.0],
            vec![("v".into(), vec![0.0; 4])],
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("lat") && e.contains("91") && e.contains("[-90, 90]"),
            "{e}"
        );
    }
}
