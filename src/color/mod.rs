//! Colour constants and conversions, kept in one place (docs/statistics.md,
//! docs/operators.md, docs/display.md).

/// BT.709 / sRGB luminance weights (docs/statistics.md).
pub const BT709: [f64; 3] = [0.2126, 0.7152, 0.0722];
/// pfstools' weights, from its sRGB→XYZ matrix (the `reinhard02` preset).
pub const PFS: [f64; 3] = [0.212656, 0.715158, 0.072186];
/// The saturation weights of the image-processing lecture (docs/bibliography.md).
pub const GRADE_SATURATION_WEIGHTS: [f64; 3] = [0.2125, 0.7154, 0.0721];

/// The smallest positive value both renderers divide by: f32's smallest
/// normal. Below it an adapter may flush a value to 0 in arithmetic
/// (Vulkan allows it; NVIDIA does) while a comparison still sees it as
/// positive, so `y > 0 ? c / y : 0` can divide by a flushed 0 and write
/// NaN. Both renderers treat a luminance or divisor under this bound as 0
/// (the CPU reference in f64 as well, so the two agree on every adapter),
/// and an f32 subnormal input therefore takes the same branch on llvmpipe,
/// which keeps subnormals, as on an adapter that flushes them. The mirror
/// in the shaders is `SMALLEST_NORMAL` in `shaders/shared/colour.wgsl`.
pub const SMALLEST_NORMAL: f64 = f32::MIN_POSITIVE as f64;

/// Y of a linear RGB triple with the given weights.
#[inline]
pub fn luminance_with(rgb: [f64; 3], w: [f64; 3]) -> f64 {
    w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2]
}

/// Y of a linear RGB triple with BT.709 weights.
#[inline]
pub fn luminance(rgb: [f64; 3]) -> f64 {
    luminance_with(rgb, BT709)
}

mod hdr;
mod primaries;

pub use hdr::{
    code16, hlg_gamma, hlg_inverse_eotf, hlg_oetf, pq_decode, pq_encode, BT2100_LUMINANCE, PQ_PEAK,
};
pub use primaries::{apply, bt709_to_bt2020, inverse, mul, npm, Mat3, BT2020_XY, BT709_XY, D65_XY};
