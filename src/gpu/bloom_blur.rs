//! `bloom_blur` pass: horizontal then vertical, weights from the reference.

use super::stages::{bind_group, dispatch_2d, pipeline, storage_buffer, Bind, Dispatch};
use super::{GpuContext, HdrFormat};
use crate::reference::bloom_blur::gaussian_weights;

pub fn bloom_blur(
    ctx: &GpuContext,
    format: HdrFormat,
    radius: u32,
    sigma: f64,
    src: &wgpu::Texture,
    tmp: &wgpu::Texture,
    blur_out: &wgpu::Texture,
) -> Vec<Dispatch> {
    let w: Vec<f32> = gaussian_weights(radius, sigma)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let weights = storage_buffer(ctx, "tonegate.bloom_blur.weights", (w.len() * 4) as u64);
    ctx.queue
        .write_buffer(&weights, 0, bytemuck::cast_slice(&w));
    let pass = |horizontal: bool, from: &wgpu::Texture, to: &wgpu::Texture| {
        let constants = [
            ("HORIZONTAL", horizontal as u32 as f64),
            ("RADIUS", radius as f64),
        ];
        let p = pipeline(ctx, "bloom_blur", "main", format, &constants);
        let bg = bind_group(
            ctx,
            &p,
            "tonegate.bloom_blur",
            &[
                (0, Bind::Buffer(&weights)),
                (1, Bind::Texture(from)),
                (2, Bind::Texture(to)),
            ],
        );
        dispatch_2d(p, bg, to.width(), to.height())
    };
    vec![pass(true, src, tmp), pass(false, tmp, blur_out)]
}
