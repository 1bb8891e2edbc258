//! What every endpoint parses the same way, without a server: urlencoded
//! parameters (unknown or bad ones refused by name), parameter names, the
//! renderer.

use super::error::{clip, ApiError};
use serde::de::DeserializeOwned;

/// Deserialises urlencoded pairs; a bad value's error names its parameter.
pub fn from_pairs<T: DeserializeOwned>(encoded: &[u8]) -> Result<T, ApiError> {
    check_names(form_urlencoded::parse(encoded).map(|(k, _)| k))?;
    let de = serde_urlencoded::Deserializer::new(form_urlencoded::parse(encoded));
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        if path == "." || path.is_empty() {
            ApiError::bad(format!("query: {}", e.inner()))
        } else {
            ApiError::bad(format!("{path}: {}", e.inner()))
        }
    })
}

/// The longest parameter name anyone means: longer ones are refused without
/// being echoed back whole.
pub const MAX_NAME: usize = 64;

/// Refuses parameter names longer than [`MAX_NAME`].
pub fn check_names<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> Result<(), ApiError> {
    for name in names {
        let name = name.as_ref();
        if name.chars().count() > MAX_NAME {
            return Err(ApiError::bad(format!(
                "a parameter name of {}; names are at most {MAX_NAME} characters",
                clip(name)
            )));
        }
    }
    Ok(())
}

/// A `renderer` parameter: gpu (the default) or cpu, as whether it is the CPU.
pub fn renderer_is_cpu(given: Option<&str>) -> Result<bool, ApiError> {
    match given {
        None | Some("gpu") => Ok(false),
        Some("cpu") => Ok(true),
        Some(other) => Err(ApiError::bad(format!(
            "renderer: expected gpu or cpu, got {}",
            clip(other)
        ))),
    }
}

/// A query string's pairs, in order, as given.
pub fn query_pairs(q: Option<&str>) -> Result<Vec<(String, String)>, ApiError> {
    serde_urlencoded::from_str(q.unwrap_or("")).map_err(|e| ApiError::bad(format!("query: {e}")))
}
