//! The stress suite: docs/stress.md's stiff and extreme inputs through both
//! renderers, each with its defined behaviour, the error of its statistics
//! against f64 and its time: the error-against-run-time table for extreme
//! inputs.
//!
//! Errors: the CPU reference's statistics are checked against an independent
//! f64 computation (pairwise sums of the same terms, no compensation: the
//! two agree to ~1e-15 unless one of them is wrong); the GPU's against the
//! CPU reference's. Both bounds are the 1e-5 relative statistics bound of
//! docs/tolerances.md.

pub mod cases;
#[cfg(test)]
mod range_safety;

pub use cases::{Case, Source};

use crate::gpu::{GpuConfig, GpuContext, GpuInput, GpuRenderer, HdrFormat, ReductionMethod};
use crate::image::{HdrImage, LinearImage};
use crate::io::LoadOptions;
use crate::operators::reinhard::WHITE_CLAMP;
use crate::plan::{Input, StagePlan};
use crate::reference::luminance_stats::LuminanceStats;
use crate::reference::{render_flat, Pipeline};
use crate::scene::Scene;
use serde::Serialize;
use std::time::Instant;

/// The statistics bound (docs/tolerances.md): relative to the f64 value, with
/// f32's smallest normal as the floor of the denominator (a value that is 0
/// in f64 is compared absolutely at that scale). Worst measured in `check`
/// at defaults on llvmpipe (LLVM 15.0.6), 2026-11-24: 8.37e-7.
pub const BOUND: f64 = 1e-5;
const FLOOR: f64 = f32::MIN_POSITIVE as f64;

/// The Reinhard set-ups every case goes through: `reinhard-global`'s plain
/// log-average with white burning (Reinhard's global operator in real time,
/// docs/bibliography.md), and `reinhard-auto-key`'s weighted mean with the
/// automatic key, bloom and a contrast/saturation grade (so every statistic
/// and every stage runs).
const REINHARD: [(&str, &str); 2] = [
    (
        "reinhard_global",
        "[operator]\nkind = \"reinhard-global\"\nkey = 0.18\nwhite_fraction = 0.9\n",
    ),
    (
        "auto_key_bloom_grade",
        "[operator]\nkind = \"reinhard-auto-key\"\nkey = \"auto\"\ncolour = \"xyy\"\n\
         [bloom]\nbright_pass = \"scaled\"\nthreshold = 1.0\ndownsample = 2\nradius = 3\nsigma = 1.5\nstrength = 0.5\n\
         [grade]\ncontrast = 1.2\nsaturation = 0.9\n",
    ),
];

/// The pipelines every case goes through, by name: the two Reinhard
/// set-ups, then every other operator known (built-in or registered) at its
/// defaults, named after it (`pbr_neutral`).
pub fn pipelines() -> Vec<(String, Scene)> {
    let mut out: Vec<(String, Scene)> = REINHARD
        .iter()
        .map(|(name, body)| (name.to_string(), pipeline_scene(body)))
        .collect();
    for op in crate::operators::all() {
        if ["reinhard-global", "reinhard-auto-key"].contains(&op.name()) {
            continue;
        }
        let body = format!("[operator]\nkind = \"{}\"\n", op.name());
        out.push((op.name().replace('-', "_"), pipeline_scene(&body)));
    }
    out
}

fn pipeline_scene(body: &str) -> Scene {
    let text = format!(
        "name = \"stress\"\nsize = [2, 2]\nframes = 1\n[environment]\nbuiltin = \"sky\"\nsize = [8, 4]\n[rotation]\ndegrees_per_frame = 0.0\n{body}"
    );
    // The texts above are constants; a parse failure is a bug caught by the tests.
    Scene::parse(&text, std::path::Path::new("stress pipeline"))
        .unwrap_or_else(|e| panic!("stress pipeline does not parse: {e}"))
}

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// `<case>/<pipeline>`.
    pub name: String,
    pub case: String,
    pub pipeline: String,
    pub renderer: String,
    /// No non-finite value in any statistic or written pixel (vacuously true
    /// when the input was refused).
    pub finite: bool,
    /// Largest relative error of the statistics (see the module doc); None
    /// when nothing was rendered.
    pub max_rel_error: Option<f64>,
    /// CPU: wall time of the whole plan; GPU: sum of the stages' timestamps.
    pub ms: f64,
    pub behaviour: String,
    /// What was seen: the refusal's message, a promotion, the key used.
    pub observed: String,
    /// The bound this row is held to: 1e-5, or a documented exception's
    /// where it applies (a GPU row on an adapter the subnormal probe found
    /// flushing).
    pub bound: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exception: Option<String>,
    /// Largest 8-bit difference from the CPU's frame (GPU rows).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_lsb_vs_cpu: Option<u16>,
    /// Finite, within its bound, and refused exactly when it must be.
    pub passed: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct StressReport {
    pub adapter: Option<String>,
    pub bound: f64,
    pub cases: Vec<Row>,
    pub passed: bool,
    /// Wall seconds of the CPU reference's rows (loading each case's input
    /// included), of the whole run's: the rest is the GPU's rows.
    pub cpu_s: f64,
    pub wall_s: f64,
}

fn rel(got: f64, want: f64) -> f64 {
    if got == want {
        return 0.0;
    }
    (got - want).abs() / want.abs().max(FLOOR)
}

fn pairwise(v: &[f64]) -> f64 {
    if v.len() <= 64 {
        v.iter().sum()
    } else {
        let (a, b) = v.split_at(v.len() / 2);
        pairwise(a) + pairwise(b)
    }
}

/// The statistics by the definitions, computed independently of
/// `reference::luminance_stats`: plain pairwise f64 sums.
pub fn independent_stats(img: &LinearImage, weights: [f64; 3], delta: f64) -> LuminanceStats {
    let ys: Vec<f64> = img
        .pixels
        .iter()
        .map(|c| weights[0] * c[0] + weights[1] * c[1] + weights[2] * c[2])
        .collect();
    let logs: Vec<f64> = ys.iter().map(|y| (delta + y).ln()).collect();
    let w: Vec<f64> = ys.iter().map(|y| 1.0 - (-y).exp()).collect();
    let wl: Vec<f64> = w.iter().zip(&logs).map(|(w, l)| w * l).collect();
    let n = ys.len() as f64;
    let log_average = (pairwise(&logs) / n).exp();
    let sw = pairwise(&w);
    LuminanceStats {
        log_average: Some(log_average),
        weighted_log_average: Some(if sw > 0.0 {
            (pairwise(&wl) / sw).exp()
        } else {
            log_average
        }),
        min: Some(ys.iter().copied().fold(f64::INFINITY, f64::min)),
        max: Some(ys.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
        weight_sum: Some(sw),
    }
}

/// Largest relative error over the statistics both sides measured.
fn stats_error(got: &LuminanceStats, want: &LuminanceStats) -> f64 {
    [
        (got.log_average, want.log_average),
        (got.weighted_log_average, want.weighted_log_average),
        (got.min, want.min),
        (got.max, want.max),
    ]
    .iter()
    .filter_map(|(g, w)| Some(rel((*g)?, (*w)?)))
    .fold(0.0, f64::max)
}

fn all_finite(img: &LinearImage) -> bool {
    img.pixels.iter().all(|p| p.iter().all(|v| v.is_finite()))
}

/// The case's input after the loader's policy, or the loader's refusal.
pub(crate) fn load(case: &Case, width_limit: u32) -> Result<(HdrImage, String), String> {
    match &case.source {
        Source::Image(img) => Ok((img.clone(), String::new())),
        Source::BeyondTextureLimit { height } => Ok((
            HdrImage::from_fn(width_limit + 1, *height, |x, _| {
                let v = 0.5 + (x % 97) as f32 / 97.0;
                [v, v, v]
            }),
            String::new(),
        )),
        Source::File { image, sanitize } => {
            let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
            let path = dir.path().join(format!("{}.pfm", case.name));
            crate::io::write_image_hdr(&path, image).map_err(|e| e.to_string())?;
            let opts = LoadOptions {
                sanitize: *sanitize,
                ..LoadOptions::default()
            };
            let (img, report) = crate::io::load_hdr(&path, &opts).map_err(|e| e.to_string())?;
            let mut what = Vec::new();
            if report.clamped_negative > 0 {
                what.push(format!(
                    "{} negative components clamped",
                    report.clamped_negative
                ));
            }
            if report.sanitized_nonfinite > 0 {
                what.push(format!(
                    "{} NaN/Inf components zeroed",
                    report.sanitized_nonfinite
                ));
            }
            Ok((img, what.join("; ")))
        }
    }
}

/// Runs every case through both pipelines on the CPU and (when `ctx` is
/// given) the GPU, whose statistics are reduced by `reduction` (`check`
/// passes its own, so `check --reduction tree` holds the tree to the same
/// bounds on every case).
pub fn run(cases: &[Case], ctx: Option<&GpuContext>, reduction: ReductionMethod) -> StressReport {
    let mut reports = run_reductions(cases, ctx, &[reduction]);
    reports.pop().unwrap_or_else(|| StressReport {
        adapter: ctx.map(|c| c.adapter.name.clone()),
        bound: BOUND,
        passed: false,
        cases: Vec::new(),
        cpu_s: 0.0,
        wall_s: 0.0,
    })
}

/// [`run`] once for each of `reductions`, in their order: a report each,
/// with the same CPU rows, for the CPU reference renders each case once
/// (its 8.4 Mpx frame through every pipeline is most of a run's time).
pub fn run_reductions(
    cases: &[Case],
    ctx: Option<&GpuContext>,
    reductions: &[ReductionMethod],
) -> Vec<StressReport> {
    let width_limit = ctx
        .map(|c| c.limits.max_texture_dimension_2d)
        .unwrap_or(16384);
    let mut rows: Vec<Vec<Row>> = vec![Vec::new(); reductions.len()];
    let pipelines = pipelines();
    let started = Instant::now();
    let mut cpu_time = std::time::Duration::ZERO;
    for case in cases {
        for (pname, scene) in &pipelines {
            let pipeline = Pipeline::of_scene(scene);
            // A documented exception is for adapters that flush subnormals:
            // it applies to a GPU row only where the probe found flushing,
            // and never to the CPU reference.
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
            let input = load(case, width_limit);
            // CPU reference.
            let mut cpu = row("cpu");
            let mut cpu_out = None;
            match &input {
                Err(e) => {
                    cpu.observed = format!("refused: {e}");
                    cpu.passed = must_refuse("cpu");
                }
                Ok((img, note)) => {
                    let t = Instant::now();
                    let rendered = render_flat(img, &pipeline);
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
            cpu_time += cpu_started.elapsed();
            for (rows, &reduction) in rows.iter_mut().zip(reductions) {
                rows.push(cpu.clone());
                let Some(ctx) = ctx else { continue };
                rows.push(gpu_row(
                    row("gpu"),
                    case,
                    &input,
                    &cpu_out,
                    ctx,
                    &pipeline,
                    reduction,
                ));
            }
        }
    }
    rows.into_iter()
        .map(|rows| StressReport {
            adapter: ctx.map(|c| c.adapter.name.clone()),
            bound: BOUND,
            passed: rows.iter().all(|r| r.passed),
            cases: rows,
            cpu_s: cpu_time.as_secs_f64(),
            wall_s: started.elapsed().as_secs_f64(),
        })
        .collect()
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
                    let toned = r.read_output("tonemap")?;
                    let display = r.read_output("display")?;
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
                        && toned.as_ref().is_none_or(all_finite)
                        && display.as_ref().is_none_or(all_finite);
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

/// The table as the console prints it.
pub fn table(r: &StressReport) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<44} {:<4} {:>6} {:>10} {:>9} {:>4}  observed",
        "case/pipeline", "on", "finite", "max rel", "ms", "ok"
    );
    for row in &r.cases {
        let _ = writeln!(
            out,
            "{:<44} {:<4} {:>6} {:>10} {:>9.3} {:>4}  {}",
            row.name,
            row.renderer,
            row.finite,
            row.max_rel_error
                .map(|e| format!("{e:.2e}"))
                .unwrap_or_else(|| "-".into()),
            row.ms,
            if row.passed { "ok" } else { "FAIL" },
            row.observed
        );
    }
    let _ = writeln!(
        out,
        "{}: statistics bound {:e} relative (documented exceptions listed in the JSON); adapter {}",
        if r.passed { "PASSED" } else { "FAILED" },
        r.bound,
        r.adapter.as_deref().unwrap_or("none (CPU only)")
    );
    out
}

/// A row's resolved values: "key 0.1800, log_average 1.2346e-1, …".
fn resolved_text(tone: &crate::operators::ToneParams) -> String {
    let parts: Vec<String> = tone
        .values
        .iter()
        .map(|(n, v)| match *n {
            "key" => format!("key {v:.4}"),
            "log_average" => format!("adaptation {v:.4e}"),
            // Outside the curve's range, the white is clamped in both
            // renderers (docs/stress.md#range-safe-arithmetic).
            "white" if *v < WHITE_CLAMP.0 => format!("white {v:.4e} (clamped to 2^-63)"),
            "white" if *v > WHITE_CLAMP.1 => format!("white {v:.4e} (clamped to 2^63)"),
            _ => format!("{n} {v:.4e}"),
        })
        .collect();
    parts.join(", ")
}
