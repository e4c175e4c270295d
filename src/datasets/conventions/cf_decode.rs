//! CF's decoding of stored values (CF 1.11 sections 2.5 and 8.1, the NetCDF User Guide's
//! attribute conventions), the one decoder every reader with attributes uses (NetCDF, HDF5), in
//! this order: the signedness `_Unsigned` declares, masking (values equal to `_FillValue` or to
//! any `missing_value`, or outside `valid_range` / `valid_min` / `valid_max`, become NaN; a
//! variable without `_FillValue` has netCDF's default fill of its type as its fill, since the
//! unwritten parts of a file hold it and netCDF-C and netCDF4-python mask it), then unpacking
//! (`stored * scale_factor + add_offset`). The masking attributes are compared in the stored
//! type, as netCDF-C compares them: a float32 variable's `_FillValue` is rounded to float32.

use crate::datasets::readers::variables::NcAttribute;

/// The type values are stored in, as far as decoding needs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stored {
    Float32,
    Float64,
    /// An integer of `bits` bits, unsigned or not as stored (before `_Unsigned`).
    Int {
        bits: u32,
        unsigned: bool,
    },
    /// Anything else (characters, strings): nothing to decode.
    Other,
}

/// How one variable's stored values become physical values.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CfDecoding {
    /// `_Unsigned` contradicting the stored type: (2^bits, read as unsigned).
    sign: Option<(f64, bool)>,
    fill: Option<f64>,
    missing: Vec<f64>,
    valid_min: Option<f64>,
    valid_max: Option<f64>,
    scale: f64,
    offset: f64,
}

fn number(attrs: &[(String, NcAttribute)], key: &str) -> Option<Vec<f64>> {
    attrs.iter().find_map(|(k, v)| match v {
        NcAttribute::Numbers(n) if k == key && !n.is_empty() => Some(n.clone()),
        _ => None,
    })
}

fn text<'a>(attrs: &'a [(String, NcAttribute)], key: &str) -> Option<&'a str> {
    attrs.iter().find_map(|(k, v)| match v {
        NcAttribute::Text(t) if k == key => Some(t.trim()),
        _ => None,
    })
}

impl CfDecoding {
    /// The decoding the attributes `attrs` of a NetCDF variable stored as `stored` ask for.
    pub(crate) fn of(attrs: &[(String, NcAttribute)], stored: Stored) -> CfDecoding {
        Self::with_defaults(attrs, stored, true)
    }

    /// [`CfDecoding::of`], with netCDF's default fill values only where `netcdf_defaults`: they
    /// are netCDF's, and a plain HDF5 dataset's values are data unless its attributes say not.
    pub(crate) fn with_defaults(
        attrs: &[(String, NcAttribute)],
        stored: Stored,
        netcdf_defaults: bool,
    ) -> CfDecoding {
        let unsigned =
            text(attrs, "_Unsigned").and_then(|u| match u.to_ascii_lowercase().as_str() {
                "true" => Some(true),
                "false" => Some(false),
                _ => None,
            });
        let sign = match (stored, unsigned) {
            (Stored::Int { bits, unsigned: u }, Some(want)) if want != u => {
                Some((2f64.powi(bits as i32), want))
            }
            _ => None,
        };
        let in_stored_type = |v: f64| {
            let v = if stored == Stored::Float32 {
                f64::from(v as f32)
            } else {
                v
            };
            reinterpret(sign, v)
        };
        let first = |key: &str| number(attrs, key).map(|n| in_stored_type(n[0]));
        let fill = match attrs.iter().any(|(k, _)| k == "_FillValue") {
            true => first("_FillValue"),
            false if netcdf_defaults => default_fill(stored, unsigned),
            false => None,
        };
        let (valid_min, valid_max) = match number(attrs, "valid_range") {
            Some(r) if r.len() >= 2 => (Some(in_stored_type(r[0])), Some(in_stored_type(r[1]))),
            _ => (first("valid_min"), first("valid_max")),
        };
        let scale = number(attrs, "scale_factor").map_or(1.0, |n| n[0]);
        let offset = number(attrs, "add_offset").map_or(0.0, |n| n[0]);
        CfDecoding {
            sign,
            fill,
            missing: number(attrs, "missing_value")
                .unwrap_or_default()
                .into_iter()
                .map(in_stored_type)
                .collect(),
            valid_min,
            valid_max,
            scale,
            offset,
        }
    }

    /// The stored values that mean missing, where decoding does nothing else (no `_Unsigned`
    /// reinterpretation, valid range, scale or offset): then a stored value is its physical one
    /// unless it is one of these. `None` otherwise.
    pub(crate) fn masks_only(&self) -> Option<Vec<f64>> {
        let plain = self.sign.is_none()
            && self.valid_min.is_none()
            && self.valid_max.is_none()
            && self.scale == 1.0
            && self.offset == 0.0;
        plain.then(|| self.fill.iter().chain(&self.missing).copied().collect())
    }

    /// The physical value of one stored value: NaN where it is missing.
    pub(crate) fn value(&self, stored: f64) -> f64 {
        let v = reinterpret(self.sign, stored);
        let masked = self.fill == Some(v)
            || self.missing.contains(&v)
            || self.valid_min.is_some_and(|lo| v < lo)
            || self.valid_max.is_some_and(|hi| v > hi);
        if masked {
            f64::NAN
        } else if self.scale == 1.0 && self.offset == 0.0 {
            v
        } else {
            v * self.scale + self.offset
        }
    }

    /// Every value of `values` decoded in place.
    pub(crate) fn apply(&self, values: &mut [f64]) {
        for v in values {
            *v = self.value(*v);
        }
    }
}

/// An integer under the signedness `_Unsigned` declares.
fn reinterpret(sign: Option<(f64, bool)>, v: f64) -> f64 {
    match sign {
        Some((modulus, true)) if v < 0.0 => v + modulus,
        Some((modulus, false)) if v >= modulus / 2.0 => v - modulus,
        _ => v,
    }
}

/// netCDF's default fill value (netcdf.h's `NC_FILL_*`) of the type the values have once
/// `_Unsigned` is applied, as f64 (the 64-bit ones rounded, as every such value is when read as
/// f64).
fn default_fill(stored: Stored, unsigned: Option<bool>) -> Option<f64> {
    Some(match stored {
        Stored::Float32 | Stored::Float64 => 9.969_209_968_386_869e36,
        Stored::Int { bits, unsigned: u } => match (bits, unsigned.unwrap_or(u)) {
            (8, true) => 255.0,
            (8, false) => -127.0,
            (16, true) => 65535.0,
            (16, false) => -32767.0,
            (32, true) => 4_294_967_295.0,
            (32, false) => -2_147_483_647.0,
            (64, true) => 18_446_744_073_709_551_614_u64 as f64,
            (64, false) => -9_223_372_036_854_775_806_i64 as f64,
            _ => return None,
        },
        Stored::Other => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attrs(list: &[(&str, NcAttribute)]) -> Vec<(String, NcAttribute)> {
        list.iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect()
    }

    fn nums(v: &[f64]) -> NcAttribute {
        NcAttribute::Numbers(v.to_vec())
    }

    #[test]
    fn masks_then_unpacks_in_the_stored_type() {
        let short = Stored::Int {
            bits: 16,
            unsigned: false,
        };
        let d = CfDecoding::of(
            &attrs(&[
                ("_FillValue", nums(&[-999.0])),
                ("missing_value", nums(&[-998.0, -997.0])),
                ("valid_range", nums(&[-100.0, 100.0])),
                ("scale_factor", nums(&[0.5])),
                ("add_offset", nums(&[10.0])),
            ]),
            short,
        );
        let mut v = vec![-999.0, -998.0, -997.0, -101.0, 101.0, 4.0, -100.0];
        d.apply(&mut v);
        assert!(v[..5].iter().all(|x| x.is_nan()), "{v:?}");
        assert_eq!(v[5..], [12.0, -40.0]);
        // A float32 fill written as a double attribute matches the stored float32.
        let f = CfDecoding::of(&attrs(&[("_FillValue", nums(&[0.1]))]), Stored::Float32);
        assert!(f.value(f64::from(0.1f32)).is_nan());
    }

    #[test]
    fn default_fills_and_unsigned_bytes() {
        let byte = Stored::Int {
            bits: 8,
            unsigned: false,
        };
        // No _FillValue: netCDF's default for the type is missing.
        let d = CfDecoding::of(&[], byte);
        assert!(d.value(-127.0).is_nan());
        assert_eq!(d.value(-126.0), -126.0);
        // _Unsigned bytes: -1 is 255, the unsigned default fill.
        let u = CfDecoding::of(
            &attrs(&[("_Unsigned", NcAttribute::Text("true".into()))]),
            byte,
        );
        assert!(u.value(-1.0).is_nan());
        assert_eq!(u.value(-2.0), 254.0);
        assert!(CfDecoding::of(&[], Stored::Float64)
            .value(9.969_209_968_386_869e36)
            .is_nan());
    }
}
