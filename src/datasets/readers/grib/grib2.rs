//! GRIB edition 2 through the `grib` crate (grib-rs): its sections, the product's parameter,
//! fixed surfaces, reference time and forecast time, the grid's node latitudes and longitudes
//! (regular, rotated and Gaussian latitude–longitude, Mercator, polar stereographic, Lambert
//! conformal) and the values of every packing operational centres use (simple, complex, complex
//! with spatial differencing, JPEG 2000, PNG, CCSDS, run length), missing points of the bitmap as
//! NaN. One message is handed to the crate at a time, so a file may mix editions.

use super::model::{GribField, GridInfo};
use super::names;

type Why = String;

/// ecCodes' `gridType` of a grid definition template (code table 3.1).
fn grid_kind(template: u16) -> Result<&'static str, Why> {
    Ok(match template {
        0 => "regular_ll",
        1 => "rotated_ll",
        10 => "mercator",
        20 => "polar_stereographic",
        30 => "lambert",
        40 => "regular_gg",
        41 => "rotated_gg",
        t => {
            return Err(format!(
                "grid definition template 3.{t} is not read (read: 3.0, 3.1, 3.10, 3.20, 3.30, 3.40, 3.41)"
            ))
        }
    })
}

/// ecCodes' `packingType` of a data representation template (code table 5.0).
fn packing(template: u16) -> Result<&'static str, Why> {
    Ok(match template {
        0 => "grid_simple",
        2 => "grid_complex",
        3 => "grid_complex_spatial_differencing",
        40 => "grid_jpeg",
        41 => "grid_png",
        42 => "grid_ccsds",
        200 => "grid_run_length",
        t => {
            return Err(format!(
                "data representation template 5.{t} is not read (read: 5.0, 5.2, 5.3, 5.40, 5.41, 5.42, 5.200)"
            ))
        }
    })
}

/// Hours in one unit of GRIB2's code table 4.4.
fn unit_hours(unit: u8) -> Result<f64, Why> {
    Ok(match unit {
        0 => 1.0 / 60.0,
        1 => 1.0,
        2 => 24.0,
        10 => 3.0,
        11 => 6.0,
        12 => 12.0,
        13 => 1.0 / 3600.0,
        u => {
            return Err(format!(
                "forecast time unit {u} (code table 4.4) is not read"
            ))
        }
    })
}

/// The one field of a GRIB2 message; a message that repeats its sections for several fields
/// is refused rather than read in part.
fn with_field<T>(
    msg: &[u8],
    f: impl FnOnce(
        grib::SubMessage<'_, grib::SeekableGrib2Reader<std::io::Cursor<&[u8]>>>,
    ) -> Result<T, Why>,
) -> Result<T, Why> {
    let grib2 = grib::from_bytes(msg).map_err(|e| e.to_string())?;
    if grib2.len() != 1 {
        return Err(format!(
            "holds {} fields in one message (repeated sections); only single-field messages are read",
            grib2.len()
        ));
    }
    let (_, field) = grib2.iter().next().ok_or("holds no field")?;
    f(field)
}

/// The metadata of a GRIB2 message (values are decoded by [`values`]).
pub(super) fn field(msg: &[u8]) -> Result<GribField, Why> {
    with_field(msg, |sub| {
        let discipline = sub.indicator().discipline;
        let prod = sub.prod_def();
        let template = prod.prod_tmpl_num();
        let (Some(category), Some(number)) = (prod.parameter_category(), prod.parameter_number())
        else {
            return Err(format!(
                "product definition template 4.{template} is not read"
            ));
        };
        let surface = |s: &grib::FixedSurface| {
            let v = s.value();
            (
                s.surface_type,
                (s.surface_type != 255 && v.is_finite()).then_some(v),
            )
        };
        let level = match prod.fixed_surfaces() {
            Some((a, b)) => names::grib2_level(surface(&a), surface(&b)),
            None => names::grib2_level((255, None), (255, None)),
        };
        let step_hours = match prod.forecast_time() {
            Some(ft) => {
                let unit = match ft.unit {
                    grib::Code::Name(u) => u8::from(u),
                    grib::Code::Num(n) => n,
                };
                ft.value as f64 * unit_hours(unit)?
            }
            None => 0.0,
        };
        // Templates 4.1 and 4.11 (ensemble members): the perturbation number, octet 36.
        let ensemble = matches!(template, 1 | 11)
            .then(|| prod.iter().nth(30).map(|&n| n as i64))
            .flatten();
        let t = sub.identification().ref_time_unchecked();
        let reference = format!(
            "{:04}-{:02}-{:02} {:02}:{:02}:{:02}",
            t.year, t.month, t.day, t.hour, t.minute, t.second
        );
        let kind = grid_kind(sub.grid_def().grid_tmpl_num())?;
        let packing = packing(sub.repr_def().repr_tmpl_num())?;
        let (ni, nj) = sub.grid_shape().map_err(|e| e.to_string())?;
        let (lats, lons): (Vec<f64>, Vec<f64>) = grib::LatLons::latlons_unchecked(&sub)
            .map_err(|e| e.to_string())?
            .unzip();
        if lats.len() != ni * nj {
            return Err(format!(
                "{} node positions for a grid of {ni} × {nj}",
                lats.len()
            ));
        }
        Ok(GribField {
            edition: 2,
            param: names::grib2_param(discipline, category, number, &level),
            level,
            reference,
            step_hours,
            number: ensemble,
            grid: GridInfo {
                kind: kind.to_string(),
                ni,
                nj,
                lats,
                lons,
            },
            packing: packing.to_string(),
            centre: sub.identification().centre_id(),
        })
    })
}

/// The message's values in scanning order, missing points as NaN.
pub(super) fn values(msg: &[u8]) -> Result<Vec<f64>, Why> {
    with_field(msg, |sub| {
        let decoder = grib::Grib2SubmessageDecoder::from(sub).map_err(|e| e.to_string())?;
        let values = decoder.dispatch().map_err(|e| e.to_string())?;
        Ok(values.map(f64::from).collect())
    })
}
