//! A [`super::ToneMapper`]'s own GPU time: timestamp queries around each
//! of its stages and its render pass, on a device with
//! `Features::TIMESTAMP_QUERY`. With them on, each stage is a compute pass
//! of its own (one pass for all of them otherwise).

use crate::perf::StageTiming;
use crate::plan::Stage;

/// The GPU time of the last frame a [`super::ToneMapper`] recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct MapperTimings {
    /// The compute passes together: statistics, adaptation, curve, bloom,
    /// grade, and the target's write on the compute path.
    pub compute_ms: f64,
    /// The render pass that writes a render-attachment target, when the
    /// frame had one.
    pub target_ms: Option<f64>,
    /// Each compute pass, by the plan's stage name (`luminance_stats`,
    /// `tonemap`, …), and `target` for the write into a storage target.
    pub stages: Vec<StageTiming>,
}

/// The most compute passes a frame has: every stage of a plan, and the
/// target's write.
const MOST_PASSES: usize = Stage::NAMES.len() + 1;

/// (begin, end) pairs: the render pass, then each compute pass.
pub(super) struct Stamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// Nanoseconds a tick.
    period: f32,
    /// Whether the last frame had a render pass.
    rendered: bool,
    /// The last frame's compute passes.
    names: Vec<&'static str>,
}

impl Stamps {
    pub(super) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Stamps {
        let count = 2 * (1 + MOST_PASSES) as u32;
        let bytes = u64::from(count) * 8;
        Stamps {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("tonegate.tone_mapper.timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonegate.tone_mapper.timestamps.resolve"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonegate.tone_mapper.timestamps.read"),
                size: bytes,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            period: queue.get_timestamp_period(),
            rendered: false,
            names: Vec::new(),
        }
    }

    /// The timestamps of compute pass `i`.
    pub(super) fn compute(&self, i: usize) -> wgpu::ComputePassTimestampWrites<'_> {
        let begin = 2 * (1 + i.min(MOST_PASSES - 1)) as u32;
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(begin),
            end_of_pass_write_index: Some(begin + 1),
        }
    }

    pub(super) fn render(&self) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// After the frame's passes (`names` the compute ones): their
    /// timestamps into the readable buffer.
    pub(super) fn resolve(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        names: Vec<&'static str>,
        rendered: bool,
    ) {
        let n = 2 * (1 + names.len().min(MOST_PASSES)) as u32;
        encoder.resolve_query_set(&self.set, 0..n, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, u64::from(n) * 8);
        self.rendered = rendered;
        self.names = names;
    }

    /// The last frame's times from its resolved timestamps.
    pub(super) fn timings(&self, ticks: &[u8]) -> MapperTimings {
        let stamp =
            |i: usize| u64::from_le_bytes(ticks[i * 8..i * 8 + 8].try_into().unwrap_or([0; 8]));
        let ms =
            |a: usize| stamp(a + 1).saturating_sub(stamp(a)) as f64 * f64::from(self.period) / 1e6;
        let stages: Vec<StageTiming> = self
            .names
            .iter()
            .enumerate()
            .map(|(i, name)| StageTiming {
                stage: (*name).to_owned(),
                ms: ms(2 * (1 + i)),
            })
            .collect();
        MapperTimings {
            compute_ms: stages.iter().map(|s| s.ms).sum(),
            target_ms: self.rendered.then(|| ms(0)),
            stages,
        }
    }

    pub(super) fn read_buffer(&self) -> &wgpu::Buffer {
        &self.read
    }
}
