//! The values one record of a [`super::ToneMapper`] maps with (the
//! operator's parameters, the adaptation's step, the TAA step, where the
//! image goes in the target), copied into the uniforms the passes bind by
//! commands of the record's own encoder.
//!
//! A `queue.write_buffer` lands before the whole submission, so two
//! records in one submission with other settings would both see the last
//! ones written. Here each record's values are written to a slot of their
//! own in a ring and copied from there into the bound uniform by the
//! encoder, in order with the record's passes: each record maps with its
//! own values, however many share a submission (up to the ring's size).

use crate::gpu::GpuContext;

/// The ring's bytes: a record stages about 100, so a submission may hold
/// several hundred records of one mapper before a slot is reused within it.
pub(super) const RING_BYTES: u64 = 64 * 1024;

/// Slots start on 16-byte boundaries (copies need 4).
const SLOT_ALIGN: u64 = 16;

/// Where the next record's values go.
pub(super) struct UniformRing {
    buffer: wgpu::Buffer,
    cursor: u64,
}

impl UniformRing {
    pub(super) fn new(ctx: &GpuContext) -> UniformRing {
        UniformRing {
            buffer: ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonegate.tone_mapper.uniform_ring"),
                size: RING_BYTES,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            cursor: 0,
        }
    }

    /// Records, into `encoder`, `bytes` (a multiple of 4 long) copied into
    /// the start of `uniform`: the passes recorded after it in the encoder
    /// read them.
    pub(super) fn stage(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &wgpu::Buffer,
        bytes: &[u8],
    ) {
        let len = bytes.len() as u64;
        let step = len.next_multiple_of(SLOT_ALIGN);
        if self.cursor + step > RING_BYTES {
            self.cursor = 0;
        }
        ctx.queue.write_buffer(&self.buffer, self.cursor, bytes);
        encoder.copy_buffer_to_buffer(&self.buffer, self.cursor, uniform, 0, len);
        self.cursor += step;
    }
}
