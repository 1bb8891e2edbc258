//! Eye adaptation (docs/adaptation.md): the luminance an operator keys on,
//! carried from frame to frame with one time constant as the scene
//! brightens (light adaptation) and another as it darkens (dark
//! adaptation).

use super::units::Positive;
use serde::{Deserialize, Serialize};

/// How the adapted luminance follows the measured one.
///
/// Each frame, in natural logarithms of luminance, the adapted value `a`
/// moves toward the frame's measurement `m` by the fraction
/// α = 1 − e^(−Δt/τ) of the gap, τ = `up` when m > a, else `down`; the first
/// frame (and the first after a reset) takes `m` as it is. The adapted value
/// replaces the log average wherever the operator reads one; an operator
/// that reads none has its input scaled by `key` / adapted (auto-exposure).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Adaptation {
    /// Seconds: the time constant as the scene brightens.
    #[serde(default = "default_up")]
    pub up: Positive,
    /// Seconds: the time constant as the scene darkens.
    #[serde(default = "default_down")]
    pub down: Positive,
    /// The grey an operator that keys on nothing maps the adapted
    /// luminance to.
    #[serde(default = "default_key")]
    pub key: Positive,
}

fn default_up() -> Positive {
    Positive(DEFAULT_UP)
}
fn default_down() -> Positive {
    Positive(DEFAULT_DOWN)
}
fn default_key() -> Positive {
    Positive(DEFAULT_ADAPTATION_KEY)
}

/// Seconds: light adaptation's default time constant.
pub const DEFAULT_UP: f64 = 0.4;
/// Seconds: dark adaptation's, four times slower.
pub const DEFAULT_DOWN: f64 = 1.6;
/// Middle grey.
pub const DEFAULT_ADAPTATION_KEY: f64 = 0.18;

impl Default for Adaptation {
    fn default() -> Adaptation {
        Adaptation {
            up: default_up(),
            down: default_down(),
            key: default_key(),
        }
    }
}

impl Adaptation {
    /// `up` and `down` seconds and `key`, or which is out of range.
    pub fn new(up: f64, down: f64, key: f64) -> Result<Adaptation, (&'static str, String)> {
        Ok(Adaptation {
            up: Positive::try_from(up).map_err(|e| ("up", e))?,
            down: Positive::try_from(down).map_err(|e| ("down", e))?,
            key: Positive::try_from(key).map_err(|e| ("key", e))?,
        })
    }

    /// The fractions of the gap one frame of `dt` seconds closes, (up,
    /// down): 1 − e^(−Δt/τ), from `exp_m1` so that a short frame keeps its
    /// digits.
    pub fn steps(&self, dt: f64) -> (f64, f64) {
        let step = |tau: f64| -(-dt / tau).exp_m1();
        (step(self.up.get()), step(self.down.get()))
    }
}
