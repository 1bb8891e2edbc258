//! tonegate: headless regression and image-quality validation for a GPU HDR tone mapper.
//!
//! The CPU reference (`reference`) is the oracle; the stage plan (`plan`) is the
//! shared contract both renderers execute; `metrics` judges the outputs.

pub mod check;
pub mod cli;
pub mod color;
pub mod conventions;
pub mod env;
pub mod error;
pub mod golden;
pub mod gpu;
pub mod history;
pub mod image;
pub mod io;
pub mod metrics;
pub mod plan;
pub mod reference;
pub mod scene;
pub mod server;
pub mod stress;
pub mod suite;
pub mod toning;
pub mod tradeoff;

pub use error::{Error, Result};
