//! Who may do what: the server's bearer token for everything that changes
//! state, a submit token for submitting frames and a triage token for
//! triaging them (each besides the server's), and any of them for reads
//! under `--private-reads`.

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

/// What a token may do. The server's own token (`--token-file`) may do
/// everything; the scoped tokens one thing each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scope {
    /// Start runs and the rest of what only the server's token may do.
    Write,
    /// Submit frames (`--submit-token-file`): what a CI job holds.
    Submit,
    /// Triage digests, promote branches, add ignore rules
    /// (`--triage-token-file`): what the people who look at images hold.
    Triage,
}

impl Scope {
    fn what(self) -> &'static str {
        match self {
            Scope::Write => "the server's token (serve --token-file)",
            Scope::Submit => "the submit token (serve --submit-token-file) or the server's",
            Scope::Triage => "the triage token (serve --triage-token-file) or the server's",
        }
    }
}

/// The tokens that scopes other than `Write` may use.
#[derive(Clone, Debug, Default)]
pub struct ScopedTokens {
    pub submit: Option<String>,
    pub triage: Option<String>,
}

impl AppState {
    /// The scope of the request's token: 401 without one, 403 for one
    /// that is none of this server's.
    fn token_scope(&self, headers: &HeaderMap, wanted: Scope) -> Result<Scope, ApiError> {
        let given = headers
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(bearer_token);
        let Some(given) = given.map(|t| t.trim().as_bytes()) else {
            return Err(ApiError::new(
                StatusCode::UNAUTHORIZED,
                "unauthorized",
                format!(
                    "this needs a bearer token, Authorization: Bearer <token>: {}",
                    wanted.what()
                ),
            ));
        };
        // Every token is compared, whichever matches, so the time taken
        // does not say which one was close.
        let admin = same_secret(given, self.token.as_bytes());
        let submit = self
            .scoped
            .submit
            .as_ref()
            .is_some_and(|t| same_secret(given, t.as_bytes()));
        let triage = self
            .scoped
            .triage
            .as_ref()
            .is_some_and(|t| same_secret(given, t.as_bytes()));
        match (admin, submit, triage) {
            (true, _, _) => Ok(Scope::Write),
            (_, true, _) => Ok(Scope::Submit),
            (_, _, true) => Ok(Scope::Triage),
            _ => Err(ApiError::new(
                StatusCode::FORBIDDEN,
                "forbidden",
                "the bearer token is not this server's",
            )),
        }
    }

    /// Lets the request through when its token may do `scope`.
    pub fn authorize(&self, headers: &HeaderMap, scope: Scope) -> Result<(), ApiError> {
        let has = self.token_scope(headers, scope)?;
        if has == Scope::Write || has == scope {
            return Ok(());
        }
        Err(ApiError::new(
            StatusCode::FORBIDDEN,
            "forbidden",
            format!(
                "this token may only {}; this needs {}",
                match has {
                    Scope::Submit => "submit frames",
                    _ => "triage",
                },
                scope.what()
            ),
        ))
    }

    pub fn authorize_write(&self, headers: &HeaderMap) -> Result<(), ApiError> {
        self.authorize(headers, Scope::Write)
    }

    /// The scope of the request's token when it carries one of the
    /// server's, else None (anonymous, or a wrong token).
    pub fn token_of(&self, headers: &HeaderMap) -> Option<Scope> {
        headers.get(header::AUTHORIZATION)?;
        self.token_scope(headers, Scope::Write).ok()
    }

    /// Whether the request may see results: always, unless reads are private
    /// and it carries no valid token.
    pub fn may_read(&self, headers: &HeaderMap) -> bool {
        self.authorize_read(headers).is_ok()
    }

    /// Reads are open, or under `--private-reads` need any of the
    /// server's tokens.
    pub fn authorize_read(&self, headers: &HeaderMap) -> Result<(), ApiError> {
        if self.private_reads {
            self.token_scope(headers, Scope::Write).map(|_| ())
        } else {
            Ok(())
        }
    }
}

/// The shortest token a token file may hold: a guessable one is no lock.
pub const MIN_TOKEN_CHARS: usize = 16;

/// Reads the token from `path` (at least [`MIN_TOKEN_CHARS`] characters),
/// or makes one there (mode 0600) when the file does not exist; the token
/// is 32 random bytes in hex.
pub fn load_or_make_token(path: &std::path::Path) -> Result<String, crate::Error> {
    let err = |e: std::io::Error| crate::Error::File {
        path: path.to_owned(),
        source: e,
    };
    match crate::io::read_small_text(path) {
        Ok(s) if s.trim().chars().count() >= MIN_TOKEN_CHARS => return Ok(s.trim().to_owned()),
        Ok(s) if !s.trim().is_empty() => {
            return Err(crate::Error::Invalid(format!(
                "{}: the token is {} characters; a token is at least {MIN_TOKEN_CHARS} (delete the file and serve makes a random one)",
                path.display(),
                s.trim().chars().count()
            )))
        }
        Ok(_) => {
            return Err(crate::Error::Invalid(format!(
                "{}: the token file is empty",
                path.display()
            )))
        }
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(err(e)),
        Err(_) => {}
    }
    let mut bytes = [0u8; 32];
    use std::io::Read;
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| crate::Error::Invalid(format!("reading /dev/urandom for a token: {e}")))?;
    let token = hex::encode(bytes);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(err)?;
    }
    use std::io::Write;
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    // Readable by its owner only, where the platform has modes.
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut f = options.open(path).map_err(err)?;
    writeln!(f, "{token}").map_err(err)?;
    Ok(token)
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
