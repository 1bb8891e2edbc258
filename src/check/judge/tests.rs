use super::*;
use crate::check::spec::tests::{on, spec};
use crate::check::Check;
use crate::check::TestKind;
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
            bits: 8,
            ssim_definition: String::new(),
        },
        fraction_over: BTreeMap::new(),
        pixels_over: BTreeMap::new(),
        flip_percentiles: BTreeMap::new(),
        adaptation: None,
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
    judged_after(checks, frame, &[])
}

/// `judged`, with `earlier` the scenes rendered before it in the run.
fn judged_after(checks: &[CheckSpec], frame: Rgb8Image, earlier: &[SceneResult]) -> SceneResult {
    judged_adapting(checks, frame, earlier, None, Vec::new())
}

/// `judged_after` for a scene whose frame was `adapted` to a luminance,
/// against the golden `curve`.
fn judged_adapting(
    checks: &[CheckSpec],
    frame: Rgb8Image,
    earlier: &[SceneResult],
    curve: Option<&[f64]>,
    adapted: Vec<f64>,
) -> SceneResult {
    let on = Judging {
        scene: "s",
        checks,
        reference_spp: 16,
        test: TestKind::Static,
        keep_last: false,
        earlier,
        compare: None,
        adaptation_curve: curve,
    };
    let rendered = Rendered {
        renderer: "test".into(),
        adapter: "test".into(),
        spp: 16,
        plan: vec!["encode"],
        frames: vec![frame.into()],
        timings: Vec::new(),
        fps: None,
        options: Vec::new(),
        adapted,
    };
    judge(on, rendered, vec![gradient().into()]).unwrap().0
}

#[test]
fn an_adapted_luminance_off_the_golden_curve_fails_and_one_on_it_passes() {
    let checks = [spec(Check::MaxAdaptationError(1e-4), None)];
    let curve = [0.25];
    let judge_at = |adapted: Vec<f64>| {
        let r = judged_adapting(&checks, gradient(), &[], Some(&curve), adapted);
        (
            r.checks[0].passed,
            r.frames[0].adaptation,
            r.checks[0].detail.clone(),
        )
    };
    let (passed, point, _) = judge_at(vec![0.25 * (1.0 + 5e-5)]);
    assert_eq!(passed, Some(true));
    let point = point.unwrap();
    assert!((point.error - (5e-5f64).ln_1p()).abs() < 1e-15, "{point:?}");
    assert_eq!(point.golden, 0.25);
    // 0.02 % off: a step a frame too slow, say.
    let (passed, _, detail) = judge_at(vec![0.25 * 1.0002]);
    assert_eq!(passed, Some(false), "{detail}");
    assert!(
        detail.contains("adapted luminance |Δ ln| 2.000e-4"),
        "{detail}"
    );
    // A renderer that reported no adapted luminance fails.
    let (passed, point, _) = judge_at(Vec::new());
    assert_eq!(passed, Some(false));
    assert!(point.unwrap().error.is_nan());
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

fn gain_over(scene: &str, db: f64, frame_db: Option<f64>, from_frame: u32) -> CheckSpec {
    spec(
        Check::MinPsnrGainOver(crate::check::GainOver {
            scene: scene.into(),
            db,
            frame_db,
            from_frame,
        }),
        None,
    )
}

/// A moving scene's result with one frame per PSNR, its checks evaluated.
fn moving(name: &str, psnrs: &[f64], specs: Vec<CheckSpec>) -> SceneResult {
    let frames: Vec<FrameResult> = psnrs
        .iter()
        .enumerate()
        .map(|(n, &p)| frame(n as u32, p))
        .collect();
    let judged: Vec<&FrameResult> = frames.iter().collect();
    let checks = (0..specs.len())
        .map(|i| evaluate(&specs, i, &judged, on("x"), &[], None))
        .collect();
    SceneResult {
        scene: name.into(),
        test: TestKind::Moving,
        renderer: "x".into(),
        adapter: "x".into(),
        spp: 16,
        plan: Vec::new(),
        judged_frames: (0..psnrs.len() as u32).collect(),
        frames,
        summaries: BTreeMap::new(),
        checks,
        problems: Vec::new(),
        timings: Vec::new(),
        fps: None,
        taa: None,
        expectation: None,
        expired_expectations: Vec::new(),
    }
}

/// `judge_gain` of `spec` for a moving scene with one frame per PSNR.
fn gain(psnrs: &[f64], spec: &CheckSpec, earlier: &[SceneResult]) -> (CheckResult, Vec<u32>) {
    let Check::MinPsnrGainOver(g) = &spec.check else {
        panic!("not a gain check")
    };
    let frames: Vec<FrameResult> = psnrs
        .iter()
        .enumerate()
        .map(|(n, &p)| frame(n as u32, p))
        .collect();
    let judged: Vec<u32> = (0..psnrs.len() as u32).collect();
    judge_gain(spec, g, &frames, &judged, earlier)
}

#[test]
fn a_gain_check_compares_frame_by_frame_with_an_earlier_scene() {
    let base = [moving("noaa", &[20.0, 21.0, 22.0, 23.0], vec![])];
    let check = |db, frame_db| gain_over("noaa", db, frame_db, 2);
    // Gains 1, 3, 2, 2: mean 2.
    let taa = [21.0, 24.0, 24.0, 25.0];
    // Alone, `evaluate` cannot decide it: `judge` does, with the run.
    let r = moving("taa", &taa, vec![check(2.0, Some(0.0))]);
    assert_eq!(r.checks[0].passed, None, "{}", r.checks[0].detail);
    let (r, late) = gain(&taa, &check(2.0, Some(0.0)), &base);
    assert_eq!(r.passed, Some(true), "{}", r.detail);
    assert!(r.detail.contains("+2.00 dB"), "{}", r.detail);
    assert!(late.is_empty());
    // A mean under the bound fails.
    let (r, _) = gain(&taa, &check(2.1, None), &base);
    assert_eq!(r.passed, Some(false));
    // A frame from `from_frame` on below its floor fails, and is named
    // (`judge` lists the check among that frame's failures); one before it
    // does not count.
    let (r, late) = gain(&[19.0, 25.0, 24.5, 25.0], &check(1.0, Some(2.1)), &base);
    assert_eq!(r.passed, Some(false), "{}", r.detail);
    assert_eq!(r.frame, Some(3));
    assert!(r.detail.contains("frames [3]"), "{}", r.detail);
    assert_eq!(late, [3]);
    // A NaN PSNR fails.
    let (r, _) = gain(&[21.0, f64::NAN, 24.0, 25.0], &check(0.0, None), &base);
    assert_eq!(r.passed, Some(false));
    // A baseline that was not rendered fails and says so.
    let (r, _) = gain(&taa, &check(0.0, None), &[]);
    assert_eq!(r.passed, Some(false));
    assert!(r.detail.contains("noaa was not rendered"));
    // The label says both conditions.
    assert_eq!(
        gain_over("noaa", 2.0, Some(0.0), 16).label(),
        "mean PSNR gain over noaa >= 2 dB, each frame from 16 >= 0 dB"
    );
}

/// `judge` decides a gain check with the run's earlier scenes: a frame under
/// the per-frame floor lists it among its failures, and a scene whose only
/// check is a gain check is judged.
#[test]
fn judge_decides_a_gain_check_with_the_earlier_scenes() {
    let shifted = {
        let mut g = gradient();
        for p in g.pixels.iter_mut() {
            p[0] = p[0].saturating_add(3);
        }
        g
    };
    let psnr = judged(&[spec(Check::MinPsnr(0.0), None)], shifted.clone()).frames[0]
        .metrics
        .psnr;
    // The baseline is 1 dB better on frame 0.
    let base = [moving("noaa", &[psnr + 1.0], vec![])];
    let checks = [gain_over("noaa", -5.0, Some(0.0), 0)];
    let r = judged_after(&checks, shifted, &base);
    assert_eq!(r.checks[0].passed, Some(false), "{}", r.checks[0].detail);
    assert_eq!(r.frames[0].failed_checks, [0]);
    assert!(r.problems.is_empty(), "{:?}", r.problems);
}

#[test]
fn a_pixel_count_check_reads_its_own_count_and_a_fraction_is_read_back_exactly() {
    let mut f = frame(0, 60.0);
    f.pixels_over.insert(2, 7);
    let specs: Vec<_> = [7, 6]
        .map(|pixels| spec(Check::MaxPixelsOver { lsb: 2, pixels }, None))
        .into();
    let judged = [&f];
    let r = evaluate(&specs, 0, &judged, on("x"), &[], None);
    assert_eq!(r.passed, Some(true), "{}", r.detail);
    assert_eq!(r.detail, "worst pixels over 2 LSB 7 at frame 0");
    assert_eq!(
        evaluate(&specs, 1, &judged, on("x"), &[], None).passed,
        Some(false)
    );
    assert_eq!(specs[1].label(), "pixels over 2 LSB <= 6");
    // Not measured: NaN, which fails.
    let other = vec![spec(
        Check::MaxPixelsOver {
            lsb: 3,
            pixels: 100,
        },
        None,
    )];
    assert_eq!(
        evaluate(&other, 0, &judged, on("x"), &[], None).passed,
        Some(false)
    );
    // A count over a frame's pixels comes back from its fraction exactly.
    let frame =
        crate::image::Frame::Rgb8(crate::image::Image::from_fn(1921, 1081, |_, _| [0u8; 3]));
    for over in [0u64, 1, 7, 1_000_003, 1921 * 1081] {
        let fraction = over as f64 / (1921.0 * 1081.0);
        assert_eq!(super::pixels_of(fraction, &frame), over);
    }
}
