//! The gate's commands: `check` and `history`.

use super::progress::Bar;
use super::{invalid, json_text, write_json, write_text, DbArgs, GpuArgs};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::gate::{CheckOptions, CheckOutcome, Renderer};
use tonegate::history::History;
use tonegate::scene::MAX_SPP;

#[derive(Args)]
pub struct CheckArgs {
    /// The suite file; goldens are found beside it.
    #[arg(long, default_value = "golden/suite.toml")]
    pub suite: PathBuf,
    /// Render with the CPU reference instead of the GPU (checks the gate itself).
    #[arg(long)]
    pub cpu: bool,
    /// Samples per pixel of the render under test (default: each scene's
    /// reference_spp, the goldens' own, or 1 for a TAA scene; 1 = the plain,
    /// aliased path, or the TAA path of a TAA scene). Checks apply at the spp
    /// they name (`spp` in the scene file, default the scene's default).
    #[arg(long)]
    pub spp: Option<u32>,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Write JUnit XML here.
    #[arg(long)]
    pub junit: Option<PathBuf>,
    /// No progress on stderr (a bar on a terminal; elsewhere, as in a CI
    /// log, a line per scene and every few seconds).
    #[arg(long)]
    pub quiet: bool,
    /// Write the full report as JSON here ("-" for stdout; the table then goes to stderr).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the actual/golden/diff/ssim PNGs of failing frames (and of each scene's worst frame) here
    /// (default: beside the database, artifacts/run-<id>); an object store,
    /// s3://bucket/prefix, keeps them there instead of in the history's own
    /// table (endpoint and keys from the AWS_* variables).
    #[arg(long)]
    pub artifacts: Option<PathBuf>,
    #[command(flatten)]
    pub db: DbArgs,
    /// Do not record the run (and find no regressions).
    #[arg(long)]
    pub no_history: bool,
    /// Fault injection: scale the tone-mapped colour by this gain, to prove the
    /// gate catches a wrong tone mapper (e.g. 1.02 brightens by 2 %).
    #[arg(long)]
    pub fault_gain: Option<f32>,
    /// Fault injection: break the TAA stage (no clipping, or the history
    /// reprojected as if the sphere stood still), to prove the TAA scenes'
    /// checks catch a broken TAA.
    #[arg(long, value_enum)]
    pub taa_fault: Option<tonegate::gpu::TaaFault>,
    /// Fault injection: wait this many milliseconds after each rendered
    /// frame, to prove a drop in FPS is found (a change point, an alert).
    #[arg(long, value_name = "MS", value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub fault_delay_ms: Option<u32>,
    /// Only this scene of the suite (repeatable); the stress suite is then
    /// skipped.
    #[arg(long = "scene")]
    pub scenes: Vec<String>,
    /// Where the 8-bit frames' metrics are computed: cpu (FLIP by NVIDIA's
    /// C++ through nv-flip), gpu (on the check's adapter: the error figures
    /// exact, SSIM within 1e-6 and FLIP within 1e-4 of the CPU's), or auto
    /// (the GPU on a hardware adapter, the CPU on llvmpipe and SwiftShader
    /// and with --cpu).
    #[arg(long, default_value = "auto", value_parser = crate::cli::by_name::<tonegate::gate::MetricsOn>)]
    pub metrics: tonegate::gate::MetricsOn,
}

#[derive(Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct HistoryArgs {
    #[command(subcommand)]
    pub action: Option<HistoryAction>,
    #[command(flatten)]
    pub db: DbArgs,
    /// Only this scene.
    #[arg(long)]
    pub scene: Option<String>,
    /// psnr, ssim, snr, mse, rmse, max_abs_diff, mean_abs_diff, fraction_over_1lsb, flip_mean, fps or a
    /// stage name (median ms). Without it, the run list.
    #[arg(long)]
    pub metric: Option<String>,
    /// Only runs on an adapter whose name contains this, any case (as the
    /// API's `adapter`).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Newest runs shown.
    #[arg(long, default_value_t = 20)]
    pub limit: u32,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn check(a: CheckArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    if let Some(spp) = a.spp.filter(|&n| n == 0 || n > MAX_SPP) {
        return Err(invalid(format!(
            "--spp must be between 1 and {MAX_SPP}, got {spp}"
        )));
    }
    if let Some(g) = a.fault_gain {
        if !(g.is_finite() && g > 0.0) {
            return Err(invalid(format!(
                "--fault-gain must be a positive number, got {g}"
            )));
        }
    }
    // A suite that is not there is no run: said with what to do, and
    // nothing is written to a history.
    if !a.suite.exists() {
        let default = a.suite == std::path::Path::new("golden/suite.toml");
        return Err(invalid(if default {
            format!(
                "no suite at {} in {}: run from the repository's root, or pass --suite FILE",
                a.suite.display(),
                std::env::current_dir()
                    .map(|d| d.display().to_string())
                    .unwrap_or_else(|_| "the current folder".into())
            )
        } else {
            format!("--suite {}: no such file", a.suite.display())
        }));
    }
    if a.cpu && a.metrics == tonegate::gate::MetricsOn::Gpu {
        return Err(invalid(
            "--metrics gpu needs an adapter, and --cpu renders with the CPU reference and none: \
             leave out --cpu, or use --metrics cpu"
                .to_string(),
        ));
    }
    let renderer = if a.cpu {
        Renderer::Cpu
    } else {
        let mut config = a.gpu.config();
        config.fault_gain = a.fault_gain;
        config.taa_fault = a.taa_fault;
        config.fault_delay_ms = a.fault_delay_ms;
        Renderer::Gpu {
            adapter: a.gpu.adapter(),
            config,
        }
    };
    let artifacts = artifacts_to(a.artifacts.as_deref())?;
    let opts = CheckOptions {
        suite: a.suite.clone(),
        renderer,
        spp: a.spp,
        artifacts,
        db: (!a.no_history).then(|| a.db.db.clone()),
        started: None,
        scenes: a.scenes.clone(),
        metrics: a.metrics,
    };
    let outcome = tonegate::gate::run(&opts, &Bar::quiet_if(a.quiet));
    if tonegate::gpu::validation::requested() && !a.cpu {
        let (errors, warnings) = tonegate::gpu::validation::seen();
        eprintln!(
            "validation layer (WGPU_VALIDATION): {errors} error(s), {warnings} warning(s) reported"
        );
    }
    match &outcome {
        CheckOutcome::Finished(report) => {
            let text = tonegate::gate::console::render(report);
            if a.json.as_deref() == Some(Path::new("-")) {
                eprint!("{text}");
            } else {
                print!("{text}");
            }
            if let Some(path) = &a.json {
                write_json(path, "the check report", report)?;
            }
            if let Some(path) = &a.junit {
                let xml = tonegate::gate::junit::render(report)?;
                write_text(path, &xml)?;
            }
        }
        CheckOutcome::Error(e, run) => {
            eprintln!("error: {e}");
            if let Some(id) = run {
                eprintln!("recorded as run {id} (status error) in {}", a.db.shown());
            }
            if let Some(path) = &a.junit {
                let xml = tonegate::gate::junit::render_error(&e.to_string())?;
                write_text(path, &xml)?;
            }
            if let Some(path) = &a.json {
                write_json(
                    path,
                    "the check report",
                    &serde_json::json!({ "passed": false, "error": e.to_string(), "run_id": run }),
                )?;
            }
        }
    }
    Ok(ExitCode::from(outcome.exit_code()))
}

/// What `history` does besides printing.
#[derive(clap::Subcommand)]
pub enum HistoryAction {
    /// Drop the artifacts (images) of runs older than --keep-days, and the
    /// stored images no kept run names; metrics, checks and reports stay.
    Prune(PruneArgs),
    /// List the images an object store did not take (kept in the history
    /// meanwhile, with the reason), send them on (--upload) or drop them.
    Pending(super::pending::PendingArgs),
}

/// `--artifacts`: an object store (`s3://…`) is made this process's store
/// for kept images, and no folder is written; anything else is a folder.
pub fn artifacts_to(given: Option<&std::path::Path>) -> Result<Option<PathBuf>> {
    match given.map(|p| p.to_string_lossy().into_owned()) {
        Some(url) if tonegate::history::is_store_url(&url) => {
            tonegate::history::set_artifact_store(Some(&url))?;
            Ok(None)
        }
        _ => Ok(given.map(PathBuf::from)),
    }
}

#[derive(Args)]
pub struct PruneArgs {
    #[command(flatten)]
    pub db: DbArgs,
    /// Also look for images no run names in this object store
    /// (s3://bucket/prefix); the stores the history names are searched anyway.
    #[arg(long)]
    pub artifacts: Option<String>,
    /// Keep the artifacts of runs started within this many days.
    #[arg(long)]
    pub keep_days: u32,
}

fn prune(a: PruneArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    if !a.db.is_url() && !a.db.db.exists() {
        return Err(invalid(format!("no history at {}", a.db.shown())));
    }
    if let Some(url) = &a.artifacts {
        if !tonegate::history::is_store_url(url) {
            return Err(invalid(format!(
                "--artifacts: an object store, s3://bucket/prefix, got {url:?}"
            )));
        }
        tonegate::history::set_artifact_store(Some(url))?;
    }
    let h = History::open(&a.db.db)?;
    let before = h.artifact_stats()?;
    let keep = std::time::Duration::from_secs(u64::from(a.keep_days) * 86_400);
    let p = h.prune_artifacts(keep)?;
    // A SQLite history's runs also kept their images in a folder beside it.
    let mut folders = 0;
    for &run in &p.runs {
        if let Some(dir) = tonegate::gate::artifacts_dir_of(&a.db.db, run) {
            if dir.is_dir() {
                std::fs::remove_dir_all(&dir).map_err(|source| tonegate::error::Error::File {
                    path: dir.clone(),
                    source,
                })?;
                folders += 1;
            }
        }
    }
    let after = h.artifact_stats()?;
    println!(
        "pruned the artifacts of {} run(s) started over {} day(s) ago and {} frames submission(s) ({} untriaged digest(s) only they had): {} name(s), {} image(s) nothing kept uses ({:.1} MiB; {} of them from an object store), {} object(s) nothing named, {} folder(s); the store now holds {} image(s), {:.1} MiB (was {}, {:.1} MiB)",
        p.runs.len(),
        a.keep_days,
        p.submissions,
        p.untriaged_digests,
        p.names,
        p.blobs,
        p.bytes as f64 / 1048576.0,
        p.objects,
        p.stray_objects,
        folders,
        after.blobs,
        after.bytes as f64 / 1048576.0,
        before.blobs,
        before.bytes as f64 / 1048576.0
    );
    Ok(ExitCode::SUCCESS)
}

pub fn history(a: HistoryArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    match a.action {
        Some(HistoryAction::Prune(p)) => return prune(p),
        Some(HistoryAction::Pending(p)) => return super::pending::pending(p),
        None => {}
    }
    if !a.db.is_url() && !a.db.db.exists() {
        a.db.open_existing()?;
    }
    // Refused in the API's words (it answered 400 where this printed "no
    // values" and exited 0).
    if let Some(m) = a
        .metric
        .as_deref()
        .filter(|m| !tonegate::gate::is_recorded_metric(m))
    {
        return Err(invalid(format!(
            "--metric: unknown metric {m:?}; use {}",
            tonegate::gate::recorded_metrics().join(", ")
        )));
    }
    let h = History::open_read_only(&a.db.db)?;
    let Some(metric) = &a.metric else {
        let runs = h.runs(a.limit)?;
        let runs: Vec<_> = runs
            .into_iter()
            .filter(|r| {
                a.adapter.as_ref().is_none_or(|x| {
                    r.adapter
                        .as_ref()
                        .is_some_and(|n| n.to_lowercase().contains(&x.to_lowercase()))
                })
            })
            .collect();
        if a.json {
            println!("{}", json_text("the run list", &runs)?);
            return Ok(ExitCode::SUCCESS);
        }
        println!(
            "{:>5} {:<9} {:<8} {:<24} {:>7} {:>6} {:>5}  adapter / detail",
            "run", "kind", "status", "started (UTC)", "scenes", "failed", "regr"
        );
        for r in &runs {
            println!(
                "{:>5} {:<9} {:<8} {:<24} {:>7} {:>6} {:>5}  {}{}",
                r.id,
                r.kind,
                r.status,
                r.started_at,
                r.scenes,
                r.scenes_failed,
                r.regressions,
                r.adapter.as_deref().unwrap_or("-"),
                r.detail
                    .as_ref()
                    .map(|d| format!(" ({d})"))
                    .unwrap_or_default()
            );
        }
        return Ok(ExitCode::SUCCESS);
    };
    let points = h.trend(
        metric,
        &tonegate::history::TrendFilter {
            scene: a.scene.as_deref(),
            adapter: None,
            adapter_contains: a.adapter.as_deref(),
            config: None,
            before: None,
            finished_only: false,
            limit: a.limit,
        },
    )?;
    if a.json {
        println!("{}", json_text("the trend", &points)?);
        return Ok(ExitCode::SUCCESS);
    }
    if points.is_empty() {
        println!("no values of {metric} in {}", a.db.shown());
        return Ok(ExitCode::SUCCESS);
    }
    let mut scenes: Vec<&str> = points.iter().map(|p| p.scene.as_str()).collect();
    scenes.sort_unstable();
    scenes.dedup();
    for scene in scenes {
        let series: Vec<_> = points.iter().filter(|p| p.scene == scene).collect();
        let finite: Vec<f64> = series
            .iter()
            .map(|p| p.value)
            .filter(|v| v.is_finite())
            .collect();
        let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        println!("{scene}: {metric}");
        for p in series {
            let bar = if p.value.is_finite() && hi > lo {
                "#".repeat(1 + ((p.value - lo) / (hi - lo) * 39.0).round() as usize)
            } else {
                "#".repeat(20)
            };
            println!(
                "  run {:>4} {:<24} {:<8} {:>12.4} {:<40}{}{}",
                p.run_id,
                p.started_at,
                p.status,
                p.value,
                bar,
                if p.regression { " REGRESSION" } else { "" },
                p.change
                    .map(|r| format!(" LEVEL SHIFT x{r:.3} (E-Divisive)"))
                    .unwrap_or_default()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
