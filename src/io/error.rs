//! The one error type of image reading and writing, and the translations from
//! the third-party decoders' errors into it.
//!
//! Every message starts with the file it concerns (for in-memory data, the
//! source name the caller gave), because a batch run over hundreds of scenes
//! is useless if the log says "invalid data" without saying where.

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// What `load_hdr` says it reads, for "unknown format" messages.
pub(crate) const SUPPORTED_INPUTS: &str =
    "OpenEXR (starts with 76 2f 31 01), Radiance RGBE .hdr (starts with \"#?RADIANCE\" or \
     \"#?RGBE\"), PFM (starts with \"PF\" or \"Pf\")";

/// Why reading or writing an image failed.
#[derive(Debug, thiserror::Error)]
pub enum HdrIoError {
    /// The operating system refused to open, read, write or rename the file.
    #[error("{file}: cannot {action}: {source}")]
    Io {
        file: String,
        action: &'static str,
        #[source]
        source: std::io::Error,
    },

    /// The first bytes match none of the HDR formats this module reads.
    #[error("{file}: not an HDR image this tool reads (it starts with {first_bytes}); supported: {SUPPORTED_INPUTS}")]
    UnknownFormat { file: String, first_bytes: String },

    /// The output file name's extension selects no format the writer produces.
    #[error("{file}: cannot tell the output format from the file name; use one of the extensions {supported}")]
    UnsupportedExtension {
        file: String,
        supported: &'static str,
    },

    /// The header declares a zero width or height.
    #[error("{file}: the header declares an empty {width}×{height} image; the file is damaged or was written empty")]
    EmptyImage {
        file: String,
        width: u64,
        height: u64,
    },

    /// The header declares more pixels than the limit; refused before any pixel is allocated.
    #[error("{file}: {width}×{height} pixels is over the limit of {max_pixels} pixels; if the image is genuine, raise the limit (--max-pixels)")]
    TooLarge {
        file: String,
        width: u64,
        height: u64,
        max_pixels: u64,
    },

    /// The header declares more than the GPU that would tone-map it holds;
    /// refused before decoding.
    #[error("{file}: {width}×{height} pixels does not fit the GPU (at most {max_side} pixels a side and {max_pixels} pixels in all); tone-map it on the CPU (gpu=false) or make it smaller")]
    TooLargeForDevice {
        file: String,
        width: u32,
        height: u32,
        max_side: u32,
        max_pixels: u64,
    },

    /// The file ends before the data its header promises.
    #[error("{file}: truncated {format} file: {detail}; the file is incomplete (interrupted copy or download?)")]
    Truncated {
        file: String,
        format: &'static str,
        detail: String,
    },

    /// The bytes contradict the format: an impossible header field, block or compressed stream.
    #[error("{file}: corrupt {format} file: {detail}")]
    Corrupt {
        file: String,
        format: &'static str,
        detail: String,
    },

    /// A well-formed file that uses a feature this module does not read; the message says what to convert to.
    #[error("{file}: unsupported {format} file: {detail}")]
    Unsupported {
        file: String,
        format: &'static str,
        detail: String,
    },

    /// NaN or ±Inf samples, refused unless `LoadOptions::sanitize` is set.
    #[error("{file}: {count} non-finite values (NaN or ±Inf), first at ({x}, {y}); pass --sanitize to set them to 0")]
    NonFinite {
        file: String,
        count: u64,
        x: u32,
        y: u32,
    },

    /// A decoder panicked; caught so that one bad file cannot take down a batch run.
    #[error("{file}: the {format} decoder crashed ({message}); the file is probably corrupt")]
    DecoderPanic {
        file: String,
        format: &'static str,
        message: String,
    },

    /// The image holds values the chosen output format cannot store; nothing was written.
    #[error("{file}: cannot store this image as {format}: {detail}")]
    Unrepresentable {
        file: String,
        format: &'static str,
        detail: String,
    },

    /// The in-memory image is inconsistent (pixel count ≠ width × height, or empty): a caller bug.
    #[error("{file}: cannot write a {width}×{height} image holding {pixel_count} pixels; the image must be non-empty and hold width × height pixels")]
    BadImage {
        file: String,
        width: u32,
        height: u32,
        pixel_count: usize,
    },

    /// An encoder failed for a reason other than the file system.
    #[error("{file}: the {format} encoder failed: {detail}")]
    Encode {
        file: String,
        format: &'static str,
        detail: String,
    },
}

/// Shows the first bytes of an unrecognised file in hex, so that a user can
/// tell "this is a JPEG" or "this is an HTML error page" from the message.
pub(crate) fn hex_prefix(bytes: &[u8]) -> String {
    if bytes.is_empty() {
        return "nothing: the file is empty".to_string();
    }
    let hex: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect();
    hex.join(" ")
}

/// Translates an `exr` error. `exr` reports an early end of file as
/// `Invalid("reference to missing bytes")`, so that message becomes `Truncated`.
pub(crate) fn from_exr(file: &str, error: exr::error::Error) -> HdrIoError {
    const FORMAT: &str = "OpenEXR";
    match error {
        exr::error::Error::Io(source) => io_or_truncated(file, FORMAT, source),
        exr::error::Error::Invalid(message) if message.contains("missing bytes") => {
            HdrIoError::Truncated {
                file: file.to_string(),
                format: FORMAT,
                detail: format!("the data ends early ({message})"),
            }
        }
        exr::error::Error::Invalid(message) => HdrIoError::Corrupt {
            file: file.to_string(),
            format: FORMAT,
            detail: message.into_owned(),
        },
        exr::error::Error::NotSupported(message) => HdrIoError::Unsupported {
            file: file.to_string(),
            format: FORMAT,
            detail: format!("{message}; convert it to a scan-line or tiled RGB EXR with ZIP, PIZ or no compression"),
        },
        exr::error::Error::Aborted => HdrIoError::Corrupt {
            file: file.to_string(),
            format: FORMAT,
            detail: "the decoder stopped".to_string(),
        },
    }
}

/// Translates an `image` crate error for the given format.
pub(crate) fn from_image(file: &str, format: &'static str, error: image::ImageError) -> HdrIoError {
    use image::ImageError;
    let file = file.to_string();
    match error {
        ImageError::IoError(source) => io_or_truncated(&file, format, source),
        ImageError::Unsupported(e) => HdrIoError::Unsupported {
            file,
            format,
            detail: e.to_string(),
        },
        ImageError::Limits(e) => HdrIoError::Corrupt {
            file,
            format,
            detail: format!("the decoder's memory limit was hit ({e})"),
        },
        ImageError::Encoding(e) => HdrIoError::Encode {
            file,
            format,
            detail: e.to_string(),
        },
        // Decoders report a short compressed stream as a decoding error whose
        // text mentions the end of the data; say "truncated" for those.
        ImageError::Decoding(e) => {
            let detail = e.to_string();
            let lower = detail.to_ascii_lowercase();
            if lower.contains("eof") || lower.contains("end of") || lower.contains("unexpected end")
            {
                HdrIoError::Truncated {
                    file,
                    format,
                    detail,
                }
            } else {
                HdrIoError::Corrupt {
                    file,
                    format,
                    detail,
                }
            }
        }
        ImageError::Parameter(e) => HdrIoError::Corrupt {
            file,
            format,
            detail: e.to_string(),
        },
    }
}

/// An early end of file is the file's fault (truncated); anything else is the system's.
pub(crate) fn io_or_truncated(
    file: &str,
    format: &'static str,
    source: std::io::Error,
) -> HdrIoError {
    if source.kind() == std::io::ErrorKind::UnexpectedEof {
        HdrIoError::Truncated {
            file: file.to_string(),
            format,
            detail: "the data ends early".to_string(),
        }
    } else {
        HdrIoError::Io {
            file: file.to_string(),
            action: "read",
            source,
        }
    }
}

/// Runs a decoder and turns a panic into `DecoderPanic`.
///
/// This is the second line of defence: the readers check sizes and lengths
/// themselves, but `exr` and `image` are large and fuzzing keeps finding
/// panics in decoders like them. The closure only touches data it creates or
/// owns, so observing it after a panic is impossible and `AssertUnwindSafe` is
/// sound. A panic must be caught on the thread it happens on: one escaping a
/// task `spawn`ed on a rayon pool aborts the process, so the EXR reader,
/// which decompresses chunks in parallel, wraps each chunk in this itself.
pub(crate) fn catch_decoder_panic<T>(
    file: &str,
    format: &'static str,
    decode: impl FnOnce() -> Result<T, HdrIoError>,
) -> Result<T, HdrIoError> {
    match catch_unwind(AssertUnwindSafe(decode)) {
        Ok(result) => result,
        Err(payload) => Err(HdrIoError::DecoderPanic {
            file: file.to_string(),
            format,
            message: panic_message(payload.as_ref()),
        }),
    }
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(message) = payload.downcast_ref::<&str>() {
        (*message).to_string()
    } else if let Some(message) = payload.downcast_ref::<String>() {
        message.clone()
    } else {
        "panic without a message".to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_caught_panic_names_the_file_and_keeps_the_message() {
        let result: Result<(), _> = catch_decoder_panic("bad.exr", "OpenEXR", || {
            panic!("index out of bounds: the len is 3 but the index is 7")
        });
        let message = result.unwrap_err().to_string();
        assert!(
            message.starts_with("bad.exr: the OpenEXR decoder crashed"),
            "{message}"
        );
        assert!(message.contains("index out of bounds"), "{message}");
    }

    #[test]
    fn an_early_end_of_file_is_reported_as_truncation() {
        let eof = std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "eof");
        assert!(matches!(
            io_or_truncated("a.pfm", "PFM", eof),
            HdrIoError::Truncated { .. }
        ));
        let denied = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "no");
        assert!(matches!(
            io_or_truncated("a.pfm", "PFM", denied),
            HdrIoError::Io { .. }
        ));
    }

    #[test]
    fn hex_prefix_shows_at_most_eight_bytes() {
        assert_eq!(
            hex_prefix(b"\x89PNG\r\n\x1a\n\0\0"),
            "89 50 4e 47 0d 0a 1a 0a"
        );
        assert_eq!(hex_prefix(b""), "nothing: the file is empty");
    }
}
