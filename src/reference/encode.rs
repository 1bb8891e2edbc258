//! `encode`: display encoding to 8 bits, or to 16-bit PQ.

use crate::color::{bt709_to_bt2020, code16, pq_encode, Mat3};
use crate::image::{Frame, LinearImage, Rgb8Image};
use crate::operators::DisplayLevels;
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
        // PQ frames are 16-bit and absolute ([`PqEncoder`]); an 8-bit view
        // of one is the display-relative image under the sRGB transfer.
        Encoding::Srgb | Encoding::Pq => srgb_oetf(v),
        Encoding::Gamma(g) => libm::pow(v, 1.0 / g.get()),
    };
    (255.0 * e + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// [`encode_channel`] for one encoding without a `pow` per sample: the 255
/// linear values where the code steps up, found once by bisecting the f64
/// bit patterns of [0, 1] (ordered like the values they hold) with
/// `encode_channel` itself as the judge. A sample's code is the number of
/// steps at or below it, which is `encode_channel`'s code wherever that is
/// non-decreasing; the tests compare the two around every step and on
/// random samples, and the goldens (encoded this way) did not change.
pub struct Encoder {
    /// `steps[k - 1]`: the least value whose code is at least `k`.
    steps: [f64; 255],
}

impl Encoder {
    pub fn new(encoding: Encoding) -> Self {
        let mut steps = [0.0; 255];
        for (k, step) in (1u8..=255).zip(steps.iter_mut()) {
            // Codes: below `k` at `lo`, at least `k` at `hi` (1.0 is 255).
            let (mut lo, mut hi) = (0f64.to_bits(), 1f64.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if encode_channel(f64::from_bits(mid), encoding) >= k {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *step = f64::from_bits(hi);
        }
        Self { steps }
    }

    /// The code of `v` (NaN and v ≤ 0 are 0, v ≥ 1 is 255).
    pub fn channel(&self, v: f64) -> u8 {
        // At most 255 steps are at or below any value.
        self.steps.partition_point(|&t| t <= v) as u8
    }
}

pub fn encode(img: &LinearImage, encoding: Encoding) -> Rgb8Image {
    let encoder = Encoder::new(encoding);
    img.par_map(|p| p.map(|v| encoder.channel(v)))
}

/// A PQ frame's pixel (docs/display.md#pq-frames): the display-relative
/// BT.709 value on the display of `levels` ([`DisplayLevels::bt2020_nits`]),
/// SMPTE ST 2084's inverse EOTF, 16-bit full-range codes.
pub struct PqEncoder {
    levels: DisplayLevels,
    m: Mat3,
}

impl PqEncoder {
    pub fn new(levels: DisplayLevels) -> Self {
        Self {
            levels,
            m: bt709_to_bt2020(),
        }
    }

    /// The codes of one display-relative pixel.
    pub fn pixel(&self, c: [f64; 3]) -> [u16; 3] {
        self.levels
            .bt2020_nits(&self.m, c)
            .map(|v| code16(pq_encode(v)))
    }
}

/// `encode`'s frame of `img`: 8-bit, or 16-bit PQ for the display of
/// `levels` (which a PQ encoding needs; `None` is refused with the reason).
pub fn encode_frame(
    img: &LinearImage,
    encoding: Encoding,
    levels: Option<DisplayLevels>,
) -> Result<Frame, &'static str> {
    match encoding {
        Encoding::Pq => {
            let pq = PqEncoder::new(levels.ok_or(
                "the display levels a PQ frame needs (an operator that maps onto a display of known peak: bt2390)",
            )?);
            Ok(Frame::Pq16(img.par_map(|p| pq.pixel(p))))
        }
        _ => Ok(Frame::Rgb8(encode(img, encoding))),
    }
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

    fn encodings() -> Vec<Encoding> {
        let mut all = vec![Encoding::Srgb];
        for g in [1.0, 1.8, 2.2, 2.4, 0.45, 7.3] {
            all.push(Encoding::Gamma(Positive::try_from(g).unwrap()));
        }
        all
    }

    /// The steps agree with the `pow` they replace: at the ends, for
    /// non-finite samples, 4,096 representable values either side of every
    /// step, and on 200,000 random samples per encoding.
    #[test]
    fn the_encoder_gives_encode_channels_codes() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for e in encodings() {
            let enc = Encoder::new(e);
            for v in [
                0.0,
                -0.0,
                1.0,
                -1.0,
                7.0,
                f64::MIN_POSITIVE,
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ] {
                assert_eq!(enc.channel(v), encode_channel(v, e), "{e:?} at {v}");
            }
            for (k, &step) in enc.steps.iter().enumerate() {
                assert!(step > 0.0 && step <= 1.0, "{e:?}: step {} at {step}", k + 1);
                let bits = step.to_bits();
                for b in bits.saturating_sub(4096)..=bits + 4096 {
                    let v = f64::from_bits(b);
                    assert_eq!(enc.channel(v), encode_channel(v, e), "{e:?} at {v:e}");
                }
            }
            for _ in 0..200_000 {
                // Uniform in [0, 1.1] and log-uniform down to 1e-12.
                let u = random() * 1.1;
                let l = 10f64.powf(-12.0 * random());
                for v in [u, l] {
                    assert_eq!(enc.channel(v), encode_channel(v, e), "{e:?} at {v:e}");
                }
            }
        }
    }
}
