//! Where the frames come from: the environment map and the sphere's motion.

use super::units::Size;
use crate::env::BuiltinEnv;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Where the environment map comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Environment {
    /// A built-in map (`sky`, `interior`, `night`, `grid`) …
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub builtin: Option<BuiltinEnv>,
    /// … or an HDR file (.hdr, .exr, .pfm), relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// Resolution of a built-in map; ignored (and refused) for files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<Size>,
}

/// Rotation of the sphere per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    /// Axis of rotation; default the horizontal x axis, as in Reinhard's global
    /// operator in real time (docs/bibliography.md).
    #[serde(default = "default_axis")]
    pub axis: [f64; 3],
    /// ω, degrees per frame; 0 makes a static sequence.
    pub degrees_per_frame: f64,
}

fn default_axis() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}

/// Largest frame count of one sequence.
pub const MAX_FRAMES: u32 = 10_000;

/// A change of the scene's light: from frame `from_frame` on, the
/// environment's radiance times `scale` (until the next step). A door
/// opening is `{ from_frame = 12, scale = 30.0 }`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightStep {
    pub from_frame: u32,
    pub scale: super::units::Positive,
}

/// The range a light step's scale may take: twenty decades, which keeps
/// the scaled radiance of any environment tonegate reads finite in f32.
pub const LIGHT_SCALE_RANGE: (f64, f64) = (1e-10, 1e10);

/// The frame rate a sequence is timed at when the scene gives none.
pub const DEFAULT_FPS: f64 = 60.0;
