//! An image's size from the first bytes of its file, before the rest has
//! arrived: what lets a server refuse an image over its pixel limit while
//! the upload is still coming, instead of after buffering it whole. Only a
//! size the header states plainly is reported; anything unclear is left to
//! the decoder, which checks everything again.

use super::HdrFormat;
use std::io::Cursor;

/// How many first bytes a caller should offer at most: a header longer
/// than this is left to the decoder.
pub const PEEK_BYTES: usize = 64 << 10;

/// The width and height the header in `head` states, once `head` holds the
/// whole header; `None` while it does not (or the header is not one to
/// trust this early).
pub fn dimensions(head: &[u8]) -> Option<(u64, u64)> {
    match HdrFormat::detect(head)? {
        HdrFormat::Pfm => pfm(head),
        HdrFormat::Radiance => {
            let found = std::panic::catch_unwind(|| {
                use image::ImageDecoder;
                image::codecs::hdr::HdrDecoder::new(Cursor::new(head))
                    .ok()
                    .map(|d| d.dimensions())
            });
            let (w, h) = found.ok().flatten()?;
            Some((u64::from(w), u64::from(h)))
        }
        HdrFormat::Exr => {
            let found = std::panic::catch_unwind(|| {
                exr::meta::MetaData::read_from_buffered(Cursor::new(head), false)
                    .ok()
                    .map(|m| {
                        // The smallest flat part: the loader reads one part,
                        // and this must never refuse an image it would take.
                        m.headers
                            .iter()
                            .filter(|h| !h.deep)
                            .map(|h| {
                                let s = h.data_window().size;
                                (s.x() as u64, s.y() as u64)
                            })
                            .min_by_key(|(w, h)| w.saturating_mul(*h))
                    })
            });
            found.ok().flatten().flatten()
        }
    }
}

/// The width and height a PNG's header states (IHDR comes first: width
/// and height at bytes 16..24, big-endian); None for anything else.
pub fn png_dimensions(head: &[u8]) -> Option<(u64, u64)> {
    const PNG: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    if !head.starts_with(&PNG) || head.get(12..16) != Some(b"IHDR") {
        return None;
    }
    let word = |at: usize| -> Option<u64> {
        let b: [u8; 4] = head.get(at..at + 4)?.try_into().ok()?;
        Some(u64::from(u32::from_be_bytes(b)))
    };
    Some((word(16)?, word(20)?))
}

/// `PF` or `Pf`, whitespace, width, whitespace, height, whitespace.
fn pfm(head: &[u8]) -> Option<(u64, u64)> {
    let rest = &head[2..];
    let mut fields = rest
        .split(|b| b.is_ascii_whitespace())
        .filter(|f| !f.is_empty());
    let (w, h) = (fields.next()?, fields.next()?);
    // The height must be followed by whitespace, or more digits may come.
    let end = rest
        .windows(h.len())
        .position(|win| std::ptr::eq(win.as_ptr(), h.as_ptr()))?
        + h.len();
    if !rest.get(end).is_some_and(u8::is_ascii_whitespace) {
        return None;
    }
    let number = |f: &[u8]| std::str::from_utf8(f).ok()?.parse::<u64>().ok();
    Some((number(w)?, number(h)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_size_is_known_once_the_header_is_complete() {
        assert_eq!(dimensions(b"PF\n6000 5000\n-1.0\n"), Some((6000, 5000)));
        assert_eq!(dimensions(b"PF\n6000 50"), None, "the height may go on");
        assert_eq!(dimensions(b"PF\n6000 5000\n"), Some((6000, 5000)));
        let radiance = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4000 +X 7000\n";
        assert_eq!(dimensions(radiance), Some((7000, 4000)));
        assert_eq!(dimensions(&radiance[..20]), None);
        assert_eq!(dimensions(b"P6\n1 1\n255\n"), None, "not an HDR format");
        // A real EXR's header, cut after it and cut inside it.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let img = crate::image::HdrImage::from_fn(40, 30, |_, _| [1.0, 0.5, 0.25]);
        super::super::write_image_hdr(&path, &img).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(
            dimensions(&bytes[..bytes.len().min(PEEK_BYTES)]),
            Some((40, 30))
        );
        assert_eq!(dimensions(&bytes[..40]), None);
    }
}
