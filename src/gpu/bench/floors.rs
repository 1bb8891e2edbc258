//! The floor passes every stage's time is divided by: one store a pixel,
//! and one load and one store, timed in the measured frame's own
//! submission.

use crate::gpu::{GpuContext, HdrFormat};
use crate::perf::{quantile, StageTiming};

/// The two floor passes, recorded after a frame's stages in the same
/// submission and timed in their own query slots.
pub(super) struct Floors {
    write: crate::gpu::stages::Dispatch,
    read_write: crate::gpu::stages::Dispatch,
    pub(super) queries: crate::gpu::timing::Queries,
    _textures: [wgpu::Texture; 2],
}

impl Floors {
    pub(super) const NAMES: [&'static str; 2] = ["floor", "floor_rw"];

    /// None where the adapter has no timestamps (nothing to time).
    pub(super) fn new(
        ctx: &GpuContext,
        width: u32,
        height: u32,
        format: HdrFormat,
    ) -> Option<Floors> {
        let queries = crate::gpu::timing::Queries::new(ctx, 2)?;
        let input =
            crate::gpu::stages::hdr_texture(ctx, "tonegate.floor_in", width, height, format);
        let out = crate::gpu::stages::hdr_texture(ctx, "tonegate.floor", width, height, format);
        Some(Floors {
            write: crate::gpu::floor::floor(ctx, format, &out),
            read_write: crate::gpu::floor::floor_rw(ctx, format, &input, &out),
            queries,
            _textures: [input, out],
        })
    }

    pub(super) fn encode(&self, encoder: &mut wgpu::CommandEncoder, slot: u32) {
        for (i, d) in [&self.write, &self.read_write].into_iter().enumerate() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(&format!("tonegate.{}", Self::NAMES[i])),
                timestamp_writes: Some(self.queries.writes(slot, i)),
            });
            d.record(&mut pass);
        }
        self.queries.resolve(encoder, slot);
    }
}

/// The median over frames of `stage`'s time / `floor`'s in the same frame.
pub(super) fn median_ratio(
    frames: &[Vec<StageTiming>],
    floors: &[Vec<StageTiming>],
    stage: &str,
    floor: usize,
) -> f64 {
    let ratios: Vec<f64> = frames
        .iter()
        .zip(floors)
        .filter_map(|(f, fl)| {
            let s = f.iter().find(|t| t.stage == stage)?.ms;
            let d = fl.get(floor)?.ms;
            (d > 0.0).then_some(s / d)
        })
        .collect();
    if ratios.is_empty() {
        f64::NAN
    } else {
        quantile(&ratios, 0.5)
    }
}
