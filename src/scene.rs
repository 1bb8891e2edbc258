//! Scene scripts (TOML): what to render, how to tone-map it and what the gate checks.
//!
//! Every struct denies unknown keys, and every range rule lives in a validated
//! type (`try_from`), so the TOML parser reports a bad value with its key and
//! line, exactly like a typo.

use crate::env::BuiltinEnv;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Largest output frame a scene may ask for (both renderers allocate it).
pub const MAX_OUTPUT_PIXELS: u64 = 64 * 1024 * 1024;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read scene file: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// TOML syntax, an unknown key, a missing key or a value out of range; the
    /// message carries the line, the column and the key.
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    /// A rule that spans several keys.
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

/// A positive, finite number.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "f64", into = "f64")]
pub struct Positive(f64);

impl TryFrom<f64> for Positive {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && v > 0.0 {
            Ok(Self(v))
        } else {
            Err(format!("must be a finite number > 0, got {v}"))
        }
    }
}

impl From<Positive> for f64 {
    fn from(v: Positive) -> f64 {
        v.0
    }
}

impl Positive {
    pub fn get(self) -> f64 {
        self.0
    }
}

/// A finite number ≥ 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "f64", into = "f64")]
pub struct NonNegative(f64);

impl TryFrom<f64> for NonNegative {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && v >= 0.0 {
            Ok(Self(v))
        } else {
            Err(format!("must be a finite number >= 0, got {v}"))
        }
    }
}

impl From<NonNegative> for f64 {
    fn from(v: NonNegative) -> f64 {
        v.0
    }
}

impl NonNegative {
    pub fn get(self) -> f64 {
        self.0
    }
}

/// A width×height pair, written `[w, h]`; both ≥ 1 and the product bounded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "[u32; 2]", into = "[u32; 2]")]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

impl TryFrom<[u32; 2]> for Size {
    type Error = String;
    fn try_from([width, height]: [u32; 2]) -> Result<Self, String> {
        if width == 0 || height == 0 {
            return Err(format!("size must be at least 1x1, got {width}x{height}"));
        }
        if width as u64 * height as u64 > MAX_OUTPUT_PIXELS {
            return Err(format!(
                "size {width}x{height} exceeds the limit of {MAX_OUTPUT_PIXELS} pixels"
            ));
        }
        Ok(Self { width, height })
    }
}

impl From<Size> for [u32; 2] {
    fn from(s: Size) -> [u32; 2] {
        [s.width, s.height]
    }
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (w, h) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("expected WxH, got {s:?}"))?;
        let parse = |t: &str| {
            t.trim()
                .parse::<u32>()
                .map_err(|_| format!("expected WxH with whole numbers, got {s:?}"))
        };
        Size::try_from([parse(w)?, parse(h)?])
    }
}

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
    /// Axis of rotation; default the horizontal x axis, as in seed 000.
    #[serde(default = "default_axis")]
    pub axis: [f64; 3],
    /// ω, degrees per frame; 0 makes a static sequence.
    pub degrees_per_frame: f64,
}

fn default_axis() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}

/// How tone-mapped luminance is put back into colour (SPEC §3); the two agree
/// to rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
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

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
enum OperatorKind {
    Seed000,
    Seed001,
    Reinhard02,
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

/// Which pixels feed the bloom.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BrightPass {
    /// Seed 001: HDR colour scaled by Y/Lmax where Y > threshold (Y in scene
    /// units): a sun spreads, a lamp-lit wall does not.
    #[default]
    Seed001,
    /// Seed 004: the tone-mapped colour where its Y > threshold (display units,
    /// e.g. 0.8), else 0.
    Threshold,
}

/// Bloom (SPEC §4): bright pass, downsample, separable Gaussian, composite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bloom {
    #[serde(default)]
    pub bright_pass: BrightPass,
    pub threshold: NonNegative,
    /// Downsample factor 2..=8 (seed 001 uses 2, seed 004 suggests 8).
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

/// Bloom downsample factor, 2..=8.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "u32", into = "u32")]
pub struct Factor(u32);

impl TryFrom<u32> for Factor {
    type Error = String;
    fn try_from(v: u32) -> Result<Self, String> {
        if (2..=8).contains(&v) {
            Ok(Self(v))
        } else {
            Err(format!("must be between 2 and 8, got {v}"))
        }
    }
}

impl From<Factor> for u32 {
    fn from(v: Factor) -> u32 {
        v.0
    }
}

impl Factor {
    pub fn get(self) -> u32 {
        self.0
    }
}

/// Gaussian radius in pixels, 1..=64.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "u32", into = "u32")]
pub struct Radius(u32);

impl TryFrom<u32> for Radius {
    type Error = String;
    fn try_from(v: u32) -> Result<Self, String> {
        if (1..=64).contains(&v) {
            Ok(Self(v))
        } else {
            Err(format!("must be between 1 and 64, got {v}"))
        }
    }
}

impl From<Radius> for u32 {
    fn from(v: Radius) -> u32 {
        v.0
    }
}

impl Radius {
    pub fn get(self) -> u32 {
        self.0
    }
}

/// Seed 004's colour grade on the display-referred image.
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

impl Grade {
    /// A neutral grade changes nothing, so the plan leaves it out.
    pub fn is_neutral(&self) -> bool {
        self.brightness.0 == 1.0 && self.contrast.0 == 1.0 && self.saturation.0 == 1.0
    }
}

/// Display encoding of the final 8-bit frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Encoding {
    /// The sRGB OETF (piecewise: linear below 0.0031308).
    #[default]
    Srgb,
    /// A plain 1/γ power, γ default 2.2 (seed 004).
    Gamma(Positive),
}

/// A typed comparison the gate applies to every frame (against its golden).
/// Each may name the adapter that set it; adapter-specific overrides come as
/// further checks with `adapter` set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    #[serde(flatten)]
    pub check: Check,
    /// Adapter name substring this bound applies to; none = every adapter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adapter: Option<String>,
    /// Samples per pixel of the render this bound is for; none = the scene's
    /// `reference_spp` (the goldens' own, a like-for-like comparison). A
    /// bound for `spp = 1` measures the plain path's aliasing instead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp: Option<u32>,
    /// Who or what set the bound, e.g. "llvmpipe 1 spp vs 16 spp, 2026-11-21".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set_by: Option<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Check {
    MinPsnr(f64),
    MinSsim(f64),
    MaxMse(f64),
    MaxAbsDiff(u8),
    /// At most `fraction` of pixels may be off by more than `lsb`.
    MaxFractionOver {
        lsb: u8,
        fraction: f64,
    },
    MaxStageMs {
        stage: String,
        ms: f64,
    },
    MinFps(f64),
}

/// One scene script.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub name: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    pub environment: Environment,
    /// Output frame size.
    pub size: Size,
    /// Vertical field of view, degrees, in (0, 180).
    #[serde(default = "default_fov")]
    pub fov_y: f64,
    pub frames: u32,
    pub rotation: Rotation,
    #[serde(default)]
    pub operator: Operator,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bloom: Option<Bloom>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grade: Option<Grade>,
    #[serde(default)]
    pub encoding: Encoding,
    /// Samples per pixel of the reference (accumulation buffer), 1..=128.
    #[serde(default = "default_spp")]
    pub reference_spp: u32,
    #[serde(default)]
    pub checks: Vec<CheckSpec>,
}

fn default_fov() -> f64 {
    60.0
}
fn default_spp() -> u32 {
    16
}

/// Largest frame count of one sequence.
pub const MAX_FRAMES: u32 = 10_000;
/// Largest reference supersampling (SPEC §5).
pub const MAX_SPP: u32 = 128;

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            path: path.to_owned(),
            source,
        })?;
        Scene::parse(&text, path)
    }

    /// Parses and validates scene text; `path` names it in errors and anchors
    /// a relative environment path.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
        let mut scene: Scene = toml::from_str(text).map_err(|e| SceneError::Parse {
            path: path.to_owned(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        scene
            .validate(text)
            .map_err(|message| SceneError::Invalid {
                path: path.to_owned(),
                message,
            })?;
        if let Some(p) = &scene.environment.path {
            if p.is_relative() {
                if let Some(dir) = path.parent() {
                    scene.environment.path = Some(dir.join(p));
                }
            }
        }
        Ok(scene)
    }

    /// Cross-key rules, each message naming the key and its line.
    fn validate(&self, text: &str) -> Result<(), String> {
        let at = |key: &str| match line_of(text, key) {
            Some(l) => format!("line {l}, key `{key}`"),
            None => format!("key `{key}`"),
        };
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(format!(
                "{}: name must be non-empty ASCII letters, digits, '-' or '_' (it names golden folders), got {:?}",
                at("name"),
                self.name
            ));
        }
        match (&self.environment.builtin, &self.environment.path) {
            (Some(_), Some(_)) | (None, None) => {
                return Err(format!(
                    "{}: give exactly one of `builtin` or `path`",
                    at("environment")
                ))
            }
            (None, Some(_)) if self.environment.size.is_some() => {
                return Err(format!(
                    "{}: `size` applies to built-in maps only; a file has its own size",
                    at("size")
                ))
            }
            _ => {}
        }
        if !(self.fov_y > 0.0 && self.fov_y < 180.0) {
            return Err(format!(
                "{}: must be in (0, 180) degrees, got {}",
                at("fov_y"),
                self.fov_y
            ));
        }
        if self.frames == 0 || self.frames > MAX_FRAMES {
            return Err(format!(
                "{}: must be between 1 and {MAX_FRAMES}, got {}",
                at("frames"),
                self.frames
            ));
        }
        let a = self.rotation.axis;
        if !a.iter().all(|c| c.is_finite()) || a.iter().all(|&c| c == 0.0) {
            return Err(format!("{}: must be a finite non-zero vector", at("axis")));
        }
        if !self.rotation.degrees_per_frame.is_finite() {
            return Err(format!("{}: must be finite", at("degrees_per_frame")));
        }
        if self.reference_spp == 0 || self.reference_spp > MAX_SPP {
            return Err(format!(
                "{}: must be between 1 and {MAX_SPP}, got {}",
                at("reference_spp"),
                self.reference_spp
            ));
        }
        if let Operator::Seed000 { white_fraction, .. } = &self.operator {
            if white_fraction.get() > 1.0 {
                return Err(format!(
                    "{}: must be in (0, 1], got {}",
                    at("white_fraction"),
                    white_fraction.get()
                ));
            }
        }
        for c in &self.checks {
            if let Some(n) = c.spp.filter(|&n| n == 0 || n > MAX_SPP) {
                return Err(format!(
                    "{}: spp must be between 1 and {MAX_SPP}, got {n}",
                    at("checks")
                ));
            }
            let ok = match &c.check {
                Check::MinPsnr(v) | Check::MaxMse(v) | Check::MinFps(v) => !v.is_nan(),
                Check::MinSsim(v) => v.is_finite() && (-1.0..=1.0).contains(v),
                Check::MaxFractionOver { fraction, .. } => (0.0..=1.0).contains(fraction),
                Check::MaxStageMs { ms, .. } => ms.is_finite() && *ms > 0.0,
                Check::MaxAbsDiff(_) => true,
            };
            if !ok {
                return Err(format!(
                    "{}: bound out of range in {:?}",
                    at("checks"),
                    c.check
                ));
            }
        }
        Ok(())
    }

    /// SHA-256 of the canonical form (JSON of the parsed scene): formatting and
    /// comments do not change it, any parameter does.
    pub fn hash(&self) -> String {
        let canonical = serde_json::to_vec(self).unwrap_or_default();
        hex::encode(Sha256::digest(&canonical))
    }

    /// The rotation angle of frame `n`, in radians.
    pub fn angle(&self, n: u32) -> f64 {
        (n as f64 * self.rotation.degrees_per_frame).to_radians()
    }

    /// A static scene (ω = 0) renders the same frame every time.
    pub fn is_static(&self) -> bool {
        self.rotation.degrees_per_frame == 0.0
    }
}

/// 1-based line of the first `key =` or `[key` in `text`.
fn line_of(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            let t = l.trim_start();
            t.strip_prefix(key)
                .map(|rest| rest.trim_start().starts_with('='))
                .unwrap_or(false)
                || t.starts_with(&format!("[{key}]"))
        })
        .map(|i| i + 1)
}

/// A suite: an ordered list of scene files and how the gate treats performance.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteFile {
    scenes: Vec<PathBuf>,
    #[serde(default)]
    performance: Performance,
    /// Run the stress suite (extreme inputs, `tonegate stress`) as part of `check`.
    #[serde(default)]
    stress: bool,
}

/// How `check` compares this run's speed with the history (nightly
/// regressions): a value is flagged when it is worse than the median of the
/// previous `window` runs on the same adapter by more than
/// `max(mads · 1.4826 · MAD, min_relative · median)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Performance {
    /// Previous runs the median is taken over.
    #[serde(default = "default_window")]
    pub window: u32,
    /// Fewest previous runs before anything is flagged.
    #[serde(default = "default_min_runs")]
    pub min_runs: u32,
    /// Robust standard deviations (1.4826·MAD) a value may stray.
    #[serde(default = "default_mads")]
    pub mads: f64,
    /// Smallest flagged change relative to the median, so a perfectly steady
    /// history (MAD 0) does not flag every nanosecond.
    #[serde(default = "default_min_relative")]
    pub min_relative: f64,
    /// Make flagged regressions fail the gate (exit 1, JUnit failures).
    #[serde(default)]
    pub fail_on_regression: bool,
}

fn default_window() -> u32 {
    10
}
fn default_min_runs() -> u32 {
    3
}
fn default_mads() -> f64 {
    4.0
}
fn default_min_relative() -> f64 {
    0.10
}

impl Default for Performance {
    fn default() -> Self {
        Performance {
            window: default_window(),
            min_runs: default_min_runs(),
            mads: default_mads(),
            min_relative: default_min_relative(),
            fail_on_regression: false,
        }
    }
}

/// A loaded suite: its scenes, in order, and its performance policy.
#[derive(Clone, Debug)]
pub struct Suite {
    pub scenes: Vec<Scene>,
    pub performance: Performance,
    /// `check` runs the stress suite too.
    pub stress: bool,
    /// SHA-256 of the scenes' canonical forms and the policy: two runs with the
    /// same hash ran the same gate.
    pub hash: String,
}

/// Loads every scene a suite file lists (paths relative to the suite file).
pub fn load_suite(path: &Path) -> Result<Vec<Scene>, SceneError> {
    load_suite_file(path).map(|s| s.scenes)
}

/// Loads a suite file with its performance policy.
pub fn load_suite_file(path: &Path) -> Result<Suite, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        path: path.to_owned(),
        source,
    })?;
    let suite: SuiteFile = toml::from_str(&text).map_err(|e| SceneError::Parse {
        path: path.to_owned(),
        message: e.to_string().trim_end().to_owned(),
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut scenes: Vec<Scene> = Vec::with_capacity(suite.scenes.len());
    for rel in &suite.scenes {
        let scene = Scene::load(&dir.join(rel))?;
        if scenes.iter().any(|s| s.name == scene.name) {
            return Err(SceneError::Invalid {
                path: path.to_owned(),
                message: format!("two scenes are named {:?}", scene.name),
            });
        }
        scenes.push(scene);
    }
    let p = &suite.performance;
    if p.window == 0
        || p.min_runs == 0
        || !(p.mads.is_finite() && p.mads > 0.0)
        || !(p.min_relative.is_finite() && p.min_relative >= 0.0)
    {
        return Err(SceneError::Invalid {
            path: path.to_owned(),
            message: format!(
                "[performance]: window and min_runs must be at least 1, mads positive and min_relative non-negative, got {p:?}"
            ),
        });
    }
    let mut h = Sha256::new();
    for s in &scenes {
        h.update(s.hash());
    }
    h.update(serde_json::to_vec(&suite.performance).unwrap_or_default());
    h.update([suite.stress as u8]);
    Ok(Suite {
        scenes,
        performance: suite.performance,
        stress: suite.stress,
        hash: hex::encode(h.finalize()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
name = "t"
size = [32, 18]
frames = 2
[environment]
builtin = "sky"
size = [64, 32]
[rotation]
degrees_per_frame = 5.0
"#;

    fn parse(text: &str) -> Result<Scene, SceneError> {
        Scene::parse(text, Path::new("scene.toml"))
    }

    #[test]
    fn minimal_scene_takes_defaults() {
        let s = parse(MINIMAL).unwrap();
        assert_eq!(s.operator, Operator::default());
        assert_eq!(s.reference_spp, 16);
        assert_eq!(s.fov_y, 60.0);
        assert_eq!(s.rotation.axis, [1.0, 0.0, 0.0]);
        assert_eq!(s.encoding, Encoding::Srgb);
    }

    #[test]
    fn unknown_key_names_key_file_and_line() {
        let text = MINIMAL.replace("frames = 2", "frames = 2\nfrobnicate = 1");
        let e = parse(&text).unwrap_err().to_string();
        assert!(
            e.contains("scene.toml") && e.contains("frobnicate") && e.contains("line 5"),
            "{e}"
        );
    }

    #[test]
    fn unknown_key_in_operator_is_refused() {
        let text = format!("{MINIMAL}\n[operator]\nkind = \"seed000\"\nkee = 0.2\n");
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains("kee") && e.contains("line"), "{e}");
    }

    #[test]
    fn out_of_range_values_name_their_line() {
        let text = format!("{MINIMAL}\n[operator]\nkind = \"reinhard02\"\nkey = -1.0\n");
        let e = parse(&text).unwrap_err().to_string();
        assert!(
            e.contains("must be a finite number > 0") && e.contains("line 13"),
            "{e}"
        );
        let text = MINIMAL.replace("size = [32, 18]", "size = [0, 18]");
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains("at least 1x1") && e.contains("line 3"), "{e}");
        let text = MINIMAL.replace("frames = 2", "frames = 0");
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains("frames") && e.contains("line 4"), "{e}");
        let text = format!("{MINIMAL}\n[operator]\nkind = \"seed000\"\nwhite_fraction = 1.5\n");
        assert!(parse(&text)
            .unwrap_err()
            .to_string()
            .contains("white_fraction"));
        let text = format!("{MINIMAL}\n[operator]\nkind = \"seed001\"\nwhite = 2.0\n");
        let e = parse(&text).unwrap_err().to_string();
        assert!(
            e.contains("`white` does not apply") && e.contains("line 11"),
            "{e}"
        );
        let text = format!("{MINIMAL}\n[operator]\nkind = \"seed000\"\nkey = \"auto\"\n");
        assert!(parse(&text)
            .unwrap_err()
            .to_string()
            .contains("needs a number"));
    }

    #[test]
    fn absurd_output_size_is_refused() {
        let text = MINIMAL.replace("size = [32, 18]", "size = [100000, 100000]");
        assert!(parse(&text)
            .unwrap_err()
            .to_string()
            .contains("exceeds the limit"));
    }

    #[test]
    fn operator_variants_and_auto_key_parse() {
        let text = format!(
            "{MINIMAL}\n[operator]\nkind = \"seed001\"\nkey = \"auto\"\ncolour = \"xyy\"\n"
        );
        let s = parse(&text).unwrap();
        assert_eq!(
            s.operator,
            Operator::Seed001 {
                key: Key::Auto,
                colour: ColourPath::Xyy
            }
        );
        let text = format!("{MINIMAL}\n[operator]\nkind = \"seed001\"\nkey = 0.3\n");
        let s = parse(&text).unwrap();
        assert!(
            matches!(s.operator, Operator::Seed001 { key: Key::Fixed(k), .. } if k.get() == 0.3)
        );
    }

    #[test]
    fn checks_parse_with_adapter_overrides() {
        let text = format!(
            "{MINIMAL}\n[[checks]]\nmin_psnr = 30.0\n[[checks]]\nmin_ssim = 0.9\nadapter = \"llvmpipe\"\nset_by = \"measured\"\n[[checks]]\nmax_fraction_over = {{ lsb = 1, fraction = 0.01 }}\n"
        );
        let s = parse(&text).unwrap();
        assert_eq!(s.checks.len(), 3);
        assert_eq!(s.checks[0].check, Check::MinPsnr(30.0));
        assert_eq!(s.checks[1].adapter.as_deref(), Some("llvmpipe"));
    }

    #[test]
    fn hash_ignores_formatting_but_not_parameters() {
        let a = parse(MINIMAL).unwrap();
        let b = parse(&MINIMAL.replace("frames = 2", "frames   =   2 # two")).unwrap();
        let c = parse(&MINIMAL.replace("frames = 2", "frames = 3")).unwrap();
        assert_eq!(a.hash(), b.hash());
        assert_ne!(a.hash(), c.hash());
    }

    #[test]
    fn environment_needs_exactly_one_source() {
        let text = MINIMAL.replace("builtin = \"sky\"", "");
        assert!(parse(&text)
            .unwrap_err()
            .to_string()
            .contains("exactly one"));
        let text = MINIMAL.replace("builtin = \"sky\"", "builtin = \"moon\"");
        assert!(parse(&text).unwrap_err().to_string().contains("moon"));
    }

    #[test]
    fn size_parses_from_command_line_form() {
        assert_eq!(
            "320x180".parse::<Size>(),
            Ok(Size {
                width: 320,
                height: 180
            })
        );
        assert!("320".parse::<Size>().is_err());
        assert!("0x5".parse::<Size>().is_err());
    }
}
