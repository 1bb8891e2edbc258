//! One rendered frame of a scene, on either renderer: the image, the
//! host time, and what the renderer reports besides.

use crate::gpu::{GpuError, GpuFrame, GpuStats};
use crate::image::Frame;
use crate::perf::StageTiming;
use crate::reference::FrameSummary;
use std::time::Instant;

/// What a frame's renderer reports besides the image.
#[derive(Clone, Debug)]
pub enum FrameDetail {
    /// The reference's statistics and resolved operator parameters.
    Cpu(FrameSummary),
    /// The GPU's statistics and each stage's time.
    Gpu {
        stats: GpuStats,
        timings: Vec<StageTiming>,
    },
}

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    pub index: u32,
    /// The encoded frame (8-bit, or 16-bit PQ).
    pub image: Frame,
    /// Host time for the frame, GPU readback included.
    pub wall_ms: f64,
    pub detail: FrameDetail,
}

impl RenderedFrame {
    /// The GPU's frame `index`, which must have been read back.
    pub(super) fn gpu(index: u32, out: GpuFrame) -> Result<RenderedFrame, GpuError> {
        let image = out
            .frame
            .ok_or_else(|| GpuError::Readback("no frame".into()))?;
        Ok(RenderedFrame {
            index,
            image,
            wall_ms: out.wall_ms,
            detail: FrameDetail::Gpu {
                stats: out.stats,
                timings: out.timings,
            },
        })
    }

    /// The reference's frame `index`, rendered since `start`.
    pub(super) fn cpu(
        index: u32,
        out: crate::reference::FrameOutputs,
        start: Instant,
    ) -> RenderedFrame {
        RenderedFrame {
            index,
            image: out.frame,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
            detail: FrameDetail::Cpu(FrameSummary {
                stats: out.stats,
                tone: out.tone,
            }),
        }
    }

    /// The log average the operator read: with eye adaptation in the plan,
    /// the luminance the frame was adapted to (docs/adaptation.md).
    pub fn log_average(&self) -> Option<f64> {
        match &self.detail {
            FrameDetail::Cpu(s) => s.stats.log_average,
            FrameDetail::Gpu { stats, .. } => Some(f64::from(stats.log_average)),
        }
    }

    /// The operator's resolved values for this frame (`op` reads the GPU's).
    pub fn tone(&self, op: &crate::operators::Operator) -> crate::operators::ToneParams {
        match &self.detail {
            FrameDetail::Cpu(s) => s.tone.clone(),
            FrameDetail::Gpu { stats, .. } => op.gpu_resolved(stats.tone),
        }
    }
}
