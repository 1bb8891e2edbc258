//! `hable`: John Hable's filmic curve from Uncharted 2 (GDC 2010;
//! docs/operators.md), per channel, with the constants and defaults of
//! colour-hdri's `tonemapping_operator_filmic`:
//! f(x) = (x(Ax + CB) + DE)/(x(Ax + B) + DF) − E/F, out = f(bias·x)/f(W).
//! Not clamped: above x = W/bias the output exceeds 1 (toward 1.1146 at the
//! defaults) and the display encoding clips it.

use super::fixed::{self, EXPOSURE};
use super::{Curve, Kind, Param, Range, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, Unmeasured};

/// `hable`.
pub struct Hable;

/// A constant of the curve: [1e-6, 1000], so that no product of two of them
/// with an f32 input leaves f64's range, and f32 holds each (a smaller one
/// would reach the GPU as 0).
const fn number(name: &'static str, doc: &'static str, default: f64) -> Param {
    Param {
        name,
        doc,
        kind: Kind::Number(Range::closed(1e-6, 1000.0)),
        default: Value::Number(default),
    }
}

const PARAMS: &[Param] = &[
    EXPOSURE,
    number("shoulder_strength", "Hable's A (shoulder strength)", 0.22),
    number("linear_strength", "Hable's B (linear strength)", 0.3),
    number("linear_angle", "Hable's C (linear angle)", 0.1),
    number("toe_strength", "Hable's D (toe strength)", 0.2),
    number("toe_numerator", "Hable's E (toe numerator)", 0.01),
    number("toe_denominator", "Hable's F (toe denominator)", 0.3),
    number(
        "exposure_bias",
        "Gain before the curve, after the exposure",
        2.0,
    ),
    number(
        "white_point",
        "Linear white W: the input mapped to 1 is W/exposure_bias",
        11.2,
    ),
];

/// The curve's six constants.
#[derive(Clone, Copy)]
struct Constants {
    a: f64,
    b: f64,
    c: f64,
    d: f64,
    e: f64,
    f: f64,
}

impl Constants {
    fn of(v: &Values) -> Constants {
        Constants {
            a: v.num("shoulder_strength"),
            b: v.num("linear_strength"),
            c: v.num("linear_angle"),
            d: v.num("toe_strength"),
            e: v.num("toe_numerator"),
            f: v.num("toe_denominator"),
        }
    }

    /// f(x), in colour-hdri's order of operations.
    #[inline]
    fn f(&self, x: f64) -> f64 {
        let Constants { a, b, c, d, e, f } = *self;
        ((x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f)) - e / f
    }
}

struct Fit {
    k: Constants,
    bias: f64,
    /// 1/f(W).
    white_scale: f64,
}

impl Curve for Fit {
    #[inline]
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        c.map(|x| self.k.f(self.bias * x) * self.white_scale)
    }
}

impl ToneOperator for Hable {
    fn name(&self) -> &'static str {
        "hable"
    }
    fn summary(&self) -> &'static str {
        "Hable's Uncharted 2 filmic curve, as colour-hdri's tonemapping_operator_filmic"
    }
    fn params(&self) -> &'static [Param] {
        PARAMS
    }
    fn check(&self, v: &Values) -> Result<(), String> {
        let k = Constants::of(v);
        // A NaN too: constants so small that their products underflow.
        let at_zero = k.f(0.0);
        if at_zero.is_nan() || at_zero.abs() > 1e-12 {
            return Err(format!(
                "toe_numerator, toe_denominator, toe_strength: the curve must map 0 to 0 (it maps it to {at_zero})"
            ));
        }
        let w = k.f(v.num("white_point"));
        if !(w.is_finite() && w > 0.0) {
            return Err(format!(
                "white_point: the curve at the white point is {w}, not > 0; raise white_point or change the curve's constants"
            ));
        }
        Ok(())
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        fixed::RESOLVED
    }
    fn resolve(&self, v: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        let k = Constants::of(v);
        Ok(fixed::resolution(
            v,
            Fit {
                k,
                bias: v.num("exposure_bias"),
                white_scale: 1.0 / k.f(v.num("white_point")),
            },
        ))
    }
    fn wgsl(&self) -> &'static str {
        include_str!("../../shaders/operators/hable.wgsl")
    }
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord::FIRST)
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        vec![v.num("exposure") as f32]
    }
    /// The curve's constants as override constants, which llvmpipe folds
    /// into the code (as uniforms they made the stage 1.70× the floor at
    /// 1080p, 2026-11-26).
    fn gpu_constants(&self, v: &Values) -> Vec<(&'static str, f64)> {
        let k = Constants::of(v);
        vec![
            ("HABLE_A", k.a),
            ("HABLE_B", k.b),
            ("HABLE_C", k.c),
            ("HABLE_D", k.d),
            ("HABLE_E", k.e),
            ("HABLE_F", k.f),
            ("HABLE_BIAS", v.num("exposure_bias")),
            ("HABLE_WHITE_SCALE", 1.0 / k.f(v.num("white_point"))),
            // f(x) − E/F without the cancellation, for the shader:
            // x·(P·x + Q) / (F·(x·(A·x + B) + D·F)), P = A(F − E), Q = B(C·F − E).
            ("HABLE_P", k.a * (k.f - k.e)),
            ("HABLE_Q", k.b * (k.c * k.f - k.e)),
        ]
    }
}
