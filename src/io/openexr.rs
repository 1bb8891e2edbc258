//! OpenEXR through the `exr` crate's block-level API.
//!
//! Why block level rather than `exr::prelude::read()`: the high-level reader
//! allocates every layer it reads before we could look at the sizes, and it
//! decompresses on a rayon pool, where a decoder panic aborts the process
//! instead of unwinding into `catch_unwind`. Here the meta data
//! (`exr::meta::MetaData`) is read first, the chosen part's data window is
//! checked against the size policy, and only that part's blocks at full
//! resolution are decompressed into one buffer: read and checked one by one,
//! decompressed a few at a time in parallel (each under its own
//! `catch_unwind`, so no panic crosses a thread), placed in file order.
//!
//! Which part: the first (non-deep) part with `R`, `G` and `B` channels, or
//! else with a `Y` channel (luminance-only EXRs become grey RGB). Alpha and
//! other channels are ignored; channel names with layer prefixes such as
//! `diffuse.R` are not matched. Samples may be f16, f32 or u32 (converted to
//! f32). Every compression `exr` reads is read, DWAA and DWAB included (hence
//! exr ≥ 1.74.1).
//!
//! Raw chunks are checked before `exr` decompresses them, and every block's
//! declared byte size is checked against the bytes left in the file before
//! `exr` reads any block (both in `exr_guards`): `exr` zero-fills a buffer
//! of the declared size, up to the part's largest possible block, before
//! reading into it.
//!
//! Writing: f32 RGB, scan lines, ZIP16 compression: lossless (the validator
//! writes reference images that must read back bit for bit), supported by
//! every OpenEXR reader, and compact on rendered images.

use std::io::{BufRead, Seek, SeekFrom, Write};

use exr::block::UncompressedBlock;
use exr::meta::attribute::SampleType;
use exr::meta::header::Header;
use exr::prelude::{f16, Vec2};

use super::error::{from_exr, HdrIoError};
use super::exr_guards::{check_block_sizes, check_dwa_counters, scan_headers, FORMAT};
use super::validate::{check_dimensions, check_fit, Decoded};
use super::LoadOptions;
use crate::image::{HdrImage, Image};

/// Where each component of the output comes from in the chosen part.
#[derive(Clone, Copy, Debug)]
enum ChannelSource {
    Rgb([usize; 3]),
    Luminance(usize),
}

impl ChannelSource {
    /// The output components a file channel fills, if any.
    fn targets(self, channel: usize) -> &'static [usize] {
        match self {
            Self::Rgb(indices) => match indices.iter().position(|&i| i == channel) {
                Some(0) => &[0],
                Some(1) => &[1],
                Some(2) => &[2],
                _ => &[],
            },
            Self::Luminance(index) if index == channel => &[0, 1, 2],
            Self::Luminance(_) => &[],
        }
    }

    /// The one channel whose lines are counted to check that every row was filled.
    fn coverage_channel(self) -> usize {
        match self {
            Self::Rgb(indices) => indices[0],
            Self::Luminance(index) => index,
        }
    }
}

pub(crate) fn decode<R: BufRead + Seek>(
    mut reader: R,
    len: u64,
    file: &str,
    opts: &LoadOptions,
) -> Result<Decoded, HdrIoError> {
    let exr_error = |e| from_exr(file, e);
    let io_error = |e: std::io::Error| from_exr(file, exr::error::Error::from(e));
    // The headers as written: their data windows, and where they end.
    let tables_at = scan_headers(&mut reader, file)?;
    reader.seek(SeekFrom::Start(0)).map_err(io_error)?;
    // The magic number and the headers, validated by exr.
    let meta = exr::meta::MetaData::read_from_buffered(&mut reader, false).map_err(exr_error)?;
    let headers = &meta.headers;
    let (part, source) = choose_part(headers, file)?;
    let header = &headers[part];
    let data_window = header.data_window();
    let (w, h, pixel_count) = check_dimensions(
        file,
        data_window.size.x() as u64,
        data_window.size.y() as u64,
        opts.max_pixels,
    )?;
    check_fit(file, w, h, opts)?;

    // Each part's offset table holds 8 bytes per block. A header that claims
    // more blocks than the file could hold is caught here, before `exr`
    // reads tables or loops over block indices.
    let table_bytes: u128 = headers.iter().map(|h| h.chunk_count as u128 * 8).sum();
    if table_bytes > u128::from(len) {
        return Err(HdrIoError::Truncated {
            file: file.to_string(),
            format: FORMAT,
            detail: format!(
                "the headers declare {table_bytes} bytes of block offset tables but the file has {len} bytes"
            ),
        });
    }

    // `exr` allocates a block's declared size, up to the part's largest
    // possible block: only when that bound is beyond the file's length
    // (hostile tile or line sizes) are the declared sizes read first.
    if let (Some(tables_at), true) = (tables_at, header.max_block_byte_size() as u64 > len) {
        check_block_sizes(&mut reader, tables_at, len, &meta, part, file)?;
    }
    reader.seek(SeekFrom::Start(0)).map_err(io_error)?;
    let reader = exr::block::read(reader, false).map_err(exr_error)?;

    let channels: Vec<String> = header
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    let mut pixels = vec![[0.0f32; 3]; pixel_count];
    // Samples written per row of the coverage channel: every row must end
    // with exactly `w`, which catches missing and duplicated blocks.
    let mut row_fill = vec![0u64; h as usize];
    let corrupt = |detail: String| HdrIoError::Corrupt {
        file: file.to_string(),
        format: FORMAT,
        detail,
    };

    // Chunks are decompressed here one by one (not with exr's
    // `decompress_sequential`) so that each raw chunk can be checked before
    // exr sees it: that it belongs to the chosen part (a corrupt offset table
    // can point anywhere) and that DWA counters are sane.
    let chunks = reader
        .filter_chunks(false, |_, tile, block| {
            block.layer == part && tile.is_largest_resolution_level()
        })
        .map_err(exr_error)?;
    // Decompressed in batches of a few chunks per core: the blocks of one
    // batch are the only decompressed data held at once.
    let batch = 2 * rayon::current_num_threads().max(1);
    let mut chunks = chunks.peekable();
    while chunks.peek().is_some() {
        let mut raw = Vec::with_capacity(batch);
        for chunk in chunks.by_ref().take(batch) {
            let chunk = chunk.map_err(exr_error)?;
            if chunk.layer_index != part {
                return Err(corrupt(format!(
                    "the offset table of part {part} points at a block of part {}",
                    chunk.layer_index
                )));
            }
            check_dwa_counters(&chunk, header).map_err(corrupt)?;
            raw.push(chunk);
        }
        let blocks: Vec<Result<UncompressedBlock, HdrIoError>> = {
            use rayon::prelude::*;
            raw.into_par_iter()
                .map(|chunk| {
                    super::error::catch_decoder_panic(file, FORMAT, || {
                        UncompressedBlock::decompress_chunk(chunk, &meta, false).map_err(exr_error)
                    })
                })
                .collect()
        };
        for block in blocks {
            let block = block?;
            if block.index.level != Vec2(0, 0) {
                return Err(corrupt(
                    "a full-resolution block slot holds a mip-map block".into(),
                ));
            }
            place_block(
                &block,
                header,
                source,
                w as usize,
                &mut pixels,
                &mut row_fill,
            )
            .map_err(corrupt)?;
        }
    }

    if let Some(y) = row_fill.iter().position(|&filled| filled != u64::from(w)) {
        return Err(corrupt(format!(
            "row {y} of the data window has {} of its {w} pixels (missing or duplicated blocks)",
            row_fill[y]
        )));
    }
    Ok(Decoded {
        image: Image {
            width: w,
            height: h,
            pixels,
        },
        channels,
    })
}

/// Picks the part to read; see the module documentation for the rule.
fn choose_part(headers: &[Header], file: &str) -> Result<(usize, ChannelSource), HdrIoError> {
    let unsupported = |detail: String| HdrIoError::Unsupported {
        file: file.to_string(),
        format: FORMAT,
        detail,
    };
    for (part, header) in headers.iter().enumerate() {
        if header.deep {
            continue;
        }
        let find = |name: &str| header.channels.list.iter().position(|c| c.name.eq(name));
        let source = match (find("R"), find("G"), find("B"), find("Y")) {
            (Some(r), Some(g), Some(b), _) => ChannelSource::Rgb([r, g, b]),
            (_, _, _, Some(y)) => {
                if find("RY").is_some() || find("BY").is_some() {
                    return Err(unsupported(
                        "luminance/chroma (Y, RY, BY) images are not read; convert the file to RGB"
                            .into(),
                    ));
                }
                ChannelSource::Luminance(y)
            }
            _ => continue,
        };
        let used = match source {
            ChannelSource::Rgb(indices) => indices.to_vec(),
            ChannelSource::Luminance(index) => vec![index],
        };
        for index in used {
            let channel = &header.channels.list[index];
            if channel.sampling != Vec2(1, 1) {
                return Err(unsupported(format!(
                    "channel {} is subsampled {}×{}; convert the file to full-resolution RGB",
                    channel.name,
                    channel.sampling.x(),
                    channel.sampling.y()
                )));
            }
        }
        return Ok((part, source));
    }
    let found: Vec<String> = headers
        .iter()
        .map(|h| {
            let names: Vec<String> = h.channels.list.iter().map(|c| c.name.to_string()).collect();
            format!("[{}]", names.join(", "))
        })
        .collect();
    Err(unsupported(format!(
        "no part has R, G and B or Y channels (found {}); export RGB or Y channels without layer prefixes",
        found.join(" ")
    )))
}

/// Copies the chosen channels of one decompressed block into the image.
/// Positions come from the file, so every index is checked.
fn place_block(
    block: &UncompressedBlock,
    header: &Header,
    source: ChannelSource,
    width: usize,
    pixels: &mut [[f32; 3]],
    row_fill: &mut [u64],
) -> Result<(), String> {
    for line in block.lines(&header.channels) {
        let location = line.location;
        let targets = source.targets(location.channel);
        if targets.is_empty() {
            continue;
        }
        let (x, y, count) = (
            location.position.x(),
            location.position.y(),
            location.sample_count,
        );
        if y >= row_fill.len() || x.checked_add(count).is_none_or(|end| end > width) {
            return Err(format!(
                "a block places {count} pixels at ({x}, {y}), outside the {width}×{} data window",
                row_fill.len()
            ));
        }
        let sample_type = header.channels.list[location.channel].sample_type;
        if line.value.len() != count * sample_type.bytes_per_sample() {
            return Err(format!("a line at row {y} has the wrong number of bytes"));
        }
        let row = &mut pixels[y * width + x..y * width + x + count];
        match sample_type {
            SampleType::F16 => fill(row, targets, line.value.chunks_exact(2), |b| {
                f16::from_bits(u16::from_ne_bytes([b[0], b[1]])).to_f32()
            }),
            SampleType::F32 => fill(row, targets, line.value.chunks_exact(4), |b| {
                f32::from_ne_bytes([b[0], b[1], b[2], b[3]])
            }),
            SampleType::U32 => fill(row, targets, line.value.chunks_exact(4), |b| {
                u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f32
            }),
        }
        if location.channel == source.coverage_channel() {
            row_fill[y] += count as u64;
        }
    }
    Ok(())
}

fn fill<'a>(
    row: &mut [[f32; 3]],
    targets: &[usize],
    samples: impl Iterator<Item = &'a [u8]>,
    convert: impl Fn(&[u8]) -> f32,
) {
    for (pixel, sample) in row.iter_mut().zip(samples) {
        let value = convert(sample);
        for &t in targets {
            pixel[t] = value;
        }
    }
}

/// Writes f32 RGB scan lines with ZIP16 compression (see the module docs).
pub(crate) fn encode(writer: impl Write + Seek, image: &HdrImage) -> Result<(), exr::error::Error> {
    use exr::prelude::{Blocks, Compression, Encoding, LineOrder, SpecificChannels, WritableImage};
    let width = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * width + x];
        (p[0], p[1], p[2])
    });
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        // Increasing order makes the file bytes independent of thread timing.
        line_order: LineOrder::Increasing,
    };
    exr::prelude::Image::from_encoded_channels((width, image.height as usize), encoding, channels)
        .write()
        .to_buffered(writer)
}
