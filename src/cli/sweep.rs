//! The sweeps: `tradeoff` (error against run time) and `stress` (extreme inputs).

use super::progress::Bar;
use super::DbArgs;
use super::{invalid, json_text, write_json, write_text};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use tonegate::error::{Error, Result};
use tonegate::gpu::{AdapterChoice, GpuContext};
use tonegate::history::{History, RunAdapter, RunKind, RunMeta, RunStatus};
use tonegate::progress::Progress;
use tonegate::scene::{Scene, MAX_SPP};

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
    /// Adapter: "default" (lavapipe when present), "hardware" (the best GPU), "any", or a name substring.
    #[arg(long, default_value = "default")]
    pub adapter: AdapterChoice,
    #[command(flatten)]
    pub backend: crate::cli::BackendArg,
    #[command(flatten)]
    pub db: DbArgs,
    #[arg(long)]
    pub no_history: bool,
    /// Print the JSON report on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn tradeoff(a: TradeoffArgs) -> Result<ExitCode> {
    a.db.set_retry(10);
    if a.reference_spp == 0 || a.reference_spp > MAX_SPP {
        return Err(invalid(format!(
            "--reference-spp must be between 1 and {MAX_SPP}, got {}",
            a.reference_spp
        )));
    }
    if a.repeats == 0 || a.frames.is_empty() {
        return Err(invalid("--repeats and --frames need at least one"));
    }
    let suite = tonegate::suite::load_suite_file(&a.suite)?;
    let scenes = suite
        .select(&a.scenes)
        .map_err(|e| invalid(format!("{}: {e}", a.suite.display())))?;
    let mut history = if a.no_history {
        None
    } else {
        Some(History::open(&a.db.db)?)
    };
    let meta = RunMeta {
        suite: Some(a.suite.display().to_string()),
        suite_hash: Some(suite.hash.clone()),
        git_commit: tonegate::history::git_commit(a.suite.parent().unwrap_or(Path::new("."))),
    };
    let run = match &history {
        Some(h) => Some(h.start_run(RunKind::Tradeoff, &meta)?),
        None => None,
    };
    let result = tradeoff_inner(&a, &scenes, history.as_mut(), run);
    if let (Some(h), Some(id)) = (&history, run) {
        let (status, detail, report) = match &result {
            Ok(report) => (RunStatus::Passed, None, serde_json::to_string(report).ok()),
            Err(e) => (RunStatus::Error, Some(e.to_string()), None),
        };
        h.finish_run(id, status, detail.as_deref(), report.as_deref())?;
    }
    let report = result?;
    if a.json {
        println!("{}", json_text("the tradeoff report", &report)?);
    } else {
        print!("{}", tradeoff_table(&report));
    }
    Ok(ExitCode::SUCCESS)
}

/// What `tradeoff` writes: every scene's points and the suite aggregate.
#[derive(serde::Serialize)]
struct TradeoffReport {
    run_id: Option<i64>,
    adapter: tonegate::gpu::AdapterReport,
    reference_spp: u32,
    frames: Vec<u32>,
    repeats: u32,
    points: Vec<tonegate::tradeoff::Point>,
    suite: Vec<tonegate::tradeoff::Point>,
    plots: Vec<PathBuf>,
}

fn tradeoff_inner(
    a: &TradeoffArgs,
    scenes: &[Scene],
    history: Option<&mut History>,
    run: Option<i64>,
) -> Result<TradeoffReport> {
    let ctx = GpuContext::new(&a.backend.apply(&a.adapter))?;
    if let (Some(h), Some(id)) = (history.as_deref(), run) {
        let ad = &ctx.adapter;
        h.set_adapter(
            id,
            &RunAdapter {
                name: ad.name.clone(),
                backend: ad.backend.clone(),
                driver: ad.driver.clone(),
                driver_info: ad.driver_info.clone(),
                config: "{}".into(),
            },
        )?;
    }
    let opts = tonegate::tradeoff::TradeoffOptions {
        frames: a.frames.clone(),
        reference_spp: a.reference_spp,
        repeats: a.repeats,
        ..Default::default()
    };
    let total: u64 = scenes
        .iter()
        .map(|s| tonegate::tradeoff::sweep(s, &opts.spps, &opts.downsamples).len() as u64)
        .sum();
    let bar = Bar::new();
    bar.start("tradeoff", total, "configurations");
    let mut points = Vec::new();
    let mut plots = Vec::new();
    std::fs::create_dir_all(&a.out).map_err(|source| Error::File {
        path: a.out.clone(),
        source,
    })?;
    for scene in scenes {
        bar.working_on(&format!(
            "{} (reference at {} spp)",
            scene.name, a.reference_spp
        ));
        let p = tonegate::tradeoff::measure_scene(&ctx, scene, &opts, |_| bar.advance(1))?;
        let path = a.out.join(format!("tradeoff-{}.svg", scene.name));
        write_text(
            &path,
            &tonegate::tradeoff::svg::scatter(
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
    bar.finish();
    let names: Vec<String> = scenes.iter().map(|s| s.name.clone()).collect();
    let suite = tonegate::tradeoff::aggregate(&points, &names);
    let path = a.out.join("tradeoff.svg");
    write_text(
        &path,
        &tonegate::tradeoff::svg::scatter(
            &suite,
            &format!(
                "suite: summed GPU time vs worst PSNR ({})",
                ctx.adapter.name
            ),
        ),
    )?;
    plots.insert(0, path);
    if let (Some(h), Some(id)) = (history, run) {
        let records: Vec<_> = points.iter().map(tonegate::tradeoff::record).collect();
        h.record_tradeoff(id, &records)?;
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
    write_json(&a.out.join("tradeoff.json"), "tradeoff.json", &report)?;
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
        "{:<56} {:>10} {:>10} {:>9} {:>12} {:>7}",
        "suite (time summed over scenes)", "ms", "PSNR dB", "SSIM", "Lavg rel err", "Pareto"
    );
    let mut rows = r.suite.clone();
    rows.sort_by(|a, b| a.ms.total_cmp(&b.ms));
    for p in &rows {
        let _ = writeln!(
            out,
            "{:<56} {:>10.3} {:>10.2} {:>9.5} {:>12.2e} {:>7}",
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
                "    {:<54} {:>8.3} ms {:>8.2} dB SSIM {:.5} Lavg {:.2e}",
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
    /// Adapter: "default" (lavapipe when present), "hardware" (the best GPU), "any", or a name substring.
    #[arg(long, default_value = "default")]
    pub adapter: AdapterChoice,
    #[command(flatten)]
    pub backend: crate::cli::BackendArg,
    /// Luminance reduction on the GPU: auto (block on a CPU adapter, subgroup or tree on a GPU), block, pingpong, tree or subgroup.
    #[arg(long, default_value = "auto", value_parser = crate::cli::by_name::<tonegate::gpu::ReductionMethod>)]
    pub reduction: tonegate::gpu::ReductionMethod,
    /// Rows run at once (default: the cores, at most 8). 1 runs them one
    /// after another, for each row's time on a quiet machine.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub jobs: Option<u32>,
}

pub fn stress(a: StressArgs) -> Result<ExitCode> {
    let mut cases = tonegate::stress::cases::all(!a.no_large);
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
        Some(GpuContext::new(&a.backend.apply(&a.adapter))?)
    };
    let jobs = a
        .jobs
        .map_or_else(tonegate::stress::default_jobs, |j| j as usize);
    let report = tonegate::stress::run_jobs(&cases, ctx.as_ref(), &[a.reduction], jobs)
        .pop()
        .ok_or_else(|| invalid("the stress suite made no report".to_string()))?;
    if a.json {
        println!("{}", json_text("the stress report", &report)?);
    } else {
        print!("{}", tonegate::stress::table(&report));
    }
    Ok(ExitCode::from(if report.passed { 0 } else { 1 }))
}
