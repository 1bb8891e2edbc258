//! A [`super::ToneMapper`]'s own GPU time: timestamp queries around its
//! compute pass and its render pass, on a device with
//! `Features::TIMESTAMP_QUERY`.

/// The GPU time of the last frame a [`super::ToneMapper`] recorded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapperTimings {
    /// The compute pass: statistics, adaptation, curve, bloom, grade, and
    /// the target's write on the compute path.
    pub compute_ms: f64,
    /// The render pass that writes a render-attachment target, when the
    /// frame had one.
    pub target_ms: Option<f64>,
}

/// Two (begin, end) pairs: the compute pass, then the render pass.
pub(super) struct Stamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// Nanoseconds a tick.
    period: f32,
    /// Whether the last frame had a render pass.
    rendered: bool,
}

impl Stamps {
    pub(super) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Stamps {
        Stamps {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("tonegate.tone_mapper.timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 4,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonegate.tone_mapper.timestamps.resolve"),
                size: 32,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tonegate.tone_mapper.timestamps.read"),
                size: 32,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            period: queue.get_timestamp_period(),
            rendered: false,
        }
    }

    pub(super) fn compute(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    pub(super) fn render(&self) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(2),
            end_of_pass_write_index: Some(3),
        }
    }

    /// After the frame's passes: their timestamps into the readable buffer.
    pub(super) fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder, rendered: bool) {
        let n = if rendered { 4 } else { 2 };
        encoder.resolve_query_set(&self.set, 0..n, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, u64::from(n) * 8);
        self.rendered = rendered;
    }

    /// The last frame's times from its resolved timestamps.
    pub(super) fn timings(&self, ticks: &[u8]) -> MapperTimings {
        let stamp =
            |i: usize| u64::from_le_bytes(ticks[i * 8..i * 8 + 8].try_into().unwrap_or([0; 8]));
        let ms =
            |a: usize| stamp(a + 1).saturating_sub(stamp(a)) as f64 * f64::from(self.period) / 1e6;
        MapperTimings {
            compute_ms: ms(0),
            target_ms: self.rendered.then(|| ms(2)),
        }
    }

    pub(super) fn read_buffer(&self) -> &wgpu::Buffer {
        &self.read
    }
}
