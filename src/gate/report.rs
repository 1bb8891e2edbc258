//! What a check run gives: its report (which the console, the JSON and the
//! JUnit are views of), the adapter it names, the part of a stored report
//! the server reads back, and how the run ended.

use super::{CheckError, Phases};
use crate::check::SceneResult;
use crate::history::Regression;
use crate::suite::Performance;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The adapter (or CPU reference) the run used, as every result records it.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AdapterInfo {
    pub name: String,
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    /// Why this adapter was tested (see `gpu::choose`).
    pub chosen: String,
    /// Whether it flushes f32 subnormals, as the probe measured (`None`: the
    /// CPU reference).
    pub flushes_subnormals: Option<bool>,
    /// How its compiler evaluated the probe's divisions
    /// (docs/stress.md#range-safe-arithmetic; `None`: the CPU reference).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub division: Option<String>,
}

/// Everything a check run found; the console, the JSON and the JUnit are
/// views of this.
#[derive(Clone, Debug, Serialize)]
pub struct CheckReport {
    /// The run's id in the history (None without a database).
    pub run_id: Option<i64>,
    pub db: Option<PathBuf>,
    pub passed: bool,
    pub started_at: String,
    pub ended_at: String,
    pub tonegate_version: String,
    pub git_commit: Option<String>,
    pub suite: PathBuf,
    pub suite_hash: String,
    pub adapter: AdapterInfo,
    /// The renderer's knobs: intermediates, reduction, filter, spp.
    pub renderer: serde_json::Value,
    pub ssim_definition: String,
    pub flip_definition: String,
    /// Where the 8-bit frames' metrics were computed: `cpu` or `gpu`
    /// (`--metrics`).
    pub metrics_on: super::MetricsOn,
    pub scenes: Vec<SceneResult>,
    pub performance: Performance,
    /// Slowdowns against the history on this adapter (failures only when
    /// `performance.fail_on_regression`).
    pub regressions: Vec<Regression>,
    pub artifacts_dir: Option<PathBuf>,
    /// Artifact files written, relative to `artifacts_dir`.
    pub artifacts: Vec<String>,
    /// Of those, the ones the object store did not take (down past the
    /// retry budget, or refusing): kept in the history, pending, and served
    /// from there until `tonegate history pending --upload` moves them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub artifacts_pending: Vec<crate::history::PendingName>,
    /// The stress suite's table, when the suite asks for it (`stress = true`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stress: Option<crate::stress::StressReport>,
    /// Where the run's wall time went.
    pub phases: Phases,
}

impl CheckReport {
    pub fn scenes_failed(&self) -> usize {
        self.scenes.iter().filter(|s| !s.passed()).count()
    }

    /// Of those, the ones an expectation on this adapter allows (they do
    /// not fail the gate).
    pub fn scenes_failed_as_expected(&self) -> usize {
        self.scenes
            .iter()
            .filter(|s| !s.passed() && !s.fails_gate())
            .count()
    }
}

/// The artifacts a stored [`CheckReport`] lists, read back from its JSON:
/// the part of the report the server needs to serve an artifact.
#[derive(Debug, Default, PartialEq, Deserialize)]
pub struct StoredArtifacts {
    pub artifacts_dir: Option<PathBuf>,
    #[serde(default)]
    pub artifacts: Vec<String>,
}

impl StoredArtifacts {
    /// None when the JSON is not a report.
    pub fn of_report(json: &str) -> Option<StoredArtifacts> {
        serde_json::from_str(json).ok()
    }
}

/// How a check ended.
pub enum CheckOutcome {
    Finished(Box<CheckReport>),
    /// The run could not happen; the run id in the history when it got that far.
    Error(CheckError, Option<i64>),
}

impl CheckOutcome {
    /// 0 all passed, 1 a check (or a regression the suite fails on) failed,
    /// 2 the run could not happen.
    pub fn exit_code(&self) -> u8 {
        match self {
            CheckOutcome::Finished(r) if r.passed => 0,
            CheckOutcome::Finished(_) => 1,
            CheckOutcome::Error(..) => 2,
        }
    }
}
