//! GRIB edition 2 through the `grib` crate (grib-rs): its sections, the product's parameter,
//! fixed surfaces, reference time and forecast time, the grid's node latitudes and longitudes
//! (regular, rotated and Gaussian latitude–longitude, reduced Gaussian, Mercator, polar stereographic, Lambert
//! conformal) and the values of every packing operational centres use (simple, complex, complex
//! with spatial differencing, JPEG 2000, PNG, CCSDS, run length), missing points of the bitmap as
//! NaN. One message is handed to the crate at a time, so a file may mix editions.

use super::model::{GribField, GridInfo};
use super::names;

type Why = String;

/// The crate's error as one line (some of its errors print as multi-line debug structures).
fn one_line(e: impl std::fmt::Display) -> Why {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

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

/// Checks that a message's sections (each a 4-octet length and its number) tile it up to
/// "7777": the crate reads a section into a buffer of its declared length, so a damaged length
/// must be refused before it is handed over.
fn check_sections(msg: &[u8]) -> Result<(), Why> {
    let end = msg.len().saturating_sub(4);
    let mut at = 16;
    let (mut jpeg, mut values) = (false, 0u64);
    while at < end {
        let len = msg
            .get(at..at + 4)
            .map(|b| u32::from_be_bytes(b.try_into().expect("4 octets")) as usize)
            .ok_or("the message ends inside a section header (truncated)")?;
        let number = msg.get(at + 4).copied().unwrap_or(0);
        if len < 5 || at + len > end || !(1..=7).contains(&number) {
            return Err(format!(
                "section {number} at offset {at} declares {len} octets where {} remain before '7777' (damaged)",
                end - at
            ));
        }
        if number == 5 {
            check_representation(&msg[at..at + len])?;
            jpeg = msg.get(at + 9..at + 11) == Some(&[0, 40]);
            values = msg.get(at + 5..at + 9).map_or(0, |b| {
                u32::from_be_bytes(b.try_into().expect("4 octets")) as u64
            });
        }
        if number == 7 && jpeg {
            check_jpeg2000(&msg[at + 5..at + len], values)?;
        }
        at += len;
    }
    Ok(())
}

/// A JPEG 2000 code stream's image size (its SIZ marker segment), which sizes the decoder's
/// buffers: one component of no more samples than the message has values.
fn check_jpeg2000(stream: &[u8], values: u64) -> Result<(), Why> {
    if stream.is_empty() {
        return Ok(());
    }
    let word = |at: usize| {
        stream
            .get(at..at + 4)
            .map(|b| u32::from_be_bytes(b.try_into().expect("4 octets")) as u64)
    };
    if stream.get(..4) != Some(&[0xff, 0x4f, 0xff, 0x51]) {
        return Err("the JPEG 2000 code stream does not begin with SOC and SIZ (damaged)".into());
    }
    let size = |a: usize, b: usize| word(a)?.checked_sub(word(b)?);
    let (width, height) = (size(8, 16), size(12, 20));
    let components = stream.get(40..42).map(|b| u16::from_be_bytes([b[0], b[1]]));
    match (width, height, components) {
        (Some(w), Some(h), Some(1)) if w > 0 && h > 0 && w.saturating_mul(h) <= values.max(1) => Ok(()),
        _ => Err(format!(
            "a JPEG 2000 image of {width:?} × {height:?} samples in {components:?} components for {values} values (damaged)"
        )),
    }
}

/// Section 5's counts that size the decoder's buffers: complex packing's number of groups can
/// be no more than the values it packs.
fn check_representation(sect: &[u8]) -> Result<(), Why> {
    let word = |at: usize| {
        sect.get(at..at + 4)
            .map(|b| u32::from_be_bytes(b.try_into().expect("4 octets")) as usize)
    };
    let template = sect.get(9..11).map(|b| u16::from_be_bytes([b[0], b[1]]));
    let values = word(5).unwrap_or(0);
    if matches!(template, Some(2 | 3)) {
        let groups = word(31).ok_or("section 5 ends before complex packing's group count")?;
        // Octets 38–41: the reference group length; 43–46: the last group's true length.
        let reference = word(37).unwrap_or(0);
        let last = word(42).unwrap_or(0);
        if groups > values || reference > values || last > values {
            return Err(format!(
                "complex packing of {values} values in {groups} groups of reference length {reference}, the last {last} long (damaged)"
            ));
        }
    }
    Ok(())
}

thread_local! {
    /// Set while the crate decodes on this thread: its panics are turned into errors, not printed.
    static DECODING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs the crate on one message, turning a panic of the crate (an arithmetic overflow on a
/// damaged message) into a one-line error; the panic hook stays quiet for it, and for nothing
/// else.
fn guarded<T>(f: impl FnOnce() -> Result<T, Why>) -> Result<T, Why> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !DECODING.with(std::cell::Cell::get) {
                previous(info);
            }
        }));
    });
    DECODING.with(|d| d.set(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    DECODING.with(|d| d.set(false));
    result.unwrap_or_else(|panic| {
        let why = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(format!("the GRIB2 decoder failed on it ({why}): the message is damaged or uses a form hdrvis does not read"))
    })
}

/// Field `k` of a GRIB2 message (most hold one; some repeat their sections for several).
fn with_field<T>(
    msg: &[u8],
    k: usize,
    f: impl FnOnce(
        grib::SubMessage<'_, grib::SeekableGrib2Reader<std::io::Cursor<&[u8]>>>,
    ) -> Result<T, Why>,
) -> Result<T, Why> {
    check_sections(msg)?;
    guarded(|| {
        let grib2 = grib::from_bytes(msg).map_err(one_line)?;
        let (_, field) = grib2
            .iter()
            .nth(k)
            .ok_or_else(|| format!("holds {} fields, not a field {k}", grib2.len()))?;
        f(field)
    })
}

/// How many fields a GRIB2 message holds (a message may repeat its sections for several).
pub(super) fn field_count(msg: &[u8]) -> Result<usize, Why> {
    check_sections(msg)?;
    guarded(|| Ok(grib::from_bytes(msg).map_err(one_line)?.len()))
}

/// The end of a statistical product's interval (templates 4.8 and 4.11, where ecCodes labels
/// the step) in hours after the forecast time, and its kind as ecCodes' `stepType` names it.
fn statistics(template: u16, payload: &[u8]) -> Result<Option<(f64, &'static str)>, Why> {
    // Octet 47 (4.8) or 50 (4.11) of section 4: the statistical process, then the type of
    // increment, the unit and the length of the time range; the payload starts at octet 6.
    let at = match template {
        8 => 41,
        11 => 44,
        _ => return Ok(None),
    };
    let (Some(&process), Some(&unit), Some(length)) = (
        payload.get(at),
        payload.get(at + 2),
        payload.get(at + 3..at + 7),
    ) else {
        return Err("a statistical product definition cut short".into());
    };
    let length = u32::from_be_bytes(length.try_into().expect("4 octets")) as f64;
    let kind = match process {
        0 => "avg",
        1 => "accum",
        2 => "max",
        3 => "min",
        4 => "diff",
        _ => "stat",
    };
    Ok(Some((length * unit_hours(unit)?, kind)))
}

/// The metadata of a GRIB2 message (values are decoded by [`values`]).
pub(super) fn field(msg: &[u8], k: usize) -> Result<GribField, Why> {
    with_field(msg, k, |sub| {
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
        let mut step_hours = match prod.forecast_time() {
            Some(ft) => {
                let unit = match ft.unit {
                    grib::Code::Name(u) => u8::from(u),
                    grib::Code::Num(n) => n,
                };
                ft.value as f64 * unit_hours(unit)?
            }
            None => 0.0,
        };
        let payload: Vec<u8> = prod.iter().copied().collect();
        let mut step_type = "instant";
        if let Some((length, kind)) = statistics(template, &payload)? {
            step_hours += length;
            step_type = kind;
        }
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
        if kind.ends_with("_gg") {
            // N, octets 68–71 of section 3 (payload from octet 6): its latitudes cost O(N²).
            let n: Vec<u8> = sub.grid_def().iter().skip(62).take(4).copied().collect();
            let n = n.try_into().map(u32::from_be_bytes).unwrap_or(0) as usize;
            if n == 0 || n > super::model::MAX_GAUSSIAN_N {
                return Err(format!(
                    "a Gaussian grid of N = {n}; expected 1 to {}",
                    super::model::MAX_GAUSSIAN_N
                ));
            }
        }
        let packing = packing(sub.repr_def().repr_tmpl_num())?;
        let section3: Vec<u8> = sub.grid_def().iter().copied().collect();
        let grid = if kind == "regular_gg" && section3.get(25..29) == Some(&[0xff; 4]) {
            reduced_gaussian(&section3)?
        } else {
            node_positions(&sub, kind)?
        };
        Ok(GribField {
            edition: 2,
            step_type: step_type.to_string(),
            param: names::grib2_param(discipline, category, number, &level),
            level,
            reference,
            step_hours,
            number: ensemble,
            grid,
            packing: packing.to_string(),
            centre: sub.identification().centre_id(),
            pv: vertical_parameters(&payload)?,
        })
    })
}

/// The vertical coordinate parameters after section 4's template: NV (octets 6–7) IEEE
/// single-precision floats ending the section; `payload` is the section from octet 6.
fn vertical_parameters(payload: &[u8]) -> Result<Vec<f64>, Why> {
    let nv = payload
        .get(..2)
        .map_or(0, |b| u16::from_be_bytes([b[0], b[1]]) as usize);
    if nv == 0 {
        return Ok(Vec::new());
    }
    let start = payload
        .len()
        .checked_sub(4 * nv)
        .filter(|&s| s >= 4)
        .ok_or_else(|| {
            format!(
                "{nv} vertical coordinate parameters in a product definition section of {} octets",
                payload.len() + 5
            )
        })?;
    Ok(payload[start..]
        .chunks_exact(4)
        .map(|b| f32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64)
        .collect())
}

/// The node positions the crate computes for a grid of `kind`, rows turned one way.
fn node_positions(
    sub: &grib::SubMessage<impl grib::Grib2Read>,
    kind: &str,
) -> Result<GridInfo, Why> {
    let (ni, nj) = sub.grid_shape().map_err(one_line)?;
    super::model::check_grid(ni, nj)?;
    let (lats, lons): (Vec<f64>, Vec<f64>) = grib::LatLons::latlons_unchecked(&sub)
        .map_err(one_line)?
        .unzip();
    if lats.len() != ni * nj {
        return Err(format!(
            "{} node positions for a grid of {ni} × {nj}",
            lats.len()
        ));
    }
    Ok(GridInfo {
        kind: kind.to_string(),
        ni,
        nj,
        lats,
        lons,
        alternate_rows: false,
        row_points: None,
    }
    .rows_one_way()
    .across_the_seam())
}

/// A global reduced Gaussian grid (template 3.40 with Ni missing) from section 3's payload
/// (octet 6 on): N, the first and last rows, and the points of each row in the list after
/// the template (octet 73 on, of the width octet 11 gives).
fn reduced_gaussian(s3: &[u8]) -> Result<GridInfo, Why> {
    let short = || "a reduced Gaussian grid's section 3 ends early (truncated)".to_string();
    let uint = |at: usize, n: usize| -> Result<u64, Why> {
        let b = s3.get(at..at + n).ok_or_else(short)?;
        Ok(b.iter().fold(0u64, |acc, &x| (acc << 8) | x as u64))
    };
    // GRIB2's signed integers: sign bit, then magnitude; angles in micro-degrees.
    let degrees = |at: usize| -> Result<f64, Why> {
        let v = uint(at, 4)?;
        let magnitude = (v & 0x7fff_ffff) as f64 * 1e-6;
        Ok(if v & 0x8000_0000 != 0 {
            -magnitude
        } else {
            magnitude
        })
    };
    let (width, interpretation) = (uint(5, 1)? as usize, uint(6, 1)?);
    let (nj, n) = (uint(29, 4)? as usize, uint(62, 4)? as usize);
    if width == 0 || interpretation != 1 || uint(33, 4)? != 0 || uint(37, 4)? != 0xffff_ffff {
        return Err(format!("a reduced Gaussian grid with a row list of {width}-octet numbers (interpretation {interpretation}) or a basic angle is not read"));
    }
    if uint(66, 1)? & 0x20 != 0 {
        return Err("a reduced grid with points consecutive along meridians is not read".into());
    }
    super::model::check_grid(1, nj)?;
    let row_points: Vec<usize> = (0..nj)
        .map(|j| uint(67 + width * j, width).map(|v| v as usize))
        .collect::<Result<_, _>>()?;
    let (la1, lo1, la2, lo2) = (degrees(41)?, degrees(45)?, degrees(50)?, degrees(54)?);
    let lats = super::model::gaussian_rows(n, la1, la2, nj)?;
    GridInfo::reduced(lats, row_points, (lo1, lo2))
}

/// The message's values in scanning order, missing points as NaN.
pub(super) fn values(msg: &[u8], k: usize) -> Result<Vec<f64>, Why> {
    with_field(msg, k, |sub| {
        let (points, coded) = (sub.grid_def().num_points(), sub.repr_def().num_points());
        if coded > points {
            return Err(format!(
                "{coded} coded values for a grid of {points} points (damaged)"
            ));
        }
        let decoder = grib::Grib2SubmessageDecoder::from(sub).map_err(one_line)?;
        let values = decoder.dispatch().map_err(one_line)?;
        // A damaged message may decode to more values than its grid has: stop one past.
        let values: Vec<f64> = values.map(f64::from).take(points as usize + 1).collect();
        if values.len() != points as usize {
            return Err(format!(
                "{} values decoded for a grid of {points} points (damaged)",
                if values.len() > points as usize {
                    "more".to_string()
                } else {
                    values.len().to_string()
                }
            ));
        }
        Ok(values)
    })
}
