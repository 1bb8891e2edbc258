//! Eye adaptation per camera: one mapper serving several views keeps an
//! adapted state for each, so a bright and a dark camera each adapt to
//! their own frames. Each record copies the current camera's state into
//! the buffer the `adaptation` pass steps and back after its passes,
//! through the record's own encoder, so records of different cameras in
//! one submission each step their own.

use crate::gpu::stages::storage_buffer;
use crate::gpu::GpuContext;

/// The most cameras one [`super::ToneMapper`] adapts.
pub const MAX_CAMERAS: usize = 8;

/// Bytes of one camera's state (`Adapted` in shaders/adaptation.wgsl, two
/// f32 logarithms, padded).
const STATE: u64 = 16;

pub(super) struct Cameras {
    /// Every camera's state, `STATE` bytes each.
    states: wgpu::Buffer,
    /// The camera the next records adapt.
    pub current: usize,
    /// Whether each camera's next frame takes its target as it is (its
    /// first, or after a reset).
    pub reset: [bool; MAX_CAMERAS],
}

impl Cameras {
    pub fn new(ctx: &GpuContext) -> Cameras {
        Cameras {
            states: storage_buffer(
                ctx,
                "tonegate.adaptation.cameras",
                STATE * MAX_CAMERAS as u64,
            ),
            current: 0,
            reset: [true; MAX_CAMERAS],
        }
    }

    fn at(&self) -> u64 {
        STATE * self.current as u64
    }

    /// Before a record's passes: the current camera's state into `adapted`.
    pub fn load(&self, encoder: &mut wgpu::CommandEncoder, adapted: &wgpu::Buffer) {
        encoder.copy_buffer_to_buffer(&self.states, self.at(), adapted, 0, STATE);
    }

    /// After them: `adapted` back into the current camera's state.
    pub fn store(&self, encoder: &mut wgpu::CommandEncoder, adapted: &wgpu::Buffer) {
        encoder.copy_buffer_to_buffer(adapted, 0, &self.states, self.at(), STATE);
    }

    /// Copies the current camera's state into `to` (16 bytes).
    pub fn copy_current(&self, encoder: &mut wgpu::CommandEncoder, to: &wgpu::Buffer) {
        encoder.copy_buffer_to_buffer(&self.states, self.at(), to, 0, STATE);
    }
}
