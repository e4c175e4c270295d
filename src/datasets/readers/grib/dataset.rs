//! Messages grouped into variables with dimensions and coordinates, as cfgrib groups them (see
//! [`super::index`] for the rules).

use super::model::{Content, GribField, GribIndex, GribVariable, GridInfo, Located};
use crate::datasets::readers::variables::NcAttribute;

fn text(s: &str) -> NcAttribute {
    NcAttribute::Text(s.to_string())
}

fn number(v: f64) -> NcAttribute {
    NcAttribute::Numbers(vec![v])
}

/// One group of messages: a parameter and level type on one grid.
struct Group {
    name: String,
    grid: usize,
    members: Vec<usize>,
}

/// Attributes, in order.
type Attributes = Vec<(String, NcAttribute)>;

/// Coordinate dimensions made so far: name and values, so variables with equal values share one.
#[derive(Default)]
struct Coords {
    made: Vec<(String, Vec<f64>, Attributes)>,
}

impl Coords {
    /// The dimension for `values` under `base`: an existing one with equal values, else a new one
    /// (`base`, `base_1`, ...).
    fn dim(&mut self, base: &str, values: &[f64], attrs: Vec<(String, NcAttribute)>) -> String {
        if let Some((name, _, _)) = self
            .made
            .iter()
            .find(|(n, v, _)| (n == base || n.starts_with(&format!("{base}_"))) && v == values)
        {
            return name.clone();
        }
        let taken = self
            .made
            .iter()
            .filter(|(n, _, _)| n == base || n.starts_with(&format!("{base}_")))
            .count();
        let name = if taken == 0 {
            base.to_string()
        } else {
            format!("{base}_{taken}")
        };
        self.made.push((name.clone(), values.to_vec(), attrs));
        name
    }
}

/// Sorted distinct values.
fn distinct(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Seconds since 1970 of a "YYYY-MM-DD hh:mm:ss" reference time.
fn seconds(reference: &str) -> f64 {
    use crate::datasets::cf_time::TimeUnits;
    static EPOCH: std::sync::OnceLock<Option<TimeUnits>> = std::sync::OnceLock::new();
    EPOCH
        .get_or_init(|| {
            TimeUnits::parse(
                "seconds since 1970-01-01 00:00:00",
                Some("proleptic_gregorian"),
            )
            .ok()
        })
        .as_ref()
        .and_then(|u| u.value(reference).ok())
        .unwrap_or(f64::NAN)
}

/// The variables of the file's messages.
pub(crate) fn build(messages: Vec<Located>) -> GribIndex {
    let mut grids: Vec<GridInfo> = Vec::new();
    let mut groups: Vec<Group> = Vec::new();
    for (k, m) in messages.iter().enumerate() {
        let f = &m.field;
        let grid = match grids.iter().position(|g| *g == f.grid) {
            Some(g) => g,
            None => {
                grids.push(f.grid.clone());
                grids.len() - 1
            }
        };
        let same = |g: &Group| {
            let first = &messages[g.members[0]].field;
            g.grid == grid
                && first.param.name == f.param.name
                && first.level.type_name == f.level.type_name
                && first.step_type == f.step_type
        };
        match groups.iter_mut().find(|g| same(g)) {
            Some(g) => g.members.push(k),
            None => groups.push(Group {
                name: f.param.name.clone(),
                grid,
                members: vec![k],
            }),
        }
    }
    name_groups(&mut groups, &messages);
    let mut coords = Coords::default();
    let grid_dims: Vec<GridDims> = grids
        .iter()
        .enumerate()
        .map(|(g, info)| grid_dims(g, info))
        .collect();
    let mut variables = Vec::new();
    for group in &groups {
        variables.push(group_variable(
            group,
            &messages,
            &grid_dims[group.grid],
            &mut coords,
        ));
    }
    hybrid_formulas(&mut coords, &mut variables, &messages);
    for (name, values, attrs) in coords.made {
        variables.push(GribVariable {
            dims: vec![(name.clone(), values.len())],
            name,
            attributes: attrs,
            content: Content::Stored(values),
        });
    }
    for g in grid_dims {
        variables.extend(g.coordinates);
    }
    let editions: Vec<u8> = distinct(messages.iter().map(|m| m.field.edition as f64).collect())
        .into_iter()
        .map(|e| e as u8)
        .collect();
    let mut globals = vec![
        ("Conventions".to_string(), text("CF-1.7")),
        (
            "GRIB_centre".to_string(),
            number(messages[0].field.centre as f64),
        ),
    ];
    if let [edition] = editions[..] {
        globals.push(("GRIB_edition".to_string(), number(edition as f64)));
    }
    GribIndex {
        messages,
        variables,
        globals,
    }
}

/// Model levels' pressure as CF's `atmosphere_hybrid_sigma_pressure_coordinate`: for each
/// `hybrid` dimension whose messages carry the PV array (A and B at the N + 1 half levels),
/// the full levels' coefficients `hyam` (Pa) and `hybm` become variables on it, each the mean
/// of its level's two half levels as the IFS defines full levels, and the dimension's
/// `formula_terms` names them with the surface pressure: the file's `sp` (Pa) on the same grid,
/// else e^`lnsp` as a variable `ps`. Without both the dimension stays plain model levels.
fn hybrid_formulas(coords: &mut Coords, variables: &mut Vec<GribVariable>, messages: &[Located]) {
    for c in 0..coords.made.len() {
        let name = coords.made[c].0.clone();
        let suffix = match name.strip_prefix("hybrid") {
            Some(s) if s.is_empty() || s.starts_with('_') => s.to_string(),
            _ => continue,
        };
        let on_dim = variables.iter().find_map(|v| match &v.content {
            Content::Messages(h) if v.dims.iter().any(|(d, _)| *d == name) => {
                h.iter().flatten().next().map(|&k| (v.dims.clone(), k))
            }
            _ => None,
        });
        let Some((dims, k)) = on_dim else { continue };
        let pv = &messages[k].field.pv;
        let half = pv.len() / 2;
        let levels = &coords.made[c].1;
        let fits = pv.len().is_multiple_of(2)
            && levels
                .iter()
                .all(|&l| l.fract() == 0.0 && l >= 1.0 && (l as usize) < half);
        if pv.is_empty() || !fits {
            continue;
        }
        let grid = &dims[dims.len() - 2..];
        let Some(ps) = surface_pressure(variables, grid, &suffix) else {
            continue;
        };
        let full = |coef: &[f64]| -> Vec<f64> {
            levels
                .iter()
                .map(|&l| (coef[l as usize - 1] + coef[l as usize]) / 2.0)
                .collect()
        };
        let (hyam, hybm) = (format!("hyam{suffix}"), format!("hybm{suffix}"));
        for (var, values, long_name, units) in [
            (
                &hyam,
                full(&pv[..half]),
                "hybrid A coefficient at full levels (GRIB PV array)",
                "Pa",
            ),
            (
                &hybm,
                full(&pv[half..]),
                "hybrid B coefficient at full levels (GRIB PV array)",
                "1",
            ),
        ] {
            variables.push(GribVariable {
                name: var.clone(),
                dims: vec![(name.clone(), values.len())],
                attributes: vec![
                    ("long_name".to_string(), text(long_name)),
                    ("units".to_string(), text(units)),
                ],
                content: Content::Stored(values),
            });
        }
        coords.made[c].2.push((
            "formula_terms".to_string(),
            text(&format!("ap: {hyam} b: {hybm} ps: {ps}")),
        ));
    }
}

/// The surface pressure (Pa) on `grid` for model levels: the file's `sp`, else a variable `ps`
/// (with `suffix`) made as e^`lnsp`; `None` when the file has neither.
fn surface_pressure(
    variables: &mut Vec<GribVariable>,
    grid: &[(String, usize)],
    suffix: &str,
) -> Option<String> {
    let on_grid = |v: &GribVariable, name: &str| {
        v.name == name
            && v.dims.len() >= 2
            && v.dims[v.dims.len() - 2..] == *grid
            && matches!(v.content, Content::Messages(_))
    };
    if let Some(sp) = variables.iter().find(|v| on_grid(v, "sp")) {
        return Some(sp.name.clone());
    }
    let lnsp = variables.iter().find(|v| on_grid(v, "lnsp"))?;
    let name = format!("ps{suffix}");
    if variables.iter().any(|v| v.name == name) {
        return Some(name);
    }
    let Content::Messages(holders) = &lnsp.content else {
        return None;
    };
    let mut attributes: Vec<(String, NcAttribute)> = lnsp
        .attributes
        .iter()
        .filter(|(k, _)| k.starts_with("GRIB_") || k == "coordinates")
        .cloned()
        .collect();
    attributes.push(("units".to_string(), text("Pa")));
    attributes.push(("long_name".to_string(), text("surface pressure (e^lnsp)")));
    attributes.push(("standard_name".to_string(), text("surface_air_pressure")));
    let ps = GribVariable {
        name: name.clone(),
        dims: lnsp.dims.clone(),
        attributes,
        content: Content::ExpOfMessages(holders.clone()),
    };
    variables.push(ps);
    Some(name)
}

/// Names that stay unique: a parameter on two level types gets the level type appended, a
/// statistic beside the instant value its step type (`_avg`, `_accum`), and one on two grids the
/// grid's number.
fn name_groups(groups: &mut [Group], messages: &[Located]) {
    let key = |g: &Group| {
        let f = &messages[g.members[0]].field;
        (
            g.name.clone(),
            f.level.type_name.clone(),
            f.step_type.clone(),
        )
    };
    let keys: Vec<(String, String, String)> = groups.iter().map(key).collect();
    for (i, g) in groups.iter_mut().enumerate() {
        let (name, level, step) = &keys[i];
        let other = |pick: &dyn Fn(&(String, String, String)) -> bool| keys.iter().any(pick);
        if other(&|k| k.0 == *name && k.1 != *level) {
            g.name = format!("{name}_{level}");
        }
        // The same parameter as an instant and as a statistic (an average, an accumulation).
        if step != "instant" && other(&|k| k.0 == *name && k.1 == *level && k.2 != *step) {
            g.name = format!("{}_{step}", g.name);
        }
        if keys.iter().filter(|k| **k == keys[i]).count() > 1 {
            g.name = format!("{}_grid{}", g.name, g.grid);
        }
    }
}

/// A grid's two dimensions and its coordinate variables.
struct GridDims {
    dims: [(String, usize); 2],
    /// The `coordinates` attribute of variables on a grid without 1-D axes.
    aux: Option<String>,
    coordinates: Vec<GribVariable>,
}

fn grid_dims(g: usize, info: &GridInfo) -> GridDims {
    let suffix = if g == 0 {
        String::new()
    } else {
        format!("_{g}")
    };
    let (lat, lon) = (format!("latitude{suffix}"), format!("longitude{suffix}"));
    let geo = |standard: &str, units: &str| {
        vec![
            ("units".to_string(), text(units)),
            ("standard_name".to_string(), text(standard)),
            ("long_name".to_string(), text(standard)),
        ]
    };
    if info.is_rectilinear() {
        let lats: Vec<f64> = (0..info.nj).map(|j| info.lats[j * info.ni]).collect();
        let lons: Vec<f64> = info.lons[..info.ni].to_vec();
        GridDims {
            dims: [(lat.clone(), info.nj), (lon.clone(), info.ni)],
            aux: None,
            coordinates: vec![
                GribVariable {
                    dims: vec![(lat.clone(), info.nj)],
                    attributes: geo("latitude", "degrees_north"),
                    name: lat,
                    content: Content::Stored(lats),
                },
                GribVariable {
                    dims: vec![(lon.clone(), info.ni)],
                    attributes: geo("longitude", "degrees_east"),
                    name: lon,
                    content: Content::Stored(lons),
                },
            ],
        }
    } else {
        let (y, x) = (format!("y{suffix}"), format!("x{suffix}"));
        let dims = vec![(y.clone(), info.nj), (x.clone(), info.ni)];
        GridDims {
            dims: [(y, info.nj), (x, info.ni)],
            aux: Some(format!("{lat} {lon}")),
            coordinates: vec![
                GribVariable {
                    dims: dims.clone(),
                    attributes: geo("latitude", "degrees_north"),
                    name: lat,
                    content: Content::Stored(info.lats.clone()),
                },
                GribVariable {
                    dims,
                    attributes: geo("longitude", "degrees_east"),
                    name: lon,
                    content: Content::Stored(info.lons.clone()),
                },
            ],
        }
    }
}

/// The attributes of a level coordinate: pressure down in hPa, heights up in metres.
fn level_attributes(type_name: &str, units: Option<&str>) -> Vec<(String, NcAttribute)> {
    let mut attrs = vec![("long_name".to_string(), text(type_name))];
    // A layer between two levels is a label, as cfgrib keeps it, not a vertical axis.
    if type_name.ends_with("Layer") {
        attrs.push(("units".to_string(), text(units.unwrap_or("1"))));
        return attrs;
    }
    // Model levels, as cfgrib marks them: vertical, numbered downward.
    if type_name == "hybrid" {
        attrs.push(("positive".to_string(), text("down")));
        attrs.push((
            "standard_name".to_string(),
            text("atmosphere_hybrid_sigma_pressure_coordinate"),
        ));
    }
    match units {
        Some("hPa" | "Pa") => {
            attrs.push(("units".to_string(), text(units.unwrap_or("hPa"))));
            attrs.push(("positive".to_string(), text("down")));
            attrs.push(("standard_name".to_string(), text("air_pressure")));
        }
        Some("m") => {
            attrs.push(("units".to_string(), text("m")));
            let down = type_name.starts_with("depth");
            attrs.push((
                "positive".to_string(),
                text(if down { "down" } else { "up" }),
            ));
        }
        Some(u) => attrs.push(("units".to_string(), text(u))),
        None => attrs.push(("units".to_string(), text("1"))),
    }
    attrs
}

/// A group's variable: its outer dimensions where its messages take several values, the grid's
/// two, and which message holds each combination.
fn group_variable(
    group: &Group,
    messages: &[Located],
    grid: &GridDims,
    coords: &mut Coords,
) -> GribVariable {
    let fields: Vec<&GribField> = group.members.iter().map(|&k| &messages[k].field).collect();
    let first = fields[0];
    let numbers = distinct(
        fields
            .iter()
            .filter_map(|f| f.number.map(|n| n as f64))
            .collect(),
    );
    let times = distinct(fields.iter().map(|f| seconds(&f.reference)).collect());
    let steps = distinct(fields.iter().map(|f| f.step_hours).collect());
    let mut levels = distinct(fields.iter().filter_map(|f| f.level.value).collect());
    // Pressure levels run from the surface up (high to low), as cfgrib orders them; layers in
    // increasing order of their bound.
    let pressure = matches!(first.level.units.as_deref(), Some("hPa" | "Pa"))
        && !first.level.type_name.ends_with("Layer");
    if pressure {
        levels.reverse();
    }
    // (dimension, its values, how a field gives its value)
    type Key = fn(&GribField) -> f64;
    let mut outer: Vec<(String, Vec<f64>, Key)> = Vec::new();
    if numbers.len() > 1 {
        let attrs = vec![
            (
                "long_name".to_string(),
                text("ensemble member numerical id"),
            ),
            ("standard_name".to_string(), text("realization")),
            ("units".to_string(), text("1")),
        ];
        outer.push((
            coords.dim("number", &numbers, attrs),
            numbers.clone(),
            |f| f.number.unwrap_or(-1) as f64,
        ));
    }
    if times.len() > 1 {
        outer.push((
            coords.dim("time", &times, time_attributes()),
            times.clone(),
            |f| seconds(&f.reference),
        ));
    }
    if steps.len() > 1 {
        let attrs = vec![
            (
                "long_name".to_string(),
                text("time since forecast_reference_time"),
            ),
            ("standard_name".to_string(), text("forecast_period")),
            ("units".to_string(), text("hours")),
        ];
        outer.push((coords.dim("step", &steps, attrs), steps.clone(), |f| {
            f.step_hours
        }));
    }
    if levels.len() > 1 {
        let attrs = level_attributes(&first.level.type_name, first.level.units.as_deref());
        let name = coords.dim(&first.level.type_name, &levels, attrs);
        outer.push((name, levels.clone(), |f| f.level.value.unwrap_or(f64::NAN)));
    }
    let shape: Vec<usize> = outer.iter().map(|(_, v, _)| v.len()).collect();
    let cells: usize = shape.iter().product();
    let mut holder = vec![None; cells];
    for (&k, f) in group.members.iter().zip(&fields) {
        let mut at = 0;
        for (_, values, key) in &outer {
            let v = key(f);
            at = at * values.len() + values.iter().position(|&x| x == v).unwrap_or(0);
        }
        holder[at].get_or_insert(k);
    }
    let mut dims: Vec<(String, usize)> =
        outer.iter().map(|(n, v, _)| (n.clone(), v.len())).collect();
    dims.extend(grid.dims.iter().cloned());
    GribVariable {
        name: group.name.clone(),
        dims,
        attributes: variable_attributes(
            first,
            grid,
            [numbers.len(), times.len(), steps.len(), levels.len()],
        ),
        content: Content::Messages(holder),
    }
}

fn time_attributes() -> Vec<(String, NcAttribute)> {
    vec![
        ("long_name".to_string(), text("initial time of forecast")),
        ("standard_name".to_string(), text("forecast_reference_time")),
        (
            "units".to_string(),
            text("seconds since 1970-01-01T00:00:00"),
        ),
        ("calendar".to_string(), text("proleptic_gregorian")),
    ]
}

/// A data variable's attributes: units and name, GRIB keys, and what its messages share (a single
/// level, step, reference time or member stays an attribute, as cfgrib keeps it a scalar
/// coordinate).
fn variable_attributes(
    first: &GribField,
    grid: &GridDims,
    counts: [usize; 4],
) -> Vec<(String, NcAttribute)> {
    let mut a = Vec::new();
    if let Some(u) = &first.param.units {
        a.push(("units".to_string(), text(u)));
    }
    a.push(("long_name".to_string(), text(&first.param.long_name)));
    a.push(("GRIB_edition".to_string(), number(first.edition as f64)));
    a.push(("GRIB_typeOfLevel".to_string(), text(&first.level.type_name)));
    a.push(("GRIB_stepType".to_string(), text(&first.step_type)));
    a.push(("GRIB_gridType".to_string(), text(&first.grid.kind)));
    a.push(("GRIB_packingType".to_string(), text(&first.packing)));
    let [numbers, times, steps, levels] = counts;
    if numbers == 1 {
        if let Some(n) = first.number {
            a.push(("GRIB_number".to_string(), number(n as f64)));
        }
    }
    if times == 1 {
        a.push(("GRIB_referenceTime".to_string(), text(&first.reference)));
    }
    if steps == 1 {
        a.push(("GRIB_stepHours".to_string(), number(first.step_hours)));
    }
    if levels == 1 {
        if let Some(v) = first.level.value {
            a.push(("GRIB_level".to_string(), number(v)));
        }
    }
    if let Some(aux) = &grid.aux {
        a.push(("coordinates".to_string(), text(aux)));
    }
    a
}
