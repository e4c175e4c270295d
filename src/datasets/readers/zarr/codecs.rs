//! Zarr chunk codecs, pure Rust: Blosc 1 frames (byte shuffle; LZ4, Zstandard or zlib inside,
//! as numcodecs writes them, which is xarray's default for Zarr v2), Zstandard (xarray's default
//! for Zarr v3, through `ruzstd`), gzip and zlib (`flate2`), and the stored element types turned
//! into f64. Every length is checked against the chunk's declared size before it is allocated.

use std::io::Read;

type Why = String;

/// A stored element type: size, kind and byte order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Dtype {
    pub size: usize,
    pub kind: char,
    pub little: bool,
}

impl Dtype {
    /// A NumPy type string of Zarr v2 (`<f4`, `>i8`, `|u1`, `|b1`).
    pub(crate) fn from_numpy(s: &str) -> Result<Dtype, Why> {
        let bytes = s.as_bytes();
        let (order, kind) = (bytes.first().copied(), bytes.get(1).map(|&b| b as char));
        let size: usize = s.get(2..).and_then(|n| n.parse().ok()).unwrap_or(0);
        match (order, kind, size) {
            (Some(b'<' | b'>' | b'|'), Some(k @ ('f' | 'i' | 'u' | 'b')), 1 | 2 | 4 | 8)
                if !(k == 'f' && size == 1) =>
            {
                Ok(Dtype { size, kind: k, little: order != Some(b'>') })
            }
            _ => Err(format!("data type {s:?} is not read (read: little- or big-endian floats, integers and booleans)")),
        }
    }

    /// A Zarr v3 data type name (`float32`, `int16`, `bool`), stored little-endian unless the
    /// `bytes` codec says otherwise.
    pub(crate) fn from_v3(s: &str) -> Result<Dtype, Why> {
        let (kind, bits) = match s {
            "bool" => ('b', 8),
            _ => {
                let split = s.find(|c: char| c.is_ascii_digit()).unwrap_or(s.len());
                let bits: usize = s[split..].parse().unwrap_or(0);
                let kind = match &s[..split] {
                    "float" => 'f',
                    "int" => 'i',
                    "uint" => 'u',
                    _ => ' ',
                };
                (kind, bits)
            }
        };
        match (kind, bits) {
            ('f', 32 | 64) | ('i' | 'u', 8 | 16 | 32 | 64) | ('b', 8) => Ok(Dtype {
                size: bits / 8,
                kind,
                little: true,
            }),
            _ => Err(format!(
                "data type {s:?} is not read (read: float32/64, (u)int8–64, bool)"
            )),
        }
    }

    /// The NetCDF name of the type, for listings.
    pub(crate) fn name(&self) -> String {
        match self.kind {
            'f' => format!("float{}", self.size * 8),
            'i' => format!("int{}", self.size * 8),
            'u' => format!("uint{}", self.size * 8),
            _ => "bool".into(),
        }
    }

    /// The CF decoder's view of the type.
    pub(crate) fn stored(&self) -> crate::datasets::conventions::cf_decode::Stored {
        use crate::datasets::conventions::cf_decode::Stored;
        match (self.kind, self.size) {
            ('f', 4) => Stored::Float32,
            ('f', _) => Stored::Float64,
            ('b', _) => Stored::Other,
            (k, n) => Stored::Int {
                bits: 8 * n as u32,
                unsigned: k == 'u',
            },
        }
    }

    /// The values of raw element bytes.
    pub(crate) fn values(&self, bytes: &[u8]) -> Vec<f64> {
        bytes
            .chunks_exact(self.size)
            .map(|b| {
                let mut word = [0u8; 8];
                if self.little {
                    word[..self.size].copy_from_slice(b);
                } else {
                    for (i, &x) in b.iter().rev().enumerate() {
                        word[i] = x;
                    }
                }
                let u = u64::from_le_bytes(word);
                match (self.kind, self.size) {
                    ('f', 4) => f32::from_bits(u as u32) as f64,
                    ('f', _) => f64::from_bits(u),
                    ('i', n) => {
                        let shift = 64 - 8 * n as u32;
                        ((u << shift) as i64 >> shift) as f64
                    }
                    _ => u as f64,
                }
            })
            .collect()
    }
}

/// One bytes-to-bytes step of a chunk's decoding.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Codec {
    Blosc,
    Zstd,
    Gzip,
    Zlib,
    /// Zarr v3's crc32c codec: a 4-byte checksum after the data.
    Crc32c,
}

impl Codec {
    /// The codec a numcodecs id or Zarr v3 codec name means.
    pub(crate) fn named(name: &str) -> Result<Codec, Why> {
        Ok(match name {
            "blosc" => Codec::Blosc,
            "zstd" => Codec::Zstd,
            "gzip" => Codec::Gzip,
            "zlib" => Codec::Zlib,
            "crc32c" => Codec::Crc32c,
            other => {
                return Err(format!(
                    "codec {other:?} is not read (read: blosc, zstd, gzip, zlib, crc32c)"
                ))
            }
        })
    }

    /// The decoded bytes, which must not exceed `limit` (the chunk's size).
    pub(crate) fn decode(&self, data: &[u8], limit: usize) -> Result<Vec<u8>, Why> {
        let read_all = |mut r: Box<dyn Read + '_>| -> Result<Vec<u8>, Why> {
            let mut out = Vec::new();
            r.by_ref()
                .take(limit as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| e.to_string())?;
            if out.len() > limit {
                return Err(format!(
                    "decompresses to more than the chunk's {limit} bytes"
                ));
            }
            Ok(out)
        };
        match self {
            Codec::Blosc => blosc(data, limit),
            Codec::Zstd => {
                let decoder = ruzstd::decoding::StreamingDecoder::new(data)
                    .map_err(|e| format!("zstd: {e}"))?;
                read_all(Box::new(decoder)).map_err(|e| format!("zstd: {e}"))
            }
            Codec::Gzip => read_all(Box::new(flate2::read::GzDecoder::new(data))),
            Codec::Zlib => read_all(Box::new(flate2::read::ZlibDecoder::new(data))),
            Codec::Crc32c => Ok(data[..data.len().saturating_sub(4)].to_vec()),
        }
    }
}

fn le32(b: &[u8], at: usize) -> Option<usize> {
    b.get(at..at + 4)
        .map(|w| u32::from_le_bytes(w.try_into().expect("4 bytes")) as usize)
}

/// A Blosc 1 frame (c-blosc's README_CHUNK_FORMAT): a 16-byte header (version, codec version,
/// flags, type size, then the uncompressed size, block size and frame size), the offsets of the
/// blocks from the frame's start, and each block as one stream or as one stream per byte of the
/// type (when the flags do not say "not split" and it is not the last, shorter block), each
/// stream preceded by its compressed size; byte shuffle is undone per block.
fn blosc(frame: &[u8], limit: usize) -> Result<Vec<u8>, Why> {
    let bad = |why: &str| format!("blosc: {why} (damaged)");
    if frame.len() < 16 {
        return Err(bad("a frame shorter than its header"));
    }
    let (flags, typesize) = (frame[2], frame[3].max(1) as usize);
    let nbytes = le32(frame, 4).unwrap_or(0);
    let blocksize = le32(frame, 8).unwrap_or(0);
    if nbytes > limit {
        return Err(bad(&format!("{nbytes} bytes for a chunk of {limit}")));
    }
    if flags & 0x02 != 0 {
        // Stored without compression.
        return frame
            .get(16..16 + nbytes)
            .map(<[u8]>::to_vec)
            .ok_or_else(|| bad("a stored frame cut short"));
    }
    if flags & 0x04 != 0 {
        return Err("blosc: bit shuffle is not read (byte shuffle and none are)".into());
    }
    if nbytes == 0 {
        return Ok(Vec::new());
    }
    if blocksize == 0 {
        return Err(bad("a block size of 0"));
    }
    let codec = flags >> 5;
    let blocks = nbytes.div_ceil(blocksize);
    let mut out = vec![0u8; nbytes];
    for b in 0..blocks {
        let start = le32(frame, 16 + 4 * b).ok_or_else(|| bad("block offsets cut short"))?;
        let size = blocksize.min(nbytes - b * blocksize);
        let leftover = size < blocksize;
        let splits = if flags & 0x10 == 0 && !leftover {
            typesize
        } else {
            1
        };
        let mut block = Vec::with_capacity(size);
        let mut at = start;
        for _ in 0..splits {
            let stream = size / splits;
            let csize = le32(frame, at).ok_or_else(|| bad("a stream size cut short"))?;
            let data = frame
                .get(at + 4..at + 4 + csize)
                .ok_or_else(|| bad("a stream cut short"))?;
            at += 4 + csize;
            if csize == stream {
                block.extend_from_slice(data);
                continue;
            }
            let decoded = match codec {
                1 => lz4_flex::block::decompress(data, stream).map_err(|e| format!("blosc lz4: {e}"))?,
                3 => Codec::Zlib.decode(data, stream)?,
                4 => Codec::Zstd.decode(data, stream)?,
                0 => return Err("blosc: its own 'blosclz' codec is not read (lz4, zlib and zstd are; numcodecs writes lz4 by default)".into()),
                c => return Err(format!("blosc: inner codec {c} (snappy or unknown) is not read")),
            };
            if decoded.len() != stream {
                return Err(bad(&format!(
                    "a stream of {} bytes where {stream} were expected",
                    decoded.len()
                )));
            }
            block.extend_from_slice(&decoded);
        }
        let dest = &mut out[b * blocksize..b * blocksize + size];
        if flags & 0x01 != 0 && typesize > 1 {
            unshuffle(&block, typesize, dest);
        } else {
            dest.copy_from_slice(&block);
        }
    }
    Ok(out)
}

/// Undoes the byte shuffle: byte j of element i was stored at j·n + i (n elements); bytes past
/// the last whole element are stored as they are.
fn unshuffle(shuffled: &[u8], typesize: usize, dest: &mut [u8]) {
    let n = dest.len() / typesize;
    for i in 0..n {
        for j in 0..typesize {
            dest[i * typesize + j] = shuffled[j * n + i];
        }
    }
    let whole = n * typesize;
    dest[whole..].copy_from_slice(&shuffled[whole..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dtypes_decode_both_byte_orders() {
        let le = Dtype::from_numpy("<i2").unwrap();
        assert_eq!(le.values(&[0xfe, 0xff, 0x01, 0x00]), [-2.0, 1.0]);
        let be = Dtype::from_numpy(">f4").unwrap();
        assert_eq!(be.values(&1.5f32.to_be_bytes()), [1.5]);
        assert_eq!(
            Dtype::from_v3("uint16").unwrap().values(&[0xff, 0xff]),
            [65535.0]
        );
        assert!(Dtype::from_numpy("<U8").is_err() && Dtype::from_v3("complex64").is_err());
    }

    #[test]
    fn a_stored_blosc_frame_and_a_shuffled_lz4_one() {
        let payload: Vec<u8> = (0..64u8).collect();
        // Memcpyed frame: flags 0x02.
        let mut frame = vec![2, 1, 0x02, 4];
        frame.extend_from_slice(&64u32.to_le_bytes());
        frame.extend_from_slice(&64u32.to_le_bytes());
        frame.extend_from_slice(&80u32.to_le_bytes());
        frame.extend_from_slice(&payload);
        assert_eq!(blosc(&frame, 64).unwrap(), payload);
        // One block, shuffled (typesize 4), not split, the stream LZ4-compressed.
        let mut shuffled = vec![0u8; 64];
        for i in 0..16 {
            for j in 0..4 {
                shuffled[j * 16 + i] = payload[i * 4 + j];
            }
        }
        let stream = lz4_flex::block::compress(&shuffled);
        let mut frame = vec![2, 1, 0x01 | 0x10 | (1 << 5), 4];
        frame.extend_from_slice(&64u32.to_le_bytes());
        frame.extend_from_slice(&64u32.to_le_bytes());
        frame.extend_from_slice(&((24 + stream.len()) as u32).to_le_bytes());
        frame.extend_from_slice(&20u32.to_le_bytes());
        frame.extend_from_slice(&(stream.len() as u32).to_le_bytes());
        frame.extend_from_slice(&stream);
        assert_eq!(blosc(&frame, 64).unwrap(), payload);
        assert!(blosc(&frame, 32)
            .unwrap_err()
            .contains("64 bytes for a chunk of 32"));
        assert!(blosc(&frame[..30], 64).is_err());
    }
}
