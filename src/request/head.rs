//! An uploaded image's header, read as the body arrives: an image over the
//! pixel limit is refused (413) as soon as its header says its size, not
//! after its whole body has been received and buffered.

use super::error::ApiError;
use crate::io::peek::{dimensions, PEEK_BYTES};
use http::StatusCode;

/// Watches the first bytes of an upload for the image's size.
pub struct HeadCheck {
    max_pixels: u64,
    head: Vec<u8>,
    /// The length at the last look: a header is looked at again when a
    /// line ends (Radiance's and PFM's headers are lines) or 512 more bytes
    /// came, so a body sent a byte at a time costs a look per line and no
    /// more than 128 others.
    looked_at: usize,
    done: bool,
}

impl HeadCheck {
    pub fn new(max_pixels: u64) -> HeadCheck {
        HeadCheck {
            max_pixels,
            head: Vec::new(),
            looked_at: 0,
            done: false,
        }
    }

    /// Takes the next bytes of the image; 413 `too_large` once its header
    /// states a size over the limit.
    pub fn feed(&mut self, chunk: &[u8]) -> Result<(), ApiError> {
        if self.done {
            return Ok(());
        }
        let take = (PEEK_BYTES - self.head.len()).min(chunk.len());
        self.head.extend_from_slice(&chunk[..take]);
        let full = self.head.len() >= PEEK_BYTES;
        let line_ended = chunk[..take].contains(&b'\n');
        if self.looked_at > 0 && self.head.len() < self.looked_at + 512 && !full && !line_ended {
            return Ok(());
        }
        self.looked_at = self.head.len();
        if let Some((w, h)) = dimensions(&self.head) {
            self.done = true;
            self.head = Vec::new();
            if w.saturating_mul(h) > self.max_pixels {
                return Err(ApiError::new(
                    StatusCode::PAYLOAD_TOO_LARGE,
                    "too_large",
                    format!(
                        "upload: {w}×{h} pixels is over the limit of {} pixels (serve \
                         --max-pixels), refused from its header before the rest of the body",
                        self.max_pixels
                    ),
                ));
            }
        } else if full {
            self.done = true;
            self.head = Vec::new();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_over_the_limit_is_refused_from_its_header_byte_by_byte() {
        let body = b"PF\n6000 5000\n-1.0\n";
        let mut c = HeadCheck::new(8 << 20);
        let refused = body.iter().map(|b| c.feed(&[*b])).find_map(Result::err);
        let e = refused.expect("refused before the pixels");
        assert_eq!(e.status, StatusCode::PAYLOAD_TOO_LARGE);
        assert!(e.detail.contains("6000×5000"), "{}", e.detail);
        // Within the limit: never refused, whatever follows.
        let mut c = HeadCheck::new(8 << 20);
        assert!(c.feed(b"PF\n64 32\n-1.0\n").is_ok());
        assert!(c.feed(&[0u8; 100_000]).is_ok());
        // Not an image this reads: left to the decoder.
        let mut c = HeadCheck::new(1);
        assert!(c.feed(&[7u8; 70_000]).is_ok());
    }
}
