//! The kernels of `--execution fused` (shaders/fused.wgsl): the plan's
//! display-referred stages merged into as few full-frame passes as their
//! data dependences allow.

use super::bloom_bright::bright_constants;
use super::encode::encode_constants;
use super::stages::{bind_group, dispatch_2d, hdr_texture, pipeline, Bind, Dispatch};
use super::tonemap::ToneParams;
use super::{GpuContext, HdrFormat};
use crate::scene::Bloom;

/// [tonemap →] bloom_bright → bloom_downsample, into `low_out`.
#[allow(clippy::too_many_arguments)]
pub fn bright_low(
    ctx: &GpuContext,
    format: HdrFormat,
    tone: &ToneParams,
    bloom: &Bloom,
    from_toned: bool,
    lum: [f64; 3],
    stats: &wgpu::Buffer,
    hdr: &wgpu::Texture,
    low_out: &wgpu::Texture,
) -> Dispatch {
    let mut constants = vec![
        ("COLOUR", tone.colour),
        ("FAULT_GAIN", tone.fault_gain),
        ("FACTOR", bloom.downsample.get() as f64),
        ("BRIGHT_FROM_TONED", from_toned as u32 as f64),
    ];
    constants.extend(bright_constants(bloom, lum));
    let p = pipeline(ctx, "fused", "bright_low", format, &constants);
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
    dispatch_2d(p, bg, low_out.width(), low_out.height())
}

/// tonemap → [bloom_composite →] encode, into the packed frame buffer.
/// `bloom` is the blurred low-resolution bloom and its strength.
#[allow(clippy::too_many_arguments)]
pub fn tail(
    ctx: &GpuContext,
    format: HdrFormat,
    tone: &ToneParams,
    bloom: Option<(&wgpu::Texture, f64)>,
    encoding: crate::scene::Encoding,
    stats: &wgpu::Buffer,
    hdr: &wgpu::Texture,
    frame_out: &wgpu::Buffer,
) -> Dispatch {
    let mut constants = vec![
        ("COLOUR", tone.colour),
        ("FAULT_GAIN", tone.fault_gain),
        ("BLOOM", bloom.is_some() as u32 as f64),
        ("STRENGTH", bloom.map(|(_, k)| k).unwrap_or(0.0)),
    ];
    constants.extend(encode_constants(encoding));
    let p = pipeline(ctx, "fused", "tail", format, &constants);
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
    dispatch_2d(p, bg, hdr.width(), hdr.height())
}
