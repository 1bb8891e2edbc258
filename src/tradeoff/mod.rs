//! Error against run time: sweeps every GPU knob that trades accuracy for
//! speed and measures, per configuration, the GPU time per frame (timestamps,
//! median) and the error against the f64 reference at 128 spp (PSNR, SSIM,
//! relative error of the adaptation luminance). The Pareto front (no other
//! configuration both faster and more accurate) is marked.

mod knobs;
pub mod svg;

pub use knobs::{sweep, taa_knobs, with_operator_knob, with_taa, Knobs, OperatorKnob, TaaKnob};

use crate::gpu::{GpuConfig, GpuContext};
use crate::history::TradeoffRecord;
use crate::metrics::compare_frames;
use crate::perf::quantile;
use crate::render::{scene_environment, RenderError, SceneRenderer};
use crate::scene::{Factor, Positive, Radius, Scene};
use serde::Serialize;

/// The frames a TAA configuration is measured on: each asked-for frame, but
/// not before frame 15, when the 16-frame jitter cycle has filled the history.
fn taa_frame(n: u32, scene: &Scene) -> u32 {
    n.max(15).min(scene.frames - 1)
}

/// One measured configuration of one scene.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub scene: String,
    pub label: String,
    pub knobs: Knobs,
    /// Median GPU time per frame (sum of the stages' timestamps), ms.
    pub ms: f64,
    /// Worst over the measured frames, against the reference's 8-bit frame.
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub psnr: f64,
    pub ssim: f64,
    /// Largest |adaptation − reference| / reference over the frames.
    pub log_average_rel_error: f64,
    /// No other configuration of this scene is at least as fast and as
    /// accurate (PSNR) and strictly better in one.
    pub pareto: bool,
}

#[derive(Clone, Debug)]
pub struct TradeoffOptions {
    /// Frames of each scene measured (clamped to the scene's length).
    pub frames: Vec<u32>,
    /// Samples per pixel of the reference (docs/taa.md: up to 128).
    pub reference_spp: u32,
    pub spps: Vec<u32>,
    pub downsamples: Vec<u32>,
    /// Timed renders per frame and configuration (after one warm-up).
    pub repeats: u32,
}

impl Default for TradeoffOptions {
    fn default() -> Self {
        TradeoffOptions {
            frames: vec![0, 3],
            reference_spp: 128,
            spps: vec![1, 4, 16],
            downsamples: vec![2, 4, 8],
            repeats: 5,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TradeoffError {
    /// The scene's environment could not be made, or the reference failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The GPU failed for one configuration.
    #[error("scene {scene}, {label}: {source}")]
    Gpu {
        scene: String,
        label: String,
        source: crate::gpu::GpuError,
    },
    /// A frame could not be compared with the reference's.
    #[error("scene {scene}: {source}")]
    Metrics {
        scene: String,
        source: crate::metrics::MetricsError,
    },
    /// A knob value the scene cannot take.
    #[error("scene {scene}: {detail}")]
    Invalid { scene: String, detail: String },
}

/// `scene` with its bloom computed at downsample factor `d`, the blur's
/// radius and σ rescaled (they are in low-resolution pixels) so the glow keeps
/// its full-resolution extent: the knob trades accuracy for speed, not for a
/// different look. The rounding of the radius is what remains of the change.
pub fn with_downsample(scene: &Scene, d: Option<u32>) -> Result<Scene, String> {
    let mut variant = scene.clone();
    if let (Some(b), Some(d)) = (variant.bloom.as_mut(), d) {
        let ratio = b.downsample.get() as f64 / d as f64;
        b.downsample = Factor::try_from(d)?;
        b.sigma = Positive::try_from(b.sigma.get() * ratio)?;
        b.radius = Radius::try_from(((b.radius.get() as f64 * ratio).round() as u32).max(1))?;
    }
    Ok(variant)
}

/// Marks the Pareto front of `points` (minimise ms, maximise PSNR).
pub fn mark_pareto(points: &mut [Point]) {
    let snapshot: Vec<(f64, f64)> = points.iter().map(|p| (p.ms, p.psnr)).collect();
    for (i, p) in points.iter_mut().enumerate() {
        let (ms, psnr) = snapshot[i];
        p.pareto = !snapshot
            .iter()
            .enumerate()
            .any(|(j, &(m, q))| j != i && m <= ms && q >= psnr && (m < ms || q > psnr));
    }
}

/// Measures every configuration of `scene`; `progress` is called after each.
pub fn measure_scene(
    ctx: &GpuContext,
    scene: &Scene,
    opts: &TradeoffOptions,
    mut progress: impl FnMut(&Point),
) -> Result<Vec<Point>, TradeoffError> {
    let env = scene_environment(scene)?;
    let frames: Vec<u32> = {
        let mut f: Vec<u32> = opts
            .frames
            .iter()
            .map(|&n| n.min(scene.frames - 1))
            .collect();
        f.dedup();
        f
    };
    // The reference: the scene as written, at reference_spp, in f64 (no
    // TAA: at more than one sample a scene is its own accumulation buffer).
    let reference = SceneRenderer::cpu(scene, &env, opts.reference_spp);
    let mut wanted: Vec<u32> = frames.clone();
    wanted.extend(frames.iter().map(|&n| taa_frame(n, scene)));
    wanted.sort_unstable();
    wanted.dedup();
    let references = wanted
        .iter()
        .map(|&n| Ok((n, reference.frame(n)?)))
        .collect::<Result<Vec<_>, RenderError>>()?;
    let mut points = Vec::new();
    for knobs in sweep(scene, &opts.spps, &opts.downsamples) {
        let label = knobs.label();
        let invalid = |detail| TradeoffError::Invalid {
            scene: scene.name.clone(),
            detail,
        };
        let variant = with_downsample(scene, knobs.bloom_downsample).map_err(invalid)?;
        let variant = with_taa(&variant, knobs.taa).map_err(invalid)?;
        let variant = with_operator_knob(&variant, knobs.operator).map_err(invalid)?;
        let measured: Vec<u32> = match knobs.taa {
            Some(_) => frames.iter().map(|&n| taa_frame(n, scene)).collect(),
            None => frames.clone(),
        };
        let failed = |e| match e {
            RenderError::Gpu { source, .. } => TradeoffError::Gpu {
                scene: scene.name.clone(),
                label: label.clone(),
                source,
            },
            other => TradeoffError::Render(other),
        };
        let config = GpuConfig {
            hdr_format: knobs.hdr_format,
            reduction: knobs.reduction,
            env_filter: knobs.env_filter,
            // Fusing changes the time, never the image at f32: the
            // front is drawn over the staged path's per-stage choices.
            execution: crate::gpu::Execution::Staged,
            fault_gain: None,
            taa_fault: None,
            fault_delay_ms: None,
        };
        let r = SceneRenderer::gpu(&variant, &env, ctx, config, knobs.spp).map_err(failed)?;
        let mut times = Vec::new();
        let (mut psnr, mut ssim, mut rel): (f64, f64, f64) = (f64::INFINITY, 1.0, 0.0);
        for &n in &measured {
            let Some((_, reference)) = references.iter().find(|(k, _)| *k == n) else {
                continue;
            };
            let out = r.frame(n).map_err(failed)?;
            let m = compare_frames(&out.image, &reference.image)
                .map(|(m, _)| m)
                .map_err(|source| TradeoffError::Metrics {
                    scene: scene.name.clone(),
                    source,
                })?;
            psnr = psnr.min(m.psnr);
            ssim = ssim.min(m.ssim);
            // The adaptation luminance, for the operators that have one.
            let adaptation =
                |f: &crate::render::RenderedFrame| f.tone(&scene.operator).get("log_average");
            let e = match (adaptation(reference), adaptation(&out)) {
                (Some(want), Some(got)) => ((got - want) / want).abs(),
                _ => 0.0,
            };
            rel = if e.is_nan() {
                f64::INFINITY
            } else {
                rel.max(e)
            };
            for _ in 0..opts.repeats {
                let timings = r.stage_times(n).map_err(failed)?;
                times.push(timings.iter().map(|s| s.ms).sum::<f64>());
            }
        }
        let p = Point {
            scene: scene.name.clone(),
            label,
            knobs,
            ms: quantile(&times, 0.5),
            psnr,
            ssim,
            log_average_rel_error: rel,
            pareto: false,
        };
        progress(&p);
        points.push(p);
    }
    mark_pareto(&mut points);
    Ok(points)
}

/// A measured point as the history stores it.
pub fn record(p: &Point) -> TradeoffRecord {
    TradeoffRecord {
        scene: p.scene.clone(),
        label: p.label.clone(),
        config: serde_json::to_string(&p.knobs).unwrap_or_default(),
        ms: p.ms,
        psnr: p.psnr,
        ssim: p.ssim,
        log_average_rel_error: p.log_average_rel_error,
        pareto: p.pareto,
    }
}

/// One configuration over the whole suite: time summed over scenes, worst
/// PSNR and SSIM, largest adaptation error. Only configurations every scene
/// measured (knobs without the bloom factor match any factor of the
/// bloom-less scenes).
pub fn aggregate(points: &[Point], scenes: &[String]) -> Vec<Point> {
    let same = |p: &Knobs, k: &Knobs| {
        let mut q = *p;
        if q.bloom_downsample.is_none() {
            q.bloom_downsample = k.bloom_downsample;
        }
        q == *k
    };
    let any_bloom = points.iter().any(|p| p.knobs.bloom_downsample.is_some());
    let mut keys: Vec<Knobs> = Vec::new();
    for p in points {
        if (p.knobs.bloom_downsample.is_some() || !any_bloom) && !keys.contains(&p.knobs) {
            keys.push(p.knobs);
        }
    }
    let mut out = Vec::new();
    for k in keys {
        let matching: Vec<&Point> = scenes
            .iter()
            .filter_map(|s| points.iter().find(|p| &p.scene == s && same(&p.knobs, &k)))
            .collect();
        if matching.len() != scenes.len() {
            continue;
        }
        out.push(Point {
            scene: "suite".into(),
            label: k.label(),
            knobs: k,
            ms: matching.iter().map(|p| p.ms).sum(),
            psnr: matching
                .iter()
                .map(|p| p.psnr)
                .fold(f64::INFINITY, f64::min),
            ssim: matching.iter().map(|p| p.ssim).fold(1.0, f64::min),
            log_average_rel_error: matching
                .iter()
                .map(|p| p.log_average_rel_error)
                .fold(0.0, f64::max),
            pareto: false,
        });
    }
    mark_pareto(&mut out);
    out
}

#[cfg(test)]
mod tests;
