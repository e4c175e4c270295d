//! The 1976 US Standard Atmosphere's pressure–height relation and the units of pressure: where
//! pressure levels are placed when they must be drawn as heights (volumes, sections, slices).

/// The layers of the 1976 US Standard Atmosphere (ICAO's to 32 km) up to 84.852 km: base
/// geopotential height (m), base temperature (K), lapse rate (K/m), base pressure (Pa).
const STANDARD_LAYERS: [(f64, f64, f64, f64); 7] = [
    (0.0, 288.15, -0.0065, 101_325.0),
    (11_000.0, 216.65, 0.0, 22_632.06),
    (20_000.0, 216.65, 0.001, 5_474.889),
    (32_000.0, 228.65, 0.0028, 868.0187),
    (47_000.0, 270.65, 0.0, 110.9063),
    (51_000.0, 270.65, -0.0028, 66.938_87),
    (71_000.0, 214.65, -0.002, 3.956_42),
];

/// The geopotential height (km) at which the 1976 US Standard Atmosphere has pressure `pa`
/// (Pa); pressures above the surface's extrapolate its lowest layer.
pub(crate) fn standard_height_km(pa: f64) -> f64 {
    // g0·M/R* of the standard: 9.80665 · 0.0289644 / 8.3144598 (K/m).
    const G_M_OVER_R: f64 = 9.806_65 * 0.028_964_4 / 8.314_459_8;
    let layer = STANDARD_LAYERS
        .iter()
        .rev()
        .find(|l| pa <= l.3)
        .unwrap_or(&STANDARD_LAYERS[0]);
    let (h, t, lapse, pb) = *layer;
    let metres = if lapse == 0.0 {
        h - t / G_M_OVER_R * (pa / pb).ln()
    } else {
        h + t / lapse * ((pa / pb).powf(-lapse / G_M_OVER_R) - 1.0)
    };
    metres / 1000.0
}

/// Whether `units` are a unit of pressure.
pub(crate) fn is_pressure_unit(units: &str) -> bool {
    pascals_per(units).is_some()
}

/// Pressure in `units` to Pa, when they are a pressure unit.
pub(crate) fn pascals_per(units: &str) -> Option<f64> {
    match units.trim().to_ascii_lowercase().as_str() {
        "pa" | "pascal" | "pascals" => Some(1.0),
        "hpa" | "mbar" | "millibar" | "millibars" | "mb" => Some(100.0),
        "kpa" => Some(1000.0),
        "bar" => Some(1e5),
        _ => None,
    }
}

/// Pressures in `units` as the standard atmosphere's heights (km); `None` when `units` are no
/// pressure unit.
pub(crate) fn heights_km(pressures: &[f64], units: &str) -> Option<Vec<f64>> {
    let scale = pascals_per(units)?;
    Some(
        pressures
            .iter()
            .map(|p| standard_height_km(p * scale))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_atmosphere_heights_match_the_1976_tables() {
        // US Standard Atmosphere 1976 (NOAA/NASA/USAF), geopotential heights: 1013.25 hPa at
        // 0 m, 500 hPa at 5 574 m, 226.32 hPa at 11 000 m, 54.749 hPa at 20 000 m, 1 hPa at
        // 47 800 m (to within the tables' rounding).
        for (hpa, km, tol) in [
            (1013.25, 0.0, 1e-9),
            (500.0, 5.574, 2e-3),
            (226.3206, 11.0, 1e-4),
            (54.74889, 20.0, 1e-4),
            (1.0, 47.8, 0.05),
        ] {
            let got = standard_height_km(hpa * 100.0);
            assert!((got - km).abs() < tol, "{hpa} hPa: {got} km, expected {km}");
        }
        // Monotonic: higher pressure, lower.
        assert!(standard_height_km(100_000.0) < standard_height_km(85_000.0));
    }
}
