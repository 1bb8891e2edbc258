//! The knobs of a flat tone-map, shared by the `tonemap` command's flags and
//! `POST /tonemap`'s parameters (one definition, so the two cannot drift),
//! and their resolution into an operator, bloom, grade and encoding.

use crate::error::{Error, Result};
use crate::reference::Pipeline;
use crate::scene::{
    Bloom, BrightPass, ColourPath, Encoding, Factor, Grade, Key, NonNegative, Operator,
    OperatorKind, OperatorParams, Positive, Radius, DEFAULT_KEY,
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
            Preset::Reinhard02 => "reinhard02",
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
    /// A preset that fixes the operator (overrides --operator and --colour).
    #[cfg_attr(feature = "cli", arg(long, value_enum))]
    pub preset: Option<Preset>,
    #[cfg_attr(
        feature = "cli",
        arg(long, value_enum, default_value = "reinhard-global")
    )]
    pub operator: OperatorKind,
    /// Key a (a number, or "auto": reinhard-auto-key's automatic key, its default).
    #[cfg_attr(feature = "cli", arg(long))]
    pub key: Option<String>,
    /// ReinhardGlobal: fraction of the scene maximum that maps to white, (0, 1].
    #[cfg_attr(feature = "cli", arg(long))]
    pub white_fraction: Option<f64>,
    /// reinhard02: absolute Lwhite (default: the maximum scaled luminance).
    #[cfg_attr(feature = "cli", arg(long))]
    pub white: Option<f64>,
    /// Fixed adaptation luminance instead of the measured log-average.
    #[cfg_attr(feature = "cli", arg(long))]
    pub log_average: Option<f64>,
    #[cfg_attr(feature = "cli", arg(long, value_enum, default_value = "ratio"))]
    pub colour: ColourPath,
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
}

impl Default for ToneSettings {
    fn default() -> Self {
        ToneSettings {
            preset: None,
            operator: OperatorKind::ReinhardGlobal,
            key: None,
            white_fraction: None,
            white: None,
            log_average: None,
            colour: ColourPath::Ratio,
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
}

impl Resolved {
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
    /// Checks every value and builds the operator, bloom, grade and encoding;
    /// the error names the parameter and what it must be.
    pub fn resolve(&self) -> Result<Resolved> {
        Ok(Resolved {
            operator: self.operator()?,
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
        })
    }

    /// The operator: each value checked (and named in the error) whether
    /// or not it applies, then [`Operator::try_from`] decides what applies
    /// to which operator, the defaults and the ranges.
    fn operator(&self) -> Result<Operator> {
        let key = match self.key.as_deref() {
            None => None,
            Some("auto") => Some(Key::Auto),
            Some(s) => {
                let v: f64 = s.parse().map_err(|_| {
                    invalid(format!("key: expected a number or \"auto\", got {s:?}"))
                })?;
                Some(Key::Fixed(positive("key", v)?))
            }
        };
        let optional = |name: &str, v: Option<f64>| v.map(|v| positive(name, v)).transpose();
        let params = OperatorParams {
            kind: self.operator,
            key,
            white_fraction: optional("white_fraction", self.white_fraction)?,
            white: optional("white", self.white)?,
            log_average: optional("log_average", self.log_average)?,
            max_luminance: None,
            colour: self.colour,
            pfs_compatible: None,
        };
        if let Some(preset) = self.preset {
            let fixed = [
                ("white", params.white.is_some()),
                ("white_fraction", params.white_fraction.is_some()),
                ("log_average", params.log_average.is_some()),
            ];
            if let Some((name, _)) = fixed.iter().find(|(_, given)| *given) {
                return Err(invalid(format!(
                    "{name}: the preset {} fixes the operator's parameters; give only key",
                    preset.as_str()
                )));
            }
            let key = match params.key {
                None => DEFAULT_KEY,
                Some(Key::Fixed(v)) => v.get(),
                Some(Key::Auto) => {
                    return Err(invalid(format!(
                        "key: the preset {} needs a number",
                        preset.as_str()
                    )))
                }
            };
            return match preset {
                Preset::Reinhard02 => Operator::reinhard02_preset(key).map_err(invalid),
            };
        }
        Operator::try_from(params).map_err(invalid)
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
mod tests {
    use super::*;

    #[cfg(feature = "cli")]
    #[test]
    fn defaults_of_flags_and_api_are_the_same() {
        use clap::Parser;
        #[derive(Parser)]
        struct Flags {
            #[command(flatten)]
            settings: ToneSettings,
        }
        let flags = Flags::try_parse_from(["x"]).unwrap();
        assert_eq!(flags.settings, ToneSettings::default());
        let api: ToneSettings = serde_json::from_str("{}").unwrap();
        assert_eq!(api, ToneSettings::default());
    }

    #[test]
    fn unknown_and_bad_parameters_are_refused_by_name() {
        let e = serde_json::from_str::<ToneSettings>(r#"{"kee": 0.2}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `kee`"), "{e}");
        let s = ToneSettings {
            white_fraction: Some(1.5),
            ..Default::default()
        };
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains("white_fraction") && e.contains("1.5"), "{e}");
        let s = ToneSettings {
            key: Some("bright".into()),
            ..Default::default()
        };
        assert!(s.resolve().unwrap_err().to_string().contains("key"));
        let s = ToneSettings {
            gamma: Some(f64::NAN),
            ..Default::default()
        };
        assert!(s.resolve().unwrap_err().to_string().contains("gamma"));
    }

    /// Found by a hostile client: `bloom_radius=9` without `bloom` was
    /// accepted and did nothing.
    #[test]
    fn a_bloom_refinement_without_a_bloom_is_refused() {
        let s = ToneSettings {
            bloom_radius: Some(9),
            ..Default::default()
        };
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains("bloom_radius: refines a bloom"), "{e}");
        let s = ToneSettings {
            bloom: 0.5,
            bloom_radius: Some(9),
            ..Default::default()
        };
        s.resolve().unwrap();
        // Out of range is refused either way.
        let s = ToneSettings {
            bloom_radius: Some(0),
            ..Default::default()
        };
        assert!(s
            .resolve()
            .unwrap_err()
            .to_string()
            .contains("bloom_radius"));
    }

    /// Found by a hostile client: `white=-1` was ignored under the default
    /// operator but refused under reinhard02.
    #[test]
    fn a_value_is_checked_and_applies_to_its_operator_whatever_the_operator() {
        fn with(
            op: OperatorKind,
            f: impl FnOnce(&mut ToneSettings),
        ) -> std::result::Result<(), String> {
            let mut s = ToneSettings {
                operator: op,
                ..Default::default()
            };
            f(&mut s);
            s.resolve().map(|_| ()).map_err(|e| e.to_string())
        }
        for op in [
            OperatorKind::ReinhardGlobal,
            OperatorKind::ReinhardAutoKey,
            OperatorKind::Reinhard02,
        ] {
            for bad in [-1.0, 0.0, f64::INFINITY, f64::NAN] {
                let e = with(op, |s| s.white = Some(bad)).unwrap_err();
                assert!(e.starts_with("white:"), "{op:?} {bad}: {e}");
                let e = with(op, |s| s.log_average = Some(bad)).unwrap_err();
                assert!(e.starts_with("log_average:"), "{op:?} {bad}: {e}");
                let e = with(op, |s| s.white_fraction = Some(bad)).unwrap_err();
                assert!(e.starts_with("white_fraction:"), "{op:?} {bad}: {e}");
            }
        }
        let e = with(OperatorKind::ReinhardGlobal, |s| s.white = Some(4.0)).unwrap_err();
        assert!(
            e.contains("white: applies to operator reinhard02 only, not reinhard-global"),
            "{e}"
        );
        let e = with(OperatorKind::Reinhard02, |s| s.white_fraction = Some(0.5)).unwrap_err();
        assert!(
            e.contains("applies to operator reinhard-global only"),
            "{e}"
        );
        let e = with(OperatorKind::ReinhardAutoKey, |s| s.log_average = Some(0.2)).unwrap_err();
        assert!(e.contains("reinhard-global and reinhard02"), "{e}");
        let e = with(OperatorKind::ReinhardGlobal, |s| {
            s.key = Some("auto".into())
        })
        .unwrap_err();
        assert!(e.contains("reinhard-auto-key only"), "{e}");
        let e = with(OperatorKind::ReinhardGlobal, |s| {
            s.preset = Some(Preset::Reinhard02);
            s.white = Some(4.0);
        })
        .unwrap_err();
        assert!(e.contains("preset reinhard02"), "{e}");
        with(OperatorKind::Reinhard02, |s| s.white = Some(4.0)).unwrap();
        with(OperatorKind::ReinhardGlobal, |s| {
            s.white_fraction = Some(0.5)
        })
        .unwrap();
        with(OperatorKind::ReinhardGlobal, |s| s.log_average = Some(0.2)).unwrap();
    }
}
