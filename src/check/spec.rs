//! The check kinds: how each is written in a scene file, named, labelled,
//! validated, matched to an adapter and an spp, and which measured figure it
//! bounds on which side.
//!
//! Every kind is described once, by its arm of [`Check::rule`]; the label, the
//! kind used for adapter overrides, the validation and the evaluation
//! (`super::judge`) are all derived from that [`Rule`]. The per-frame figures
//! a rule can read are the rows of `super::figures`.

use super::figures::{FrameMetric, FLIP_MEAN, MAX_ABS_DIFF, MEAN_ABS_DIFF, MSE, PSNR, SSIM};
use crate::conventions::MAX_SPP;
use serde::{Deserialize, Serialize};

/// A typed comparison the gate applies (against the golden, or to the
/// run's speed). Written in a scene file as `min_psnr = 50.0`,
/// `max_fraction_over = { lsb = 1, fraction = 0.001 }`, ….
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Check {
    MinPsnr(f64),
    MinSsim(f64),
    MaxMse(f64),
    MaxAbsDiff(u8),
    /// The mean absolute sample difference, in LSB: the typical error, which a
    /// few outlying pixels do not decide (unlike `max_abs_diff`), and which a
    /// uniform shift of every pixel does (unlike `max_fraction_over`).
    MaxMeanAbsDiff(f64),
    /// At most `fraction` of pixels may be off by more than `lsb`.
    MaxFractionOver {
        lsb: u8,
        fraction: f64,
    },
    /// At most `pixels` pixels may be off by more than `lsb` (a pixel is
    /// off when any of its channels is): a count, whatever the frame's size
    /// (Playwright's `maxDiffPixels`, Skia Gold's "max different pixels").
    MaxPixelsOver {
        lsb: u8,
        pixels: u64,
    },
    MaxStageMs {
        stage: String,
        ms: f64,
    },
    MinFps(f64),
    /// NVIDIA's FLIP error, mean over the frame: the perceptual difference
    /// wgpu's and vello's image tests gate on.
    MaxFlipMean(f64),
    /// FLIP's weighted percentile `p` (0..=1) of the frame's error: bounds the
    /// worst visible differences rather than their average.
    MaxFlipPercentile {
        p: f64,
        value: f64,
    },
    /// This scene's PSNR against another scene's of the same sequence in the
    /// same run (its no-AA render, say): "TAA helps here" as a gate
    /// condition.
    MinPsnrGainOver(GainOver),
    /// Eye adaptation (docs/adaptation.md): the luminance each frame was
    /// adapted to against the golden adaptation curve, |Δ ln L| (a
    /// relative error), for a scene with `[adaptation]`.
    MaxAdaptationError(f64),
}

/// `min_psnr_gain_over = { scene = "taa-ghost-noaa", db = 2.0, frame_db =
/// 0.0, from_frame = 16 }`: over the judged frames, the mean of this scene's
/// PSNR less `scene`'s on the same frame is at least `db`; and, when
/// `frame_db` is given, every judged frame from `from_frame` on gains at
/// least `frame_db`. `scene` must render the same frames against the same
/// goldens and come earlier in the suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainOver {
    pub scene: String,
    pub db: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_db: Option<f64>,
    #[serde(default)]
    pub from_frame: u32,
}

/// What a rule bounds.
#[derive(Clone, Copy)]
pub enum Subject<'a> {
    /// A metric of every judged frame.
    Frame(&'static FrameMetric),
    /// The fraction of a judged frame's pixels off by more than this many LSB.
    FractionOver(u8),
    /// How many of a judged frame's pixels are off by more than this many
    /// LSB.
    PixelsOver(u8),
    /// A stage's median GPU time over the sequence.
    StageMs(&'a str),
    /// Frames per second with readback over the sequence.
    Fps,
    /// FLIP's weighted percentile `p` of a judged frame's error map.
    FlipPercentile(f64),
    /// The PSNR gain over another scene of the run, frame by frame.
    GainOver(&'a GainOver),
    /// |Δ ln| of a judged frame's adapted luminance against the golden
    /// adaptation curve's.
    Adaptation,
}

impl Subject<'_> {
    /// What labels call the bounded figure.
    fn title(&self) -> String {
        match self {
            Subject::Frame(m) => m.title.into(),
            Subject::FractionOver(lsb) => format!("fraction over {lsb} LSB"),
            Subject::PixelsOver(lsb) => format!("pixels over {lsb} LSB"),
            Subject::StageMs(stage) => (*stage).into(),
            Subject::Fps => "FPS".into(),
            Subject::FlipPercentile(p) => format!("FLIP weighted percentile {p}"),
            Subject::GainOver(g) => format!("mean PSNR gain over {}", g.scene),
            Subject::Adaptation => "adapted luminance |Δ ln|".into(),
        }
    }

    /// A measured value as details print it: `PSNR 51.23 dB`.
    pub fn show(&self, v: f64) -> String {
        match self {
            Subject::Frame(m) => (m.show)(v),
            Subject::FractionOver(lsb) => format!("fraction over {lsb} LSB {v:.5}"),
            Subject::PixelsOver(lsb) => format!("pixels over {lsb} LSB {v}"),
            Subject::StageMs(stage) => format!("{stage} median {v:.3} ms"),
            Subject::Fps => format!("{v:.1} FPS with readback"),
            Subject::FlipPercentile(p) => format!("FLIP weighted percentile {p} {v:.5}"),
            Subject::GainOver(g) => format!("PSNR gain over {} {v:+.2} dB", g.scene),
            Subject::Adaptation => format!("adapted luminance |Δ ln| {v:.3e}"),
        }
    }

    fn bound_unit(&self) -> &'static str {
        match self {
            Subject::Frame(m) => m.bound_unit,
            Subject::StageMs(_) => " ms",
            Subject::GainOver(_) => " dB",
            Subject::FractionOver(_)
            | Subject::PixelsOver(_)
            | Subject::Fps
            | Subject::FlipPercentile(_)
            | Subject::Adaptation => "",
        }
    }

    fn valid_bound(&self, bound: f64) -> bool {
        match self {
            Subject::Frame(m) => (m.valid_bound)(bound),
            Subject::FractionOver(_) => (0.0..=1.0).contains(&bound),
            Subject::PixelsOver(_) => bound >= 0.0,
            Subject::StageMs(_) => bound.is_finite() && bound > 0.0,
            Subject::Fps => !bound.is_nan(),
            Subject::FlipPercentile(p) => (0.0..=1.0).contains(p) && (0.0..=1.0).contains(&bound),
            Subject::GainOver(g) => {
                bound.is_finite() && g.frame_db.is_none_or(f64::is_finite) && !g.scene.is_empty()
            }
            Subject::Adaptation => bound.is_finite() && bound >= 0.0,
        }
    }

    /// Whether the figure is read from each judged frame (rather than from
    /// the run as a whole).
    pub fn per_frame(&self) -> bool {
        matches!(
            self,
            Subject::Frame(_)
                | Subject::FractionOver(_)
                | Subject::PixelsOver(_)
                | Subject::FlipPercentile(_)
                | Subject::Adaptation
        )
    }
}

/// Which side of the bound passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The figure must be at least the bound.
    Min,
    /// The figure must be at most the bound.
    Max,
}

/// A check kind described once: what it bounds, on which side, by how much.
pub struct Rule<'a> {
    /// What makes two checks the same kind, so that an adapter's bound
    /// overrides the generic one: the name, plus the stage or the LSB count.
    pub kind: String,
    pub subject: Subject<'a>,
    pub side: Side,
    pub bound: f64,
}

impl Rule<'_> {
    fn new(kind: impl Into<String>, subject: Subject<'_>, side: Side, bound: f64) -> Rule<'_> {
        Rule {
            kind: kind.into(),
            subject,
            side,
            bound,
        }
    }

    /// Whether a measured value fails; NaN always fails.
    pub fn fails(&self, value: f64) -> bool {
        let order = value.partial_cmp(&self.bound);
        match self.side {
            Side::Min => order.is_none_or(|o| o == std::cmp::Ordering::Less),
            Side::Max => order.is_none_or(|o| o == std::cmp::Ordering::Greater),
        }
    }

    /// A short human name, for tables and JUnit test cases: `PSNR >= 50 dB`.
    pub fn label(&self) -> String {
        let op = match self.side {
            Side::Min => ">=",
            Side::Max => "<=",
        };
        let frames = match self.subject {
            Subject::GainOver(GainOver {
                frame_db: Some(f),
                from_frame,
                ..
            }) => format!(", each frame from {from_frame} >= {f} dB"),
            _ => String::new(),
        };
        format!(
            "{} {op} {}{}{frames}",
            self.subject.title(),
            self.bound,
            self.subject.bound_unit()
        )
    }
}

impl Check {
    /// The one description of each check kind.
    pub fn rule(&self) -> Rule<'_> {
        use Side::{Max, Min};
        use Subject::Frame;
        match self {
            Check::MinPsnr(v) => Rule::new("min_psnr", Frame(&PSNR), Min, *v),
            Check::MinSsim(v) => Rule::new("min_ssim", Frame(&SSIM), Min, *v),
            Check::MaxMse(v) => Rule::new("max_mse", Frame(&MSE), Max, *v),
            Check::MaxAbsDiff(v) => {
                Rule::new("max_abs_diff", Frame(&MAX_ABS_DIFF), Max, f64::from(*v))
            }
            Check::MaxMeanAbsDiff(v) => {
                Rule::new("max_mean_abs_diff", Frame(&MEAN_ABS_DIFF), Max, *v)
            }
            Check::MaxFractionOver { lsb, fraction } => Rule::new(
                format!("max_fraction_over:{lsb}"),
                Subject::FractionOver(*lsb),
                Max,
                *fraction,
            ),
            Check::MaxPixelsOver { lsb, pixels } => Rule::new(
                format!("max_pixels_over:{lsb}"),
                Subject::PixelsOver(*lsb),
                Max,
                *pixels as f64,
            ),
            Check::MaxStageMs { stage, ms } => Rule::new(
                format!("max_stage_ms:{stage}"),
                Subject::StageMs(stage),
                Max,
                *ms,
            ),
            Check::MinFps(v) => Rule::new("min_fps", Subject::Fps, Min, *v),
            Check::MaxFlipMean(v) => Rule::new("max_flip_mean", Frame(&FLIP_MEAN), Max, *v),
            Check::MaxFlipPercentile { p, value } => Rule::new(
                format!("max_flip_percentile:{p}"),
                Subject::FlipPercentile(*p),
                Max,
                *value,
            ),
            Check::MinPsnrGainOver(g) => Rule::new(
                format!("min_psnr_gain_over:{}", g.scene),
                Subject::GainOver(g),
                Min,
                g.db,
            ),
            Check::MaxAdaptationError(v) => {
                Rule::new("max_adaptation_error", Subject::Adaptation, Max, *v)
            }
        }
    }

    /// The scene a check compares with, if it compares with one.
    pub fn baseline(&self) -> Option<&str> {
        match self {
            Check::MinPsnrGainOver(g) => Some(&g.scene),
            _ => None,
        }
    }

    /// See [`Rule::kind`].
    pub fn kind(&self) -> String {
        self.rule().kind
    }
}

/// A renderer option that trades accuracy for speed. A check naming options
/// (`options = ["rgba16float"]`) is that option's own measured bound: it
/// applies only to renders with all of them in effect, and there it
/// overrides the generic bound of its kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AccuracyOption {
    /// f16 intermediates (`--hdr-format rgba16float`): 11-bit significands.
    #[serde(alias = "f16")]
    Rgba16float,
    /// The texture unit's filter (`--env-filter hardware`): sub-texel weights
    /// of as few as 4 bits (Vulkan's minimum `subTexelPrecisionBits`).
    HardwareFilter,
}

impl AccuracyOption {
    pub fn name(self) -> &'static str {
        match self {
            AccuracyOption::Rgba16float => "rgba16float",
            AccuracyOption::HardwareFilter => "hardware_filter",
        }
    }
}

/// A check as a scene file writes it: the comparison, and where it applies.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    #[serde(flatten)]
    pub check: Check,
    /// Adapter name substring this bound applies to; none = every adapter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adapter: Option<String>,
    /// Accuracy-trading options this bound is for; none = the exact path.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub options: Vec<AccuracyOption>,
    /// Samples per pixel of the render this bound is for; none = the scene's
    /// `reference_spp` (the goldens' own, a like-for-like comparison). A
    /// bound for `spp = 1` measures the plain path's aliasing instead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp: Option<u32>,
    /// Who or what set the bound, e.g. "llvmpipe 1 spp vs 16 spp, 2026-11-21".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set_by: Option<String>,
}

impl CheckSpec {
    /// The label of [`Rule::label`], with the adapter it is for.
    pub fn label(&self) -> String {
        let base = self.check.rule().label();
        let on: Vec<&str> = self
            .adapter
            .as_deref()
            .into_iter()
            .chain(self.options.iter().map(|o| o.name()))
            .collect();
        match on.is_empty() {
            true => base,
            false => format!("{base} [{}]", on.join(", ")),
        }
    }

    /// Whether `self` is a narrower bound than `other`: for all of its
    /// options and more (whatever the adapters: an option changes what is
    /// rendered, so an adapter's bound measured without it says nothing
    /// about a render with it), or for the same options on an adapter where
    /// `other` names none. Among the bounds of one kind that apply, a
    /// narrower one overrides a wider; bounds for different options (f16
    /// here, the hardware filter there) both hold.
    fn narrower_than(&self, other: &CheckSpec) -> bool {
        if !other.options.iter().all(|o| self.options.contains(o)) {
            return false;
        }
        self.options.len() > other.options.len()
            || (self.adapter.is_some() && other.adapter.is_none())
    }

    fn options_match(&self, on: &[AccuracyOption]) -> bool {
        self.options.iter().all(|o| on.contains(o))
    }

    /// The rules a parser cannot express: the spp range and a bound that
    /// makes sense for its figure.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(n) = self.spp.filter(|&n| n == 0 || n > MAX_SPP) {
            return Err(format!("spp must be between 1 and {MAX_SPP}, got {n}"));
        }
        let rule = self.check.rule();
        if !rule.subject.valid_bound(rule.bound) {
            return Err(format!("bound out of range in {:?}", self.check));
        }
        // Options are a set: a repeat would make a bound look narrower
        // than the same bound without it.
        for (i, o) in self.options.iter().enumerate() {
            if self.options[..i].contains(o) {
                return Err(format!("option {} listed twice", o.name()));
            }
        }
        Ok(())
    }

    fn adapter_matches(&self, adapter: &str) -> bool {
        self.adapter
            .as_ref()
            .map(|a| adapter.to_lowercase().contains(&a.to_lowercase()))
            .unwrap_or(true)
    }

    fn spp_matches(&self, on: Judged) -> bool {
        self.spp.unwrap_or(on.reference_spp) == on.spp
    }
}

/// What a check's applicability depends on: the renderer and its spp.
#[derive(Clone, Copy, Debug)]
pub struct Judged<'a> {
    /// The adapter name (`cpu-reference` on the CPU).
    pub adapter: &'a str,
    /// Samples per pixel of the render under test.
    pub spp: u32,
    /// The spp of checks that name none (`Scene::default_spp`: the goldens'
    /// own, or 1 for a TAA scene).
    pub reference_spp: u32,
    /// The accuracy-trading options the render had in effect.
    pub options: &'a [AccuracyOption],
}

/// Why check `index` of `specs` is not applied here, if it is not: a bound
/// for another spp, another adapter's bound, or a generic bound this
/// adapter overrides.
pub fn not_applied(specs: &[CheckSpec], index: usize, on: Judged) -> Option<String> {
    let spec = &specs[index];
    if !spec.spp_matches(on) {
        return Some(format!(
            "a bound for {} spp; this render has {}",
            spec.spp.unwrap_or(on.reference_spp),
            on.spp
        ));
    }
    if !spec.adapter_matches(on.adapter) {
        return Some(format!(
            "applies to adapter {:?} only",
            spec.adapter.as_deref().unwrap_or("")
        ));
    }
    if !spec.options_match(on.options) {
        let names: Vec<&str> = spec.options.iter().map(|o| o.name()).collect();
        return Some(format!(
            "a bound for renders with {}; this one has {}",
            names.join(" and "),
            match on.options {
                [] => "none".to_string(),
                o => o.iter().map(|o| o.name()).collect::<Vec<_>>().join(" and "),
            }
        ));
    }
    let kind = spec.check.kind();
    if let Some(o) = specs.iter().find(|o| {
        o.narrower_than(spec)
            && o.adapter_matches(on.adapter)
            && o.options_match(on.options)
            && o.spp_matches(on)
            && o.check.kind() == kind
    }) {
        return Some(format!("overridden by the narrower bound {}", o.label()));
    }
    None
}

#[cfg(test)]
pub(super) mod tests;
