//! What judging a scene produces: per-frame metrics, per-check outcomes and
//! the best / worst / mean summaries of the TAA thesis
//! (docs/bibliography.md). The report, the JUnit, the console and the history
//! are views of these.

use super::spec::{CheckSpec, Subject};
use crate::metrics::Metrics;
use crate::perf::TimingSummary;
use serde::Serialize;
use std::collections::BTreeMap;

/// The two kinds of test of the TAA thesis (docs/bibliography.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TestKind {
    /// No motion (ω = 0): the checks judge the converged frame, the last one.
    Static,
    /// A rotating sequence: the checks judge every frame; the report gives
    /// best / worst / mean per metric with the frame index (ghosting tables).
    Moving,
}

impl TestKind {
    pub fn name(self) -> &'static str {
        match self {
            TestKind::Static => "static",
            TestKind::Moving => "moving",
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct FrameResult {
    pub frame: u32,
    pub metrics: Metrics,
    /// Fraction of pixels off by more than k LSB, for each k a check asks
    /// about (1 is in `metrics`).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub fraction_over: BTreeMap<u8, f64>,
    /// How many pixels are off by more than k LSB, for each k a check asks
    /// about.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub pixels_over: BTreeMap<u8, u64>,
    /// FLIP's weighted percentiles, for each p (as written) a check asks about.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub flip_percentiles: BTreeMap<String, f64>,
    /// Eye adaptation: the luminance the frame was adapted to, against the
    /// golden adaptation curve's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptation: Option<AdaptationPoint>,
    /// Indices (into the scene's `checks`) of the per-frame checks this frame fails.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub failed_checks: Vec<usize>,
    /// Artifact files written for this frame (failing frames, and each
    /// scene's worst judged frame).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub artifacts: Vec<String>,
}

/// One frame of an adapting scene: the luminance it was adapted to, the
/// golden curve's, and |Δ ln| between them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AdaptationPoint {
    pub adapted: f64,
    pub golden: f64,
    pub error: f64,
}

impl AdaptationPoint {
    pub fn new(adapted: f64, golden: f64) -> AdaptationPoint {
        AdaptationPoint {
            adapted,
            golden,
            // NaN (a non-positive or missing value) fails every bound.
            error: (adapted.ln() - golden.ln()).abs(),
        }
    }
}

impl FrameResult {
    /// The per-frame figure a check's subject reads; None for run-level subjects.
    pub(super) fn value(&self, subject: Subject) -> Option<f64> {
        match subject {
            Subject::Frame(m) => Some((m.read)(&self.metrics)),
            Subject::FractionOver(1) => Some(self.metrics.fraction_over_1lsb),
            Subject::FractionOver(lsb) => {
                Some(self.fraction_over.get(&lsb).copied().unwrap_or(f64::NAN))
            }
            Subject::PixelsOver(lsb) => {
                Some(self.pixels_over.get(&lsb).map_or(f64::NAN, |&n| n as f64))
            }
            Subject::FlipPercentile(p) => Some(
                self.flip_percentiles
                    .get(&p.to_string())
                    .copied()
                    .unwrap_or(f64::NAN),
            ),
            Subject::Adaptation => self.adaptation.map(|a| a.error),
            Subject::StageMs(_) | Subject::Fps | Subject::GainOver(_) => None,
        }
    }

    /// Whether this frame fails a per-frame check; None for run-level checks.
    pub(super) fn fails(&self, spec: &CheckSpec) -> Option<bool> {
        let rule = spec.check.rule();
        self.value(rule.subject).map(|v| rule.fails(v))
    }
}

/// Best, worst and mean of one metric over a sequence, with frame indices
/// (as in the TAA thesis's ghosting tables).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub best: f64,
    pub best_frame: u32,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub worst: f64,
    pub worst_frame: u32,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub mean: f64,
}

impl Summary {
    /// `higher_is_better` says which end is best. Ties keep the first frame.
    pub fn of(values: &[(u32, f64)], higher_is_better: bool) -> Summary {
        let Some(&first) = values.first() else {
            return Summary {
                best: f64::NAN,
                best_frame: 0,
                worst: f64::NAN,
                worst_frame: 0,
                mean: f64::NAN,
            };
        };
        let mut best = first;
        let mut worst = first;
        let mut sum = 0.0;
        for &(f, v) in values {
            let (better, worse) = if higher_is_better {
                (v > best.1, v < worst.1)
            } else {
                (v < best.1, v > worst.1)
            };
            if better {
                best = (f, v);
            }
            if worse {
                worst = (f, v);
            }
            sum += v;
        }
        Summary {
            best: best.1,
            best_frame: best.0,
            worst: worst.1,
            worst_frame: worst.0,
            mean: sum / values.len() as f64,
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct CheckResult {
    pub spec: CheckSpec,
    /// None when the check does not apply here (timing on the CPU, another
    /// adapter's bound, a generic bound overridden by this adapter's).
    pub passed: Option<bool>,
    pub detail: String,
    /// The frame that decided a per-frame check (its worst).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame: Option<u32>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub scene: String,
    pub test: TestKind,
    pub renderer: String,
    /// The adapter name checks' `adapter` overrides are matched against.
    pub adapter: String,
    pub spp: u32,
    pub plan: Vec<&'static str>,
    pub frames: Vec<FrameResult>,
    /// The frames the checks judged: the last one for a static test, all for a moving one.
    pub judged_frames: Vec<u32>,
    /// Best / worst / mean over every frame, per metric (see [`crate::check::FRAME_METRICS`]).
    pub summaries: BTreeMap<String, Summary>,
    pub checks: Vec<CheckResult>,
    /// Why the scene fails regardless of its checks (for example: none apply).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<String>,
    /// Per-stage GPU time (median, p95) over the sequence; empty on the CPU.
    pub timings: Vec<TimingSummary>,
    /// Frames per second with readback (GPU only).
    pub fps: Option<f64>,
    /// A TAA scene's variant and the sequence it shares with the other
    /// variants' scenes (the dashboard compares them side by side).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub taa: Option<TaaTag>,
    /// The scene's expectation on this adapter, when one applies, and what
    /// it made of the result.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub expectation: Option<super::ExpectationOutcome>,
    /// Expectations that match this adapter but have expired (renew or remove).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub expired_expectations: Vec<String>,
}

/// Which TAA variant a scene ran, on which sequence.
#[derive(Clone, Debug, Serialize)]
pub struct TaaTag {
    /// `off`, `clip`, `edge_aware` or `variance`.
    pub variant: String,
    /// The other keys that tell TAA configurations apart: history filter,
    /// feedback rule, blend ("" for no AA).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub settings: String,
    /// `Scene::sequence_key`: equal for scenes that differ only in their TAA
    /// settings, name, description and checks (same frames, same goldens).
    pub sequence: String,
}

impl SceneResult {
    pub fn passed(&self) -> bool {
        self.problems.is_empty() && self.checks.iter().all(|c| c.passed != Some(false))
    }

    /// Whether the scene fails the gate: it failed, and no expectation on
    /// this adapter says it may.
    pub fn fails_gate(&self) -> bool {
        !self.passed()
            && !self.expectation.as_ref().is_some_and(|e| {
                matches!(e.outcome.as_str(), "failed_as_expected" | "flaky_failure")
            })
    }

    pub fn summary(&self, metric: &str) -> Option<&Summary> {
        self.summaries.get(metric)
    }

    pub fn failed_checks(&self) -> impl Iterator<Item = &CheckResult> {
        self.checks.iter().filter(|c| c.passed == Some(false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_kind_names_are_the_serde_names() {
        for k in [TestKind::Static, TestKind::Moving] {
            assert_eq!(serde_json::to_value(k).unwrap(), k.name());
        }
    }

    #[test]
    fn summaries_name_the_frames_of_the_extremes() {
        let s = Summary::of(&[(0, 30.0), (1, 50.0), (2, 20.0)], true);
        assert_eq!(
            (s.best, s.best_frame, s.worst, s.worst_frame),
            (50.0, 1, 20.0, 2)
        );
        assert!((s.mean - 100.0 / 3.0).abs() < 1e-12);
        let s = Summary::of(&[(0, 3.0), (1, 1.0)], false);
        assert_eq!((s.best_frame, s.worst_frame), (1, 0));
    }
}
