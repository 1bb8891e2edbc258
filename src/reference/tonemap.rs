//! `tonemap`: the global Reinhard 2002 family (docs/operators.md) and both
//! colour paths.

use crate::color::{luminance_with, BT709, PFS, SMALLEST_NORMAL};
use crate::image::LinearImage;
use crate::plan::PlanError;
use crate::reference::luminance_stats::LuminanceStats;
use crate::scene::{ColourPath, Key, Operator, Positive};
use rayon::prelude::*;
use serde::Serialize;

/// Log offset δ of the plain and weighted log-averages (the image-processing
/// lecture, docs/bibliography.md).
pub const DELTA: f64 = 1e-4;
/// pfstools' δ (the `reinhard02` preset).
pub const DELTA_PFS: f64 = 1e-5;

/// Everything the per-pixel operator needs, resolved from the operator and the
/// frame's statistics. Every variant reduces to one curve,
/// Ld = L·(1 + L/white_sq)/(1 + L) with L = scale·Y, which is what the shader
/// evaluates too.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ToneParams {
    /// The key a (fixed or automatic).
    pub key: f64,
    /// The adaptation luminance the key is relative to.
    pub log_average: f64,
    /// a / log_average.
    pub scale: f64,
    /// The denominator of L/… in the curve: Lwhite² (`reinhard-auto-key`,
    /// `reinhard02`) or w²·Lmax (`reinhard-global`). +∞ disables burning
    /// (Ld = L/(1 + L)).
    pub white_sq: f64,
    /// Luminance weights (also the Y row of the XYZ matrix used by `xyy`).
    pub weights: [f64; 3],
    pub colour: ColourPath,
}

/// The luminance weights and log offset an operator uses.
pub fn operator_constants(op: &Operator) -> ([f64; 3], f64) {
    match op {
        Operator::Reinhard02 {
            pfs_compatible: true,
            ..
        } => (PFS, DELTA_PFS),
        _ => (BT709, DELTA),
    }
}

fn finite_positive_or_inf(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        f64::INFINITY
    }
}

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

/// Resolves the operator's parameters for one frame. Statistics the plan did
/// not measure must be fixed in the operator (the plan guarantees it; a plan
/// that does not is a [`PlanError`]).
pub fn resolve(op: &Operator, stats: &LuminanceStats) -> Result<ToneParams, PlanError> {
    let (weights, _) = operator_constants(op);
    // A measured statistic, unless the operator fixes it.
    let measured = |v: Option<f64>| v.ok_or(PlanError::order("tonemap", "luminance_stats"));
    let fixed_or =
        |fixed: &Option<Positive>, v: Option<f64>| measured(fixed.map(|f| f.get()).or(v));
    let (key, log_average, white_sq) = match op {
        Operator::ReinhardGlobal {
            key,
            white_fraction,
            log_average,
            max_luminance,
            ..
        } => {
            let lavg = fixed_or(log_average, stats.log_average)?;
            let lmax = fixed_or(max_luminance, stats.max)?;
            let w = white_fraction.get();
            (key.get(), lavg, finite_positive_or_inf(w * w * lmax))
        }
        Operator::ReinhardAutoKey { key, .. } => {
            let lavg = measured(stats.weighted_log_average)?;
            let lmax = measured(stats.max)?;
            let a = match key {
                Key::Fixed(k) => k.get(),
                Key::Auto => automatic_key(measured(stats.min)?, lavg, lmax),
            };
            let white = a * lmax / lavg;
            (a, lavg, finite_positive_or_inf(white * white))
        }
        Operator::Reinhard02 {
            key,
            white,
            log_average,
            ..
        } => {
            let lavg = fixed_or(log_average, stats.log_average)?;
            let a = key.get();
            let white = match white {
                Some(w) => w.get(),
                None => a * measured(stats.max)? / lavg,
            };
            (a, lavg, finite_positive_or_inf(white * white))
        }
    };
    Ok(ToneParams {
        key,
        log_average,
        scale: key / log_average,
        white_sq,
        weights,
        colour: op.colour(),
    })
}

/// The display luminance of scaled luminance L. Written as L/(1+L)·(1+L/W)
/// rather than L(1+L/W)/(1+L) so that a huge L does not overflow to ∞/∞.
#[inline]
pub fn reinhard_curve(l: f64, white_sq: f64) -> f64 {
    l / (1.0 + l) * (1.0 + l / white_sq)
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

fn mul3(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// Tone-maps one pixel. Y ≤ 0 has no chromaticity and maps to black (never NaN).
#[inline]
pub fn tonemap_pixel(
    c: [f64; 3],
    p: &ToneParams,
    to_xyz: &[[f64; 3]; 3],
    to_rgb: &[[f64; 3]; 3],
) -> [f64; 3] {
    match p.colour {
        ColourPath::Ratio => {
            let y = luminance_with(c, p.weights);
            if y.is_nan() || y < SMALLEST_NORMAL {
                return [0.0; 3];
            }
            let ratio = reinhard_curve(p.scale * y, p.white_sq) / y;
            [c[0] * ratio, c[1] * ratio, c[2] * ratio]
        }
        ColourPath::Xyy => {
            let xyz = mul3(to_xyz, c);
            let sum = xyz[0] + xyz[1] + xyz[2];
            if xyz[1].is_nan() || xyz[1] < SMALLEST_NORMAL || sum.is_nan() || sum < SMALLEST_NORMAL
            {
                return [0.0; 3];
            }
            let (x, y) = (xyz[0] / sum, xyz[1] / sum);
            let ld = reinhard_curve(p.scale * xyz[1], p.white_sq);
            let out = [x * ld / y, ld, (1.0 - x - y) * ld / y];
            mul3(to_rgb, out)
        }
    }
}

/// Tone-maps a linear HDR frame.
pub fn tonemap(img: &LinearImage, p: &ToneParams) -> LinearImage {
    tonemap_into(img.clone(), p)
}

/// [`tonemap`] in the input's own buffer.
pub fn tonemap_into(mut img: LinearImage, p: &ToneParams) -> LinearImage {
    let to_xyz = rgb_to_xyz(p.weights);
    let to_rgb = invert3(to_xyz);
    img.pixels
        .par_iter_mut()
        .for_each(|c| *c = tonemap_pixel(*c, p, &to_xyz, &to_rgb));
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Positive;

    fn params(colour: ColourPath) -> ToneParams {
        ToneParams {
            key: 0.18,
            log_average: 0.5,
            scale: 0.36,
            white_sq: 4.0,
            weights: BT709,
            colour,
        }
    }

    #[test]
    fn colour_paths_agree_to_rounding() {
        let pr = params(ColourPath::Ratio);
        let px = params(ColourPath::Xyy);
        let (m, mi) = (rgb_to_xyz(BT709), invert3(rgb_to_xyz(BT709)));
        for c in [
            [1.0, 0.5, 0.25],
            [100.0, 3.0, 0.01],
            [0.001, 0.002, 0.0005],
            [5.0, 5.0, 5.0],
        ] {
            let a = tonemap_pixel(c, &pr, &m, &mi);
            let b = tonemap_pixel(c, &px, &m, &mi);
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
        let (m, mi) = (rgb_to_xyz(BT709), invert3(rgb_to_xyz(BT709)));
        for colour in [ColourPath::Ratio, ColourPath::Xyy] {
            assert_eq!(tonemap_pixel([0.0; 3], &params(colour), &m, &mi), [0.0; 3]);
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

    #[test]
    fn resolve_builds_each_variant() {
        let stats = LuminanceStats {
            log_average: Some(0.5),
            weighted_log_average: Some(0.8),
            min: Some(0.01),
            max: Some(100.0),
            weight_sum: Some(1.0),
        };
        let global = Operator::default();
        let p = resolve(&global, &stats).unwrap();
        assert!((p.white_sq - 0.64 * 100.0).abs() < 1e-12 && (p.scale - 0.36).abs() < 1e-15);
        let auto_key = Operator::ReinhardAutoKey {
            key: Key::Auto,
            colour: ColourPath::Ratio,
        };
        let p = resolve(&auto_key, &stats).unwrap();
        let a = automatic_key(0.01, 0.8, 100.0);
        assert!((p.key - a).abs() < 1e-15 && (p.white_sq - (a * 100.0 / 0.8).powi(2)).abs() < 1e-9);
        let r02 = Operator::Reinhard02 {
            key: Positive::try_from(0.18).unwrap(),
            white: Some(Positive::try_from(3.0).unwrap()),
            log_average: None,
            colour: ColourPath::Ratio,
            pfs_compatible: false,
        };
        assert_eq!(resolve(&r02, &stats).unwrap().white_sq, 9.0);
    }

    #[test]
    fn black_frame_does_not_divide_by_zero() {
        let stats = LuminanceStats {
            log_average: Some(1e-4),
            max: Some(0.0),
            ..Default::default()
        };
        let p = resolve(&Operator::default(), &stats).unwrap();
        assert_eq!(p.white_sq, f64::INFINITY);
    }
}
