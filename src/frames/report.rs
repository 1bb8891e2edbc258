//! What a submission answers: a verdict a frame, the figures against the
//! positive it was judged by, as JSON and JUnit, and the exit code CI
//! reads (0 passed, 1 failed, 2 the submission could not be judged).

use super::names::clip;
use super::FramesError;
use crate::history::{HistoryError, StoredSubmission};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Where a frame's digest stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Its digest is a positive of its test.
    Positive,
    /// Untriaged, but within its test's rules of a positive.
    Matched,
    /// Its digest is a negative of its test.
    Negative,
    /// Nobody has said, and no positive is near enough.
    Untriaged,
    /// It would have failed, and an ignore rule covers its test.
    Ignored,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Positive => "positive",
            Status::Matched => "matched",
            Status::Negative => "negative",
            Status::Untriaged => "untriaged",
            Status::Ignored => "ignored",
        }
    }
}

/// The positive a frame was held to, and how far it was.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Closest {
    pub digest: String,
    /// Each figure computed, by its check's name (`psnr`, `max_abs_diff`,
    /// `hdr_flip_mean`, …).
    pub figures: BTreeMap<String, f64>,
    /// The rules it broke, as `PSNR >= 45 dB (was 38.2)`.
    pub failed: Vec<String>,
}

/// One frame's verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameVerdict {
    pub test: String,
    pub file: String,
    pub digest: String,
    pub status: Status,
    pub passed: bool,
    /// An untriaged digest passed under `untriaged = "warn"`.
    pub warning: bool,
    /// The positive it matched or came closest to, when the test has one
    /// and the two could be compared.
    pub closest: Option<Closest>,
    /// In words: why it passed or failed.
    pub detail: String,
}

/// A submission's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SubmissionReport {
    /// Its id in the history (the first submission's, for a retry under
    /// the same idempotency key).
    pub submission: i64,
    pub keys: BTreeMap<String, String>,
    /// The branch its frames were judged on: the main line's name, or the
    /// `branch` key's (which falls back to the main line's triage).
    pub branch: String,
    pub passed: bool,
    pub frames: Vec<FrameVerdict>,
    /// Frames whose digests nobody has triaged.
    pub untriaged: usize,
    /// The digests of its images the object store did not take, kept in
    /// the history, pending (`history pending --upload` offers them again).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pending_images: Vec<String>,
    /// Tests the last submission of the same trace on the same branch had
    /// and this one has not, and that submission.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vanished: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vanished_since: Option<i64>,
    /// Whether the vanished tests fail the submission (`vanished = "fail"`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub vanished_fail: bool,
}

impl SubmissionReport {
    pub fn new(
        keys: BTreeMap<String, String>,
        branch: String,
        frames: Vec<FrameVerdict>,
    ) -> SubmissionReport {
        SubmissionReport {
            submission: 0,
            keys,
            branch,
            passed: frames.iter().all(|f| f.passed),
            untriaged: frames
                .iter()
                .filter(|f| f.status == Status::Untriaged)
                .count(),
            frames,
            pending_images: Vec::new(),
            vanished: Vec::new(),
            vanished_since: None,
            vanished_fail: false,
        }
    }

    /// 0 when every frame passed, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        if self.passed {
            0
        } else {
            1
        }
    }

    /// One line a frame that did not simply pass, then a summary.
    pub fn console(&self) -> String {
        let mut out = String::new();
        for f in &self.frames {
            let mark = match (f.passed, f.warning) {
                (true, false) if f.status == Status::Positive => continue,
                (true, false) => "ok  ",
                (true, true) => "WARN",
                (false, _) => "FAIL",
            };
            // The digest whole: what `frames triage --digest` takes.
            out.push_str(&format!(
                "{mark} {} ({}, digest {}): {}\n",
                f.test,
                f.status.as_str(),
                f.digest,
                f.detail
            ));
        }
        if let (false, Some(since)) = (self.vanished.is_empty(), self.vanished_since) {
            out.push_str(&format!(
                "VANISHED {} test{} submission {since} had: {}\n",
                self.vanished.len(),
                if self.vanished.len() == 1 { "" } else { "s" },
                self.vanished.join(", ")
            ));
        }
        let failed = self.frames.iter().filter(|f| !f.passed).count();
        out.push_str(&format!(
            "submission {}: {} frames, {} failed, {} untriaged: {}\n",
            self.submission,
            self.frames.len(),
            failed,
            self.untriaged,
            if self.passed { "PASSED" } else { "FAILED" }
        ));
        out
    }

    /// A Markdown summary for a CI job's summary page or a pull request's
    /// comment: the verdict, then a row per frame that did not simply pass
    /// (its test, status, digest, what was found), and the triage page's
    /// link when the submission is on a server (`triage`).
    pub fn markdown(&self, triage: Option<&str>) -> String {
        let failed = self.frames.iter().filter(|f| !f.passed).count();
        let mut out = format!(
            "### tonegate frames: {}\n\nSubmission {}: {} frames, {failed} failed, {} untriaged.\n",
            if self.passed { "passed" } else { "FAILED" },
            self.submission,
            self.frames.len(),
            self.untriaged,
        );
        if let Some(link) = triage {
            out.push_str(&format!("Triage them at <{link}>.\n"));
        }
        if let (false, Some(since)) = (self.vanished.is_empty(), self.vanished_since) {
            let names: Vec<String> = self.vanished.iter().map(|t| format!("`{t}`")).collect();
            out.push_str(&format!(
                "\nVanished since submission {since}: {}.\n",
                names.join(", ")
            ));
        }
        let cell = |t: &str| t.replace('|', "\\|").replace('\n', " ");
        let rows: Vec<&FrameVerdict> = self
            .frames
            .iter()
            .filter(|f| !f.passed || f.warning || f.status == Status::Ignored)
            .collect();
        if !rows.is_empty() {
            out.push_str("\n| test | status | digest | what was found |\n|---|---|---|---|\n");
            for f in rows {
                let status = match (f.passed, f.warning) {
                    (false, _) => format!("**{}** (fails)", f.status.as_str()),
                    (true, true) => format!("{} (warning)", f.status.as_str()),
                    _ => f.status.as_str().to_owned(),
                };
                out.push_str(&format!(
                    "| `{}` | {status} | `{}` | {} |\n",
                    cell(&f.test),
                    &f.digest[..f.digest.len().min(12)],
                    cell(&f.detail)
                ));
            }
        }
        out
    }

    /// JUnit XML: one suite, one test case a frame.
    pub fn junit(&self) -> Result<String, quick_junit::SerializeError> {
        use quick_junit::{NonSuccessKind, Report, TestCase, TestCaseStatus, TestSuite};
        let mut report = Report::new("tonegate frames");
        let mut suite = TestSuite::new("frames");
        for (k, v) in &self.keys {
            suite.add_property((k.as_str(), v.as_str()));
        }
        for f in &self.frames {
            let status = if f.passed {
                TestCaseStatus::success()
            } else {
                let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
                s.set_message(f.detail.clone());
                s
            };
            let mut case = TestCase::new(f.test.clone(), status);
            case.set_classname("tonegate.frames");
            // A warning passes, and says so where a CI's test view shows it.
            let warned = if f.warning { "WARNING (passes): " } else { "" };
            case.set_system_out(format!(
                "{warned}{} {} {}: {}",
                f.file,
                f.digest,
                f.status.as_str(),
                f.detail
            ));
            if f.warning {
                case.set_system_err(format!("WARNING: {}: {}", f.test, f.detail));
            }
            suite.add_test_case(case);
        }
        // A vanished test is a case too: failed under `vanished = "fail"`,
        // skipped otherwise, so a CI's test view shows it either way.
        for test in &self.vanished {
            let why = format!(
                "vanished: submission {} had it, this one has not",
                self.vanished_since.unwrap_or_default()
            );
            let mut status = match self.vanished_fail {
                true => TestCaseStatus::non_success(NonSuccessKind::Failure),
                false => TestCaseStatus::skipped(),
            };
            status.set_message(why);
            let mut case = TestCase::new(test.clone(), status);
            case.set_classname("tonegate.frames");
            suite.add_test_case(case);
        }
        report.add_test_suite(suite);
        report.to_string()
    }
}

/// How a submission of `keys` and `digests` (test → digest) differs from
/// the one `first` reports, in words; None when it is the same.
pub fn difference(
    first: &SubmissionReport,
    keys: &BTreeMap<String, String>,
    digests: &BTreeMap<&str, &str>,
) -> Option<String> {
    if &first.keys != keys {
        let shown = |k: &BTreeMap<String, String>| {
            let pairs: Vec<String> = k.iter().map(|(n, v)| format!("{n}={v}")).collect();
            format!("[{}]", pairs.join(", "))
        };
        let (was, now) = (shown(&first.keys), shown(keys));
        return Some(format!(
            "its keys were {} and are now {}",
            clip(&was, 48),
            clip(&now, 48)
        ));
    }
    let before: BTreeMap<&str, &str> = first
        .frames
        .iter()
        .map(|f| (f.test.as_str(), f.digest.as_str()))
        .collect();
    for (test, digest) in digests {
        match before.get(test) {
            None => return Some(format!("test {} is new", clip(test, 48))),
            Some(d) if d != digest => {
                return Some(format!(
                    "test {}'s frame was {} and is now {}",
                    clip(test, 48),
                    &d[..d.len().min(12)],
                    &digest[..digest.len().min(12)]
                ))
            }
            Some(_) => {}
        }
    }
    before
        .keys()
        .find(|t| !digests.contains_key(*t))
        .map(|t| format!("test {} is missing", clip(t, 48)))
}

/// The report a stored submission answered with.
pub fn stored(s: &StoredSubmission) -> Result<SubmissionReport, FramesError> {
    let mut report: SubmissionReport = serde_json::from_str(&s.report)
        .map_err(|e| HistoryError::Invalid(format!("submission {}'s stored report: {e}", s.id)))?;
    report.submission = s.id;
    Ok(report)
}
