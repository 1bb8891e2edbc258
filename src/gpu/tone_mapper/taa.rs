//! Temporal anti-aliasing in a [`ToneMapper`]: the application renders
//! each frame with a sub-pixel jitter and gives its motion vectors; the
//! mapper resolves the frame against its history (the gate's `taa` stage,
//! its `_motion` entries) before measuring and mapping it, and carries the
//! history from one record to the next (docs/embedding.md#taa).

use super::target::{check_texture, TextureRole, ToneMapperError};
use super::{SourceView, TargetView, ToneMapper};
use crate::gpu::taa::TaaUniforms;
use crate::image::Image;
use crate::reference::taa::TaaHistory;

/// The formats a [`MotionVectors`] texture may have: the vector is its
/// first two channels.
pub const MOTION_FORMATS: [wgpu::TextureFormat; 4] = [
    wgpu::TextureFormat::Rg16Float,
    wgpu::TextureFormat::Rg32Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba32Float,
];

/// What a motion vector measures. Either way it is where the surface a
/// pixel shows is now minus where it was in the previous frame, with y
/// down (the convention of bevy, Unity and Unreal).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MotionUnits {
    /// Pixels of the frame.
    #[default]
    Pixels,
    /// Texture coordinates: the frame is 1 wide and 1 high (bevy's and
    /// Unity's motion vectors).
    Uv,
}

/// A frame's motion vectors: a view of a texture of the input's size, in
/// one of [`MOTION_FORMATS`], with `TEXTURE_BINDING`.
#[derive(Clone, Copy, Debug)]
pub struct MotionVectors<'a> {
    /// The first level of the view is read.
    pub view: &'a wgpu::TextureView,
    /// What the vectors measure.
    pub units: MotionUnits,
}

impl<'a> MotionVectors<'a> {
    /// Vectors in pixels.
    pub fn pixels(view: &'a wgpu::TextureView) -> MotionVectors<'a> {
        MotionVectors {
            view,
            units: MotionUnits::Pixels,
        }
    }

    /// Vectors in texture coordinates.
    pub fn uv(view: &'a wgpu::TextureView) -> MotionVectors<'a> {
        MotionVectors {
            view,
            units: MotionUnits::Uv,
        }
    }

    /// What turns a vector into the offset, in pixels of a frame of `size`,
    /// from a pixel to where it was: `reference::taa::Reprojection::Motion`'s
    /// scale.
    pub fn scale(&self, size: (u32, u32)) -> [f64; 2] {
        match self.units {
            MotionUnits::Pixels => [-1.0, -1.0],
            MotionUnits::Uv => [-(size.0 as f64), -(size.1 as f64)],
        }
    }
}

impl ToneMapper {
    /// Records a frame as [`ToneMapper::record`] does, resolving it first
    /// against the history by `motion` when the settings have TAA (and
    /// ignoring `motion` when they do not). The frame is the application's
    /// render with this frame's jitter (a sequence of sub-pixel offsets,
    /// such as `conventions::taa_jitter`'s); the history is the mapper's,
    /// carried from the previous record. TAA reads the whole first level of
    /// `input`'s texture.
    pub fn record_with_motion<'a>(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        input: impl Into<SourceView<'a>>,
        motion: MotionVectors<'a>,
        output: impl Into<TargetView<'a>>,
    ) -> Result<(), ToneMapperError> {
        self.record_frame(encoder, input.into(), Some(motion), output.into())
    }

    /// The next frame has no history (a camera cut, a teleport): it passes
    /// through TAA as it is, and the history starts again from it. The
    /// first frame after `new`, after TAA settings change, and after the
    /// input's size changes has none anyway.
    pub fn reset_history(&mut self) {
        self.history.reset = true;
    }

    /// The history the last frame recorded (and submitted) wrote: its
    /// resolved colours and each pixel's frame count; `None` without TAA
    /// or before a frame. It waits for the device: for tests and debugging
    /// views, not for every frame.
    pub fn read_history(&self) -> Result<Option<TaaHistory>, ToneMapperError> {
        let Some(resources) = &self.history.resources else {
            return Ok(None);
        };
        let texture = &resources.history[usize::from(self.history.odd)];
        let (w, h) = (texture.width(), texture.height());
        // Rgba32Float, the history's format in the mapper's configuration.
        let row = (w * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let staging = self.ctx.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tonegate.taa.history.read"),
            size: u64::from(row * h),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: None,
                },
            },
            texture.size(),
        );
        self.ctx.queue.submit([encoder.finish()]);
        let bytes = self
            .ctx
            .read_buffer(&staging)
            .map_err(ToneMapperError::Readback)?;
        let texel = |x: u32, y: u32| -> [f64; 4] {
            let at = (y * row + x * 16) as usize;
            let v: [f32; 4] = bytemuck::pod_read_unaligned(&bytes[at..at + 16]);
            v.map(f64::from)
        };
        Ok(Some(TaaHistory {
            colour: Image::from_fn(w, h, |x, y| {
                let t = texel(x, y);
                [t[0], t[1], t[2]]
            }),
            confidence: Image::from_fn(w, h, |x, y| texel(x, y)[3]),
        }))
    }

    /// Whether the settings resolve frames against a history.
    pub(super) fn has_taa(&self) -> bool {
        self.settings
            .taa
            .as_ref()
            .is_some_and(|t| t.variant != crate::scene::TaaVariant::Off)
    }

    /// The motion view to wire, or why the mapper cannot use it for an
    /// input of `size` in `input`'s texture at `level`.
    pub(super) fn motion_key(
        &self,
        input: &wgpu::Texture,
        level: u32,
        size: (u32, u32),
        motion: Option<&MotionVectors>,
    ) -> Result<Option<wgpu::TextureView>, ToneMapperError> {
        if !self.has_taa() {
            return Ok(None);
        }
        let Some(motion) = motion else {
            return Err(ToneMapperError::NoMotionVectors);
        };
        let whole = (input.width(), input.height());
        if level != 0 || size != whole {
            return Err(ToneMapperError::TaaInput {
                level,
                size,
                texture: whole,
            });
        }
        let texture = motion.view.texture();
        if !MOTION_FORMATS.contains(&texture.format()) {
            return Err(ToneMapperError::MotionFormat {
                format: texture.format(),
            });
        }
        check_texture(
            texture,
            TextureRole::Motion,
            wgpu::TextureUsages::TEXTURE_BINDING,
        )?;
        let motion_size = (texture.width(), texture.height());
        if motion_size != size {
            return Err(ToneMapperError::MotionSize {
                motion: motion_size,
                input: size,
            });
        }
        Ok(Some(motion.view.clone()))
    }

    /// Copies this frame's TAA uniforms in by `encoder`; true when the
    /// frame reads the second texture of the history pair. Nothing without
    /// TAA.
    pub(super) fn step_history(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        motion: Option<&MotionVectors>,
        size: (u32, u32),
    ) -> bool {
        let (Some(motion), Some(resources)) = (motion, &self.history.resources) else {
            return false;
        };
        let [sx, sy] = motion.scale(size);
        let u = TaaUniforms::motion(!self.history.reset, [sx as f32, sy as f32]);
        self.ring.stage(
            &self.ctx,
            encoder,
            &resources.uniforms,
            bytemuck::bytes_of(&u),
        );
        self.history.reset = false;
        let odd = self.history.odd;
        self.history.odd = !odd;
        odd
    }
}

/// The TAA history a mapper carries between records.
pub(super) struct History {
    /// The pair of history textures and the stage's uniforms, made by the
    /// first wiring with TAA and kept while the input's size stays.
    pub resources: Option<crate::gpu::taa::TaaResources>,
    /// The next frame reads the pair's second texture.
    pub odd: bool,
    /// The next frame has no history.
    pub reset: bool,
}

impl Default for History {
    fn default() -> History {
        History {
            resources: None,
            odd: false,
            reset: true,
        }
    }
}
