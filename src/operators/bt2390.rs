//! `bt2390`: the EETF of ITU-R BT.2390 (the Hermite-spline roll-off of a
//! mastering display's range onto a target display's, in the PQ signal
//! domain; docs/operators.md), as libplacebo's `bt2390` tone-mapping
//! function computes it, applied to each channel's PQ signal.
//!
//! The input is scene-linear: `exposure × reference_white × c` is taken as
//! cd/m², clipped to the mastering range [`source_black`, `source_peak`].
//! The result, in cd/m² within [`target_black`, `target_peak`], is handed to
//! the display as `(L − target_black) / (target_peak − target_black)`: 0 is
//! the target display's black and 1 its peak, so the sRGB encoding (or a
//! BT.1886 display) reproduces it and black stays black.

use super::fixed::{self, EXPOSURE};
use super::{Curve, DisplayLevels, Kind, Param, Range, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, Unmeasured};

/// `bt2390`.
pub struct Bt2390;

use crate::color::{pq_decode, PQ_PEAK};

/// ST 2084's inverse EOTF as libplacebo has it: 0 cd/m² (and below) is
/// signal 0, where the formula gives c1^m2 = 7.3e-7 (the level below which
/// every signal decodes to 0); above 10000 cd/m², 1.
pub fn pq_encode(nits: f64) -> f64 {
    if nits <= 0.0 {
        return 0.0;
    }
    crate::color::pq_encode(nits.min(PQ_PEAK))
}

/// A level in cd/m² up to PQ's 10000. A black may be 0; a peak or a
/// reference white is at least 1e-3 cd/m² (a thousandth of a candela:
/// darker than any display's peak), below which the EETF's f32 arithmetic
/// on a GPU that flushes subnormals no longer gives the reference's codes
/// (docs/stress.md#range-safe-arithmetic).
const fn nits(name: &'static str, doc: &'static str, positive: bool, default: f64) -> Param {
    Param {
        name,
        doc,
        kind: Kind::Number(Range::closed(if positive { 1e-3 } else { 0.0 }, PQ_PEAK)),
        default: Value::Number(default),
    }
}

const PARAMS: &[Param] = &[
    EXPOSURE,
    nits(
        "reference_white",
        "cd/m² an input of 1 stands for (after the exposure); 203 is BT.2408's HDR reference white",
        true,
        203.0,
    ),
    nits(
        "source_peak",
        "The mastering display's peak, cd/m²: brighter input is clipped to it",
        true,
        1000.0,
    ),
    nits(
        "source_black",
        "The mastering display's black, cd/m²",
        false,
        0.0,
    ),
    nits(
        "target_peak",
        "The target display's peak, cd/m² (100 for SDR)",
        true,
        100.0,
    ),
    nits(
        "target_black",
        "The target display's black, cd/m²: the EETF lifts the shadows toward it",
        false,
        0.0,
    ),
    Param {
        name: "knee_offset",
        doc: "Where the roll-off starts: KS = (1 + k)·maxLum − k; 0.5 is BT.2390's, 1 libplacebo's default",
        kind: Kind::Number(Range::closed(0.5, 2.0)),
        default: Value::Number(0.5),
    },
];

/// The EETF's constants, from the parameters: all in PQ signal, the
/// spline's in the source range normalised to [0, 1].
#[derive(Clone, Copy, Debug)]
struct Eetf {
    /// cd/m² of an input of 1 (the exposure is applied before).
    reference_white: f64,
    source_black: f64,
    source_peak: f64,
    /// PQ of the source black, and PQ(source peak) − that.
    e_min: f64,
    e_range: f64,
    /// The target's black and peak in the normalised source range.
    min_lum: f64,
    max_lum: f64,
    /// The knee start.
    ks: f64,
    /// The black-point lift's exponent and the gain that keeps the peak.
    bp: f64,
    gain: f64,
    /// PQ of the target's black and peak: the output's bounds.
    out_min: f64,
    out_max: f64,
    target_black: f64,
    target_range: f64,
}

impl Eetf {
    fn of(v: &Values) -> Eetf {
        let (sb, sp) = (v.num("source_black"), v.num("source_peak"));
        let (tb, tp) = (v.num("target_black"), v.num("target_peak"));
        let e_min = pq_encode(sb);
        let e_range = pq_encode(sp) - e_min;
        let min_lum = (pq_encode(tb) - e_min) / e_range;
        let max_lum = (pq_encode(tp) - e_min) / e_range;
        let k = v.num("knee_offset");
        let bp = if min_lum > 0.0 {
            (1.0 / min_lum).min(4.0)
        } else {
            4.0
        };
        let gain = if max_lum < 1.0 {
            1.0 / (1.0 + min_lum / max_lum * (1.0 - max_lum).powf(bp))
        } else {
            1.0
        };
        Eetf {
            reference_white: v.num("reference_white"),
            source_black: sb,
            source_peak: sp,
            e_min,
            e_range,
            min_lum,
            max_lum,
            ks: (1.0 + k) * max_lum - k,
            bp,
            gain,
            out_min: pq_encode(tb),
            out_max: pq_encode(tp),
            target_black: tb,
            target_range: tp - tb,
        }
    }

    /// The signal at or below which the output is the target's black: 4
    /// f32 steps (2⁻²² relative) above its PQ code, as the GPU sees it.
    fn black_snap(&self) -> f64 {
        f64::from(self.out_min as f32) * (1.0 + 4.0 / 16_777_216.0)
    }

    /// The EETF on one PQ signal in the source range: libplacebo's steps in
    /// its order, in f64.
    fn signal(&self, e: f64) -> f64 {
        let mut x = (e - self.e_min) / self.e_range;
        // With maxLum ≥ 1 (a target as bright as the source) KS ≥ 1 and
        // nothing is rolled off; at exactly 1 the spline would divide 0 by 0.
        if x >= self.ks && self.ks < 1.0 {
            let t = (x - self.ks) / (1.0 - self.ks);
            let (t2, t3) = (t * t, t * t * t);
            x = (2.0 * t3 - 3.0 * t2 + 1.0) * self.ks
                + (t3 - 2.0 * t2 + t) * (1.0 - self.ks)
                + (-2.0 * t3 + 3.0 * t2) * self.max_lum;
        }
        if x < 1.0 {
            x += self.min_lum * (1.0 - x).powf(self.bp);
            x = self.gain * (x - self.min_lum) + self.min_lum;
        }
        (x * self.e_range + self.e_min).clamp(self.out_min, self.out_max)
    }

    /// One channel: scene-linear (after the exposure) to display-relative.
    fn channel(&self, c: f64) -> f64 {
        let nits = (c * self.reference_white).clamp(self.source_black, self.source_peak);
        let e = self.signal(pq_encode(nits));
        // The target's black and peak are exactly 0 and 1, and a signal
        // within 4 f32 steps of the black is the black (the shader says why).
        if e <= self.black_snap() {
            return 0.0;
        }
        if e >= self.out_max {
            return 1.0;
        }
        ((pq_decode(e) - self.target_black) / self.target_range).clamp(0.0, 1.0)
    }
}

impl Curve for Eetf {
    #[inline]
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        // NaN-free for ±∞: the clamp takes them to the mastering range.
        c.map(|v| self.channel(v))
    }
}

impl ToneOperator for Bt2390 {
    fn name(&self) -> &'static str {
        "bt2390"
    }
    fn summary(&self) -> &'static str {
        "ITU-R BT.2390 EETF per channel in PQ, as libplacebo's bt2390 (HDR to SDR or HDR)"
    }
    fn params(&self) -> &'static [Param] {
        PARAMS
    }
    fn check(&self, v: &Values) -> Result<(), String> {
        let (sb, sp) = (v.num("source_black"), v.num("source_peak"));
        let (tb, tp) = (v.num("target_black"), v.num("target_peak"));
        if sb >= sp {
            return Err(format!(
                "source_black ({sb}) must be below source_peak ({sp})"
            ));
        }
        if tb >= tp {
            return Err(format!(
                "target_black ({tb}) must be below target_peak ({tp})"
            ));
        }
        if tp <= sb {
            return Err(format!(
                "target_peak ({tp}) must be above source_black ({sb}): the target's whole range would be below the source's black"
            ));
        }
        Ok(())
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        fixed::RESOLVED
    }
    fn resolve(&self, v: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        Ok(fixed::resolution(v, Eetf::of(v)))
    }
    fn wgsl(&self) -> &'static str {
        include_str!("../../shaders/operators/bt2390.wgsl")
    }
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord::FIRST)
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        vec![v.num("exposure") as f32]
    }
    /// The target display's: the output is relative to its black and peak.
    fn display_levels(&self, v: &Values) -> Option<DisplayLevels> {
        Some(DisplayLevels {
            black: v.num("target_black"),
            peak: v.num("target_peak"),
        })
    }
    /// The EETF's constants, computed here in f64, as override constants
    /// (llvmpipe folds them into the code, as it does Hable's).
    fn gpu_constants(&self, v: &Values) -> Vec<(&'static str, f64)> {
        let e = Eetf::of(v);
        vec![
            ("BT2390_REFERENCE_WHITE", e.reference_white),
            ("BT2390_SOURCE_BLACK", e.source_black),
            ("BT2390_SOURCE_PEAK", e.source_peak),
            ("BT2390_E_MIN", e.e_min),
            ("BT2390_E_RANGE", e.e_range),
            ("BT2390_MIN_LUM", e.min_lum),
            ("BT2390_MAX_LUM", e.max_lum),
            ("BT2390_KS", e.ks),
            ("BT2390_BP", e.bp),
            ("BT2390_GAIN", e.gain),
            ("BT2390_OUT_MIN", e.out_min),
            ("BT2390_OUT_MAX", e.out_max),
            ("BT2390_BLACK_SNAP", e.black_snap()),
            ("BT2390_TARGET_BLACK", e.target_black),
            ("BT2390_TARGET_RANGE", e.target_range),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pq_round_trips_and_has_its_anchor_points() {
        assert_eq!(pq_encode(0.0), 0.0);
        assert!((pq_encode(PQ_PEAK) - 1.0).abs() < 1e-15);
        // BT.2100's table: 100 cd/m² is PQ 0.5081, 1000 cd/m² is 0.7518.
        assert!((pq_encode(100.0) - 0.508_078).abs() < 1e-6);
        assert!((pq_encode(1000.0) - 0.751_827).abs() < 1e-6);
        for nits in [1e-4, 0.1, 1.0, 203.0, 4000.0] {
            let back = pq_decode(pq_encode(nits));
            assert!((back - nits).abs() <= 1e-12 * nits, "{nits}: {back}");
        }
    }

    #[test]
    fn the_defaults_keep_black_and_reach_the_target_peak_only_at_the_source_peak() {
        let e = Eetf::of(&Values::new(
            PARAMS.iter().map(|p| (p.name, p.default)).collect(),
        ));
        assert_eq!(e.channel(0.0), 0.0);
        assert_eq!(e.channel(f64::INFINITY), 1.0);
        assert_eq!(e.channel(f64::NEG_INFINITY), 0.0);
        let peak_in = 1000.0 / 203.0;
        assert!((e.channel(peak_in) - 1.0).abs() < 1e-12);
        assert!(e.channel(0.99 * peak_in) < 1.0);
        // Below the knee the signal passes: 1 cd/m² is still 1 cd/m².
        assert!((e.channel(1.0 / 203.0) - 0.01).abs() < 1e-12);
        // Monotonic over the whole range.
        let mut last = 0.0;
        for i in 0..=2000 {
            let y = e.channel(peak_in * i as f64 / 2000.0);
            assert!(y >= last, "{i}");
            last = y;
        }
    }
}
