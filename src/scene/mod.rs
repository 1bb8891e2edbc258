//! Scene scripts (TOML): what to render, how to tone-map it and what the gate checks.
//!
//! Every struct denies unknown keys, and every range rule lives in a validated
//! type (`try_from`), so the TOML parser reports a bad value with its key and
//! line, exactly like a typo.

mod adaptation;
mod display;
#[cfg(feature = "reference")]
mod file;
#[cfg(feature = "reference")]
mod sequence;
mod taa;
mod units;

pub use crate::conventions::MAX_SPP;
pub use crate::operators::reinhard::{ColourPath, DEFAULT_KEY, DEFAULT_WHITE_FRACTION};
pub use adaptation::{
    Adaptation, Compensation, Mask, Metering, Speed, COMPENSATION_POINTS, DEFAULT_ADAPTATION_KEY,
    DEFAULT_DOWN, DEFAULT_UP, HISTOGRAM_BINS, MAX_COMPENSATION, MAX_EV,
};
pub use display::{
    Bloom, BrightPass, Encoding, Grade, FACTOR_MAX, GAMMA_RANGE, GRADE_MAX, SPAN_MAX,
};
#[cfg(feature = "reference")]
pub use file::{read_text, Scene, SceneError, MAX_TEXT_BYTES};
#[cfg(feature = "reference")]
pub use sequence::{Environment, LightStep, Rotation, DEFAULT_FPS, LIGHT_SCALE_RANGE, MAX_FRAMES};
pub use taa::{BlendSpace, FeedbackRule, HistoryFilter, Taa, TaaParams, TaaVariant};
pub use units::{
    Factor, Feedback, NonNegative, Positive, Radius, Size, Unit, Weight, MAX_OUTPUT_PIXELS,
};

#[cfg(test)]
mod tests;
