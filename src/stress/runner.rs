//! The stress suite's rows: every (case, pipeline) through the CPU
//! reference and the GPU, several at a time, each case's input loaded once.

use super::{
    all_finite, independent_stats, load, measures_statistics, pipelines, rel, resolved_text,
    stats_error, Case, Row, Source, StressReport, BOUND,
};
use crate::gpu::{GpuConfig, GpuContext, GpuInput, GpuRenderer, HdrFormat, ReductionMethod};
use crate::image::HdrImage;
use crate::plan::{Input, StagePlan};
use crate::reference::{render_flat, Pipeline};
use std::time::Instant;

/// How many rows [`run_reductions`](super::run_reductions) runs at once: the machine's cores, at
/// most 8. Each row is one case through one pipeline on both renderers;
/// most of a row's time outside the large case is the GPU driver compiling
/// pipelines for the case's size (their override constants include it),
/// which only more threads shorten: on a 16-core host with an H200, the
/// suite took 22.1 s one row at a time.
pub fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get().min(8))
}

/// Rows over this many input pixels run at most [`BIG_AT_ONCE`] at a time:
/// each holds its input and the CPU reference's intermediates (f64), about
/// 1 GB for the 8.4 Mpx case.
const BIG_PIXELS: u64 = 1 << 20;
const BIG_AT_ONCE: usize = 2;

/// [`run_reductions`](super::run_reductions) with `jobs` rows at a time (1: one after another, as
/// a quiet timing of each row needs). The report lists the rows in the
/// same order whatever `jobs` is; the CPU and GPU seconds are summed over
/// rows, so with several jobs they can exceed the wall time.
pub fn run_jobs(
    cases: &[Case],
    ctx: Option<&GpuContext>,
    reductions: &[ReductionMethod],
    jobs: usize,
) -> Vec<StressReport> {
    run_jobs_told(cases, ctx, reductions, jobs, &crate::progress::Silent)
}

/// [`run_jobs`], telling `progress` of each row as it ends.
pub fn run_jobs_told(
    cases: &[Case],
    ctx: Option<&GpuContext>,
    reductions: &[ReductionMethod],
    jobs: usize,
    progress: &dyn crate::progress::Progress,
) -> Vec<StressReport> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::{Arc, Condvar, Mutex};
    type Loaded = Arc<Result<(HdrImage, String), String>>;
    let width_limit = ctx
        .map(|c| c.limits.max_texture_dimension_2d)
        .unwrap_or(16384);
    let scenes = pipelines();
    let pipelines: Vec<(&str, Pipeline)> = scenes
        .iter()
        .map(|(name, scene)| (name.as_str(), Pipeline::of_scene(scene)))
        .collect();
    let measuring: Vec<bool> = scenes.iter().map(|(_, s)| measures_statistics(s)).collect();
    let started = Instant::now();
    // Every (case, pipeline) the case goes through, biggest inputs first so
    // that the large case does not run alone at the end.
    let mut order: Vec<(usize, usize)> = (0..cases.len())
        .flat_map(|c| (0..pipelines.len()).map(move |p| (c, p)))
        .filter(|&(c, p)| !cases[c].statistics_only || measuring[p])
        .collect();
    order.sort_by_key(|&(c, _)| std::cmp::Reverse(input_pixels(&cases[c], width_limit)));
    // Each case's input is loaded once, by the first row that needs it, and
    // dropped once its last row has taken it.
    let inputs: Vec<Mutex<(Option<Loaded>, usize)>> = (0..cases.len())
        .map(|c| Mutex::new((None, order.iter().filter(|&&(oc, _)| oc == c).count())))
        .collect();
    let big = (Mutex::new(0usize), Condvar::new());
    let next = AtomicUsize::new(0);
    let done: Vec<Mutex<Option<Done>>> = order.iter().map(|_| Mutex::new(None)).collect();
    progress.start("stress", order.len() as u64, "rows");
    let work = || loop {
        let i = next.fetch_add(1, Ordering::Relaxed);
        let Some(&(c, p)) = order.get(i) else { break };
        let case = &cases[c];
        let is_big = input_pixels(case, width_limit) > BIG_PIXELS;
        if is_big {
            let mut running = big.0.lock().unwrap_or_else(|e| e.into_inner());
            while *running >= BIG_AT_ONCE {
                running = big.1.wait(running).unwrap_or_else(|e| e.into_inner());
            }
            *running += 1;
        }
        let load_started = Instant::now();
        let input = {
            let mut slot = inputs[c].lock().unwrap_or_else(|e| e.into_inner());
            let input = slot
                .0
                .get_or_insert_with(|| Arc::new(load(case, width_limit)))
                .clone();
            slot.1 -= 1;
            if slot.1 == 0 {
                slot.0 = None;
            }
            input
        };
        let load_s = load_started.elapsed().as_secs_f64();
        let (name, pipeline) = &pipelines[p];
        let mut row_done = row_of(case, name, pipeline, &input, ctx, reductions);
        progress.advance(1);
        row_done.cpu_s += load_s;
        drop(input);
        if is_big {
            *big.0.lock().unwrap_or_else(|e| e.into_inner()) -= 1;
            big.1.notify_one();
        }
        *done[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(row_done);
    };
    std::thread::scope(|s| {
        for _ in 1..jobs.max(1) {
            s.spawn(work);
        }
        work();
    });
    progress.finish();
    // Back into the table's order: case by case, pipelines in turn.
    let mut by_place: Vec<Option<Done>> =
        (0..cases.len() * pipelines.len()).map(|_| None).collect();
    for (i, &(c, p)) in order.iter().enumerate() {
        by_place[c * pipelines.len() + p] =
            done[i].lock().unwrap_or_else(|e| e.into_inner()).take();
    }
    let (mut cpu_s, mut gpu_s) = (0.0, 0.0);
    let mut rows: Vec<Vec<Row>> = vec![Vec::new(); reductions.len()];
    for d in by_place.into_iter().flatten() {
        cpu_s += d.cpu_s;
        gpu_s += d.gpu_s;
        for ((rows, gpu), _) in rows.iter_mut().zip(d.gpu).zip(reductions) {
            rows.push(d.cpu.clone());
            rows.extend(gpu);
        }
    }
    rows.into_iter()
        .map(|rows| StressReport {
            adapter: ctx.map(|c| c.adapter.name.clone()),
            bound: BOUND,
            passed: rows.iter().all(|r| r.passed),
            cases: rows,
            cpu_s,
            gpu_s,
            wall_s: started.elapsed().as_secs_f64(),
            jobs: jobs.max(1),
        })
        .collect()
}

/// The pixels a case's input has (the large case's are what bound memory).
fn input_pixels(case: &Case, width_limit: u32) -> u64 {
    let size = |img: &HdrImage| img.width as u64 * img.height as u64;
    match &case.source {
        Source::Image(img) | Source::File { image: img, .. } => size(img),
        Source::BeyondTextureLimit { height } => (width_limit as u64 + 1) * *height as u64,
    }
}

/// One case through one pipeline: its CPU row, its GPU row for each
/// reduction (none without an adapter), and the seconds each side took.
struct Done {
    cpu: Row,
    gpu: Vec<Option<Row>>,
    cpu_s: f64,
    gpu_s: f64,
}

fn row_of(
    case: &Case,
    pname: &str,
    pipeline: &Pipeline,
    input: &Result<(HdrImage, String), String>,
    ctx: Option<&GpuContext>,
    reductions: &[ReductionMethod],
) -> Done {
    // A documented exception is for adapters that flush subnormals: it
    // applies to a GPU row only where the probe found flushing, and never
    // to the CPU reference.
    let excused = |renderer: &str| {
        renderer == "gpu" && ctx.is_some_and(|c| c.adapter.flushes_subnormals == Some(true))
    };
    let row = |renderer: &str| Row {
        name: format!("{}/{pname}", case.name),
        case: case.name.into(),
        pipeline: pname.into(),
        renderer: renderer.into(),
        finite: true,
        max_rel_error: None,
        ms: 0.0,
        behaviour: case.behaviour.into(),
        observed: String::new(),
        bound: case
            .exception
            .filter(|_| excused(renderer))
            .map_or(BOUND, |e| e.1),
        exception: case
            .exception
            .filter(|_| excused(renderer))
            .map(|e| e.0.to_string()),
        max_lsb_vs_cpu: None,
        passed: false,
    };
    let must_refuse = |r: &str| case.refused_by.contains(&r);
    let cpu_started = Instant::now();
    // CPU reference.
    let mut cpu = row("cpu");
    let mut cpu_out = None;
    match input {
        Err(e) => {
            cpu.observed = format!("refused: {e}");
            cpu.passed = must_refuse("cpu");
        }
        Ok((img, note)) => {
            let t = Instant::now();
            let rendered = render_flat(img, pipeline);
            cpu.ms = t.elapsed().as_secs_f64() * 1e3;
            match rendered {
                // Plans are built valid: a fault is a tonegate bug, shown as a failed row.
                Err(e) => cpu.observed = format!("error: {e}"),
                Ok((_, out)) => {
                    let lum = pipeline.operator.luminance();
                    let independent = independent_stats(&out.hdr, lum.weights, lum.delta);
                    let err = stats_error(&out.stats, &independent);
                    cpu.finite = all_finite(&out.hdr)
                        && all_finite(&out.toned)
                        && all_finite(&out.display)
                        && out.bloom.as_ref().is_none_or(all_finite)
                        && out.tone.sane();
                    cpu.max_rel_error = Some(err);
                    cpu.observed = format!(
                        "{}{}{}",
                        resolved_text(&out.tone),
                        if note.is_empty() { "" } else { "; " },
                        note
                    );
                    cpu.passed = !must_refuse("cpu") && cpu.finite && err <= cpu.bound;
                    cpu_out = Some(out);
                }
            }
        }
    }
    let cpu_s = cpu_started.elapsed().as_secs_f64();
    let gpu_started = Instant::now();
    let gpu = reductions
        .iter()
        .map(|&reduction| {
            ctx.map(|ctx| gpu_row(row("gpu"), case, input, &cpu_out, ctx, pipeline, reduction))
        })
        .collect();
    Done {
        cpu,
        gpu,
        cpu_s,
        gpu_s: gpu_started.elapsed().as_secs_f64(),
    }
}

/// A case's GPU row: rendered with `reduction`, held to the CPU
/// reference's output `reference` of the same input.
fn gpu_row(
    mut gpu: Row,
    case: &Case,
    input: &Result<(HdrImage, String), String>,
    reference: &Option<crate::reference::FrameOutputs>,
    ctx: &GpuContext,
    pipeline: &Pipeline,
    reduction: ReductionMethod,
) -> Row {
    let must_refuse = |r: &str| case.refused_by.contains(&r);
    match (input, reference) {
        (Err(e), _) => {
            gpu.observed = format!("refused: {e}");
            gpu.passed = must_refuse("gpu");
        }
        (Ok((img, _)), Some(reference)) => {
            let config = GpuConfig {
                hdr_format: if case.f16 {
                    HdrFormat::Rgba16Float
                } else {
                    HdrFormat::Rgba32Float
                },
                reduction,
                ..Default::default()
            };
            let plan = StagePlan::build(
                Input::Flat,
                pipeline.operator,
                pipeline.bloom,
                pipeline.grade,
            );
            let rendered = GpuRenderer::new(ctx, plan, GpuInput::Flat(img), pipeline, config)
                .and_then(|r| {
                    // The first dispatch of a pipeline compiles it on
                    // llvmpipe: one warm-up render keeps that out of `ms`.
                    r.render(false)?;
                    let out = r.render(true)?;
                    let toned = r.output_finite("tonemap")?;
                    let display = r.output_finite("display")?;
                    Ok((r.notes.clone(), out, toned, display))
                });
            match rendered {
                Err(e) => {
                    gpu.observed = format!("refused: {e}");
                    gpu.passed = must_refuse("gpu");
                }
                Ok((notes, out, toned, display)) => {
                    let s = out.stats;
                    let got = s.luminance_stats();
                    let tone = pipeline.operator.gpu_resolved(s.tone);
                    // Only what the plan measured is compared.
                    let want = reference.stats;
                    let mut err = stats_error(&got, &want);
                    if want.log_average.is_some() || want.weighted_log_average.is_some() {
                        if let (Some(g), Some(w)) =
                            (tone.get("log_average"), reference.tone.get("log_average"))
                        {
                            err = err.max(rel(g, w));
                        }
                    }
                    gpu.finite = [s.log_average, s.weighted_log_average, s.min, s.max]
                        .iter()
                        .all(|v| v.is_finite())
                        && tone.sane()
                        && toned != Some(false)
                        && display != Some(false);
                    gpu.max_rel_error = Some(err);
                    gpu.ms = out.timings.iter().map(|t| t.ms).sum();
                    gpu.max_lsb_vs_cpu = out
                        .frame
                        .as_ref()
                        .and_then(|f| crate::metrics::frame_max_abs_diff(f, &reference.frame).ok());
                    gpu.observed = format!(
                        "{}{}{}",
                        resolved_text(&tone),
                        if notes.is_empty() { "" } else { "; " },
                        notes.join("; ")
                    );
                    gpu.passed = !must_refuse("gpu") && gpu.finite && err <= gpu.bound;
                }
            }
        }
        (Ok(_), None) => {
            gpu.observed = "no CPU reference to compare with".into();
        }
    }
    gpu
}
