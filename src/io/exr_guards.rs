//! What an OpenEXR file is checked for before the `exr` crate is let at
//! it: headers walked as written, every block's declared size against the
//! bytes left, DWA chunks' counters against their block. Each guards
//! against a hostile file making `exr` allocate or abort (docs/operations.md).

use std::io::{BufRead, Read, Seek, SeekFrom};

use exr::block::chunk::{Chunk, CompressedBlock};
use exr::compression::Compression;
use exr::meta::header::Header;

use super::error::{from_exr, HdrIoError};

/// The format name errors and load reports give.
pub(super) const FORMAT: &str = "OpenEXR";

/// Walks the headers as written (not as `exr` corrects them), checking
/// each part's data window: `exr` swaps the corners of an inverted window
/// silently, so an empty or inverted window would otherwise surface as a
/// size the blocks then contradict ("decompressed data", "chunk count").
/// Returns where the headers end (the offset tables start), or `None` for
/// headers too malformed to walk, which `exr` then names.
pub(super) fn scan_headers<R: BufRead + Seek>(
    r: &mut R,
    file: &str,
) -> Result<Option<u64>, HdrIoError> {
    let mut start = [0u8; 8];
    if r.read_exact(&mut start).is_err() {
        return Ok(None);
    }
    let multipart = u32::from_le_bytes([start[4], start[5], start[6], start[7]]) & 0x1000 != 0;
    // Names and type names are at most 255 bytes and a null.
    let text = |r: &mut R| -> Option<Vec<u8>> {
        let mut buf = Vec::new();
        r.by_ref().take(256).read_until(0, &mut buf).ok()?;
        (buf.last() == Some(&0)).then_some(buf)
    };
    for part in 0.. {
        loop {
            let Some(name) = text(r) else {
                return Ok(None);
            };
            if name == [0] {
                break;
            }
            if text(r).is_none() {
                return Ok(None);
            }
            let mut size = [0u8; 4];
            if r.read_exact(&mut size).is_err() {
                return Ok(None);
            }
            let Ok(size) = u32::try_from(i32::from_le_bytes(size)) else {
                return Ok(None);
            };
            if name == b"dataWindow\0" && size == 16 {
                let mut v = [0u8; 16];
                if r.read_exact(&mut v).is_err() {
                    return Ok(None);
                }
                let at = |i: usize| i32::from_le_bytes([v[i], v[i + 1], v[i + 2], v[i + 3]]);
                check_window(file, part, [at(0), at(4), at(8), at(12)])?;
            } else if r.seek(SeekFrom::Current(i64::from(size))).is_err() {
                return Ok(None);
            }
        }
        if !multipart {
            break;
        }
        // A multi-part file ends its list of headers with a null byte.
        match r.fill_buf() {
            Ok([0, ..]) => {
                r.consume(1);
                break;
            }
            Ok([]) | Err(_) => return Ok(None),
            Ok(_) => {}
        }
    }
    Ok(r.stream_position().ok())
}

/// Checks that every block of the chosen part fits in the file before
/// `exr` reads it: `exr` allocates a block's declared size up to the part's
/// largest possible block, which hostile tile sizes make gigabytes (a
/// 76-byte file asked for 1.49 GB; found by fuzzing). Offsets outside the
/// file are left to `exr`, which refuses them.
pub(super) fn check_block_sizes<R: Read + Seek>(
    r: &mut R,
    tables_at: u64,
    len: u64,
    meta: &exr::meta::MetaData,
    part: usize,
    file: &str,
) -> Result<(), HdrIoError> {
    let io_error = |e: std::io::Error| from_exr(file, exr::error::Error::from(e));
    let before: u64 = meta.headers[..part]
        .iter()
        .map(|h| h.chunk_count as u64 * 8)
        .sum();
    let header = &meta.headers[part];
    let mut table = vec![0u8; header.chunk_count * 8];
    r.seek(SeekFrom::Start(tables_at + before))
        .map_err(io_error)?;
    if r.read_exact(&mut table).is_err() {
        return Ok(()); // a short table: exr says so
    }
    let prefix = if meta.requirements.has_multiple_layers {
        4
    } else {
        0
    } + match header.blocks {
        exr::meta::BlockDescription::ScanLines => 4,
        exr::meta::BlockDescription::Tiles(_) => 16,
    };
    for (index, offset) in table.chunks_exact(8).enumerate() {
        let offset = u64::from_le_bytes(offset.try_into().unwrap_or([0xff; 8]));
        let Some(size_at) = offset
            .checked_add(prefix)
            .filter(|&at| at.checked_add(4).is_some_and(|end| end <= len))
        else {
            continue;
        };
        r.seek(SeekFrom::Start(size_at)).map_err(io_error)?;
        let mut size = [0u8; 4];
        r.read_exact(&mut size).map_err(io_error)?;
        let size = i64::from(i32::from_le_bytes(size));
        let left = len - size_at - 4;
        if size < 0 || size as u64 > left {
            return Err(HdrIoError::Truncated {
                file: file.to_string(),
                format: FORMAT,
                detail: format!(
                    "block {index} of part {part} (at byte {offset}) declares {size} bytes of data, \
                     but the file has {left} bytes after it"
                ),
            });
        }
    }
    Ok(())
}

fn check_window(file: &str, part: usize, [x0, y0, x1, y1]: [i32; 4]) -> Result<(), HdrIoError> {
    let (w, h) = (
        i64::from(x1) - i64::from(x0) + 1,
        i64::from(y1) - i64::from(y0) + 1,
    );
    if w >= 1 && h >= 1 {
        return Ok(());
    }
    if w >= 0 && h >= 0 {
        return Err(HdrIoError::EmptyImage {
            file: file.to_string(),
            width: w as u64,
            height: h as u64,
        });
    }
    Err(HdrIoError::Corrupt {
        file: file.to_string(),
        format: FORMAT,
        detail: format!(
            "the data window of part {part} is inverted: (xMin, yMin) = ({x0}, {y0}) lies past (xMax, yMax) = ({x1}, {y1})"
        ),
    })
}

/// Refuses DWA chunks whose header counters exceed what the block can hold.
///
/// Why: exr 1.74.2's DWA decoder trusts the nine size counters at the start
/// of each chunk and asks zlib for an output buffer of that size, so one
/// flipped byte can request petabytes, and a failed allocation aborts the
/// process (`catch_unwind` cannot help). No section of a block, compressed or
/// not, is larger than the block's pixels padded to whole 8×8 DCT blocks;
/// twice that plus a little leaves room for RLE expansion.
pub(super) fn check_dwa_counters(chunk: &Chunk, header: &Header) -> Result<(), String> {
    if !matches!(
        header.compression,
        Compression::DWAA(_) | Compression::DWAB(_)
    ) {
        return Ok(());
    }
    let data = match &chunk.compressed_block {
        CompressedBlock::ScanLine(block) => &block.compressed_pixels_le,
        CompressedBlock::Tile(block) => &block.compressed_pixels_le,
        _ => return Ok(()), // deep blocks are never decoded here
    };
    let bytes_per_pixel = header.channels.bytes_per_pixel as u128;
    let bounds = header
        .get_block_data_indices(&chunk.compressed_block)
        .and_then(|tile| header.get_absolute_block_pixel_coordinates(tile))
        .map_err(|e| e.to_string())?;
    let (width, height) = (bounds.size.x() as u128, bounds.size.y() as u128);
    // Stored raw when compression did not help: there is no DWA header then.
    if data.len() as u128 == width * height * bytes_per_pixel || data.is_empty() {
        return Ok(());
    }
    let padded = width.div_ceil(8) * 8 * height.div_ceil(8) * 8;
    let limit = 2 * padded * bytes_per_pixel + 4096;
    // Counters 1..=9 of the 11 little-endian u64s are sizes and counts.
    for (index, counter) in data.chunks_exact(8).enumerate().take(10).skip(1) {
        let value = u64::from_le_bytes(counter.try_into().map_err(|_| "short DWA header")?);
        if u128::from(value) > limit {
            return Err(format!(
                "DWA block header field {index} declares {value}, more than a {width}×{height} block can hold"
            ));
        }
    }
    Ok(())
}
