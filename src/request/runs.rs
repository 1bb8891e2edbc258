//! `POST /runs`' body without the server: what a run may ask for, checked.

use super::error::ApiError;
use serde::Deserialize;

/// What `POST /runs` may ask for.
#[derive(Deserialize, Default)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct RunRequest {
    /// gpu (default) or cpu (the reference itself, to check the gate).
    pub renderer: Option<String>,
    /// Samples per pixel (default: each scene's goldens' spp). Not with a
    /// fleet's queue: its runners render at the scenes' defaults.
    pub spp: Option<u32>,
    /// With a shared (PostgreSQL) history: only a runner whose adapter name
    /// contains this (case-insensitive) takes the run.
    pub adapter: Option<String>,
    /// With a shared history: only a runner with this label takes the run.
    pub label: Option<String>,
    /// With a shared history: only these scenes of the suite.
    pub scenes: Option<Vec<String>>,
}

/// A `POST /runs` body as JSON; an empty (or blank) body asks for the defaults.
pub fn parse_run_request(body: &[u8]) -> Result<RunRequest, ApiError> {
    if body.iter().all(|b| b.is_ascii_whitespace()) {
        Ok(RunRequest::default())
    } else {
        let req: RunRequest =
            serde_json::from_slice(body).map_err(|e| ApiError::bad(format!("body: {e}")))?;
        if req.scenes.as_ref().is_some_and(Vec::is_empty) {
            return Err(ApiError::bad(
                "scenes: an empty list selects no scene; leave scenes out to run the whole suite",
            ));
        }
        Ok(req)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_scene_list_is_refused_not_read_as_the_whole_suite() {
        let e = parse_run_request(br#"{"scenes": []}"#)
            .err()
            .expect("refused");
        assert!(
            e.detail.starts_with("scenes: an empty list"),
            "{}",
            e.detail
        );
        let r = parse_run_request(br#"{"scenes": ["grid-static"]}"#).unwrap();
        assert_eq!(r.scenes, Some(vec!["grid-static".to_owned()]));
        assert!(parse_run_request(b"").unwrap().scenes.is_none());
    }
}

/// A run of a server's own (SQLite) history, as its body asks for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OwnRun {
    /// The CPU reference rather than the server's GPU.
    pub cpu: bool,
    /// Samples per pixel; `None` is each scene's goldens' own.
    pub spp: Option<u32>,
}

/// What a `POST /runs` body asks of a server whose runs are its own,
/// checked: empty means the defaults.
pub fn own_run(body: &[u8]) -> Result<OwnRun, ApiError> {
    let req = parse_run_request(body)?;
    if req.adapter.is_some() || req.label.is_some() || req.scenes.is_some() {
        return Err(ApiError::bad(
            "adapter, label and scenes select a fleet's runner; this server's history is a SQLite file, so its runs are its own (serve --db postgres://... queues them)",
        ));
    }
    let spp = match req.spp {
        None => None,
        Some(n @ 1..=256) => Some(n),
        Some(n) => return Err(ApiError::bad(format!("spp: must be 1 to 256, got {n}"))),
    };
    let cpu = super::params::renderer_is_cpu(req.renderer.as_deref())?;
    Ok(OwnRun { cpu, spp })
}
