//! What the fuzz targets (`fuzz/`) run, and what the test replaying their
//! regression inputs runs: each entry calls the function the product calls
//! on that input, with the product's limits, and panics when something that
//! must hold does not (an error that does not name the input, an image over
//! the pixel limit, a non-finite pixel past the policy, an error detail that
//! quotes a client without bound). Allocation is bounded by libFuzzer's
//! `-malloc_limit_mb` (`ci/fuzz.sh`).
#![doc(hidden)]

mod exr;

use crate::io::{HdrIoError, LoadOptions};
use std::path::{Path, PathBuf};

/// The name inputs go by in errors.
pub const NAME: &str = "fuzz-input";

/// The server's pixel limit: the one a hostile upload meets.
fn max_pixels() -> u64 {
    crate::request::MAX_UPLOAD_PIXELS
}

fn names_the_input(message: &str) {
    assert!(
        message.starts_with(&format!("{NAME}: ")),
        "the error does not name the input: {message}"
    );
    assert!(
        message.len() < 4096,
        "an error of {} bytes: {}",
        message.len(),
        &message[..200]
    );
}

fn image_error(e: &HdrIoError) {
    assert!(
        !matches!(e, HdrIoError::DecoderPanic { .. }),
        "a decoder panicked (caught): {e}"
    );
    names_the_input(&e.to_string());
}

/// An uploaded or loaded HDR file (OpenEXR, Radiance, PFM: the format is
/// sniffed as the product does), without and with `sanitize`.
pub fn hdr(data: &[u8]) {
    for sanitize in [false, true] {
        let opts = LoadOptions {
            sanitize,
            max_pixels: max_pixels(),
            device: None,
        };
        match crate::io::decode_hdr(data, NAME, &opts) {
            Ok((img, _)) => {
                let n = u64::from(img.width) * u64::from(img.height);
                assert!(
                    n >= 1 && n <= opts.max_pixels,
                    "{}×{}",
                    img.width,
                    img.height
                );
                assert_eq!(img.pixels.len() as u64, n);
                assert!(
                    img.pixels
                        .iter()
                        .flatten()
                        .all(|v| v.is_finite() && *v >= 0.0),
                    "a pixel past the load policy (non-finite or negative)"
                );
            }
            Err(e) => image_error(&e),
        }
    }
}

/// A PNG as `compare` reads it, and as a submitted frame is read (8-bit,
/// or 16-bit with a cICP chunk saying PQ).
pub fn png(data: &[u8]) {
    match crate::io::decode_png8(data, NAME) {
        Ok(img) => {
            let n = u64::from(img.width) * u64::from(img.height);
            assert!((1..=crate::io::DEFAULT_MAX_PIXELS).contains(&n));
            assert_eq!(img.pixels.len() as u64, n);
        }
        Err(e) => image_error(&e),
    }
    match crate::io::decode_frame_png(data, NAME) {
        Ok(frame) => {
            let (w, h, len) = match &frame {
                crate::image::Frame::Rgb8(i) => (i.width, i.height, i.pixels.len()),
                crate::image::Frame::Pq16(i) => (i.width, i.height, i.pixels.len()),
            };
            let n = u64::from(w) * u64::from(h);
            assert!((1..=crate::io::DEFAULT_MAX_PIXELS).contains(&n));
            assert_eq!(len as u64, n);
        }
        Err(e) => image_error(&e),
    }
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// A scene file's text, and the plan `tonegate plan` would build from it.
pub fn scene(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = golden_dir().join("scenes/fuzz.toml");
    match crate::scene::Scene::parse(text, &path) {
        Ok(scene) => {
            let _ = scene.hash();
            let _ = scene.judging();
            let _ = crate::plan::StagePlan::for_scene(&scene, 1);
        }
        Err(e) => {
            let m = e.to_string();
            assert!(m.starts_with(&path.display().to_string()), "{m}");
        }
    }
}

/// A suite file's text; the scenes it lists are loaded from `golden/`.
pub fn suite(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = golden_dir().join("fuzz-suite.toml");
    if let Err(e) = crate::suite::parse_suite(text, &path) {
        // The error names the suite, or the scene file it could not use.
        assert!(e.to_string().starts_with('/'), "{e}");
    }
}

fn api_error(e: &crate::request::ApiError) {
    assert!(
        e.detail.chars().count() <= crate::request::error::MAX_DETAIL + 1,
        "a detail of {} characters",
        e.detail.chars().count()
    );
    assert!(
        e.status.is_client_error(),
        "{} for a client's mistake: {}",
        e.status,
        e.detail
    );
}

/// `POST /tonemap`'s parameters: the first line is the query string, the
/// rest are form fields (`name=value` per line), as a multipart form adds
/// them; then the settings are resolved as before a job is queued.
pub fn tonemap_params(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let (query, form) = text.split_once('\n').unwrap_or((&text, ""));
    let mut pairs = match crate::request::params::query_pairs(Some(query)) {
        Ok(p) => p,
        Err(e) => return api_error(&e),
    };
    pairs.extend(form.lines().map(|l| {
        let (k, v) = l.split_once('=').unwrap_or((l, ""));
        (k.to_owned(), v.to_owned())
    }));
    let headers = http::HeaderMap::new();
    match crate::request::tonemap::parse_params(pairs, &headers) {
        Ok((_, settings)) => {
            if let Err(e) = settings.resolve() {
                api_error(&crate::request::ApiError::of_crate(&e));
            }
        }
        Err(e) => api_error(&e),
    }
}

/// The boundary multipart inputs use.
pub const BOUNDARY: &str = "fuzzboundary";

/// A multipart `POST /tonemap` body (boundary [`BOUNDARY`]), read as the
/// handler reads it: its file field, and its text fields as parameters.
pub fn multipart(data: &[u8]) {
    let body = futures_util::stream::iter([Ok::<_, crate::request::tonemap::BodyError>(
        bytes::Bytes::copy_from_slice(data),
    )]);
    let content_type = format!("multipart/form-data; boundary={BOUNDARY}");
    let mut pairs = Vec::new();
    let read = crate::request::tonemap::read_multipart(
        body,
        &content_type,
        &mut pairs,
        crate::request::MAX_UPLOAD_PIXELS,
    );
    match pollster::block_on(read) {
        Ok(file) => {
            assert!(file.len() <= data.len());
            let headers = http::HeaderMap::new();
            if let Err(e) = crate::request::tonemap::parse_params(pairs, &headers) {
                api_error(&e);
            }
        }
        Err(e) => api_error(&e),
    }
}

/// A `POST /runs` body.
pub fn runs_json(data: &[u8]) {
    if let Err(e) = crate::request::runs::own_run(data) {
        api_error(&e);
    }
}

/// Structure-aware OpenEXR: the input chooses header values (sane ones
/// mostly, hostile ones sometimes) and block contents, and a file is built
/// around them, so the decoder's checks past the magic and the header's
/// syntax are reached on most inputs.
pub fn exr_structured(data: &[u8]) {
    hdr(&exr_structured_file(data));
}

/// The OpenEXR file `exr_structured` builds from `data`: to keep what it
/// found as a plain file, and to look at it with other readers.
pub fn exr_structured_file(data: &[u8]) -> Vec<u8> {
    exr::build(data)
}

/// What a fuzz target runs on one input.
pub type Entry = fn(&[u8]);

/// Every target by name, for the replay test and `ci/fuzz.sh`.
pub const TARGETS: &[(&str, Entry)] = &[
    ("exr", hdr),
    ("exr_structured", exr_structured),
    ("radiance", hdr),
    ("pfm", hdr),
    ("png", png),
    ("scene_toml", scene),
    ("suite_toml", suite),
    ("tonemap_params", tonemap_params),
    ("multipart", multipart),
    ("runs_json", runs_json),
];
