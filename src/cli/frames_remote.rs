//! `frames submit --server URL`: the same folder, keys, rules and
//! idempotency key sent to a `tonegate serve` as a multipart form
//! (`POST /api/v1/frames/submissions`, docs/api.md#frames) under the
//! submit token; the server's report is written as a local one would be.

use std::path::PathBuf;
use tonegate::error::{Error, Result};
use tonegate::frames::{Input, Source, SubmissionReport, MAX_FILE_BYTES};

fn file_error(path: &std::path::Path, source: std::io::Error) -> Error {
    Error::File {
        path: path.to_owned(),
        source,
    }
}

/// What `frames submit` was given, besides the folder's files.
pub struct Remote<'a> {
    pub server: &'a str,
    pub token_file: Option<&'a std::path::Path>,
    pub keys: &'a [String],
    pub rules: Option<&'a PathBuf>,
    pub idempotency_key: Option<&'a str>,
}

pub fn submit(a: Remote, inputs: Vec<Input>) -> Result<SubmissionReport> {
    let server = a.server;
    if !(server.starts_with("http://") || server.starts_with("https://")) {
        return Err(Error::Invalid(format!(
            "--server {server:?}: an http:// or https:// address"
        )));
    }
    let token_file = a
        .token_file
        .ok_or_else(|| Error::Invalid("--server needs --token-file (the submit token)".into()))?;
    let token = tonegate::io::read_small_text(token_file)
        .map_err(|e| file_error(token_file, e))?
        .trim()
        .to_owned();
    let mut form = webhook_http::multipart::Form::new();
    for input in inputs {
        let Source::Path(path) = &input.source else {
            continue;
        };
        let size = std::fs::metadata(path)
            .map_err(|e| file_error(path, e))?
            .len();
        if size > MAX_FILE_BYTES {
            return Err(tonegate::frames::FramesError::TooBig {
                file: input.file,
                bytes: size,
                max: MAX_FILE_BYTES,
            }
            .into());
        }
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(
            &mut tonegate::io::open_regular(path).map_err(|e| file_error(path, e))?,
            &mut bytes,
        )
        .map_err(|e| file_error(path, e))?;
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("png");
        let name = format!("{}.{ext}", input.test);
        form = form.part(
            "file",
            webhook_http::multipart::Part::bytes(bytes).file_name(name),
        );
    }
    for k in a.keys {
        form = form.text("key", k.clone());
    }
    if let Some(rules) = a.rules {
        let text = tonegate::io::read_small_text(rules).map_err(|e| file_error(rules, e))?;
        form = form.text("rules", text);
    }
    let url = format!("{}/api/v1/frames/submissions", server.trim_end_matches('/'));
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|source| Error::Service {
            what: "starting the async runtime".into(),
            source,
        })?;
    let (status, text) = rt.block_on(async {
        let mut req = webhook_http::Client::new()
            .post(&url)
            .bearer_auth(&token)
            .multipart(form);
        if let Some(k) = a.idempotency_key {
            req = req.header("Idempotency-Key", k);
        }
        let r = req
            .send()
            .await
            .map_err(|e| Error::Invalid(format!("{url}: {e}")))?;
        let status = r.status();
        let text = r
            .text()
            .await
            .map_err(|e| Error::Invalid(format!("{url}: reading the answer: {e}")))?;
        Ok::<_, Error>((status, text))
    })?;
    if !status.is_success() {
        let detail = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v["detail"].as_str().map(str::to_owned))
            .unwrap_or(text);
        return Err(Error::Invalid(format!("{url} answered {status}: {detail}")));
    }
    serde_json::from_str(&text)
        .map_err(|e| Error::Invalid(format!("{url}: the report does not read: {e}")))
}
