//! `tonegate runner`: one machine of a fleet. It registers its adapter and
//! labels in the shared history, heartbeats on a thread of its own, claims
//! queued check runs its adapter and labels match (`history::fleet`), runs
//! each through the same gate as `tonegate check`, and records the job's end.
//! Before each claim it declares silent runners lost, so a runner killed
//! mid-run has its job queued again and finished by another.

use crate::gate::{CheckOptions, CheckOutcome, Renderer};
use crate::gpu::{AdapterChoice, GpuConfig};
use crate::history::{History, HistoryError, RunnerInfo};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How a runner behaves.
#[derive(Clone, Debug)]
pub struct RunnerOptions {
    /// The shared history (a `postgres://` address; a SQLite file works for
    /// runners on one machine).
    pub db: PathBuf,
    /// Shown in the dashboard (default: host and pid).
    pub name: Option<String>,
    pub adapter: AdapterChoice,
    pub gpu_config: GpuConfig,
    /// Register as the CPU reference instead of opening an adapter: it then
    /// takes only jobs that ask for no adapter, rendering them on the CPU.
    pub cpu: bool,
    pub labels: Vec<String>,
    /// How often to look for a job when the queue is empty.
    pub poll: Duration,
    /// How often to heartbeat.
    pub heartbeat: Duration,
    /// Silence after which a runner is declared lost.
    pub lost_after: Duration,
    /// Stop after this many jobs.
    pub max_jobs: Option<u64>,
    /// Stop after the queue has had nothing for this runner this long.
    pub exit_when_idle: Option<Duration>,
    /// Where each job's kept images go (`<dir>/job-<id>`); none without it.
    pub artifacts: Option<PathBuf>,
    /// Set (by a signal handler, or another thread) to stop after the job in
    /// hand: the runner then ends that job, marks itself stopped and returns.
    pub stop: Option<Arc<AtomicBool>>,
}

/// What a runner did before it stopped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunnerSummary {
    pub runner: i64,
    pub jobs: u64,
    pub passed: u64,
    pub failed: u64,
    pub errors: u64,
    /// Jobs whose result was not the job's (this runner had been declared lost).
    pub discarded: u64,
}

/// Heartbeats on its own connection until dropped.
struct Heart {
    stop: Arc<AtomicBool>,
    lost: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Heart {
    fn start(db: PathBuf, runner: i64, every: Duration) -> Result<Heart, HistoryError> {
        let h = History::open(&db)?;
        let stop = Arc::new(AtomicBool::new(false));
        let lost = Arc::new(AtomicBool::new(false));
        let (s, l) = (stop.clone(), lost.clone());
        let thread = std::thread::Builder::new()
            .name(format!("heartbeat-{runner}"))
            .spawn(move || {
                let mut last = Instant::now();
                while !s.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(50).min(every));
                    if last.elapsed() < every {
                        continue;
                    }
                    last = Instant::now();
                    match h.heartbeat(runner) {
                        Ok(true) => {}
                        Ok(false) => l.store(true, Ordering::Relaxed),
                        Err(e) => tracing::warn!("runner {runner}: heartbeat: {e}"),
                    }
                }
            })
            .map_err(|e| HistoryError::Invalid(format!("starting the heartbeat thread: {e}")))?;
        Ok(Heart {
            stop,
            lost,
            thread: Some(thread),
        })
    }
}

impl Drop for Heart {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn register(
    h: &History,
    info: &RunnerInfo,
    opts: &RunnerOptions,
) -> Result<(i64, Heart), HistoryError> {
    let id = h.register_runner(info)?;
    let heart = Heart::start(opts.db.clone(), id, opts.heartbeat)?;
    Ok((id, heart))
}

/// Runs jobs until a limit in `opts` stops it (or, with none, forever).
/// `say` is told each job's outcome as a line.
pub fn run(opts: &RunnerOptions, say: &mut dyn FnMut(&str)) -> Result<RunnerSummary, crate::Error> {
    let (adapter, driver) = if opts.cpu {
        (
            crate::render::CPU_REFERENCE.to_owned(),
            "tonegate".to_owned(),
        )
    } else {
        let ctx = crate::gpu::GpuContext::new(&opts.adapter)?;
        (ctx.adapter.name.clone(), ctx.adapter.driver.clone())
    };
    let info = RunnerInfo {
        name: opts
            .name
            .clone()
            .unwrap_or_else(|| format!("{}:{}", crate::history::host_name(), std::process::id())),
        adapter,
        driver,
        labels: opts.labels.clone(),
    };
    let h = History::open(&opts.db)?;
    let (mut id, mut heart) = register(&h, &info, opts)?;
    say(&format!(
        "runner {id} ({}) on {} with labels [{}], waiting for jobs in {}",
        info.name,
        info.adapter,
        info.labels.join(","),
        h.path().display()
    ));
    let mut summary = RunnerSummary {
        runner: id,
        ..Default::default()
    };
    let mut idle_since = Instant::now();
    let stopping = || {
        opts.stop
            .as_ref()
            .is_some_and(|s| s.load(Ordering::Relaxed))
    };
    let mut recovered = crate::history::last_recovery();
    let mut store_recovered = crate::history::store_last_recovery();
    loop {
        if crate::history::last_recovery() != recovered {
            recovered = crate::history::last_recovery();
            say("the history database was unreachable and answers again: reconnected");
        }
        if crate::history::store_last_recovery() != store_recovered {
            store_recovered = crate::history::store_last_recovery();
            say("the artifact store did not answer and takes images again: held on");
        }
        if stopping() {
            say("asked to stop: no more jobs taken");
            break;
        }
        if heart.lost.load(Ordering::Relaxed) {
            drop(heart);
            (id, heart) = register(&h, &info, opts)?;
            say(&format!(
                "declared lost by the fleet; registered again as runner {id}"
            ));
            summary.runner = id;
        }
        if opts.max_jobs.is_some_and(|m| summary.jobs >= m) {
            break;
        }
        let expired = match patiently(&h, say, &stopping, "looking for lost runners", |h| {
            h.expire_runners(opts.lost_after)
        })? {
            Some(e) => e,
            None => continue,
        };
        if !expired.runners.is_empty() {
            say(&format!(
                "runners {:?} declared lost: jobs {:?} queued again, {:?} aborted",
                expired.runners, expired.requeued, expired.aborted
            ));
        }
        let claimable = if opts.cpu { "" } else { info.adapter.as_str() };
        let claimed = patiently(&h, say, &stopping, "claiming a job", |h| {
            h.claim(id, claimable, &info.labels)
        })?;
        let Some(job) = claimed.flatten() else {
            if opts
                .exit_when_idle
                .is_some_and(|d| idle_since.elapsed() >= d)
            {
                break;
            }
            // Sleep in short steps, so a stop is seen within 50 ms.
            let until = Instant::now() + opts.poll;
            while Instant::now() < until && !stopping() {
                std::thread::sleep(Duration::from_millis(50).min(opts.poll));
            }
            continue;
        };
        let started = Instant::now();
        let renderer = if job.cpu || opts.cpu {
            Renderer::Cpu
        } else {
            Renderer::Gpu {
                adapter: opts.adapter.clone(),
                config: opts.gpu_config,
            }
        };
        let (tx, rx) = std::sync::mpsc::channel();
        let check = CheckOptions {
            suite: PathBuf::from(&job.suite),
            renderer,
            spp: None,
            artifacts: opts
                .artifacts
                .as_ref()
                .map(|d| d.join(format!("job-{}", job.id))),
            db: Some(opts.db.clone()),
            started: Some(tx),
            scenes: job.scenes.clone(),
            metrics: crate::gate::MetricsOn::Auto,
        };
        let gate = std::thread::Builder::new()
            .name(format!("job-{}", job.id))
            .spawn(move || crate::gate::run(&check, &crate::progress::Silent))
            .map_err(|e| HistoryError::Invalid(format!("starting job {}: {e}", job.id)))?;
        // The run's id arrives as soon as it is recorded (never, when the
        // run could not start: the sender is dropped with the options).
        // A database lost past the retry budget here only costs the link
        // from the job to its run (the run itself is recorded by the gate,
        // which retries on its own connection): the job is still run.
        if let Ok(run) = rx.recv() {
            if let Err(e) = h.job_started(job.id, run) {
                if !e.unavailable() {
                    return Err(e.into());
                }
                say(&format!("job {}: its run {run} is not linked: {e}", job.id));
            }
        }
        let outcome = gate.join().unwrap_or_else(|_| {
            CheckOutcome::Error(
                HistoryError::Invalid("the run panicked".into()).into(),
                None,
            )
        });
        let detail = match &outcome {
            CheckOutcome::Finished(r) if r.passed => {
                summary.passed += 1;
                format!("run {} passed", r.run_id.unwrap_or_default())
            }
            CheckOutcome::Finished(r) => {
                summary.failed += 1;
                format!("run {} failed", r.run_id.unwrap_or_default())
            }
            CheckOutcome::Error(e, run) => {
                summary.errors += 1;
                match run {
                    Some(run) => format!("run {run} could not happen: {e}"),
                    None => format!("could not start: {e}"),
                }
            }
        };
        summary.jobs += 1;
        // The result is kept through a database outage of any length: a
        // runner asked to stop gives up only after one more retry budget.
        let never = || false;
        let held = patiently(&h, say, &never, "storing the job's end", |h| {
            h.finish_job(id, job.id, &detail)
        })?
        .unwrap_or(false);
        if !held {
            summary.discarded += 1;
        }
        say(&format!(
            "job {} (attempt {}): {detail} in {:.1} s{}",
            job.id,
            job.attempt,
            started.elapsed().as_secs_f64(),
            if held {
                ""
            } else {
                " (not recorded as the job's: this runner had been declared lost)"
            }
        ));
        idle_since = Instant::now();
    }
    drop(heart);
    if let Err(e) = h.stop_runner(id) {
        // Not marked stopped: the fleet declares it lost after its silence.
        if !e.unavailable() {
            return Err(e.into());
        }
        say(&format!("could not mark runner {id} stopped: {e}"));
    }
    Ok(summary)
}

/// Runs `f` until the database answers: an unreachable database (past the
/// retry budget each try already spent, reconnecting) is said once and
/// waited out, so a restart or failover of the fleet's database never stops
/// a runner. None when `stop` was asked for while waiting; any other error
/// is returned.
fn patiently<T>(
    h: &History,
    say: &mut dyn FnMut(&str),
    stop: &dyn Fn() -> bool,
    what: &str,
    mut f: impl FnMut(&History) -> Result<T, HistoryError>,
) -> Result<Option<T>, crate::Error> {
    let mut said = false;
    loop {
        match f(h) {
            Ok(v) => {
                if said {
                    say(&format!("{what}: the history database answers again"));
                }
                return Ok(Some(v));
            }
            Err(e) if e.unavailable() => {
                if !said {
                    say(&format!("{what}: {e}; waiting for the database"));
                    said = true;
                }
                if stop() {
                    return Ok(None);
                }
                std::thread::sleep(Duration::from_secs(1));
            }
            Err(e) => return Err(e.into()),
        }
    }
}
