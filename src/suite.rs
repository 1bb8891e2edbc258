//! One scene of a suite rendered (GPU or CPU reference) and judged against its
//! goldens: every frame compared with every metric, the scene's typed checks
//! evaluated with adapter overrides applied, seed 002's static and moving
//! summaries. `check` (src/check/) runs this over a whole suite.

use crate::conventions::rotation_matrix;
use crate::golden::{read_frame, scene_environment, GoldenError};
use crate::gpu::timing::{summarise, TimingSummary};
use crate::gpu::{GpuConfig, GpuContext, GpuInput, GpuRenderer};
use crate::image::Rgb8Image;
use crate::metrics::{compare, fraction_over, Metrics};
use crate::plan::StagePlan;
use crate::reference::{render_frame, scene_camera, Pipeline};
use crate::scene::{Check, CheckSpec, Scene};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// A golden frame or the scene's environment could not be read.
    #[error(transparent)]
    Golden(#[from] GoldenError),
    /// The GPU failed while rendering the scene.
    #[error("scene {scene}: {source}")]
    Gpu {
        scene: String,
        source: crate::gpu::GpuError,
    },
    /// A frame could not be compared with its golden (sizes differ).
    #[error("scene {scene}, frame {frame}: {source}")]
    Metrics {
        scene: String,
        frame: u32,
        source: crate::metrics::MetricsError,
    },
}

/// Seed 002's two kinds of test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TestKind {
    /// No motion (ω = 0): the checks judge the converged frame, the last one.
    Static,
    /// A rotating sequence: the checks judge every frame; the report gives
    /// best / worst / mean per metric with the frame index (ghosting tables).
    Moving,
}

impl TestKind {
    pub fn of(scene: &Scene) -> TestKind {
        if scene.rotation.degrees_per_frame == 0.0 {
            TestKind::Static
        } else {
            TestKind::Moving
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct FrameResult {
    pub frame: u32,
    pub metrics: Metrics,
    /// Fraction of pixels off by more than k LSB, for each k a check asks
    /// about (1 is in `metrics`).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub fraction_over: BTreeMap<u8, f64>,
    /// Indices (into the scene's `checks`) of the per-frame checks this frame fails.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub failed_checks: Vec<usize>,
    /// Artifact files written for this frame (failing frames, and each
    /// scene's worst judged frame).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub artifacts: Vec<String>,
}

impl FrameResult {
    fn fraction(&self, lsb: u8) -> f64 {
        if lsb == 1 {
            self.metrics.fraction_over_1lsb
        } else {
            self.fraction_over.get(&lsb).copied().unwrap_or(f64::NAN)
        }
    }
}

/// Best, worst and mean of one metric over a sequence, with frame indices
/// (seed 002's ghosting tables).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub best: f64,
    pub best_frame: u32,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub worst: f64,
    pub worst_frame: u32,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub mean: f64,
}

impl Summary {
    /// `higher_is_better` says which end is best. Ties keep the first frame.
    pub fn of(values: &[(u32, f64)], higher_is_better: bool) -> Summary {
        let Some(&first) = values.first() else {
            return Summary {
                best: f64::NAN,
                best_frame: 0,
                worst: f64::NAN,
                worst_frame: 0,
                mean: f64::NAN,
            };
        };
        let mut best = first;
        let mut worst = first;
        let mut sum = 0.0;
        for &(f, v) in values {
            let (better, worse) = if higher_is_better {
                (v > best.1, v < worst.1)
            } else {
                (v < best.1, v > worst.1)
            };
            if better {
                best = (f, v);
            }
            if worse {
                worst = (f, v);
            }
            sum += v;
        }
        Summary {
            best: best.1,
            best_frame: best.0,
            worst: worst.1,
            worst_frame: worst.0,
            mean: sum / values.len() as f64,
        }
    }
}

/// The metrics summarised per sequence, and which way is better.
pub const SUMMARISED: [(&str, bool); 7] = [
    ("psnr", true),
    ("ssim", true),
    ("snr", true),
    ("mse", false),
    ("rmse", false),
    ("max_abs_diff", false),
    ("fraction_over_1lsb", false),
];

/// The named metric of a frame.
pub fn metric(m: &Metrics, name: &str) -> Option<f64> {
    Some(match name {
        "psnr" => m.psnr,
        "ssim" => m.ssim,
        "snr" => m.snr,
        "mse" => m.mse,
        "rmse" => m.rmse,
        "max_abs_diff" => m.max_abs_diff as f64,
        "fraction_over_1lsb" => m.fraction_over_1lsb,
        _ => return None,
    })
}

#[derive(Clone, Debug, Serialize)]
pub struct CheckResult {
    pub spec: CheckSpec,
    /// None when the check does not apply here (timing on the CPU, another
    /// adapter's bound, a generic bound overridden by this adapter's).
    pub passed: Option<bool>,
    pub detail: String,
    /// The frame that decided a per-frame check (its worst).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame: Option<u32>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub scene: String,
    pub test: TestKind,
    pub renderer: String,
    /// The adapter name checks' `adapter` overrides are matched against.
    pub adapter: String,
    pub spp: u32,
    pub plan: Vec<&'static str>,
    pub frames: Vec<FrameResult>,
    /// The frames the checks judged: the last one for a static test, all for a moving one.
    pub judged_frames: Vec<u32>,
    /// Best / worst / mean over every frame, per metric (see [`SUMMARISED`]).
    pub summaries: BTreeMap<String, Summary>,
    pub checks: Vec<CheckResult>,
    /// Why the scene fails regardless of its checks (for example: none apply).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<String>,
    /// Per-stage GPU time (median, p95) over the sequence; empty on the CPU.
    pub timings: Vec<TimingSummary>,
    /// Frames per second with readback (GPU only).
    pub fps: Option<f64>,
}

impl SceneResult {
    pub fn passed(&self) -> bool {
        self.problems.is_empty() && self.checks.iter().all(|c| c.passed != Some(false))
    }

    pub fn summary(&self, metric: &str) -> Option<&Summary> {
        self.summaries.get(metric)
    }

    pub fn failed_checks(&self) -> impl Iterator<Item = &CheckResult> {
        self.checks.iter().filter(|c| c.passed == Some(false))
    }
}

/// What makes two checks the same kind, so an adapter's bound can override
/// the generic one: the variant, plus the stage or the LSB count.
pub fn check_kind(check: &Check) -> String {
    match check {
        Check::MinPsnr(_) => "min_psnr".into(),
        Check::MinSsim(_) => "min_ssim".into(),
        Check::MaxMse(_) => "max_mse".into(),
        Check::MaxAbsDiff(_) => "max_abs_diff".into(),
        Check::MaxFractionOver { lsb, .. } => format!("max_fraction_over:{lsb}"),
        Check::MaxStageMs { stage, .. } => format!("max_stage_ms:{stage}"),
        Check::MinFps(_) => "min_fps".into(),
    }
}

/// A short human name of a check, for tables and JUnit test cases.
pub fn check_label(spec: &CheckSpec) -> String {
    let base = match &spec.check {
        Check::MinPsnr(v) => format!("PSNR >= {v} dB"),
        Check::MinSsim(v) => format!("SSIM >= {v}"),
        Check::MaxMse(v) => format!("MSE <= {v}"),
        Check::MaxAbsDiff(v) => format!("max abs diff <= {v}"),
        Check::MaxFractionOver { lsb, fraction } => {
            format!("fraction over {lsb} LSB <= {fraction}")
        }
        Check::MaxStageMs { stage, ms } => format!("{stage} <= {ms} ms"),
        Check::MinFps(v) => format!("FPS >= {v}"),
    };
    match &spec.adapter {
        Some(a) => format!("{base} [{a}]"),
        None => base,
    }
}

/// What a check's applicability depends on: the renderer and its spp.
#[derive(Clone, Copy, Debug)]
pub struct Judged<'a> {
    /// The adapter name (`cpu-reference` on the CPU).
    pub adapter: &'a str,
    /// Samples per pixel of the render under test.
    pub spp: u32,
    /// The scene's `reference_spp`: the spp of checks that name none.
    pub reference_spp: u32,
}

fn adapter_matches(spec: &CheckSpec, adapter: &str) -> bool {
    spec.adapter
        .as_ref()
        .map(|a| adapter.to_lowercase().contains(&a.to_lowercase()))
        .unwrap_or(true)
}

fn spp_matches(spec: &CheckSpec, on: Judged) -> bool {
    spec.spp.unwrap_or(on.reference_spp) == on.spp
}

/// Why a check is not applied here, if it is not: a bound for another spp,
/// another adapter's bound, or a generic bound this adapter overrides.
pub fn not_applied(specs: &[CheckSpec], index: usize, on: Judged) -> Option<String> {
    let spec = &specs[index];
    let adapter = on.adapter;
    if !spp_matches(spec, on) {
        return Some(format!(
            "a bound for {} spp; this render has {}",
            spec.spp.unwrap_or(on.reference_spp),
            on.spp
        ));
    }
    if !adapter_matches(spec, adapter) {
        return Some(format!(
            "applies to adapter {:?} only",
            spec.adapter.as_deref().unwrap_or("")
        ));
    }
    if spec.adapter.is_none() {
        let kind = check_kind(&spec.check);
        if let Some(o) = specs.iter().find(|o| {
            o.adapter.is_some()
                && adapter_matches(o, adapter)
                && spp_matches(o, on)
                && check_kind(&o.check) == kind
        }) {
            return Some(format!(
                "overridden by the {:?} bound ({})",
                o.adapter.as_deref().unwrap_or(""),
                check_label(o)
            ));
        }
    }
    None
}

/// `v < min`, with NaN failing too.
fn below(v: f64, min: f64) -> bool {
    v.partial_cmp(&min)
        .is_none_or(|o| o == std::cmp::Ordering::Less)
}

/// `v > max`, with NaN failing too.
fn above(v: f64, max: f64) -> bool {
    v.partial_cmp(&max)
        .is_none_or(|o| o == std::cmp::Ordering::Greater)
}

/// Whether `frame` fails a per-frame check; None for run-level checks.
fn frame_fails(check: &Check, frame: &FrameResult) -> Option<bool> {
    let m = &frame.metrics;
    Some(match check {
        Check::MinPsnr(b) => below(m.psnr, *b),
        Check::MinSsim(b) => below(m.ssim, *b),
        Check::MaxMse(b) => above(m.mse, *b),
        Check::MaxAbsDiff(b) => m.max_abs_diff > *b,
        Check::MaxFractionOver { lsb, fraction } => above(frame.fraction(*lsb), *fraction),
        Check::MaxStageMs { .. } | Check::MinFps(_) => return None,
    })
}

/// Evaluates check `index` of `specs` over the judged `frames`.
pub fn evaluate(
    specs: &[CheckSpec],
    index: usize,
    frames: &[&FrameResult],
    on: Judged,
    timings: &[TimingSummary],
    fps: Option<f64>,
) -> CheckResult {
    let spec = &specs[index];
    let result = |passed: Option<bool>, detail: String, frame: Option<u32>| CheckResult {
        spec: spec.clone(),
        passed,
        detail,
        frame,
    };
    if let Some(why) = not_applied(specs, index, on) {
        return result(None, why, None);
    }
    // (value, frame) of the worst judged frame; NaN counts as worst.
    let worst = |f: &dyn Fn(&FrameResult) -> f64, lower_is_worse: bool| {
        frames
            .iter()
            .map(|r| (f(r), r.frame))
            .reduce(|(w, wf), (v, fr)| {
                let worse = v.is_nan() || if lower_is_worse { v < w } else { v > w };
                if worse && !w.is_nan() {
                    (v, fr)
                } else {
                    (w, wf)
                }
            })
    };
    let per_frame = |value: &dyn Fn(&FrameResult) -> f64,
                     lower_is_worse: bool,
                     show: &dyn Fn(f64) -> String| {
        match worst(value, lower_is_worse) {
            None => result(Some(false), "no frames to judge".into(), None),
            Some((v, f)) => {
                let failed = frames
                    .iter()
                    .filter(|fr| frame_fails(&spec.check, fr) == Some(true))
                    .count();
                let passed = failed == 0;
                let detail = if passed {
                    format!("worst {} at frame {f}", show(v))
                } else {
                    format!(
                        "worst {} at frame {f}; {failed} of {} judged frames fail",
                        show(v),
                        frames.len()
                    )
                };
                result(Some(passed), detail, Some(f))
            }
        }
    };
    match &spec.check {
        Check::MinPsnr(_) => per_frame(&|r| r.metrics.psnr, true, &|v| format!("PSNR {v:.2} dB")),
        Check::MinSsim(_) => per_frame(&|r| r.metrics.ssim, true, &|v| format!("SSIM {v:.5}")),
        Check::MaxMse(_) => per_frame(&|r| r.metrics.mse, false, &|v| format!("MSE {v:.4}")),
        Check::MaxAbsDiff(_) => per_frame(&|r| r.metrics.max_abs_diff as f64, false, &|v| {
            format!("max abs diff {v} LSB")
        }),
        Check::MaxFractionOver { lsb, .. } => per_frame(&|r| r.fraction(*lsb), false, &|v| {
            format!("fraction over {lsb} LSB {v:.5}")
        }),
        Check::MaxStageMs { stage, ms } => match timings.iter().find(|t| &t.name == stage) {
            Some(t) => result(
                Some(t.median_ms <= *ms),
                format!("{stage} median {:.3} ms (max {ms})", t.median_ms),
                None,
            ),
            None => result(None, format!("no GPU timing for stage {stage}"), None),
        },
        Check::MinFps(bound) => match fps {
            Some(v) => result(
                Some(v >= *bound),
                format!("{v:.1} FPS with readback (min {bound})"),
                None,
            ),
            None => result(None, "FPS is measured on the GPU renderer".into(), None),
        },
    }
}

/// What a renderer produced for one scene.
pub struct Rendered {
    /// Renderer description for reports.
    pub renderer: String,
    /// Adapter name the checks' `adapter` overrides are matched against.
    pub adapter: String,
    pub spp: u32,
    pub frames: Vec<Rgb8Image>,
    pub timings: Vec<TimingSummary>,
    pub fps: Option<f64>,
}

/// A frame whose images are kept as artifacts (a failing frame, or the
/// scene's worst judged frame so a passing run can be looked at too).
pub struct KeptFrame {
    pub frame: u32,
    /// Whether the frame failed a check (else it is the scene's worst frame).
    pub failed: bool,
    pub actual: Rgb8Image,
    pub golden: Rgb8Image,
}

/// Compares rendered frames with the goldens under `root` and evaluates the
/// scene's checks. Returns the images of the failing frames and of the worst
/// judged frame (lowest PSNR), for artifacts.
pub fn judge(
    root: &Path,
    scene: &Scene,
    rendered: Rendered,
) -> Result<(SceneResult, Vec<KeptFrame>), SuiteError> {
    let Rendered {
        renderer,
        adapter,
        spp,
        frames: images,
        timings,
        fps,
    } = rendered;
    let mut lsbs: Vec<u8> = scene
        .checks
        .iter()
        .filter_map(|c| match c.check {
            Check::MaxFractionOver { lsb, .. } if lsb != 1 => Some(lsb),
            _ => None,
        })
        .collect();
    lsbs.sort_unstable();
    lsbs.dedup();
    let mut frames = Vec::with_capacity(images.len());
    let mut goldens = Vec::with_capacity(images.len());
    for (n, frame) in images.iter().enumerate() {
        let n = n as u32;
        let golden = read_frame(root, &scene.name, n)?;
        let err = |source| SuiteError::Metrics {
            scene: scene.name.clone(),
            frame: n,
            source,
        };
        let metrics = compare(frame.raster(), golden.raster()).map_err(err)?;
        let mut fraction = BTreeMap::new();
        for &k in &lsbs {
            fraction.insert(
                k,
                fraction_over(frame.raster(), golden.raster(), k).map_err(err)?,
            );
        }
        frames.push(FrameResult {
            frame: n,
            metrics,
            fraction_over: fraction,
            failed_checks: Vec::new(),
            artifacts: Vec::new(),
        });
        goldens.push(golden);
    }
    let test = TestKind::of(scene);
    let judged_frames: Vec<u32> = match test {
        TestKind::Static => frames.last().map(|f| f.frame).into_iter().collect(),
        TestKind::Moving => frames.iter().map(|f| f.frame).collect(),
    };
    let judged: Vec<&FrameResult> = frames
        .iter()
        .filter(|f| judged_frames.contains(&f.frame))
        .collect();
    let checks: Vec<CheckResult> = (0..scene.checks.len())
        .map(|i| {
            let on = Judged {
                adapter: &adapter,
                spp,
                reference_spp: scene.reference_spp,
            };
            evaluate(&scene.checks, i, &judged, on, &timings, fps)
        })
        .collect();
    // Per-frame failures of the applied checks, on the judged frames.
    for f in frames
        .iter_mut()
        .filter(|f| judged_frames.contains(&f.frame))
    {
        for (i, c) in checks.iter().enumerate() {
            if c.passed.is_some() && frame_fails(&c.spec.check, f) == Some(true) {
                f.failed_checks.push(i);
            }
        }
    }
    let mut problems = Vec::new();
    if scene.checks.is_empty() {
        problems.push("the scene has no checks: a scene with no checks fails".into());
    } else if checks.iter().all(|c| c.passed.is_none()) {
        problems.push(format!(
            "none of the scene's {} checks applies to {adapter} at {spp} spp: nothing was judged",
            checks.len()
        ));
    }
    let mut summaries = BTreeMap::new();
    for (name, higher_is_better) in SUMMARISED {
        let values: Vec<(u32, f64)> = frames
            .iter()
            .filter_map(|f| metric(&f.metrics, name).map(|v| (f.frame, v)))
            .collect();
        summaries.insert(name.to_string(), Summary::of(&values, higher_is_better));
    }
    let worst = frames
        .iter()
        .filter(|f| judged_frames.contains(&f.frame))
        .min_by(|a, b| a.metrics.psnr.total_cmp(&b.metrics.psnr))
        .map(|f| f.frame);
    let kept: Vec<KeptFrame> = frames
        .iter()
        .filter(|f| !f.failed_checks.is_empty() || Some(f.frame) == worst)
        .map(|f| KeptFrame {
            frame: f.frame,
            failed: !f.failed_checks.is_empty(),
            actual: images[f.frame as usize].clone(),
            golden: goldens[f.frame as usize].clone(),
        })
        .collect();
    Ok((
        SceneResult {
            scene: scene.name.clone(),
            test,
            renderer,
            adapter,
            spp,
            plan: StagePlan::for_scene(scene, spp).names(),
            frames,
            judged_frames,
            summaries,
            checks,
            problems,
            timings,
            fps,
        },
        kept,
    ))
}

/// Renders every frame of `scene` on the CPU reference at `spp`.
pub fn render_scene_cpu(scene: &Scene, spp: u32) -> Result<Rendered, SuiteError> {
    let env = scene_environment(scene)?;
    let frames = (0..scene.frames)
        .map(|n| render_frame(scene, &env, n, spp).frame)
        .collect();
    Ok(Rendered {
        renderer: format!("cpu-reference ({spp} spp)"),
        adapter: "cpu-reference".into(),
        spp,
        frames,
        timings: Vec::new(),
        fps: None,
    })
}

/// Renders every frame of `scene` on the GPU at `spp` (1 is the plain path;
/// the golden's spp is the matched gate), with stage times and FPS.
pub fn render_scene_gpu(
    scene: &Scene,
    ctx: &GpuContext,
    config: GpuConfig,
    spp: u32,
) -> Result<Rendered, SuiteError> {
    let env = scene_environment(scene)?;
    let gpu = |e: crate::gpu::GpuError| SuiteError::Gpu {
        scene: scene.name.clone(),
        source: e,
    };
    let r = GpuRenderer::new(
        ctx,
        StagePlan::for_scene(scene, spp),
        GpuInput::Sphere {
            env: &env,
            camera: scene_camera(scene),
            spp,
        },
        &Pipeline::of_scene(scene),
        config,
    )
    .map_err(gpu)?;
    let mut frames = Vec::with_capacity(scene.frames as usize);
    let mut times = Vec::with_capacity(scene.frames as usize);
    let mut wall = 0.0;
    for n in 0..scene.frames {
        r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
        let out = r.render(true).map_err(gpu)?;
        wall += out.wall_ms;
        times.push(out.timings);
        frames.push(
            out.frame
                .ok_or_else(|| gpu(crate::gpu::GpuError::Readback("no frame".into())))?,
        );
    }
    Ok(Rendered {
        renderer: ctx.adapter.name.clone(),
        adapter: ctx.adapter.name.clone(),
        spp,
        frames,
        timings: summarise(&times),
        fps: Some(scene.frames as f64 / (wall / 1e3)),
    })
}

/// Renders `scene` on the CPU at `spp` and judges it against the goldens.
pub fn run_scene_cpu(root: &Path, scene: &Scene, spp: u32) -> Result<SceneResult, SuiteError> {
    judge(root, scene, render_scene_cpu(scene, spp)?).map(|(r, _)| r)
}

/// Renders `scene` on the GPU at `spp` and judges it against the goldens.
pub fn run_scene_gpu(
    root: &Path,
    scene: &Scene,
    ctx: &GpuContext,
    config: GpuConfig,
    spp: u32,
) -> Result<SceneResult, SuiteError> {
    judge(root, scene, render_scene_gpu(scene, ctx, config, spp)?).map(|(r, _)| r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(check: Check, adapter: Option<&str>) -> CheckSpec {
        CheckSpec {
            check,
            adapter: adapter.map(str::to_owned),
            spp: None,
            set_by: None,
        }
    }

    fn on(adapter: &str) -> Judged<'_> {
        Judged {
            adapter,
            spp: 16,
            reference_spp: 16,
        }
    }

    fn frame(n: u32, psnr: f64) -> FrameResult {
        FrameResult {
            frame: n,
            metrics: Metrics {
                mse: 0.0,
                rmse: 0.0,
                psnr,
                snr: psnr,
                ssim: 1.0,
                max_abs_diff: 0,
                fraction_over_1lsb: 0.0,
                ssim_definition: String::new(),
            },
            fraction_over: BTreeMap::new(),
            failed_checks: Vec::new(),
            artifacts: Vec::new(),
        }
    }

    #[test]
    fn an_adapter_bound_overrides_the_generic_one_of_its_kind_only() {
        let specs = vec![
            spec(Check::MinPsnr(40.0), None),
            spec(Check::MinPsnr(30.0), Some("llvmpipe")),
            spec(Check::MinSsim(0.9), None),
        ];
        assert!(not_applied(&specs, 0, on("llvmpipe (LLVM 15)"))
            .unwrap()
            .contains("overridden"));
        assert_eq!(not_applied(&specs, 1, on("llvmpipe (LLVM 15)")), None);
        assert_eq!(not_applied(&specs, 2, on("llvmpipe (LLVM 15)")), None);
        // On another adapter the generic bound holds and the override does not apply.
        assert_eq!(not_applied(&specs, 0, on("NVIDIA H100")), None);
        assert!(not_applied(&specs, 1, on("NVIDIA H100")).is_some());
        let frames = [frame(0, 35.0), frame(1, 33.0)];
        let judged: Vec<&FrameResult> = frames.iter().collect();
        let on_llvmpipe = evaluate(&specs, 1, &judged, on("llvmpipe"), &[], None);
        assert_eq!(on_llvmpipe.passed, Some(true));
        let generic = evaluate(&specs, 0, &judged, on("NVIDIA H100"), &[], None);
        assert_eq!(generic.passed, Some(false));
        assert_eq!(generic.frame, Some(1), "{}", generic.detail);
    }

    #[test]
    fn a_bound_applies_at_its_own_spp_only() {
        let mut plain = spec(Check::MinPsnr(20.0), None);
        plain.spp = Some(1);
        let specs = vec![plain, spec(Check::MinPsnr(50.0), None)];
        let at = |spp| Judged {
            adapter: "llvmpipe",
            spp,
            reference_spp: 16,
        };
        assert_eq!(not_applied(&specs, 0, at(1)), None);
        assert!(not_applied(&specs, 1, at(1)).is_some());
        assert!(not_applied(&specs, 0, at(16)).is_some());
        assert_eq!(not_applied(&specs, 1, at(16)), None);
    }

    #[test]
    fn a_nan_metric_is_the_worst_and_fails() {
        let specs = vec![spec(Check::MinPsnr(10.0), None)];
        let frames = [frame(0, 50.0), frame(1, f64::NAN), frame(2, 40.0)];
        let judged: Vec<&FrameResult> = frames.iter().collect();
        let r = evaluate(&specs, 0, &judged, on("x"), &[], None);
        assert_eq!(r.passed, Some(false));
        assert_eq!(r.frame, Some(1));
    }

    #[test]
    fn summaries_name_the_frames_of_the_extremes() {
        let s = Summary::of(&[(0, 30.0), (1, 50.0), (2, 20.0)], true);
        assert_eq!(
            (s.best, s.best_frame, s.worst, s.worst_frame),
            (50.0, 1, 20.0, 2)
        );
        assert!((s.mean - 100.0 / 3.0).abs() < 1e-12);
        let s = Summary::of(&[(0, 3.0), (1, 1.0)], false);
        assert_eq!((s.best_frame, s.worst_frame), (1, 0));
    }
}
