//! Frames a user's own renderer wrote, through the gate (docs/frames.md):
//! a submission is a folder of images, each a frame of the test its name
//! says, with keys (device, backend, branch, commit, …) for the whole
//! submission. Each image is stored once by its digest (the SHA-256 of its
//! file); each frame passes when its digest is a positive of its test, or
//! when it is within its test's rules of one; a negative digest fails, and
//! an untriaged one fails or warns as the rules say. People triage digests
//! (`tonegate frames triage`); every action is logged.

pub mod budget;
pub mod report;
pub mod rules;

mod judge;

use crate::history::{History, HistoryError, NewFrame, MAIN};
use crate::image::{Frame, HdrImage};
use crate::io::{HdrIoError, LoadOptions};
use rayon::prelude::*;
pub use report::{FrameVerdict, Status, SubmissionReport};
use rules::Rules;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The most frames one submission may have: a folder with more is refused
/// before any file is read.
pub const MAX_FRAMES: usize = 4096;

/// The most bytes one submitted file may have, checked before it is read.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// The extensions a submitted image may have.
pub const EXTENSIONS: [&str; 5] = ["png", "exr", "hdr", "pfm", "pic"];

/// Why a submission was refused. Nothing of it is stored.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    #[error("{file}: {detail}")]
    File { file: String, detail: String },
    #[error(transparent)]
    Image(#[from] HdrIoError),
    #[error("{count} files in {folder}: a submission takes at most {max}")]
    TooMany {
        folder: String,
        count: usize,
        max: usize,
    },
    #[error("{file}: {bytes} bytes, over the {max} bytes a submitted image may have")]
    TooBig { file: String, bytes: u64, max: u64 },
    #[error("{first} and {second} are both frames of test {test:?}: one image a test")]
    Duplicate {
        test: String,
        first: String,
        second: String,
    },
    #[error("{folder}: no images (.png, .exr, .hdr, .pfm)")]
    Empty { folder: String },
    #[error("key {0:?}: keys are name=value, the name of letters, digits, '_', '-' and '.'")]
    Key(String),
    /// More keys, or a longer name or value, than a submission may carry.
    #[error("{what}: at most {most}")]
    KeyBounds { what: String, most: usize },
    /// An image whose decoding and comparing alone take more than the
    /// whole memory budget (`budget`).
    #[error("{what} needs {mib} MiB to decode and judge, more than the {budget_mib} MiB the process gives it: send it smaller, or raise --decode-budget-mib (of serve, or of frames submit)")]
    OverBudget {
        what: String,
        mib: u64,
        budget_mib: u64,
    },
    /// The memory budget stayed full for the wait: other submissions hold
    /// it; try again.
    #[error("the frames being judged hold the memory budget: try again in {seconds} s")]
    Busy { seconds: u64 },
    /// An idempotency key used before by a submission of other frames or
    /// keys: a retry must send what the first attempt sent.
    #[error("Idempotency-Key {key:?} was used by submission {submission} with other contents: {difference}; a retry sends what the first attempt sent, and new contents take a new key")]
    KeyReused {
        key: String,
        submission: i64,
        difference: String,
    },
    #[error(transparent)]
    History(#[from] HistoryError),
}

/// A file to submit: the test it is a frame of, what errors and reports
/// call it (its path, or an uploaded part's file name), and its bytes or
/// where they are.
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    pub test: String,
    pub file: String,
    pub source: Source,
}

/// Where a submitted file's bytes are.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A file, read (its size checked first) when the submission is judged.
    Path(PathBuf),
    /// Bytes already received (an upload, its size checked as it came).
    Bytes(Vec<u8>),
}

/// A submitted image decoded: a display frame (8-bit, or 16-bit PQ), or
/// scene-referred light.
pub enum Decoded {
    Frame(Frame),
    Hdr(HdrImage),
}

/// The images in `folder` and its subfolders, each a frame of the test
/// named by its path from `folder` without its extension (`ui/button` for
/// `ui/button.png`), in name order. Files of other extensions are left
/// out; links are not followed.
pub fn collect_folder(folder: &Path) -> Result<Vec<Input>, FramesError> {
    Ok(collect_folder_noting(folder)?.0)
}

/// [`collect_folder`], with the files it left out (not images, or not
/// regular files), by path, so that a command can say so.
pub fn collect_folder_noting(folder: &Path) -> Result<(Vec<Input>, Vec<String>), FramesError> {
    let name = folder.display().to_string();
    let mut skipped = Vec::new();
    let mut found: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut pending = vec![folder.to_path_buf()];
    let mut files = 0usize;
    while let Some(dir) = pending.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|e| FramesError::File {
            file: dir.display().to_string(),
            detail: format!("cannot list it: {e}"),
        })?;
        for entry in entries {
            let entry = entry.map_err(|e| FramesError::File {
                file: dir.display().to_string(),
                detail: format!("cannot list it: {e}"),
            })?;
            let path = entry.path();
            let kind = entry.file_type().map_err(|e| FramesError::File {
                file: path.display().to_string(),
                detail: e.to_string(),
            })?;
            if kind.is_dir() {
                pending.push(path);
                continue;
            }
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase);
            if !kind.is_file() || !ext.is_some_and(|e| EXTENSIONS.contains(&e.as_str())) {
                skipped.push(path.display().to_string());
                continue;
            }
            files += 1;
            if files > MAX_FRAMES {
                return Err(FramesError::TooMany {
                    folder: name,
                    count: files,
                    max: MAX_FRAMES,
                });
            }
            let test = test_name(folder, &path)?;
            if let Some(first) = found.get(&test) {
                let (a, b) = ordered(first, &path);
                return Err(FramesError::Duplicate {
                    test,
                    first: a,
                    second: b,
                });
            }
            found.insert(test, path);
        }
    }
    if found.is_empty() {
        return Err(FramesError::Empty { folder: name });
    }
    skipped.sort();
    let inputs = found
        .into_iter()
        .map(|(test, path)| Input {
            test,
            file: path.display().to_string(),
            source: Source::Path(path),
        })
        .collect();
    Ok((inputs, skipped))
}

fn ordered(a: &Path, b: &Path) -> (String, String) {
    let (a, b) = (a.display().to_string(), b.display().to_string());
    if a <= b {
        (a, b)
    } else {
        (b, a)
    }
}

/// A character that shows nothing or turns the text around it (Unicode's
/// format characters: zero-width ones, the bidirectional controls, the
/// byte-order mark, the soft hyphen): in a test name it can make one test
/// look like another.
fn invisible(c: char) -> bool {
    matches!(c,
        '\u{00AD}' | '\u{061C}' | '\u{180E}' | '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}'
        | '\u{2060}'..='\u{2064}' | '\u{2066}'..='\u{206F}' | '\u{FEFF}' | '\u{FFF9}'..='\u{FFFB}')
}

/// `path`'s test name: its path from `folder`, `/`-separated, without the
/// extension.
fn test_name(folder: &Path, path: &Path) -> Result<String, FramesError> {
    let file = path.display().to_string();
    let relative = path.strip_prefix(folder).unwrap_or(path).with_extension("");
    let mut parts = Vec::new();
    for c in relative.components() {
        match c {
            std::path::Component::Normal(p) => match p.to_str() {
                Some(s) if s.chars().any(|c| c.is_control() || invisible(c)) => {
                    return Err(FramesError::File {
                        file,
                        detail: "a control, invisible or direction-changing character (such as U+202E) in the name, which would show another name on the triage page".into(),
                    })
                }
                Some(s) => parts.push(s.to_owned()),
                None => {
                    return Err(FramesError::File {
                        file,
                        detail: "a name that is not UTF-8 cannot be a test name".into(),
                    })
                }
            },
            _ => {
                return Err(FramesError::File {
                    file,
                    detail: "a test name is a plain path inside the folder".into(),
                })
            }
        }
    }
    Ok(parts.join("/"))
}

/// The most keys a submission carries.
pub const MAX_KEYS: usize = 32;
/// The longest key name, in bytes.
pub const MAX_KEY_NAME: usize = 64;
/// The longest key value, in bytes: keys name a device, a backend, a
/// branch or a commit, and go into every report, alert and listing.
pub const MAX_KEY_VALUE: usize = 256;

/// `name=value` pairs, as `--key` gives them: at most [`MAX_KEYS`], each
/// name at most [`MAX_KEY_NAME`] bytes and each value [`MAX_KEY_VALUE`].
pub fn parse_keys(pairs: &[String]) -> Result<BTreeMap<String, String>, FramesError> {
    if pairs.len() > MAX_KEYS {
        return Err(FramesError::KeyBounds {
            what: format!("{} keys", pairs.len()),
            most: MAX_KEYS,
        });
    }
    let mut keys = BTreeMap::new();
    for pair in pairs {
        let shown = || clip(pair, 48);
        let Some((k, v)) = pair.split_once('=') else {
            return Err(FramesError::Key(shown()));
        };
        if k.len() > MAX_KEY_NAME {
            return Err(FramesError::KeyBounds {
                what: format!("key {}: a name of {} bytes", shown(), k.len()),
                most: MAX_KEY_NAME,
            });
        }
        if v.len() > MAX_KEY_VALUE {
            return Err(FramesError::KeyBounds {
                what: format!("key {k}: a value of {} bytes", v.len()),
                most: MAX_KEY_VALUE,
            });
        }
        let plain = |c: char| c.is_ascii_alphanumeric() || "_-.".contains(c);
        if k.is_empty()
            || !k.chars().all(plain)
            || keys.insert(k.to_owned(), v.to_owned()).is_some()
        {
            return Err(FramesError::Key(shown()));
        }
    }
    Ok(keys)
}

/// `text`'s first `most` characters, and `…` when there were more.
fn clip(text: &str, most: usize) -> String {
    match text.char_indices().nth(most) {
        Some((at, _)) => format!("{}…", &text[..at]),
        None => text.to_owned(),
    }
}

/// One file read (its size checked first) and hashed; decoded unless its
/// digest is already a positive or negative of its test.
struct Read {
    input: Input,
    bytes: Vec<u8>,
    digest: String,
    image: Option<Decoded>,
    /// Its test's digests and their labels on the submission's branch.
    labels: Vec<(String, crate::history::Label)>,
}

fn read(mut input: Input) -> Result<Read, FramesError> {
    let file = input.file.clone();
    let bytes = match std::mem::replace(&mut input.source, Source::Bytes(Vec::new())) {
        Source::Bytes(bytes) => bytes,
        Source::Path(path) => {
            let meta = std::fs::metadata(&path).map_err(|e| FramesError::File {
                file: file.clone(),
                detail: e.to_string(),
            })?;
            if meta.len() > MAX_FILE_BYTES {
                return Err(FramesError::TooBig {
                    file,
                    bytes: meta.len(),
                    max: MAX_FILE_BYTES,
                });
            }
            read_regular(&path).map_err(|e| FramesError::File {
                file: file.clone(),
                detail: e.to_string(),
            })?
        }
    };
    let digest = hex::encode(Sha256::digest(&bytes));
    Ok(Read {
        input,
        bytes,
        digest,
        image: None,
        labels: Vec::new(),
    })
}

/// A test name an uploaded file's name gives (`ui/button.png` is a frame
/// of `ui/button`): `/`-separated plain names, no `.` or `..`, no empty
/// part, no backslash or control character, and an image extension.
pub fn test_of_upload(name: &str) -> Result<String, FramesError> {
    // The name quoted short, so that a long one's reason is not cut off.
    let bad = |detail: &str| FramesError::File {
        file: clip(name, 48),
        detail: detail.to_owned(),
    };
    let (stem, ext) = name
        .rsplit_once('.')
        .filter(|(stem, _)| !stem.is_empty() && !stem.ends_with('/'))
        .ok_or_else(|| bad("no extension: name each image test.png, .exr, .hdr or .pfm"))?;
    if !EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str()) {
        return Err(bad("not an image extension (.png, .exr, .hdr, .pfm)"));
    }
    if name.len() > 512 {
        return Err(bad("a name over 512 bytes"));
    }
    for part in stem.split('/') {
        if part.is_empty() || part == "." || part == ".." {
            return Err(bad(
                "a test name is a plain relative path: no empty part, '.', '..' or leading '/'",
            ));
        }
        if part.chars().any(|c| c == '\\' || c.is_control()) {
            return Err(bad("a backslash or control character in the name"));
        }
        if part.chars().any(invisible) {
            return Err(bad(
                "an invisible or direction-changing character (such as U+202E) in the name, which would show another name on the triage page",
            ));
        }
    }
    Ok(stem.to_owned())
}

/// Decodes a submitted image: a PNG (by its signature or its name) as a frame, 8-bit
/// or 16-bit with a cICP chunk saying BT.2100 PQ; anything else as EXR,
/// Radiance or PFM light (NaN and infinities refused). `file` names it in
/// errors.
pub fn decode_bytes(bytes: &[u8], file: &str) -> Result<Decoded, FramesError> {
    const PNG: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    // A file named .png is read as one, so that a damaged one is reported
    // by the PNG reader, not as "not an HDR image".
    let named_png = file.to_ascii_lowercase().ends_with(".png");
    Ok(if bytes.starts_with(&PNG) || named_png {
        Decoded::Frame(crate::io::decode_frame_png(bytes, file)?)
    } else {
        Decoded::Hdr(crate::io::decode_hdr(bytes, file, &LoadOptions::default())?.0)
    })
}

/// What one submission asks.
pub struct Submission<'a> {
    pub inputs: Vec<Input>,
    pub keys: BTreeMap<String, String>,
    /// A retried submission with the same key stores nothing and answers
    /// what the first did.
    pub idempotency_key: Option<&'a str>,
    pub rules: &'a Rules,
    /// How 8-bit frames are compared with a positive when not on the CPU
    /// (the GPU's metrics, `frames submit --metrics gpu`).
    pub compare: Option<crate::metrics::CompareBy<'a>>,
}

/// Reads, judges and stores a submission. Every file is read and decoded
/// before anything is stored, so a bad file stores nothing; the images,
/// the frames and the report are then stored in one transaction.
pub fn submit(history: &History, s: Submission) -> Result<SubmissionReport, FramesError> {
    let done = s
        .idempotency_key
        .map(|k| history.submission_by_key(k))
        .transpose()?
        .flatten();
    // Files are read and hashed on every core.
    let mut read: Vec<Read> = s
        .inputs
        .into_par_iter()
        .map(read)
        .collect::<Result<_, _>>()?;
    if let (Some(done), Some(key)) = (done, s.idempotency_key) {
        let first = report::stored(&done)?;
        let digests: BTreeMap<&str, &str> = read
            .iter()
            .map(|r| (r.input.test.as_str(), r.digest.as_str()))
            .collect();
        if let Some(difference) = report::difference(&first, &s.keys, &digests) {
            return Err(FramesError::KeyReused {
                key: key.to_owned(),
                submission: done.id,
                difference,
            });
        }
        return Ok(first);
    }
    // The branch's triage, falling back to the main line's.
    let named = s.keys.get("branch").filter(|b| **b != s.rules.main_branch);
    let branch = named.map_or(MAIN, String::as_str).to_owned();
    let shown = named
        .cloned()
        .unwrap_or_else(|| s.rules.main_branch.clone());
    // Every image is decoded before anything is stored, but one whose
    // digest is a positive or negative of its test: those bytes decoded
    // when they were first submitted, and its verdict needs no pixels
    // (the exact matches a CI run is mostly made of: hashed and looked up).
    let mut undecided = Vec::new();
    for (i, r) in read.iter_mut().enumerate() {
        r.labels = history.digest_labels(&branch, &r.input.test)?;
        let said = r
            .labels
            .iter()
            .any(|(d, l)| *d == r.digest && *l != crate::history::Label::Untriaged);
        if !said {
            undecided.push(i);
        }
    }
    let ignores = judge::Ignores::of(history.active_ignore_rules()?, &s.keys);
    let on = judge::On {
        history,
        keys: &s.keys,
        rules: s.rules,
        ignores: &ignores,
        compare: s.compare,
    };
    // The undecided images in groups: each group's memory reserved from
    // the process's budget at once (from the headers), decoded on every
    // core, judged, then dropped before the next group's.
    let costs: Vec<u64> = undecided
        .iter()
        .map(|&i| {
            let r = &read[i];
            let compared = r
                .labels
                .iter()
                .any(|(_, l)| *l == crate::history::Label::Positive);
            budget::cost(&r.bytes, compared).unwrap_or(0)
        })
        .collect();
    let width = rayon::current_num_threads().max(1);
    let mut verdicts: Vec<Option<report::FrameVerdict>> = read.iter().map(|_| None).collect();
    let mut at = 0;
    while at < undecided.len() {
        let mut end = at + 1;
        let mut sum = costs[at];
        while end < undecided.len() && end - at < width && sum + costs[end] <= budget::total() {
            sum += costs[end];
            end += 1;
        }
        let what = match end - at {
            1 => read[undecided[at]].input.file.clone(),
            n => format!("{n} images from {}", read[undecided[at]].input.file),
        };
        let held = budget::reserve(sum, &what)?;
        let group = &undecided[at..end];
        read.par_iter_mut()
            .enumerate()
            .filter(|(i, _)| group.binary_search(i).is_ok())
            .try_for_each(|(_, r)| {
                r.image = Some(decode_bytes(&r.bytes, &r.input.file)?);
                Ok::<(), FramesError>(())
            })?;
        for &i in group {
            let r = &mut read[i];
            verdicts[i] = Some(on.judge(&r.input, (&r.digest, &r.labels), r.image.as_ref())?);
            r.image = None;
        }
        drop(held);
        at = end;
    }
    let mut judged = Vec::with_capacity(read.len());
    for (r, v) in read.iter().zip(verdicts) {
        judged.push(match v {
            Some(v) => v,
            None => on.judge(&r.input, (&r.digest, &r.labels), None)?,
        });
    }
    let verdicts = judged;
    let mut report = SubmissionReport::new(s.keys, shown, verdicts);
    let frames: Vec<NewFrame> = read
        .iter()
        .zip(&report.frames)
        .map(|(r, v)| NewFrame {
            test: &r.input.test,
            sha256: &r.digest,
            bytes: &r.bytes,
            verdict: v.status.as_str(),
        })
        .collect();
    // A retry's first answer stands: nothing is offered to the store for
    // a key already stored.
    let refused = match s.idempotency_key.map(|k| history.submission_by_key(k)) {
        Some(Ok(Some(_))) => Default::default(),
        _ => history.offer_new_images(&frames)?,
    };
    report.pending_images = refused.keys().cloned().collect();
    report.pending_images.sort();
    let keys = serde_json::to_string(&report.keys).unwrap_or_default();
    let text = serde_json::to_string(&report).unwrap_or_default();
    let stored = history.store_submission(&crate::history::NewSubmission {
        key: s.idempotency_key,
        branch: &branch,
        keys: &keys,
        passed: report.passed,
        report: &text,
        frames: &frames,
        refused: &refused,
    })?;
    if !stored.new {
        // Another process stored the same key first: its answer stands.
        return report::stored(&stored);
    }
    report.submission = stored.id;
    Ok(report)
}

/// A file of a submitted folder, read only if it is still a regular file
/// when opened (a FIFO put in its place is refused, not waited on).
fn read_regular(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    crate::io::open_regular(path)?.read_to_end(&mut bytes)?;
    Ok(bytes)
}
