//! Reading a stage's output texture back to the host: what the
//! stage-by-stage tests compare with the f64 reference, never part of a
//! measured frame.

use super::renderer::{extent_of, GpuRenderer};
use super::stages::read_buffer;
use super::{GpuError, HdrFormat};
use crate::image::LinearImage;
use crate::reference::bloom_downsample::downsampled_size;

impl GpuRenderer<'_> {
    /// Reads back the output texture of `stage` ("sphere", "taa_sobel",
    /// "taa", "tonemap", "bloom_blur", "bloom_composite", "grade", "display"
    /// for the frame entering `encode`, "taa_history" for the unsharpened
    /// TAA blend of the last frame, or "taa_confidence" for its frame counts
    /// in every channel) as f64, or None when the plan has no such stage.
    pub fn read_output(&self, stage: &str) -> Result<Option<LinearImage>, GpuError> {
        // The TAA history the last frame wrote: the texture the next frame
        // reads, its frame counts in alpha.
        let history = self.taa.as_ref().into_iter().flat_map(|t| {
            let odd = self.odd.load(std::sync::atomic::Ordering::Relaxed);
            let texture = &t.history[usize::from(odd)];
            [("taa_history", texture), ("taa_confidence", texture)]
        });
        let alpha = stage == "taa_confidence";
        let found = self
            .outputs
            .iter()
            .map(|(n, t)| (*n, t))
            .chain(history)
            .find(|(n, _)| *n == stage);
        let Some((_, texture)) = found else {
            return Ok(None);
        };
        // The part the frame covers: a texture of the capacity holds the
        // frame, one of the bloom's level at the capacity holds its level.
        let extent = extent_of(*self.lock_size(), self.bloom_factor);
        let texture_size = (texture.width(), texture.height());
        let (w, h) = if texture_size == self.capacity {
            (extent.frame[0], extent.frame[1])
        } else if Some(texture_size)
            == self
                .bloom_factor
                .map(|f| downsampled_size(self.capacity.0, self.capacity.1, f))
        {
            (extent.low[0], extent.low[1])
        } else {
            texture_size
        };
        let single = texture.format() == wgpu::TextureFormat::R32Float;
        let bpp = if single {
            4
        } else {
            self.config.hdr_format.bytes_per_pixel()
        };
        let row = (w * bpp).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buf = read_buffer(self.ctx, "tonegate.readback", row as u64 * h as u64);
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("tonegate.readback"),
            });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.ctx.queue.submit([encoder.finish()]);
        let bytes = self.ctx.read_buffer(&buf)?;
        let mut pixels = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h as usize {
            let line = &bytes[y * row as usize..y * row as usize + (w * bpp) as usize];
            for px in line.chunks_exact(bpp as usize) {
                if single {
                    let v = f32::from_le_bytes([px[0], px[1], px[2], px[3]]) as f64;
                    pixels.push([v, v, v]);
                    continue;
                }
                let c = |i: usize| -> f64 {
                    match self.config.hdr_format {
                        HdrFormat::Rgba32Float => f32::from_le_bytes([
                            px[4 * i],
                            px[4 * i + 1],
                            px[4 * i + 2],
                            px[4 * i + 3],
                        ]) as f64,
                        HdrFormat::Rgba16Float => {
                            half::f16::from_le_bytes([px[2 * i], px[2 * i + 1]]).to_f64()
                        }
                    }
                };
                pixels.push(if alpha { [c(3); 3] } else { [c(0), c(1), c(2)] });
            }
        }
        Ok(Some(LinearImage {
            width: w,
            height: h,
            pixels,
        }))
    }
}
