//! tonegate: headless regression and image-quality validation for a GPU HDR tone mapper.
//!
//! The CPU reference (`reference`) is the oracle; the stage plan (`plan`) is the
//! shared contract both renderers execute; `metrics` and `check` judge the
//! outputs; `gate` runs the CI gate over a suite; `server` serves the history.
//! ARCHITECTURE.md draws the layers. The command line lives in the binary.
//!
//! Cargo features (all on by default) follow the layers: without any, the
//! crate is the operators, the scene's types and plans; `reference` adds
//! the CPU reference, the metrics, the file formats, scene and suite files
//! and the parsers of what a client sends; `embed` the `ToneMapper` alone
//! on an application's wgpu device (no backend of its own, nothing of the
//! service); `gpu` both, the wgpu renderer and what runs on it, `history` the run store and the gate
//! of submitted frames (`frames`; with `gpu`, the suite's gate), `postgres`
//! and `s3` a fleet's history and artifact store, `server` the HTTP API and
//! the runner, `cli` the binary.

#[cfg(feature = "server")]
pub mod alerts;
pub mod changepoint;
#[cfg(feature = "reference")]
pub mod check;
pub mod color;
pub mod conventions;
#[cfg(feature = "reference")]
pub mod env;
#[cfg(feature = "reference")]
pub mod error;
#[cfg(feature = "history")]
pub mod frames;
#[cfg(feature = "reference")]
pub mod fuzzing;
#[cfg(all(feature = "gpu", feature = "history"))]
pub mod gate;
#[cfg(feature = "gpu")]
pub mod golden;
#[cfg(feature = "embed")]
pub mod gpu;
#[cfg(feature = "history")]
pub mod history;
pub mod image;
#[cfg(feature = "reference")]
pub mod io;
#[cfg(feature = "reference")]
pub mod metrics;
#[deny(missing_docs)]
pub mod operators;
mod par;
pub mod perf;
pub mod plan;
pub mod progress;
pub mod reference;
#[cfg(feature = "gpu")]
pub mod render;
#[cfg(feature = "reference")]
pub mod request;
#[cfg(feature = "server")]
pub mod runner;
pub mod scene;
#[cfg(feature = "server")]
pub mod server;
#[cfg(feature = "gpu")]
pub mod stress;
#[cfg(feature = "reference")]
pub mod suite;
#[cfg(feature = "reference")]
pub mod toning;
#[cfg(all(feature = "gpu", feature = "history"))]
pub mod tradeoff;

#[cfg(feature = "reference")]
pub use error::{Error, Result};
#[cfg(feature = "embed")]
pub use gpu::{ToneMapper, ToneMapperError, ToneMapperSettings};
