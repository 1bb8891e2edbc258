//! The knobs of a flat tone-map, shared by the `tonemap` command's flags and
//! `POST /tonemap`'s parameters (one definition, so the two cannot drift),
//! and their resolution into an operator, bloom, grade and encoding.

use super::display::{Display, HdrOutput};
use super::operator_params::OperatorParams;
use super::OutputKind;
use crate::error::{Error, Result};
use crate::operators;
use crate::reference::Pipeline;
use crate::scene::{
    Bloom, BrightPass, Encoding, Factor, Grade, NonNegative, Operator, Positive, Radius,
    DEFAULT_KEY,
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
    /// A preset that fixes the operator (overrides --operator and its parameters but key).
    #[cfg_attr(feature = "cli", arg(long, value_enum))]
    pub preset: Option<Preset>,
    /// The operator (`tonegate operators` lists them with their parameters).
    #[cfg_attr(feature = "cli", arg(long, default_value = "reinhard-global"))]
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
            operator: "reinhard-global".to_owned(),
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
            return Operator::from_text(def, &self.params.0).map_err(invalid);
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
            Preset::Reinhard02 => operators::reinhard02_preset(key).map_err(invalid),
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
        let mut s = ToneSettings::default();
        s.params.set("white_fraction", 1.5);
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains("white_fraction") && e.contains("1.5"), "{e}");
        let mut s = ToneSettings::default();
        s.params.set("key", "bright");
        assert!(s.resolve().unwrap_err().to_string().contains("key"));
        let s = ToneSettings {
            operator: "reinhard-glob".into(),
            ..Default::default()
        };
        let e = s.resolve().unwrap_err().to_string();
        assert!(
            e.contains("unknown operator") && e.contains("reinhard02"),
            "{e}"
        );
        let mut s = ToneSettings::default();
        s.params.set("kee", 0.2);
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains("unknown parameter \"kee\""), "{e}");
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
            op: &str,
            given: &[(&str, &str)],
            preset: Option<Preset>,
        ) -> std::result::Result<(), String> {
            let mut s = ToneSettings {
                operator: op.to_owned(),
                preset,
                ..Default::default()
            };
            for (n, v) in given {
                s.params.set(n, v);
            }
            s.resolve().map(|_| ()).map_err(|e| e.to_string())
        }
        for op in ["reinhard-global", "reinhard-auto-key", "reinhard02"] {
            for bad in ["-1", "0", "inf", "NaN"] {
                for name in ["white", "log_average", "white_fraction"] {
                    let e = with(op, &[(name, bad)], None).unwrap_err();
                    assert!(e.starts_with(&format!("{name}:")), "{op} {bad}: {e}");
                }
            }
        }
        let e = with("reinhard-global", &[("white", "4")], None).unwrap_err();
        assert!(
            e.contains("white: applies to operator reinhard02 only, not reinhard-global"),
            "{e}"
        );
        let e = with("reinhard02", &[("white_fraction", "0.5")], None).unwrap_err();
        assert!(
            e.contains("applies to operator reinhard-global only"),
            "{e}"
        );
        let e = with("reinhard-auto-key", &[("log_average", "0.2")], None).unwrap_err();
        assert!(e.contains("reinhard-global and reinhard02"), "{e}");
        let e = with("reinhard-global", &[("key", "auto")], None).unwrap_err();
        assert!(e.contains("reinhard-auto-key only"), "{e}");
        let e = with(
            "reinhard-global",
            &[("white", "4")],
            Some(Preset::Reinhard02),
        )
        .unwrap_err();
        assert!(e.contains("preset reinhard02"), "{e}");
        with("reinhard02", &[("white", "4")], None).unwrap();
        with("reinhard-global", &[("white_fraction", "0.5")], None).unwrap();
        with("reinhard-global", &[("log_average", "0.2")], None).unwrap();
    }

    #[test]
    fn values_the_gpu_cannot_carry_are_refused_by_name() {
        type Set = fn(&mut ToneSettings);
        let cases: [(&str, Set); 6] = [
            ("bloom", |s| s.bloom = 1e39),
            ("brightness", |s| s.brightness = 3.5e38),
            ("contrast", |s| s.contrast = 101.0),
            ("saturation", |s| s.saturation = 1e6),
            ("gamma", |s| s.gamma = Some(1e-40)),
            ("bloom_sigma", |s| {
                s.bloom = 0.5;
                s.bloom_sigma = Some(1e7)
            }),
        ];
        for (name, set) in cases {
            let mut s = ToneSettings::default();
            set(&mut s);
            let e = s.resolve().unwrap_err().to_string();
            assert!(e.contains(&format!("{name}: must be")), "{name}: {e}");
        }
        // The ends of the ranges are taken.
        let s = ToneSettings {
            bloom: 100.0,
            contrast: 100.0,
            gamma: Some(0.1),
            ..ToneSettings::default()
        };
        assert!(s.resolve().is_ok());
    }

    #[test]
    fn a_preset_beside_another_operator_is_refused() {
        let with = |operator: &str| ToneSettings {
            preset: Some(Preset::Reinhard02),
            operator: operator.to_owned(),
            ..ToneSettings::default()
        };
        let e = with("agx").operator().unwrap_err().to_string();
        assert!(
            e.contains("operator") && e.contains("preset reinhard02") && e.contains("agx"),
            "{e}"
        );
        // Naming the preset's own operator, or none, is no conflict.
        assert!(with("reinhard02").operator().is_ok());
        assert!(with("reinhard-global").operator().is_ok());
    }

    /// The preset is pfstmo_reinhard02's operator with the key given, and
    /// the key alone.
    #[test]
    fn the_preset_takes_a_key_and_nothing_else() {
        let mut s = ToneSettings {
            preset: Some(Preset::Reinhard02),
            ..Default::default()
        };
        s.params.set("key", 0.3);
        let op = s.resolve().unwrap().operator;
        assert_eq!(op, crate::operators::reinhard02_preset(0.3).unwrap());
        assert!(op.values().flag("pfs_compatible"));
        s.params.set("key", "auto");
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains("preset reinhard02 needs a number"), "{e}");
    }
}
