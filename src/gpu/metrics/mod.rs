//! Metrics on the GPU: `flip` (FLIP's LDR pipeline as three compute
//! passes, locked to nv-flip) and `compare` (every 8-bit figure of a pair
//! in one submission, and a kept frame's SSIM and FLIP maps).

pub mod compare;
pub mod flip;
