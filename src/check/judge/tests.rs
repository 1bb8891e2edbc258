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
