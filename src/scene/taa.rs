//! Temporal anti-aliasing (the TAA thesis in docs/bibliography.md; docs/taa.md):
//! which variant, and its knobs.

use super::units::{Feedback, Unit};
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
}

impl TaaVariant {
    pub fn name(self) -> &'static str {
        match self {
            TaaVariant::Off => "off",
            TaaVariant::Clip => "clip",
            TaaVariant::EdgeAware => "edge_aware",
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
    #[default]
    Bilinear,
    /// Catmull-Rom over 4×4 texels (as Unreal's TAA reads its history,
    /// Karis 2014): its negative lobes undo most of the per-frame blur.
    /// Not in the thesis. Measured against bilinear on llvmpipe (LLVM
    /// 15.0.6), 2026-11-23: mean PSNR on the built-in ghosting scenes 21.88 →
    /// 23.27 dB (clip), at no cost to the static test (docs/taa.md).
    /// Negative results are clamped to 0.
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
    /// The history's weight where the current and clipped history colours
    /// differ most in luminance (the thesis's §3.6.3 feedback, low end).
    #[serde(default = "default_feedback_min")]
    pub feedback_min: Feedback,
    /// The history's weight where they agree (the high end).
    #[serde(default = "default_feedback_max")]
    pub feedback_max: Feedback,
    /// Strength s of the thesis's sharpen kernel [0 −1 0; −1 5 −1; 0 −1 0]
    /// (eq. 3.1), applied as I + s·(K − I): 1 is the printed kernel, 0.25 is
    /// exactly the normalised kernel of §4.3.5 [0 −¼ 0; −¼ 2 −¼; 0 −¼ 0],
    /// 0 turns it off.
    #[serde(default = "default_sharpen")]
    pub sharpen: Unit,
    #[serde(default, skip_serializing_if = "is_bilinear")]
    pub history_filter: HistoryFilter,
    /// Frames (besides frame 0) whose history is discarded, e.g. a cut.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reset_frames: Vec<u32>,
}

fn is_bilinear(f: &HistoryFilter) -> bool {
    *f == HistoryFilter::Bilinear
}

/// Playdead's INSIDE TAA (Pedersen, GDC 2016, the thesis's [7]) blends with
/// feedback between 0.88 and 0.97.
fn default_feedback_min() -> Feedback {
    Feedback(0.88)
}
fn default_feedback_max() -> Feedback {
    Feedback(0.97)
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
    pub feedback_min: f64,
    pub feedback_max: f64,
    pub sharpen: f64,
    pub history_filter: HistoryFilter,
}

impl Taa {
    pub fn params(&self) -> TaaParams {
        TaaParams {
            variant: self.variant,
            feedback_min: self.feedback_min.get(),
            feedback_max: self.feedback_max.get(),
            sharpen: self.sharpen.get(),
            history_filter: self.history_filter,
        }
    }

    /// Whether frame `n` starts with an empty history.
    pub fn resets_at(&self, n: u32) -> bool {
        n == 0 || self.reset_frames.contains(&n)
    }
}
