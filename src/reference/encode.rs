//! `encode`: display encoding to 8 bits.

use crate::image::{LinearImage, Rgb8Image};
use crate::scene::Encoding;

/// The sRGB OETF (IEC 61966-2-1), for v in [0, 1].
pub fn srgb_oetf(v: f64) -> f64 {
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * libm::pow(v, 1.0 / 2.4) - 0.055
    }
}

/// One channel: clamp to [0, 1] (NaN → 0), apply the OETF, then round half up
/// to 8 bits: q = ⌊255·e + 0.5⌋.
pub fn encode_channel(v: f64, encoding: Encoding) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let e = match encoding {
        Encoding::Srgb => srgb_oetf(v),
        Encoding::Gamma(g) => libm::pow(v, 1.0 / g.get()),
    };
    (255.0 * e + 0.5).floor().clamp(0.0, 255.0) as u8
}

pub fn encode(img: &LinearImage, encoding: Encoding) -> Rgb8Image {
    img.map(|p| p.map(|v| encode_channel(v, encoding)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Positive;

    #[test]
    fn end_points_rounding_and_non_finite() {
        for e in [
            Encoding::Srgb,
            Encoding::Gamma(Positive::try_from(2.2).unwrap()),
        ] {
            assert_eq!(encode_channel(0.0, e), 0);
            assert_eq!(encode_channel(1.0, e), 255);
            assert_eq!(encode_channel(7.0, e), 255);
            assert_eq!(encode_channel(-1.0, e), 0);
            assert_eq!(encode_channel(f64::NAN, e), 0);
            assert_eq!(encode_channel(f64::INFINITY, e), 255);
        }
        // sRGB 0.5 linear is 0.7354 encoded: 187.5 → rounds half up to 188.
        assert_eq!(encode_channel(0.5, Encoding::Srgb), 188);
        // γ = 1 is a plain scale: 0.5·255 = 127.5 → 128.
        assert_eq!(
            encode_channel(0.5, Encoding::Gamma(Positive::try_from(1.0).unwrap())),
            128
        );
    }
}
