//! `adaptation` pass: the luminance the eye is adapted to, carried across
//! frames in a buffer of the renderer's (shaders/adaptation.wgsl; the f64
//! reference is `reference::adaptation`).

use crate::gpu::stages::{bind_group, pipeline, storage_buffer, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};
use crate::operators::StatsNeeds;
use crate::scene::Adaptation;

/// Mirrors `Steps` in shaders/adaptation.wgsl: one frame's step.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Steps {
    pub up: f32,
    pub down: f32,
    pub key: f32,
    /// 1: the frame takes its measurement (the first, or after a reset).
    pub reset: u32,
}

impl Steps {
    /// The step of a frame `dt` seconds after the one before (the
    /// fractions computed in f64, then rounded once to f32).
    pub fn new(adaptation: &Adaptation, dt: f64, reset: bool) -> Steps {
        let (up, down) = adaptation.steps(dt);
        Steps {
            up: up as f32,
            down: down as f32,
            key: adaptation.key.get() as f32,
            reset: u32::from(reset),
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

/// The constants of the pass for an operator with `needs`.
fn constants(needs: StatsNeeds) -> [(&'static str, f64); 2] {
    [
        ("WEIGHTED", f64::from(u8::from(needs.weighted_log_average))),
        ("EXPOSE", f64::from(u8::from(!needs.keys_on_average()))),
    ]
}

/// The one-invocation pass, between `luminance_stats` (which measured at
/// least the log average) and `tonemap`'s resolve step.
pub fn adaptation(
    ctx: &GpuContext,
    format: HdrFormat,
    needs: StatsNeeds,
    stats: &wgpu::Buffer,
    adapted: &wgpu::Buffer,
    steps: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(ctx, "adaptation", "main", format, &constants(needs));
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.adaptation",
        &[
            (0, Bind::Buffer(stats)),
            (1, Bind::Buffer(adapted)),
            (2, Bind::Buffer(steps)),
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
}

impl AdaptationResources {
    pub fn new(ctx: &GpuContext, stage: crate::plan::AdaptationStage) -> AdaptationResources {
        AdaptationResources {
            stage,
            adapted: adapted_buffer(ctx),
            steps: steps_buffer(ctx),
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
            stats,
            &self.adapted,
            &self.steps,
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
