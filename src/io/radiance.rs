//! Radiance RGBE (`.hdr`): read with the `image` crate's decoder, written by
//! hand.
//!
//! Reading: `image`'s `HdrDecoder` parses the header (and so reports the size)
//! before it allocates anything, so the size policy can run first and the
//! pixels are decoded straight into our buffer. `EXPOSURE` headers are not
//! applied (nor by most readers); `FORMAT=32-bit_rle_xyze` and orientations
//! other than `-Y h +X w` are refused by the decoder as unsupported.
//!
//! Writing by hand, because `image`'s encoder truncates mantissas (relative
//! error up to 2^-7 instead of 2^-8) and wraps the exponent of values ≥ 2^127
//! round to tiny ones. This encoder rounds to nearest, so every component of
//! a pixel whose largest component is m decodes within m / 255.5 (about
//! 2^-8 · m) of its value: the components share one exponent, m's mantissa
//! is at least 128 units, and rounding is off by half a unit; when m itself
//! rounds up to 256 units the exponent grows by one, the unit doubles, and
//! half of it is m / 255.5 at most. Scan lines are run-length encoded ("new"
//! RLE) where the format allows it (8 ≤ width ≤ 32767), flat otherwise.

use std::io::{BufRead, Read, Seek, SeekFrom, Write};

use image::codecs::hdr::HdrDecoder;
use image::ImageDecoder;

use super::error::{from_image, HdrIoError};
use super::validate::{check_dimensions, check_fit, Decoded};
use super::LoadOptions;
use crate::image::{HdrImage, Image};

const FORMAT: &str = "Radiance RGBE";

/// The largest value RGBE stores: mantissa 255 at the top exponent, 255/256 · 2^127.
pub(crate) const MAX_RGBE: f64 = 255.0 / 256.0 * 1.7014118346046923e38;

/// Reads an RGBE file; `strict` requires the `#?RADIANCE` signature (files
/// starting `#?RGBE` need the decoder's non-strict mode).
pub(crate) fn decode(
    mut reader: impl BufRead + Seek,
    strict: bool,
    file: &str,
    opts: &LoadOptions,
) -> Result<Decoded, HdrIoError> {
    let mut head = Vec::new();
    let io_error = |source| HdrIoError::Io {
        file: file.to_string(),
        action: "read",
        source,
    };
    reader
        .by_ref()
        .take(HEADER_SCAN_BYTES)
        .read_to_end(&mut head)
        .map_err(io_error)?;
    reader.seek(SeekFrom::Start(0)).map_err(io_error)?;
    check_header_ends(&head, file)?;
    let decoder =
        HdrDecoder::with_strictness(reader, strict).map_err(|e| from_image(file, FORMAT, e))?;
    let (width, height) = decoder.dimensions();
    let (w, h, pixel_count) =
        check_dimensions(file, u64::from(width), u64::from(height), opts.max_pixels)?;
    check_fit(file, w, h, opts)?;
    let mut pixels = vec![[0.0f32; 3]; pixel_count];
    decoder
        .read_image(bytemuck::cast_slice_mut(&mut pixels))
        .map_err(|e| from_image(file, FORMAT, e))?;
    Ok(Decoded {
        image: Image {
            width: w,
            height: h,
            pixels,
        },
        channels: vec!["R".into(), "G".into(), "B".into()],
    })
}

/// How much of the file's start is scanned for the header's end.
const HEADER_SCAN_BYTES: u64 = 64 << 10;

/// A header cut short: the decoder reads whatever stands where the file
/// ends as a value ("format `32` is not supported", "dimensions line too
/// short"), so the end of the header and of the dimensions line are looked
/// for first. A header longer than the scan is left to the decoder.
fn check_header_ends(head: &[u8], file: &str) -> Result<(), HdrIoError> {
    if head.len() as u64 >= HEADER_SCAN_BYTES {
        return Ok(());
    }
    let truncated = |detail: String| HdrIoError::Truncated {
        file: file.to_string(),
        format: FORMAT,
        detail,
    };
    let Some(blank) = head.windows(2).position(|w| w == b"\n\n") else {
        return Err(truncated(format!(
            "the file ends inside the header, after {} bytes, before the blank line that closes it",
            head.len()
        )));
    };
    let dims = &head[blank + 2..];
    if !dims.contains(&b'\n') {
        let text = String::from_utf8_lossy(&dims[..dims.len().min(40)]).into_owned();
        return Err(truncated(format!(
            "the file ends inside the dimensions line after the header ({text:?}, {} bytes in all)",
            head.len()
        )));
    }
    Ok(())
}

/// Components RGBE cannot hold, found while encoding.
#[derive(Default)]
pub(crate) struct Unrepresentable {
    pub count: u64,
    pub first: Option<(u32, u32)>,
}

/// Writes an RGBE file. Negative, non-finite and too-large components cannot
/// be stored: they are counted (and written as black, so the stream stays
/// well-formed) and the caller turns a non-zero count into an error, which
/// makes the atomic writer discard the file.
pub(crate) fn encode(
    writer: &mut impl Write,
    image: &HdrImage,
) -> std::io::Result<Unrepresentable> {
    let width = image.width as usize;
    write!(
        writer,
        "#?RADIANCE\n# written by tonegate\nFORMAT=32-bit_rle_rgbe\n\n-Y {} +X {}\n",
        image.height, image.width
    )?;
    let mut bad = Unrepresentable::default();
    let mut rgbe = vec![[0u8; 4]; width];
    let mut out = Vec::with_capacity(width * 4 + 64);
    for (y, row) in image.pixels.chunks_exact(width.max(1)).enumerate() {
        for (x, (pixel, encoded)) in row.iter().zip(rgbe.iter_mut()).enumerate() {
            *encoded = to_rgbe(*pixel).unwrap_or_else(|bad_components| {
                bad.count += bad_components;
                bad.first.get_or_insert((x as u32, y as u32));
                [0; 4]
            });
        }
        out.clear();
        if (8..=0x7fff).contains(&width) {
            out.extend_from_slice(&[2, 2, (width >> 8) as u8, (width & 0xff) as u8]);
            for component in 0..4 {
                let plane: Vec<u8> = rgbe.iter().map(|p| p[component]).collect();
                run_length_encode(&plane, &mut out);
            }
        } else {
            // Flat pixels. A normalised pixel's largest mantissa is ≥ 128, so
            // none can be mistaken for an old-style run marker (1, 1, 1, n).
            out.extend(rgbe.iter().flatten());
        }
        writer.write_all(&out)?;
    }
    Ok(bad)
}

/// Encodes one pixel, rounding to nearest; `Err` carries how many of its
/// components cannot be stored. Values below 2^-128 flush to 0.
fn to_rgbe(pixel: [f32; 3]) -> Result<[u8; 4], u64> {
    let bad = pixel
        .iter()
        .filter(|c| !c.is_finite() || **c < 0.0 || f64::from(**c) > MAX_RGBE)
        .count() as u64;
    if bad > 0 {
        return Err(bad);
    }
    let components = pixel.map(f64::from);
    let max = components[0].max(components[1]).max(components[2]);
    if max <= 0.0 {
        return Ok([0; 4]);
    }
    // frexp: max = f · 2^exponent with f in [0.5, 1), from the f64 bits (the
    // f32 input is always a normal f64, so this is exact).
    let mut exponent = ((max.to_bits() >> 52) & 0x7ff) as i32 - 1022;
    let mantissas = |exponent: i32| components.map(|c| (c * 2f64.powi(8 - exponent)).round());
    let mut m = mantissas(exponent);
    if m.iter().any(|&v| v >= 256.0) {
        // Rounding carried into the next power of two.
        exponent += 1;
        m = mantissas(exponent);
    }
    let biased = exponent + 128;
    if biased < 1 {
        return Ok([0; 4]);
    }
    if biased > 255 {
        return Err(1);
    }
    Ok([m[0] as u8, m[1] as u8, m[2] as u8, biased as u8])
}

/// Radiance's per-component RLE: a count byte > 128 repeats the next byte
/// (count − 128) times; a count byte ≤ 128 is followed by that many literals.
fn run_length_encode(bytes: &[u8], out: &mut Vec<u8>) {
    const MIN_RUN: usize = 3;
    let run_at = |i: usize, limit: usize| {
        bytes[i..]
            .iter()
            .take(limit)
            .take_while(|&&b| b == bytes[i])
            .count()
    };
    let mut i = 0;
    while i < bytes.len() {
        let run = run_at(i, 127);
        if run >= MIN_RUN {
            out.push(128 + run as u8);
            out.push(bytes[i]);
            i += run;
            continue;
        }
        let start = i;
        while i < bytes.len() && i - start < 128 && run_at(i, MIN_RUN) < MIN_RUN {
            i += 1;
        }
        out.push((i - start) as u8);
        out.extend_from_slice(&bytes[start..i]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_rgbe(p: [u8; 4]) -> [f64; 3] {
        let scale = if p[3] == 0 {
            0.0
        } else {
            2f64.powi(i32::from(p[3]) - 136)
        };
        [0, 1, 2].map(|i| f64::from(p[i]) * scale)
    }

    #[test]
    fn encoding_rounds_within_the_largest_component_over_255_5() {
        for pixel in [
            [1.0f32, 0.5, 0.25],
            [0.999, 1e-3, 0.3],
            [1.0e-30, 3.0e-31, 0.0],
            [65504.0, 1.0, 7.5],
            [0.998_046_9, 0.0, 0.0], // rounds up to 1.0: the carry path
            [7.995, 0.031_25, 0.0],  // carry, and 0.03125 is half a new unit
        ] {
            let max = pixel.iter().fold(0.0f64, |m, &c| m.max(f64::from(c)));
            let decoded = decode_rgbe(to_rgbe(pixel).unwrap());
            for (c, d) in pixel.iter().zip(decoded) {
                assert!(
                    (f64::from(*c) - d).abs() <= max / 255.5,
                    "{pixel:?} -> {decoded:?}"
                );
            }
        }
    }

    #[test]
    fn unstorable_components_are_counted() {
        assert_eq!(to_rgbe([-1.0, f32::NAN, 1.0]), Err(2));
        assert_eq!(to_rgbe([f32::MAX, 1.0, 1.0]), Err(1));
        assert_eq!(to_rgbe([0.0, 0.0, 0.0]), Ok([0; 4]));
    }

    #[test]
    fn run_length_encoding_round_trips() {
        let mut bytes = vec![7u8; 300];
        bytes.extend((0..200u32).map(|i| (i * 37 % 251) as u8));
        bytes.extend([1, 1, 2, 2, 2, 2, 3]);
        let mut encoded = Vec::new();
        run_length_encode(&bytes, &mut encoded);
        let mut decoded = Vec::new();
        let mut i = 0;
        while i < encoded.len() {
            let count = encoded[i] as usize;
            assert!(count > 0);
            if count > 128 {
                decoded.extend(std::iter::repeat_n(encoded[i + 1], count - 128));
                i += 2;
            } else {
                decoded.extend_from_slice(&encoded[i + 1..i + 1 + count]);
                i += 1 + count;
            }
        }
        assert_eq!(decoded, bytes);
        assert!(encoded.len() < bytes.len());
    }
}
