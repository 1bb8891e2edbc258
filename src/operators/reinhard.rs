//! What the three Reinhard 2002 global operators share (docs/operators.md):
//! the curve Ld = L·(1 + L/Lwhite²)/(1 + L) with L = scale·Y, the two ways
//! of putting tone-mapped luminance back into colour, the automatic key,
//! and the GPU side's `OperatorConfig` (shaders/shared/reinhard.wgsl).

use super::{Curve, Kind, Param, Range, Resolution, Value, Values};
use crate::color::{luminance_with, BT709, PFS, SMALLEST_NORMAL};

/// Log offset δ of the plain and weighted log-averages (the image-processing
/// lecture, docs/bibliography.md).
pub const DELTA: f64 = 1e-4;
/// pfstools' δ (the `reinhard02` preset).
pub const DELTA_PFS: f64 = 1e-5;
/// The key every operator with a fixed key defaults to.
pub const DEFAULT_KEY: f64 = 0.18;
/// `reinhard-global`'s default white fraction.
pub const DEFAULT_WHITE_FRACTION: f64 = 0.8;

/// How tone-mapped luminance is put back into colour; the two agree to
/// rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColourPath {
    /// Scale RGB by Ld/Y (as the modified Reinhard for training simulators
    /// does, docs/bibliography.md): cheapest, keeps hue exactly.
    #[default]
    Ratio,
    /// Round-trip through CIE xyY with the sRGB/XYZ matrices (as in
    /// Reinhard's global operator in real time and the image-processing
    /// lecture, both in docs/bibliography.md).
    Xyy,
}

impl ColourPath {
    /// The colour path a `colour` word names.
    pub fn of(values: &Values) -> ColourPath {
        match values.word("colour") {
            "xyy" => ColourPath::Xyy,
            _ => ColourPath::Ratio,
        }
    }
}

/// The key's range: [1e-6, 100]. Real keys are 0.045-0.72 (Reinhard et al.
/// 2002); with the adaptation luminance at least δ, the scale key/adaptation
/// stays under 1e6, so scale·Y stays finite in f32 for inputs up to 1e30
/// under any rewrite a driver may apply (docs/stress.md#range-safe-arithmetic).
pub(super) const KEY_RANGE: Range = Range::closed(1e-6, 100.0);

/// A fixed adaptation luminance's range: [δ, 1e6]. A measured
/// log-average is never below δ = 1e-4 (it is exp of a mean of ln(δ + Y)).
pub(super) const LOG_AVERAGE_RANGE: Range = Range::closed(DELTA, 1e6);

/// The key a (every Reinhard variant's; `reinhard-auto-key`'s also takes
/// "auto").
pub(super) const KEY: Param = Param {
    name: "key",
    doc: "Key a: the display value of the adaptation luminance",
    kind: Kind::Number(KEY_RANGE),
    default: Value::Number(DEFAULT_KEY),
};

/// The colour path.
pub(super) const COLOUR: Param = Param {
    name: "colour",
    doc: "ratio (scale RGB by Ld/Y) or xyy (round trip through CIE xyY)",
    kind: Kind::Word(&["ratio", "xyy"]),
    default: Value::Word("ratio"),
};

/// A fixed adaptation luminance instead of the measured log-average.
pub(super) const LOG_AVERAGE: Param = Param {
    name: "log_average",
    doc: "Fixed adaptation luminance instead of the measured log-average",
    kind: Kind::Number(LOG_AVERAGE_RANGE),
    default: Value::Unset,
};

/// What the Reinhard variants resolve per frame, in the order of the GPU's
/// vec4 (shaders/shared/reinhard.wgsl).
pub(super) const RESOLVED: &[&str] = &["key", "log_average", "scale", "white"];

/// `reinhard-auto-key`'s automatic key (from the modified Reinhard for
/// training simulators, docs/bibliography.md):
/// a = 0.18·2^(2(B − A)/(A + B)), A = Lmax − Lavg, B = Lavg − Lmin.
/// A + B = Lmax − Lmin; for a uniform frame it is 0 and the key falls back to
/// 0.18. δ can put Lavg a hair outside [Lmin, Lmax], so the ratio is clamped
/// to [−1, 1], its range for any Lavg inside.
pub fn automatic_key(min: f64, log_average: f64, max: f64) -> f64 {
    let a = max - log_average;
    let b = log_average - min;
    let span = max - min;
    if !(span.is_finite() && span >= SMALLEST_NORMAL) {
        return 0.18;
    }
    let ratio = ((b - a) / span).clamp(-1.0, 1.0);
    0.18 * libm::exp2(2.0 * ratio)
}

/// The display luminance of scaled luminance L. Written as L/(1+L)·(1+L/W)
/// rather than L(1+L/W)/(1+L) so that a huge L does not overflow to ∞/∞.
///
/// The burn term is clamped as the GPU's must be to stay within f32 under
/// any rewrite a driver may apply (shaders/shared/reinhard.wgsl,
/// docs/stress.md#range-safe-arithmetic): Lwhite to [2^-63, 2^63] (W to
/// [2^-126, 2^126]), and L to at most 2^40·Lwhite inside L/W. Neither
/// changes a displayed pixel: a pixel at L ≥ Lwhite burns to white either
/// way, and under Lwhite = 2^-63 only pixels darker than that are left.
#[inline]
pub fn reinhard_curve(l: f64, white_sq: f64) -> f64 {
    if white_sq == f64::INFINITY {
        return l / (1.0 + l);
    }
    let w_sq = white_sq.clamp(WHITE_SQ_MIN, WHITE_SQ_MAX);
    // l > 2^40·Lwhite, without a square root per pixel.
    let lc = if l * l > w_sq * BURN_SPAN_SQ {
        w_sq.sqrt() * BURN_SPAN
    } else {
        l
    };
    l / (1.0 + l) * (1.0 + lc / w_sq)
}

/// The range the curve clamps Lwhite to, 2^-63 to 2^63 (reports say when
/// a frame's white was outside it).
pub const WHITE_CLAMP: (f64, f64) = (1.0842021724855044e-19, 9.223372036854776e18);

/// 2^-126 and 2^126: Lwhite² for Lwhite = 2^-63 and 2^63.
const WHITE_SQ_MIN: f64 = 1.1754943508222875e-38;
const WHITE_SQ_MAX: f64 = 8.507059173023462e37;
/// 2^40 and its square.
const BURN_SPAN: f64 = 1_099_511_627_776.0;
const BURN_SPAN_SQ: f64 = BURN_SPAN * BURN_SPAN;

/// `v` when it is a finite positive number, else +∞ (never burn).
pub(super) fn finite_positive_or_inf(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        f64::INFINITY
    }
}

/// RGB→XYZ whose Y row is exactly `weights` (sRGB primaries, D65), so the two
/// colour paths see the same Y.
pub fn rgb_to_xyz(weights: [f64; 3]) -> [[f64; 3]; 3] {
    if weights == PFS {
        // pfstools' own matrix (src/pfs/colorspace.cpp).
        [
            [0.412424, 0.357579, 0.180464],
            weights,
            [0.019332, 0.119193, 0.950444],
        ]
    } else {
        [[0.4124, 0.3576, 0.1805], weights, [0.0193, 0.1192, 0.9505]]
    }
}

/// The exact f64 inverse of a 3×3 matrix (cofactors), so the xyY round trip
/// returns the input to rounding.
pub fn invert3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let det = m[0][0] * c(1, 2, 1, 2) - m[0][1] * c(1, 2, 0, 2) + m[0][2] * c(1, 2, 0, 1);
    let inv = [
        [c(1, 2, 1, 2), -c(0, 2, 1, 2), c(0, 1, 1, 2)],
        [-c(1, 2, 0, 2), c(0, 2, 0, 2), -c(0, 1, 0, 2)],
        [c(1, 2, 0, 1), -c(0, 2, 0, 1), c(0, 1, 0, 1)],
    ];
    inv.map(|row| row.map(|v| v / det))
}

/// m·v.
pub fn mul3(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// One frame's Reinhard curve: Ld = L·(1 + L/white_sq)/(1 + L), L = scale·Y,
/// put back into colour by `colour`.
pub struct ReinhardCurve {
    /// a / log_average.
    pub scale: f64,
    /// The denominator of L/… in the curve: Lwhite² (`reinhard-auto-key`,
    /// `reinhard02`) or w²·Lmax (`reinhard-global`). +∞ disables burning
    /// (Ld = L/(1 + L)).
    pub white_sq: f64,
    /// Luminance weights (also the Y row of the XYZ matrix used by `xyy`).
    pub weights: [f64; 3],
    /// The colour path.
    pub colour: ColourPath,
    to_xyz: [[f64; 3]; 3],
    to_rgb: [[f64; 3]; 3],
}

impl ReinhardCurve {
    /// The curve with these parameters.
    pub fn new(scale: f64, white_sq: f64, weights: [f64; 3], colour: ColourPath) -> ReinhardCurve {
        let to_xyz = rgb_to_xyz(weights);
        ReinhardCurve {
            scale,
            white_sq,
            weights,
            colour,
            to_xyz,
            to_rgb: invert3(to_xyz),
        }
    }
}

impl Curve for ReinhardCurve {
    /// Y ≤ 0 has no chromaticity and maps to black (never NaN).
    #[inline]
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        match self.colour {
            ColourPath::Ratio => {
                let y = luminance_with(c, self.weights);
                if y.is_nan() || y < SMALLEST_NORMAL {
                    return [0.0; 3];
                }
                let ratio = reinhard_curve(self.scale * y, self.white_sq) / y;
                [c[0] * ratio, c[1] * ratio, c[2] * ratio]
            }
            ColourPath::Xyy => {
                let xyz = mul3(&self.to_xyz, c);
                let sum = xyz[0] + xyz[1] + xyz[2];
                if xyz[1].is_nan()
                    || xyz[1] < SMALLEST_NORMAL
                    || sum.is_nan()
                    || sum < SMALLEST_NORMAL
                {
                    return [0.0; 3];
                }
                let (x, y) = (xyz[0] / sum, xyz[1] / sum);
                let ld = reinhard_curve(self.scale * xyz[1], self.white_sq);
                let out = [x * ld / y, ld, (1.0 - x - y) * ld / y];
                mul3(&self.to_rgb, out)
            }
        }
    }
}

/// A resolved Reinhard variant: its report (key, log_average, scale, white)
/// and curve.
pub(super) fn resolution(
    key: f64,
    log_average: f64,
    white_sq: f64,
    weights: [f64; 3],
    values: &Values,
) -> Resolution {
    let scale = key / log_average;
    let mut report = vec![("key", key), ("log_average", log_average), ("scale", scale)];
    // No white point (+∞: never burns) is reported as none.
    if white_sq.is_finite() {
        report.push(("white", white_sq.sqrt()));
    }
    Resolution {
        values: report,
        curve: Box::new(ReinhardCurve::new(
            scale,
            white_sq,
            weights,
            ColourPath::of(values),
        )),
    }
}

/// The GPU's resolved vec4 (key, adaptation, scale, white) as a report;
/// white <= 0 or +∞ means "never burn", left out like the reference's.
pub(super) fn gpu_resolved(slots: [f32; 4]) -> Vec<(&'static str, f64)> {
    let white = slots[3] as f64;
    let mut values = vec![
        ("key", slots[0] as f64),
        ("log_average", slots[1] as f64),
        ("scale", slots[2] as f64),
    ];
    if white > 0.0 && white != f64::INFINITY {
        values.push(("white", white));
    }
    values
}

/// The numbers the Reinhard shaders read (shaders/shared/reinhard.wgsl's
/// `OperatorConfig`).
pub(super) struct GpuNumbers {
    pub weights: [f64; 3],
    pub key: f64,
    pub white_fraction: f64,
    /// Absolute Lwhite; 0 = the maximum scaled luminance.
    pub white: f64,
    /// 0 = measured.
    pub fixed_log_average: f64,
    /// 0 = measured.
    pub fixed_max: f64,
}

impl GpuNumbers {
    /// `OperatorConfig`: the weights and six matrix rows as vec4s, then five
    /// scalars and three pads (36 f32).
    pub fn config(&self) -> Vec<f32> {
        let to_xyz = rgb_to_xyz(self.weights);
        let to_rgb = invert3(to_xyz);
        let mut c = vec![0f32; 36];
        let row = |c: &mut [f32], at: usize, v: [f64; 3]| {
            c[at] = v[0] as f32;
            c[at + 1] = v[1] as f32;
            c[at + 2] = v[2] as f32;
        };
        row(&mut c, 0, self.weights);
        for i in 0..3 {
            row(&mut c, 4 + 4 * i, to_xyz[i]);
            row(&mut c, 16 + 4 * i, to_rgb[i]);
        }
        c[28] = self.key as f32;
        c[29] = self.white_fraction as f32;
        c[30] = self.white as f32;
        c[31] = self.fixed_log_average as f32;
        c[32] = self.fixed_max as f32;
        c
    }
}

/// The colour path as the shaders' `COLOUR` override.
pub(super) fn colour_constant(values: &Values) -> (&'static str, f64) {
    (
        "COLOUR",
        (ColourPath::of(values) == ColourPath::Xyy) as u32 as f64,
    )
}

/// BT.709 or pfstools' weights.
pub(super) fn weights(pfs: bool) -> [f64; 3] {
    if pfs {
        PFS
    } else {
        BT709
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(colour: ColourPath) -> ReinhardCurve {
        ReinhardCurve::new(0.36, 4.0, BT709, colour)
    }

    #[test]
    fn colour_paths_agree_to_rounding() {
        let (pr, px) = (curve(ColourPath::Ratio), curve(ColourPath::Xyy));
        for c in [
            [1.0, 0.5, 0.25],
            [100.0, 3.0, 0.01],
            [0.001, 0.002, 0.0005],
            [5.0, 5.0, 5.0],
        ] {
            let a = pr.pixel(c);
            let b = px.pixel(c);
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-14 * a[k].abs().max(1.0),
                    "{c:?}: {a:?} vs {b:?}"
                );
            }
        }
    }

    #[test]
    fn zero_luminance_gives_black_not_nan() {
        for colour in [ColourPath::Ratio, ColourPath::Xyy] {
            assert_eq!(curve(colour).pixel([0.0; 3]), [0.0; 3]);
        }
    }

    #[test]
    fn curve_reaches_one_at_white_and_survives_huge_input() {
        // Ld(Lwhite) = 1 for the Reinhard curve with white_sq = Lwhite².
        assert!((reinhard_curve(2.0, 4.0) - 1.0).abs() < 1e-15);
        assert!(reinhard_curve(1e300, f64::INFINITY).is_finite());
    }

    #[test]
    fn automatic_key_matches_its_paper_and_handles_uniform_frames() {
        // Lavg at the midpoint of [min, max] gives A = B and a = 0.18.
        assert!((automatic_key(1.0, 2.0, 3.0) - 0.18).abs() < 1e-15);
        // Dark frame (Lavg near Lmin): B − A < 0 lowers the key.
        let a = automatic_key(0.0, 1.0, 9.0);
        assert!((a - 0.18 * 2f64.powf(2.0 * (1.0 - 8.0) / 9.0)).abs() < 1e-15);
        assert_eq!(automatic_key(2.0, 2.0, 2.0), 0.18);
    }
}
