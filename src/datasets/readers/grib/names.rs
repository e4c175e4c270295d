//! Names for what GRIB codes by number: parameters and level types, as ecCodes names them and
//! cfgrib presents them (cfgrib's variable names are ecCodes' `cfVarName`: `t`, `gh`, `t2m`,
//! `u10`, `msl`). The table holds the parameters weather and climate files carry most; any other
//! is named from the WMO parameter table (GRIB2 code table 4.2, through the `grib` crate) or, for
//! GRIB1, by its number in the centre's table.

use super::model::{Level, Param};

fn param(name: &str, long_name: &str, units: &str) -> Param {
    Param {
        name: name.to_string(),
        long_name: long_name.to_string(),
        units: Some(units.to_string()),
    }
}

/// cfgrib's names of the usual parameters at the heights where ecCodes gives them their own
/// (2 m temperature is `t2m`, 10 m wind `u10`/`v10`), and the rest by the plain name.
fn common(key: &str, level: &Level) -> Option<Param> {
    let at = |t: &str, v: f64| level.type_name == t && level.value == Some(v);
    let p = match key {
        "t" if at("heightAboveGround", 2.0) => param("t2m", "2 metre temperature", "K"),
        "t" => param("t", "Temperature", "K"),
        "dpt" if at("heightAboveGround", 2.0) => param("d2m", "2 metre dewpoint temperature", "K"),
        "dpt" => param("dpt", "Dew point temperature", "K"),
        "u" if at("heightAboveGround", 10.0) => {
            param("u10", "10 metre U wind component", "m s**-1")
        }
        "u" => param("u", "U component of wind", "m s**-1"),
        "v" if at("heightAboveGround", 10.0) => {
            param("v10", "10 metre V wind component", "m s**-1")
        }
        "v" => param("v", "V component of wind", "m s**-1"),
        "w" => param("w", "Vertical velocity", "Pa s**-1"),
        "q" => param("q", "Specific humidity", "kg kg**-1"),
        "r" if at("heightAboveGround", 2.0) => param("r2", "2 metre relative humidity", "%"),
        "r" => param("r", "Relative humidity", "%"),
        "gh" if level.type_name == "surface" => param("orog", "Orography", "m"),
        "gh" => param("gh", "Geopotential height", "gpm"),
        "cape" => param("cape", "Convective available potential energy", "J kg**-1"),
        "cin" => param("cin", "Convective inhibition", "J kg**-1"),
        "acpcp" => param("acpcp", "Convective precipitation (water)", "kg m**-2"),
        "hlcy" => param("hlcy", "Storm relative helicity", "m**2 s**-2"),
        "z" => param("z", "Geopotential", "m**2 s**-2"),
        "pres" if level.type_name == "surface" => param("sp", "Surface pressure", "Pa"),
        "pres" if level.type_name == "meanSea" => param("msl", "Mean sea level pressure", "Pa"),
        "pres" if level.type_name == "tropopause" => param("trpp", "Tropopause pressure", "Pa"),
        "pres" if level.type_name == "cloudBase" => param("pcdb", "Pressure at cloud base", "Pa"),
        "pres" => param("pres", "Pressure", "Pa"),
        "prmsl" => param("prmsl", "Pressure reduced to MSL", "Pa"),
        "msl" => param("msl", "Mean sea level pressure", "Pa"),
        "sp" => param("sp", "Surface pressure", "Pa"),
        "lnsp" => param("lnsp", "Logarithm of surface pressure", "Numeric"),
        "tp" => param("tp", "Total precipitation", "kg m**-2"),
        "tcc" => param("tcc", "Total cloud cover", "%"),
        "lsm" => param("lsm", "Land-sea mask", "(0 - 1)"),
        "vo" => param("vo", "Vorticity (relative)", "s**-1"),
        "absv" => param("absv", "Absolute vorticity", "s**-1"),
        "sst" => param("sst", "Sea surface temperature", "K"),
        "skt" => param("skt", "Skin temperature", "K"),
        "t2m" => param("t2m", "2 metre temperature", "K"),
        "d2m" => param("d2m", "2 metre dewpoint temperature", "K"),
        "u10" => param("u10", "10 metre U wind component", "m s**-1"),
        "v10" => param("v10", "10 metre V wind component", "m s**-1"),
        _ => return None,
    };
    Some(p)
}

/// A GRIB2 parameter (discipline, category, number) at `level`.
pub(crate) fn grib2_param(discipline: u8, category: u8, number: u8, level: &Level) -> Param {
    let key = match (discipline, category, number) {
        (0, 0, 0) => "t",
        (0, 0, 6) => "dpt",
        (0, 0, 17) => "skt",
        (0, 1, 0) => "q",
        (0, 1, 1) => "r",
        (0, 1, 8) => "tp",
        (0, 1, 10) => "acpcp",
        (0, 3, 25) => "lnsp",
        (0, 7, 6) => "cape",
        (0, 7, 7) => "cin",
        (0, 7, 8) => "hlcy",
        (0, 2, 2) => "u",
        (0, 2, 3) => "v",
        (0, 2, 8) => "w",
        (0, 2, 10) => "absv",
        (0, 2, 12) => "vo",
        (0, 3, 0) => "pres",
        (0, 3, 1) => "prmsl",
        (0, 3, 4) => "z",
        (0, 3, 5) => "gh",
        (0, 6, 1) => "tcc",
        (2, 0, 0) => "lsm",
        (10, 3, 0) => "sst",
        _ => "",
    };
    if let Some(p) = common(key, level) {
        return p;
    }
    use grib::codetables::{CodeTable4_2, Lookup};
    let looked = CodeTable4_2::new(discipline, category)
        .lookup(usize::from(number))
        .to_string();
    let known = !looked.is_empty() && !looked.starts_with("code") && !looked.contains("Missing");
    Param {
        name: if known {
            snake(&looked)
        } else {
            format!("param{discipline}_{category}_{number}")
        },
        long_name: if known {
            looked
        } else {
            format!("GRIB2 parameter {discipline}.{category}.{number}")
        },
        units: None,
    }
}

/// A variable name from a WMO parameter name: lower case, words joined by '_'.
fn snake(name: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('_') && !out.is_empty() {
            out.push('_');
        }
    }
    out.trim_end_matches('_').to_string()
}

/// A GRIB1 parameter: `table` (the centre's table 2 version), `centre` and its number.
pub(crate) fn grib1_param(
    table: u8,
    (centre, subcentre): (u16, u8),
    number: u8,
    level: &Level,
) -> Param {
    // ECMWF's table 128 (centre 98, or another centre's product archived in ECMWF's MARS, sub-
    // centre 98), else WMO's table 2 (versions 1 to 3, which all centres share below 128).
    let ecmwf = (centre == 98 || subcentre == 98) && table == 128;
    let key = if ecmwf {
        match number {
            34 => "sst",
            129 => "z",
            130 => "t",
            131 => "u",
            132 => "v",
            133 => "q",
            134 => "sp",
            135 => "w",
            138 => "vo",
            151 => "msl",
            152 => "lnsp",
            157 => "r",
            164 => "tcc",
            165 => "u10",
            166 => "v10",
            167 => "t2m",
            168 => "d2m",
            172 => "lsm",
            228 => "tp",
            235 => "skt",
            _ => "",
        }
    } else if table <= 3 {
        match number {
            1 => "pres",
            2 => "prmsl",
            6 => "z",
            7 => "gh",
            11 => "t",
            17 => "dpt",
            33 => "u",
            34 => "v",
            39 => "w",
            41 => "absv",
            43 => "vo",
            51 => "q",
            52 => "r",
            61 => "tp",
            71 => "tcc",
            81 => "lsm",
            _ => "",
        }
    } else {
        ""
    };
    // ECMWF's total precipitation is a depth of water (m), WMO's a mass per area.
    let units = (ecmwf && key == "tp").then(|| "m".to_string());
    common(key, level)
        .map(|p| Param {
            units: units.or(p.units),
            ..p
        })
        .unwrap_or_else(|| Param {
            name: format!("param{number}_table{table}"),
            long_name: format!(
                "GRIB1 parameter {number} of table 2 version {table} (centre {centre})"
            ),
            units: None,
        })
}

/// A GRIB2 level from its first and second fixed surfaces (code table 4.5): ecCodes'
/// `typeOfLevel` and the level in the unit ecCodes gives it (hPa for pressure).
pub(crate) fn grib2_level(first: (u8, Option<f64>), second: (u8, Option<f64>)) -> Level {
    let (kind, value) = first;
    let (name, scale, units) = match kind {
        1 => ("surface", 1.0, ""),
        2 => ("cloudBase", 1.0, ""),
        3 => ("cloudTop", 1.0, ""),
        4 => ("isothermZero", 1.0, ""),
        6 => ("maxWind", 1.0, ""),
        7 => ("tropopause", 1.0, ""),
        8 => ("nominalTop", 1.0, ""),
        10 => ("entireAtmosphere", 1.0, ""),
        // ecCodes names a pressure that is no whole number of hPa "isobaricInPa".
        100 if value.is_some_and(|p| p % 100.0 != 0.0) => ("isobaricInPa", 1.0, "Pa"),
        100 => ("isobaricInhPa", 0.01, "hPa"),
        101 => ("meanSea", 1.0, ""),
        102 => ("heightAboveSea", 1.0, "m"),
        103 => ("heightAboveGround", 1.0, "m"),
        104 => ("sigma", 1.0, "1"),
        105 => ("hybrid", 1.0, "1"),
        106 => ("depthBelowLand", 1.0, "m"),
        107 => ("theta", 1.0, "K"),
        // ecCodes keeps this layer's bound in Pa.
        108 => ("pressureFromGroundLayer", 1.0, "Pa"),
        109 => ("potentialVorticity", 1.0, "K m**2 kg**-1 s**-1"),
        160 => ("depthBelowSea", 1.0, "m"),
        255 => ("unknown", 1.0, ""),
        _ => ("", 1.0, ""),
    };
    let layer = second.0 != 255 && second.0 == kind && second.1 != value;
    let type_name = match (name, layer) {
        ("", _) => format!("level{kind}"),
        (n, true) if !n.ends_with("Layer") => format!("{n}Layer"),
        (n, _) => n.to_string(),
    };
    Level {
        type_name,
        value: value.map(|v| v * scale),
        units: (!units.is_empty()).then(|| units.to_string()),
    }
}

/// A GRIB1 level (code table 3) from its type and the two level octets.
pub(crate) fn grib1_level(kind: u8, a: u8, b: u8) -> Level {
    let both = ((a as u16) << 8 | b as u16) as f64;
    let (name, value, units): (&str, Option<f64>, &str) = match kind {
        1 => ("surface", Some(0.0), ""),
        2 => ("cloudBase", Some(0.0), ""),
        3 => ("cloudTop", Some(0.0), ""),
        4 => ("isothermZero", Some(0.0), ""),
        6 => ("maxWind", Some(0.0), ""),
        7 => ("tropopause", Some(0.0), ""),
        8 => ("nominalTop", Some(0.0), ""),
        100 => ("isobaricInhPa", Some(both), "hPa"),
        101 => ("isobaricLayer", Some(a as f64 * 10.0), "hPa"),
        102 => ("meanSea", Some(0.0), ""),
        103 => ("heightAboveSea", Some(both), "m"),
        105 => ("heightAboveGround", Some(both), "m"),
        107 => ("sigma", Some(both / 10000.0), "1"),
        109 => ("hybrid", Some(both), "1"),
        111 => ("depthBelowLand", Some(both / 100.0), "m"),
        112 => ("depthBelowLandLayer", Some(a as f64 / 100.0), "m"),
        113 => ("theta", Some(both), "K"),
        117 => ("potentialVorticity", Some(both), "K m**2 kg**-1 s**-1"),
        160 => ("depthBelowSea", Some(both), "m"),
        200 => ("entireAtmosphere", Some(0.0), ""),
        _ => ("", Some(both), ""),
    };
    Level {
        type_name: if name.is_empty() {
            format!("level{kind}")
        } else {
            name.to_string()
        },
        value,
        units: (!units.is_empty()).then(|| units.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_cfgrib_and_the_wmo_tables() {
        let pressure = grib2_level((100, Some(50000.0)), (255, None));
        assert_eq!(pressure.type_name, "isobaricInhPa");
        assert_eq!(pressure.value, Some(500.0));
        assert_eq!(grib2_param(0, 0, 0, &pressure).name, "t");
        let two_metres = grib2_level((103, Some(2.0)), (255, None));
        assert_eq!(grib2_param(0, 0, 0, &two_metres).name, "t2m");
        let ten = grib1_level(105, 0, 10);
        assert_eq!(grib1_param(128, (98, 0), 165, &ten).name, "u10");
        assert_eq!(grib1_param(128, (7, 98), 167, &ten).name, "t2m");
        assert_eq!(
            grib1_param(128, (98, 0), 228, &ten).units.as_deref(),
            Some("m")
        );
        assert_eq!(
            grib1_param(2, (7, 0), 11, &grib1_level(100, 1, 244)).name,
            "t"
        );
        assert_eq!(grib1_level(100, 1, 244).value, Some(500.0));
        // A parameter outside the table is named from WMO's code table 4.2.
        let p = grib2_param(0, 1, 3, &pressure);
        assert_eq!(p.name, "precipitable_water", "{p:?}");
        assert_eq!(
            snake("Snow depth (water equivalent)"),
            "snow_depth_water_equivalent"
        );
    }
}
