//! Where `check` computes FLIP (`--metrics cpu|gpu|auto`): nv-flip on the
//! CPU, or tonegate's port of the same pipeline on the check's own adapter
//! (`gpu::flip`, locked to nv-flip within 1e-4 of the mean).

use crate::gpu::GpuContext;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MetricsOn {
    /// The GPU on a hardware adapter; the CPU on a CPU adapter (llvmpipe,
    /// SwiftShader) and for the CPU reference: on llvmpipe, FLIP on the GPU
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
