//! `sphere` pass: renders the view of the rotating environment.

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::{GpuContext, HdrFormat};

pub fn sphere(
    ctx: &GpuContext,
    format: HdrFormat,
    spp: u32,
    frame: &wgpu::Buffer,
    env: &wgpu::Buffer,
    env_size: (u32, u32),
    hdr_out: &wgpu::Texture,
) -> Dispatch {
    let constants = [
        ("SPP", spp as f64),
        ("ENV_W", env_size.0 as f64),
        ("ENV_H", env_size.1 as f64),
    ];
    let p = pipeline(ctx, "sphere", "main", format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.sphere",
        &[
            (0, Bind::Buffer(frame)),
            (1, Bind::Buffer(env)),
            (2, Bind::Texture(hdr_out)),
        ],
    );
    dispatch_2d(p, bg, hdr_out.width(), hdr_out.height())
}
