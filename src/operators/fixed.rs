//! What the fixed curves share (`aces-narkowicz`, `aces-hill`, `agx`,
//! `pbr-neutral`, `hable`): no statistics, an exposure as their only
//! resolved value, and a curve applied to exposure × RGB.

use super::{Curve, Kind, Param, Range, Resolution, Value, Values};

/// The exposure every fixed curve takes: a gain on the linear input (1 is
/// the curve as its reference defines it).
pub(super) const EXPOSURE: Param = Param {
    name: "exposure",
    doc: "Gain on the linear input before the curve (1 = as the reference defines it)",
    kind: Kind::Number(Range::GAIN),
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

/// The row-major matrix as a WGSL constant, `const NAME = mat3x3<f32>(…);`
/// (column by column, each value the f32 nearest the f64, printed so that
/// it reads back exactly). A constant rather than a uniform: llvmpipe folds
/// it into the code, where a uniform matrix made AgX's `tonemap` stage take
/// half again as long (57 ms against 38 ms with three of its four matrices
/// removed, 1080p, 2026-11-26).
pub(super) fn wgsl_mat3(name: &str, m: &[[f64; 3]; 3]) -> String {
    let mut values = Vec::with_capacity(9);
    for col in 0..3 {
        for row in m {
            values.push(format!("{:?}", row[col] as f32));
        }
    }
    format!("const {name} = mat3x3<f32>({});\n", values.join(", "))
}

/// An operator's WGSL with constants written by the host first: made once,
/// kept for the process (a module is `'static` text).
pub(super) fn with_constants(
    cell: &'static std::sync::OnceLock<String>,
    constants: impl FnOnce() -> String,
    body: &'static str,
) -> &'static str {
    cell.get_or_init(|| format!("{}{body}", constants()))
}
