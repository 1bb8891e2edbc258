//! `tonegate runner`, `tonegate enqueue` and `tonegate fleet`: machines that
//! take queued check runs from a shared history, and the queue itself.

use super::DbArgs;
use super::GpuArgs;
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;
use tonegate::error::{Error, Result};
use tonegate::history::{History, JobSpec};
use tonegate::runner::RunnerOptions;

#[derive(Args)]
pub struct RunnerArgs {
    #[command(flatten)]
    pub db: DbArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Render every job with the CPU reference (registers as `cpu-reference`).
    #[arg(long)]
    pub cpu: bool,
    /// Labels a job can ask for (comma-separated: letters, digits, - _ . :).
    #[arg(long, value_delimiter = ',')]
    pub labels: Vec<String>,
    /// The runner's name in the dashboard, 1 to 128 characters (default:
    /// host:pid).
    #[arg(long)]
    pub name: Option<String>,
    /// Milliseconds between looks at an empty queue.
    #[arg(long, default_value_t = 1000)]
    pub poll_ms: u64,
    /// Milliseconds between heartbeats.
    #[arg(long, default_value_t = 2000)]
    pub heartbeat_ms: u64,
    /// Seconds of silence after which a runner is declared lost and its job queued again.
    #[arg(long, default_value_t = 30)]
    pub lost_after_s: u64,
    /// Stop after this many jobs.
    #[arg(long)]
    pub max_jobs: Option<u64>,
    /// Stop once the queue has had nothing for this runner for this many seconds.
    #[arg(long)]
    pub exit_when_idle_s: Option<u64>,
    /// Keep each job's images in DIR/job-<id> (a shared history has no folder
    /// of its own), or in an object store, s3://bucket/prefix (endpoint and
    /// keys from the AWS_* variables), with the history holding their hashes.
    #[arg(long)]
    pub artifacts: Option<PathBuf>,
}

/// A flag SIGTERM and SIGINT set instead of killing the process: the runner
/// finishes the job in hand, marks itself stopped and exits 0.
fn stop_on_signals() -> std::sync::Arc<std::sync::atomic::AtomicBool> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, OnceLock};
    static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    extern "C" fn on_signal(_: libc::c_int) {
        // Only an atomic store: async-signal-safe.
        if let Some(s) = STOP.get() {
            s.store(true, Ordering::Relaxed);
        }
    }
    let flag = STOP
        .get_or_init(|| Arc::new(AtomicBool::new(false)))
        .clone();
    let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: installs a handler that only stores to an atomic.
    unsafe {
        libc::signal(libc::SIGTERM, handler);
        libc::signal(libc::SIGINT, handler);
    }
    flag
}

pub fn runner(a: RunnerArgs) -> Result<ExitCode> {
    if a.heartbeat_ms == 0 || a.poll_ms == 0 {
        return Err(Error::Invalid(
            "--heartbeat-ms and --poll-ms: must be at least 1".into(),
        ));
    }
    if a.lost_after_s * 1000 < 2 * a.heartbeat_ms {
        return Err(Error::Invalid(format!(
            "--lost-after-s {}: must be at least two heartbeats ({} ms), or live runners are declared lost",
            a.lost_after_s,
            2 * a.heartbeat_ms
        )));
    }
    a.db.set_retry(600);
    let opts = RunnerOptions {
        db: a.db.db.clone(),
        name: a.name.clone(),
        adapter: a.gpu.adapter(),
        gpu_config: a.gpu.config(),
        cpu: a.cpu,
        labels: a.labels.clone(),
        poll: Duration::from_millis(a.poll_ms),
        heartbeat: Duration::from_millis(a.heartbeat_ms),
        lost_after: Duration::from_secs(a.lost_after_s),
        max_jobs: a.max_jobs,
        exit_when_idle: a.exit_when_idle_s.map(Duration::from_secs),
        artifacts: super::gate::artifacts_to(a.artifacts.as_deref())?,
        stop: Some(stop_on_signals()),
    };
    let s = tonegate::runner::run(&opts, &mut |line| eprintln!("{line}"))?;
    println!(
        "runner {}: {} jobs ({} passed, {} failed, {} could not run, {} not recorded as the job's)",
        s.runner, s.jobs, s.passed, s.failed, s.errors, s.discarded
    );
    Ok(ExitCode::SUCCESS)
}

#[derive(Args)]
pub struct EnqueueArgs {
    #[command(flatten)]
    pub db: DbArgs,
    /// The suite file, as the runners see it.
    #[arg(long, default_value = "golden/suite.toml")]
    pub suite: String,
    /// Only this scene (repeatable; default: the whole suite).
    #[arg(long)]
    pub scene: Vec<String>,
    /// Refuse to queue past this many waiting jobs.
    #[arg(long, default_value_t = tonegate::history::MAX_QUEUED_JOBS)]
    pub max_queued: u64,
    /// Ask for the CPU reference instead of the runner's GPU.
    #[arg(long)]
    pub cpu: bool,
    /// Only a runner whose adapter name contains this (case-insensitive).
    #[arg(long)]
    pub want_adapter: Option<String>,
    /// Only a runner with this label.
    #[arg(long)]
    pub want_label: Option<String>,
    /// Queue this many identical jobs.
    #[arg(long, default_value_t = 1)]
    pub count: u32,
}

pub fn enqueue(a: EnqueueArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    if !(1..=10_000).contains(&a.count) {
        return Err(Error::Invalid(format!(
            "--count: must be 1 to 10000, got {}",
            a.count
        )));
    }
    // The suite must load here and name the scenes asked for, in the API's
    // words: a bad name used to be queued and fail in a runner, and a file
    // that is not a suite put its first line into the run's detail.
    let suite = tonegate::suite::load_suite_file(std::path::Path::new(&a.suite))
        .map_err(|e| Error::Invalid(format!("--suite: {e}")))?;
    if !a.scene.is_empty() {
        suite
            .select(&a.scene)
            .map_err(|m| Error::Invalid(format!("scenes: {m}")))?;
    }
    let h = History::open(&a.db.db)?;
    let spec = JobSpec {
        suite: a.suite.clone(),
        scenes: a.scene.clone(),
        cpu: a.cpu,
        adapter: a.want_adapter.clone(),
        label: a.want_label.clone(),
    };
    let mut ids = Vec::new();
    let mut refused = None;
    for _ in 0..a.count {
        match h.enqueue_within(&spec, a.max_queued) {
            Ok(id) => ids.push(id),
            Err(e) => {
                refused = Some(e);
                break;
            }
        }
    }
    match ids.as_slice() {
        [one] => println!("queued job {one} in {}", a.db.shown()),
        [first, .., last] => println!(
            "queued jobs {first}..{last} ({}) in {}",
            ids.len(),
            a.db.shown()
        ),
        [] => {}
    }
    match refused {
        Some(e) => Err(e.into()),
        None => Ok(ExitCode::SUCCESS),
    }
}

#[derive(Args)]
pub struct FleetArgs {
    #[command(flatten)]
    pub db: DbArgs,
    /// Stopped and lost runners too.
    #[arg(long)]
    pub all: bool,
    /// Newest jobs shown.
    #[arg(long, default_value_t = 20)]
    pub limit: u32,
    /// As JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn fleet(a: FleetArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    let h = a.db.open_existing()?;
    let runners = h.runners(a.all)?;
    let jobs = h.jobs(None, a.limit)?;
    let counts = h.job_counts()?;
    if a.json {
        let v = serde_json::json!({ "runners": runners, "jobs": jobs, "job_counts": counts });
        println!("{v:#}");
        return Ok(ExitCode::SUCCESS);
    }
    println!("runners ({}):", runners.len());
    for r in &runners {
        println!(
            "  {:>4} {:<8} {:<28} {:<24} [{}] heartbeat {}{}",
            r.id,
            r.state,
            r.name,
            r.adapter,
            r.labels.join(","),
            r.heartbeat,
            r.job_id.map(|j| format!(", job {j}")).unwrap_or_default()
        );
    }
    let counts: Vec<String> = counts.iter().map(|(s, n)| format!("{n} {s}")).collect();
    println!(
        "jobs: {}",
        if counts.is_empty() {
            "none".into()
        } else {
            counts.join(", ")
        }
    );
    for j in &jobs {
        println!(
            "  {:>5} {:<8} {} attempt {}{}{}",
            j.id,
            j.state,
            j.suite,
            j.attempts,
            j.run_id.map(|r| format!(", run {r}")).unwrap_or_default(),
            j.detail
                .as_deref()
                .map(|d| format!(": {d}"))
                .unwrap_or_default()
        );
    }
    Ok(ExitCode::SUCCESS)
}
