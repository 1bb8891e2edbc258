//! Expectations per device, as data: a scene says it is known to fail, or to
//! fail now and then, on adapters (and drivers) matching a pattern, with the
//! reason, a bug link and an optional expiry date, as Chromium's and wgpu's
//! test expectations do. A failure so expected does not fail the gate but is
//! shown as such; an expected failure that passes is reported so the line
//! gets removed; an expired expectation stops applying and says so.

use serde::{Deserialize, Serialize};

/// What is expected of a scene on the adapters an expectation names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Expected {
    /// Fails every time: a failure is expected, a pass is news.
    ExpectedFail,
    /// Fails sometimes: a failure is tolerated, a pass is normal.
    Flaky,
}

impl Expected {
    pub fn name(self) -> &'static str {
        match self {
            Expected::ExpectedFail => "expected_fail",
            Expected::Flaky => "flaky",
        }
    }
}

/// One line of a scene's `[[expectations]]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expectation {
    /// A substring of the adapter name, any case (`"NVIDIA"`, `"llvmpipe"`).
    pub adapter: String,
    /// A substring of the driver and its version, any case (`"580."`); any
    /// driver when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub driver: Option<String>,
    pub status: Expected,
    /// Why: what is wrong on that device.
    pub reason: String,
    /// Where it is tracked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bug: Option<String>,
    /// Stops applying after this day (YYYY-MM-DD, UTC).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expires: Option<String>,
}

/// How an expectation met a scene's result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExpectationOutcome {
    pub status: Expected,
    pub reason: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bug: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub expires: Option<String>,
    /// `failed_as_expected`, `flaky_failure`, `passed` (flaky, normal) or
    /// `unexpected_pass` (an expected failure passed: remove the expectation).
    pub outcome: String,
}

impl Expectation {
    /// Checks the fields a scene file gave; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        if self.adapter.trim().is_empty() {
            return Err("adapter: give a substring of the adapter name".into());
        }
        if self.reason.trim().is_empty() {
            return Err("reason: say why it fails there".into());
        }
        if let Some(d) = &self.expires {
            if chrono::NaiveDate::parse_from_str(d, "%Y-%m-%d").is_err() {
                return Err(format!("expires: a date as YYYY-MM-DD, got {d:?}"));
            }
        }
        Ok(())
    }

    /// Whether it names this adapter and driver.
    pub fn matches(&self, adapter: &str, driver: &str) -> bool {
        let has = |hay: &str, needle: &str| hay.to_lowercase().contains(&needle.to_lowercase());
        has(adapter, &self.adapter) && self.driver.as_deref().is_none_or(|d| has(driver, d))
    }

    /// Whether it has expired on `today` (YYYY-MM-DD): it applies through its
    /// `expires` day and not after.
    pub fn expired(&self, today: &str) -> bool {
        self.expires.as_deref().is_some_and(|d| today > d)
    }
}

/// The expectation that applies to a scene on this adapter and driver today
/// (the first matching one that has not expired), and the matching ones that
/// have expired (reported, so they get renewed or removed).
pub fn applicable<'a>(
    expectations: &'a [Expectation],
    adapter: &str,
    driver: &str,
    today: &str,
) -> (Option<&'a Expectation>, Vec<&'a Expectation>) {
    let matching = expectations.iter().filter(|e| e.matches(adapter, driver));
    let (expired, live): (Vec<_>, Vec<_>) = matching.partition(|e| e.expired(today));
    (live.into_iter().next(), expired)
}

/// What an applying expectation makes of a scene that `passed` or not.
pub fn outcome(e: &Expectation, passed: bool) -> ExpectationOutcome {
    let outcome = match (e.status, passed) {
        (Expected::ExpectedFail, false) => "failed_as_expected",
        (Expected::ExpectedFail, true) => "unexpected_pass",
        (Expected::Flaky, false) => "flaky_failure",
        (Expected::Flaky, true) => "passed",
    };
    ExpectationOutcome {
        status: e.status,
        reason: e.reason.clone(),
        bug: e.bug.clone(),
        expires: e.expires.clone(),
        outcome: outcome.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(
        adapter: &str,
        driver: Option<&str>,
        status: Expected,
        expires: Option<&str>,
    ) -> Expectation {
        Expectation {
            adapter: adapter.into(),
            driver: driver.map(Into::into),
            status,
            reason: "r".into(),
            bug: None,
            expires: expires.map(Into::into),
        }
    }

    #[test]
    fn an_expectation_matches_adapter_and_driver_substrings_until_it_expires() {
        let list = [
            e(
                "nvidia",
                Some("580."),
                Expected::ExpectedFail,
                Some("2026-12-31"),
            ),
            e("NVIDIA", None, Expected::Flaky, None),
            e("llvmpipe", None, Expected::ExpectedFail, Some("2026-01-01")),
        ];
        let h100 = "NVIDIA H100 80GB HBM3";
        let (live, expired) = applicable(&list, h100, "580.159.04", "2026-11-23");
        assert_eq!(live, Some(&list[0]));
        assert!(expired.is_empty());
        // The last day still applies; the day after, the next match does.
        assert_eq!(
            applicable(&list, h100, "580.1", "2026-12-31").0,
            Some(&list[0])
        );
        let (live, expired) = applicable(&list, h100, "580.1", "2027-01-01");
        assert_eq!((live, expired), (Some(&list[1]), vec![&list[0]]));
        // Another driver: only the driver-free line.
        assert_eq!(
            applicable(&list, h100, "575.0", "2026-11-23").0,
            Some(&list[1])
        );
        // Expired and nothing else: none applies, and it is reported.
        let (live, expired) = applicable(&list, "llvmpipe (LLVM 15.0.6)", "Mesa", "2026-11-23");
        assert_eq!((live, expired.len()), (None, 1));
        assert_eq!(outcome(&list[0], true).outcome, "unexpected_pass");
        assert_eq!(outcome(&list[0], false).outcome, "failed_as_expected");
        assert_eq!(outcome(&list[1], false).outcome, "flaky_failure");
    }

    #[test]
    fn bad_fields_are_named() {
        let mut x = e("", None, Expected::Flaky, None);
        assert!(x.validate().unwrap_err().starts_with("adapter"));
        x.adapter = "a".into();
        x.expires = Some("31/12/2026".into());
        assert!(x.validate().unwrap_err().starts_with("expires"));
        x.expires = Some("2026-12-31".into());
        assert!(x.validate().is_ok());
    }
}
