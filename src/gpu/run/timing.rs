//! Per-stage GPU time from timestamp queries: one (begin, end) pair per
//! pass, in one of `TIMING_SLOTS` slots so frames in flight keep theirs.

use crate::gpu::{GpuContext, GpuError};
use crate::perf::StageTiming;

/// Frames in flight whose timestamps can be kept before they are read.
pub const TIMING_SLOTS: u32 = 32;

/// Timestamp queries: one (begin, end) pair per pass per slot.
pub struct Queries {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// Byte stride of one slot in the resolve buffer (256-aligned).
    stride: u64,
    passes: u32,
}

impl Queries {
    /// Queries for `passes` passes, or None when the adapter cannot time.
    pub fn new(ctx: &GpuContext, passes: usize) -> Option<Queries> {
        if !ctx.adapter.timestamps {
            return None;
        }
        let n = 2 * passes as u32;
        let stride = (n as u64 * 8).div_ceil(256) * 256;
        Some(Queries {
            set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("tonegate.timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: n * TIMING_SLOTS,
            }),
            resolve: ctx.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonegate.timestamps.resolve"),
                size: stride * TIMING_SLOTS as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: crate::gpu::stages::read_buffer(
                ctx,
                "tonegate.timestamps.read",
                stride * TIMING_SLOTS as u64,
            ),
            stride,
            passes: passes as u32,
        })
    }

    /// The timestamp writes of pass `pass` in `slot`.
    pub fn writes(&self, slot: u32, pass: usize) -> wgpu::ComputePassTimestampWrites<'_> {
        let base = slot % TIMING_SLOTS * 2 * self.passes;
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(base + 2 * pass as u32),
            end_of_pass_write_index: Some(base + 2 * pass as u32 + 1),
        }
    }

    /// Resolves `slot`'s timestamps into the resolve buffer.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder, slot: u32) {
        let n = 2 * self.passes;
        let s = slot % TIMING_SLOTS;
        encoder.resolve_query_set(
            &self.set,
            s * n..(s + 1) * n,
            &self.resolve,
            s as u64 * self.stride,
        );
    }

    /// Bytes of one slot's resolved timestamps.
    pub fn slot_bytes(&self) -> u64 {
        self.stride
    }

    /// Copies `slot`'s resolved timestamps into `dst` (a frame's own staging).
    pub fn copy_slot(&self, encoder: &mut wgpu::CommandEncoder, slot: u32, dst: &wgpu::Buffer) {
        let s = (slot % TIMING_SLOTS) as u64;
        encoder.copy_buffer_to_buffer(&self.resolve, s * self.stride, dst, 0, self.stride);
    }

    /// Stage times from one slot's resolved timestamps, passes named by `names`.
    pub fn parse(&self, bytes: &[u8], names: &[&str], ctx: &GpuContext) -> Vec<StageTiming> {
        let ticks: Vec<u64> = bytes[..2 * names.len() * 8]
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
            .collect();
        durations(names, &ticks, ctx.timestamp_period)
    }

    /// Copies every slot's resolved timestamps where `read` can map them.
    pub fn copy(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_buffer_to_buffer(
            &self.resolve,
            0,
            &self.read,
            0,
            self.stride * TIMING_SLOTS as u64,
        );
    }

    /// The stage times of the first `slots` slots, passes named by `names`
    /// (after `copy` ran).
    pub fn read(
        &self,
        ctx: &GpuContext,
        names: &[&str],
        slots: u32,
    ) -> Result<Vec<Vec<StageTiming>>, GpuError> {
        let bytes = ctx.read_buffer(&self.read)?;
        let n = 2 * names.len();
        Ok((0..slots.min(TIMING_SLOTS) as usize)
            .map(|s| {
                let at = s * self.stride as usize;
                let ticks: Vec<u64> = bytes[at..at + n * 8]
                    .chunks_exact(8)
                    .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                    .collect();
                durations(names, &ticks, ctx.timestamp_period)
            })
            .collect())
    }
}

/// Stage durations from resolved (begin, end) tick pairs.
pub fn durations(names: &[&str], ticks: &[u64], period_ns: f32) -> Vec<StageTiming> {
    names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let (b, e) = (ticks[2 * i], ticks[2 * i + 1]);
            StageTiming {
                stage: (*name).to_owned(),
                ms: e.saturating_sub(b) as f64 * period_ns as f64 * 1e-6,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perf::summarise;

    #[test]
    fn durations_scale_ticks_by_the_period() {
        let d = durations(&["a", "b"], &[100, 1100, 2000, 2500], 1.0);
        assert_eq!(d[0].ms, 0.001);
        assert_eq!(d[1].ms, 0.0005);
        let s = summarise(&[d.clone(), d]);
        assert_eq!(s[1].median_ms, 0.0005);
    }
}
