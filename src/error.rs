//! The crate's top-level error: each module keeps its own enum, this one joins them.

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
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// A command-line argument or parameter that cannot be used.
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
