//! The binary payloads of a `.vti` data array: raw or base64 blocks after a byte count, or VTK's
//! compressed block layout (a header of block count, block size, last block size and each
//! block's compressed size, then the blocks) by zlib, LZ4 or LZMA.

use base64::Engine as _;

use super::Document;

/// A `VTKFile` `compressor`: how each block of a binary array is compressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Compressor {
    Zlib,
    Lz4,
    Lzma,
}

impl Compressor {
    pub(super) fn from_name(name: &str) -> std::result::Result<Compressor, String> {
        Ok(match name {
            "vtkZLibDataCompressor" => Compressor::Zlib,
            "vtkLZ4DataCompressor" => Compressor::Lz4,
            "vtkLZMADataCompressor" => Compressor::Lzma,
            other => {
                return Err(format!(
                    "compressor '{other}' is not supported; save with vtkZLibDataCompressor, \
                     vtkLZ4DataCompressor, vtkLZMADataCompressor or none"
                ))
            }
        })
    }

    fn name(self) -> &'static str {
        match self {
            Compressor::Zlib => "zlib",
            Compressor::Lz4 => "LZ4",
            Compressor::Lzma => "LZMA",
        }
    }

    /// One block inflated; it must give exactly `size` bytes.
    fn inflate(self, block: &[u8], size: usize) -> std::result::Result<Vec<u8>, String> {
        use std::io::Read as _;
        let mut out = Vec::with_capacity(size);
        let result = match self {
            Compressor::Zlib => flate2::read::ZlibDecoder::new(block)
                .take(size as u64 + 1)
                .read_to_end(&mut out)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Compressor::Lz4 => lz4_flex::block::decompress_into(block, {
                out.resize(size, 0);
                &mut out
            })
            .map(|n| out.truncate(n))
            .map_err(|e| e.to_string()),
            Compressor::Lzma => {
                lzma_rs::xz_decompress(&mut std::io::BufReader::new(block), &mut out)
                    .map_err(|e| e.to_string())
            }
        };
        result.map_err(|e| format!("corrupt {} block: {e}", self.name()))?;
        if out.len() != size {
            let got = if out.len() > size {
                "more than".to_string()
            } else {
                out.len().to_string()
            };
            return Err(format!(
                "{} block inflates to {got} bytes; its header says {size}",
                self.name()
            ));
        }
        Ok(out)
    }
}

pub(super) fn byte_count(header: &[u8], little: bool) -> u64 {
    let fold = |acc: u64, &b: &u8| (acc << 8) | u64::from(b);
    if little {
        header.iter().rev().fold(0, fold)
    } else {
        header.iter().fold(0, fold)
    }
}

/// An uncompressed appended block: a byte count of `header_size` bytes, then the data.
pub(super) fn read_raw_block(
    block: &[u8],
    header_size: usize,
    little: bool,
) -> std::result::Result<Vec<u8>, String> {
    let header = block
        .get(..header_size)
        .ok_or("appended data ends inside a block header")?;
    let n = usize::try_from(byte_count(header, little))
        .map_err(|_| "block byte count too large".to_string())?;
    let end = header_size
        .checked_add(n)
        .ok_or("block byte count too large")?;
    let data = block
        .get(header_size..end)
        .ok_or_else(|| format!("appended data ends before its {n} bytes"))?;
    Ok(data.to_vec())
}

/// An uncompressed base64 block. VTK encodes the byte count and the data as one stream, but some
/// writers encode the count on its own (then its padding '=' ends the first group); accept both.
pub(super) fn decode_base64_block(
    text: &[u8],
    header_size: usize,
    little: bool,
) -> std::result::Result<Vec<u8>, String> {
    let engine = base64::engine::general_purpose::STANDARD;
    let header_chars = header_size.div_ceil(3) * 4;
    let prefix = text
        .get(..header_chars)
        .ok_or("base64 DataArray is shorter than its byte count")?;
    let separate = prefix.last() == Some(&b'=') && text.len() > header_chars;
    let decoded_prefix = engine
        .decode(prefix)
        .map_err(|e| format!("bad base64 in DataArray: {e}"))?;
    let n = usize::try_from(byte_count(&decoded_prefix[..header_size], little))
        .map_err(|_| "block byte count too large".to_string())?;
    if separate {
        let data = engine
            .decode(&text[header_chars..])
            .map_err(|e| format!("bad base64 in DataArray: {e}"))?;
        return data
            .get(..n)
            .map(<[u8]>::to_vec)
            .ok_or_else(|| format!("DataArray holds {} bytes, its count says {n}", data.len()));
    }
    let total = header_size
        .checked_add(n)
        .ok_or("block byte count too large")?;
    let chars = total
        .div_ceil(3)
        .checked_mul(4)
        .ok_or("block byte count too large")?;
    let stream = text
        .get(..chars)
        .ok_or_else(|| format!("base64 DataArray ends before its {n} bytes"))?;
    let decoded = engine
        .decode(stream)
        .map_err(|e| format!("bad base64 in DataArray: {e}"))?;
    decoded
        .get(header_size..total)
        .map(<[u8]>::to_vec)
        .ok_or_else(|| format!("DataArray ends before its {n} bytes"))
}

/// A compressed array's header: `[block count, block size, last block size, compressed sizes…]`.
struct BlockHeader {
    block_size: usize,
    last_size: usize,
    compressed: Vec<usize>,
}

impl BlockHeader {
    /// The header from its `3 + block count` numbers (each `header_size` bytes in `bytes`),
    /// checked to describe `expected_bytes` of data.
    fn parse(
        bytes: &[u8],
        doc: &Document,
        expected_bytes: usize,
    ) -> std::result::Result<BlockHeader, String> {
        let h = doc.header_size;
        let numbers: Vec<u64> = bytes
            .chunks_exact(h)
            .map(|c| byte_count(c, doc.little_endian))
            .collect();
        let too_large = || "compression header numbers too large".to_string();
        let as_usize = |v: u64| usize::try_from(v).map_err(|_| too_large());
        let blocks = as_usize(numbers[0])?;
        let block_size = as_usize(numbers[1])?;
        let last = as_usize(numbers[2])?;
        let last_size = if last == 0 { block_size } else { last };
        let total = blocks
            .checked_sub(1)
            .map_or(Some(0), |full| {
                full.checked_mul(block_size)?.checked_add(last_size)
            })
            .ok_or_else(too_large)?;
        if total != expected_bytes || (blocks > 0 && (block_size == 0 || last_size > block_size)) {
            return Err(format!(
                "compression header describes {blocks} blocks of {block_size} bytes (last {last_size}), \
                 {total} bytes in all; the extent needs {expected_bytes}"
            ));
        }
        let compressed = numbers[3..]
            .iter()
            .map(|&v| as_usize(v))
            .collect::<std::result::Result<_, _>>()?;
        Ok(BlockHeader {
            block_size,
            last_size,
            compressed,
        })
    }

    /// The header's length in bytes once the block count (the first number) is known.
    fn len_for(prefix: &[u8], doc: &Document) -> std::result::Result<usize, String> {
        let blocks = usize::try_from(byte_count(&prefix[..doc.header_size], doc.little_endian))
            .ok()
            .and_then(|b| b.checked_add(3)?.checked_mul(doc.header_size))
            .ok_or("compression header block count too large")?;
        Ok(blocks)
    }

    fn compressed_total(&self) -> std::result::Result<usize, String> {
        self.compressed
            .iter()
            .try_fold(0usize, |acc, &c| acc.checked_add(c))
            .ok_or_else(|| "compressed sizes too large".to_string())
    }

    /// Every block of `data` (the blocks back to back) inflated and joined.
    fn inflate(&self, data: &[u8], compressor: Compressor) -> std::result::Result<Vec<u8>, String> {
        let mut out = Vec::new();
        let mut at = 0usize;
        let n = self.compressed.len();
        for (b, &c) in self.compressed.iter().enumerate() {
            let block = at
                .checked_add(c)
                .and_then(|end| data.get(at..end))
                .ok_or_else(|| format!("data end inside compressed block {} of {n}", b + 1))?;
            let size = if b + 1 == n {
                self.last_size
            } else {
                self.block_size
            };
            let inflated = compressor
                .inflate(block, size)
                .map_err(|e| format!("{e} (block {} of {n})", b + 1))?;
            out.extend_from_slice(&inflated);
            at += c;
        }
        Ok(out)
    }
}

/// A compressed array in raw appended data: the header, then the compressed blocks.
pub(super) fn read_compressed_raw(
    block: &[u8],
    doc: &Document,
    compressor: Compressor,
    expected_bytes: usize,
) -> std::result::Result<Vec<u8>, String> {
    let prefix = block
        .get(..3 * doc.header_size)
        .ok_or("appended data ends inside a compression header")?;
    let header_len = BlockHeader::len_for(prefix, doc)?;
    let header_bytes = block
        .get(..header_len)
        .ok_or("appended data ends inside a compression header")?;
    let header = BlockHeader::parse(header_bytes, doc, expected_bytes)?;
    header.inflate(&block[header_len..], compressor)
}

/// A compressed array in base64: the header and the blocks are encoded as two base64 streams.
pub(super) fn decode_compressed_base64(
    text: &[u8],
    doc: &Document,
    compressor: Compressor,
    expected_bytes: usize,
) -> std::result::Result<Vec<u8>, String> {
    let engine = base64::engine::general_purpose::STANDARD;
    let decode = |chars: &[u8]| {
        engine
            .decode(chars)
            .map_err(|e| format!("bad base64 in DataArray: {e}"))
    };
    // The first three numbers are 3·h bytes, a whole number of base64 groups.
    let prefix = decode(
        text.get(..4 * doc.header_size)
            .ok_or("base64 DataArray ends inside its compression header")?,
    )?;
    let header_len = BlockHeader::len_for(&prefix, doc)?;
    let header_chars = header_len.div_ceil(3) * 4;
    let header_bytes = decode(
        text.get(..header_chars)
            .ok_or("base64 DataArray ends inside its compression header")?,
    )?;
    let header = BlockHeader::parse(&header_bytes[..header_len], doc, expected_bytes)?;
    let data_chars = header.compressed_total()?.div_ceil(3) * 4;
    let data = decode(
        text.get(header_chars..header_chars + data_chars)
            .ok_or("base64 DataArray ends inside its compressed blocks")?,
    )?;
    header.inflate(&data, compressor)
}
