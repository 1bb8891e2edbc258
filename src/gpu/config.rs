//! The GPU path's knobs: each has serde names (the words the command line,
//! the API and the reports use), and the rule for what actually runs.

use crate::plan::{Stage, StagePlan};
use serde::{Deserialize, Serialize};

/// The largest finite value f16 (rgba16float) can hold.
pub const F16_MAX: f32 = 65504.0;

/// Format of the HDR intermediates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HdrFormat {
    /// Half floats: half the bandwidth; overflows above 65504.
    #[serde(alias = "rgba16float", alias = "f16")]
    Rgba16Float,
    /// Full floats: the default, exact enough to match the f64 reference.
    #[default]
    #[serde(alias = "rgba32float", alias = "f32")]
    Rgba32Float,
}

impl HdrFormat {
    pub fn wgsl_name(self) -> &'static str {
        match self {
            HdrFormat::Rgba16Float => "rgba16float",
            HdrFormat::Rgba32Float => "rgba32float",
        }
    }

    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            HdrFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
            HdrFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
        }
    }

    pub fn bytes_per_pixel(self) -> u32 {
        match self {
            HdrFormat::Rgba16Float => 8,
            HdrFormat::Rgba32Float => 16,
        }
    }
}

/// How `sphere` filters the environment and `taa` its history.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EnvFilter {
    /// Bilinear in the shader from four loads: the reference's arithmetic.
    #[default]
    Manual,
    /// The texture unit's linear filter (needs float32-filterable textures).
    Hardware,
}

/// How `luminance_stats` (and `grade_stats`) reduce the frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReductionMethod {
    /// Per adapter ([`ReductionMethod::resolve`]): block partials on a CPU
    /// adapter; on a GPU the subgroup tree where it has subgroup
    /// operations, else the shared-memory tree.
    #[default]
    Auto,
    /// The reduction of the modified Reinhard for training simulators
    /// (docs/bibliography.md): one pass of barrier-free 16×16 block partials,
    /// one combine. Fastest on llvmpipe, where barriers are expensive; on a
    /// discrete GPU its one-invocation combine of thousands of partials
    /// dominated the frame (1.66 ms of 1.94 at 1080p on an NVIDIA H100 80GB
    /// HBM3, Vulkan driver 580.159.04, build a4e9bd9 of 2026-11-21).
    #[serde(alias = "block")]
    BlockPartials,
    /// The reduction of Reinhard's global operator in real time: log₂ passes
    /// of 2×2 downsampling.
    #[serde(alias = "pingpong")]
    PingPong,
    /// Workgroup tree: 256 invocations reduce a 32×32 tile in shared memory,
    /// then one workgroup reduces the tiles' partials the same way.
    #[serde(alias = "workgroup_tree")]
    Tree,
    /// The tree's tiles and order of work, with subgroup operations: each
    /// subgroup merges its invocations' partials by a butterfly of shuffles
    /// (no shared memory, no barrier), and shared memory holds one partial
    /// per subgroup. Needs an adapter with subgroup operations; without
    /// them it runs as `tree`, and the configuration's notes say so.
    #[serde(alias = "subgroup")]
    SubgroupTree,
}

/// What an adapter offers that decides which configuration runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdapterTraits {
    /// A CPU adapter (device type `Cpu`: llvmpipe, SwiftShader).
    pub cpu: bool,
    /// Subgroup operations (wgpu's `SUBGROUP` feature).
    pub subgroups: bool,
}

impl ReductionMethod {
    /// The method that runs: `Auto` becomes block partials on a CPU adapter,
    /// the subgroup tree on a GPU with subgroup operations and the shared-
    /// memory tree on one without; the subgroup tree asked of an adapter
    /// without them becomes the shared-memory tree.
    pub fn resolve(self, adapter: AdapterTraits) -> ReductionMethod {
        match self {
            ReductionMethod::Auto if adapter.cpu => ReductionMethod::BlockPartials,
            ReductionMethod::Auto | ReductionMethod::SubgroupTree if adapter.subgroups => {
                ReductionMethod::SubgroupTree
            }
            ReductionMethod::Auto | ReductionMethod::SubgroupTree => ReductionMethod::Tree,
            method => method,
        }
    }
}

/// How the plan's stages map onto kernels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Execution {
    /// One kernel per stage: every stage timed and readable on its own.
    #[default]
    Staged,
    /// The display-referred stages merged (shaders/fused.wgsl): tonemap,
    /// bloom_composite and encode in one kernel; bloom_bright and
    /// bloom_downsample in another. Same per-pixel functions in the same
    /// order, fewer full-frame stores and loads. Timed per kernel; the
    /// merged stages' outputs cannot be read back. Plans with a grade run
    /// staged (the grade needs the whole frame's mean first); `notes` says so.
    Fused,
}

/// The knobs of the GPU path that trade accuracy for speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct GpuConfig {
    pub hdr_format: HdrFormat,
    pub reduction: ReductionMethod,
    pub env_filter: EnvFilter,
    pub execution: Execution,
    /// Fault injection: multiply the tone-mapped colour by this gain, a
    /// deliberately wrong tone mapper that proves the gate catches one
    /// (`check --fault-gain 1.02`). None in every real run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fault_gain: Option<f32>,
    /// Fault injection: a deliberately broken TAA that proves the gate's TAA
    /// checks catch one (`check --taa-fault no-clip`). None in every real run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub taa_fault: Option<TaaFault>,
    /// Fault injection: wait this many milliseconds after each frame of a
    /// sequence, a deliberately slower renderer that proves a change in
    /// FPS is found and alerted on (`check --fault-delay-ms 40`). None in
    /// every real run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fault_delay_ms: Option<u32>,
}

/// The ways `check --taa-fault` breaks the TAA stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum TaaFault {
    /// The history is blended without the clipping box (ghosts stay).
    NoClip,
    /// The history is reprojected as if the sphere had not turned.
    WrongRotation,
}

impl GpuConfig {
    /// The accuracy options this configuration has in effect, which bounds
    /// for them apply to (after an f16 promotion to f32 there is no f16 left
    /// to excuse).
    #[cfg(feature = "reference")]
    pub fn accuracy_options(&self) -> Vec<crate::check::AccuracyOption> {
        use crate::check::AccuracyOption;
        let mut v = Vec::new();
        if self.hdr_format == HdrFormat::Rgba16Float {
            v.push(AccuracyOption::Rgba16float);
        }
        if self.env_filter == EnvFilter::Hardware {
            v.push(AccuracyOption::HardwareFilter);
        }
        v
    }

    /// What runs for `plan` on an input whose largest component is
    /// `input_max` on an adapter that is (or is not) a CPU, and why it
    /// differs from `self` (the renderer's notes).
    pub fn in_effect(
        self,
        input_max: f32,
        plan: &StagePlan,
        adapter: AdapterTraits,
    ) -> (GpuConfig, Vec<String>) {
        let mut config = self;
        let mut notes = Vec::new();
        config.reduction = self.reduction.resolve(adapter);
        if self.reduction == ReductionMethod::SubgroupTree
            && config.reduction != ReductionMethod::SubgroupTree
        {
            notes.push(
                "reduction subgroup_tree ran as tree: the adapter has no subgroup operations"
                    .into(),
            );
        }
        // f16 overflow: every HDR intermediate before `tonemap` is a filtered
        // or averaged copy of the input, so none exceeds the input's largest
        // component. Past f16's 65504 the f16 path would store +Inf, so it is
        // promoted to f32 here and the promotion reported.
        if config.hdr_format == HdrFormat::Rgba16Float && input_max > F16_MAX {
            notes.push(format!(
                "rgba16float intermediates promoted to rgba32float: the input reaches {input_max:.4e}, beyond f16's largest value {F16_MAX}"
            ));
            config.hdr_format = HdrFormat::Rgba32Float;
        }
        if config.execution == Execution::Fused
            && plan
                .stages()
                .iter()
                .any(|s| matches!(s, Stage::Grade | Stage::GradeStats))
        {
            notes.push(
                "executed staged: fused execution covers plans without a grade (the grade needs the whole frame's mean first)".into(),
            );
            config.execution = Execution::Staged;
        }
        (config, notes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_reduction_is_block_partials_on_a_cpu_adapter_and_a_tree_on_a_gpu() {
        let at = |cpu, subgroups| AdapterTraits { cpu, subgroups };
        use ReductionMethod::*;
        assert_eq!(Auto.resolve(at(true, false)), BlockPartials);
        assert_eq!(Auto.resolve(at(true, true)), BlockPartials);
        assert_eq!(Auto.resolve(at(false, false)), Tree);
        assert_eq!(Auto.resolve(at(false, true)), SubgroupTree);
        assert_eq!(SubgroupTree.resolve(at(true, true)), SubgroupTree);
        assert_eq!(SubgroupTree.resolve(at(false, false)), Tree);
        for m in [BlockPartials, PingPong, Tree] {
            for a in [at(true, false), at(false, false), at(false, true)] {
                assert_eq!(m.resolve(a), m);
            }
        }
        let plan = StagePlan::build(
            crate::plan::Input::Flat,
            &crate::operators::Operator::named("reinhard-auto-key", &[]).unwrap(),
            None,
            None,
        );
        let (c, notes) = GpuConfig::default().in_effect(1.0, &plan, at(false, false));
        assert_eq!(c.reduction, Tree);
        assert!(notes.is_empty());
        let asked = GpuConfig {
            reduction: SubgroupTree,
            ..Default::default()
        };
        let (c, notes) = asked.in_effect(1.0, &plan, at(false, false));
        assert_eq!(c.reduction, Tree);
        assert!(notes[0].contains("no subgroup operations"), "{notes:?}");
        let (c, notes) = asked.in_effect(1.0, &plan, at(false, true));
        assert_eq!(c.reduction, SubgroupTree);
        assert!(notes.is_empty());
    }
}
