//! Who may do what: the bearer token for everything that changes state,
//! and for reads too under `--private-reads`.

use super::error::ApiError;
use super::AppState;
use axum::http::{header, HeaderMap, StatusCode};

/// The token of an `Authorization: Bearer <token>` value. The scheme is
/// case-insensitive and separated from the token by spaces or tabs (RFC 7235).
fn bearer_token(value: &str) -> Option<&str> {
    let value = value.trim_matches([' ', '\t']);
    let (scheme, token) = value.split_once([' ', '\t'])?;
    scheme
        .eq_ignore_ascii_case("bearer")
        .then(|| token.trim_matches([' ', '\t']))
        .filter(|t| !t.is_empty())
}

/// Compares in time independent of where the strings differ.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

impl AppState {
    pub fn authorize_write(&self, headers: &HeaderMap) -> Result<(), ApiError> {
        let given = headers
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(bearer_token);
        match given {
            None => Err(ApiError::new(
                StatusCode::UNAUTHORIZED,
                "unauthorized",
                "this needs the bearer token: Authorization: Bearer <token> (serve --token-file)",
            )),
            Some(t) if same_secret(t.trim().as_bytes(), self.token.as_bytes()) => Ok(()),
            Some(_) => Err(ApiError::new(
                StatusCode::FORBIDDEN,
                "forbidden",
                "the bearer token is not this server's",
            )),
        }
    }

    /// Whether the request may see results: always, unless reads are private
    /// and it carries no valid token.
    pub fn may_read(&self, headers: &HeaderMap) -> bool {
        self.authorize_read(headers).is_ok()
    }

    pub fn authorize_read(&self, headers: &HeaderMap) -> Result<(), ApiError> {
        if self.private_reads {
            self.authorize_write(headers)
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bearer_scheme_is_case_insensitive_and_spaces_or_tabs_separate() {
        for v in [
            "Bearer abc",
            "bearer abc",
            "BEARER abc",
            "Bearer\tabc",
            "Bearer   abc ",
            " bEaReR abc",
        ] {
            assert_eq!(bearer_token(v), Some("abc"), "{v:?}");
        }
        for v in ["Basic abc", "Bearer", "Bearer ", "Bearerabc", "abc"] {
            assert_eq!(bearer_token(v), None, "{v:?}");
        }
    }
}
