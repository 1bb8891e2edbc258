//! The knobs of a flat tone-map, shared by the `tonemap` command's flags and
//! `POST /tonemap`'s parameters (one definition, so the two cannot drift),
//! and their resolution into an operator, bloom, grade and encoding.

use super::display::{Display, HdrOutput};
use super::operator_params::OperatorParams;
use super::OutputKind;
use crate::error::{Error, Result};
use crate::operators;
use crate::operators::Operator;
use crate::reference::Pipeline;
use crate::scene::{
    Bloom, BrightPass, Encoding, Factor, Grade, NonNegative, Positive, Radius, DEFAULT_KEY,
};
use serde::{Deserialize, Serialize};

/// A named set of operator parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// pfstmo_reinhard02 in global mode: pfstools' luminance, δ = 1e-5, Lwhite = max scaled.
    Reinhard02,
}

impl Preset {
    pub fn as_str(self) -> &'static str {
        match self {
            Preset::Reinhard02 => crate::operators::REINHARD02,
        }
    }
}

/// The operator, bloom, grade and encoding of a flat tone-map. As flags
/// (`--white-fraction`, with the `cli` feature the binary builds with) and as
/// API parameters (`white_fraction`); unknown API parameters are refused.
/// `Default` is what the flags default to (a test holds the two together).
/// The enums are the scene schema's own, so a flag takes the words a scene
/// file takes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct ToneSettings {
    /// A preset that fixes the operator (overrides --operator and its parameters but key).
    #[cfg_attr(feature = "cli", arg(long, value_enum))]
    pub preset: Option<Preset>,
    /// The operator (`tonegate operators` lists them with their parameters).
    #[cfg_attr(
        feature = "cli",
        arg(long, default_value = crate::operators::REINHARD_GLOBAL)
    )]
    pub operator: String,
    /// The operator's parameters as given, by name, as text: one flag per
    /// parameter any operator takes (`--white-fraction`), one API parameter
    /// each (`white_fraction`); made from the operators' definitions.
    #[cfg_attr(feature = "cli", command(flatten))]
    #[serde(skip_deserializing, flatten)]
    pub params: OperatorParams,
    /// Bloom strength k (0 = no bloom).
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 0.0))]
    pub bloom: f64,
    /// The bright pass (default scaled). This and the four below refine a
    /// bloom: given without one (strength 0), they are refused.
    #[cfg_attr(feature = "cli", arg(long, value_enum))]
    pub bloom_pass: Option<BrightPass>,
    /// Bright-pass threshold (default 1).
    #[cfg_attr(feature = "cli", arg(long))]
    pub bloom_threshold: Option<f64>,
    /// Downsample factor, 2 to 8 (default 2).
    #[cfg_attr(feature = "cli", arg(long))]
    pub bloom_downsample: Option<u32>,
    /// Blur radius in pixels, 1 to 64 (default 6).
    #[cfg_attr(feature = "cli", arg(long))]
    pub bloom_radius: Option<u32>,
    /// Blur sigma in pixels (default 3).
    #[cfg_attr(feature = "cli", arg(long))]
    pub bloom_sigma: Option<f64>,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub brightness: f64,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub contrast: f64,
    #[cfg_attr(feature = "cli", arg(long, default_value_t = 1.0))]
    pub saturation: f64,
    /// Encode with a 1/γ power instead of the sRGB OETF.
    #[cfg_attr(feature = "cli", arg(long))]
    pub gamma: Option<f64>,
    /// The display: sdr (8-bit, the sRGB transfer or --gamma), or pq or hlg
    /// (a 16-bit BT.2100 PNG, for an operator that maps onto a display of
    /// known peak: bt2390).
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "sdr"))]
    pub display: Display,
}

impl Default for ToneSettings {
    fn default() -> Self {
        ToneSettings {
            preset: None,
            operator: crate::operators::REINHARD_GLOBAL.to_owned(),
            params: OperatorParams::default(),
            bloom: 0.0,
            bloom_pass: None,
            bloom_threshold: None,
            bloom_downsample: None,
            bloom_radius: None,
            bloom_sigma: None,
            brightness: 1.0,
            contrast: 1.0,
            saturation: 1.0,
            gamma: None,
            display: Display::Sdr,
        }
    }
}

/// Validated settings, ready to become a [`Pipeline`].
#[derive(Clone, Debug)]
pub struct Resolved {
    pub operator: Operator,
    pub bloom: Option<Bloom>,
    pub grade: Grade,
    pub encoding: Encoding,
    /// The PQ or HLG output; `None` for SDR.
    pub hdr: Option<HdrOutput>,
}

impl Resolved {
    /// What the tone-map is asked for: the HDR image for PQ or HLG, else
    /// `kind` (what the output file's name asks for), refusing a PQ or HLG
    /// output to anything but a PNG.
    pub fn output_kind(&self, kind: OutputKind) -> Result<OutputKind> {
        match (self.hdr, kind) {
            (None, kind) => Ok(kind),
            (Some(hdr), OutputKind::Encoded) => Ok(OutputKind::Hdr(hdr)),
            (Some(hdr), _) => Err(invalid(format!(
                "display {}: writes a 16-bit PNG; name the output .png (an .exr, .hdr or .pfm output is the display-referred image, with --display sdr)",
                hdr.display.as_str()
            ))),
        }
    }

    pub fn pipeline(&self) -> Pipeline<'_> {
        Pipeline {
            operator: &self.operator,
            bloom: self.bloom.as_ref(),
            grade: Some(&self.grade),
            encoding: self.encoding,
        }
    }
}

fn invalid(msg: impl Into<String>) -> Error {
    Error::Invalid(msg.into())
}

fn positive(name: &str, v: f64) -> Result<Positive> {
    Positive::try_from(v).map_err(|e| invalid(format!("{name}: {e}")))
}

fn non_negative(name: &str, v: f64) -> Result<NonNegative> {
    NonNegative::try_from(v).map_err(|e| invalid(format!("{name}: {e}")))
}

impl ToneSettings {
    /// The default settings with operator `name` and its parameters as
    /// text (as flags or query parameters give them).
    pub fn for_operator(name: &str, params: &[(&str, &str)]) -> ToneSettings {
        let mut s = ToneSettings {
            operator: name.to_owned(),
            ..Default::default()
        };
        for (n, v) in params {
            s.params.set(n, v);
        }
        s
    }

    /// Checks every value and builds the operator, bloom, grade and encoding;
    /// the error names the parameter and what it must be.
    pub fn resolve(&self) -> Result<Resolved> {
        let operator = self.operator()?;
        let hdr = self.display.hdr_output(&operator).map_err(invalid)?;
        if let (Some(_), Some(_)) = (hdr, self.gamma) {
            return Err(invalid(format!(
                "gamma: applies to SDR output only; display {} has its own transfer",
                self.display.as_str()
            )));
        }
        let resolved = Resolved {
            operator,
            hdr,
            bloom: self.bloom()?,
            grade: Grade {
                brightness: non_negative("brightness", self.brightness)?,
                contrast: non_negative("contrast", self.contrast)?,
                saturation: non_negative("saturation", self.saturation)?,
            },
            encoding: match self.gamma {
                Some(g) => Encoding::Gamma(positive("gamma", g)?),
                None => Encoding::Srgb,
            },
        };
        // The bounds both renderers share (docs/display.md#limits), named as
        // the flags and parameters name them.
        let named = |(key, msg): (&str, String)| {
            let name = match key {
                "strength" => "bloom",
                "threshold" => "bloom_threshold",
                "sigma" => "bloom_sigma",
                k => k,
            };
            invalid(format!("{name}: {msg}"))
        };
        if let Some(b) = &resolved.bloom {
            b.check().map_err(named)?;
        }
        resolved.grade.check().map_err(named)?;
        resolved.encoding.check().map_err(named)?;
        Ok(resolved)
    }

    /// The operator: each value checked (and named in the error) whether
    /// or not it applies, then [`Operator::from_text`] decides what applies
    /// to which operator, the defaults and the ranges.
    fn operator(&self) -> Result<Operator> {
        let def = operators::find(&self.operator).ok_or_else(|| {
            invalid(format!(
                "operator: unknown operator {:?}; expected one of {}",
                self.operator,
                operators::names().join(", ")
            ))
        })?;
        let Some(preset) = self.preset else {
            return Operator::from_text(def, &self.params.0).map_err(|e| invalid(e.to_string()));
        };
        // The preset is the operator: another one named beside it is a
        // conflict, not something to drop without a word.
        if self.operator != ToneSettings::default().operator && def.name() != preset.as_str() {
            return Err(invalid(format!(
                "operator: the preset {} is the operator; leave out operator {:?}",
                preset.as_str(),
                self.operator
            )));
        }
        if let Some((name, _)) = self.params.0.iter().find(|(n, _)| n != "key") {
            return Err(invalid(format!(
                "{name}: the preset {} fixes the operator's parameters; give only key",
                preset.as_str()
            )));
        }
        let key = match self.params.0.iter().find(|(n, _)| n == "key") {
            None => DEFAULT_KEY,
            Some((_, text)) if text.trim() == "auto" => {
                return Err(invalid(format!(
                    "key: the preset {} needs a number",
                    preset.as_str()
                )))
            }
            Some((_, text)) => text
                .trim()
                .parse::<f64>()
                .map_err(|_| invalid(format!("key: expected a number, got {text:?}")))?,
        };
        match preset {
            Preset::Reinhard02 => {
                operators::reinhard02_preset(key).map_err(|e| invalid(e.to_string()))
            }
        }
    }

    /// These settings with the bloom's refinements filled in with the values
    /// in effect (the defaults where not given) when there is a bloom: what
    /// a report echoes.
    pub fn in_effect(&self) -> ToneSettings {
        let mut s = self.clone();
        if s.bloom != 0.0 {
            s.bloom_pass.get_or_insert(BrightPass::Scaled);
            s.bloom_threshold.get_or_insert(1.0);
            s.bloom_downsample.get_or_insert(2);
            s.bloom_radius.get_or_insert(6);
            s.bloom_sigma.get_or_insert(3.0);
        }
        s
    }

    /// The bloom, None at strength 0. A refinement (`bloom_pass`, …) given
    /// without a bloom is refused rather than ignored, and each is checked
    /// either way (a bad radius is a mistake even while bloom is off).
    fn bloom(&self) -> Result<Option<Bloom>> {
        let given = [
            ("bloom_pass", self.bloom_pass.is_some()),
            ("bloom_threshold", self.bloom_threshold.is_some()),
            ("bloom_downsample", self.bloom_downsample.is_some()),
            ("bloom_radius", self.bloom_radius.is_some()),
            ("bloom_sigma", self.bloom_sigma.is_some()),
        ];
        let bloom = Bloom {
            bright_pass: self.bloom_pass.unwrap_or(BrightPass::Scaled),
            threshold: non_negative("bloom_threshold", self.bloom_threshold.unwrap_or(1.0))?,
            downsample: Factor::try_from(self.bloom_downsample.unwrap_or(2))
                .map_err(|e| invalid(format!("bloom_downsample: {e}")))?,
            radius: Radius::try_from(self.bloom_radius.unwrap_or(6))
                .map_err(|e| invalid(format!("bloom_radius: {e}")))?,
            sigma: positive("bloom_sigma", self.bloom_sigma.unwrap_or(3.0))?,
            strength: non_negative("bloom", self.bloom)?,
        };
        if self.bloom == 0.0 {
            if let Some((name, _)) = given.iter().find(|(_, set)| *set) {
                return Err(invalid(format!(
                    "{name}: refines a bloom, and bloom (its strength) is 0; give bloom > 0 too, or leave {name} out"
                )));
            }
            return Ok(None);
        }
        Ok(Some(bloom))
    }
}

#[cfg(test)]
#[path = "settings_tests.rs"]
mod tests;
