//! `tonemap` pass: the operator's resolve step (one invocation: the
//! statistics into the curve's values), then its curve on every pixel. The
//! operator's module is part of the pipeline (src/operators/mod.rs).

use crate::gpu::stages::{
    bind_group, dispatch_2d, pipeline_with, uniform_buffer, Bind, Dispatch, ImageView,
};
use crate::gpu::{GpuContext, HdrFormat};
use crate::operators::Operator;

/// The operator's module, override constants and `OperatorConfig` uniform,
/// shared by the `tonemap` stage and the fused kernels.
#[derive(Clone)]
pub struct OperatorShader {
    /// The operator's `OperatorConfig`.
    pub config: wgpu::Buffer,
    /// The operator's WGSL module.
    pub module: &'static str,
    /// The operator's override constants, then `FAULT_GAIN`.
    pub constants: Vec<(&'static str, f64)>,
    /// The curve's input is scaled by eye adaptation's auto-exposure
    /// (`ADAPTED` in shaders/shared/tone.wgsl), for an operator that keys
    /// on no log average in a plan with `adaptation`.
    pub exposed: bool,
}

impl OperatorShader {
    pub fn new(ctx: &GpuContext, op: &Operator, fault_gain: Option<f32>) -> OperatorShader {
        OperatorShader {
            config: uniform_buffer(
                ctx,
                "tonegate.tonemap.config",
                bytemuck::cast_slice(&OperatorShader::config_of(op)),
            ),
            module: op.definition().wgsl(),
            constants: OperatorShader::constants_of(op, fault_gain),
            exposed: false,
        }
    }

    /// The `OperatorConfig` uniform's contents for `op`, padded to whole
    /// 16-byte rows (an empty one still binds).
    pub fn config_of(op: &Operator) -> Vec<f32> {
        let mut config = op.definition().gpu_config(op.values());
        config.resize(config.len().div_ceil(4).max(1) * 4, 0.0);
        config
    }

    /// The override constants for `op`, then `FAULT_GAIN`.
    pub fn constants_of(op: &Operator, fault_gain: Option<f32>) -> Vec<(&'static str, f64)> {
        let mut constants = op.definition().gpu_constants(op.values());
        constants.push(("FAULT_GAIN", fault_gain.unwrap_or(1.0) as f64));
        constants
    }

    /// The pipeline for `entry` of `stage` (`tonemap` or `fused`) with this
    /// operator, and `extra` constants of the stage's own.
    pub fn pipeline(
        &self,
        ctx: &GpuContext,
        stage: &str,
        entry: &str,
        format: HdrFormat,
        extra: &[(&str, f64)],
    ) -> wgpu::ComputePipeline {
        let mut constants: Vec<(&str, f64)> = self.constants.clone();
        if self.exposed {
            constants.push(("ADAPTED", 1.0));
        }
        constants.extend_from_slice(extra);
        pipeline_with(ctx, stage, entry, format, &constants, Some(self.module))
    }
}

/// The one-invocation step that turns the statistics into the operator's
/// resolved values (`stats.tone`).
pub fn resolve(
    ctx: &GpuContext,
    format: HdrFormat,
    params: &OperatorShader,
    stats: &wgpu::Buffer,
) -> Dispatch {
    let p = params.pipeline(ctx, "tonemap", "resolve", format, &[]);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.tonemap.resolve",
        &[(0, Bind::Buffer(&params.config)), (1, Bind::Buffer(stats))],
    );
    Dispatch::new(p, bg, (1, 1))
}

pub fn tonemap(
    ctx: &GpuContext,
    format: HdrFormat,
    params: &OperatorShader,
    stats: &wgpu::Buffer,
    hdr: &ImageView,
    toned_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Vec<Dispatch> {
    let main = params.pipeline(ctx, "tonemap", "main", format, &[]);
    let bg = bind_group(
        ctx,
        &main,
        "tonegate.tonemap",
        &[
            (0, Bind::Buffer(&params.config)),
            (2, Bind::View(&hdr.view)),
            (3, Bind::Texture(toned_out)),
            (4, Bind::Buffer(stats)),
        ],
    );
    vec![
        resolve(ctx, format, params, stats),
        dispatch_2d(main, bg, hdr.width, hdr.height).sized(ctx, extent),
    ]
}
