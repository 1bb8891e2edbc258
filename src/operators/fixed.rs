//! What the fixed curves share (`aces-narkowicz`, `aces-hill`, `agx`,
//! `pbr-neutral`, `hable`): no statistics, an exposure as their only
//! resolved value, and a curve applied to exposure × RGB.

use super::{Curve, Kind, Param, Range, Resolution, Value, Values};

/// The exposure every fixed curve takes: a gain on the linear input (1 is
/// the curve as its reference defines it).
pub(super) const EXPOSURE: Param = Param {
    name: "exposure",
    doc: "Gain on the linear input before the curve (1 = as the reference defines it)",
    kind: Kind::Number(Range::POSITIVE),
    default: Value::Number(1.0),
};

/// The one value a fixed curve resolves.
pub(super) const RESOLVED: &[&str] = &["exposure"];

/// A fixed curve with its exposure: `curve(exposure · c)`.
pub(super) fn resolution<C: Curve + 'static>(values: &Values, curve: C) -> Resolution {
    let exposure = values.num("exposure");
    Resolution {
        values: vec![("exposure", exposure)],
        curve: Box::new(Exposed { exposure, curve }),
    }
}

struct Exposed<C> {
    exposure: f64,
    curve: C,
}

impl<C: Curve> Curve for Exposed<C> {
    #[inline]
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        self.curve.pixel(c.map(|v| v * self.exposure))
    }
}

/// m·v, summed left to right as GLSL and WGSL write `m * v`.
#[inline]
pub(super) fn mul3(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    super::reinhard::mul3(m, v)
}

/// The row-major matrix as three vec4 columns of `OperatorConfig` (WGSL's
/// `mat3x3<f32>` in a uniform: three columns, each padded to 16 bytes).
pub(super) fn columns(m: &[[f64; 3]; 3]) -> [f32; 12] {
    let mut out = [0f32; 12];
    for col in 0..3 {
        for row in 0..3 {
            out[col * 4 + row] = m[row][col] as f32;
        }
    }
    out
}
