//! Range-safe arithmetic, proven without a GPU: every per-pixel formula of
//! the tone-mapping stages, evaluated from the WGSL itself (naga's IR,
//! [`interp`]) in f32 under every combination of the rewrites a Vulkan
//! driver may apply, over the stress suite's inputs and the operators'
//! parameter ranges. No intermediate may leave f32's finite range, and the
//! output under any rewrite must stay within the gate's bound of the output
//! as written (docs/stress.md#range-safe-arithmetic). It lives with the
//! stress suite because it runs over the suite's inputs and pipelines.

mod chain;
mod interp;
mod tests;
