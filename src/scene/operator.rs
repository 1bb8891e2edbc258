//! The tone-mapping operator and its colour path (SPEC §3).

use super::units::Positive;
use serde::{Deserialize, Serialize};

/// How tone-mapped luminance is put back into colour (SPEC §3); the two agree
/// to rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum ColourPath {
    /// Scale RGB by Ld/Y (seed 001): cheapest, keeps hue exactly.
    #[default]
    Ratio,
    /// Round-trip through CIE xyY with the sRGB/XYZ matrices (seeds 000, 004).
    Xyy,
}

/// The scene key `a`: a number, or seed 001's automatic key from min/avg/max
/// (written `key = "auto"`).
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

/// A tone-mapping operator: all are global Reinhard 2002 variants (SPEC §3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", try_from = "OperatorTable")]
pub enum Operator {
    /// Seed 000: plain log-average; a white fraction `w` of the scene maximum
    /// burns the brightest areas as `w` falls: Ld = L(1 + L/(w²·Lmax))/(1 + L).
    Seed000 {
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
    /// Seed 001: weighted log-average (w = 1 − e^(−Y)), so large near-black
    /// areas do not drag the exposure up; automatic key; white = scaled Lmax.
    Seed001 { key: Key, colour: ColourPath },
    /// Reinhard 2002 global (pfstmo_reinhard02 without --scales): key a, an
    /// absolute Lwhite, or the maximum scaled luminance when unset.
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

fn default_key() -> Positive {
    Positive(0.18)
}
fn default_white_fraction() -> Positive {
    Positive(0.8)
}

/// The `[operator]` table as written. A flat struct (rather than parsing the
/// enum directly) keeps the TOML parser's line and key in every error; the
/// conversion then refuses keys that do not belong to the chosen kind.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OperatorTable {
    kind: OperatorKind,
    key: Option<Key>,
    white_fraction: Option<Positive>,
    white: Option<Positive>,
    log_average: Option<Positive>,
    max_luminance: Option<Positive>,
    #[serde(default)]
    colour: ColourPath,
    pfs_compatible: Option<bool>,
}

/// Which operator, without its parameters (`kind = "seed001"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum OperatorKind {
    Seed000,
    Seed001,
    Reinhard02,
}

impl OperatorKind {
    /// The name a scene file and the API use.
    pub fn as_str(self) -> &'static str {
        match self {
            OperatorKind::Seed000 => "seed000",
            OperatorKind::Seed001 => "seed001",
            OperatorKind::Reinhard02 => "reinhard02",
        }
    }
}

impl TryFrom<OperatorTable> for Operator {
    type Error = String;
    fn try_from(t: OperatorTable) -> Result<Self, String> {
        let kind = format!("{:?}", t.kind).to_lowercase();
        let refuse = |present: bool, key: &str| -> Result<(), String> {
            if present {
                Err(format!(
                    "key `{key}` does not apply to operator kind `{kind}`"
                ))
            } else {
                Ok(())
            }
        };
        let fixed_key = |k: Option<Key>| -> Result<Positive, String> {
            match k {
                None => Ok(default_key()),
                Some(Key::Fixed(v)) => Ok(v),
                Some(Key::Auto) => Err(format!(
                    "key = \"auto\" is seed 001's automatic key; operator kind `{kind}` needs a number"
                )),
            }
        };
        match t.kind {
            OperatorKind::Seed000 => {
                refuse(t.white.is_some(), "white")?;
                refuse(t.pfs_compatible.is_some(), "pfs_compatible")?;
                Ok(Operator::Seed000 {
                    key: fixed_key(t.key)?,
                    white_fraction: t.white_fraction.unwrap_or_else(default_white_fraction),
                    log_average: t.log_average,
                    max_luminance: t.max_luminance,
                    colour: t.colour,
                })
            }
            OperatorKind::Seed001 => {
                refuse(t.white_fraction.is_some(), "white_fraction")?;
                refuse(t.white.is_some(), "white")?;
                refuse(t.log_average.is_some(), "log_average")?;
                refuse(t.max_luminance.is_some(), "max_luminance")?;
                refuse(t.pfs_compatible.is_some(), "pfs_compatible")?;
                Ok(Operator::Seed001 {
                    key: t.key.unwrap_or(Key::Auto),
                    colour: t.colour,
                })
            }
            OperatorKind::Reinhard02 => {
                refuse(t.white_fraction.is_some(), "white_fraction")?;
                refuse(t.max_luminance.is_some(), "max_luminance")?;
                Ok(Operator::Reinhard02 {
                    key: fixed_key(t.key)?,
                    white: t.white,
                    log_average: t.log_average,
                    colour: t.colour,
                    pfs_compatible: t.pfs_compatible.unwrap_or(false),
                })
            }
        }
    }
}

impl Default for Operator {
    fn default() -> Self {
        Operator::Seed000 {
            key: default_key(),
            white_fraction: default_white_fraction(),
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

    pub fn colour(&self) -> ColourPath {
        match self {
            Operator::Seed000 { colour, .. }
            | Operator::Seed001 { colour, .. }
            | Operator::Reinhard02 { colour, .. } => *colour,
        }
    }
}
