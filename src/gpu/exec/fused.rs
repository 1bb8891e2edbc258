//! The kernels of `--execution fused` (shaders/fused.wgsl): the plan's
//! display-referred stages merged into as few full-frame passes as their
//! data dependences allow, and how they are wired in place of those stages.

use super::wiring::{Pass, Wiring};
use crate::gpu::bloom_bright::bright_constants;
use crate::gpu::encode::encode_constants;
use crate::gpu::stages::{bind_group, dispatch_2d, hdr_texture, Bind, Dispatch};
use crate::gpu::tonemap::OperatorShader;
use crate::gpu::{GpuContext, GpuError, HdrFormat};
use crate::plan::{BloomSource, PlanError, Stage};
use crate::reference::bloom_downsample::downsampled_size;
use crate::scene::Bloom;

/// Wires `stage` for fused execution: the merged stages become (part of) one
/// kernel; None for the stages that run as in staged execution (`sphere`,
/// `luminance_stats`, `bloom_blur`).
pub fn wire(w: &mut Wiring, stage: &Stage) -> Result<Option<Pass>, GpuError> {
    let name = stage.name();
    let (ctx, format) = (w.ctx, w.format);
    Ok(Some(match stage {
        Stage::Tonemap { .. } => {
            w.tone = Some(w.operator_shader());
            // The curve's resolve step, until a fused kernel runs it first.
            w.pending_resolve = true;
            Pass::merged(name)
        }
        Stage::BloomBright { source } => {
            w.bright_source = Some(*source);
            Pass::merged(name)
        }
        Stage::BloomDownsample { factor } => {
            let b = w.bloom(name)?;
            let (Some(source), Some(t)) = (w.bright_source, &w.tone) else {
                return Err(PlanError::order(name, "bloom_bright").into());
            };
            let (lw, lh) = downsampled_size(w.width, w.height, *factor);
            let out = hdr_texture(ctx, "tonegate.bloom_downsample", lw, lh, format);
            let from_toned = source == BloomSource::Toned;
            let mut dispatches = Vec::new();
            let name = if from_toned {
                dispatches.push(crate::gpu::tonemap::resolve(ctx, format, t, &w.stats));
                w.pending_resolve = false;
                "tonemap+bloom_bright+bloom_downsample"
            } else {
                "bloom_bright+bloom_downsample"
            };
            dispatches.push(bright_low(
                ctx, format, t, b, from_toned, w.weights, &w.stats, &w.hdr, &out, &w.extent,
            ));
            w.low = Some(out);
            Pass::every_frame(name, dispatches)
        }
        Stage::BloomComposite => {
            let strength = w.bloom(name)?.strength.get();
            let blurred = w
                .blurred
                .clone()
                .ok_or(PlanError::order(name, "bloom_blur"))?;
            w.composite = Some((blurred, strength));
            Pass::merged(name)
        }
        Stage::Encode => {
            let frame = w.frame_buffer();
            let Some(t) = &w.tone else {
                return Err(PlanError::order(name, "tonemap").into());
            };
            let bloom = w.composite.as_ref().map(|(t, k)| (t, *k));
            let name = if bloom.is_some() {
                "tonemap+bloom_composite+encode"
            } else {
                "tonemap+encode"
            };
            let mut dispatches = Vec::new();
            if w.pending_resolve {
                dispatches.push(crate::gpu::tonemap::resolve(ctx, format, t, &w.stats));
                w.pending_resolve = false;
            }
            dispatches.push(tail(
                ctx,
                format,
                t,
                bloom,
                w.pipeline.encoding,
                w.pipeline.operator.display_levels(),
                &w.stats,
                &w.hdr,
                &frame,
                &w.extent,
            ));
            Pass::every_frame(name, dispatches)
        }
        _ => return Ok(None),
    }))
}

/// [tonemap →] bloom_bright → bloom_downsample, into `low_out`.
#[allow(clippy::too_many_arguments)]
pub fn bright_low(
    ctx: &GpuContext,
    format: HdrFormat,
    tone: &OperatorShader,
    bloom: &Bloom,
    from_toned: bool,
    lum: [f64; 3],
    stats: &wgpu::Buffer,
    hdr: &wgpu::Texture,
    low_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let mut constants = vec![
        ("FACTOR", bloom.downsample.get() as f64),
        ("BRIGHT_FROM_TONED", from_toned as u32 as f64),
    ];
    constants.extend(bright_constants(bloom, lum));
    let p = tone.pipeline(ctx, "fused", "bright_low", format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.fused.bright_low",
        &[
            (0, Bind::Buffer(&tone.config)),
            (1, Bind::Buffer(stats)),
            (2, Bind::Texture(hdr)),
            (5, Bind::Texture(low_out)),
        ],
    );
    dispatch_2d(p, bg, low_out.width(), low_out.height()).sized(ctx, extent)
}

/// tonemap → [bloom_composite →] encode, into the packed frame buffer.
/// `bloom` is the blurred low-resolution bloom and its strength.
#[allow(clippy::too_many_arguments)]
pub fn tail(
    ctx: &GpuContext,
    format: HdrFormat,
    tone: &OperatorShader,
    bloom: Option<(&wgpu::Texture, f64)>,
    encoding: crate::scene::Encoding,
    levels: Option<crate::operators::DisplayLevels>,
    stats: &wgpu::Buffer,
    hdr: &wgpu::Texture,
    frame_out: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let mut constants = vec![
        ("BLOOM", bloom.is_some() as u32 as f64),
        ("STRENGTH", bloom.map(|(_, k)| k).unwrap_or(0.0)),
    ];
    constants.extend(encode_constants(encoding, levels));
    let p = tone.pipeline(ctx, "fused", "tail", format, &constants);
    // Without bloom the kernel never reads binding 3; it still needs a texture.
    let placeholder;
    let bloom_texture = match bloom {
        Some((t, _)) => t,
        None => {
            placeholder = hdr_texture(ctx, "tonegate.fused.no_bloom", 1, 1, format);
            &placeholder
        }
    };
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.fused.tail",
        &[
            (0, Bind::Buffer(&tone.config)),
            (1, Bind::Buffer(stats)),
            (2, Bind::Texture(hdr)),
            (3, Bind::Texture(bloom_texture)),
            (4, Bind::Buffer(frame_out)),
        ],
    );
    dispatch_2d(p, bg, hdr.width(), hdr.height()).sized(ctx, extent)
}
