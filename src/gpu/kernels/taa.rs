//! `taa` pass: the resolve against the history and the sharpen
//! (shaders/taa.wgsl). The history is a ping-pong pair: an even frame reads
//! `history[0]` and writes `history[1]`, an odd frame the other way round,
//! so the stage has one set of dispatches per parity. The history is read
//! with loads (the reference's arithmetic) or, with `--env-filter hardware`,
//! through the texture unit's linear filter (`_hardware` entries: 9 taps
//! for Catmull-Rom instead of 16 loads). The history is found by the
//! camera's reprojection (the gate's sphere) or, in an application that
//! embeds the tone mapper, by its motion vectors (`_motion` entries, loads).

use crate::conventions::Mat3;
use crate::gpu::config::{EnvFilter, TaaFault};
use crate::gpu::stages::{
    bind_group, dispatch_2d, hdr_texture, pipeline, uniform_buffer, Bind, Dispatch,
};
use crate::gpu::{GpuContext, GpuError, HdrFormat};
use crate::scene::{BlendSpace, FeedbackRule, HistoryFilter, TaaParams, TaaVariant};

/// Mirrors `TaaUniforms` in shaders/taa.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TaaUniforms {
    pub rows: [[f32; 4]; 3],
    pub has_history: u32,
    pub _pad: u32,
    pub motion_scale: [f32; 2],
}

impl TaaUniforms {
    /// The camera's reprojection from the previous frame's rotation
    /// (`conventions::reprojection`), or None for a reset.
    pub fn rotation(reprojection: Option<&Mat3>) -> TaaUniforms {
        let row = |m: &Mat3, i: usize| [m[i][0] as f32, m[i][1] as f32, m[i][2] as f32, 0.0];
        TaaUniforms {
            rows: match reprojection {
                Some(m) => [row(m, 0), row(m, 1), row(m, 2)],
                None => [[0.0; 4]; 3],
            },
            has_history: reprojection.is_some() as u32,
            _pad: 0,
            motion_scale: [0.0; 2],
        }
    }

    /// Motion vectors times `scale` are the offsets, in pixels, to where
    /// each pixel was; `has_history` false for a reset.
    pub fn motion(has_history: bool, scale: [f32; 2]) -> TaaUniforms {
        TaaUniforms {
            rows: [[0.0; 4]; 3],
            has_history: has_history as u32,
            _pad: 0,
            motion_scale: scale,
        }
    }
}

/// What the stage reads and writes.
pub struct TaaTextures<'a> {
    /// The frame uniforms: the film's size, and the camera the rotation
    /// reprojects through.
    pub frame: &'a wgpu::Buffer,
    /// This frame's jittered image.
    pub current: &'a wgpu::Texture,
    /// `taa_sobel`'s aliasing amount (the edge-aware variant).
    pub amount: Option<&'a wgpu::Texture>,
    /// Motion vectors, in place of the camera's reprojection.
    pub motion: Option<&'a wgpu::TextureView>,
    /// The stage's output.
    pub out: &'a wgpu::Texture,
}

/// The stage's resources beside its dispatches: kept by a caller whose
/// history outlives one wiring (a `ToneMapper`'s pairs of views).
#[derive(Clone)]
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

/// The stage between `io`'s textures, with the history and uniforms of
/// `kept` when they are of the frame's size (a new pair otherwise).
pub fn taa(
    ctx: &GpuContext,
    format: HdrFormat,
    params: &TaaParams,
    (fault, filter): (Option<TaaFault>, EnvFilter),
    io: &TaaTextures,
    kept: Option<TaaResources>,
) -> Result<TaaDispatches, GpuError> {
    let TaaTextures {
        frame,
        current,
        amount,
        motion,
        out,
    } = *io;
    // The motion entries read with loads.
    let hardware = filter == EnvFilter::Hardware && motion.is_none();
    // f16 textures are filterable everywhere; f32 ones only with the feature.
    if hardware && format == HdrFormat::Rgba32Float && !ctx.float32_filterable {
        return Err(GpuError::MissingFeature {
            adapter: ctx.adapter.name.clone(),
            feature: "FLOAT32_FILTERABLE",
            what: "--env-filter hardware (the TAA history)",
        });
    }
    let (w, h) = (current.width(), current.height());
    let fits = |r: &TaaResources| {
        let t = &r.history[0];
        (t.width(), t.height(), t.format()) == (w, h, format.texture_format())
    };
    let TaaResources { uniforms, history } = match kept.filter(fits) {
        Some(r) => r,
        None => TaaResources {
            uniforms: uniform_buffer(
                ctx,
                "tonegate.taa.uniforms",
                bytemuck::bytes_of(&TaaUniforms::rotation(None)),
            ),
            history: [
                hdr_texture(ctx, "tonegate.taa.history.0", w, h, format),
                hdr_texture(ctx, "tonegate.taa.history.1", w, h, format),
            ],
        },
    };
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
        (TaaVariant::EdgeAware, Some(_), _) if motion.is_some() => "resolve_edge_aware_motion",
        (TaaVariant::Variance, _, _) if motion.is_some() => "resolve_variance_motion",
        _ if motion.is_some() => "resolve_clip_motion",
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
        if let Some(m) = motion {
            binds.push((9, Bind::View(m)));
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
