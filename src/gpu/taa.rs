//! `taa` pass: the resolve against the history and the sharpen
//! (shaders/taa.wgsl). The history is a ping-pong pair: an even frame reads
//! `history[0]` and writes `history[1]`, an odd frame the other way round,
//! so the stage has one set of dispatches per parity. The history is read
//! with loads (the reference's arithmetic) or, with `--env-filter hardware`,
//! through the texture unit's linear filter (`_hardware` entries: 9 taps
//! for Catmull-Rom instead of 16 loads).

use super::config::{EnvFilter, TaaFault};
use super::stages::{
    bind_group, dispatch_2d, hdr_texture, pipeline, uniform_buffer, Bind, Dispatch,
};
use super::{GpuContext, GpuError, HdrFormat};
use crate::scene::{BlendSpace, FeedbackRule, HistoryFilter, TaaParams, TaaVariant};

/// Mirrors `TaaUniforms` in shaders/taa.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TaaUniforms {
    pub rows: [[f32; 4]; 3],
    pub has_history: u32,
    pub _pad: [u32; 3],
}

/// The stage's resources beside its dispatches.
pub struct TaaResources {
    pub uniforms: wgpu::Buffer,
    pub history: [wgpu::Texture; 2],
}

/// The dispatches for even and for odd frames.
pub struct TaaDispatches {
    pub even: Vec<Dispatch>,
    pub odd: Vec<Dispatch>,
    pub resources: TaaResources,
}

#[allow(clippy::too_many_arguments)]
pub fn taa(
    ctx: &GpuContext,
    format: HdrFormat,
    params: &TaaParams,
    fault: Option<TaaFault>,
    filter: EnvFilter,
    frame: &wgpu::Buffer,
    current: &wgpu::Texture,
    amount: Option<&wgpu::Texture>,
    out: &wgpu::Texture,
) -> Result<TaaDispatches, GpuError> {
    let hardware = filter == EnvFilter::Hardware;
    // f16 textures are filterable everywhere; f32 ones only with the feature.
    if hardware && format == HdrFormat::Rgba32Float && !ctx.float32_filterable {
        return Err(GpuError::MissingFeature {
            adapter: ctx.adapter.name.clone(),
            feature: "FLOAT32_FILTERABLE",
            what: "--env-filter hardware (the TAA history)",
        });
    }
    let (w, h) = (current.width(), current.height());
    let history = [
        hdr_texture(ctx, "tonegate.taa.history.0", w, h, format),
        hdr_texture(ctx, "tonegate.taa.history.1", w, h, format),
    ];
    let uniforms = uniform_buffer(
        ctx,
        "tonegate.taa.uniforms",
        bytemuck::bytes_of(&TaaUniforms {
            rows: [[0.0; 4]; 3],
            has_history: 0,
            _pad: [0; 3],
        }),
    );
    let flag = |on: bool| if on { 1.0 } else { 0.0 };
    let constants = [
        (
            "MOTION_FEEDBACK",
            flag(params.feedback == FeedbackRule::Motion),
        ),
        ("CURRENT_MIN", params.current_min),
        ("CURRENT_MOVING", params.current_moving),
        ("CURRENT_PER_PX", params.current_per_px),
        ("CURRENT_MAX", params.current_max),
        ("STATIC_PX", params.static_px),
        ("VARIANCE_GAMMA", params.variance_gamma),
        (
            "TONEMAPPED_BLEND",
            flag(params.blend == BlendSpace::Tonemapped),
        ),
        ("FEEDBACK_MIN", params.feedback_min),
        ("FEEDBACK_MAX", params.feedback_max),
        ("SHARPEN", params.sharpen),
        ("NO_CLIP", flag(fault == Some(TaaFault::NoClip))),
        (
            "CATMULL_ROM",
            flag(params.history_filter == HistoryFilter::CatmullRom),
        ),
    ];
    let entry = match (params.variant, amount, hardware) {
        (TaaVariant::EdgeAware, Some(_), false) => "resolve_edge_aware",
        (TaaVariant::EdgeAware, Some(_), true) => "resolve_edge_aware_hardware",
        (TaaVariant::Variance, _, false) => "resolve_variance",
        (TaaVariant::Variance, _, true) => "resolve_variance_hardware",
        (_, _, false) => "resolve_clip",
        (_, _, true) => "resolve_clip_hardware",
    };
    let resolve = pipeline(ctx, "taa", entry, format, &constants);
    let sampler = hardware.then(|| {
        ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("tonegate.taa.history_sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        })
    });
    let sharpen =
        (params.sharpen != 0.0).then(|| pipeline(ctx, "taa", "sharpen", format, &constants));
    let parity = |read: &wgpu::Texture, write: &wgpu::Texture| {
        let mut binds = vec![
            (0, Bind::Buffer(frame)),
            (1, Bind::Buffer(&uniforms)),
            (2, Bind::Texture(current)),
            (3, Bind::Texture(read)),
            (5, Bind::Texture(write)),
            (6, Bind::Texture(out)),
        ];
        if let (TaaVariant::EdgeAware, Some(a)) = (params.variant, amount) {
            binds.push((4, Bind::Texture(a)));
        }
        if let Some(s) = &sampler {
            binds.push((8, Bind::Sampler(s)));
        }
        let bg = bind_group(ctx, &resolve, "tonegate.taa", &binds);
        let mut d = vec![dispatch_2d(resolve.clone(), bg, w, h)];
        if let Some(p) = &sharpen {
            let bg = bind_group(
                ctx,
                p,
                "tonegate.taa.sharpen",
                &[
                    (0, Bind::Buffer(frame)),
                    (6, Bind::Texture(out)),
                    (7, Bind::Texture(write)),
                ],
            );
            d.push(dispatch_2d(p.clone(), bg, w, h));
        }
        d
    };
    let even = parity(&history[0], &history[1]);
    let odd = parity(&history[1], &history[0]);
    Ok(TaaDispatches {
        even,
        odd,
        resources: TaaResources { uniforms, history },
    })
}
