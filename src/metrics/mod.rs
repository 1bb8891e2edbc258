//! Full-reference image metrics (SPEC §6).

#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    #[error("not implemented yet")]
    Placeholder,
}
