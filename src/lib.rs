//! tonegate: headless regression and image-quality validation for a GPU HDR tone mapper.
//!
//! The CPU reference (`reference`) is the oracle; the stage plan (`plan`) is the
//! shared contract both renderers execute; `metrics` and `check` judge the
//! outputs; `gate` runs the CI gate over a suite; `server` serves the history.
//! ARCHITECTURE.md draws the layers. The command line lives in the binary.

pub mod changepoint;
pub mod check;
pub mod color;
pub mod conventions;
pub mod env;
pub mod error;
pub mod fuzzing;
pub mod gate;
pub mod golden;
pub mod gpu;
pub mod history;
pub mod image;
pub mod io;
pub mod metrics;
#[deny(missing_docs)]
pub mod operators;
pub mod perf;
pub mod plan;
pub mod progress;
pub mod reference;
pub mod render;
pub mod runner;
pub mod scene;
pub mod server;
pub mod stress;
pub mod suite;
pub mod toning;
pub mod tradeoff;

pub use error::{Error, Result};
pub use gpu::{ToneMapper, ToneMapperSettings};
