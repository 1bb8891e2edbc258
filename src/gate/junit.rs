//! JUnit XML of a check report, the format CI systems render: one test suite
//! a scene, one test case a check, failures with their numbers and the
//! artifact paths; performance regressions in a suite of their own.

use super::CheckReport;
use quick_junit::{NonSuccessKind, Report, TestCase, TestCaseStatus, TestSuite};

pub fn render(r: &CheckReport) -> Result<String, quick_junit::SerializeError> {
    let mut report = Report::new("tonegate check");
    for s in &r.scenes {
        let mut suite = TestSuite::new(s.scene.clone());
        suite.add_property(("adapter", r.adapter.name.as_str()));
        suite.add_property(("adapter_chosen", r.adapter.chosen.as_str()));
        suite.add_property(("test", s.test.name()));
        let classname = format!("tonegate.{}", s.scene);
        // A failure an expectation on this adapter allows is reported as
        // skipped with the expectation's words, not as a failure.
        let excused = s
            .expectation
            .as_ref()
            .filter(|e| matches!(e.outcome.as_str(), "failed_as_expected" | "flaky_failure"));
        let excuse = excused.map(|e| {
            format!(
                "{} on {}: {}{}",
                e.status.name(),
                r.adapter.name,
                e.reason,
                e.bug
                    .as_deref()
                    .map(|b| format!(" ({b})"))
                    .unwrap_or_default()
            )
        });
        if let Some(e) = &s.expectation {
            suite.add_property(("expectation", e.status.name()));
            suite.add_property(("expectation_outcome", e.outcome.as_str()));
            if e.outcome == "unexpected_pass" {
                let mut case = TestCase::new("expectation", TestCaseStatus::success());
                case.set_classname(classname.clone());
                case.set_system_out(format!(
                    "UNEXPECTED PASS: the scene passed on {} although expected to fail ({}); remove the expectation",
                    r.adapter.name, e.reason
                ));
                suite.add_test_case(case);
            }
        }
        for x in &s.expired_expectations {
            let mut case = TestCase::new("expired expectation", TestCaseStatus::success());
            case.set_classname(classname.clone());
            case.set_system_out(format!("EXPIRED (no longer applied): {x}"));
            suite.add_test_case(case);
        }
        for p in &s.problems {
            let mut status = TestCaseStatus::non_success(NonSuccessKind::Failure);
            status.set_message(p.clone());
            let mut case = TestCase::new("scene", status);
            case.set_classname(classname.clone());
            suite.add_test_case(case);
        }
        for (i, c) in s.checks.iter().enumerate() {
            let status = match c.passed {
                Some(true) => TestCaseStatus::success(),
                None => {
                    let mut st = TestCaseStatus::skipped();
                    st.set_message(c.detail.clone());
                    st
                }
                Some(false) if excuse.is_some() => {
                    let mut st = TestCaseStatus::skipped();
                    st.set_message(format!(
                        "{} [{}]",
                        excuse.clone().unwrap_or_default(),
                        c.detail
                    ));
                    st
                }
                Some(false) => {
                    let mut st = TestCaseStatus::non_success(NonSuccessKind::Failure);
                    let mut description = format!("{}\n", c.detail);
                    if let Some(set_by) = &c.spec.set_by {
                        description.push_str(&format!("bound set by: {set_by}\n"));
                    }
                    for f in s.frames.iter().filter(|f| f.failed_checks.contains(&i)) {
                        let m = &f.metrics;
                        description.push_str(&format!(
                            "frame {}: PSNR {:.2} dB, SSIM {:.5}, MSE {:.4}, max abs diff {}, FLIP mean {:.5}",
                            f.frame, m.psnr, m.ssim, m.mse, m.max_abs_diff, m.flip_mean
                        ));
                        if let Some(dir) = &r.artifacts_dir {
                            for a in &f.artifacts {
                                description.push_str(&format!(" {}", dir.join(a).display()));
                            }
                        }
                        description.push('\n');
                    }
                    st.set_message(c.detail.clone());
                    st.set_type(c.spec.check.kind());
                    st.set_description(description);
                    st
                }
            };
            let mut case = TestCase::new(c.spec.label(), status);
            case.set_classname(classname.clone());
            suite.add_test_case(case);
        }
        report.add_test_suite(suite);
    }
    if let Some(st) = &r.stress {
        let mut suite = TestSuite::new("stress");
        for c in &st.cases {
            let status = if c.passed {
                TestCaseStatus::success()
            } else {
                let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
                s.set_message(format!(
                    "finite {}, max rel error {:?} (bound {:e}): {}",
                    c.finite, c.max_rel_error, c.bound, c.observed
                ));
                s.set_description(c.behaviour.clone());
                s
            };
            let mut case = TestCase::new(format!("{} [{}]", c.name, c.renderer), status);
            case.set_classname("tonegate.stress");
            suite.add_test_case(case);
        }
        report.add_test_suite(suite);
    }
    let mut perf = TestSuite::new("performance");
    for g in &r.regressions {
        let message = format!(
            "{} {}: {:.3} vs median {:.3} of {} runs on this adapter (bound {:.3}, MAD {:.3}, x{:.2})",
            g.scene, g.metric, g.value, g.median, g.runs, g.bound, g.mad, g.ratio
        );
        let mut case = if r.performance.fail_on_regression {
            let mut st = TestCaseStatus::non_success(NonSuccessKind::Failure);
            st.set_message(message);
            st.set_type("performance_regression");
            TestCase::new(format!("regression {} {}", g.scene, g.metric), st)
        } else {
            let mut case = TestCase::new(
                format!("regression {} {}", g.scene, g.metric),
                TestCaseStatus::success(),
            );
            case.set_system_out(format!(
                "flagged, not failing (fail_on_regression = false): {message}"
            ));
            case
        };
        case.set_classname("tonegate.performance");
        perf.add_test_case(case);
    }
    if !r.regressions.is_empty() {
        report.add_test_suite(perf);
    }
    report.to_string()
}

/// JUnit for a run that could not happen: one errored test case, so CI shows
/// the reason instead of a missing report.
pub fn render_error(message: &str) -> Result<String, quick_junit::SerializeError> {
    let mut report = Report::new("tonegate check");
    let mut suite = TestSuite::new("tonegate");
    let mut status = TestCaseStatus::non_success(NonSuccessKind::Error);
    status.set_message(message.to_owned());
    let mut case = TestCase::new("run", status);
    case.set_classname("tonegate");
    suite.add_test_case(case);
    report.add_test_suite(suite);
    report.to_string()
}
