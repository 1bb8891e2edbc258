//! Temporal anti-aliasing (the TAA thesis in docs/bibliography.md; docs/taa.md):
//! which variant, and its knobs.

use super::units::{Feedback, NonNegative, Positive, Unit, Weight};
use serde::{Deserialize, Serialize};

/// Which anti-aliasing a 1-spp TAA scene runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum TaaVariant {
    /// No anti-aliasing: the plain unjittered 1-spp frame (the thesis's
    /// "No AA").
    Off,
    /// The baseline the thesis compares against ("Uncharted 4"): the 3×3 and
    /// cross neighbourhoods' min/max averaged into a clipping box.
    #[default]
    Clip,
    /// The thesis's improvement (§4.3): a Sobel pass on the current colour
    /// says how aliased each pixel is; that amount blends the cross and 3×3
    /// neighbourhoods and shrinks the clipping box toward the current colour
    /// where there is no edge.
    EdgeAware,
    /// Variance clipping (Salvi 2016): the box is the 3×3 neighbourhood's
    /// mean ± γ standard deviations in YCoCg, and the history is clipped
    /// toward the mean in YCoCg. Not in the thesis.
    Variance,
}

impl TaaVariant {
    pub fn name(self) -> &'static str {
        match self {
            TaaVariant::Off => "off",
            TaaVariant::Clip => "clip",
            TaaVariant::EdgeAware => "edge_aware",
            TaaVariant::Variance => "variance",
        }
    }
}

/// How the current frame's weight in the blend is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum FeedbackRule {
    /// The thesis's rule: the history's weight falls from `feedback_max` to
    /// `feedback_min` as the clipped history and the current colour differ
    /// in luminance.
    Luminance,
    /// From the reprojected motion, which tonegate knows exactly: a pixel
    /// that moves takes `current_moving + current_per_px · motion` of the
    /// current frame (at most `current_max`), a static one `current_min`,
    /// and a pixel whose history holds only k frames at least 1/(k + 1), so
    /// a new history averages its first frames equally.
    #[default]
    Motion,
}

impl FeedbackRule {
    pub fn name(self) -> &'static str {
        match self {
            FeedbackRule::Luminance => "luminance",
            FeedbackRule::Motion => "motion",
        }
    }
}

/// Where the current colour and the history are blended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum BlendSpace {
    /// A plain weighted mean of the linear colours.
    Linear,
    /// In a moving pixel, each colour weighted also by 1 / (1 + Y), Y its
    /// luminance (Karis 2014): a reversible tone map that keeps one bright
    /// sample (or a bright ghost in the history) from dominating the blend.
    /// A static pixel is blended linearly, so its history converges on the
    /// plain mean an accumulation reference is. The default: measured on
    /// llvmpipe (LLVM 15.0.6), 2026-11-25, it raised the ghosting scenes'
    /// mean PSNR gain over no AA from +1.30 to +2.68 dB (interior) and from
    /// +1.60 to +2.43 dB (grid), clip box and the other keys at their
    /// defaults then.
    #[default]
    Tonemapped,
}

impl BlendSpace {
    pub fn name(self) -> &'static str {
        match self {
            BlendSpace::Linear => "linear",
            BlendSpace::Tonemapped => "tonemapped",
        }
    }
}

/// How the history is read at its reprojected position.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum HistoryFilter {
    /// Four texels (as in the thesis): each frame's resampling blurs the
    /// history a little more, and in motion that blur accumulates over the
    /// history's length.
    Bilinear,
    /// Catmull-Rom over 4×4 texels (as Unreal's TAA reads its history,
    /// Karis 2014): its negative lobes undo most of the per-frame blur.
    /// Not in the thesis. Measured against bilinear on llvmpipe (LLVM
    /// 15.0.6), 2026-11-23: mean PSNR on the built-in ghosting scenes 21.88 →
    /// 23.27 dB (clip), at no cost to the static test (docs/taa.md).
    /// Negative results are clamped to 0. The default.
    #[default]
    CatmullRom,
}

impl HistoryFilter {
    pub fn name(self) -> &'static str {
        match self {
            HistoryFilter::Bilinear => "bilinear",
            HistoryFilter::CatmullRom => "catmull_rom",
        }
    }
}

/// `[taa]` of a scene: the scene renders one jittered sample per pixel per
/// frame and resolves it against its reprojected history.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Taa {
    #[serde(default)]
    pub variant: TaaVariant,
    /// How the current frame's weight is chosen (docs/taa.md#feedback).
    #[serde(default)]
    pub feedback: FeedbackRule,
    /// `feedback = "luminance"`: the history's weight where the current and
    /// clipped history colours differ most in luminance (the thesis's
    /// §3.6.3 feedback, low end).
    #[serde(default = "default_feedback_min")]
    pub feedback_min: Feedback,
    /// `feedback = "luminance"`: the history's weight where they agree (the
    /// high end).
    #[serde(default = "default_feedback_max")]
    pub feedback_max: Feedback,
    /// `feedback = "motion"`: the current frame's weight in a static pixel
    /// whose history is full.
    #[serde(default = "default_current_min")]
    pub current_min: Weight,
    /// `feedback = "motion"`: the current frame's weight in a moving pixel,
    /// before the term per pixel of motion.
    #[serde(default = "default_current_moving")]
    pub current_moving: Weight,
    /// `feedback = "motion"`: added to the current frame's weight per pixel
    /// the point moved since the last frame.
    #[serde(default = "default_current_per_px")]
    pub current_per_px: NonNegative,
    /// `feedback = "motion"`: the most the current frame weighs from motion.
    #[serde(default = "default_current_max")]
    pub current_max: Weight,
    /// `feedback = "motion"`: a point that moved less than this many pixels
    /// counts as static.
    #[serde(default = "default_static_px")]
    pub static_px: NonNegative,
    /// `variant = "variance"`: the box's half-width in standard deviations.
    #[serde(default = "default_variance_gamma")]
    pub variance_gamma: Positive,
    /// Where the current colour and the history are blended.
    #[serde(default)]
    pub blend: BlendSpace,
    /// Strength s of the thesis's sharpen kernel [0 −1 0; −1 5 −1; 0 −1 0]
    /// (eq. 3.1), applied as I + s·(K − I): 1 is the printed kernel, 0.25 is
    /// exactly the normalised kernel of §4.3.5 [0 −¼ 0; −¼ 2 −¼; 0 −¼ 0],
    /// 0 turns it off.
    #[serde(default = "default_sharpen")]
    pub sharpen: Unit,
    #[serde(default)]
    pub history_filter: HistoryFilter,
    /// Frames (besides frame 0) whose history is discarded, e.g. a cut.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reset_frames: Vec<u32>,
}

/// Playdead's INSIDE TAA (Pedersen, GDC 2016, the thesis's [7]) blends with
/// feedback between 0.88 and 0.97.
fn default_feedback_min() -> Feedback {
    Feedback(0.88)
}
fn default_feedback_max() -> Feedback {
    Feedback(0.97)
}
/// 1/16: a static pixel's history settles on the mean of the 16 jitter
/// offsets of one cycle.
fn default_current_min() -> Weight {
    Weight(1.0 / 16.0)
}
/// 0.2 + 0.1 per pixel, at most 0.35: the best of the settings tried on
/// the built-in ghosting scenes (interior and grid maps, 0.5°/frame, clip
/// box, Catmull-Rom history, tone-mapped blend) on llvmpipe (LLVM 15.0.6),
/// 2026-11-25: mean PSNR gain over no AA +2.67 dB (interior) and +2.94 dB
/// (grid), against +2.68 and +2.43 for Unreal Engine 4's 1/8 + 1/8 per
/// pixel, at most 1/4 (Karis 2014), and +2.64 and +1.87 for 0.1 + 0.1, at
/// most 0.2 (docs/taa.md#feedback).
fn default_current_moving() -> Weight {
    Weight(0.2)
}
fn default_current_per_px() -> NonNegative {
    NonNegative(0.1)
}
fn default_current_max() -> Weight {
    Weight(0.35)
}
/// A thousandth of a pixel: far below any motion that shows, far above the
/// f32 error of a reprojection that does not move.
fn default_static_px() -> NonNegative {
    NonNegative(1e-3)
}
/// γ = 1, as Salvi (GDC 2016) recommends.
fn default_variance_gamma() -> Positive {
    Positive(1.0)
}
/// Off by default. The gate judges TAA against the accumulation reference,
/// a box-filtered average of jittered samples, which a converged history
/// already approaches; any sharpening moves it away. Measured on the CPU
/// reference, interior environment, 256×144: the static test's last frame
/// is 44.1 dB at s = 0, 23.4 dB at 0.1 and 21.0 dB at 0.25 (no AA: 21.6);
/// in motion (0.5°/frame) sharpening pays back the bilinear history's blur,
/// 21.4 dB at s = 0 and 23.8 dB at 0.25 (no AA: 23.5). A renderer tuned
/// for the eye rather than for the reference may want 0.25, the normalised
/// kernel the thesis settled on in §4.3.5.
fn default_sharpen() -> Unit {
    Unit(0.0)
}

/// The TAA stage's parameters, as plain numbers, in the stage plan.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TaaParams {
    pub variant: TaaVariant,
    pub feedback: FeedbackRule,
    pub feedback_min: f64,
    pub feedback_max: f64,
    pub current_min: f64,
    pub current_moving: f64,
    pub current_per_px: f64,
    pub current_max: f64,
    pub static_px: f64,
    pub variance_gamma: f64,
    pub blend: BlendSpace,
    pub sharpen: f64,
    pub history_filter: HistoryFilter,
}

impl Default for TaaParams {
    /// The parameters of a `[taa]` table with every key left out.
    fn default() -> TaaParams {
        Taa::default().params()
    }
}

impl Default for Taa {
    fn default() -> Taa {
        Taa {
            variant: TaaVariant::default(),
            feedback: FeedbackRule::default(),
            feedback_min: default_feedback_min(),
            feedback_max: default_feedback_max(),
            current_min: default_current_min(),
            current_moving: default_current_moving(),
            current_per_px: default_current_per_px(),
            current_max: default_current_max(),
            static_px: default_static_px(),
            variance_gamma: default_variance_gamma(),
            blend: BlendSpace::default(),
            sharpen: default_sharpen(),
            history_filter: HistoryFilter::default(),
            reset_frames: Vec::new(),
        }
    }
}

impl Taa {
    pub fn params(&self) -> TaaParams {
        TaaParams {
            variant: self.variant,
            feedback: self.feedback,
            feedback_min: self.feedback_min.get(),
            feedback_max: self.feedback_max.get(),
            current_min: self.current_min.get(),
            current_moving: self.current_moving.get(),
            current_per_px: self.current_per_px.get(),
            current_max: self.current_max.get(),
            static_px: self.static_px.get(),
            variance_gamma: self.variance_gamma.get(),
            blend: self.blend,
            sharpen: self.sharpen.get(),
            history_filter: self.history_filter,
        }
    }

    /// The table that has `params` and `reset_frames`, each number checked
    /// as the scene parser checks it.
    pub fn from_params(params: &TaaParams, reset_frames: Vec<u32>) -> Result<Taa, String> {
        let key = |k: &'static str| move |e: String| format!("taa.{k} {e}");
        Ok(Taa {
            variant: params.variant,
            feedback: params.feedback,
            feedback_min: Feedback::try_from(params.feedback_min).map_err(key("feedback_min"))?,
            feedback_max: Feedback::try_from(params.feedback_max).map_err(key("feedback_max"))?,
            current_min: Weight::try_from(params.current_min).map_err(key("current_min"))?,
            current_moving: Weight::try_from(params.current_moving)
                .map_err(key("current_moving"))?,
            current_per_px: NonNegative::try_from(params.current_per_px)
                .map_err(key("current_per_px"))?,
            current_max: Weight::try_from(params.current_max).map_err(key("current_max"))?,
            static_px: NonNegative::try_from(params.static_px).map_err(key("static_px"))?,
            variance_gamma: Positive::try_from(params.variance_gamma)
                .map_err(key("variance_gamma"))?,
            blend: params.blend,
            sharpen: Unit::try_from(params.sharpen).map_err(key("sharpen"))?,
            history_filter: params.history_filter,
            reset_frames,
        })
    }

    /// What tells this TAA from another of the same variant, for reports:
    /// "catmull_rom history, motion feedback, tonemapped blend" ("" for no AA).
    pub fn settings(&self) -> String {
        if self.variant == TaaVariant::Off {
            return String::new();
        }
        let mut s = format!(
            "{} history, {} feedback, {} blend",
            self.history_filter.name(),
            self.feedback.name(),
            self.blend.name()
        );
        if self.sharpen.get() > 0.0 {
            s.push_str(&format!(", sharpen {}", self.sharpen.get()));
        }
        s
    }

    /// Whether frame `n` starts with an empty history.
    pub fn resets_at(&self, n: u32) -> bool {
        n == 0 || self.reset_frames.contains(&n)
    }
}
