//! 16-bit PNG for HDR displays (PNG Third Edition): the code values with a
//! cICP chunk naming their primaries and transfer (ITU-T H.273 code
//! points), and, where known, mDCV (the mastering display's colour volume)
//! and cLLI (the content's light levels). Written through the `png` crate,
//! since `image` writes none of the three; read back the same way.

use std::io::Cursor;
use std::path::Path;

use super::atomic::write_atomically;
use super::cicp::Cicp;
use super::error::HdrIoError;
use super::png::{check_consistent, check_png_extension, Rgb16Image};

const FORMAT: &str = "PNG";

/// mDCV: the mastering display's primaries and white (CIE 1931 x, y) and
/// its luminance range in cd/m².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mastering {
    /// Red, green, blue.
    pub primaries: [[f64; 2]; 3],
    /// The white point.
    pub white: [f64; 2],
    /// Peak, cd/m².
    pub max_nits: f64,
    /// Black, cd/m².
    pub min_nits: f64,
}

/// cLLI: the brightest pixel's brightest channel (MaxCLL) and the mean over
/// the frame of each pixel's brightest channel (MaxFALL), cd/m²
/// (CTA-861.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightLevel {
    /// MaxCLL.
    pub max_cll: f64,
    /// MaxFALL.
    pub max_fall: f64,
}

/// What an HDR PNG says of its pixels besides their values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HdrPngInfo {
    /// cICP.
    pub cicp: Cicp,
    /// mDCV, when known.
    pub mastering: Option<Mastering>,
    /// cLLI, when known.
    pub light_level: Option<LightLevel>,
}

/// Chromaticities in units of 0.00002, luminances in 0.0001 cd/m², as mDCV
/// and cLLI store them (rounded; out-of-range values saturate).
fn units(v: f64, unit: f64) -> u32 {
    (v / unit).round().clamp(0.0, u32::MAX as f64) as u32
}

fn chunks(info: &HdrPngInfo) -> Vec<(png::chunk::ChunkType, Vec<u8>)> {
    let mut out = vec![(
        png::chunk::cICP,
        vec![info.cicp.primaries, info.cicp.transfer, 0, 1],
    )];
    if let Some(m) = info.mastering {
        let mut data = Vec::with_capacity(24);
        for [x, y] in m.primaries.into_iter().chain([m.white]) {
            for v in [x, y] {
                data.extend_from_slice(
                    &(units(v, 0.00002).min(u16::MAX as u32) as u16).to_be_bytes(),
                );
            }
        }
        data.extend_from_slice(&units(m.max_nits, 0.0001).to_be_bytes());
        data.extend_from_slice(&units(m.min_nits, 0.0001).to_be_bytes());
        out.push((png::chunk::mDCV, data));
    }
    if let Some(l) = info.light_level {
        let mut data = Vec::with_capacity(8);
        data.extend_from_slice(&units(l.max_cll, 0.0001).to_be_bytes());
        data.extend_from_slice(&units(l.max_fall, 0.0001).to_be_bytes());
        out.push((png::chunk::cLLI, data));
    }
    out
}

fn encode<W: std::io::Write>(
    w: W,
    file: &str,
    image: &Rgb16Image,
    info: &HdrPngInfo,
) -> Result<(), HdrIoError> {
    let failed = |e: png::EncodingError| HdrIoError::Encode {
        file: file.to_string(),
        format: FORMAT,
        detail: e.to_string(),
    };
    let mut encoder = png::Encoder::new(w, image.width, image.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Sixteen);
    let mut writer = encoder.write_header().map_err(failed)?;
    // All three come before the image data.
    for (kind, data) in chunks(info) {
        writer.write_chunk(kind, &data).map_err(failed)?;
    }
    let mut samples = Vec::with_capacity(image.pixels.len() * 6);
    for p in &image.pixels {
        for c in p {
            samples.extend_from_slice(&c.to_be_bytes());
        }
    }
    writer.write_image_data(&samples).map_err(failed)?;
    writer.finish().map_err(failed)
}

/// The PNG of a 16-bit RGB image with its HDR chunks, in memory.
pub fn encode_hdr_png(image: &Rgb16Image, info: &HdrPngInfo) -> Result<Vec<u8>, HdrIoError> {
    const NAME: &str = "<in-memory PNG>";
    check_consistent(NAME, image)?;
    let mut bytes = Cursor::new(Vec::new());
    encode(&mut bytes, NAME, image, info)?;
    Ok(bytes.into_inner())
}

/// Writes a 16-bit RGB image with its HDR chunks to `path` (a `.png`),
/// whole or not at all.
pub fn write_hdr_png(path: &Path, image: &Rgb16Image, info: &HdrPngInfo) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    check_png_extension(path, &file)?;
    check_consistent(&file, image)?;
    write_atomically(path, |w| encode(w, &file, image, info))
}

/// The HDR chunks a PNG has, each `None` where it has not that chunk.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoundChunks {
    /// cICP.
    pub cicp: Option<Cicp>,
    /// mDCV.
    pub mastering: Option<Mastering>,
    /// cLLI.
    pub light_level: Option<LightLevel>,
}

/// The HDR chunks of a PNG in memory; `file` names it in errors. The
/// pixels are read by `read_png16`.
pub fn read_hdr_png_info(bytes: &[u8], file: &str) -> Result<FoundChunks, HdrIoError> {
    let corrupt = |e: png::DecodingError| HdrIoError::Corrupt {
        file: file.to_string(),
        format: FORMAT,
        detail: e.to_string(),
    };
    // cICP as the file has it (once, RGB, full range), not as a decoder
    // kept it.
    let cicp = super::cicp::scan(bytes, file)?;
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    decoder.set_ignore_text_chunk(true);
    let mut reader = decoder.read_info().map_err(corrupt)?;
    // mDCV and cLLI may follow the header anywhere before the image data,
    // which read_info has reached.
    let info = reader.info();
    let xy = |p: (png::ScaledFloat, png::ScaledFloat)| {
        [p.0.into_value() as f64, p.1.into_value() as f64]
    };
    let mastering = info.mastering_display_color_volume.map(|m| Mastering {
        primaries: [
            xy(m.chromaticities.red),
            xy(m.chromaticities.green),
            xy(m.chromaticities.blue),
        ],
        white: xy(m.chromaticities.white),
        max_nits: m.max_luminance as f64 * 0.0001,
        min_nits: m.min_luminance as f64 * 0.0001,
    });
    let light_level = info.content_light_level.map(|l| LightLevel {
        max_cll: l.max_content_light_level as f64 * 0.0001,
        max_fall: l.max_frame_average_light_level as f64 * 0.0001,
    });
    // The image data is checked too: a file whose pixels do not decode is
    // no HDR PNG, whatever its chunks say.
    let mut buf = vec![0; reader.output_buffer_size().unwrap_or(0)];
    reader.next_frame(&mut buf).map_err(corrupt)?;
    Ok(FoundChunks {
        cicp,
        mastering,
        light_level,
    })
}
