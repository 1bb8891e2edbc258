//! Portable Float Map, hand-written: the format is three text tokens and raw
//! floats, simpler to read correctly than to wrap.
//!
//! Layout: `PF` (RGB) or `Pf` (grey), whitespace, width, whitespace, height,
//! whitespace, scale, exactly one whitespace byte, then width × height ×
//! channels 32-bit floats, rows from the BOTTOM of the image to the top. The
//! scale's sign gives the byte order (negative: little-endian); its magnitude
//! is a nominal "absolute luminance" factor that writers set to 1 and readers
//! (pfstools, OpenCV, HDR Toolbox) ignore, so it is ignored here too.
//! Comments are not part of the format and are refused. Bytes after the last
//! row are ignored, as other readers do.

use std::io::{BufRead, Write};

use super::error::{io_or_truncated, HdrIoError};
use super::validate::{check_dimensions, check_fit, Decoded};
use super::LoadOptions;
use crate::image::{HdrImage, Image};

const FORMAT: &str = "PFM";

/// Longest header token accepted: a width, height or scale never needs more,
/// and the bound keeps a garbage file from being read as one huge token.
const MAX_TOKEN_LEN: usize = 64;

/// Reads a PFM whose first byte is at the reader's position; `len` is the
/// number of bytes from there to the end, for the truncation check.
pub(crate) fn decode(
    mut reader: impl BufRead,
    len: u64,
    file: &str,
    opts: &LoadOptions,
) -> Result<Decoded, HdrIoError> {
    let corrupt = |detail: String| HdrIoError::Corrupt {
        file: file.to_string(),
        format: FORMAT,
        detail,
    };
    let mut header = HeaderReader {
        reader: &mut reader,
        consumed: 0,
        file,
    };
    let channels = match header.token("magic")?.as_str() {
        "PF" => 3usize,
        "Pf" => 1usize,
        other => {
            return Err(corrupt(format!(
                "the magic is {other:?}, not \"PF\" or \"Pf\""
            )))
        }
    };
    let width = parse_size(&header.token("width")?, "width").map_err(corrupt)?;
    let height = parse_size(&header.token("height")?, "height").map_err(corrupt)?;
    let scale_token = header.token("scale")?;
    let scale: f64 = scale_token
        .parse()
        .ok()
        .filter(|s: &f64| s.is_finite() && *s != 0.0)
        .ok_or_else(|| {
            corrupt(format!(
                "the scale {scale_token:?} is not a non-zero number (its sign gives the byte order)"
            ))
        })?;
    let little_endian = scale < 0.0;
    let header_len = header.consumed;

    let (w, h, pixel_count) = check_dimensions(file, width, height, opts.max_pixels)?;
    check_fit(file, w, h, opts)?;
    let row_bytes = w as usize * channels * 4;
    let payload = pixel_count as u64 * channels as u64 * 4;
    let available = len.saturating_sub(header_len);
    if available < payload {
        return Err(HdrIoError::Truncated {
            file: file.to_string(),
            format: FORMAT,
            detail: format!(
                "the header declares {w}×{h}×{channels} floats ({payload} bytes) but only {available} bytes follow it"
            ),
        });
    }

    let mut pixels = vec![[0.0f32; 3]; pixel_count];
    crate::image::advise_huge_pages(&pixels);
    // An RGB file in the host's byte order is read straight into the pixels.
    let direct = channels == 3 && little_endian == cfg!(target_endian = "little");
    let mut row = vec![0u8; if direct { 0 } else { row_bytes }];
    let decode_sample = |b: &[u8]| {
        let bytes = [b[0], b[1], b[2], b[3]];
        if little_endian {
            f32::from_le_bytes(bytes)
        } else {
            f32::from_be_bytes(bytes)
        }
    };
    for stored_row in 0..h as usize {
        // Stored bottom-to-top: the first stored row is the image's last.
        let y = h as usize - 1 - stored_row;
        let target = &mut pixels[y * w as usize..(y + 1) * w as usize];
        if direct {
            reader
                .read_exact(bytemuck::cast_slice_mut(target))
                .map_err(|e| io_or_truncated(file, FORMAT, e))?;
            continue;
        }
        reader
            .read_exact(&mut row)
            .map_err(|e| io_or_truncated(file, FORMAT, e))?;
        for (pixel, samples) in target.iter_mut().zip(row.chunks_exact(channels * 4)) {
            *pixel = if channels == 3 {
                [
                    decode_sample(&samples[0..4]),
                    decode_sample(&samples[4..8]),
                    decode_sample(&samples[8..12]),
                ]
            } else {
                [decode_sample(samples); 3]
            };
        }
    }
    let channel_names = if channels == 3 {
        vec!["R", "G", "B"]
    } else {
        vec!["Y"]
    };
    Ok(Decoded {
        image: Image {
            width: w,
            height: h,
            pixels,
        },
        channels: channel_names.into_iter().map(String::from).collect(),
    })
}

fn parse_size(token: &str, what: &str) -> Result<u64, String> {
    token
        .parse::<u64>()
        .map_err(|_| format!("the {what} {token:?} is not a whole number"))
}

/// Writes an RGB PFM: little-endian (scale −1), rows bottom to top, the
/// layout most readers expect.
pub(crate) fn encode(writer: &mut impl Write, image: &HdrImage) -> std::io::Result<()> {
    encode_mapped(writer, image, |c| c)
}

/// [`encode`] of `image` with `map` applied to every pixel, a band of rows
/// at a time on every core, with no image of the results.
pub(crate) fn encode_mapped(
    writer: &mut impl Write,
    image: &HdrImage,
    map: impl Fn([f32; 3]) -> [f32; 3] + Sync,
) -> std::io::Result<()> {
    use rayon::prelude::*;
    const BAND: usize = 64;
    write!(writer, "PF\n{} {}\n-1.0\n", image.width, image.height)?;
    let width = image.width as usize;
    let mut band = vec![[0.0f32; 3]; BAND.min(image.height as usize) * width];
    // Bottom band first, each band's rows bottom to top.
    let mut end = image.height as usize;
    while end > 0 {
        let start = end.saturating_sub(BAND);
        let out = &mut band[..(end - start) * width];
        out.par_chunks_mut(width.max(1))
            .enumerate()
            .for_each(|(i, row)| {
                let y = end - 1 - i;
                let pixels = &image.pixels[y * width..(y + 1) * width];
                for (o, &c) in row.iter_mut().zip(pixels) {
                    // Little-endian samples whatever the host's order.
                    *o = map(c).map(|v| f32::from_bits(v.to_bits().to_le()));
                }
            });
        writer.write_all(bytemuck::cast_slice(out))?;
        end = start;
    }
    Ok(())
}

/// Reads whitespace-separated header tokens, counting the bytes it consumes
/// so that the payload length can be checked before allocating.
struct HeaderReader<'r, R> {
    reader: &'r mut R,
    consumed: u64,
    file: &'r str,
}

impl<R: BufRead> HeaderReader<'_, R> {
    /// Skips leading whitespace, reads a token, and consumes exactly one
    /// whitespace byte after it (after the scale, that byte is the last of
    /// the header).
    fn token(&mut self, what: &str) -> Result<String, HdrIoError> {
        let mut token = Vec::new();
        loop {
            let byte = self.next_byte(what)?;
            if byte.is_ascii_whitespace() {
                if token.is_empty() {
                    continue;
                }
                break;
            }
            if token.len() == MAX_TOKEN_LEN {
                return Err(HdrIoError::Corrupt {
                    file: self.file.to_string(),
                    format: FORMAT,
                    detail: format!("the header's {what} is longer than {MAX_TOKEN_LEN} bytes"),
                });
            }
            token.push(byte);
        }
        Ok(String::from_utf8_lossy(&token).into_owned())
    }

    fn next_byte(&mut self, what: &str) -> Result<u8, HdrIoError> {
        let mut byte = [0u8];
        match self.reader.read_exact(&mut byte) {
            Ok(()) => {
                self.consumed += 1;
                Ok(byte[0])
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(HdrIoError::Truncated {
                file: self.file.to_string(),
                format: FORMAT,
                detail: format!("the header ends while reading its {what}"),
            }),
            Err(e) => Err(io_or_truncated(self.file, FORMAT, e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_bytes(bytes: &[u8]) -> Result<Decoded, HdrIoError> {
        decode(bytes, bytes.len() as u64, "t.pfm", &LoadOptions::default())
    }

    #[test]
    fn rows_are_stored_bottom_to_top() {
        let image = Image::from_fn(2, 3, |x, y| [x as f32, y as f32, 0.5]);
        let mut bytes = Vec::new();
        encode(&mut bytes, &image).unwrap();
        assert!(bytes.starts_with(b"PF\n2 3\n-1.0\n"));
        // The first stored pixel is (0, 2): the bottom-left one.
        let first = f32::from_le_bytes(bytes[12 + 4..12 + 8].try_into().unwrap());
        assert_eq!(first, 2.0);
        assert_eq!(decode_bytes(&bytes).unwrap().image, image);
    }

    #[test]
    fn big_endian_grey_with_the_header_on_one_line_is_read() {
        let mut bytes = b"Pf 2 1 1.0\n".to_vec();
        bytes.extend_from_slice(&0.25f32.to_be_bytes());
        bytes.extend_from_slice(&4.0f32.to_be_bytes());
        let decoded = decode_bytes(&bytes).unwrap();
        assert_eq!(decoded.image.pixels, vec![[0.25; 3], [4.0; 3]]);
        assert_eq!(decoded.channels, vec!["Y"]);
    }

    #[test]
    fn bad_header_fields_are_named() {
        let cases: [(&[u8], &str); 4] = [
            (b"PF\n-3 2\n-1.0\n", "width"),
            (b"PF\n3 2\n0\n", "scale"),
            (b"PF\n3 2\nnan\n", "scale"),
            (b"PF\n3 two\n-1\n", "height"),
        ];
        for (bytes, field) in cases {
            let message = decode_bytes(bytes).unwrap_err().to_string();
            assert!(message.starts_with("t.pfm: corrupt PFM file"), "{message}");
            assert!(message.contains(field), "{message}");
        }
    }

    #[test]
    fn an_endless_token_is_refused() {
        let bytes = [b'9'; 1000];
        let mut with_magic = b"PF ".to_vec();
        with_magic.extend_from_slice(&bytes);
        assert!(matches!(
            decode_bytes(&with_magic),
            Err(HdrIoError::Corrupt { .. })
        ));
    }
}
