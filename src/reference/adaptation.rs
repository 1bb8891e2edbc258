//! `adaptation`: the luminance the eye is adapted to, carried across frames
//! (scene::Adaptation; docs/adaptation.md), in f64.

use crate::operators::{LuminanceStats, StatsNeeds};
use crate::scene::Adaptation;

/// What a sequence is adapted to after a frame: the natural logarithms of
/// the adapted log average and weighted log average (each where measured).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adapted {
    pub log_average: f64,
    pub weighted_log_average: Option<f64>,
}

/// One frame's step: `before` (None on the first frame, or after a reset)
/// moved toward the frame's `measured` statistics by the fraction of the
/// gap `steps` gives (up, down: [`Adaptation::steps`]).
pub fn adapt(measured: &LuminanceStats, before: Option<&Adapted>, steps: (f64, f64)) -> Adapted {
    // A non-finite measurement (a NaN or infinite pixel) never enters the
    // state: the adapted value stays, and a first frame takes ln 1 = 0
    // (docs/adaptation.md#bad-pixels).
    let step = |a: Option<f64>, m: f64| match a {
        _ if !m.is_finite() => a.unwrap_or(0.0),
        None => m,
        Some(a) => a + (m - a) * if m > a { steps.0 } else { steps.1 },
    };
    let m = measured
        .log_average
        .expect("adaptation measures the log average")
        .ln();
    Adapted {
        log_average: step(before.map(|b| b.log_average), m),
        weighted_log_average: measured
            .weighted_log_average
            .map(|w| step(before.and_then(|b| b.weighted_log_average), w.ln())),
    }
}

impl Adapted {
    /// The statistics the operator reads: the adapted values in place of
    /// the measured ones.
    pub fn statistics(&self, measured: &LuminanceStats) -> LuminanceStats {
        LuminanceStats {
            log_average: Some(self.log_average.exp()),
            weighted_log_average: self.weighted_log_average.map(f64::exp),
            ..*measured
        }
    }

    /// The scale of an operator's input that keys on no log average
    /// (`needs`): `key` over the adapted luminance; 1 for the others.
    pub fn exposure(&self, adaptation: &Adaptation, needs: StatsNeeds) -> f64 {
        if needs.keys_on_average() {
            1.0
        } else {
            adaptation.key.get() / self.log_average.exp()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(l: f64) -> LuminanceStats {
        LuminanceStats {
            log_average: Some(l),
            ..Default::default()
        }
    }

    /// An infinite or NaN measurement leaves the state where it was, and a
    /// first frame's is ln 1.
    #[test]
    fn a_non_finite_measurement_never_enters_the_state() {
        let a = Adaptation::default();
        let steps = a.steps(1.0 / 60.0);
        let before = adapt(&stats(0.5), None, steps);
        for bad in [f64::INFINITY, f64::NAN, 0.0] {
            let after = adapt(&stats(bad), Some(&before), steps);
            assert_eq!(after.log_average, before.log_average, "{bad}");
            assert_eq!(adapt(&stats(bad), None, steps).log_average, 0.0, "{bad}");
        }
    }

    #[test]
    fn the_first_frame_takes_the_measurement_and_later_ones_close_the_gap_by_the_step() {
        let a = Adaptation::new(0.5, 2.0, 0.18).unwrap();
        let steps = a.steps(1.0 / 60.0);
        let first = adapt(&stats(0.01), None, steps);
        assert_eq!(first.log_average, 0.01f64.ln());
        // Brighter: the up step; n frames leave (1 - α)^n of the gap.
        let mut s = first;
        for _ in 0..60 {
            s = adapt(&stats(1.0), Some(&s), steps);
        }
        let gap = 0.01f64.ln() * (1.0 - steps.0).powi(60);
        assert!(
            (s.log_average - gap).abs() < 1e-12,
            "{} {gap}",
            s.log_average
        );
        // One second at τ = 0.5 s leaves e^-2 of the gap.
        assert!((gap / 0.01f64.ln() - (-2f64).exp()).abs() < 1e-12);
        // Darker: the slower down step.
        let down = adapt(&stats(0.01), Some(&s), steps);
        let up = adapt(&stats(s.log_average.exp().powi(2) * 50.0), Some(&s), steps);
        assert!((down.log_average - s.log_average).abs() < (up.log_average - s.log_average).abs());
        assert!((steps.1 - (-(-1.0f64 / 120.0).exp_m1())).abs() < 1e-15);
    }

    #[test]
    fn operators_that_key_on_nothing_get_key_over_the_adapted_luminance() {
        let a = Adaptation::new(0.5, 2.0, 0.18).unwrap();
        let s = adapt(&stats(0.09), None, a.steps(0.1));
        let none = StatsNeeds::default();
        assert!((s.exposure(&a, none) - 2.0).abs() < 1e-12);
        let reinhard = StatsNeeds {
            log_average: true,
            ..none
        };
        assert_eq!(s.exposure(&a, reinhard), 1.0);
        assert!((s.statistics(&stats(5.0)).log_average.unwrap() - 0.09).abs() < 1e-15);
    }
}
