//! `bloom_blur` pass: horizontal then vertical, weights from the reference.

use crate::gpu::stages::{bind_group, groups, pipeline, uniform_buffer, Bind, Dispatch, GROUP_X};
use crate::gpu::{GpuContext, HdrFormat};
use crate::reference::bloom_blur::gaussian_weights;

/// Pixels each invocation writes; `RUN` in bloom_blur.wgsl.
const RUN: u32 = 4;

#[allow(clippy::too_many_arguments)]
pub fn bloom_blur(
    ctx: &GpuContext,
    format: HdrFormat,
    radius: u32,
    sigma: f64,
    src: &wgpu::Texture,
    tmp: &wgpu::Texture,
    blur_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Vec<Dispatch> {
    // `array<vec4<f32>, 33>` in bloom_blur.wgsl: room for radius 64.
    let mut w = [0f32; 4 * 33];
    for (slot, v) in w.iter_mut().zip(gaussian_weights(radius, sigma)) {
        *slot = v as f32;
    }
    let weights = uniform_buffer(ctx, "tonegate.bloom_blur.weights", bytemuck::cast_slice(&w));
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
        // One invocation per RUN pixels along the pass (bloom_blur.wgsl).
        let (w, h) = (to.width(), to.height());
        let (x, y) = if horizontal {
            (w.div_ceil(RUN), h)
        } else {
            (w, h.div_ceil(RUN))
        };
        Dispatch::new(p, bg, (groups(x, GROUP_X), y)).sized(ctx, extent)
    };
    vec![pass(true, src, tmp), pass(false, tmp, blur_out)]
}
