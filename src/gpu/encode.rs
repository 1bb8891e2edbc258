//! `encode` pass.

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::{GpuContext, HdrFormat};
use crate::color::bt709_to_bt2020;
use crate::operators::DisplayLevels;
use crate::scene::Encoding;

/// The encoding's override constants (shaders/shared/encode.wgsl); a PQ
/// encoding also takes the display's levels and the BT.709 → BT.2020
/// matrix, computed here in f64. A PQ encoding without levels is refused
/// by the scene and the renderer before it gets here; it would encode a
/// 0..100 cd/m² display.
pub fn encode_constants(
    encoding: Encoding,
    levels: Option<DisplayLevels>,
) -> Vec<(&'static str, f64)> {
    match encoding {
        Encoding::Srgb => vec![("ENCODING", 0.0), ("GAMMA", 2.2)],
        Encoding::Gamma(g) => vec![("ENCODING", 1.0), ("GAMMA", g.get())],
        Encoding::Pq => {
            let levels = levels.unwrap_or(DisplayLevels {
                black: 0.0,
                peak: 100.0,
            });
            let m = bt709_to_bt2020();
            let mut c = vec![
                ("ENCODING", 2.0),
                ("GAMMA", 2.2),
                ("PQ_BLACK", levels.black),
                ("PQ_PEAK", levels.peak),
            ];
            const NAMES: [&str; 9] = [
                "PQ_M00", "PQ_M01", "PQ_M02", "PQ_M10", "PQ_M11", "PQ_M12", "PQ_M20", "PQ_M21",
                "PQ_M22",
            ];
            for (i, name) in NAMES.into_iter().enumerate() {
                c.push((name, m[i / 3][i % 3]));
            }
            c
        }
    }
}

/// Bytes of the packed frame per pixel: RGBA8 in one u32, or R|G and
/// B|A (16 bits each) in two.
pub fn frame_bytes_per_pixel(encoding: Encoding) -> u64 {
    u64::from(encoding.bits()) / 2
}

pub fn encode(
    ctx: &GpuContext,
    format: HdrFormat,
    encoding: Encoding,
    levels: Option<DisplayLevels>,
    src: &wgpu::Texture,
    frame_out: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "encode",
        "main",
        format,
        &encode_constants(encoding, levels),
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode",
        &[(0, Bind::Texture(src)), (1, Bind::Buffer(frame_out))],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}

/// `encode` into a caller's Rgba8Unorm storage texture (the same bytes as
/// [`encode`] packs into its buffer).
pub fn encode_to_texture(
    ctx: &GpuContext,
    format: HdrFormat,
    encoding: Encoding,
    src: &wgpu::Texture,
    frame_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "encode",
        "to_texture",
        format,
        &encode_constants(encoding, None),
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode.to_texture",
        &[(0, Bind::Texture(src)), (2, Bind::Texture(frame_out))],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}
