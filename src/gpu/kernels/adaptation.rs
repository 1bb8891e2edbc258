//! `adaptation` pass: the luminance the eye is adapted to, carried across
//! frames in a buffer of the renderer's (shaders/adaptation.wgsl; the f64
//! reference is `reference::adaptation`).

use crate::gpu::stages::{bind_group, pipeline, storage_buffer, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};
use crate::operators::StatsNeeds;
use crate::scene::{Adaptation, Mask, Metering, Speed, HISTOGRAM_BINS};

/// Mirrors `Steps` in shaders/shared/adaptation.wgsl: one frame's
/// parameters (every number computed in f64, then rounded once to f32).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Steps {
    pub up: f32,
    pub down: f32,
    pub near_up: f32,
    pub near_down: f32,
    pub key: f32,
    /// 1: the frame takes its target (the first, or after a reset).
    pub reset: u32,
    /// 0: time constants; 1: stops per second.
    pub model: u32,
    /// 0: the log average; 1: the histogram.
    pub metering: u32,
    pub min_ev: f32,
    pub max_ev: f32,
    pub bins_per_ev: f32,
    /// 0: uniform; 1: centre-weighted.
    pub mask: u32,
    pub low: f32,
    pub high: f32,
    pub points: u32,
    pub pad: u32,
    /// The compensation curve, (EV, stops) pairs, two a row.
    pub curve: [[f32; 4]; 4],
}

impl Steps {
    /// The parameters of a frame `dt` seconds after the one before.
    pub fn new(a: &Adaptation, dt: f64, reset: bool) -> Steps {
        let (up, down, near_up, near_down) = match a.speed {
            Speed::TimeConstant => {
                let (up, down) = a.steps(dt);
                (up, down, 0.0, 0.0)
            }
            Speed::Stops => {
                let ((up, down), (near_up, near_down)) = a.stop_steps(dt);
                (up, down, near_up, near_down)
            }
        };
        // The transition's fraction is unbounded when it is 0: f32's
        // largest, which a gap of 0 still multiplies to 0.
        let near = |v: f64| v.min(f64::from(f32::MAX)) as f32;
        let mut curve = [[0.0f32; 4]; 4];
        for (i, [ev, stops]) in a.compensation.points().iter().enumerate() {
            curve[i / 2][2 * (i % 2)] = *ev as f32;
            curve[i / 2][2 * (i % 2) + 1] = *stops as f32;
        }
        Steps {
            up: up as f32,
            down: down as f32,
            near_up: near(near_up),
            near_down: near(near_down),
            key: a.key.get() as f32,
            reset: u32::from(reset),
            model: u32::from(a.speed == Speed::Stops),
            metering: u32::from(a.metering == Metering::Histogram),
            min_ev: a.min_ev as f32,
            max_ev: a.max_ev as f32,
            bins_per_ev: (HISTOGRAM_BINS as f64 / (a.max_ev - a.min_ev)) as f32,
            mask: u32::from(a.mask == Mask::Centre),
            low: a.low as f32,
            high: a.high as f32,
            points: a.compensation.points().len() as u32,
            pad: 0,
            curve,
        }
    }
}

/// The buffer the adapted values live in between frames: ln of the adapted
/// log average and weighted log average, f32 each.
pub fn adapted_buffer(ctx: &GpuContext) -> wgpu::Buffer {
    storage_buffer(ctx, "tonegate.adaptation.adapted", 16)
}

/// The uniform of [`Steps`], written per frame.
pub fn steps_buffer(ctx: &GpuContext) -> wgpu::Buffer {
    ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tonegate.adaptation.steps"),
        size: std::mem::size_of::<Steps>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The constants of the pass for an operator with `needs`, the white
/// point adapting where `white`.
fn constants(needs: StatsNeeds, white: bool) -> [(&'static str, f64); 3] {
    [
        ("WEIGHTED", f64::from(u8::from(needs.weighted_log_average))),
        ("EXPOSE", f64::from(u8::from(!needs.keys_on_average()))),
        ("WHITE", f64::from(u8::from(white && needs.max))),
    ]
}

/// The one-invocation pass, between `luminance_stats` (which measured at
/// least the log average) and `tonemap`'s resolve step.
#[allow(clippy::too_many_arguments)]
pub fn adaptation(
    ctx: &GpuContext,
    format: HdrFormat,
    needs: StatsNeeds,
    white: bool,
    stats: &wgpu::Buffer,
    adapted: &wgpu::Buffer,
    steps: &wgpu::Buffer,
    bins: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(ctx, "adaptation", "main", format, &constants(needs, white));
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.adaptation",
        &[
            (0, Bind::Buffer(stats)),
            (1, Bind::Buffer(adapted)),
            (2, Bind::Buffer(steps)),
            (3, Bind::Buffer(bins)),
        ],
    );
    Dispatch::new(p, bg, (1, 1))
}

/// A renderer's adaptation: the state buffer, the step uniform, and what
/// the plan's stage runs with.
#[derive(Clone)]
pub struct AdaptationResources {
    pub stage: crate::plan::AdaptationStage,
    pub adapted: wgpu::Buffer,
    pub steps: wgpu::Buffer,
    pub bins: wgpu::Buffer,
}

impl AdaptationResources {
    pub fn new(ctx: &GpuContext, stage: crate::plan::AdaptationStage) -> AdaptationResources {
        AdaptationResources {
            stage,
            adapted: adapted_buffer(ctx),
            steps: steps_buffer(ctx),
            bins: super::histogram::bins_buffer(ctx),
        }
    }

    /// Whether the operator gets the auto-exposure (it keys on no log
    /// average).
    pub fn exposes(&self) -> bool {
        !self.stage.operator_needs.keys_on_average()
    }

    /// The stage's dispatch on `stats`.
    pub fn dispatch(&self, ctx: &GpuContext, format: HdrFormat, stats: &wgpu::Buffer) -> Dispatch {
        adaptation(
            ctx,
            format,
            self.stage.operator_needs,
            self.stage.adaptation.adapt_white,
            stats,
            &self.adapted,
            &self.steps,
            &self.bins,
        )
    }

    /// Writes the next frame's step: `reset` on the first frame of a
    /// sequence (or a cut).
    pub fn set_frame(&self, ctx: &GpuContext, reset: bool) {
        let steps = Steps::new(&self.stage.adaptation, self.stage.frame_seconds, reset);
        ctx.queue
            .write_buffer(&self.steps, 0, bytemuck::bytes_of(&steps));
    }
}
