//! The vocabulary of checks, in one place: what a scene file may ask the gate
//! to bound (`spec`), and how one rendered scene is judged against its
//! goldens with those checks (`judge`).
//!
//! Adding a check kind is one variant of [`Check`] and one arm of
//! [`Check::rule`]; a new per-frame figure is one row of [`FRAME_METRICS`].
//! Nothing here renders or reads files: the gate (`crate::gate`) renders,
//! loads the goldens and calls [`judge`].

pub mod judge;
pub mod spec;

pub use judge::{
    evaluate, judge, CheckResult, FrameResult, JudgeError, Judging, KeptFrame, Rendered,
    SceneResult, Summary, TestKind,
};
pub use spec::{
    not_applied, Check, CheckSpec, FrameMetric, Judged, Rule, Side, Subject, FRAME_METRICS,
};
