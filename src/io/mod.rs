//! HDR and LDR image files: reading with a validation policy, writing
//! atomically.
//!
//! HDR input (`load_hdr`, `decode_hdr`) is OpenEXR, Radiance RGBE or PFM,
//! recognised by its first bytes, never by its extension (a renamed or
//! mis-named file still loads, and a non-image is refused with what it starts
//! with). Every load goes through the policy on [`LoadOptions`]: size checked
//! from the header before allocation, NaN/±Inf refused (or zeroed with
//! `sanitize`), negatives clamped, all counted in the [`LoadReport`]. Decoders
//! run under `catch_unwind`, so a corrupt file is an error, never a crash.
//!
//! Output is chosen by extension (`.exr`, `.pfm`, `.hdr`; `.png` for the PNG
//! writers) and always goes through a temporary file and a rename, so a failed
//! write leaves the previous file intact.

mod atomic;
mod cicp;
mod error;
mod exr_guards;
mod hdr_png;
mod openexr;
pub use small::{
    line_at, nth_line_starting, read_small, read_small_text, toml_error, MAX_SMALL_FILE_BYTES,
};
pub mod peek;
mod pfm;
mod png;
pub use png::Alpha;
pub(crate) mod radiance;
mod small;
mod validate;

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use serde::Serialize;

pub use self::cicp::Cicp;
pub use self::error::HdrIoError;
pub use self::hdr_png::{
    encode_hdr_png, read_hdr_png_info, write_hdr_png, FoundChunks, HdrPngInfo, LightLevel,
    Mastering,
};
pub use self::png::Rgb16Image;
pub use self::validate::{
    DeviceFit, LoadOptions, LoadReport, DEFAULT_MAX_PIXELS, LOG_AVERAGE_DELTA,
};

use self::atomic::write_atomically;
use self::error::{catch_decoder_panic, hex_prefix};
use crate::image::{Frame, HdrImage, Rgb8Image};

/// The HDR file formats `load_hdr` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum HdrFormat {
    /// OpenEXR: f16/f32/u32 channels, any compression the `exr` crate reads.
    Exr,
    /// Radiance RGBE (`.hdr`, `.pic`): 8-bit mantissas with a shared exponent.
    Radiance,
    /// Portable Float Map: raw f32, rows bottom to top.
    Pfm,
}

impl HdrFormat {
    /// The human-readable name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Exr => "OpenEXR",
            Self::Radiance => "Radiance RGBE",
            Self::Pfm => "PFM",
        }
    }

    /// Recognises a format from the first bytes of a file (16 are plenty).
    pub fn detect(first_bytes: &[u8]) -> Option<Self> {
        if first_bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
            Some(Self::Exr)
        } else if first_bytes.starts_with(b"#?RADIANCE") || first_bytes.starts_with(b"#?RGBE") {
            Some(Self::Radiance)
        } else if (first_bytes.starts_with(b"PF") || first_bytes.starts_with(b"Pf"))
            && first_bytes.get(2).is_some_and(u8::is_ascii_whitespace)
        {
            Some(Self::Pfm)
        } else {
            None
        }
    }

    /// The format whose signature a file too short to hold it begins (a
    /// `#?RAD` of 5 bytes): a truncated file of that format, not an unknown
    /// one.
    pub fn cut_short(first_bytes: &[u8]) -> Option<Self> {
        let signatures: [(&[u8], Self); 4] = [
            (&[0x76, 0x2f, 0x31, 0x01], Self::Exr),
            (b"#?RADIANCE", Self::Radiance),
            (b"#?RGBE", Self::Radiance),
            (b"PF", Self::Pfm),
        ];
        signatures.iter().find_map(|(sig, format)| {
            (first_bytes.len() >= 2
                && first_bytes.len() < sig.len()
                && sig.starts_with(first_bytes))
            .then_some(*format)
        })
    }
}

/// Opens `path` for reading only if it is a regular file. A FIFO would
/// block `open` until a writer came (forever, for a mistyped path), and a
/// device or a folder is no file of ours: each is refused at once. On Unix
/// the file is opened without blocking, then its type is checked on the
/// open descriptor, so nothing can swap it in between.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path)?;
    if file.metadata()?.is_file() {
        Ok(file)
    } else {
        Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a FIFO, a device or a folder is refused)",
        ))
    }
}

/// Loads an HDR image file and applies the validation policy.
pub fn load_hdr(path: &Path, opts: &LoadOptions) -> Result<(HdrImage, LoadReport), HdrIoError> {
    let file = path.display().to_string();
    let io_error = |action| {
        let file = file.clone();
        move |source| HdrIoError::Io {
            file,
            action,
            source,
        }
    };
    let handle = open_regular(path).map_err(io_error("open"))?;
    let len = handle.metadata().map_err(io_error("read"))?.len();
    decode_stream(BufReader::with_capacity(1 << 16, handle), len, &file, opts)
}

/// Decodes an HDR image held in memory (an HTTP upload, say); `source_name`
/// stands for the file name in errors and in the report.
pub fn decode_hdr(
    bytes: &[u8],
    source_name: &str,
    opts: &LoadOptions,
) -> Result<(HdrImage, LoadReport), HdrIoError> {
    decode_stream(
        std::io::Cursor::new(bytes),
        bytes.len() as u64,
        source_name,
        opts,
    )
}

fn decode_stream<R: BufRead + Seek>(
    mut reader: R,
    len: u64,
    file: &str,
    opts: &LoadOptions,
) -> Result<(HdrImage, LoadReport), HdrIoError> {
    let io_error = |source| HdrIoError::Io {
        file: file.to_string(),
        action: "read",
        source,
    };
    let mut head = Vec::with_capacity(16);
    reader
        .by_ref()
        .take(16)
        .read_to_end(&mut head)
        .map_err(io_error)?;
    reader.seek(SeekFrom::Start(0)).map_err(io_error)?;
    if let (None, Some(format)) = (HdrFormat::detect(&head), HdrFormat::cut_short(&head)) {
        return Err(HdrIoError::Truncated {
            file: file.to_string(),
            format: format.name(),
            detail: format!("{} bytes, fewer than its signature", head.len()),
        });
    }
    let format = HdrFormat::detect(&head).ok_or_else(|| HdrIoError::UnknownFormat {
        file: file.to_string(),
        first_bytes: hex_prefix(&head),
    })?;
    let decoded = catch_decoder_panic(file, format.name(), || match format {
        HdrFormat::Exr => openexr::decode(reader, len, file, opts),
        HdrFormat::Radiance => {
            radiance::decode(reader, head.starts_with(b"#?RADIANCE"), file, opts)
        }
        HdrFormat::Pfm => pfm::decode(reader, len, file, opts),
    })?;
    validate::apply_policy(decoded, format, file, opts)
}

/// The extensions `write_image_hdr` understands.
const HDR_OUTPUTS: &str = ".exr (f32 RGB, ZIP16), .pfm (f32 RGB), .hdr (Radiance RGBE)";

/// Writes an HDR image, the format chosen by the extension: `.exr` (f32 RGB,
/// lossless ZIP16), `.pfm` (f32 RGB, little-endian) or `.hdr` (RGBE, lossy:
/// each component within 1/255.5 of its pixel's largest component). EXR and PFM store any f32,
/// NaN and negatives included; RGBE refuses what it cannot store.
pub fn write_image_hdr(path: &Path, img: &HdrImage) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !matches!(extension.as_str(), "exr" | "pfm" | "hdr") {
        return Err(HdrIoError::UnsupportedExtension {
            file,
            supported: HDR_OUTPUTS,
        });
    }
    png::check_consistent(&file, img)?;
    let write_error = |source| HdrIoError::Io {
        file: file.clone(),
        action: "write",
        source,
    };
    write_atomically(path, |writer| match extension.as_str() {
        "exr" => openexr::encode(writer, img).map_err(|e| match e {
            exr::error::Error::Io(source) => write_error(source),
            other => HdrIoError::Encode {
                file: file.clone(),
                format: "OpenEXR",
                detail: other.to_string(),
            },
        }),
        "pfm" => pfm::encode(writer, img).map_err(write_error),
        _ => {
            let bad = radiance::encode(writer, img).map_err(write_error)?;
            match bad.first {
                None => Ok(()),
                Some((x, y)) => Err(HdrIoError::Unrepresentable {
                    file: file.clone(),
                    format: "Radiance RGBE",
                    detail: format!(
                        "{} components are negative, NaN, ±Inf or above {:.3e}, first at ({x}, {y}); write .exr or .pfm instead",
                        bad.count,
                        radiance::MAX_RGBE
                    ),
                }),
            }
        }
    })
}

/// Writes `img` with `map` applied to every pixel as a `.pfm` (f32 RGB),
/// a band of rows at a time: the tone map of a large image straight to its
/// file, with no image of the results in memory.
pub fn write_pfm_mapped(
    path: &Path,
    img: &HdrImage,
    map: impl Fn([f32; 3]) -> [f32; 3] + Sync,
) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    let is_pfm = path
        .extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("pfm"));
    if !is_pfm {
        return Err(HdrIoError::UnsupportedExtension {
            file,
            supported: ".pfm",
        });
    }
    png::check_consistent(&file, img)?;
    write_atomically(path, |writer| {
        pfm::encode_mapped(writer, img, map).map_err(|source| HdrIoError::Io {
            file: file.clone(),
            action: "write",
            source,
        })
    })
}

/// Writes an 8-bit RGB PNG (the path must end in `.png`).
pub fn write_png8(path: &Path, img: &Rgb8Image) -> Result<(), HdrIoError> {
    png::write_png8(path, img)
}

/// Writes a 16-bit RGB PNG (the path must end in `.png`).
pub fn write_png16(path: &Path, img: &Rgb16Image) -> Result<(), HdrIoError> {
    png::write_png16(path, img)
}

/// Reads an 8-bit PNG (RGB, grey, or opaque RGBA/grey-alpha) as RGB.
pub fn read_png8(path: &Path) -> Result<Rgb8Image, HdrIoError> {
    png::read_png8(path)
}

/// [`read_png8`] on bytes in memory, as `compare` reads a PNG; `name`
/// names them in errors.
pub fn decode_png8(bytes: &[u8], name: &str) -> Result<Rgb8Image, HdrIoError> {
    png::decode_png8(bytes, name, Alpha::Opaque)
}

/// Reads a 16-bit PNG (RGB, grey, or opaque RGBA/grey-alpha) as RGB.
pub fn read_png16(path: &Path) -> Result<Rgb16Image, HdrIoError> {
    png::read_png16(path)
}

/// Writes bytes already encoded (an artifact PNG) to `path`, whole or not
/// at all: a temporary file beside it, renamed once written.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    write_atomically(path, |w| {
        std::io::Write::write_all(w, bytes).map_err(|source| HdrIoError::Io {
            file,
            action: "write",
            source,
        })
    })
}

/// Encodes an 8-bit RGB PNG in memory (for HTTP responses and hashing).
pub fn encode_png8(img: &Rgb8Image) -> Result<Vec<u8>, HdrIoError> {
    png::encode_png8(img)
}

/// What a PQ frame's PNG says of itself: BT.2100 PQ. The display's levels
/// are the scene's, so no mDCV or cLLI is written.
const PQ_FRAME_PNG: HdrPngInfo = HdrPngInfo {
    cicp: Cicp::BT2100_PQ,
    mastering: None,
    light_level: None,
};

/// A frame's PNG in memory: 8-bit RGB, or 16-bit RGB whose cICP chunk says
/// BT.2100 PQ.
pub fn encode_frame_png(frame: &Frame) -> Result<Vec<u8>, HdrIoError> {
    match frame {
        Frame::Rgb8(img) => png::encode_png8(img),
        Frame::Pq16(img) => encode_hdr_png(img, &PQ_FRAME_PNG),
    }
}

/// Writes a frame's PNG ([`encode_frame_png`]) to `path`, whole or not at all.
pub fn write_frame_png(path: &Path, frame: &Frame) -> Result<(), HdrIoError> {
    match frame {
        Frame::Rgb8(img) => png::write_png8(path, img),
        Frame::Pq16(img) => write_hdr_png(path, img, &PQ_FRAME_PNG),
    }
}

/// Reads a frame's PNG: an 8-bit PNG as an 8-bit frame, a 16-bit one as a
/// PQ frame when its cICP chunk says BT.2100 PQ (and refused otherwise:
/// 16-bit codes of another transfer are not a PQ frame).
pub fn read_frame_png(path: &Path) -> Result<Frame, HdrIoError> {
    let file = path.display().to_string();
    let io = |source| HdrIoError::Io {
        file: file.clone(),
        action: "read",
        source,
    };
    let mut bytes = Vec::new();
    open_regular(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(io)?;
    decode_frame_png(&bytes, &file)
}

/// [`read_frame_png`] on bytes in memory; `file` names them in errors.
pub fn decode_frame_png(bytes: &[u8], file: &str) -> Result<Frame, HdrIoError> {
    decode_frame_png_with(bytes, file, Alpha::Opaque)
}

/// [`decode_frame_png`] of a frame whose alpha channel means what `alpha`
/// says (a submitted frame's rule: composited over a background, or
/// dropped) instead of being refused unless opaque.
pub fn decode_frame_png_with(bytes: &[u8], file: &str, alpha: Alpha) -> Result<Frame, HdrIoError> {
    // The IHDR chunk comes first: its bit depth is byte 24.
    if bytes.get(24) != Some(&16) {
        return png::decode_png8(bytes, file, alpha).map(Frame::Rgb8);
    }
    let image = png::decode_png16(bytes, file, alpha)?;
    let chunks = read_hdr_png_info(bytes, file)?;
    if chunks.cicp != Some(Cicp::BT2100_PQ) {
        return Err(HdrIoError::Unsupported {
            file: file.to_owned(),
            format: "PNG",
            detail: format!(
                "a 16-bit frame must be BT.2100 PQ (cICP primaries 9, transfer 16), and this one's cICP {}",
                chunks
                    .cicp
                    .map_or("is missing".to_string(), |c| format!("says {c}"))
            ),
        });
    }
    Ok(Frame::Pq16(image))
}

#[cfg(test)]
mod tests {
    use super::error::SUPPORTED_INPUTS;
    use super::*;

    #[test]
    fn a_file_cut_inside_its_signature_is_truncated_not_unknown() {
        let dir = tempfile::tempdir().unwrap();
        for (bytes, format) in [
            (&b"#?RAD"[..], "Radiance RGBE"),
            (&b"#?RG"[..], "Radiance RGBE"),
            (&[0x76, 0x2f][..], "OpenEXR"),
        ] {
            let path = dir.path().join("cut.hdr");
            std::fs::write(&path, bytes).unwrap();
            let e = load_hdr(&path, &LoadOptions::default()).unwrap_err();
            assert!(
                matches!(e, HdrIoError::Truncated { format: f, .. } if f == format),
                "{bytes:?}: {e}"
            );
        }
        // Bytes no signature begins with stay unknown.
        assert_eq!(HdrFormat::cut_short(b"GIF8"), None);
        assert_eq!(HdrFormat::cut_short(b"#"), None);
    }

    #[test]
    fn formats_are_recognised_by_their_first_bytes() {
        assert_eq!(
            HdrFormat::detect(&[0x76, 0x2f, 0x31, 0x01, 2]),
            Some(HdrFormat::Exr)
        );
        assert_eq!(
            HdrFormat::detect(b"#?RADIANCE\n"),
            Some(HdrFormat::Radiance)
        );
        assert_eq!(HdrFormat::detect(b"#?RGBE\n"), Some(HdrFormat::Radiance));
        assert_eq!(HdrFormat::detect(b"PF\n1 1"), Some(HdrFormat::Pfm));
        assert_eq!(HdrFormat::detect(b"Pf 1 1"), Some(HdrFormat::Pfm));
        assert_eq!(HdrFormat::detect(b"PFX"), None);
        assert_eq!(HdrFormat::detect(b"\x89PNG\r\n\x1a\n"), None);
        assert_eq!(HdrFormat::detect(b""), None);
    }

    #[test]
    fn an_unknown_format_lists_what_is_supported() {
        let error =
            decode_hdr(b"\x89PNG\r\n\x1a\nrest", "x.png", &LoadOptions::default()).unwrap_err();
        let message = error.to_string();
        assert!(message.starts_with("x.png: not an HDR image"), "{message}");
        assert!(message.contains("89 50 4e 47"), "{message}");
        assert!(message.contains(SUPPORTED_INPUTS), "{message}");
    }

    #[test]
    fn the_report_serialises_the_format_in_lowercase() {
        assert_eq!(
            serde_json::to_string(&HdrFormat::Radiance).unwrap(),
            "\"radiance\""
        );
    }
}
