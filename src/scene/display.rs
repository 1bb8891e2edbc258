//! What follows the operator: bloom, the colour grade and the display
//! encoding (docs/display.md).

use super::units::{Factor, NonNegative, Positive, Radius};
use serde::{Deserialize, Serialize};

/// Which pixels feed the bloom.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum BrightPass {
    /// The bright pass of the modified Reinhard for training simulators
    /// (docs/bibliography.md): HDR colour scaled by Y/Lmax where Y > threshold
    /// (Y in scene units): a sun spreads, a lamp-lit wall does not.
    #[default]
    #[serde(alias = "seed001")]
    #[cfg_attr(feature = "cli", value(alias = "seed001"))]
    Scaled,
    /// The image-processing lecture's bright pass: the tone-mapped colour
    /// where its Y > threshold (display units, e.g. 0.8), else 0.
    Threshold,
}

/// Bloom (docs/display.md): bright pass, downsample, separable Gaussian,
/// composite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bloom {
    #[serde(default)]
    pub bright_pass: BrightPass,
    pub threshold: NonNegative,
    /// Downsample factor 2..=8 (the training-simulator Reinhard uses 2, the
    /// image-processing lecture suggests 8).
    #[serde(default = "default_downsample")]
    pub downsample: Factor,
    /// Gaussian radius in low-resolution pixels (taps = 2·radius + 1).
    #[serde(default = "default_radius")]
    pub radius: Radius,
    pub sigma: Positive,
    /// k in C = C_tone + k·C_bloom.
    pub strength: NonNegative,
}

fn default_downsample() -> Factor {
    Factor(2)
}
fn default_radius() -> Radius {
    Radius(6)
}

/// The image-processing lecture's colour grade on the display-referred image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grade {
    /// Scales every channel.
    #[serde(default = "one")]
    pub brightness: NonNegative,
    /// Mix with the mean-luminance grey: 0 is flat grey, 1 unchanged.
    #[serde(default = "one")]
    pub contrast: NonNegative,
    /// Mix with the pixel's luminance: 0 is greyscale, 1 unchanged.
    #[serde(default = "one")]
    pub saturation: NonNegative,
}

fn one() -> NonNegative {
    NonNegative(1.0)
}

/// The largest bloom strength and grade factor: 100. Every real look is
/// within 0-4; the bound keeps the GPU's f32 arithmetic finite for inputs up
/// to 1e30, and the value itself within what a pipeline's f32 override
/// constant can hold (1e39 was a 500 from the driver layer, 2026-11-27;
/// docs/display.md#limits).
pub const FACTOR_MAX: f64 = 100.0;
/// The largest grade factor: 4, the top of every real look. The grade
/// multiplies what the operator hands it (brightness × contrast around its
/// pivot × saturation around the luminance), so it multiplies the GPU's f32
/// rounding of the operator's curve too; at 78 × 100 the two renderers
/// were 4 LSB apart on agx's punchy look (tests/it/random_params.rs).
pub const GRADE_MAX: f64 = 4.0;
/// The largest bloom threshold and blur sigma: 1e6.
pub const SPAN_MAX: f64 = 1e6;
/// A 1/γ encoding's γ: 0.1 to 3 (real displays are 1.8 to 2.6). A
/// steeper one shows f32's rounding at black: v^(1/γ) near 0 turns the
/// residue of a curve's cancellation there (hable's f(0) − E/F, bt2390's
/// lifted black; about 1e-7) into LSBs, where the f64 reference has none.
/// At γ = 3 the two renderers stayed within 1 LSB over random parameter
/// sets (tests/it/random_params.rs); at γ = 9.8 they were 51 apart.
pub const GAMMA_RANGE: (f64, f64) = (0.1, 3.0);

fn at_most(key: &'static str, v: f64, max: f64) -> Result<(), (&'static str, String)> {
    if v <= max {
        Ok(())
    } else {
        let shown = if v.abs() >= 1e7 {
            format!("{v:e}")
        } else {
            format!("{v}")
        };
        Err((key, format!("must be at most {max}, got {shown}")))
    }
}

impl Bloom {
    /// The bounds beyond each value's own type (`FACTOR_MAX`,
    /// `SPAN_MAX`); the error names the scene key.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        at_most("strength", self.strength.0, FACTOR_MAX)?;
        at_most("threshold", self.threshold.0, SPAN_MAX)?;
        at_most("sigma", self.sigma.0, SPAN_MAX)
    }
}

impl Grade {
    /// Each factor at most `GRADE_MAX`.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        at_most("brightness", self.brightness.0, GRADE_MAX)?;
        at_most("contrast", self.contrast.0, GRADE_MAX)?;
        at_most("saturation", self.saturation.0, GRADE_MAX)
    }

    /// A neutral grade changes nothing, so the plan leaves it out.
    pub fn is_neutral(&self) -> bool {
        self.brightness.0 == 1.0 && self.contrast.0 == 1.0 && self.saturation.0 == 1.0
    }
}

/// Display encoding of the final frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Encoding {
    /// The sRGB OETF (piecewise: linear below 0.0031308), 8 bits.
    #[default]
    Srgb,
    /// A plain 1/γ power, γ default 2.2 (the image-processing lecture), 8 bits.
    Gamma(Positive),
    /// BT.2100 PQ, 16 bits (docs/display.md#pq-frames): the operator's
    /// display-relative output taken to cd/m² on the display it maps onto,
    /// BT.709 → BT.2020, SMPTE ST 2084. Only for an operator with display
    /// levels (`bt2390`).
    Pq,
}

impl Encoding {
    /// γ within `GAMMA_RANGE`.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        match self {
            Encoding::Gamma(g) if !(GAMMA_RANGE.0..=GAMMA_RANGE.1).contains(&g.0) => Err((
                "gamma",
                format!(
                    "must be in [{}, {}], got {}",
                    GAMMA_RANGE.0, GAMMA_RANGE.1, g.0
                ),
            )),
            _ => Ok(()),
        }
    }

    /// Bits per sample of the frames it makes.
    pub fn bits(self) -> u32 {
        match self {
            Encoding::Srgb | Encoding::Gamma(_) => 8,
            Encoding::Pq => 16,
        }
    }
}
