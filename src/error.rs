//! The crate's top-level error: each module keeps its own enum, this one joins
//! them, so a command can fail with any of them and the binary still knows
//! which (it picks the exit code from the variant).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing an image file failed or was refused by the validation policy.
    #[error(transparent)]
    HdrIo(#[from] crate::io::HdrIoError),
    /// Comparing two images failed (sizes or channel counts differ).
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    /// Any other file-system failure, with the path it concerned.
    #[error("{path}: {source}")]
    File {
        path: PathBuf,
        source: std::io::Error,
    },
    /// No usable adapter, or the GPU failed.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// A renderer met a plan it cannot execute (a tonegate bug).
    #[error(transparent)]
    Plan(#[from] crate::plan::PlanError),
    /// A scene or suite file is unreadable or invalid.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// A scene could not be rendered (its environment, the GPU, the reference).
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// The goldens could not be read or written.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Golden(#[from] crate::golden::GoldenError),
    /// The history database could not be opened, read or written.
    #[cfg(feature = "history")]
    #[error(transparent)]
    History(#[from] crate::history::HistoryError),
    /// A trade-off sweep could not measure a configuration.
    #[cfg(all(feature = "gpu", feature = "history"))]
    #[error(transparent)]
    Tradeoff(#[from] crate::tradeoff::TradeoffError),
    /// A report could not be written as JSON.
    #[error("writing {what} as JSON: {source}")]
    Json {
        what: &'static str,
        source: serde_json::Error,
    },
    /// The JUnit report could not be written.
    #[cfg(feature = "history")]
    #[error("writing JUnit XML: {0}")]
    Junit(#[from] quick_junit::SerializeError),
    /// A submission of frames could not be read or stored.
    #[cfg(feature = "history")]
    #[error(transparent)]
    Frames(#[from] crate::frames::FramesError),
    /// The server could not start, or stopped serving.
    #[error("{what}: {source}")]
    Service {
        what: String,
        source: std::io::Error,
    },
    /// A command-line argument or parameter that cannot be used.
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
