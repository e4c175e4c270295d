//! GRIB edition 1 (WMO FM 92 GRIB, edition 1), decoded here: the `grib` crate reads edition 2
//! only, and what archives still hold in edition 1 (NCEP's Eta and reanalysis files, ERA-40,
//! ECMWF's MARS) is grid-point data in simple packing, which is short to decode. Read: the
//! product definition (parameter, level, reference time and forecast step, ECMWF's ensemble
//! member), regular, Gaussian (also reduced) and rotated latitude–longitude grids, Mercator,
//! Lambert conformal and polar stereographic grids, the bitmap, and simple packing
//! Y = (R + X·2^E)/10^D with R an IBM single-precision float. Reduced latitude–longitude grids,
//! spherical harmonics and second-order packing are refused in one line naming what the
//! message holds.

use super::model::{GribField, GridInfo};
use super::names;

/// An unsigned big-endian integer of `n` octets at `at`.
fn uint(b: &[u8], at: usize, n: usize) -> Option<u64> {
    let bytes = b.get(at..at + n)?;
    Some(bytes.iter().fold(0u64, |acc, &x| (acc << 8) | x as u64))
}

/// GRIB1's signed integers: the top bit is the sign, the rest the magnitude.
fn signed(b: &[u8], at: usize, n: usize) -> Option<i64> {
    let v = uint(b, at, n)?;
    let sign_bit = 1u64 << (8 * n - 1);
    let magnitude = (v & (sign_bit - 1)) as i64;
    Some(if v & sign_bit != 0 {
        -magnitude
    } else {
        magnitude
    })
}

/// An IBM System/360 single-precision float: sign, 7-bit excess-64 exponent of 16, 24-bit
/// fraction.
pub(super) fn ibm_float(bits: u32) -> f64 {
    let sign = if bits & 0x8000_0000 != 0 { -1.0 } else { 1.0 };
    let exponent = ((bits >> 24) & 0x7f) as i32 - 64;
    let fraction = (bits & 0x00ff_ffff) as f64 / (1u64 << 24) as f64;
    sign * fraction * 16f64.powi(exponent)
}

/// Why a message cannot be read, in words for a one-line error.
type Why = String;

/// The sections of one GRIB1 message (bytes from "GRIB" to "7777").
struct Sections<'a> {
    pds: &'a [u8],
    gds: Option<&'a [u8]>,
    bms: Option<&'a [u8]>,
    bds: &'a [u8],
}

fn sections(msg: &[u8]) -> Result<Sections<'_>, Why> {
    let short = || "the message ends inside a section (truncated)".to_string();
    let section = |at: usize| -> Result<&[u8], Why> {
        let len = uint(msg, at, 3).ok_or_else(short)? as usize;
        if len < 3 {
            return Err(format!("a section length of {len} octets at offset {at}"));
        }
        msg.get(at..at + len).ok_or_else(short)
    };
    let pds = section(8)?;
    if pds.len() < 28 {
        return Err(format!(
            "a product definition section of {} octets; expected at least 28",
            pds.len()
        ));
    }
    let flags = pds[7];
    let mut at = 8 + pds.len();
    let gds = if flags & 0x80 != 0 {
        let s = section(at)?;
        at += s.len();
        Some(s)
    } else {
        None
    };
    let bms = if flags & 0x40 != 0 {
        let s = section(at)?;
        at += s.len();
        Some(s)
    } else {
        None
    };
    let bds = section(at)?;
    if msg.get(at + bds.len()..at + bds.len() + 4) != Some(b"7777") {
        return Err("no end section '7777' after the data (truncated or damaged)".into());
    }
    Ok(Sections { pds, gds, bms, bds })
}

/// The metadata of a GRIB1 message (its values are decoded by [`values`]).
pub(super) fn field(msg: &[u8]) -> Result<GribField, Why> {
    let s = sections(msg)?;
    let p = s.pds;
    let table = p[3];
    let centre = p[4] as u16;
    let parameter = p[8];
    let level_type = p[9];
    let level = names::grib1_level(level_type, p[10], p[11]);
    let century = p[24] as i64;
    let year = (century - 1) * 100 + p[12] as i64;
    let (month, day, hour, minute) = (p[13], p[14], p[15], p[16]);
    let unit_hours = match p[17] {
        0 => 1.0 / 60.0,
        1 => 1.0,
        2 => 24.0,
        10 => 3.0,
        11 => 6.0,
        12 => 12.0,
        13 => 0.25,
        254 => 1.0 / 3600.0,
        u => {
            return Err(format!(
                "unit of time range {u} (GRIB1 code table 4) is not read"
            ))
        }
    };
    let (p1, p2, range) = (p[18] as f64, p[19] as f64, p[20]);
    let step_hours = unit_hours
        * match range {
            // P1 and P2 form one 16-bit forecast time.
            10 => uint(p, 18, 2).unwrap_or(0) as f64,
            // Averages and accumulations from P1 to P2 are labelled at their end, as ecCodes does.
            2..=5 => p2,
            _ => p1,
        };
    let grid = match s.gds {
        Some(gds) => grid(gds)?,
        None => return Err(format!("a predefined grid (catalogue number {}) without a grid description section is not read", p[6])),
    };
    Ok(GribField {
        edition: 1,
        param: names::grib1_param(table, (centre, p[25]), parameter, &level),
        level,
        reference: format!("{year:04}-{month:02}-{day:02} {hour:02}:{minute:02}:00"),
        step_hours,
        step_type: if (2..=5).contains(&range) {
            "stat"
        } else {
            "instant"
        }
        .into(),
        number: ecmwf_member(p, centre),
        grid,
        packing: "grid_simple".into(),
        centre,
        pv: s
            .gds
            .map(vertical_parameters)
            .transpose()?
            .unwrap_or_default(),
    })
}

/// The vertical coordinate parameters (IBM floats) the grid description carries for model
/// levels: NV of them (octet 4) from the octet octet 5 names.
fn vertical_parameters(gds: &[u8]) -> Result<Vec<f64>, Why> {
    let (nv, pvl) = (gds[3] as usize, gds[4] as usize);
    if nv == 0 || pvl == 255 || pvl == 0 {
        return Ok(Vec::new());
    }
    (0..nv)
        .map(|i| uint(gds, pvl - 1 + 4 * i, 4).map(|b| ibm_float(b as u32)))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("{nv} vertical coordinate parameters that the grid description section does not hold (truncated)"))
}

/// The ensemble member of an ECMWF product (centre or sub-centre 98), where ecCodes reads
/// `perturbationNumber` after the MARS labels of its local definition (octet 41 on): one octet
/// at octet 50 in definitions 1, 15, 16, 26, 30 and 36, two octets at 50–51 in definition 12
/// (monthly means, as seasonal forecasts are archived).
fn ecmwf_member(pds: &[u8], centre: u16) -> Option<i64> {
    if !(centre == 98 || pds.get(25) == Some(&98)) {
        return None;
    }
    match pds.get(40)? {
        1 | 15 | 16 | 26 | 30 | 36 => pds.get(49).map(|&n| n as i64),
        12 => pds
            .get(49..51)
            .map(|b| u16::from_be_bytes([b[0], b[1]]) as i64),
        _ => None,
    }
}

/// Latitudes and longitudes of a latitude–longitude (0), Gaussian (4) or rotated (10) grid.
fn grid(gds: &[u8]) -> Result<GridInfo, Why> {
    let kind = gds
        .get(5)
        .copied()
        .ok_or("an empty grid description section")?;
    let name = match kind {
        0 => "regular_ll",
        4 => "regular_gg",
        10 => "rotated_ll",
        1 => return mercator(gds),
        3 => return lambert(gds),
        5 => return polar_stereographic(gds),
        50 => {
            return Err("spherical harmonics (GRIB1 grid type 50) are not grid-point data".into())
        }
        k => return Err(format!("GRIB1 grid type {k} (code table 6) is not read")),
    };
    let ni = uint(gds, 6, 2).ok_or_else(short)? as usize;
    let nj = uint(gds, 8, 2).ok_or_else(short)? as usize;
    let reduced = ni == 0xffff;
    if reduced && kind != 4 {
        return Err("a reduced (quasi-regular) latitude–longitude grid is not read; regrid it first (cdo setgridtype,regular)".into());
    }
    super::model::check_grid(if reduced { 1 } else { ni }, nj)?;
    let milli = |at| {
        signed(gds, at, 3)
            .map(|v| v as f64 / 1000.0)
            .ok_or_else(short)
    };
    let (la1, lo1, la2, lo2) = (milli(10)?, milli(13)?, milli(17)?, milli(20)?);
    let scan = gds.get(27).copied().ok_or_else(short)?;
    if scan & 0x20 != 0 {
        return Err("points consecutive along meridians (scanning mode 0x20) are not read".into());
    }
    let lons = axis_between(lo1, lo2, ni, scan & 0x80 != 0, true);
    let lats = if kind == 4 {
        let n = uint(gds, 25, 2).ok_or_else(short)? as usize;
        if n == 0 || n > super::model::MAX_GAUSSIAN_N || nj > 2 * n {
            return Err(format!(
                "a Gaussian grid of N = {n}; expected 1 to {}",
                super::model::MAX_GAUSSIAN_N
            ));
        }
        super::model::gaussian_rows(n, la1, la2, nj)?
    } else {
        axis_between(la1, la2, nj, scan & 0x40 == 0, false)
    };
    if reduced {
        return reduced_gaussian(gds, lats, (lo1, lo2));
    }
    let mut info = GridInfo::regular(name, lats, lons).across_the_seam();
    if kind == 10 {
        let south_lat = milli(32)?;
        let south_lon = milli(35)?;
        let angle = uint(gds, 38, 4).map(|b| ibm_float(b as u32)).unwrap_or(0.0);
        if angle != 0.0 {
            return Err(format!(
                "a rotated grid turned by {angle}° about the pole is not read"
            ));
        }
        info = info.rotated(south_lat, south_lon)?;
    }
    Ok(info)
}

/// A global reduced Gaussian grid: the points of each row from the grid description's list
/// (after the vertical coordinate parameters, if any), every row from 0° around the globe.
fn reduced_gaussian(gds: &[u8], lats: Vec<f64>, (lo1, lo2): (f64, f64)) -> Result<GridInfo, Why> {
    let (nv, pvl) = (gds[3] as usize, gds[4] as usize);
    if pvl == 255 || pvl == 0 {
        return Err("a reduced grid without its list of points per row".into());
    }
    let at = pvl - 1 + 4 * nv;
    let row_points: Vec<usize> = (0..lats.len())
        .map(|j| uint(gds, at + 2 * j, 2).map(|n| n as usize))
        .collect::<Option<_>>()
        .ok_or("the list of points per row ends early (truncated)")?;
    GridInfo::reduced(lats, row_points, (lo1, lo2))
}

/// A Mercator grid (data representation type 1) on GRIB1's spherical Earth: Di and Dj metres
/// at the latitude Latin where the projection is true; each row at one latitude and each
/// column at one longitude (Snyder 1987, eqs. 7-1, 7-2 and 7-4 with k at Latin).
fn mercator(gds: &[u8]) -> Result<GridInfo, Why> {
    let u = |at: usize, n: usize| uint(gds, at, n).ok_or_else(short);
    let (ni, nj) = (u(6, 2)? as usize, u(8, 2)? as usize);
    super::model::check_grid(ni, nj)?;
    if u(16, 1)? & 0x40 != 0 {
        return Err(
            "a Mercator grid on the oblate IAU 1965 spheroid is not read (the spherical Earth is)"
                .into(),
        );
    }
    let (la1, lo1, latin) = (radians(gds, 10)?, radians(gds, 13)?, radians(gds, 23)?);
    let scan = u(27, 1)?;
    let (di, dj) = (u(28, 3)? as f64, u(31, 3)? as f64);
    if scan & 0x20 != 0 || di == 0.0 || dj == 0.0 || latin.abs() >= 89f64.to_radians() {
        return Err(format!(
            "a Mercator grid with scanning mode {scan:#04x}, steps {di} × {dj} m and Latin {:.3}° is not read",
            latin.to_degrees()
        ));
    }
    let r = EARTH_RADIUS_M * latin.cos();
    let (dx, dy) = (
        if scan & 0x80 != 0 { -di } else { di },
        if scan & 0x40 != 0 { dj } else { -dj },
    );
    let y1 = r * (std::f64::consts::FRAC_PI_4 + la1 / 2.0).tan().ln();
    let lats = (0..nj)
        .map(|j| {
            (2.0 * ((y1 + j as f64 * dy) / r).exp().atan() - std::f64::consts::FRAC_PI_2)
                .to_degrees()
        })
        .collect();
    let lons = (0..ni)
        .map(|i| (lo1 + i as f64 * dx / r).to_degrees())
        .collect();
    Ok(GridInfo::regular("mercator", lats, lons).across_the_seam())
}

/// The radius of GRIB1's spherical Earth (m), when the resolution flags do not ask for the
/// IAU 1965 spheroid.
const EARTH_RADIUS_M: f64 = 6_367_470.0;

/// What GRIB1's projected grids (Lambert conformal, polar stereographic) share in their grid
/// description: the grid's size, its first point and the orientation longitude (radians), the
/// steps in metres with the direction the scanning mode gives them, and the octets to read the
/// rest from.
struct Projected<'a> {
    gds: &'a [u8],
    ni: usize,
    nj: usize,
    la1: f64,
    lo1: f64,
    lov: f64,
    /// Dx and Dy in metres, signed by the scanning mode.
    step: (f64, f64),
}

impl<'a> Projected<'a> {
    fn read(gds: &'a [u8], what: &str) -> Result<Projected<'a>, Why> {
        let u = |at: usize, n: usize| uint(gds, at, n).ok_or_else(short);
        let (ni, nj) = (u(6, 2)? as usize, u(8, 2)? as usize);
        super::model::check_grid(ni, nj)?;
        if u(16, 1)? & 0x40 != 0 {
            return Err(format!(
                "a {what} grid on the oblate IAU 1965 spheroid is not read (the spherical Earth is)"
            ));
        }
        let (dx, dy) = (u(20, 3)? as f64, u(23, 3)? as f64);
        let scan = u(27, 1)?;
        if scan & 0x20 != 0 || dx == 0.0 || dy == 0.0 {
            return Err(format!(
                "a {what} grid with scanning mode {scan:#04x} and steps {dx} × {dy} m is not read"
            ));
        }
        Ok(Projected {
            gds,
            ni,
            nj,
            la1: radians(gds, 10)?,
            lo1: radians(gds, 13)?,
            lov: radians(gds, 17)?,
            step: (
                if scan & 0x80 != 0 { -dx } else { dx },
                if scan & 0x40 != 0 { dy } else { -dy },
            ),
        })
    }

    /// The grid of `kind` whose first point projects to `first` (metres) and whose nodes
    /// `unproject` turns into latitude and longitude (radians).
    fn nodes(
        &self,
        kind: &str,
        first: (f64, f64),
        unproject: impl Fn(f64, f64) -> (f64, f64),
    ) -> GridInfo {
        let (mut lats, mut lons) = (
            Vec::with_capacity(self.ni * self.nj),
            Vec::with_capacity(self.ni * self.nj),
        );
        for j in 0..self.nj {
            for i in 0..self.ni {
                let x = first.0 + i as f64 * self.step.0;
                let y = first.1 + j as f64 * self.step.1;
                let (phi, lam) = unproject(x, y);
                lats.push(phi.to_degrees());
                lons.push(lam.to_degrees());
            }
        }
        GridInfo {
            kind: kind.into(),
            ni: self.ni,
            nj: self.nj,
            lats,
            lons,
            alternate_rows: false,
            row_points: None,
        }
    }
}

fn short() -> Why {
    "the grid description section is too short".to_string()
}

/// A signed 3-octet angle in millidegrees at `at`, in radians.
fn radians(gds: &[u8], at: usize) -> Result<f64, Why> {
    signed(gds, at, 3)
        .map(|v| (v as f64 / 1000.0).to_radians())
        .ok_or_else(short)
}

/// A Lambert conformal grid (data representation type 3) on GRIB1's spherical Earth: each node
/// placed by the projection's closed forms (Snyder, "Map Projections: A Working Manual", USGS
/// 1987, eqs. 15-1 to 15-5 and 14-4): the first point projected, then steps of Dx and Dy
/// metres, and every node unprojected.
fn lambert(gds: &[u8]) -> Result<GridInfo, Why> {
    let g = Projected::read(gds, "Lambert")?;
    let (latin1, latin2) = (radians(g.gds, 28)?, radians(g.gds, 31)?);
    let t = |phi: f64| (std::f64::consts::FRAC_PI_4 + phi / 2.0).tan();
    let n = if (latin1 - latin2).abs() < 1e-12 {
        latin1.sin()
    } else {
        (latin1.cos() / latin2.cos()).ln() / (t(latin2) / t(latin1)).ln()
    };
    let f = latin1.cos() * t(latin1).powf(n) / n;
    let rho = EARTH_RADIUS_M * f / t(g.la1).powf(n);
    let theta = n * (g.lo1 - g.lov);
    let first = (rho * theta.sin(), -rho * theta.cos());
    Ok(g.nodes("lambert", first, |x, y| {
        let r = n.signum() * x.hypot(y);
        let theta = (n.signum() * x).atan2(-n.signum() * y);
        let phi = 2.0 * (EARTH_RADIUS_M * f / r).powf(1.0 / n).atan() - std::f64::consts::FRAC_PI_2;
        (phi, g.lov + theta / n)
    }))
}

/// A polar stereographic grid (data representation type 5) on GRIB1's spherical Earth, true
/// at 60° in the hemisphere of its projection centre (GRIB1 fixes it there): the first point
/// projected, steps of Dx and Dy metres, every node unprojected (Snyder 1987, eqs. 21-2 to
/// 21-4, 20-14 and 20-15 with k at 60°; the south-polar case by the same forms with latitude
/// and longitude from the pole turned, as ecCodes' iterator writes them with its sign).
fn polar_stereographic(gds: &[u8]) -> Result<GridInfo, Why> {
    let g = Projected::read(gds, "polar stereographic")?;
    // Projection centre flag, bit 1: the south pole is on the projection plane.
    let s = if uint(gds, 26, 1).ok_or_else(short)? & 0x80 != 0 {
        -1.0
    } else {
        1.0
    };
    let scale = EARTH_RADIUS_M * (1.0 + 60f64.to_radians().sin());
    let rho = scale * (std::f64::consts::FRAC_PI_4 - s * g.la1 / 2.0).tan();
    let turn = s * (g.lo1 - g.lov);
    let first = (s * rho * turn.sin(), -s * rho * turn.cos());
    Ok(g.nodes("polar_stereographic", first, |x, y| {
        let phi = s * (std::f64::consts::FRAC_PI_2 - 2.0 * (x.hypot(y) / scale).atan());
        (phi, g.lov + s * (s * x).atan2(-s * y))
    }))
}

/// `n` evenly spaced values from `first` to `last`; `decreasing` says which way they run, and
/// longitudes (`wraps`) cross the seam instead of running back.
fn axis_between(first: f64, last: f64, n: usize, decreasing: bool, wraps: bool) -> Vec<f64> {
    if n <= 1 {
        return vec![first; n];
    }
    let mut span = last - first;
    if wraps {
        if !decreasing && span < 0.0 {
            span += 360.0;
        } else if decreasing && span > 0.0 {
            span -= 360.0;
        }
    }
    let d = span / (n - 1) as f64;
    (0..n).map(|i| first + i as f64 * d).collect()
}

/// The message's values in scanning order, missing points (bitmap) as NaN.
pub(super) fn values(msg: &[u8], points: usize) -> Result<Vec<f64>, Why> {
    let s = sections(msg)?;
    let d = signed(s.pds, 26, 2).unwrap_or(0);
    let bds = s.bds;
    if bds.len() < 11 {
        return Err("a binary data section of under 11 octets".into());
    }
    let flags = bds[3] >> 4;
    if flags & 0x8 != 0 {
        return Err("spherical harmonic coefficients are not grid-point data".into());
    }
    if flags & 0x4 != 0 {
        return Err("second-order (complex) GRIB1 packing is not read yet".into());
    }
    let e = signed(bds, 4, 2).unwrap_or(0) as i32;
    let r = ibm_float(uint(bds, 6, 4).unwrap_or(0) as u32);
    let bits = bds[10] as usize;
    let present = match s.bms {
        Some(bms) => {
            if uint(bms, 4, 2) != Some(0) {
                return Err("a predefined bitmap (not in the message) is not read".into());
            }
            let map = &bms[6..];
            if map.len() * 8 < points {
                return Err(format!(
                    "a bitmap of {} bits for {points} points",
                    map.len() * 8
                ));
            }
            (0..points)
                .map(|i| map[i / 8] & (0x80 >> (i % 8)) != 0)
                .collect()
        }
        None => vec![true; points],
    };
    let packed = present.iter().filter(|&&p| p).count();
    let data = &bds[11..];
    if bits > 0 && data.len() * 8 < packed * bits {
        return Err(format!(
            "{} octets of packed data for {packed} values of {bits} bits (truncated)",
            data.len()
        ));
    }
    let scale = 2f64.powi(e);
    let decimal = 10f64.powi(-(d as i32));
    let mut reader = BitReader { data, at: 0 };
    Ok(present
        .iter()
        .map(|&p| {
            if !p {
                return f64::NAN;
            }
            let x = if bits == 0 { 0 } else { reader.take(bits) };
            (r + x as f64 * scale) * decimal
        })
        .collect())
}

/// Reads big-endian bit fields of any width up to 64.
struct BitReader<'a> {
    data: &'a [u8],
    at: usize,
}

impl BitReader<'_> {
    fn take(&mut self, bits: usize) -> u64 {
        let mut v = 0u64;
        for _ in 0..bits {
            let byte = self.data[self.at / 8];
            v = (v << 1) | ((byte >> (7 - self.at % 8)) & 1) as u64;
            self.at += 1;
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ibm_floats_decode_as_the_format_defines() {
        // 0x4110_0000: fraction 1/16, exponent 65 → 1.0; 0xC276_A000: −118.625 (the textbook
        // example of IBM hexadecimal floating point).
        assert_eq!(ibm_float(0x4110_0000), 1.0);
        assert_eq!(ibm_float(0xC276_A000), -118.625);
        assert_eq!(ibm_float(0), 0.0);
    }

    #[test]
    fn sign_and_magnitude_integers() {
        assert_eq!(signed(&[0x80, 0x00, 0x05], 0, 3), Some(-5));
        assert_eq!(signed(&[0x00, 0x01, 0x00], 0, 3), Some(256));
        assert_eq!(signed(&[0x80, 0x01], 0, 2), Some(-1));
    }

    #[test]
    fn bit_fields_cross_octets() {
        let mut r = BitReader {
            data: &[0b1010_1100, 0b0111_0000],
            at: 0,
        };
        assert_eq!(r.take(3), 0b101);
        assert_eq!(r.take(9), 0b0_1100_0111);
    }
}
