//! `tonegate check`: the CI gate. Renders every scene of a suite, compares
//! every frame with its golden, evaluates the typed checks, writes artifacts
//! for failing frames (and each scene's worst frame), flags performance regressions against the history and
//! records the run.
//!
//! The outcome is one of three, and the exit code says which (see
//! [`CheckOutcome::exit_code`]): everything passed (0), a check failed (1), or
//! the run could not happen (2: no adapter, missing golden, bad suite file).

mod artifacts;
pub mod console;
pub mod junit;
mod metrics_on;
mod phases;
pub mod regress;
mod report;
mod stored;

pub use artifacts::{adapter_slug, artifact_name};
pub use metrics_on::MetricsOn;
pub use phases::Phases;
pub use regress::find_regressions;
pub use report::{AdapterInfo, CheckOutcome, CheckReport, StoredArtifacts};
pub use stored::{is_recorded_metric, recorded_metrics, scene_record};

use crate::check::{judge, JudgeError};
use crate::golden::Problem;
use crate::gpu::GpuContext;
use crate::history::{History, HistoryError, RunAdapter, RunKind, RunMeta, RunStatus};
use crate::progress::Progress;
pub use crate::render::Renderer;
use crate::render::{scene_environment, RenderError, SceneRenderer, CPU_REFERENCE};
use crate::scene::SceneError;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct CheckOptions {
    pub suite: PathBuf,
    pub renderer: Renderer,
    /// Samples per pixel; None renders each scene at its default spp
    /// (`reference_spp`, like for like with its goldens; 1 for a TAA scene).
    pub spp: Option<u32>,
    /// Where the kept frames' PNGs go (failing frames, each scene's worst frame); None writes none.
    pub artifacts: Option<PathBuf>,
    /// The history database; None records nothing (and finds no regressions).
    pub db: Option<PathBuf>,
    /// Told the run's id as soon as the history has it (the HTTP API answers
    /// `POST /runs` with it while the run goes on).
    pub started: Option<std::sync::mpsc::Sender<i64>>,
    /// Only these scenes of the suite (empty: all), and then no stress suite.
    pub scenes: Vec<String>,
    /// Where FLIP is computed (`--metrics`).
    pub metrics: MetricsOn,
}

#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The suite file or one of its scenes is unreadable or invalid.
    #[error(transparent)]
    Suite(#[from] SceneError),
    /// Goldens are missing, stale or tampered with; `golden bless` makes them.
    #[error("the golden set is incomplete or stale:\n  {}\n(run `tonegate golden bless` after reviewing the change)", .0.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("\n  "))]
    Goldens(Vec<Problem>),
    /// The manifest could not be read.
    #[error(transparent)]
    Golden(#[from] crate::golden::GoldenError),
    /// No usable adapter, or the device failed.
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// Rendering a scene failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A frame could not be compared with its golden.
    #[error(transparent)]
    Judge(#[from] JudgeError),
    /// The history database could not be opened or written.
    #[error(transparent)]
    History(#[from] HistoryError),
    /// An artifact could not be written.
    #[error("writing artifact {path}: {detail}")]
    Artifact { path: PathBuf, detail: String },
}

/// Runs the gate and records it in the history (when a database is given):
/// the run is `running` from the start and ends `passed`, `failed` or `error`.
pub fn run(opts: &CheckOptions, progress: &dyn Progress) -> CheckOutcome {
    let mut history = match opts.db.as_deref().map(History::open).transpose() {
        Ok(h) => h,
        Err(e) => return CheckOutcome::Error(e.into(), None),
    };
    let meta = RunMeta {
        suite: Some(opts.suite.display().to_string()),
        suite_hash: None,
        git_commit: crate::history::git_commit(opts.suite.parent().unwrap_or(Path::new("."))),
    };
    let run_id = match history
        .as_ref()
        .map(|h| h.start_run(RunKind::Check, &meta))
        .transpose()
    {
        Ok(id) => id,
        Err(e) => return CheckOutcome::Error(e.into(), None),
    };
    if let (Some(tx), Some(id)) = (&opts.started, run_id) {
        let _ = tx.send(id);
    }
    let started_at = crate::history::now();
    // Without --artifacts, a recorded run keeps its images beside the
    // database, one folder a run, where the API can serve them.
    let mut opts = opts.clone();
    if opts.artifacts.is_none() {
        if let (Some(db), Some(id)) = (&opts.db, run_id) {
            opts.artifacts = artifacts_dir_of(db, id);
        }
    }
    let result = run_inner(&opts, &meta, &mut history, run_id, started_at, progress);
    if let (Some(h), Some(id)) = (&history, run_id) {
        let finished = match &result {
            Ok(report) => {
                // Served to anonymous readers: the history's address goes
                // in without its host.
                let stored = CheckReport {
                    db: report
                        .db
                        .as_ref()
                        .map(|d| crate::history::without_host(&d.to_string_lossy()).into()),
                    ..report.clone()
                };
                let json = serde_json::to_string(&stored).ok();
                let status = if report.passed {
                    RunStatus::Passed
                } else {
                    RunStatus::Failed
                };
                h.finish_run(id, status, None, json.as_deref())
            }
            Err(e) => h.finish_run(id, RunStatus::Error, Some(&e.to_string()), None),
        };
        if let Err(e) = finished {
            return CheckOutcome::Error(e.into(), run_id);
        }
    }
    match result {
        Ok(report) => CheckOutcome::Finished(Box::new(report)),
        Err(e) => CheckOutcome::Error(e, run_id),
    }
}

fn spp_json(spp: Option<u32>) -> serde_json::Value {
    match spp {
        Some(n) => n.into(),
        None => "scene_default".into(),
    }
}

/// Marks what the scene's expectations on this adapter make of its result.
fn apply_expectations(
    result: &mut crate::check::SceneResult,
    expectations: &[crate::check::Expectation],
    adapter: &AdapterInfo,
    today: &str,
) {
    let driver = format!("{} {}", adapter.driver, adapter.driver_info);
    let (live, expired) =
        crate::check::expect::applicable(expectations, &adapter.name, &driver, today);
    result.expectation = live.map(|e| crate::check::expect::outcome(e, result.passed()));
    result.expired_expectations = expired
        .iter()
        .map(|e| {
            format!(
                "{} on {} expired {} ({}{})",
                e.status.name(),
                e.adapter,
                e.expires.as_deref().unwrap_or(""),
                e.reason,
                e.bug
                    .as_deref()
                    .map(|b| format!(", {b}"))
                    .unwrap_or_default()
            )
        })
        .collect();
}

/// Where a recorded run's artifacts go by default: `<db folder>/artifacts/run-<id>`.
/// None for a PostgreSQL history, which has no folder: its runs keep images
/// only where `--artifacts` says.
pub fn artifacts_dir_of(db: &Path, run: i64) -> Option<PathBuf> {
    if crate::history::is_url(&db.to_string_lossy()) {
        return None;
    }
    Some(
        db.parent()
            .unwrap_or(Path::new("."))
            .join("artifacts")
            .join(format!("run-{run}")),
    )
}

fn run_inner(
    opts: &CheckOptions,
    meta: &RunMeta,
    history: &mut Option<History>,
    run_id: Option<i64>,
    started_at: String,
    progress: &dyn Progress,
) -> Result<CheckReport, CheckError> {
    let mut clock = phases::Clock::start();
    let mut suite = crate::suite::load_suite_file(&opts.suite)?;
    if !opts.scenes.is_empty() {
        suite.scenes = suite
            .select(&opts.scenes)
            .map_err(|message| SceneError::Invalid {
                path: opts.suite.clone(),
                message: format!("--scene: {message}"),
            })?;
        suite.stress = false;
    }
    if let (Some(h), Some(id)) = (history.as_ref(), run_id) {
        clock.time(|p| &mut p.history_s, || h.set_suite_hash(id, &suite.hash))?;
    }
    let root = opts.suite.parent().unwrap_or(Path::new(".")).to_owned();
    let problems = crate::golden::check_manifest(&root, &suite.scenes)?;
    if !problems.is_empty() {
        return Err(CheckError::Goldens(problems));
    }
    let (ctx, adapter, renderer_json) = match &opts.renderer {
        Renderer::Gpu { adapter, config } => {
            let ctx = clock.time(|p| &mut p.device_s, || GpuContext::new(adapter))?;
            let a = &ctx.adapter;
            let info = AdapterInfo {
                name: a.name.clone(),
                backend: a.backend.clone(),
                driver: a.driver.clone(),
                driver_info: a.driver_info.clone(),
                chosen: a.chosen.clone(),
                flushes_subnormals: a.flushes_subnormals,
                division: a.division.clone(),
            };
            let mut json = serde_json::to_value(config).unwrap_or_default();
            if let Some(o) = json.as_object_mut() {
                o.insert("spp".into(), spp_json(opts.spp));
                o.insert("adapter_chosen".into(), a.chosen.clone().into());
                // Measured by the probe when the device was opened; the
                // adapter matrix shows it, and the stress exception for
                // flushed subnormals applies only where it is true.
                o.insert("flushes_subnormals".into(), a.flushes_subnormals.into());
                // What `--reduction auto` became on this adapter.
                o.insert(
                    "reduction_in_effect".into(),
                    serde_json::to_value(config.reduction.resolve(ctx.traits()))
                        .unwrap_or_default(),
                );
            }
            (Some((ctx, *config)), info, json)
        }
        Renderer::Cpu => (
            None,
            AdapterInfo {
                name: CPU_REFERENCE.into(),
                backend: "cpu".into(),
                driver: "tonegate".into(),
                driver_info: format!("reference version {}", crate::reference::REFERENCE_VERSION),
                chosen: "--cpu: the f64 CPU reference, no adapter".into(),
                flushes_subnormals: None,
                division: None,
            },
            serde_json::json!({ "spp": spp_json(opts.spp) }),
        ),
    };
    let metrics_on = opts.metrics.resolve(ctx.as_ref().map(|(c, _)| c));
    let flip_adapter = adapter.name.clone();
    // The GPU's metrics are trusted on an adapter once they pass their
    // locks there; an adapter that fails judges on the CPU and says why.
    let (gpu_metrics, metrics_on, metrics_refused) = match (&ctx, metrics_on) {
        (Some((c, _)), MetricsOn::Gpu) => {
            let g = crate::gpu::compare::GpuCompare::new(c);
            match g.self_check() {
                Ok(()) => (Some(g), MetricsOn::Gpu, None),
                Err(why) => (None, MetricsOn::Cpu, Some(why)),
            }
        }
        _ => (None, metrics_on, None),
    };
    let compare_on_gpu = gpu_metrics
        .as_ref()
        .map(|g| move |t: crate::metrics::Raster, r: crate::metrics::Raster| g.compare(t, r));
    let compare_by = compare_on_gpu
        .as_ref()
        .map(|f| crate::metrics::CompareBy(f));
    if let (Some(h), Some(id)) = (history.as_ref(), run_id) {
        let record = RunAdapter {
            name: adapter.name.clone(),
            backend: adapter.backend.clone(),
            driver: adapter.driver.clone(),
            driver_info: adapter.driver_info.clone(),
            config: renderer_json.to_string(),
        };
        clock.time(|p| &mut p.history_s, || h.set_adapter(id, &record))?;
    }
    let total: u64 = suite.scenes.iter().map(|s| s.frames as u64).sum();
    progress.start("check", total, "frames");
    let slug = adapter_slug(&adapter.name);
    // Expectations expire by UTC day; TONEGATE_TODAY (YYYY-MM-DD) sets the
    // day, for tests and for replaying a past run's verdict.
    let today = std::env::var("TONEGATE_TODAY")
        .ok()
        .filter(|d| chrono::NaiveDate::parse_from_str(d, "%Y-%m-%d").is_ok())
        .unwrap_or_else(|| chrono::Utc::now().format("%Y-%m-%d").to_string());
    let mut scenes = Vec::with_capacity(suite.scenes.len());
    let mut written = Vec::new();
    let mut pending = Vec::new();
    for scene in &suite.scenes {
        progress.working_on(&scene.name);
        let spp = opts.spp.unwrap_or(scene.default_spp());
        let env = clock.time(|p| &mut p.pipelines_s, || scene_environment(scene))?;
        let renderer = clock.time(
            |p| &mut p.pipelines_s,
            || -> Result<_, CheckError> {
                Ok(match &ctx {
                    Some((ctx, config)) => SceneRenderer::gpu(scene, &env, ctx, *config, spp)?,
                    None => SceneRenderer::cpu(scene, &env, spp),
                })
            },
        )?;
        let rendered = clock.time(
            |p| &mut p.render_s,
            || renderer.sequence(|_| progress.advance(1)),
        )?;
        let goldens = clock.time(
            |p| &mut p.goldens_s,
            || {
                (0..scene.frames)
                    .map(|n| crate::golden::read_frame(&root, &scene.name, n))
                    .collect::<Result<Vec<_>, _>>()
            },
        )?;
        let curve = match scene.adaptation {
            Some(_) => Some(crate::golden::read_adaptation_curve(
                &root,
                &scene.name,
                scene.frames,
            )?),
            None => None,
        };
        let judging = crate::check::Judging {
            earlier: &scenes,
            compare: compare_by,
            adaptation_curve: curve.as_deref(),
            ..scene.judging()
        };
        let (mut result, kept) =
            clock.time(|p| &mut p.metrics_s, || judge(judging, rendered, goldens))?;
        apply_expectations(&mut result, &scene.expectations, &adapter, &today);
        result.taa = scene.taa.as_ref().map(|t| crate::check::TaaTag {
            variant: t.variant.name().into(),
            settings: t.settings(),
            sequence: scene.sequence_key(),
        });
        // The kept frames' images go to the artifacts folder and, content-
        // addressed, into the history (where a fleet's server finds them).
        let store = history.as_ref().zip(run_id);
        let artifacts_started = std::time::Instant::now();
        if opts.artifacts.is_some() || store.is_some() {
            for f in &kept {
                let files = artifacts::render_frame(&scene.name, &slug, f, gpu_metrics.as_ref())?;
                if let Some(dir) = &opts.artifacts {
                    artifacts::write_files(dir, &files)?;
                }
                if let Some((h, id)) = store {
                    pending.extend(h.store_artifacts(id, &files)?.pending);
                }
                let names: Vec<String> = files.into_iter().map(|(n, _)| n).collect();
                if let Some(fr) = result.frames.iter_mut().find(|r| r.frame == f.frame) {
                    fr.artifacts = names.clone();
                }
                written.extend(names);
            }
        }
        clock.phases.artifacts_s += artifacts_started.elapsed().as_secs_f64();
        if let (Some(h), Some(id)) = (history.as_mut(), run_id) {
            let record = scene_record(&result)?;
            clock.time(|p| &mut p.history_s, || h.record_scene(id, &record))?;
        }
        scenes.push(result);
    }
    progress.finish();
    let regressions = match (history.as_mut(), run_id, &ctx) {
        (Some(h), Some(id), Some(_)) => clock.time(
            |p| &mut p.history_s,
            || -> Result<_, CheckError> {
                let found = find_regressions(
                    h,
                    id,
                    &adapter.name,
                    &renderer_json.to_string(),
                    &scenes,
                    &suite.performance,
                )?;
                h.record_regressions(id, &found)?;
                Ok(found)
            },
        )?,
        _ => Vec::new(),
    };
    let stress = suite.stress.then(|| {
        crate::stress::run_told(
            &crate::stress::cases::all(true),
            ctx.as_ref().map(|(c, _)| c),
            ctx.as_ref()
                .map(|(_, config)| config.reduction)
                .unwrap_or_default(),
            progress,
        )
    });
    if let Some(st) = &stress {
        clock.phases.stress_s = st.wall_s;
        clock.phases.stress_cpu_s = st.cpu_s;
        clock.phases.stress_gpu_s = st.gpu_s;
    }
    let passed = scenes.iter().all(|s| !s.fails_gate())
        && (regressions.is_empty() || !suite.performance.fail_on_regression)
        && stress.as_ref().is_none_or(|s| s.passed);
    Ok(CheckReport {
        run_id,
        // A PostgreSQL address is reported without its password.
        db: opts
            .db
            .as_deref()
            .map(|d| crate::history::redacted(&d.to_string_lossy()).into()),
        passed,
        started_at,
        ended_at: crate::history::now(),
        tonegate_version: env!("CARGO_PKG_VERSION").into(),
        git_commit: meta.git_commit.clone(),
        suite: opts.suite.clone(),
        suite_hash: suite.hash,
        adapter,
        renderer: renderer_json,
        ssim_definition: crate::metrics::SSIM_DEFINITION.into(),
        flip_definition: match metrics_on {
            MetricsOn::Gpu => format!(
                "{}; for 8-bit frames computed on the GPU ({}) by tonegate's port of the same \
                 pipeline, locked to nv-flip within 1e-4 of the mean (SSIM within 1e-6 of the \
                 CPU's, the error figures exact)",
                crate::metrics::FLIP_DEFINITION,
                flip_adapter
            ),
            _ => match &metrics_refused {
                Some(why) => format!(
                    "{}; on the CPU: the metrics on the GPU failed their check on this adapter \
                     ({why})",
                    crate::metrics::FLIP_DEFINITION
                ),
                None => crate::metrics::FLIP_DEFINITION.into(),
            },
        },
        metrics_on,
        scenes,
        performance: suite.performance,
        regressions,
        artifacts_dir: opts.artifacts.clone(),
        artifacts: written,
        artifacts_pending: pending,
        stress,
        phases: clock.finish(),
    })
}
