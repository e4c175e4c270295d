//! Coastlines embedded in the binary: Natural Earth's 1:110m and 1:50m land outlines (public
//! domain), converted by `tools/coastlines.py` from the TopoJSON of the npm package
//! `world-atlas@2` into `datasets/coastlines/ne_*.bin` (b"HDCL", version, polyline and point
//! counts, the points per polyline, then i32 longitude/latitude pairs in micro-degrees). The
//! files are decoded once, on first use.

use crate::error::{Error, Result};
use std::sync::OnceLock;

/// Which Natural Earth scale to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CoastResolution {
    /// 1:110m, for whole-globe and continental maps (~5 000 points).
    Coarse,
    /// 1:50m, for regional maps (~60 000 points).
    Fine,
}

impl CoastResolution {
    pub fn parse(s: &str) -> Result<CoastResolution> {
        match s {
            "110m" => Ok(CoastResolution::Coarse),
            "50m" => Ok(CoastResolution::Fine),
            _ => Err(Error::invalid(
                "coastlines.resolution",
                format!("expected \"110m\" or \"50m\" (Natural Earth scales), got {s:?}"),
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            CoastResolution::Coarse => "110m",
            CoastResolution::Fine => "50m",
        }
    }

    /// The scale for a view spanning `degrees` of longitude or latitude at most: 50m under 60°,
    /// where the 110m outlines' kilometre-scale corners would show, else 110m.
    pub(crate) fn for_extent(degrees: f64) -> CoastResolution {
        if degrees < 60.0 {
            CoastResolution::Fine
        } else {
            CoastResolution::Coarse
        }
    }
}

/// A polyline of (longitude, latitude) in degrees.
pub(crate) type Polyline = Vec<[f64; 2]>;

static COARSE: OnceLock<Vec<Polyline>> = OnceLock::new();
static FINE: OnceLock<Vec<Polyline>> = OnceLock::new();

/// The coastlines at `res`, as polylines of (longitude, latitude) in degrees within ±180, ±90.
pub fn coastlines(res: CoastResolution) -> &'static [Polyline] {
    match res {
        CoastResolution::Coarse => COARSE.get_or_init(|| {
            decode(include_bytes!("../../datasets/coastlines/ne_110m.bin")).expect("ne_110m.bin")
        }),
        CoastResolution::Fine => FINE.get_or_init(|| {
            decode(include_bytes!("../../datasets/coastlines/ne_50m.bin")).expect("ne_50m.bin")
        }),
    }
}

/// Decodes one coastline file; `None` when it is not one (the embedded files always are).
fn decode(bytes: &[u8]) -> Option<Vec<Polyline>> {
    let word = |i: usize| -> Option<u32> {
        Some(u32::from_le_bytes(
            bytes.get(4 * i..4 * i + 4)?.try_into().ok()?,
        ))
    };
    if bytes.get(..4)? != b"HDCL" || word(1)? != 1 {
        return None;
    }
    let (lines, points) = (word(2)? as usize, word(3)? as usize);
    let mut next = 4 + lines;
    let mut out = Vec::with_capacity(lines);
    for l in 0..lines {
        let n = word(4 + l)? as usize;
        let line = (0..n)
            .map(|k| {
                let at = next + 2 * k;
                Some([
                    word(at)? as i32 as f64 * 1e-6,
                    word(at + 1)? as i32 as f64 * 1e-6,
                ])
            })
            .collect::<Option<Polyline>>()?;
        next += 2 * n;
        out.push(line);
    }
    (next == 4 + lines + 2 * points && bytes.len() == 4 * next).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_files_decode_with_their_counts_and_ranges() {
        for (res, lines, points) in [
            (CoastResolution::Coarse, 128, 5123),
            (CoastResolution::Fine, 1422, 60367),
        ] {
            let c = coastlines(res);
            assert_eq!(c.len(), lines, "{}", res.name());
            assert_eq!(c.iter().map(Vec::len).sum::<usize>(), points);
            for p in c.iter().flatten() {
                assert!(p[0].abs() <= 180.0 && p[1].abs() <= 90.0, "{p:?}");
            }
        }
    }

    #[test]
    fn cape_of_good_hope_is_on_the_coast() {
        // 18.47°E 34.36°S: the nearest vertex of either scale lies within 0.3° (the 110m outline
        // cuts the cape's tip by about 0.24°).
        for res in [CoastResolution::Coarse, CoastResolution::Fine] {
            let d = coastlines(res)
                .iter()
                .flatten()
                .map(|p| (p[0] - 18.47).hypot(p[1] + 34.36))
                .fold(f64::INFINITY, f64::min);
            assert!(d < 0.3, "{}: {d}", res.name());
        }
    }

    #[test]
    fn bad_names_and_files_are_refused() {
        let e = CoastResolution::parse("10m").unwrap_err().to_string();
        assert!(
            e.starts_with("coastlines.resolution:") && e.contains("110m"),
            "{e}"
        );
        assert!(decode(b"HDCL").is_none());
        assert!(decode(&[0; 16]).is_none());
    }
}
