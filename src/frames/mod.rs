//! Frames a user's own renderer wrote, through the gate (docs/frames.md):
//! a submission is a folder of images, each a frame of the test its name
//! says, with keys (device, backend, branch, commit, …) for the whole
//! submission. Each image is stored once by its digest (the SHA-256 of its
//! file); each frame passes when its digest is a positive of its test, or
//! when it is within its test's rules of one; a negative digest fails, and
//! an untriaged one fails or warns as the rules say. People triage digests
//! (`tonegate frames triage`); every action is logged.

pub mod budget;
mod pixels;
pub mod report;
pub mod rules;

mod judge;
mod names;

use crate::history::{History, HistoryError, NewFrame, MAIN};
use crate::image::{Frame, HdrImage};
use crate::io::{HdrIoError, LoadOptions};
use names::read_regular;
pub use names::{
    collect_folder, collect_folder_noting, parse_keys, test_of_upload, MAX_KEYS, MAX_KEY_NAME,
    MAX_KEY_VALUE,
};
use rayon::prelude::*;
pub use report::{FrameVerdict, Status, SubmissionReport};
use rules::Rules;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::PathBuf;

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
#[derive(Clone)]
pub enum Decoded {
    Frame(Frame),
    Hdr(HdrImage),
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

/// Decodes a submitted image: a PNG (by its signature or its name) as a frame, 8-bit
/// or 16-bit with a cICP chunk saying BT.2100 PQ; anything else as EXR,
/// Radiance or PFM light (NaN and infinities refused). `file` names it in
/// errors.
pub fn decode_bytes(
    bytes: &[u8],
    file: &str,
    alpha: crate::io::Alpha,
) -> Result<Decoded, FramesError> {
    const PNG: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    // A file named .png is read as one, so that a damaged one is reported
    // by the PNG reader, not as "not an HDR image".
    let named_png = file.to_ascii_lowercase().ends_with(".png");
    Ok(if bytes.starts_with(&PNG) || named_png {
        Decoded::Frame(crate::io::decode_frame_png_with(bytes, file, alpha)?)
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
                let rule = s.rules.for_test(&r.input.test, &s.keys);
                r.image = Some(decode_bytes(
                    &r.bytes,
                    &r.input.file,
                    rules::alpha_of(rule),
                )?);
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
    // Tests the last submission of this trace had and this one has not.
    let keys = serde_json::to_string(&s.keys).unwrap_or_default();
    let (vanished, since) = match history.last_of_trace(&branch, &keys)? {
        Some(last) => {
            let now: std::collections::BTreeSet<&str> =
                read.iter().map(|r| r.input.test.as_str()).collect();
            let gone: Vec<String> = history
                .submission_frames(last, None)?
                .into_iter()
                .map(|f| f.test)
                .filter(|t| !now.contains(t.as_str()))
                .collect();
            (gone, Some(last))
        }
        None => (Vec::new(), None),
    };
    let mut report = SubmissionReport::new(s.keys, shown, verdicts);
    if !vanished.is_empty() {
        report.vanished_since = since;
        report.vanished_fail = s.rules.vanished == rules::Vanished::Fail;
        report.passed &= !report.vanished_fail;
        report.vanished = vanished;
    }
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
