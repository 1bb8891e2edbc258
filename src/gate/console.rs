//! The console view of a check report: one line a scene, the failures with
//! their numbers and artifacts, stage times, regressions and a summary.

use super::CheckReport;
use crate::check::{FrameResult, Summary};
use std::fmt::Write;

fn fmt_metric(v: f64, decimals: usize) -> String {
    if v.is_infinite() {
        if v > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        }
    } else {
        format!("{v:.decimals$}")
    }
}

/// The report as the console prints it.
pub fn render(r: &CheckReport) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<36} {:<6} {:>6} {:>18} {:>8} {:>18} {:>8} {:>8}",
        "scene", "test", "frames", "PSNR dB worst@f", "mean", "SSIM worst@f", "mean", "checks"
    );
    for s in &r.scenes {
        let applied = s.checks.iter().filter(|c| c.passed.is_some()).count();
        let failed = s.failed_checks().count();
        let excused = !s.passed() && !s.fails_gate();
        let status = if excused {
            "xfail".to_string()
        } else if !s.problems.is_empty() {
            "FAIL".to_string()
        } else if failed == 0 {
            format!("{applied} ok")
        } else {
            format!("{failed} FAIL")
        };
        let (p, q) = (s.summary("psnr"), s.summary("ssim"));
        let worst = |m: Option<&Summary>, d: usize| {
            m.map(|m| format!("{} @{}", fmt_metric(m.worst, d), m.worst_frame))
                .unwrap_or_default()
        };
        let mean =
            |m: Option<&Summary>, d: usize| m.map(|m| fmt_metric(m.mean, d)).unwrap_or_default();
        let test = s.test.name();
        let _ = writeln!(
            out,
            "{:<36} {:<6} {:>6} {:>18} {:>8} {:>18} {:>8} {:>8}",
            s.scene,
            test,
            s.frames.len(),
            worst(p, 2),
            mean(p, 2),
            worst(q, 5),
            mean(q, 5),
            status
        );
        let word = if excused { "XFAIL" } else { "FAIL" };
        for p in &s.problems {
            let _ = writeln!(out, "    {word} {p}");
        }
        for c in s.failed_checks() {
            let _ = writeln!(out, "    {word} {}: {}", c.spec.label(), c.detail);
        }
        if let Some(e) = &s.expectation {
            let bug = e
                .bug
                .as_deref()
                .map(|b| format!(", {b}"))
                .unwrap_or_default();
            let line = match e.outcome.as_str() {
                "failed_as_expected" => {
                    format!("EXPECTED FAILURE on this adapter: {}{bug}", e.reason)
                }
                "flaky_failure" => format!(
                    "FLAKY on this adapter, failure tolerated: {}{bug}",
                    e.reason
                ),
                "unexpected_pass" => format!(
                    "UNEXPECTED PASS: expected to fail here ({}{bug}); remove the expectation",
                    e.reason
                ),
                _ => format!("flaky on this adapter ({}{bug}), passed", e.reason),
            };
            let _ = writeln!(out, "    {line}");
        }
        for x in &s.expired_expectations {
            let _ = writeln!(out, "    EXPIRED expectation, no longer applied: {x}");
        }
        let with_artifacts: Vec<&FrameResult> = s
            .frames
            .iter()
            .filter(|f| !f.artifacts.is_empty() && !f.failed_checks.is_empty())
            .collect();
        if let (Some(dir), Some(first)) = (&r.artifacts_dir, with_artifacts.first()) {
            let _ = writeln!(
                out,
                "    artifacts of {} failing frame(s) ({}) in {}, e.g. {}",
                with_artifacts.len(),
                with_artifacts
                    .iter()
                    .map(|f| f.frame.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                dir.display(),
                first.artifacts.join(" ")
            );
        }
    }
    if r.scenes.iter().any(|s| !s.timings.is_empty()) {
        let _ = writeln!(out, "\nGPU median ms per stage (FPS with readback):");
        for s in &r.scenes {
            let stages: Vec<String> = s
                .timings
                .iter()
                .map(|t| format!("{} {:.3}", t.name, t.median_ms))
                .collect();
            let _ = writeln!(
                out,
                "  {:<34} {} ({:.1} FPS)",
                s.scene,
                stages.join(", "),
                s.fps.unwrap_or(f64::NAN)
            );
        }
    }
    if !r.regressions.is_empty() {
        let verdict = if r.performance.fail_on_regression {
            "FAIL"
        } else {
            "flagged (not failing: the suite does not set fail_on_regression)"
        };
        let _ = writeln!(out, "\nperformance regressions, {verdict}:");
        for g in &r.regressions {
            let unit = if g.metric == "fps" { " FPS" } else { " ms" };
            let _ = writeln!(
                out,
                "  {} {}: {:.3}{unit} vs median {:.3}{unit} of {} runs (x{:.2}; bound {:.3}, MAD {:.3})",
                g.scene, g.metric, g.value, g.median, g.runs, g.ratio, g.bound, g.mad
            );
        }
    }
    if let Some(st) = &r.stress {
        let failing: Vec<&crate::stress::Row> = st.cases.iter().filter(|c| !c.passed).collect();
        let _ = writeln!(
            out,
            "\nstress suite: {} of {} rows passed; {}; `tonegate stress` prints the table",
            st.cases.len() - failing.len(),
            st.cases.len(),
            stress_worst(st)
        );
        for c in failing {
            let _ = writeln!(
                out,
                "    FAIL {} on {}: finite {}, max rel {:?}, {}",
                c.name, c.renderer, c.finite, c.max_rel_error, c.observed
            );
        }
    }
    let failed = r.scenes_failed();
    let expected = r.scenes_failed_as_expected();
    let failed_text = match (failed, expected) {
        (f, 0) => format!("{f} failed"),
        (f, e) if f == e => format!("{f} failed as expected"),
        (f, e) => format!("{} failed, {e} more as expected", f - e),
    };
    let _ = writeln!(
        out,
        "\n{}: {} of {} scenes passed, {}, {} regressions; adapter {} ({}, {}); renderer {}",
        if r.passed { "PASSED" } else { "FAILED" },
        r.scenes.len() - failed,
        r.scenes.len(),
        failed_text,
        r.regressions.len(),
        r.adapter.name,
        r.adapter.backend,
        r.adapter.driver_info,
        renderer_words(&r.renderer)
    );
    let _ = writeln!(out, "adapter chosen: {}", r.adapter.chosen);
    if let (Some(id), Some(db)) = (r.run_id, &r.db) {
        let _ = writeln!(out, "recorded as run {id} in {}", db.display());
    }
    if let Some(first) = r.artifacts_pending.first() {
        let _ = writeln!(
            out,
            "WARNING: {} artifact(s) kept in the history, pending: {}; \
             `tonegate history pending --upload` sends them to the store",
            r.artifacts_pending.len(),
            first.reason
        );
    }
    let _ = writeln!(out, "{}", r.phases.line());
    let _ = writeln!(out, "SSIM: {}", r.ssim_definition);
    let _ = writeln!(out, "FLIP: {}", r.flip_definition);
    out
}

/// The worst statistics error among the rows held to the generic bound, and
/// apart from it each row held to a documented exception, with its bound:
/// one figure next to one bound would mix the two.
fn stress_worst(st: &crate::stress::StressReport) -> String {
    let worst = |excepted: bool| {
        st.cases
            .iter()
            .filter(|c| c.exception.is_some() == excepted)
            .filter_map(|c| Some((c.max_rel_error?, c)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    };
    let mut s = match worst(false) {
        Some((e, c)) => format!(
            "worst statistics error {e:.2e} ({} on {}; bound {:e})",
            c.name, c.renderer, st.bound
        ),
        None => "no statistics compared".to_string(),
    };
    let excepted: Vec<&crate::stress::Row> =
        st.cases.iter().filter(|c| c.exception.is_some()).collect();
    if !excepted.is_empty() {
        let (e, c) = worst(true).map_or((0.0, excepted[0]), |(e, c)| (e, c));
        s.push_str(&format!(
            "; {} row(s) under the subnormal-flush exception (the probe found this adapter flushing), worst {e:.2e} ({} on {}; bound {:e})",
            excepted.len(),
            c.name,
            c.renderer,
            c.bound
        ));
    }
    s
}

/// The renderer's knobs as words (`execution staged, hdr_format
/// rgba32_float, …`), without the adapter's choice, which has a line of
/// its own; a fault's value at the precision it was given.
fn renderer_words(renderer: &serde_json::Value) -> String {
    let Some(knobs) = renderer.as_object() else {
        return renderer.to_string();
    };
    knobs
        .iter()
        .filter(|(k, _)| k.as_str() != "adapter_chosen")
        .map(|(k, v)| {
            let v = match v {
                serde_json::Value::String(s) => s.clone(),
                // Knobs are f32 on the GPU: shown as the f32 they are.
                serde_json::Value::Number(n) => match n.as_f64() {
                    Some(x) if n.is_f64() => format!("{}", x as f32),
                    _ => n.to_string(),
                },
                other => other.to_string(),
            };
            format!("{k} {v}")
        })
        .collect::<Vec<_>>()
        .join(", ")
}
