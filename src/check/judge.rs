//! Judging one rendered scene against its goldens: every frame compared with
//! every metric, the scene's checks evaluated with adapter overrides applied,
//! the static and moving summaries of the TAA thesis (docs/bibliography.md).

use super::figures::FRAME_METRICS;
use super::result::{AdaptationPoint, CheckResult, FrameResult, SceneResult, Summary, TestKind};
use super::spec::{not_applied, Check, CheckSpec, GainOver, Judged, Subject};
use crate::image::Frame;
use crate::metrics::{compare_frames_by, frame_fraction_over};
use crate::perf::TimingSummary;
use rayon::prelude::*;
use std::collections::BTreeMap;

#[derive(Debug, thiserror::Error)]
pub enum JudgeError {
    /// A frame could not be compared with its golden (sizes differ).
    #[error("scene {scene}, frame {frame}: {source}")]
    Metrics {
        scene: String,
        frame: u32,
        source: crate::metrics::MetricsError,
    },
    /// The renderer produced another number of frames than there are goldens.
    #[error("scene {scene}: {rendered} frames rendered for {goldens} goldens")]
    FrameCount {
        scene: String,
        rendered: usize,
        goldens: usize,
    },
}

/// Evaluates check `index` of `specs` over the judged `frames`.
pub fn evaluate(
    specs: &[CheckSpec],
    index: usize,
    frames: &[&FrameResult],
    on: Judged,
    timings: &[TimingSummary],
    fps: Option<f64>,
) -> CheckResult {
    let spec = &specs[index];
    let result = |passed: Option<bool>, detail: String, frame: Option<u32>| CheckResult {
        spec: spec.clone(),
        passed,
        detail,
        frame,
    };
    if let Some(why) = not_applied(specs, index, on) {
        return result(None, why, None);
    }
    let rule = spec.check.rule();
    match rule.subject {
        Subject::Frame(_)
        | Subject::FractionOver(_)
        | Subject::PixelsOver(_)
        | Subject::FlipPercentile(_)
        | Subject::Adaptation => {
            let lower_is_worse = rule.side == super::spec::Side::Min;
            // (value, frame) of the worst judged frame; NaN counts as worst.
            let worst = frames
                .iter()
                .filter_map(|r| r.value(rule.subject).map(|v| (v, r.frame)))
                .reduce(|(w, wf), (v, fr)| {
                    let worse = v.is_nan() || if lower_is_worse { v < w } else { v > w };
                    if worse && !w.is_nan() {
                        (v, fr)
                    } else {
                        (w, wf)
                    }
                });
            let show = |v| rule.subject.show(v);
            match worst {
                None => result(Some(false), "no frames to judge".into(), None),
                Some((v, f)) => {
                    let failed = frames
                        .iter()
                        .filter(|fr| fr.fails(spec) == Some(true))
                        .count();
                    let detail = if failed == 0 {
                        format!("worst {} at frame {f}", show(v))
                    } else {
                        format!(
                            "worst {} at frame {f}; {failed} of {} judged frames fail",
                            show(v),
                            frames.len()
                        )
                    };
                    result(Some(failed == 0), detail, Some(f))
                }
            }
        }
        Subject::StageMs(stage) => match timings.iter().find(|t| t.name == stage) {
            Some(t) => result(
                Some(!rule.fails(t.median_ms)),
                format!("{} (max {})", rule.subject.show(t.median_ms), rule.bound),
                None,
            ),
            None => result(None, format!("no GPU timing for stage {stage}"), None),
        },
        // Needs the other scene's frames: `judge` decides it (`judge_gain`).
        Subject::GainOver(g) => result(
            None,
            format!("compares with scene {}: judged with the run", g.scene),
            None,
        ),
        Subject::Fps => match fps {
            Some(v) => result(
                Some(!rule.fails(v)),
                format!("{} (min {})", rule.subject.show(v), rule.bound),
                None,
            ),
            None => result(None, "FPS is measured on the GPU renderer".into(), None),
        },
    }
}

/// A `min_psnr_gain_over` check, decided against the scenes rendered before
/// this one in the same run (`earlier`): frame by frame, this scene's PSNR
/// (`frames`) less the other's, over this scene's `judged` frames. Returns
/// the result and the frames under the per-frame floor. A check whose scene
/// was not rendered fails and says so.
pub fn judge_gain(
    spec: &CheckSpec,
    g: &GainOver,
    frames: &[FrameResult],
    judged: &[u32],
    earlier: &[SceneResult],
) -> (CheckResult, Vec<u32>) {
    let result = |passed: bool, detail: String, frame: Option<u32>| CheckResult {
        spec: spec.clone(),
        passed: Some(passed),
        detail,
        frame,
    };
    let psnr = |frames: &[FrameResult], n: u32| {
        frames.iter().find(|f| f.frame == n).map(|f| f.metrics.psnr)
    };
    let Some(base) = earlier.iter().find(|r| r.scene == g.scene) else {
        let why = format!(
            "scene {} was not rendered before this one in this run",
            g.scene
        );
        return (result(false, why, None), Vec::new());
    };
    let gains: Vec<(u32, f64)> = judged
        .iter()
        .map(|&n| {
            let gain = match (psnr(frames, n), psnr(&base.frames, n)) {
                (Some(a), Some(b)) => a - b,
                _ => f64::NAN,
            };
            (n, gain)
        })
        .collect();
    if gains.is_empty() {
        return (result(false, "no frames to judge".into(), None), Vec::new());
    }
    let mean = gains.iter().map(|g| g.1).sum::<f64>() / gains.len() as f64;
    let (worst_frame, worst) = gains
        .iter()
        .copied()
        .reduce(|w, v| if v.1.is_nan() || v.1 < w.1 { v } else { w })
        .unwrap_or((0, f64::NAN));
    let late_fails: Vec<u32> = match g.frame_db {
        Some(floor) => gains
            .iter()
            .filter(|(n, v)| *n >= g.from_frame && (v.is_nan() || *v < floor))
            .map(|(n, _)| *n)
            .collect(),
        None => Vec::new(),
    };
    // The mean with the decimals it takes to differ from the bound (a
    // failing +3.4689 printed as +3.47 read like a pass against 3.47).
    let shown = (2..=6)
        .map(|d| format!("{mean:+.d$}"))
        .find(|m| mean == g.db || m.parse::<f64>().ok() != Some(g.db))
        .unwrap_or_else(|| format!("{mean:+e}"));
    let side = if mean >= g.db { "at least" } else { "below" };
    let mut detail = format!(
        "mean PSNR gain over {} {shown} dB over {} frames, {side} the bound {} dB (a mean over the frames); worst frame {worst_frame} {worst:+.2} dB",
        g.scene,
        gains.len(),
        g.db
    );
    if let Some(floor) = g.frame_db {
        detail.push_str(&match late_fails.as_slice() {
            [] => format!("; every frame from {} gains >= {floor} dB", g.from_frame),
            f => format!("; frames {f:?} gain less than {floor} dB over {}", g.scene),
        });
    }
    let frame = Some(late_fails.first().copied().unwrap_or(worst_frame));
    let passed = mean >= g.db && late_fails.is_empty() && !mean.is_nan();
    (result(passed, detail, frame), late_fails)
}

/// What judging needs to know of a scene.
#[derive(Clone, Copy, Debug)]
pub struct Judging<'a> {
    pub scene: &'a str,
    pub checks: &'a [CheckSpec],
    /// The spp of checks that name none: the goldens' own, or 1 for a TAA
    /// scene (`Scene::default_spp`).
    pub reference_spp: u32,
    pub test: TestKind,
    /// Keep the last frame's images as well (TAA scenes: the frame the
    /// variants are compared on).
    pub keep_last: bool,
    /// The scenes rendered before this one in the run, which
    /// `min_psnr_gain_over` checks compare with.
    pub earlier: &'a [SceneResult],
    /// What compares 8-bit frames when not the CPU (the GPU, under
    /// `check --metrics gpu`).
    pub compare: Option<crate::metrics::CompareBy<'a>>,
    /// The golden adaptation curve of a scene with eye adaptation.
    pub adaptation_curve: Option<&'a [f64]>,
}

/// What a renderer produced for one scene.
pub struct Rendered {
    /// Renderer description for reports.
    pub renderer: String,
    /// Adapter name the checks' `adapter` overrides are matched against.
    pub adapter: String,
    pub spp: u32,
    /// The stages the frames went through.
    pub plan: Vec<&'static str>,
    pub frames: Vec<Frame>,
    pub timings: Vec<TimingSummary>,
    pub fps: Option<f64>,
    /// The accuracy-trading options the renderer had in effect (none on
    /// the CPU): the checks for them apply.
    pub options: Vec<super::spec::AccuracyOption>,
    /// With eye adaptation in the plan, the luminance each frame was
    /// adapted to (empty otherwise).
    pub adapted: Vec<f64>,
}

/// A frame whose images are kept as artifacts (a failing frame, or the
/// scene's worst judged frame so a passing run can be looked at too).
pub struct KeptFrame {
    pub frame: u32,
    /// Whether the frame failed a check (else it is the scene's worst frame).
    pub failed: bool,
    pub actual: Frame,
    pub golden: Frame,
}

/// Compares the rendered frames with `goldens` (frame n with golden n) and
/// evaluates the scene's checks. Returns the images of the failing frames and
/// of the worst judged frame (lowest PSNR), for artifacts.
pub fn judge(
    on: Judging,
    rendered: Rendered,
    goldens: Vec<Frame>,
) -> Result<(SceneResult, Vec<KeptFrame>), JudgeError> {
    let Rendered {
        renderer,
        adapter,
        spp,
        plan,
        frames: images,
        timings,
        fps,
        options,
        adapted,
    } = rendered;
    if on
        .adaptation_curve
        .is_some_and(|c| c.len() != goldens.len())
    {
        return Err(JudgeError::FrameCount {
            scene: on.scene.into(),
            rendered: images.len(),
            goldens: on.adaptation_curve.map_or(0, <[f64]>::len),
        });
    }
    if images.len() != goldens.len() {
        return Err(JudgeError::FrameCount {
            scene: on.scene.into(),
            rendered: images.len(),
            goldens: goldens.len(),
        });
    }
    let mut lsbs: Vec<u8> = on
        .checks
        .iter()
        .filter_map(|c| match c.check.rule().subject {
            Subject::FractionOver(lsb) if lsb != 1 => Some(lsb),
            _ => None,
        })
        .collect();
    lsbs.sort_unstable();
    lsbs.dedup();
    let mut count_lsbs: Vec<u8> = on
        .checks
        .iter()
        .filter_map(|c| match c.check.rule().subject {
            Subject::PixelsOver(lsb) => Some(lsb),
            _ => None,
        })
        .collect();
    count_lsbs.sort_unstable();
    count_lsbs.dedup();
    let flip_ps: Vec<f64> = on
        .checks
        .iter()
        .filter_map(|c| match c.check.rule().subject {
            Subject::FlipPercentile(p) => Some(p),
            _ => None,
        })
        .collect();
    // Frames are compared in parallel: FLIP's bands are as tall as a small
    // frame, so one frame at a time left most of a many-core machine idle
    // (check's FLIP took 10.6 s of 35.3 on a 16-core host with an H200).
    let scene = on.scene;
    let mut frames = images
        .par_iter()
        .zip(goldens.par_iter())
        .enumerate()
        .map(|(n, (frame, golden))| {
            let n = n as u32;
            let err = |source| JudgeError::Metrics {
                scene: scene.into(),
                frame: n,
                source,
            };
            let (metrics, flip) = compare_frames_by(frame, golden, on.compare).map_err(err)?;
            let flip_percentiles = flip_ps
                .iter()
                .map(|&p| (p.to_string(), flip.weighted_percentile(p)))
                .collect();
            let mut fraction = BTreeMap::new();
            for &k in &lsbs {
                fraction.insert(k, frame_fraction_over(frame, golden, k).map_err(err)?);
            }
            let mut pixels_over = BTreeMap::new();
            for &k in &count_lsbs {
                let f = frame_fraction_over(frame, golden, k).map_err(err)?;
                pixels_over.insert(k, pixels_of(f, frame));
            }
            let adaptation = on.adaptation_curve.map(|c| {
                AdaptationPoint::new(
                    adapted.get(n as usize).copied().unwrap_or(f64::NAN),
                    c[n as usize],
                )
            });
            Ok(FrameResult {
                frame: n,
                metrics,
                fraction_over: fraction,
                pixels_over,
                flip_percentiles,
                adaptation,
                failed_checks: Vec::new(),
                artifacts: Vec::new(),
            })
        })
        .collect::<Result<Vec<_>, JudgeError>>()?;
    let judged_frames: Vec<u32> = match on.test {
        TestKind::Static => frames.last().map(|f| f.frame).into_iter().collect(),
        TestKind::Moving => frames.iter().map(|f| f.frame).collect(),
    };
    let judged: Vec<&FrameResult> = frames
        .iter()
        .filter(|f| judged_frames.contains(&f.frame))
        .collect();
    let applies_on = Judged {
        adapter: &adapter,
        spp,
        reference_spp: on.reference_spp,
        options: &options,
    };
    // (check index, frames under its per-frame floor) of the gain checks.
    let mut gain_fails: Vec<(usize, Vec<u32>)> = Vec::new();
    let mut checks: Vec<CheckResult> = Vec::with_capacity(on.checks.len());
    for (i, spec) in on.checks.iter().enumerate() {
        match &spec.check {
            Check::MinPsnrGainOver(g) if not_applied(on.checks, i, applies_on).is_none() => {
                let (r, late) = judge_gain(spec, g, &frames, &judged_frames, on.earlier);
                gain_fails.push((i, late));
                checks.push(r);
            }
            _ => checks.push(evaluate(on.checks, i, &judged, applies_on, &timings, fps)),
        }
    }
    // Per-frame failures of the applied checks, on the judged frames.
    for f in frames
        .iter_mut()
        .filter(|f| judged_frames.contains(&f.frame))
    {
        for (i, c) in checks.iter().enumerate() {
            let under_floor = gain_fails
                .iter()
                .any(|(k, late)| *k == i && late.contains(&f.frame));
            if c.passed.is_some() && (f.fails(&c.spec) == Some(true) || under_floor) {
                f.failed_checks.push(i);
            }
        }
    }
    let mut problems = Vec::new();
    if on.checks.is_empty() {
        problems.push("the scene has no checks: a scene with no checks fails".into());
    } else if checks.iter().all(|c| c.passed.is_none()) {
        problems.push(format!(
            "none of the scene's {} checks applies to {adapter} at {spp} spp: nothing was judged",
            checks.len()
        ));
    }
    // Over the judged frames: a static scene's last, as its checks and
    // failures name it (over every frame, a static scene's equal values
    // named frame 0 as the worst while its failures said frame 5).
    let summaries = FRAME_METRICS
        .iter()
        .map(|m| {
            let values: Vec<(u32, f64)> = frames
                .iter()
                .filter(|f| judged_frames.contains(&f.frame))
                .map(|f| (f.frame, (m.read)(&f.metrics)))
                .collect();
            (m.name.to_string(), Summary::of(&values, m.higher_is_better))
        })
        .collect();
    let worst = frames
        .iter()
        .filter(|f| judged_frames.contains(&f.frame))
        .min_by(|a, b| a.metrics.psnr.total_cmp(&b.metrics.psnr))
        .map(|f| f.frame);
    let last = frames.last().map(|f| f.frame).filter(|_| on.keep_last);
    let kept: Vec<KeptFrame> = frames
        .iter()
        .filter(|f| !f.failed_checks.is_empty() || Some(f.frame) == worst || Some(f.frame) == last)
        .map(|f| KeptFrame {
            frame: f.frame,
            failed: !f.failed_checks.is_empty(),
            actual: images[f.frame as usize].clone(),
            golden: goldens[f.frame as usize].clone(),
        })
        .collect();
    Ok((
        SceneResult {
            scene: on.scene.into(),
            test: on.test,
            renderer,
            adapter,
            spp,
            plan,
            frames,
            judged_frames,
            summaries,
            checks,
            problems,
            timings,
            fps,
            taa: None,
            expectation: None,
            expired_expectations: Vec::new(),
        },
        kept,
    ))
}

/// The pixel count a fraction of `frame`'s pixels stands for: exact, as
/// the fraction is a count over the frame's pixels (below 2^53 of them).
pub(crate) fn pixels_of(fraction: f64, frame: &crate::image::Frame) -> u64 {
    (fraction * f64::from(frame.width()) * f64::from(frame.height())).round() as u64
}

#[cfg(test)]
mod tests;
