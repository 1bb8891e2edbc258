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
mod runner;

pub use cases::{Case, Source};
pub use runner::{default_jobs, run_jobs};

use crate::gpu::{GpuContext, ReductionMethod};
use crate::image::{HdrImage, LinearImage};
use crate::io::LoadOptions;
use crate::operators::reinhard::WHITE_CLAMP;
use crate::reference::luminance_stats::LuminanceStats;
use crate::scene::Scene;
use serde::Serialize;

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
fn reinhard() -> [(&'static str, String); 2] {
    use crate::operators::{REINHARD_AUTO_KEY, REINHARD_GLOBAL};
    [
        (
            "reinhard_global",
            format!("[operator]\nkind = \"{REINHARD_GLOBAL}\"\nkey = 0.18\nwhite_fraction = 0.9\n"),
        ),
        (
            "auto_key_bloom_grade",
            format!(
                "[operator]\nkind = \"{REINHARD_AUTO_KEY}\"\nkey = \"auto\"\ncolour = \"xyy\"\n\
                 [bloom]\nbright_pass = \"scaled\"\nthreshold = 1.0\ndownsample = 2\nradius = 3\nsigma = 1.5\nstrength = 0.5\n\
                 [grade]\ncontrast = 1.2\nsaturation = 0.9\n"
            ),
        ),
    ]
}

/// The pipelines every case goes through, by name: the two Reinhard
/// set-ups, then every other operator known (built-in or registered) at its
/// defaults, named after it (`pbr_neutral`).
pub fn pipelines() -> Vec<(String, Scene)> {
    use crate::operators::{REINHARD_AUTO_KEY, REINHARD_GLOBAL};
    let mut out: Vec<(String, Scene)> = reinhard()
        .iter()
        .map(|(name, body)| (name.to_string(), pipeline_scene(body)))
        .collect();
    for op in crate::operators::all() {
        if [REINHARD_GLOBAL, REINHARD_AUTO_KEY].contains(&op.name()) {
            continue;
        }
        let body = format!("[operator]\nkind = \"{}\"\n", op.name());
        out.push((op.name().replace('-', "_"), pipeline_scene(&body)));
    }
    out
}

/// Whether the plan of pipeline `scene` measures luminance statistics (a
/// fixed-parameter operator without a scaled bright pass measures none).
pub fn measures_statistics(scene: &Scene) -> bool {
    crate::plan::stats_needs(&scene.operator, scene.bloom.as_ref()).any()
}

/// The pipelines case `case` goes through: every one of [`pipelines`], or
/// only those that measure statistics where the case says so.
pub fn case_pipelines(case: &Case) -> Vec<(String, Scene)> {
    pipelines()
        .into_iter()
        .filter(|(_, scene)| !case.statistics_only || measures_statistics(scene))
        .collect()
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
    /// Seconds of the CPU reference's rows (loading each case's input
    /// included) and of the GPU's rows, each summed over rows: with
    /// several rows at a time (`jobs`) their sum exceeds `wall_s`.
    pub cpu_s: f64,
    pub gpu_s: f64,
    pub wall_s: f64,
    /// Rows run at once.
    pub jobs: usize,
}

pub(crate) fn rel(got: f64, want: f64) -> f64 {
    if got == want {
        return 0.0;
    }
    (got - want).abs() / want.abs().max(FLOOR)
}

/// The pairwise sum of `term(i)` over `range`: halves summed apart, down
/// to runs of 64 summed in order. The halves of long runs are summed on two
/// threads; the additions and their order are the same on any number of
/// threads, so the sum is too.
fn pairwise(range: std::ops::Range<usize>, term: &(impl Fn(usize) -> f64 + Sync)) -> f64 {
    let n = range.len();
    if n <= 64 {
        range.map(term).sum()
    } else {
        let mid = range.start + n / 2;
        let (a, b) = (range.start..mid, mid..range.end);
        if n >= 1 << 14 {
            let (a, b) = rayon::join(|| pairwise(a, term), || pairwise(b, term));
            a + b
        } else {
            pairwise(a, term) + pairwise(b, term)
        }
    }
}

/// The statistics by the definitions, computed independently of
/// `reference::luminance_stats`: plain pairwise f64 sums.
pub fn independent_stats(img: &LinearImage, weights: [f64; 3], delta: f64) -> LuminanceStats {
    use rayon::prelude::*;
    let y = |i: usize| {
        let c = img.pixels[i];
        weights[0] * c[0] + weights[1] * c[1] + weights[2] * c[2]
    };
    let log = |i: usize| (delta + y(i)).ln();
    let w = |i: usize| 1.0 - (-y(i)).exp();
    let all = 0..img.pixels.len();
    let n = all.len() as f64;
    let log_average = (pairwise(all.clone(), &log) / n).exp();
    let sw = pairwise(all.clone(), &w);
    let (min, max) = all.clone().into_par_iter().map(|i| (y(i), y(i))).reduce(
        || (f64::INFINITY, f64::NEG_INFINITY),
        |a, b| (a.0.min(b.0), a.1.max(b.1)),
    );
    LuminanceStats {
        log_average: Some(log_average),
        weighted_log_average: Some(if sw > 0.0 {
            (pairwise(all, &|i| w(i) * log(i)) / sw).exp()
        } else {
            log_average
        }),
        min: Some(min),
        max: Some(max),
        weight_sum: Some(sw),
    }
}

/// Largest relative error over the statistics both sides measured.
pub(crate) fn stats_error(got: &LuminanceStats, want: &LuminanceStats) -> f64 {
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

pub(crate) fn all_finite(img: &LinearImage) -> bool {
    use rayon::prelude::*;
    img.pixels
        .par_iter()
        .all(|p| p.iter().all(|v| v.is_finite()))
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
            // The loader names the file; the report names it without the
            // temporary folder, so that two runs' tables are the same.
            let folder = format!("{}{}", dir.path().display(), std::path::MAIN_SEPARATOR);
            let (img, report) = crate::io::load_hdr(&path, &opts)
                .map_err(|e| e.to_string().replace(&folder, ""))?;
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
    run_told(cases, ctx, reduction, &crate::progress::Silent)
}

/// [`run`], telling `progress` of each row.
pub fn run_told(
    cases: &[Case],
    ctx: Option<&GpuContext>,
    reduction: ReductionMethod,
    progress: &dyn crate::progress::Progress,
) -> StressReport {
    let mut reports = runner::run_jobs_told(cases, ctx, &[reduction], default_jobs(), progress);
    reports.pop().unwrap_or_else(|| StressReport {
        adapter: ctx.map(|c| c.adapter.name.clone()),
        bound: BOUND,
        passed: false,
        cases: Vec::new(),
        cpu_s: 0.0,
        gpu_s: 0.0,
        wall_s: 0.0,
        jobs: 1,
    })
}

/// [`run`] once for each of `reductions`, in their order: a report each,
/// with the same CPU rows, for the CPU reference renders each case once
/// (its 8.4 Mpx frame through every pipeline is most of a run's time).
/// Rows run [`default_jobs`] at a time.
pub fn run_reductions(
    cases: &[Case],
    ctx: Option<&GpuContext>,
    reductions: &[ReductionMethod],
) -> Vec<StressReport> {
    run_jobs(cases, ctx, reductions, default_jobs())
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
pub(crate) fn resolved_text(tone: &crate::operators::ToneParams) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The pairwise sum as first written: terms into a vector, halves
    /// summed one after the other on one thread.
    fn sequential(v: &[f64]) -> f64 {
        if v.len() <= 64 {
            v.iter().sum()
        } else {
            let (a, b) = v.split_at(v.len() / 2);
            sequential(a) + sequential(b)
        }
    }

    /// The threaded pairwise sum makes the same additions in the same
    /// order: bit for bit the sequential one, on a length that splits
    /// unevenly and is long enough to go to two threads.
    #[test]
    fn the_threaded_pairwise_sum_is_the_sequential_one_bit_for_bit() {
        let n = 100_003;
        let term = |i: usize| ((i as f64 * 0.618_033_988_7).fract() - 0.3) * 1e3 + 1e-7;
        let terms: Vec<f64> = (0..n).map(term).collect();
        assert_eq!(
            pairwise(0..n, &term).to_bits(),
            sequential(&terms).to_bits()
        );
        // And it is not the plain left-to-right sum (so the test can tell).
        let plain: f64 = terms.iter().sum();
        assert_ne!(plain.to_bits(), sequential(&terms).to_bits());
    }
}
