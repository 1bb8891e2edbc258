//! HDR and LDR image files: reading with a validation policy, writing.

#[derive(Debug, thiserror::Error)]
pub enum HdrIoError {
    #[error("not implemented yet")]
    Placeholder,
}
