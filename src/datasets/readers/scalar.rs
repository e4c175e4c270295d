//! The binary sample types of raw volume files (NRRD, VTK ImageData, NumPy) and
//! their one conversion to f32. Each format names the types its own way and maps the names here;
//! the decoding is shared, so the same bytes give the same value whatever file they came in.
//! Integers of 32 and 64 bits go through f64, as the in-memory `.npy` reader converts them, so a
//! `.npy` read in place and a loaded one hold the same values.

/// One stored sample type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    F16,
    F32,
    F64,
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
}

impl Scalar {
    /// Bytes per sample.
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::F16 | Scalar::I16 | Scalar::U16 => 2,
            Scalar::F32 | Scalar::I32 | Scalar::U32 => 4,
            Scalar::F64 | Scalar::I64 | Scalar::U64 => 8,
        }
    }

    /// NumPy's name of the type (`float32`, `int16`, ...), as listings show it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Scalar::F16 => "float16",
            Scalar::F32 => "float32",
            Scalar::F64 => "float64",
            Scalar::I8 => "int8",
            Scalar::I16 => "int16",
            Scalar::I32 => "int32",
            Scalar::I64 => "int64",
            Scalar::U8 => "uint8",
            Scalar::U16 => "uint16",
            Scalar::U32 => "uint32",
            Scalar::U64 => "uint64",
        }
    }

    /// Converts `bytes` (a whole number of samples) into `out`, big- or little-endian.
    pub(crate) fn decode_into(self, big: bool, bytes: &[u8], out: &mut [f32]) {
        if self == Scalar::F32 && !big {
            for (o, c) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                *o = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            }
            return;
        }
        self.decode_as(big, bytes, out, |v| v, |v| v as f32);
    }

    /// [`Scalar::decode_into`] for f64 values: every type but 64-bit integers beyond 2^53 exactly
    /// (float64 data keep their precision).
    pub(crate) fn decode_f64(self, big: bool, bytes: &[u8]) -> Vec<f64> {
        let mut out = vec![0.0; bytes.len() / self.size()];
        self.decode_as(big, bytes, &mut out, f64::from, |v| v);
        out
    }

    /// The one conversion of samples: floats of 32 bits or less through `from_f32`, every other
    /// type through `from_f64` (which holds integers up to 2^53 exactly).
    fn decode_as<T>(
        self,
        big: bool,
        bytes: &[u8],
        out: &mut [T],
        from_f32: impl Fn(f32) -> T,
        from_f64: impl Fn(f64) -> T,
    ) {
        macro_rules! conv {
            ($t:ty, $n:literal, $f:expr) => {{
                for (o, c) in out.iter_mut().zip(bytes.chunks_exact($n)) {
                    let a: [u8; $n] = c.try_into().expect("chunk of sample size");
                    let v = if big {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    };
                    *o = $f(v);
                }
            }};
        }
        match self {
            Scalar::F32 => conv!(f32, 4, &from_f32),
            Scalar::F64 => conv!(f64, 8, &from_f64),
            Scalar::F16 => conv!(u16, 2, |v| from_f32(half::f16::from_bits(v).to_f32())),
            Scalar::I8 => conv!(i8, 1, |v| from_f64(f64::from(v))),
            Scalar::U8 => conv!(u8, 1, |v| from_f64(f64::from(v))),
            Scalar::I16 => conv!(i16, 2, |v| from_f64(f64::from(v))),
            Scalar::U16 => conv!(u16, 2, |v| from_f64(f64::from(v))),
            Scalar::I32 => conv!(i32, 4, |v| from_f64(f64::from(v))),
            Scalar::U32 => conv!(u32, 4, |v| from_f64(f64::from(v))),
            Scalar::I64 => conv!(i64, 8, |v| from_f64(v as f64)),
            Scalar::U64 => conv!(u64, 8, |v| from_f64(v as f64)),
        }
    }

    /// One sample written as text (ascii VTK and NRRD data): a float sample is parsed straight
    /// to f32 so that it rounds once, exactly as its binary form would hold it.
    pub(crate) fn parse_text(self, word: &str) -> Option<f32> {
        match self {
            Scalar::F32 | Scalar::F16 => word.parse::<f32>().ok(),
            _ => word.parse::<f64>().ok().map(|v| v as f32),
        }
    }

    /// Every sample of `bytes` (a whole number of samples) as f32.
    pub(crate) fn decode(self, big: bool, bytes: &[u8]) -> Vec<f32> {
        let mut out = vec![0.0; bytes.len() / self.size()];
        self.decode_into(big, bytes, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::Scalar;

    #[test]
    fn every_type_decodes_both_byte_orders() {
        let cases: [(Scalar, Vec<u8>, f32); 11] = [
            (Scalar::I8, (-5i8).to_le_bytes().to_vec(), -5.0),
            (Scalar::U8, 200u8.to_le_bytes().to_vec(), 200.0),
            (Scalar::I16, (-300i16).to_le_bytes().to_vec(), -300.0),
            (Scalar::U16, 60_000u16.to_le_bytes().to_vec(), 60_000.0),
            (Scalar::I32, (-70_000i32).to_le_bytes().to_vec(), -70_000.0),
            (Scalar::U32, 4_000_000_000u32.to_le_bytes().to_vec(), 4e9),
            (
                Scalar::I64,
                (-1i64 << 40).to_le_bytes().to_vec(),
                -(2f32.powi(40)),
            ),
            (
                Scalar::U64,
                (1u64 << 50).to_le_bytes().to_vec(),
                2f32.powi(50),
            ),
            (
                Scalar::F16,
                half::f16::from_f32(0.5).to_bits().to_le_bytes().to_vec(),
                0.5,
            ),
            (Scalar::F32, 1.25e-7f32.to_le_bytes().to_vec(), 1.25e-7),
            (Scalar::F64, 3.5e20f64.to_le_bytes().to_vec(), 3.5e20),
        ];
        for (s, le, want) in cases {
            assert_eq!(le.len(), s.size(), "{s:?}");
            assert_eq!(s.decode(false, &le), [want], "{s:?} little-endian");
            let be: Vec<u8> = le.iter().rev().copied().collect();
            assert_eq!(s.decode(true, &be), [want], "{s:?} big-endian");
        }
    }

    #[test]
    fn f64_decoding_keeps_float64_and_integer_precision() {
        let values: [f64; 3] = [1.0 + 1e-12, -3.3e-300, 123_456_789.123_456_78];
        let le: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let be: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
        assert_eq!(Scalar::F64.decode_f64(false, &le), values);
        assert_eq!(Scalar::F64.decode_f64(true, &be), values);
        let ints = [i32::MIN, 16_777_217, i32::MAX];
        let bytes: Vec<u8> = ints.iter().flat_map(|v| v.to_le_bytes()).collect();
        let want: Vec<f64> = ints.iter().map(|&v| f64::from(v)).collect();
        assert_eq!(Scalar::I32.decode_f64(false, &bytes), want);
        // The f32 decoding of the same samples rounds once, as before.
        assert_eq!(Scalar::I32.decode(false, &bytes)[1], 16_777_216.0);
    }
}
