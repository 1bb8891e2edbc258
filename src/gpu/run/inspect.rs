//! Reading a stage's output texture back to the host: what the
//! stage-by-stage tests compare with the f64 reference, never part of a
//! measured frame.

use super::renderer::GpuRenderer;
use crate::gpu::stages::extent_of;
use crate::gpu::stages::read_buffer;
use crate::gpu::{GpuError, HdrFormat};
use crate::image::LinearImage;
use crate::reference::bloom_downsample::downsampled_size;

impl GpuRenderer<'_> {
    /// The bytes of `stage`'s output as [`read_output`](Self::read_output)
    /// finds it, with where its pixels are in them, handed to `read`.
    fn with_output<T>(
        &self,
        stage: &str,
        read: impl FnOnce(&[u8], Layout) -> T,
    ) -> Result<Option<T>, GpuError> {
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
        let layout = Layout {
            width: w,
            height: h,
            row: row as usize,
            bpp: bpp as usize,
            single,
            alpha,
            format: self.config.hdr_format,
        };
        self.ctx
            .with_mapped(&buf, |bytes| read(bytes, layout))
            .map(Some)
    }

    /// Reads back the output texture of `stage` ("sphere", "taa_sobel",
    /// "taa", "tonemap", "bloom_blur", "bloom_composite", "grade", "display"
    /// for the frame entering `encode`, "taa_history" for the unsharpened
    /// TAA blend of the last frame, or "taa_confidence" for its frame counts
    /// in every channel) as f64, or None when the plan has no such stage.
    pub fn read_output(&self, stage: &str) -> Result<Option<LinearImage>, GpuError> {
        self.with_output(stage, |bytes, l| {
            let mut pixels = Vec::with_capacity(l.width as usize * l.height as usize);
            l.each(bytes, |px| pixels.push(px));
            LinearImage {
                width: l.width,
                height: l.height,
                pixels,
            }
        })
    }

    /// Whether every value [`read_output`](Self::read_output) would give
    /// for `stage` is finite, read off the mapping without building the f64
    /// image (the stress suite's 8.4 Mpx rows ask it of two stages each).
    pub fn output_finite(&self, stage: &str) -> Result<Option<bool>, GpuError> {
        self.with_output(stage, |bytes, l| {
            let mut finite = true;
            l.each(bytes, |px| finite &= px.iter().all(|v| v.is_finite()));
            finite
        })
    }
}

/// Where a read-back output's pixels are in its bytes.
struct Layout {
    width: u32,
    height: u32,
    /// Bytes from one row to the next (rows are padded for the copy).
    row: usize,
    bpp: usize,
    /// One f32 channel (an R32Float texture), replicated.
    single: bool,
    /// The alpha channel, replicated (TAA's frame counts).
    alpha: bool,
    format: HdrFormat,
}

impl Layout {
    /// Each pixel's three values, in order, as f64.
    fn each(&self, bytes: &[u8], mut f: impl FnMut([f64; 3])) {
        for y in 0..self.height as usize {
            let line = &bytes[y * self.row..y * self.row + self.width as usize * self.bpp];
            for px in line.chunks_exact(self.bpp) {
                if self.single {
                    let v = f32::from_le_bytes([px[0], px[1], px[2], px[3]]) as f64;
                    f([v, v, v]);
                    continue;
                }
                let c = |i: usize| -> f64 {
                    match self.format {
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
                f(if self.alpha {
                    [c(3); 3]
                } else {
                    [c(0), c(1), c(2)]
                });
            }
        }
    }
}
