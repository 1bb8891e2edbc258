//! What a submitted frame's pixels are before they are judged, as its rule
//! says (docs/frames.md#masks, docs/frames.md#frames-with-alpha): its alpha
//! channel composited over a background or ignored, and the regions its
//! masks leave out of every figure.

use super::Decoded;
use serde::Deserialize;

/// A rectangle of a frame, in pixels from its top-left corner, that no
/// figure sees: filled with black in the frame and in each positive
/// before the two are compared (as Playwright fills its masks), so what
/// differs there differs nowhere. The part outside the frame is ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mask {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl Mask {
    /// Whether pixel (`px`, `py`) is inside.
    pub fn covers(&self, px: u32, py: u32) -> bool {
        px >= self.x
            && py >= self.y
            && u64::from(px) < u64::from(self.x) + u64::from(self.width)
            && u64::from(py) < u64::from(self.y) + u64::from(self.height)
    }
}

/// The most masks a rule may hold.
pub const MAX_MASKS: usize = 64;

/// What a frame's alpha channel means to the judge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlphaRule {
    /// The colour composited over the rule's background (straight alpha,
    /// on the stored codes, as a browser draws the PNG on a page).
    #[default]
    Over,
    /// The alpha channel dropped.
    Ignore,
}

/// A colour written `"#rrggbb"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub struct Colour(pub [u8; 3]);

impl TryFrom<String> for Colour {
    type Error = String;
    fn try_from(text: String) -> Result<Colour, String> {
        let hex = text
            .strip_prefix('#')
            .filter(|h| h.len() == 6 && h.chars().all(|c| c.is_ascii_hexdigit()))
            .ok_or_else(|| format!("background {text:?}: expected \"#rrggbb\""))?;
        let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).unwrap_or(0);
        Ok(Colour([byte(0), byte(2), byte(4)]))
    }
}

/// How a frame no rule covers reads its alpha: over black.
pub const DEFAULT_ALPHA: crate::io::Alpha = crate::io::Alpha::Over([0, 0, 0]);

/// `d` with every pixel a mask covers black.
pub(super) fn masked(d: &Decoded, masks: &[Mask]) -> Decoded {
    fn fill<P: Copy>(img: &mut crate::image::Image<P>, masks: &[Mask], black: P) {
        let w = img.width.max(1);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let (x, y) = (
                (i as u64 % u64::from(w)) as u32,
                (i as u64 / u64::from(w)) as u32,
            );
            if masks.iter().any(|m| m.covers(x, y)) {
                *p = black;
            }
        }
    }
    let mut d = d.clone();
    match &mut d {
        Decoded::Frame(crate::image::Frame::Rgb8(img)) => fill(img, masks, [0; 3]),
        Decoded::Frame(crate::image::Frame::Pq16(img)) => fill(img, masks, [0; 3]),
        Decoded::Hdr(img) => fill(img, masks, [0.0; 3]),
    }
    d
}
