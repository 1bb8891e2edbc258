//! The built-in suite run on the CPU path: every frame of every scene rendered
//! at a given spp and compared with its golden, and the scene's checks
//! evaluated. The GPU renderer will take the renderer's place here.

use crate::conventions::rotation_matrix;
use crate::golden::{read_frame, scene_environment, GoldenError};
use crate::gpu::timing::{summarise, TimingSummary};
use crate::gpu::{GpuConfig, GpuContext, GpuInput, GpuRenderer};
use crate::metrics::{compare, fraction_over, Metrics};
use crate::plan::StagePlan;
use crate::reference::{render_frame, scene_camera, Pipeline};
use crate::scene::{Check, CheckSpec, Scene};
use serde::Serialize;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    #[error(transparent)]
    Golden(#[from] GoldenError),
    #[error("scene {scene}: {source}")]
    Gpu {
        scene: String,
        source: crate::gpu::GpuError,
    },
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
    /// Per-stage GPU time (median, p95) over the sequence; empty on the CPU.
    pub timings: Vec<TimingSummary>,
    /// Frames per second with readback (GPU only).
    pub fps: Option<f64>,
}

impl SceneResult {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.passed != Some(false))
    }
}

/// Evaluates one check over all frames; `adapter` is the renderer's name.
pub fn evaluate(
    spec: &CheckSpec,
    frames: &[FrameResult],
    adapter: &str,
    timings: &[TimingSummary],
    fps: Option<f64>,
) -> CheckResult {
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
        Check::MaxStageMs { stage, ms } => match timings.iter().find(|t| &t.name == stage) {
            Some(t) => (
                t.median_ms <= *ms,
                format!("{stage} median {:.3} ms (max {ms})", t.median_ms),
            ),
            None => return result(None, format!("no GPU timing for stage {stage}")),
        },
        Check::MinFps(bound) => match fps {
            Some(v) => (
                v >= *bound,
                format!("{v:.1} FPS with readback (min {bound})"),
            ),
            None => return result(None, "FPS is measured on the GPU renderer".into()),
        },
    };
    result(Some(passed), detail)
}

/// What a renderer produced for one scene.
struct Rendered {
    /// Renderer description for reports.
    renderer: String,
    /// Adapter name the checks' `adapter` overrides are matched against.
    adapter: String,
    spp: u32,
    frames: Vec<crate::image::Rgb8Image>,
    timings: Vec<TimingSummary>,
    fps: Option<f64>,
}

/// Compares rendered frames with the goldens under `root` and evaluates the
/// scene's checks.
fn judge(root: &Path, scene: &Scene, rendered: Rendered) -> Result<SceneResult, SuiteError> {
    let Rendered {
        renderer,
        adapter,
        spp,
        frames: images,
        timings,
        fps,
    } = rendered;
    let mut frames = Vec::with_capacity(images.len());
    for (n, frame) in images.iter().enumerate() {
        let n = n as u32;
        let golden = read_frame(root, &scene.name, n)?;
        let err = |source| SuiteError::Metrics {
            scene: scene.name.clone(),
            frame: n,
            source,
        };
        let metrics = compare(frame.raster(), golden.raster()).map_err(err)?;
        let over = fraction_over(frame.raster(), golden.raster(), 1).map_err(err)?;
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
        .map(|c| evaluate(c, &frames, &adapter, &timings, fps))
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
        timings,
        fps,
    })
}

/// Renders every frame of `scene` on the CPU at `spp` and compares it with the
/// golden under `root`.
pub fn run_scene_cpu(root: &Path, scene: &Scene, spp: u32) -> Result<SceneResult, SuiteError> {
    let env = scene_environment(scene)?;
    let rendered = (0..scene.frames)
        .map(|n| render_frame(scene, &env, n, spp).frame)
        .collect();
    judge(
        root,
        scene,
        Rendered {
            renderer: format!("cpu-reference ({spp} spp)"),
            adapter: "cpu-reference".into(),
            spp,
            frames: rendered,
            timings: Vec::new(),
            fps: None,
        },
    )
}

/// Renders every frame of `scene` on the GPU (1 spp, the plain path) and
/// compares it with the golden under `root`; stage times and FPS come along.
pub fn run_scene_gpu(
    root: &Path,
    scene: &Scene,
    ctx: &GpuContext,
    config: GpuConfig,
) -> Result<SceneResult, SuiteError> {
    let env = scene_environment(scene)?;
    let gpu = |e: crate::gpu::GpuError| SuiteError::Gpu {
        scene: scene.name.clone(),
        source: e,
    };
    let r = GpuRenderer::new(
        ctx,
        StagePlan::for_scene(scene, 1),
        GpuInput::Sphere {
            env: &env,
            camera: scene_camera(scene),
            spp: 1,
        },
        &Pipeline::of_scene(scene),
        config,
    )
    .map_err(gpu)?;
    let mut rendered = Vec::with_capacity(scene.frames as usize);
    let mut times = Vec::with_capacity(scene.frames as usize);
    let mut wall = 0.0;
    for n in 0..scene.frames {
        r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
        let out = r.render(true).map_err(gpu)?;
        wall += out.wall_ms;
        times.push(out.timings);
        rendered.push(
            out.frame
                .ok_or_else(|| gpu(crate::gpu::GpuError::Readback("no frame".into())))?,
        );
    }
    let fps = scene.frames as f64 / (wall / 1e3);
    judge(
        root,
        scene,
        Rendered {
            renderer: ctx.adapter.name.clone(),
            adapter: ctx.adapter.name.clone(),
            spp: 1,
            frames: rendered,
            timings: summarise(&times),
            fps: Some(fps),
        },
    )
}
