//! One submitted frame against what people said of its test's digests: a
//! positive digest passes, a negative fails; an untriaged one is compared
//! with each positive of its test and passes when its test's rules hold
//! against one (the closest is reported either way), and otherwise fails
//! or warns as the rules say.

use super::report::{Closest, FrameVerdict, Status};
use super::rules::{Rules, TestRule, Untriaged};
use super::{decode_bytes, Decoded, FramesError, Input};
use crate::check::spec::{Check, Side};
use crate::history::{History, IgnoreRule, Label};
use crate::metrics::frames::{compare_frames_by, frame_fraction_over};
use crate::metrics::hdr::{compare_hdr, HdrOptions};
use std::collections::BTreeMap;

/// The ignore rules that apply to a submission: those whose keys it has.
pub(super) struct Ignores(Vec<IgnoreRule>);

impl Ignores {
    pub(super) fn of(rules: Vec<IgnoreRule>, keys: &BTreeMap<String, String>) -> Ignores {
        Ignores(
            rules
                .into_iter()
                .filter(|r| {
                    let wanted: BTreeMap<String, String> =
                        serde_json::from_str(&r.keys).unwrap_or_default();
                    wanted.iter().all(|(k, v)| keys.get(k) == Some(v))
                })
                .collect(),
        )
    }

    fn covering(&self, test: &str) -> Option<&IgnoreRule> {
        self.0
            .iter()
            .find(|r| super::rules::matches(&r.pattern, test))
    }
}

/// What a submission's frames are judged with.
pub(super) struct On<'a> {
    pub history: &'a History,
    /// The submission's keys, which choose among the rules.
    pub keys: &'a BTreeMap<String, String>,
    pub rules: &'a Rules,
    pub ignores: &'a Ignores,
    pub compare: Option<crate::metrics::CompareBy<'a>>,
}

impl On<'_> {
    /// One frame's verdict; a failing one that an ignore rule covers is
    /// `ignored`, and passes, unless its digest is a negative: what people
    /// said is wrong stays wrong whatever rule was added since.
    /// `labels`: its test's digests and their labels on the branch;
    /// `image`: the frame decoded, which an untriaged digest needs.
    pub(super) fn judge(
        &self,
        input: &Input,
        (digest, labels): (&str, &[(String, Label)]),
        image: Option<&Decoded>,
    ) -> Result<FrameVerdict, FramesError> {
        let mut v = judge(self, input, (digest, labels), image)?;
        let negative = labels
            .iter()
            .any(|(d, l)| d == digest && *l == Label::Negative);
        if (!v.passed || v.warning) && !negative {
            if let Some(r) = self.ignores.covering(&input.test) {
                v.detail = format!(
                    "ignored until {} by rule {} ({}: {}); {}",
                    r.expires_at, r.id, r.who, r.reason, v.detail
                );
                v.status = Status::Ignored;
                v.passed = true;
                v.warning = false;
            }
        }
        Ok(v)
    }
}

fn judge(
    on: &On,
    input: &Input,
    (digest, labels): (&str, &[(String, Label)]),
    image: Option<&Decoded>,
) -> Result<FrameVerdict, FramesError> {
    let (history, rules) = (on.history, on.rules);
    let label = labels
        .iter()
        .find(|(d, _)| d == digest)
        .map_or(Label::Untriaged, |(_, l)| *l);
    let verdict =
        |status: Status, passed: bool, closest: Option<Closest>, detail: String| FrameVerdict {
            test: input.test.clone(),
            file: input.file.clone(),
            digest: digest.to_owned(),
            status,
            passed,
            warning: false,
            closest,
            detail,
        };
    match label {
        Label::Positive => {
            return Ok(verdict(
                Status::Positive,
                true,
                None,
                "a positive digest of its test".into(),
            ))
        }
        Label::Negative => {
            return Ok(verdict(
                Status::Negative,
                false,
                None,
                "a negative digest of its test: marked as wrong".into(),
            ))
        }
        Label::Untriaged => {}
    }
    let Some(image) = image else {
        return Err(FramesError::File {
            file: input.file.clone(),
            detail: "an untriaged frame reached judging undecoded (a tonegate bug)".into(),
        });
    };
    let rule = rules.for_test(&input.test, on.keys);
    let mut best: Option<Closest> = None;
    let mut problems = Vec::new();
    for (positive, _) in labels.iter().filter(|(_, l)| *l == Label::Positive) {
        let Some(bytes) = history.blob(positive)? else {
            continue;
        };
        let theirs = decode_bytes(&bytes, &input.test, super::rules::alpha_of(rule))?;
        let adapter = on.keys.get("adapter").map_or("", String::as_str);
        match against(image, &theirs, rule, adapter, on.compare) {
            Ok(c) => {
                if better(&c, best.as_ref()) {
                    best = Some(Closest {
                        digest: positive.clone(),
                        ..c
                    });
                }
            }
            Err(why) => problems.push(format!("positive {}: {why}", short(positive))),
        }
    }
    let matched = rule.is_some() && best.as_ref().is_some_and(|c| c.failed.is_empty());
    if matched {
        let c = best.as_ref().map(|c| short(&c.digest)).unwrap_or_default();
        let detail = format!("untriaged, within its rules of positive {c}");
        return Ok(verdict(Status::Matched, true, best, detail));
    }
    let why = match (&best, rule) {
        (None, _) if problems.is_empty() => "untriaged; its test has no positive yet".to_owned(),
        (None, _) => format!("untriaged; no positive compares: {}", problems.join("; ")),
        (Some(c), None) => format!(
            "untriaged; no rule for its test, the closest positive is {}",
            short(&c.digest)
        ),
        (Some(c), Some(_)) => format!(
            "untriaged; the closest positive {} misses {}",
            short(&c.digest),
            c.failed.join(", ")
        ),
    };
    // A new test: nobody ever marked one of its digests either way.
    let new_test = labels.iter().all(|(_, l)| *l == Label::Untriaged);
    let (warn, why) = match rules.untriaged {
        Untriaged::Warn => (true, why),
        Untriaged::AcceptNew if new_test => (true, format!("{why}; a new test, accepted")),
        Untriaged::AcceptNew => (
            false,
            format!("{why}; its test has marked digests, so this is a change, not a new test"),
        ),
        Untriaged::Fail => (false, why),
    };
    let mut v = verdict(Status::Untriaged, warn, best, why);
    v.warning = warn;
    Ok(v)
}

fn short(digest: &str) -> &str {
    &digest[..digest.len().min(12)]
}

/// Whether `c` is closer than the best so far: fewer rules broken, then
/// the lower FLIP.
fn better(c: &Closest, best: Option<&Closest>) -> bool {
    let flip = |c: &Closest| {
        c.figures
            .get("flip_mean")
            .or(c.figures.get("hdr_flip_mean"))
            .copied()
            .unwrap_or(f64::INFINITY)
    };
    best.is_none_or(|b| (c.failed.len(), flip(c)) < (b.failed.len(), flip(b)))
}

/// The figures of `ours` against the positive `theirs`, and the rules
/// broken; an error when the two cannot be compared.
fn against(
    ours: &Decoded,
    theirs: &Decoded,
    rule: Option<&TestRule>,
    adapter: &str,
    by: Option<crate::metrics::CompareBy>,
) -> Result<Closest, String> {
    let masks = rule.map_or(&[][..], |r| &r.masks);
    if !masks.is_empty() {
        let (ours, theirs) = (
            super::pixels::masked(ours, masks),
            super::pixels::masked(theirs, masks),
        );
        return compared(&ours, &theirs, rule, adapter, by);
    }
    compared(ours, theirs, rule, adapter, by)
}

/// [`against`] on the frames as the rule's masks leave them.
fn compared(
    ours: &Decoded,
    theirs: &Decoded,
    rule: Option<&TestRule>,
    adapter: &str,
    by: Option<crate::metrics::CompareBy>,
) -> Result<Closest, String> {
    let mut figures = BTreeMap::new();
    let mut failed = Vec::new();
    match (ours, theirs) {
        (Decoded::Frame(a), Decoded::Frame(b)) => {
            let (m, flip) = compare_frames_by(a, b, by).map_err(|e| e.to_string())?;
            for (k, v) in [
                ("psnr", m.psnr),
                ("ssim", m.ssim),
                ("mse", m.mse),
                ("max_abs_diff", f64::from(m.max_abs_diff)),
                ("mean_abs_diff", m.mean_abs_diff),
                ("fraction_over_1lsb", m.fraction_over_1lsb),
                ("flip_mean", m.flip_mean),
            ] {
                figures.insert(k.to_owned(), v);
            }
            let specs = rule.map_or(&[][..], |r| &r.checks);
            // Which bounds apply: those for the submission's `adapter` key
            // override the ones for every adapter, as in a scene.
            let on = crate::check::spec::Judged {
                adapter,
                spp: 1,
                reference_spp: 1,
                options: &[],
            };
            for (i, spec) in specs.iter().enumerate() {
                if crate::check::spec::not_applied(specs, i, on).is_some() {
                    continue;
                }
                let check = &spec.check;
                let value = match check {
                    Check::MinPsnr(_) => m.psnr,
                    Check::MinSsim(_) => m.ssim,
                    Check::MaxMse(_) => m.mse,
                    Check::MaxAbsDiff(_) => f64::from(m.max_abs_diff),
                    Check::MaxMeanAbsDiff(_) => m.mean_abs_diff,
                    Check::MaxFractionOver { lsb, .. } => {
                        let v = frame_fraction_over(a, b, *lsb).map_err(|e| e.to_string())?;
                        figures.insert(format!("fraction_over_{lsb}lsb"), v);
                        v
                    }
                    Check::MaxPixelsOver { lsb, .. } => {
                        let f = frame_fraction_over(a, b, *lsb).map_err(|e| e.to_string())?;
                        let v = crate::check::judge::pixels_of(f, a) as f64;
                        figures.insert(format!("pixels_over_{lsb}lsb"), v);
                        v
                    }
                    Check::MaxFlipMean(_) => m.flip_mean,
                    Check::MaxFlipPercentile { p, .. } => {
                        let v = flip.weighted_percentile(*p);
                        figures.insert(format!("flip_p{p}"), v);
                        v
                    }
                    // Refused when the rules were read.
                    _ => continue,
                };
                let r = check.rule();
                if r.fails(value) {
                    failed.push(format!("{} (was {})", spec.label(), figure(value)));
                }
            }
            if rule.is_some_and(|r| r.checks.is_empty()) {
                failed.push("its rule has no checks for a PNG frame".into());
            }
        }
        (Decoded::Hdr(a), Decoded::Hdr(b)) => {
            let c = compare_hdr(a, b, &HdrOptions::default()).map_err(|e| e.to_string())?;
            let m = &c.metrics;
            figures.insert("hdr_flip_mean".to_owned(), m.hdr_flip.mean);
            figures.insert("pu21_psnr".to_owned(), m.pu21_psnr);
            figures.insert("delta_e_itp_mean".to_owned(), m.delta_e_itp_mean);
            if let Some(h) = rule.map(|r| &r.hdr) {
                for (name, side, bound, value) in [
                    (
                        "HDR-FLIP mean",
                        Side::Max,
                        h.max_hdr_flip_mean,
                        m.hdr_flip.mean,
                    ),
                    ("PU21 PSNR", Side::Min, h.min_pu21_psnr, m.pu21_psnr),
                    (
                        "ΔE_ITP mean",
                        Side::Max,
                        h.max_delta_e_itp_mean,
                        m.delta_e_itp_mean,
                    ),
                ] {
                    let Some(bound) = bound else { continue };
                    // NaN fails either way.
                    let (holds, op) = match side {
                        Side::Min => (value >= bound, ">="),
                        Side::Max => (value <= bound, "<="),
                    };
                    if !holds {
                        failed.push(format!("{name} {op} {bound} (was {})", figure(value)));
                    }
                }
            }
            if rule.is_some_and(|r| r.hdr.is_empty()) {
                failed.push("its rule has no hdr bounds for an HDR file".into());
            }
        }
        _ => return Err("one is a PNG frame and the other an HDR file".into()),
    }
    Ok(Closest {
        digest: String::new(),
        figures,
        failed,
    })
}

fn figure(v: f64) -> String {
    if v.is_infinite() {
        "inf".into()
    } else {
        format!("{v:.6}")
    }
}
