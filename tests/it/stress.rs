//! The extreme inputs of docs/stress.md, every case on both renderers: finite, within
//! 1e-5 of f64 (or a documented exception's bound), refused where it must be,
//! and each defined fallback actually taken.

use tonegate::gpu::{AdapterChoice, GpuContext, ReductionMethod};
use tonegate::stress::{self, Row, StressReport};

fn report() -> &'static StressReport {
    static REPORT: std::sync::OnceLock<StressReport> = std::sync::OnceLock::new();
    REPORT.get_or_init(|| {
        let ctx = GpuContext::new(&AdapterChoice::default())
            .expect("lavapipe (mesa-vulkan-drivers) is installed");
        stress::run(&stress::cases::all(true), Some(&ctx), ReductionMethod::Auto)
    })
}

fn rows(case: &str, renderer: &str) -> Vec<&'static Row> {
    let r: Vec<&Row> = report()
        .cases
        .iter()
        .filter(|r| r.case == case && r.renderer == renderer)
        .collect();
    let case = stress::cases::all(true)
        .into_iter()
        .find(|c| c.name == case)
        .expect("a case of the suite");
    let through: Vec<String> = stress::case_pipelines(&case)
        .into_iter()
        .map(|(name, _)| name)
        .collect();
    let got: Vec<&str> = r.iter().map(|row| row.pipeline.as_str()).collect();
    assert_eq!(
        got, through,
        "{} on {renderer}: one row per pipeline it goes through",
        case.name
    );
    r
}

/// The 8.4 Mpx case goes through the pipelines that measure statistics,
/// every other case through every pipeline.
#[test]
fn only_the_large_case_skips_the_pipelines_that_measure_nothing() {
    let all = stress::pipelines();
    let measuring: Vec<&str> = all
        .iter()
        .filter(|(_, s)| stress::measures_statistics(s))
        .map(|(n, _)| n.as_str())
        .collect();
    // The Reinhard set-ups measure their key; the fixed operators nothing.
    for name in ["reinhard_global", "auto_key_bloom_grade", "reinhard02"] {
        assert!(measuring.contains(&name), "{measuring:?}");
    }
    for name in ["hable", "aces2", "bt2390"] {
        assert!(!measuring.contains(&name), "{measuring:?}");
    }
    for case in stress::cases::all(true) {
        let n = stress::case_pipelines(&case).len();
        if case.name == "large_4096x2048" {
            assert_eq!(n, measuring.len(), "{}", case.name);
        } else {
            assert_eq!(n, all.len(), "{}", case.name);
        }
    }
}

/// The rows of the two Reinhard set-ups, which measure a key and an
/// adaptation luminance.
fn reinhard_rows(case: &str, renderer: &str) -> Vec<&'static Row> {
    rows(case, renderer)
        .into_iter()
        .filter(|r| r.pipeline == "reinhard_global" || r.pipeline == "auto_key_bloom_grade")
        .collect()
}

#[test]
fn every_case_runs_on_both_renderers_and_holds_its_bound() {
    let r = report();
    for case in stress::cases::all(true) {
        for renderer in ["cpu", "gpu"] {
            for row in rows(case.name, renderer) {
                assert!(row.finite, "{} on {renderer}: non-finite output", row.name);
                assert!(row.passed, "{} on {renderer}: {row:?}", row.name);
                if let Some(e) = row.max_rel_error {
                    assert!(
                        e <= row.bound,
                        "{} on {renderer}: {e:e} > {:e}",
                        row.name,
                        row.bound
                    );
                }
            }
        }
    }
    assert!(r.passed);
    // Only documented exceptions may use a wider bound than 1e-5.
    for row in &r.cases {
        assert!(
            row.bound == stress::BOUND || row.exception.is_some(),
            "{row:?}"
        );
    }
}

#[test]
fn the_documented_fallbacks_are_taken_on_both_renderers() {
    for renderer in ["cpu", "gpu"] {
        // A + B = 0 in the automatic key: 0.18.
        let uniform = reinhard_rows("uniform", renderer);
        assert!(
            uniform.iter().all(|r| r.observed.starts_with("key 0.1800")),
            "{uniform:?}"
        );
        // Σw = 0: the weighted mean falls back to the plain log-average, delta.
        let zero = reinhard_rows("weights_sum_zero", renderer);
        assert!(
            zero.iter()
                .all(|r| r.observed.contains("adaptation 1.0000e-4")),
            "{zero:?}"
        );
        // NaN/Inf: refused without --sanitize, with count and coordinate.
        for r in rows("nan_inf_refused", renderer) {
            assert!(
                r.observed.contains("3 non-finite values") && r.observed.contains("(7, 5)"),
                "{r:?}"
            );
            assert_eq!(r.max_rel_error, None);
        }
        for r in rows("nan_inf_sanitized", renderer) {
            assert!(r.max_rel_error.is_some(), "{r:?}");
        }
    }
    for r in rows("nan_inf_sanitized", "cpu") {
        assert!(r.observed.contains("3 NaN/Inf components zeroed"), "{r:?}");
    }
    for r in rows("negative_values", "cpu") {
        assert!(r.observed.contains("negative components clamped"), "{r:?}");
    }
}

#[test]
fn f16_overflow_is_detected_and_promoted_and_oversize_is_refused_by_the_gpu_only() {
    for r in rows("beyond_f16_with_f16", "gpu") {
        assert!(r.observed.contains("promoted to rgba32float"), "{r:?}");
        assert!(r.max_rel_error.unwrap() <= stress::BOUND);
    }
    for r in rows("beyond_texture_limit", "gpu") {
        assert!(
            r.observed.contains("exceeds the adapter's texture limit"),
            "{r:?}"
        );
    }
    for r in rows("beyond_texture_limit", "cpu") {
        assert!(r.max_rel_error.is_some(), "{r:?}");
    }
}

#[test]
fn the_gpu_frames_match_the_cpu_frames_on_extreme_inputs() {
    // The frame, not just the statistics: at most 2 LSB (the GPU-vs-CPU
    // tolerance of docs/tolerances.md) wherever both rendered.
    for row in report().cases.iter().filter(|r| r.renderer == "gpu") {
        if row.max_rel_error.is_some() {
            // Every GPU row that rendered has a frame to compare (a 1x1
            // frame once came back with the readback buffer's padding as
            // three extra pixels).
            let lsb = row
                .max_lsb_vs_cpu
                .unwrap_or_else(|| panic!("{}: no frame compared", row.name));
            assert!(lsb <= 2, "{}: {lsb} LSB", row.name);
        }
    }
}

#[test]
fn the_independent_statistics_catch_a_wrong_sum() {
    // The CPU rows compare against `independent_stats`; it must see an error.
    let img = tonegate::image::LinearImage::from_fn(16, 16, |x, y| {
        let v = 0.1 + (x + 16 * y) as f64;
        [v, v, v]
    });
    let weights = tonegate::color::BT709;
    let good = stress::independent_stats(&img, weights, 1e-4);
    let mut bad = img.clone();
    bad.pixels[0] = [1.0, 1.0, 1.0];
    let other = stress::independent_stats(&bad, weights, 1e-4);
    assert_ne!(good.log_average, other.log_average);
}

/// The workgroup trees (what `--reduction auto` runs on a GPU: in shared
/// memory, and with subgroup shuffles where the adapter has them) on the
/// cases whose statistics stress a reduction: every size edge, the 8.4 Mpx
/// frame, 60 decades and subnormals, held to the same bounds here on
/// llvmpipe (which has subgroup operations, with 8-wide subgroups).
#[test]
fn the_workgroup_tree_holds_every_bound_on_the_reduction_cases() {
    let ctx = GpuContext::new(&AdapterChoice::default()).expect("lavapipe is installed");
    let names = [
        "size_1x1",
        "size_1xN",
        "size_Nx1",
        "size_prime_127x131",
        "large_4096x2048",
        "span_1e-30_to_1e30",
        "subnormals",
        "single_bright_pixel",
        "all_black",
    ];
    let cases: Vec<_> = stress::cases::all(true)
        .into_iter()
        .filter(|c| names.contains(&c.name))
        .collect();
    assert_eq!(cases.len(), names.len());
    assert!(ctx.subgroups, "{}", ctx.adapter.name);
    // Both trees against one CPU render of each case.
    let methods = [ReductionMethod::Tree, ReductionMethod::SubgroupTree];
    let reports = stress::run_reductions(&cases, Some(&ctx), &methods);
    assert_eq!(reports.len(), methods.len());
    for (method, report) in methods.into_iter().zip(reports) {
        for row in report.cases.iter().filter(|r| r.renderer == "gpu") {
            assert!(row.finite && row.passed, "{method:?} {row:?}");
            if let Some(e) = row.max_rel_error {
                assert!(
                    e <= row.bound,
                    "{method:?} {}: {e:e} > {:e}",
                    row.name,
                    row.bound
                );
            }
        }
        assert!(report.passed, "{method:?}");
    }
}

/// Rows run several at a time give the table one at a time gives: the same
/// rows in the same order with the same figures (times aside). Two GPU
/// rows in flight at once share the device, its pipeline cache and its map
/// callbacks: a row that read another's results, or a map outcome lost to
/// another thread's poll (which failed the 8.4 Mpx rows before `collect`
/// waited for it), shows here.
#[test]
fn rows_run_at_once_give_the_table_one_at_a_time_gives() {
    let ctx = GpuContext::new(&AdapterChoice::default())
        .expect("lavapipe (mesa-vulkan-drivers) is installed");
    let cases = stress::cases::all(false);
    let one = stress::run_jobs(&cases, Some(&ctx), &[ReductionMethod::Auto], 1);
    let four = stress::run_jobs(&cases, Some(&ctx), &[ReductionMethod::Auto], 4);
    let (one, four) = (&one[0], &four[0]);
    assert_eq!((one.jobs, four.jobs), (1, 4));
    assert_eq!(one.cases.len(), cases.len() * stress::pipelines().len() * 2);
    assert_eq!(one.cases.len(), four.cases.len());
    for (a, b) in one.cases.iter().zip(&four.cases) {
        let key = |r: &Row| {
            (
                r.name.clone(),
                r.renderer.clone(),
                r.finite,
                r.max_rel_error.map(f64::to_bits),
                r.max_lsb_vs_cpu,
                r.observed.clone(),
                r.passed,
            )
        };
        assert_eq!(key(a), key(b));
    }
    assert!(four.passed, "{}", stress::table(four));
}
