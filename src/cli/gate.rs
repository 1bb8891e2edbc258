//! The gate's commands: `check`, `history` and `tradeoff`.

use super::{gpu_error, invalid, write_json, GpuArgs};
use crate::check::{CheckOptions, CheckOutcome, Renderer};
use crate::error::{Error, Result};
use crate::history::{History, RunKind, RunMeta, RunStatus};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Where the history lives.
#[derive(Args, Clone)]
pub struct DbArgs {
    /// The history database (SQLite, created when absent).
    #[arg(long, env = "TONEGATE_DB", default_value = ".tonegate/history.sqlite")]
    pub db: PathBuf,
}

#[derive(Args)]
pub struct CheckArgs {
    /// The suite file; goldens are found beside it.
    #[arg(long, default_value = "golden/suite.toml")]
    pub suite: PathBuf,
    /// Render with the CPU reference instead of the GPU (checks the gate itself).
    #[arg(long)]
    pub cpu: bool,
    /// Samples per pixel of the render under test (default: each scene's
    /// reference_spp, the goldens' own; 1 = the plain, aliased path). Checks
    /// apply at the spp they name (`spp` in the scene file, default reference_spp).
    #[arg(long)]
    pub spp: Option<u32>,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Write JUnit XML here.
    #[arg(long)]
    pub junit: Option<PathBuf>,
    /// Write the full report as JSON here ("-" for stdout; the table then goes to stderr).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the actual/golden/diff/ssim PNGs of failing frames (and of each scene's worst frame) here
    /// (default: beside the database, artifacts/run-<id>).
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
}

#[derive(Args)]
pub struct HistoryArgs {
    #[command(flatten)]
    pub db: DbArgs,
    /// Only this scene.
    #[arg(long)]
    pub scene: Option<String>,
    /// psnr, ssim, snr, mse, rmse, max_abs_diff, fraction_over_1lsb, fps or a
    /// stage name (median ms). Without it, the run list.
    #[arg(long)]
    pub metric: Option<String>,
    /// Only runs on this adapter (exact name).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Newest runs shown.
    #[arg(long, default_value_t = 20)]
    pub limit: u32,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct TradeoffArgs {
    /// Scenes to sweep (names from the suite); all when none.
    pub scenes: Vec<String>,
    #[arg(long, default_value = "golden/suite.toml")]
    pub suite: PathBuf,
    /// Frames measured per scene.
    #[arg(long, value_delimiter = ',', default_values_t = [0u32, 3])]
    pub frames: Vec<u32>,
    /// Samples per pixel of the f64 reference.
    #[arg(long, default_value_t = 128)]
    pub reference_spp: u32,
    /// Timed renders per frame and configuration.
    #[arg(long, default_value_t = 5)]
    pub repeats: u32,
    /// Output folder for tradeoff.json and the SVG scatter plots.
    #[arg(long, default_value = "out/tradeoff")]
    pub out: PathBuf,
    /// Adapter: "default", "any", or a name substring.
    #[arg(long, default_value = "default")]
    pub adapter: crate::gpu::AdapterChoice,
    #[command(flatten)]
    pub db: DbArgs,
    #[arg(long)]
    pub no_history: bool,
    /// Print the JSON report on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::File {
            path: dir.to_owned(),
            source,
        })?;
    }
    std::fs::write(path, text).map_err(|source| Error::File {
        path: path.to_owned(),
        source,
    })
}

pub fn check(a: CheckArgs) -> Result<ExitCode> {
    if let Some(spp) = a.spp.filter(|&n| n == 0 || n > crate::scene::MAX_SPP) {
        return Err(invalid(format!(
            "--spp must be between 1 and {}, got {spp}",
            crate::scene::MAX_SPP
        )));
    }
    if let Some(g) = a.fault_gain {
        if !(g.is_finite() && g > 0.0) {
            return Err(invalid(format!(
                "--fault-gain must be a positive number, got {g}"
            )));
        }
    }
    let renderer = if a.cpu {
        Renderer::Cpu { spp: a.spp }
    } else {
        let mut config = a.gpu.config();
        config.fault_gain = a.fault_gain;
        Renderer::Gpu {
            adapter: a.gpu.adapter.clone(),
            config,
            spp: a.spp,
        }
    };
    let opts = CheckOptions {
        suite: a.suite.clone(),
        renderer,
        artifacts: a.artifacts.clone(),
        db: (!a.no_history).then(|| a.db.db.clone()),
        progress: true,
        started: None,
    };
    let outcome = crate::check::run(&opts);
    match &outcome {
        CheckOutcome::Finished(report) => {
            let text = crate::check::console::render(report);
            if a.json.as_deref() == Some(Path::new("-")) {
                eprint!("{text}");
            } else {
                print!("{text}");
            }
            if let Some(path) = &a.json {
                write_json(path, report)?;
            }
            if let Some(path) = &a.junit {
                let xml = crate::check::junit::render(report).map_err(invalid)?;
                write_text(path, &xml)?;
            }
        }
        CheckOutcome::Error(e, run) => {
            eprintln!("error: {e}");
            if let Some(id) = run {
                eprintln!(
                    "recorded as run {id} (status error) in {}",
                    a.db.db.display()
                );
            }
            if let Some(path) = &a.junit {
                let xml = crate::check::junit::render_error(&e.to_string()).map_err(invalid)?;
                write_text(path, &xml)?;
            }
            if let Some(path) = &a.json {
                write_json(
                    path,
                    &serde_json::json!({ "passed": false, "error": e.to_string(), "run_id": run }),
                )?;
            }
        }
    }
    Ok(ExitCode::from(outcome.exit_code()))
}

fn history_error(e: crate::history::HistoryError) -> Error {
    invalid(e.to_string())
}

pub fn history(a: HistoryArgs) -> Result<ExitCode> {
    if !a.db.db.exists() {
        return Err(invalid(format!(
            "no history at {} (run `tonegate check` first, or pass --db)",
            a.db.db.display()
        )));
    }
    let h = History::open_read_only(&a.db.db).map_err(history_error)?;
    let Some(metric) = &a.metric else {
        let runs = h.runs(a.limit).map_err(history_error)?;
        let runs: Vec<_> = runs
            .into_iter()
            .filter(|r| {
                a.adapter
                    .as_ref()
                    .is_none_or(|x| r.adapter.as_ref() == Some(x))
            })
            .collect();
        if a.json {
            println!(
                "{}",
                serde_json::to_string_pretty(&runs).map_err(|e| invalid(e.to_string()))?
            );
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
    let points = h
        .trend(
            metric,
            &crate::history::query::TrendFilter {
                scene: a.scene.as_deref(),
                adapter: a.adapter.as_deref(),
                config: None,
                before: None,
                finished_only: false,
                limit: a.limit,
            },
        )
        .map_err(history_error)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&points).map_err(|e| invalid(e.to_string()))?
        );
        return Ok(ExitCode::SUCCESS);
    }
    if points.is_empty() {
        println!("no values of {metric} in {}", a.db.db.display());
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
                "  run {:>4} {:<24} {:<8} {:>12.4} {:<40}{}",
                p.run_id,
                p.started_at,
                p.status,
                p.value,
                bar,
                if p.regression { " REGRESSION" } else { "" }
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

pub fn tradeoff(a: TradeoffArgs) -> Result<ExitCode> {
    if a.reference_spp == 0 || a.reference_spp > crate::scene::MAX_SPP {
        return Err(invalid(format!(
            "--reference-spp must be between 1 and {}, got {}",
            crate::scene::MAX_SPP,
            a.reference_spp
        )));
    }
    if a.repeats == 0 || a.frames.is_empty() {
        return Err(invalid("--repeats and --frames need at least one"));
    }
    let suite = crate::scene::load_suite_file(&a.suite).map_err(|e| invalid(e.to_string()))?;
    let scenes: Vec<_> = if a.scenes.is_empty() {
        suite.scenes.clone()
    } else {
        let mut out = Vec::new();
        for name in &a.scenes {
            match suite.scenes.iter().find(|s| &s.name == name) {
                Some(s) => out.push(s.clone()),
                None => {
                    return Err(invalid(format!(
                        "no scene {name:?} in {}; it has: {}",
                        a.suite.display(),
                        suite
                            .scenes
                            .iter()
                            .map(|s| s.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )))
                }
            }
        }
        out
    };
    let mut history = if a.no_history {
        None
    } else {
        Some(History::open(&a.db.db).map_err(history_error)?)
    };
    let meta = RunMeta {
        suite: Some(a.suite.display().to_string()),
        suite_hash: Some(suite.hash.clone()),
        git_commit: crate::history::git_commit(a.suite.parent().unwrap_or(Path::new("."))),
    };
    let run = match &history {
        Some(h) => Some(
            h.start_run(RunKind::Tradeoff, &meta)
                .map_err(history_error)?,
        ),
        None => None,
    };
    let result = tradeoff_inner(&a, &scenes, history.as_mut(), run);
    if let (Some(h), Some(id)) = (&history, run) {
        let (status, detail, report) = match &result {
            Ok(report) => (RunStatus::Passed, None, serde_json::to_string(report).ok()),
            Err(e) => (RunStatus::Error, Some(e.to_string()), None),
        };
        h.finish_run(id, status, detail.as_deref(), report.as_deref())
            .map_err(history_error)?;
    }
    let report = result?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| invalid(e.to_string()))?
        );
    } else {
        print!("{}", tradeoff_table(&report));
    }
    Ok(ExitCode::SUCCESS)
}

/// What `tradeoff` writes: every scene's points and the suite aggregate.
#[derive(serde::Serialize)]
struct TradeoffReport {
    run_id: Option<i64>,
    adapter: crate::gpu::AdapterReport,
    reference_spp: u32,
    frames: Vec<u32>,
    repeats: u32,
    points: Vec<crate::tradeoff::Point>,
    suite: Vec<crate::tradeoff::Point>,
    plots: Vec<PathBuf>,
}

fn tradeoff_inner(
    a: &TradeoffArgs,
    scenes: &[crate::scene::Scene],
    history: Option<&mut History>,
    run: Option<i64>,
) -> Result<TradeoffReport> {
    let ctx = crate::gpu::GpuContext::new(&a.adapter).map_err(gpu_error)?;
    if let (Some(h), Some(id)) = (history.as_deref(), run) {
        let ad = &ctx.adapter;
        h.set_adapter(
            id,
            &crate::history::RunAdapter {
                name: ad.name.clone(),
                backend: ad.backend.clone(),
                driver: ad.driver.clone(),
                driver_info: ad.driver_info.clone(),
                config: "{}".into(),
            },
        )
        .map_err(history_error)?;
    }
    let opts = crate::tradeoff::TradeoffOptions {
        frames: a.frames.clone(),
        reference_spp: a.reference_spp,
        repeats: a.repeats,
        ..Default::default()
    };
    let total: u64 = scenes
        .iter()
        .map(|s| crate::tradeoff::sweep(s, &opts.spps, &opts.downsamples).len() as u64)
        .sum();
    let bar = crate::golden::progress_bar(total, "tradeoff");
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{prefix:>8} [{bar:30}] {pos}/{len} configurations {msg} ({elapsed})",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    let mut points = Vec::new();
    let mut plots = Vec::new();
    std::fs::create_dir_all(&a.out).map_err(|source| Error::File {
        path: a.out.clone(),
        source,
    })?;
    for scene in scenes {
        bar.set_message(format!(
            "{} (reference at {} spp)",
            scene.name, a.reference_spp
        ));
        let p = crate::tradeoff::measure_scene(&ctx, scene, &opts, |_| bar.inc(1))
            .map_err(|e| invalid(e.to_string()))?;
        let path = a.out.join(format!("tradeoff-{}.svg", scene.name));
        write_text(
            &path,
            &crate::tradeoff::svg::scatter(
                &p,
                &format!(
                    "{}: error against GPU time ({})",
                    scene.name, ctx.adapter.name
                ),
            ),
        )?;
        plots.push(path);
        points.extend(p);
    }
    bar.finish_and_clear();
    let names: Vec<String> = scenes.iter().map(|s| s.name.clone()).collect();
    let suite = crate::tradeoff::aggregate(&points, &names);
    let path = a.out.join("tradeoff.svg");
    write_text(
        &path,
        &crate::tradeoff::svg::scatter(
            &suite,
            &format!(
                "suite: summed GPU time vs worst PSNR ({})",
                ctx.adapter.name
            ),
        ),
    )?;
    plots.insert(0, path);
    if let (Some(h), Some(id)) = (history, run) {
        h.record_tradeoff(id, &points).map_err(history_error)?;
    }
    let report = TradeoffReport {
        run_id: run,
        adapter: ctx.adapter.clone(),
        reference_spp: a.reference_spp,
        frames: a.frames.clone(),
        repeats: a.repeats,
        points,
        suite,
        plots,
    };
    write_json(&a.out.join("tradeoff.json"), &report)?;
    Ok(report)
}

fn tradeoff_table(r: &TradeoffReport) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "adapter {} ({}); reference: CPU f64 at {} spp; frames {:?}; time: median GPU timestamps of {} renders a frame",
        r.adapter.name, r.adapter.backend, r.reference_spp, r.frames, r.repeats
    );
    let _ = writeln!(
        out,
        "{:<40} {:>10} {:>10} {:>9} {:>12} {:>7}",
        "suite (time summed over scenes)", "ms", "PSNR dB", "SSIM", "Lavg rel err", "Pareto"
    );
    let mut rows = r.suite.clone();
    rows.sort_by(|a, b| a.ms.total_cmp(&b.ms));
    for p in &rows {
        let _ = writeln!(
            out,
            "{:<40} {:>10.3} {:>10.2} {:>9.5} {:>12.2e} {:>7}",
            p.label,
            p.ms,
            p.psnr,
            p.ssim,
            p.log_average_rel_error,
            if p.pareto { "*" } else { "" }
        );
    }
    let _ = writeln!(out, "\nPareto front per scene:");
    let mut scenes: Vec<&str> = r.points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    for s in scenes {
        let mut front: Vec<_> = r
            .points
            .iter()
            .filter(|p| p.scene == s && p.pareto)
            .collect();
        front.sort_by(|a, b| a.ms.total_cmp(&b.ms));
        let _ = writeln!(out, "  {s}:");
        for p in front {
            let _ = writeln!(
                out,
                "    {:<38} {:>8.3} ms {:>8.2} dB SSIM {:.5} Lavg {:.2e}",
                p.label, p.ms, p.psnr, p.ssim, p.log_average_rel_error
            );
        }
    }
    let _ = writeln!(
        out,
        "plots: {}",
        r.plots
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    out
}

#[derive(Args)]
pub struct StressArgs {
    /// Print the JSON report instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Leave out the 8.4 Mpx case.
    #[arg(long)]
    pub no_large: bool,
    /// Only these cases (names as in the table).
    #[arg(long, value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Run the CPU reference only (no GPU needed).
    #[arg(long)]
    pub cpu_only: bool,
    /// Adapter: "default", "any", or a name substring.
    #[arg(long, default_value = "default")]
    pub adapter: crate::gpu::AdapterChoice,
}

pub fn stress(a: StressArgs) -> Result<ExitCode> {
    let mut cases = crate::stress::cases::all(!a.no_large);
    if !a.cases.is_empty() {
        let known: Vec<&str> = cases.iter().map(|c| c.name).collect();
        if let Some(bad) = a.cases.iter().find(|n| !known.contains(&n.as_str())) {
            return Err(invalid(format!(
                "no stress case {bad:?}; the cases are: {}",
                known.join(", ")
            )));
        }
        cases.retain(|c| a.cases.iter().any(|n| n == c.name));
    }
    let ctx = if a.cpu_only {
        None
    } else {
        Some(crate::gpu::GpuContext::new(&a.adapter).map_err(gpu_error)?)
    };
    let report = crate::stress::run(&cases, ctx.as_ref());
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| invalid(e.to_string()))?
        );
    } else {
        print!("{}", crate::stress::table(&report));
    }
    Ok(ExitCode::from(if report.passed { 0 } else { 1 }))
}
