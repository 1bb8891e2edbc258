//! Judging one rendered scene against its goldens: every frame compared with
//! every metric, the scene's checks evaluated with adapter overrides applied,
//! the static and moving summaries of the TAA thesis (docs/bibliography.md).

use super::figures::FRAME_METRICS;
use super::result::{CheckResult, FrameResult, SceneResult, Summary, TestKind};
use super::spec::{not_applied, CheckSpec, Judged, Subject};
use crate::image::Rgb8Image;
use crate::metrics::{compare_with_flip, fraction_over};
use crate::perf::TimingSummary;
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
        Subject::Frame(_) | Subject::FractionOver(_) | Subject::FlipPercentile(_) => {
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
    pub frames: Vec<Rgb8Image>,
    pub timings: Vec<TimingSummary>,
    pub fps: Option<f64>,
    /// The accuracy-trading options the renderer had in effect (none on
    /// the CPU): the checks for them apply.
    pub options: Vec<super::spec::AccuracyOption>,
}

/// A frame whose images are kept as artifacts (a failing frame, or the
/// scene's worst judged frame so a passing run can be looked at too).
pub struct KeptFrame {
    pub frame: u32,
    /// Whether the frame failed a check (else it is the scene's worst frame).
    pub failed: bool,
    pub actual: Rgb8Image,
    pub golden: Rgb8Image,
}

/// Compares the rendered frames with `goldens` (frame n with golden n) and
/// evaluates the scene's checks. Returns the images of the failing frames and
/// of the worst judged frame (lowest PSNR), for artifacts.
pub fn judge(
    on: Judging,
    rendered: Rendered,
    goldens: Vec<Rgb8Image>,
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
    } = rendered;
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
    let flip_ps: Vec<f64> = on
        .checks
        .iter()
        .filter_map(|c| match c.check.rule().subject {
            Subject::FlipPercentile(p) => Some(p),
            _ => None,
        })
        .collect();
    let mut frames = Vec::with_capacity(images.len());
    for (n, (frame, golden)) in images.iter().zip(&goldens).enumerate() {
        let n = n as u32;
        let err = |source| JudgeError::Metrics {
            scene: on.scene.into(),
            frame: n,
            source,
        };
        let (metrics, flip) = compare_with_flip(frame.raster(), golden.raster()).map_err(err)?;
        let flip_percentiles = flip_ps
            .iter()
            .map(|&p| (p.to_string(), flip.weighted_percentile(p)))
            .collect();
        let mut fraction = BTreeMap::new();
        for &k in &lsbs {
            fraction.insert(
                k,
                fraction_over(frame.raster(), golden.raster(), k).map_err(err)?,
            );
        }
        frames.push(FrameResult {
            frame: n,
            metrics,
            fraction_over: fraction,
            flip_percentiles,
            failed_checks: Vec::new(),
            artifacts: Vec::new(),
        });
    }
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
    let checks: Vec<CheckResult> = (0..on.checks.len())
        .map(|i| evaluate(on.checks, i, &judged, applies_on, &timings, fps))
        .collect();
    // Per-frame failures of the applied checks, on the judged frames.
    for f in frames
        .iter_mut()
        .filter(|f| judged_frames.contains(&f.frame))
    {
        for (i, c) in checks.iter().enumerate() {
            if c.passed.is_some() && f.fails(&c.spec) == Some(true) {
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
    let summaries = FRAME_METRICS
        .iter()
        .map(|m| {
            let values: Vec<(u32, f64)> = frames
                .iter()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::spec::tests::{on, spec};
    use crate::check::Check;
    use crate::image::Rgb8Image;
    use crate::metrics::Metrics;

    fn frame(n: u32, psnr: f64) -> FrameResult {
        FrameResult {
            frame: n,
            metrics: Metrics {
                mse: 0.0,
                rmse: 0.0,
                psnr,
                snr: psnr,
                ssim: 1.0,
                max_abs_diff: 0,
                mean_abs_diff: 0.0,
                fraction_over_1lsb: 0.0,
                flip_mean: 0.0,
                ssim_definition: String::new(),
            },
            fraction_over: BTreeMap::new(),
            flip_percentiles: BTreeMap::new(),
            failed_checks: Vec::new(),
            artifacts: Vec::new(),
        }
    }

    #[test]
    fn an_adapter_bound_is_evaluated_on_its_adapter_and_the_generic_elsewhere() {
        let specs = vec![
            spec(Check::MinPsnr(40.0), None),
            spec(Check::MinPsnr(30.0), Some("llvmpipe")),
            spec(Check::MinSsim(0.9), None),
        ];
        let frames = [frame(0, 35.0), frame(1, 33.0)];
        let judged: Vec<&FrameResult> = frames.iter().collect();
        let on_llvmpipe = evaluate(&specs, 1, &judged, on("llvmpipe"), &[], None);
        assert_eq!(on_llvmpipe.passed, Some(true));
        let generic = evaluate(&specs, 0, &judged, on("NVIDIA H100"), &[], None);
        assert_eq!(generic.passed, Some(false));
        assert_eq!(generic.frame, Some(1), "{}", generic.detail);
    }

    #[test]
    fn a_nan_metric_is_the_worst_and_fails() {
        let specs = vec![spec(Check::MinPsnr(10.0), None)];
        let frames = [frame(0, 50.0), frame(1, f64::NAN), frame(2, 40.0)];
        let judged: Vec<&FrameResult> = frames.iter().collect();
        let r = evaluate(&specs, 0, &judged, on("x"), &[], None);
        assert_eq!(r.passed, Some(false));
        assert_eq!(r.frame, Some(1));
    }

    #[test]
    fn run_level_checks_read_the_timings_and_the_fps() {
        let specs = vec![
            spec(
                Check::MaxStageMs {
                    stage: "sphere".into(),
                    ms: 5.0,
                },
                None,
            ),
            spec(Check::MinFps(30.0), None),
        ];
        let timings = [TimingSummary {
            name: "sphere".into(),
            median_ms: 6.0,
            p95_ms: 7.0,
        }];
        let r = evaluate(&specs, 0, &[], on("x"), &timings, Some(31.0));
        assert_eq!(r.passed, Some(false), "{}", r.detail);
        assert_eq!(r.detail, "sphere median 6.000 ms (max 5)");
        let r = evaluate(&specs, 1, &[], on("x"), &timings, Some(31.0));
        assert_eq!(r.passed, Some(true), "{}", r.detail);
        // On the CPU there is neither: the checks do not apply.
        assert_eq!(evaluate(&specs, 0, &[], on("x"), &[], None).passed, None);
        assert_eq!(evaluate(&specs, 1, &[], on("x"), &[], None).passed, None);
    }

    #[test]
    fn a_fraction_check_reads_its_own_lsb_count() {
        let mut f = frame(0, 60.0);
        f.metrics.fraction_over_1lsb = 0.5;
        f.fraction_over.insert(3, 0.01);
        let specs = vec![
            spec(
                Check::MaxFractionOver {
                    lsb: 3,
                    fraction: 0.02,
                },
                None,
            ),
            spec(
                Check::MaxFractionOver {
                    lsb: 1,
                    fraction: 0.02,
                },
                None,
            ),
        ];
        let judged = [&f];
        let r = evaluate(&specs, 0, &judged, on("x"), &[], None);
        assert_eq!(r.passed, Some(true), "{}", r.detail);
        assert_eq!(r.detail, "worst fraction over 3 LSB 0.01000 at frame 0");
        assert_eq!(
            evaluate(&specs, 1, &judged, on("x"), &[], None).passed,
            Some(false)
        );
    }

    /// A smooth 32×24 frame: large enough for SSIM's window.
    fn gradient() -> Rgb8Image {
        Rgb8Image {
            width: 32,
            height: 24,
            pixels: (0..32 * 24)
                .map(|i| {
                    let (x, y) = (i % 32, i / 32);
                    [(x * 7) as u8, (y * 9) as u8, ((x + y) * 3) as u8]
                })
                .collect(),
        }
    }

    fn judged(checks: &[CheckSpec], frame: Rgb8Image) -> SceneResult {
        let on = Judging {
            scene: "s",
            checks,
            reference_spp: 16,
            test: TestKind::Static,
            keep_last: false,
        };
        let rendered = Rendered {
            renderer: "test".into(),
            adapter: "test".into(),
            spp: 16,
            plan: vec!["encode"],
            frames: vec![frame],
            timings: Vec::new(),
            fps: None,
            options: Vec::new(),
        };
        judge(on, rendered, vec![gradient()]).unwrap().0
    }

    #[test]
    fn the_mean_check_catches_a_uniform_shift_the_per_pixel_bounds_let_through() {
        let checks = [
            spec(Check::MaxAbsDiff(1), None),
            spec(
                Check::MaxFractionOver {
                    lsb: 1,
                    fraction: 0.001,
                },
                None,
            ),
            spec(Check::MaxMeanAbsDiff(0.5), None),
        ];
        // Every sample one level brighter: a biased encoder, not rounding noise.
        let mut shifted = gradient();
        for p in &mut shifted.pixels {
            *p = p.map(|c| c.saturating_add(1));
        }
        let r = judged(&checks, shifted);
        let passed: Vec<Option<bool>> = r.checks.iter().map(|c| c.passed).collect();
        assert_eq!(
            passed,
            [Some(true), Some(true), Some(false)],
            "{:?}",
            r.checks
        );
        assert!(r.checks[2]
            .detail
            .starts_with("worst mean abs diff 1.0000 LSB"));
        assert_eq!(r.frames[0].failed_checks, [2]);
        // A few wild pixels: the maximum catches them, the mean does not move much.
        let mut outliers = gradient();
        for p in outliers.pixels.iter_mut().step_by(97) {
            p[0] = p[0].wrapping_add(40);
        }
        let r = judged(&checks, outliers);
        let passed: Vec<Option<bool>> = r.checks.iter().map(|c| c.passed).collect();
        assert_eq!(
            passed,
            [Some(false), Some(false), Some(true)],
            "{:?}",
            r.checks
        );
        // The figure is summarised with the others.
        assert!(r.summary("mean_abs_diff").unwrap().worst < 0.5);
        // The frame against its own golden passes everything.
        let r = judged(&checks, gradient());
        assert!(r.passed(), "{:?}", r.checks);
    }
}
