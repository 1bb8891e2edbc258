//! The one walk over a plan's stages that turns them into passes: each
//! stage wired fused (where `--execution fused` merges it) or staged, in
//! plan order, up to a stage the caller writes in its own way. The gate's
//! renderer and the `ToneMapper` both wire through it, so what the gate
//! renders and what an application embeds are the same passes.

use super::wiring::{Pass, Wiring};
use super::{Execution, GpuError};
use crate::plan::StagePlan;

/// `plan`'s passes on `wiring`, in order, without the stages merged into
/// another's pass; the walk stops before the stage named `until` (the
/// `ToneMapper` writes its caller's target instead of `encode`'s packed
/// frame).
pub(super) fn wire_plan(
    wiring: &mut Wiring,
    plan: &StagePlan,
    execution: Execution,
    until: Option<&str>,
) -> Result<Vec<Pass>, GpuError> {
    let mut passes = Vec::new();
    for stage in plan.stages() {
        if until == Some(stage.name()) {
            break;
        }
        let fused = match execution {
            Execution::Fused => super::fused::wire(wiring, stage)?,
            Execution::Staged => None,
        };
        let pass = match fused {
            Some(pass) => pass,
            None => wiring.staged(stage)?,
        };
        if !pass.dispatches.is_empty() {
            passes.push(pass);
        }
    }
    Ok(passes)
}
