//! The tone-mapping operator and its colour path (docs/operators.md).

use super::units::Positive;
use serde::{Deserialize, Serialize};

/// How tone-mapped luminance is put back into colour (docs/operators.md); the two agree
/// to rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum ColourPath {
    /// Scale RGB by Ld/Y (as the modified Reinhard for training simulators
    /// does, docs/bibliography.md): cheapest, keeps hue exactly.
    #[default]
    Ratio,
    /// Round-trip through CIE xyY with the sRGB/XYZ matrices (as in Reinhard's
    /// global operator in real time and the image-processing lecture, both in
    /// docs/bibliography.md).
    Xyy,
}

/// The scene key `a`: a number, or `reinhard-auto-key`'s automatic key from
/// min/avg/max (written `key = "auto"`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Key {
    Fixed(Positive),
    Auto,
}

impl Serialize for Key {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Key::Fixed(v) => s.serialize_f64(v.get()),
            Key::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct KeyVisitor;
        impl serde::de::Visitor<'_> for KeyVisitor {
            type Value = Key;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number > 0 or \"auto\"")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Key, E> {
                Positive::try_from(v).map(Key::Fixed).map_err(E::custom)
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Key, E> {
                self.visit_f64(v as f64)
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Key, E> {
                if v == "auto" {
                    Ok(Key::Auto)
                } else {
                    Err(E::custom(format!(
                        "expected a number > 0 or \"auto\", got {v:?}"
                    )))
                }
            }
        }
        d.deserialize_any(KeyVisitor)
    }
}

/// A tone-mapping operator: all are global Reinhard 2002 variants
/// (docs/operators.md). A scene file writes it as an `[operator]` table of
/// [`OperatorParams`], which decide what applies to which kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", try_from = "OperatorParams")]
pub enum Operator {
    /// Reinhard's global operator with a white point at a fraction `w` of
    /// the scene maximum: the brightest areas burn as `w` falls;
    /// Ld = L(1 + L/(w²·Lmax))/(1 + L).
    #[serde(rename = "reinhard-global")]
    ReinhardGlobal {
        key: Positive,
        white_fraction: Positive,
        /// Fixed adaptation luminance instead of the measured log-average.
        #[serde(skip_serializing_if = "Option::is_none")]
        log_average: Option<Positive>,
        /// Fixed Lmax instead of the measured maximum.
        #[serde(skip_serializing_if = "Option::is_none")]
        max_luminance: Option<Positive>,
        colour: ColourPath,
    },
    /// Weighted log-average (w = 1 − e^(−Y)), so large near-black areas do
    /// not drag the exposure up; the key follows the scene's spread around
    /// it (automatic); white = the scaled maximum.
    #[serde(rename = "reinhard-auto-key")]
    ReinhardAutoKey { key: Key, colour: ColourPath },
    /// Reinhard 2002 global as pfstmo_reinhard02 without --scales: key a, an
    /// absolute Lwhite, or the maximum scaled luminance when unset.
    #[serde(rename = "reinhard02")]
    Reinhard02 {
        key: Positive,
        #[serde(skip_serializing_if = "Option::is_none")]
        white: Option<Positive>,
        #[serde(skip_serializing_if = "Option::is_none")]
        log_average: Option<Positive>,
        colour: ColourPath,
        /// pfstools' luminance weights and δ = 1e-5 (the `reinhard02` preset).
        pfs_compatible: bool,
    },
}

/// The key every operator with a fixed key defaults to.
pub const DEFAULT_KEY: f64 = 0.18;
/// `reinhard-global`'s default white fraction.
pub const DEFAULT_WHITE_FRACTION: f64 = 0.8;

/// An operator's parameters as a user writes them, each optional: the
/// `[operator]` table of a scene file, and what the `tonemap` flags and API
/// parameters become. [`Operator::try_from`] is the one place that decides
/// which parameter applies to which kind, the defaults, and the ranges. A
/// flat struct (rather than parsing the enum directly) keeps the TOML
/// parser's line and key in every error.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OperatorParams {
    pub kind: OperatorKind,
    pub key: Option<Key>,
    pub white_fraction: Option<Positive>,
    pub white: Option<Positive>,
    pub log_average: Option<Positive>,
    pub max_luminance: Option<Positive>,
    #[serde(default)]
    pub colour: ColourPath,
    pub pfs_compatible: Option<bool>,
}

/// Which operator, without its parameters (`kind = "reinhard-auto-key"`).
/// The names the first versions used (`seed000`, `seed001`, after the papers
/// they came from) are still accepted everywhere.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum OperatorKind {
    #[default]
    #[serde(rename = "reinhard-global", alias = "seed000")]
    #[cfg_attr(feature = "cli", value(name = "reinhard-global", alias = "seed000"))]
    ReinhardGlobal,
    #[serde(rename = "reinhard-auto-key", alias = "seed001")]
    #[cfg_attr(feature = "cli", value(name = "reinhard-auto-key", alias = "seed001"))]
    ReinhardAutoKey,
    #[serde(rename = "reinhard02")]
    #[cfg_attr(feature = "cli", value(name = "reinhard02"))]
    Reinhard02,
}

impl OperatorKind {
    /// The name a scene file and the API use.
    pub fn as_str(self) -> &'static str {
        match self {
            OperatorKind::ReinhardGlobal => "reinhard-global",
            OperatorKind::ReinhardAutoKey => "reinhard-auto-key",
            OperatorKind::Reinhard02 => "reinhard02",
        }
    }

    /// The kinds a parameter applies to.
    fn taking(param: &str) -> &'static [OperatorKind] {
        use OperatorKind::*;
        match param {
            "white_fraction" | "max_luminance" => &[ReinhardGlobal],
            "white" | "pfs_compatible" => &[Reinhard02],
            "log_average" => &[ReinhardGlobal, Reinhard02],
            _ => &[ReinhardGlobal, ReinhardAutoKey, Reinhard02],
        }
    }
}

impl TryFrom<OperatorParams> for Operator {
    type Error = String;
    fn try_from(t: OperatorParams) -> Result<Self, String> {
        let kind = t.kind;
        let applies = |present: bool, param: &str| -> Result<(), String> {
            let to = OperatorKind::taking(param);
            if present && !to.contains(&kind) {
                let names: Vec<_> = to.iter().map(|k| k.as_str()).collect();
                return Err(format!(
                    "{param}: applies to operator {} only, not {}",
                    names.join(" and "),
                    kind.as_str()
                ));
            }
            Ok(())
        };
        applies(t.white_fraction.is_some(), "white_fraction")?;
        applies(t.max_luminance.is_some(), "max_luminance")?;
        applies(t.white.is_some(), "white")?;
        applies(t.pfs_compatible.is_some(), "pfs_compatible")?;
        applies(t.log_average.is_some(), "log_average")?;
        let fixed_key = |k: Option<Key>| -> Result<Positive, String> {
            match k {
                None => Ok(Positive(DEFAULT_KEY)),
                Some(Key::Fixed(v)) => Ok(v),
                Some(Key::Auto) => Err(format!(
                    "key: \"auto\" applies to operator reinhard-auto-key only; {} needs a number",
                    kind.as_str()
                )),
            }
        };
        Ok(match kind {
            OperatorKind::ReinhardGlobal => {
                let white_fraction = t.white_fraction.unwrap_or(Positive(DEFAULT_WHITE_FRACTION));
                if white_fraction.get() > 1.0 {
                    return Err(format!(
                        "white_fraction: must be in (0, 1], got {}",
                        white_fraction.get()
                    ));
                }
                Operator::ReinhardGlobal {
                    key: fixed_key(t.key)?,
                    white_fraction,
                    log_average: t.log_average,
                    max_luminance: t.max_luminance,
                    colour: t.colour,
                }
            }
            OperatorKind::ReinhardAutoKey => Operator::ReinhardAutoKey {
                key: t.key.unwrap_or(Key::Auto),
                colour: t.colour,
            },
            OperatorKind::Reinhard02 => Operator::Reinhard02 {
                key: fixed_key(t.key)?,
                white: t.white,
                log_average: t.log_average,
                colour: t.colour,
                pfs_compatible: t.pfs_compatible.unwrap_or(false),
            },
        })
    }
}

impl Default for Operator {
    fn default() -> Self {
        Operator::ReinhardGlobal {
            key: Positive(DEFAULT_KEY),
            white_fraction: Positive(DEFAULT_WHITE_FRACTION),
            log_average: None,
            max_luminance: None,
            colour: ColourPath::Ratio,
        }
    }
}

impl Operator {
    /// pfstmo_reinhard02's global mode with the given key.
    pub fn reinhard02_preset(key: f64) -> Result<Self, String> {
        Ok(Operator::Reinhard02 {
            key: Positive::try_from(key)?,
            white: None,
            log_average: None,
            colour: ColourPath::Ratio,
            pfs_compatible: true,
        })
    }

    pub fn kind(&self) -> OperatorKind {
        match self {
            Operator::ReinhardGlobal { .. } => OperatorKind::ReinhardGlobal,
            Operator::ReinhardAutoKey { .. } => OperatorKind::ReinhardAutoKey,
            Operator::Reinhard02 { .. } => OperatorKind::Reinhard02,
        }
    }

    pub fn colour(&self) -> ColourPath {
        match self {
            Operator::ReinhardGlobal { colour, .. }
            | Operator::ReinhardAutoKey { colour, .. }
            | Operator::Reinhard02 { colour, .. } => *colour,
        }
    }
}
