//! Where `check` computes the 8-bit frames' metrics (`--metrics
//! cpu|gpu|auto`): on the CPU (FLIP by nv-flip), or on the check's own
//! adapter (`gpu::compare`: the error figures exact, SSIM within 1e-6 and
//! FLIP within 1e-4 of the CPU's).

use crate::gpu::GpuContext;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MetricsOn {
    /// The GPU on a hardware adapter; the CPU on a CPU adapter (llvmpipe,
    /// SwiftShader) and for the CPU reference: on llvmpipe, the metrics on the GPU
    /// measured slower than nv-flip on the same cores
    /// (docs/checks.md#metrics-on-the-gpu).
    #[default]
    Auto,
    Cpu,
    Gpu,
}

impl MetricsOn {
    /// What this choice is on `ctx` (None: the CPU reference renders, with
    /// no adapter): `Cpu` or `Gpu`.
    pub fn resolve(self, ctx: Option<&GpuContext>) -> MetricsOn {
        match (self, ctx) {
            (_, None) | (MetricsOn::Cpu, _) => MetricsOn::Cpu,
            (MetricsOn::Gpu, Some(_)) => MetricsOn::Gpu,
            (MetricsOn::Auto, Some(ctx)) if ctx.cpu_adapter => MetricsOn::Cpu,
            (MetricsOn::Auto, Some(_)) => MetricsOn::Gpu,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            MetricsOn::Auto => "auto",
            MetricsOn::Cpu => "cpu",
            MetricsOn::Gpu => "gpu",
        }
    }
}
