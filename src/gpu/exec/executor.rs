//! The executor: the one code that turns a stage plan into passes and
//! records them into a command encoder. Both front ends wire and record
//! through it: [`crate::gpu::GpuRenderer`] (the gate's frames, whose sink is the
//! `encode` stage and the readback ring) and [`crate::gpu::ToneMapper`] (an
//! application's frames, whose sink is the caller's view: a last dispatch
//! into a storage target, or a fullscreen triangle drawn into a render
//! attachment by [`draw`]). What the gate renders and what an application
//! embeds are therefore the same passes, recorded the same way.

use super::wiring::{Pass, Wiring};
use crate::gpu::stages::Dispatch;
use crate::gpu::{Execution, GpuError};
use crate::plan::StagePlan;

/// A plan's stages wired on one set of resources: per stage, its
/// dispatches (and those of odd frames where the TAA history's pair
/// alternates).
pub(in crate::gpu) struct Executor {
    passes: Vec<Pass>,
}

/// Where a timed frame's compute pass `i` writes its timestamps.
pub(in crate::gpu) type ComputeStamps<'f, 's> =
    &'f dyn Fn(usize) -> wgpu::ComputePassTimestampWrites<'s>;

impl Executor {
    /// `plan`'s passes on `wiring`, in order: each stage wired fused (where
    /// `--execution fused` merges it into another's pass) or staged, up to
    /// the stage named `until`, which the caller's sink replaces (the
    /// `ToneMapper` writes its caller's target instead of `encode`'s
    /// packed frame).
    pub(in crate::gpu) fn wire(
        wiring: &mut Wiring,
        plan: &StagePlan,
        execution: Execution,
        until: Option<&str>,
    ) -> Result<Executor, GpuError> {
        let mut passes = Vec::new();
        for stage in plan.stages() {
            if until == Some(stage.name()) {
                break;
            }
            let fused = match execution {
                Execution::Fused => super::fused::wire(wiring, stage)?,
                Execution::Staged => None,
            };
            let pass = match fused {
                Some(pass) => pass,
                None => wiring.staged(stage)?,
            };
            if !pass.dispatches.is_empty() {
                passes.push(pass);
            }
        }
        Ok(Executor { passes })
    }

    /// The stages that have passes of their own, in order: what a timed
    /// frame's compute passes are named.
    pub(in crate::gpu) fn stage_names(&self) -> Vec<&'static str> {
        self.passes.iter().map(|p| p.name).collect()
    }

    /// How many compute passes a timed frame records before its sink's.
    #[cfg(feature = "gpu")]
    pub(in crate::gpu) fn len(&self) -> usize {
        self.passes.len()
    }

    /// Records one frame: every stage's dispatches (those of odd frames
    /// when `odd`), then `tail`, the sink's own dispatch into a storage
    /// target. Timed (`stamps`): each stage, and the tail, a compute pass
    /// of its own, named `tonegate.<stage>` (`tonegate.target`) and
    /// stamped by `stamps(i)`; untimed: one compute pass named `label`.
    pub(in crate::gpu) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        odd: bool,
        tail: Option<&Dispatch>,
        stamps: Option<ComputeStamps<'_, '_>>,
        label: &str,
    ) {
        fn of(p: &Pass, odd: bool) -> &[Dispatch] {
            match &p.odd {
                Some(d) if odd => d,
                _ => &p.dispatches,
            }
        }
        let dispatches = |p| of(p, odd);
        let Some(stamps) = stamps else {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            });
            for p in &self.passes {
                for d in dispatches(p) {
                    d.record(&mut pass);
                }
            }
            if let Some(tail) = tail {
                tail.record(&mut pass);
            }
            return;
        };
        let named = self.passes.iter().map(|p| (p.name, dispatches(p)));
        let tail = tail.map(|d| ("target", std::slice::from_ref(d)));
        for (i, (name, list)) in named.chain(tail).enumerate() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(&format!("tonegate.{name}")),
                timestamp_writes: Some(stamps(i)),
            });
            for d in list {
                d.record(&mut pass);
            }
        }
    }
}

/// A sink's fullscreen triangle into a render attachment: the display
/// image drawn by `pipeline` and `bind_group` into `view`, over the
/// `size` rectangle at `origin`.
pub(in crate::gpu) struct Draw<'a> {
    pub pipeline: &'a wgpu::RenderPipeline,
    pub bind_group: &'a wgpu::BindGroup,
    pub view: &'a wgpu::TextureView,
    pub origin: (u32, u32),
    pub size: (u32, u32),
}

/// Records `d` as a render pass of its own (stamped by `stamps`),
/// keeping what the attachment holds outside the rectangle.
pub(in crate::gpu) fn draw(
    encoder: &mut wgpu::CommandEncoder,
    d: Draw,
    stamps: Option<wgpu::RenderPassTimestampWrites>,
) {
    let ((x, y), (w, h)) = (d.origin, d.size);
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("tonegate.tone_mapper.to_attachment"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: d.view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: stamps,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_viewport(x as f32, y as f32, w as f32, h as f32, 0.0, 1.0);
    pass.set_scissor_rect(x, y, w, h);
    pass.set_pipeline(d.pipeline);
    pass.set_bind_group(0, d.bind_group, &[]);
    pass.draw(0..3, 0..1);
}
