//! The built-in suite run on the CPU path: every frame of every scene rendered
//! at a given spp and compared with its golden, and the scene's checks
//! evaluated. The GPU renderer will take the renderer's place here.

use crate::golden::{read_frame, scene_environment, GoldenError};
use crate::metrics::{compare, fraction_over, Metrics};
use crate::plan::StagePlan;
use crate::reference::render_frame;
use crate::scene::{Check, CheckSpec, Scene};
use serde::Serialize;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    #[error(transparent)]
    Golden(#[from] GoldenError),
    #[error("scene {scene}, frame {frame}: {source}")]
    Metrics {
        scene: String,
        frame: u32,
        source: crate::metrics::MetricsError,
    },
}

#[derive(Clone, Debug, Serialize)]
pub struct FrameResult {
    pub frame: u32,
    pub metrics: Metrics,
    /// Fraction of pixels with a channel off by more than 1 LSB.
    pub fraction_over_1lsb: f64,
}

/// Best, worst and mean of one metric over a sequence, with frame indices
/// (seed 002's ghosting tables).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub best: f64,
    pub best_frame: u32,
    pub worst: f64,
    pub worst_frame: u32,
    pub mean: f64,
}

impl Summary {
    /// `higher_is_better` says which end is best.
    pub fn of(values: &[(u32, f64)], higher_is_better: bool) -> Summary {
        let mut best = values[0];
        let mut worst = values[0];
        let mut sum = 0.0;
        for &(f, v) in values {
            let better = if higher_is_better {
                v > best.1
            } else {
                v < best.1
            };
            let worse = if higher_is_better {
                v < worst.1
            } else {
                v > worst.1
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

#[derive(Clone, Debug, Serialize)]
pub struct CheckResult {
    pub spec: CheckSpec,
    /// None when the check does not apply to this renderer (timing on CPU,
    /// another adapter's override).
    pub passed: Option<bool>,
    pub detail: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub scene: String,
    pub renderer: String,
    pub spp: u32,
    pub plan: Vec<&'static str>,
    pub frames: Vec<FrameResult>,
    pub psnr: Summary,
    pub ssim: Summary,
    pub checks: Vec<CheckResult>,
}

impl SceneResult {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.passed != Some(false))
    }
}

/// Evaluates one check over all frames; `adapter` is the renderer's name.
pub fn evaluate(spec: &CheckSpec, frames: &[FrameResult], adapter: &str) -> CheckResult {
    let applies = spec
        .adapter
        .as_ref()
        .map(|a| adapter.to_lowercase().contains(&a.to_lowercase()))
        .unwrap_or(true);
    let result = |passed: Option<bool>, detail: String| CheckResult {
        spec: spec.clone(),
        passed,
        detail,
    };
    if !applies {
        return result(None, format!("applies to adapter {:?} only", spec.adapter));
    }
    // (value, frame) of the worst frame, lower values being worse when `min`.
    let worst = |f: &dyn Fn(&FrameResult) -> f64, lower_is_worse: bool| {
        frames
            .iter()
            .map(|r| (f(r), r.frame))
            .fold(None, |acc: Option<(f64, u32)>, (v, fr)| match acc {
                None => Some((v, fr)),
                Some((w, wf)) => {
                    let worse = if lower_is_worse { v < w } else { v > w };
                    Some(if worse { (v, fr) } else { (w, wf) })
                }
            })
            .unwrap_or((f64::NAN, 0))
    };
    let (passed, detail) = match &spec.check {
        Check::MinPsnr(bound) => {
            let (v, f) = worst(&|r| r.metrics.psnr, true);
            (
                v >= *bound,
                format!("worst PSNR {v:.2} dB at frame {f} (min {bound})"),
            )
        }
        Check::MinSsim(bound) => {
            let (v, f) = worst(&|r| r.metrics.ssim, true);
            (
                v >= *bound,
                format!("worst SSIM {v:.5} at frame {f} (min {bound})"),
            )
        }
        Check::MaxMse(bound) => {
            let (v, f) = worst(&|r| r.metrics.mse, false);
            (
                v <= *bound,
                format!("worst MSE {v:.4} at frame {f} (max {bound})"),
            )
        }
        Check::MaxAbsDiff(bound) => {
            let (v, f) = worst(&|r| r.metrics.max_abs_diff as f64, false);
            (
                v <= *bound as f64,
                format!("worst max abs diff {v} at frame {f} (max {bound})"),
            )
        }
        Check::MaxFractionOver { lsb, fraction } => {
            if *lsb != 1 {
                return result(
                    None,
                    "only 1 LSB fractions are measured on this path".into(),
                );
            }
            let (v, f) = worst(&|r| r.fraction_over_1lsb, false);
            (
                v <= *fraction,
                format!("worst fraction over {lsb} LSB {v:.5} at frame {f} (max {fraction})"),
            )
        }
        Check::MaxStageMs { .. } | Check::MinFps(_) => {
            return result(None, "timing checks apply to the GPU renderer".into());
        }
    };
    result(Some(passed), detail)
}

/// Renders every frame of `scene` on the CPU at `spp` and compares it with the
/// golden under `root`.
pub fn run_scene_cpu(root: &Path, scene: &Scene, spp: u32) -> Result<SceneResult, SuiteError> {
    let env = scene_environment(scene)?;
    let renderer = format!("cpu-reference ({spp} spp)");
    let mut frames = Vec::with_capacity(scene.frames as usize);
    for n in 0..scene.frames {
        let golden = read_frame(root, &scene.name, n)?;
        let out = render_frame(scene, &env, n, spp);
        let err = |source| SuiteError::Metrics {
            scene: scene.name.clone(),
            frame: n,
            source,
        };
        let metrics = compare(out.frame.raster(), golden.raster()).map_err(err)?;
        let over = fraction_over(out.frame.raster(), golden.raster(), 1).map_err(err)?;
        frames.push(FrameResult {
            frame: n,
            metrics,
            fraction_over_1lsb: over,
        });
    }
    let psnr: Vec<(u32, f64)> = frames.iter().map(|f| (f.frame, f.metrics.psnr)).collect();
    let ssim: Vec<(u32, f64)> = frames.iter().map(|f| (f.frame, f.metrics.ssim)).collect();
    let checks = scene
        .checks
        .iter()
        .map(|c| evaluate(c, &frames, "cpu-reference"))
        .collect();
    Ok(SceneResult {
        scene: scene.name.clone(),
        renderer,
        spp,
        plan: StagePlan::for_scene(scene, spp).names(),
        psnr: Summary::of(&psnr, true),
        ssim: Summary::of(&ssim, true),
        frames,
        checks,
    })
}
