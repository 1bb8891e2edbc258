//! PNG in and out: 8-bit RGB (the pipeline's output and the goldens) and
//! 16-bit RGB (finer diagnostics), through the `image` crate.
//!
//! Reading accepts grey (expanded to RGB), RGB, and RGBA or grey-alpha only
//! when every alpha sample is opaque: a golden with transparency would be
//! compared against an output that has none, so it is refused rather than
//! silently flattened. The bit depth must match the function (no silent
//! 8 ↔ 16 conversion that would change what "equal" means in a comparison).
//! A file must end with its IEND chunk (see `read_png`).

use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek, SeekFrom, Write};
use std::path::Path;

use image::codecs::png::{PngDecoder, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder};

use super::atomic::write_atomically;
use super::error::{catch_decoder_panic, from_image, HdrIoError};
use super::validate::{check_dimensions, DEFAULT_MAX_PIXELS};
pub use crate::image::Rgb16Image;
use crate::image::{Image, Rgb8Image};

const FORMAT: &str = "PNG";

pub(crate) fn read_png8(path: &Path) -> Result<Rgb8Image, HdrIoError> {
    let file = path.display().to_string();
    let (handle, len) = open(path, &file)?;
    png8(read_png(handle, len, &file)?, &file)
}

/// [`read_png8`] on bytes in memory; `file` names them in errors.
pub(crate) fn decode_png8(bytes: &[u8], file: &str) -> Result<Rgb8Image, HdrIoError> {
    png8(
        read_png(Cursor::new(bytes), bytes.len() as u64, file)?,
        file,
    )
}

fn png8(image: DynamicImage, file: &str) -> Result<Rgb8Image, HdrIoError> {
    let file = file.to_string();
    match image {
        DynamicImage::ImageRgb8(rgb) => Ok(from_raw(rgb.width(), rgb.height(), &rgb.into_raw())),
        DynamicImage::ImageLuma8(grey) => {
            Ok(grey_to_rgb(grey.width(), grey.height(), &grey.into_raw()))
        }
        DynamicImage::ImageRgba8(rgba) => {
            let (w, h) = rgba.dimensions();
            let rgb = opaque_rgb(&file, rgba.into_raw().as_slice(), 4, 255)?;
            Ok(from_raw(w, h, &rgb))
        }
        DynamicImage::ImageLumaA8(grey) => {
            let (w, h) = grey.dimensions();
            let luma = opaque_rgb(&file, grey.into_raw().as_slice(), 2, 255)?;
            Ok(grey_to_rgb(w, h, &luma))
        }
        _ => Err(wrong_depth(&file, "16-bit", "read_png16")),
    }
}

pub(crate) fn read_png16(path: &Path) -> Result<Rgb16Image, HdrIoError> {
    let file = path.display().to_string();
    let (handle, len) = open(path, &file)?;
    png16(read_png(handle, len, &file)?, &file)
}

/// [`read_png16`] on bytes in memory; `file` names them in errors.
pub(crate) fn decode_png16(bytes: &[u8], file: &str) -> Result<Rgb16Image, HdrIoError> {
    png16(
        read_png(Cursor::new(bytes), bytes.len() as u64, file)?,
        file,
    )
}

fn png16(image: DynamicImage, file: &str) -> Result<Rgb16Image, HdrIoError> {
    match image {
        DynamicImage::ImageRgb16(rgb) => Ok(from_raw(rgb.width(), rgb.height(), &rgb.into_raw())),
        DynamicImage::ImageLuma16(grey) => {
            Ok(grey_to_rgb(grey.width(), grey.height(), &grey.into_raw()))
        }
        DynamicImage::ImageRgba16(rgba) => {
            let (w, h) = rgba.dimensions();
            let rgb = opaque_rgb(file, rgba.into_raw().as_slice(), 4, u16::MAX)?;
            Ok(from_raw(w, h, &rgb))
        }
        DynamicImage::ImageLumaA16(grey) => {
            let (w, h) = grey.dimensions();
            let luma = opaque_rgb(file, grey.into_raw().as_slice(), 2, u16::MAX)?;
            Ok(grey_to_rgb(w, h, &luma))
        }
        _ => Err(wrong_depth(file, "8-bit", "read_png8")),
    }
}

/// The IEND chunk every PNG must end with: length 0, type, CRC.
const IEND: [u8; 12] = [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xae, 0x42, 0x60, 0x82];

/// Decodes after checking that the file is complete and that the header's
/// size is within the default pixel limit.
///
/// The IEND check is ours: the `png` decoder stops after the last image data
/// and does not notice a file cut in its final chunks, but a golden that lost
/// its tail was not written completely and must not be trusted.
fn open(path: &Path, file: &str) -> Result<(File, u64), HdrIoError> {
    let io_error = |action| {
        move |source| HdrIoError::Io {
            file: file.to_string(),
            action,
            source,
        }
    };
    let handle = super::open_regular(path).map_err(io_error("open"))?;
    let len = handle.metadata().map_err(io_error("read"))?.len();
    Ok((handle, len))
}

fn read_png<R: Read + Seek>(
    mut handle: R,
    len: u64,
    file: &str,
) -> Result<DynamicImage, HdrIoError> {
    let io_error = |action| {
        move |source| HdrIoError::Io {
            file: file.to_string(),
            action,
            source,
        }
    };
    let mut tail = [0u8; 12];
    let complete = len >= 12 && {
        handle.seek(SeekFrom::End(-12)).map_err(io_error("read"))?;
        handle.read_exact(&mut tail).map_err(io_error("read"))?;
        tail == IEND
    };
    if !complete {
        return Err(HdrIoError::Truncated {
            file: file.to_string(),
            format: FORMAT,
            detail: "the file does not end with the IEND chunk".to_string(),
        });
    }
    handle.seek(SeekFrom::Start(0)).map_err(io_error("read"))?;
    catch_decoder_panic(file, FORMAT, || {
        let decoder =
            PngDecoder::new(BufReader::new(handle)).map_err(|e| from_image(file, FORMAT, e))?;
        let (width, height) = image::ImageDecoder::dimensions(&decoder);
        check_dimensions(
            file,
            u64::from(width),
            u64::from(height),
            DEFAULT_MAX_PIXELS,
        )?;
        DynamicImage::from_decoder(decoder).map_err(|e| from_image(file, FORMAT, e))
    })
}

fn wrong_depth(file: &str, depth: &str, other: &str) -> HdrIoError {
    HdrIoError::Unsupported {
        file: file.to_string(),
        format: FORMAT,
        detail: format!("it is a {depth} PNG; read it with {other}"),
    }
}

/// Drops the alpha channel after checking that it is opaque everywhere.
fn opaque_rgb<T: Copy + PartialEq>(
    file: &str,
    samples: &[T],
    stride: usize,
    opaque: T,
) -> Result<Vec<T>, HdrIoError> {
    if let Some(index) = samples
        .chunks_exact(stride)
        .position(|p| p[stride - 1] != opaque)
    {
        return Err(HdrIoError::Unsupported {
            file: file.to_string(),
            format: FORMAT,
            detail: format!(
                "pixel {index} (in row-major order) is not opaque; goldens and references must have no transparency"
            ),
        });
    }
    Ok(samples
        .chunks_exact(stride)
        .flat_map(|p| p[..stride - 1].iter().copied())
        .collect())
}

fn from_raw<T: Copy>(width: u32, height: u32, samples: &[T]) -> Image<[T; 3]> {
    Image {
        width,
        height,
        pixels: samples
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    }
}

fn grey_to_rgb<T: Copy>(width: u32, height: u32, samples: &[T]) -> Image<[T; 3]> {
    Image {
        width,
        height,
        pixels: samples.iter().map(|&v| [v; 3]).collect(),
    }
}

/// Checks that the image is non-empty and its buffer matches its size: the
/// fields are public, and the encoder would otherwise panic or misread.
pub(crate) fn check_consistent<P>(file: &str, image: &Image<P>) -> Result<(), HdrIoError> {
    let expected = image.width as usize * image.height as usize;
    if expected == 0 || image.pixels.len() != expected {
        return Err(HdrIoError::BadImage {
            file: file.to_string(),
            width: image.width,
            height: image.height,
            pixel_count: image.pixels.len(),
        });
    }
    Ok(())
}

fn encode(
    writer: impl Write,
    file: &str,
    bytes: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<(), HdrIoError> {
    PngEncoder::new(writer)
        .write_image(bytes, width, height, color)
        .map_err(|e| from_image(file, FORMAT, e))
}

pub(crate) fn encode_png8(image: &Rgb8Image) -> Result<Vec<u8>, HdrIoError> {
    const NAME: &str = "<in-memory PNG>";
    check_consistent(NAME, image)?;
    let mut bytes = Cursor::new(Vec::new());
    encode(
        &mut bytes,
        NAME,
        image.as_bytes(),
        image.width,
        image.height,
        ExtendedColorType::Rgb8,
    )?;
    Ok(bytes.into_inner())
}

pub(crate) fn write_png8(path: &Path, image: &Rgb8Image) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    check_png_extension(path, &file)?;
    check_consistent(&file, image)?;
    write_atomically(path, |w| {
        encode(
            w,
            &file,
            image.as_bytes(),
            image.width,
            image.height,
            ExtendedColorType::Rgb8,
        )
    })
}

pub(crate) fn write_png16(path: &Path, image: &Rgb16Image) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    check_png_extension(path, &file)?;
    check_consistent(&file, image)?;
    // `image` takes 16-bit samples in native byte order and writes them big-endian.
    let bytes: &[u8] = bytemuck::cast_slice(&image.pixels);
    write_atomically(path, |w| {
        encode(
            w,
            &file,
            bytes,
            image.width,
            image.height,
            ExtendedColorType::Rgb16,
        )
    })
}

/// PNG writers insist on `.png` so that a golden is never written under a
/// name that says it is something else.
pub(crate) fn check_png_extension(path: &Path, file: &str) -> Result<(), HdrIoError> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        Ok(())
    } else {
        Err(HdrIoError::UnsupportedExtension {
            file: file.to_string(),
            supported: ".png",
        })
    }
}
