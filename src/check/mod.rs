//! The vocabulary of checks, in one place: what a scene file may ask the gate
//! to bound (`spec`), and how one rendered scene is judged against its
//! goldens with those checks (`judge`).
//!
//! Adding a check kind is one variant of [`Check`] and one arm of
//! [`Check::rule`]; a new per-frame figure is one row of [`FRAME_METRICS`] (`figures`).
//! Nothing here renders or reads files: the gate (`crate::gate`) renders,
//! loads the goldens and calls [`judge::judge`].

pub mod expect;
pub mod figures;
pub mod judge;
pub mod result;
pub mod spec;

pub use expect::{Expectation, ExpectationOutcome, Expected};
pub use figures::{FrameMetric, FRAME_METRICS};
pub use judge::{evaluate, judge, judge_gain, JudgeError, Judging, KeptFrame, Rendered};
pub use result::{CheckResult, FrameResult, SceneResult, Summary, TaaTag, TestKind};
pub use spec::{
    not_applied, AccuracyOption, Check, CheckSpec, GainOver, Judged, Rule, Side, Subject,
};
