//! `POST /tonemap`'s request without the server: its parameters (the
//! renderer choice, the answer's format and the tone settings) and its
//! multipart body, read with multer, the parser axum's own extractor uses.

use super::error::ApiError;
use crate::toning::ToneSettings;
use bytes::Bytes;
use futures_util::Stream;
use http::{header, HeaderMap, StatusCode};

/// The parameters `POST /tonemap` takes besides the tone settings.
#[derive(Debug)]
pub struct Extra {
    /// Render on the GPU (the default) rather than with the CPU reference.
    pub gpu: bool,
    /// Answer JSON with the PNG inline rather than the PNG.
    pub json: bool,
    /// Set NaN/Inf to 0 instead of refusing the file.
    pub sanitize: bool,
}

/// Splits the request's parameters into the renderer choice and the tone
/// settings; unknown names and bad values are refused with their name.
pub fn parse_params(
    pairs: Vec<(String, String)>,
    headers: &HeaderMap,
) -> Result<(Extra, ToneSettings), ApiError> {
    super::params::check_names(pairs.iter().map(|(k, _)| k))?;
    let mut extra = Extra {
        gpu: true,
        json: headers
            .get(header::ACCEPT)
            .and_then(|v| v.to_str().ok())
            .is_some_and(|v| v.contains("application/json")),
        sanitize: false,
    };
    let flag = |name: &str, v: &str| match v {
        "true" | "1" | "yes" | "" => Ok(true),
        "false" | "0" | "no" => Ok(false),
        other => Err(ApiError::bad(format!(
            "{name}: expected true or false, got {}",
            super::error::clip(other)
        ))),
    };
    let mut seen = std::collections::BTreeSet::new();
    let mut rest = Vec::new();
    // The operator's parameters, from the operators' definitions.
    let mut operator_params = crate::toning::OperatorParams::default();
    for (k, v) in pairs {
        if !seen.insert(k.clone()) {
            return Err(ApiError::bad(format!(
                "parameter {} is given twice",
                super::error::clip(&k)
            )));
        }
        match k.as_str() {
            "gpu" => extra.gpu = flag("gpu", &v)?,
            "sanitize" => extra.sanitize = flag("sanitize", &v)?,
            "format" => {
                extra.json = match v.as_str() {
                    "json" => true,
                    "png" => false,
                    other => {
                        return Err(ApiError::bad(format!(
                            "format: expected png or json, got {}",
                            super::error::clip(other)
                        )))
                    }
                }
            }
            name if crate::toning::OperatorParams::takes(name) => operator_params.set(name, v),
            _ => rest.push((k, v)),
        }
    }
    let settings_names = settings_names();
    if let Some((k, _)) = rest.iter().find(|(k, _)| !settings_names.contains(k)) {
        let mut known: Vec<String> = settings_names.to_vec();
        known.extend(["gpu", "sanitize", "format"].map(String::from));
        known.extend(
            crate::operators::all_params()
                .iter()
                .map(|(p, _)| p.name.to_owned()),
        );
        known.sort();
        known.dedup();
        return Err(ApiError::bad(format!(
            "{}: unknown parameter; expected one of {}",
            super::error::clip(k),
            known.join(", ")
        )));
    }
    let encoded = serde_urlencoded::to_string(&rest).map_err(|e| ApiError::bad(e.to_string()))?;
    let mut settings: ToneSettings = super::params::from_pairs(encoded.as_bytes())?;
    settings.params = operator_params;
    Ok((extra, settings))
}

/// The names [`ToneSettings`] itself takes, read from what it serialises
/// (so a new setting needs no list kept by hand); the operator's
/// parameters are a separate map.
fn settings_names() -> &'static [String] {
    static NAMES: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    NAMES.get_or_init(|| match serde_json::to_value(ToneSettings::default()) {
        Ok(serde_json::Value::Object(m)) => m.keys().cloned().collect(),
        _ => Vec::new(),
    })
}

/// Why a body's stream stopped short, as the server saw it.
#[derive(Debug)]
pub enum BodyError {
    /// Over the server's body limit.
    TooLarge,
    /// The connection failed, or the client stopped sending.
    Read(String),
    /// The server is receiving as many bytes as it may (the detail says so).
    Busy(String),
}

impl std::fmt::Display for BodyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BodyError::TooLarge => f.write_str("Request payload is too large"),
            BodyError::Read(e) => write!(f, "reading the body: {e}"),
            BodyError::Busy(e) => f.write_str(e),
        }
    }
}

impl std::error::Error for BodyError {}

/// The file field of a multipart body (`content_type` names its boundary);
/// its text fields join the parameters. One file a request; an image whose
/// header states more than `max_pixels` is refused as soon as it does.
pub async fn read_multipart<S>(
    body: S,
    content_type: &str,
    pairs: &mut Vec<(String, String)>,
    max_pixels: u64,
) -> Result<Bytes, ApiError>
where
    S: Stream<Item = Result<Bytes, BodyError>> + Send + 'static,
{
    let boundary = multer::parse_boundary(content_type).map_err(|_| {
        ApiError::bad("multipart: Invalid `boundary` for `multipart/form-data` request")
    })?;
    let mut mp = multer::Multipart::new(body, boundary);
    let mut file = None;
    while let Some(field) = mp.next_field().await.map_err(|e| multipart_error(&e))? {
        let name = field.name().unwrap_or("").to_owned();
        // The image is the part named `file`; a file sent under another
        // name is refused rather than taken for it (or for a parameter).
        if field.file_name().is_some() && name != "file" {
            return Err(ApiError::bad(format!(
                "multipart: a file in the part named {}; the image goes in the part named \"file\"",
                super::error::clip(&name)
            )));
        }
        if name == "file" {
            if file.is_some() {
                return Err(ApiError::bad(
                    "multipart: more than one file; send one image per request",
                ));
            }
            let mut check = super::head::HeadCheck::new(max_pixels);
            let mut got = bytes::BytesMut::new();
            let mut field = field;
            while let Some(chunk) = field.chunk().await.map_err(|e| multipart_error(&e))? {
                check.feed(&chunk)?;
                got.extend_from_slice(&chunk);
            }
            file = Some(got.freeze());
        } else {
            let v = field.text().await.map_err(|e| multipart_error(&e))?;
            pairs.push((name, v));
        }
    }
    file.ok_or_else(|| ApiError::bad("multipart: no file field (name it \"file\")"))
}

/// A body over the limit is 413, as the server answers a raw body over it;
/// anything else wrong with the form is the client's, 400.
pub fn multipart_error(e: &multer::Error) -> ApiError {
    if let multer::Error::StreamReadFailed(inner) = e {
        if let Some(BodyError::Busy(detail)) = inner.downcast_ref::<BodyError>() {
            return ApiError::unavailable("busy", detail.clone(), 1);
        }
    }
    let too_large = match e {
        multer::Error::FieldSizeExceeded { .. } | multer::Error::StreamSizeExceeded { .. } => true,
        multer::Error::StreamReadFailed(inner) => {
            matches!(inner.downcast_ref::<BodyError>(), Some(BodyError::TooLarge))
        }
        _ => false,
    };
    if too_large {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
            "Request payload is too large",
        )
    } else {
        ApiError::bad(format!("multipart: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(pairs: &[(&str, &str)]) -> Result<(Extra, ToneSettings), ApiError> {
        let pairs = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        parse_params(pairs, &HeaderMap::new())
    }

    #[test]
    fn an_unknown_parameter_lists_every_name_that_is_taken() {
        let e = parse(&[("kee", "0.2")]).unwrap_err();
        let text = e.detail;
        assert!(text.starts_with("\"kee\": unknown parameter"), "{text}");
        // The whole list fits in an answer's detail, uncut.
        assert!(!text.ends_with('…'), "{text}");
        assert!(
            text.chars().count() <= super::super::error::MAX_DETAIL,
            "{text}"
        );
        for name in [
            "gpu",
            "sanitize",
            "format",
            "exposure",
            "white_fraction",
            "bloom",
            "preset",
        ] {
            assert!(text.contains(name), "{name} missing from {text}");
        }
        // Every name the list gives is taken.
        for name in [
            "gpu",
            "sanitize",
            "format",
            "bloom",
            "display",
            "white_fraction",
        ] {
            let v = match name {
                "format" => "json",
                "display" => "sdr",
                "gpu" | "sanitize" => "true",
                "white_fraction" => "0.5",
                _ => "0",
            };
            assert!(parse(&[(name, v)]).is_ok(), "{name}");
        }
    }

    fn multipart(parts: &[(&str, Option<&str>, &str)]) -> (String, Vec<Result<Bytes, BodyError>>) {
        let mut body = String::new();
        for (name, file, value) in parts {
            body.push_str("--XyZ\r\n");
            match file {
                Some(f) => body.push_str(&format!(
                    "Content-Disposition: form-data; name=\"{name}\"; filename=\"{f}\"\r\n\r\n"
                )),
                None => body.push_str(&format!(
                    "Content-Disposition: form-data; name=\"{name}\"\r\n\r\n"
                )),
            }
            body.push_str(value);
            body.push_str("\r\n");
        }
        body.push_str("--XyZ--\r\n");
        (
            "multipart/form-data; boundary=XyZ".into(),
            vec![Ok(Bytes::from(body))],
        )
    }

    #[test]
    fn only_the_part_named_file_is_the_image() {
        let read = |parts: &[(&str, Option<&str>, &str)]| {
            let (ct, chunks) = multipart(parts);
            let mut pairs = Vec::new();
            let r = pollster::block_on(read_multipart(
                futures_util::stream::iter(chunks),
                &ct,
                &mut pairs,
                crate::request::MAX_UPLOAD_PIXELS,
            ));
            (r, pairs)
        };
        let (r, pairs) = read(&[("operator", None, "agx"), ("file", Some("a.hdr"), "IMAGE")]);
        assert_eq!(r.unwrap(), Bytes::from("IMAGE"));
        assert_eq!(pairs, vec![("operator".to_owned(), "agx".to_owned())]);
        let (r, _) = read(&[("upload", Some("a.hdr"), "IMAGE")]);
        let e = r.unwrap_err().detail;
        assert!(
            e.contains("\"upload\"") && e.contains("named \"file\""),
            "{e}"
        );
    }

    #[test]
    fn operator_parameters_are_reported_as_the_values_they_are() {
        let (_, s) = parse(&[("operator", "hable"), ("exposure", "2")]).unwrap();
        let v = serde_json::to_value(s.in_effect()).unwrap();
        assert_eq!(v["exposure"], serde_json::json!(2.0), "{v}");
        let (_, s) = parse(&[("operator", "reinhard-auto-key"), ("key", "auto")]).unwrap();
        let v = serde_json::to_value(s.in_effect()).unwrap();
        assert_eq!(v["key"], "auto", "{v}");
    }
}
