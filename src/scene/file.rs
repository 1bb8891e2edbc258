//! A scene file: its TOML read, checked and hashed into a [`Scene`].

use super::*;
use crate::operators::Operator;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

use crate::check::{CheckSpec, Judging, TestKind};

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read it: {source}")]
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
    /// Temporal anti-aliasing: the scene renders 1 jittered spp per frame
    /// and resolves it against its history (or, `variant = "off"`, the plain
    /// 1-spp frame: the no-AA side of the comparison).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taa: Option<Taa>,
    /// Eye adaptation (docs/adaptation.md): the luminance the operator keys
    /// on follows the frames with a time constant up and down.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptation: Option<Adaptation>,
    /// The sequence's frame rate, for adaptation's time step; 60 when
    /// absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fps: Option<Positive>,
    /// Changes of the light over the sequence (`[[light]]`), in frame order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub light: Vec<LightStep>,
    /// Samples per pixel of the reference (accumulation buffer), 1..=128.
    #[serde(default = "default_spp")]
    pub reference_spp: u32,
    #[serde(default)]
    pub checks: Vec<CheckSpec>,
    /// Known failures on some adapters (`[[expectations]]`): they change how
    /// a result counts, never what is rendered.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub expectations: Vec<crate::check::Expectation>,
}

fn default_fov() -> f64 {
    60.0
}
fn default_spp() -> u32 {
    16
}

/// The largest scene or suite file read, in bytes.
pub const MAX_TEXT_BYTES: u64 = 1 << 20;

/// Reads a scene or suite file: a regular file of at most
/// [`MAX_TEXT_BYTES`] (a path naming `/dev/zero` or a FIFO would otherwise
/// be read forever), in UTF-8.
pub fn read_text(path: &Path) -> Result<String, SceneError> {
    use std::io::Read;
    let read_err = |source| SceneError::Read {
        path: path.to_owned(),
        source,
    };
    let invalid = |message: String| SceneError::Invalid {
        path: path.to_owned(),
        message,
    };
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return Err(invalid("is not a regular file".into()));
    }
    let file = crate::io::open_regular(path).map_err(read_err)?;
    let mut bytes = Vec::new();
    file.take(MAX_TEXT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(read_err)?;
    if bytes.len() as u64 > MAX_TEXT_BYTES {
        return Err(invalid(format!(
            "is larger than {MAX_TEXT_BYTES} bytes; scene and suite files are small TOML"
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        invalid(format!(
            "is not UTF-8 text (byte {} is not valid)",
            e.utf8_error().valid_up_to()
        ))
    })
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::parse(&read_text(path)?, path)
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
                    at("environment.size")
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
        // The bounds the tone-map's flags and API parameters share
        // (docs/display.md#limits).
        let keyed = |table: &str, (key, msg): (&str, String)| {
            format!("{}: {msg}", at(&format!("{table}.{key}")))
        };
        if let Some(b) = &self.bloom {
            b.check().map_err(|e| keyed("bloom", e))?;
        }
        if let Some(g) = &self.grade {
            g.check().map_err(|e| keyed("grade", e))?;
        }
        self.encoding
            .check()
            .map_err(|(k, m)| format!("{}: {m}", at(k)))?;
        if let Some(taa) = &self.taa {
            if self.reference_spp < 2 {
                return Err(format!(
                    "{}: a TAA scene is judged against the accumulation reference, which needs at least 2 samples, got {}",
                    at("reference_spp"),
                    self.reference_spp
                ));
            }
            if taa.feedback_min.get() > taa.feedback_max.get() {
                return Err(format!(
                    "{}: feedback_min {} exceeds feedback_max {}",
                    at("feedback_min"),
                    taa.feedback_min.get(),
                    taa.feedback_max.get()
                ));
            }
            if let Some(n) = taa.reset_frames.iter().find(|&&n| n >= self.frames) {
                return Err(format!(
                    "{}: frame {n} is past the sequence's last frame {}",
                    at("reset_frames"),
                    self.frames - 1
                ));
            }
        }
        let mut after = None;
        // The i-th step's keys are the i-th of their names in the text.
        let at_step = |key: &str, i: usize| match nth_line_of(text, key, i) {
            Some(l) => format!("line {l}, key `{key}`"),
            None => format!("key `{key}`"),
        };
        for (i, step) in self.light.iter().enumerate() {
            let at = |key: &str| at_step(key, i);
            if step.from_frame >= self.frames {
                return Err(format!(
                    "{}: from_frame {} is past the sequence's last frame {}",
                    at("from_frame"),
                    step.from_frame,
                    self.frames - 1
                ));
            }
            if after.is_some_and(|a| step.from_frame <= a) {
                return Err(format!(
                    "{}: the steps must be in increasing frame order, and frame {} comes after {}",
                    at("from_frame"),
                    step.from_frame,
                    after.unwrap_or(0)
                ));
            }
            after = Some(step.from_frame);
            let (lo, hi) = LIGHT_SCALE_RANGE;
            if !(lo..=hi).contains(&step.scale.get()) {
                return Err(format!(
                    "{}: must be in [{lo:e}, {hi:e}], got {}",
                    at("scale"),
                    step.scale.get()
                ));
            }
        }
        if self.encoding == Encoding::Pq && self.operator.display_levels().is_none() {
            return Err(format!(
                "{}: PQ frames are absolute cd/m², and operator {}'s output is relative to an SDR display's white; use an operator that maps onto a display of known peak (bt2390), or encoding \"srgb\"",
                at("encoding"),
                self.operator.name()
            ));
        }
        if let Some(a) = &self.adaptation {
            a.check()
                .map_err(|(key, reason)| format!("{}: {reason}", at(key)))?;
        }
        for c in &self.checks {
            c.validate()
                .map_err(|message| format!("{}: {message}", at("checks")))?;
            if matches!(c.check, crate::check::Check::MaxAdaptationError(_))
                && self.adaptation.is_none()
            {
                return Err(format!(
                    "{}: max_adaptation_error bounds eye adaptation's curve, and the scene has no [adaptation]",
                    at("max_adaptation_error")
                ));
            }
        }
        for (i, e) in self.expectations.iter().enumerate() {
            e.validate().map_err(|message| {
                format!("{} (expectation {}): {message}", at("expectations"), i + 1)
            })?;
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

    /// The light of frame `n`: the scale of the last `[[light]]` step at or
    /// before it, 1 before the first.
    pub fn light(&self, n: u32) -> f64 {
        self.light
            .iter()
            .rev()
            .find(|s| s.from_frame <= n)
            .map_or(1.0, |s| s.scale.get())
    }

    /// The largest light scale of the sequence (1 without `[[light]]`).
    pub fn brightest_light(&self) -> f64 {
        self.light.iter().map(|s| s.scale.get()).fold(1.0, f64::max)
    }

    /// Seconds between frames: 1 / `fps`.
    pub fn frame_seconds(&self) -> f64 {
        1.0 / self.fps.map_or(DEFAULT_FPS, Positive::get)
    }

    /// The TAA the scene's 1-spp frames run, if any (`variant = "off"` runs none).
    pub fn taa_active(&self) -> Option<&Taa> {
        self.taa.as_ref().filter(|t| t.variant != TaaVariant::Off)
    }

    /// The spp `check` renders at unless told otherwise, and the spp of
    /// checks that name none: a TAA scene (any variant) is about its 1-spp
    /// frames; any other scene renders like for like with its goldens.
    pub fn default_spp(&self) -> u32 {
        if self.taa.is_some() {
            1
        } else {
            self.reference_spp
        }
    }

    /// A static scene (ω = 0) renders the same frame every time.
    pub fn is_static(&self) -> bool {
        self.rotation.degrees_per_frame == 0.0
    }

    /// The kind of test the TAA thesis uses (docs/bibliography.md): static
    /// scenes are judged on their converged frame, moving ones on every frame.
    pub fn test_kind(&self) -> TestKind {
        if self.is_static() {
            TestKind::Static
        } else {
            TestKind::Moving
        }
    }

    /// What the gate's judge needs of this scene.
    pub fn judging(&self) -> Judging<'_> {
        Judging {
            scene: &self.name,
            checks: &self.checks,
            reference_spp: self.default_spp(),
            test: self.test_kind(),
            keep_last: self.taa.is_some(),
            earlier: &[],
            compare: None,
            adaptation_curve: None,
        }
    }

    /// A key equal for scenes that differ only in name, description, checks
    /// and TAA settings: the same sequence against the same goldens, the
    /// rows of one no-AA / clip / edge-aware comparison.
    pub fn sequence_key(&self) -> String {
        let mut s = self.clone();
        s.name.clear();
        s.description.clear();
        s.checks.clear();
        s.expectations.clear();
        s.taa = None;
        let canonical = serde_json::to_vec(&s).unwrap_or_default();
        hex::encode(&Sha256::digest(&canonical)[..8])
    }
}

/// 1-based line of the first `key =` or `[key]` in `text`; for
/// `table.key`, of `key =` inside the `[table]` section (the environment's
/// `size` is not the frame's).
pub(super) fn line_of(text: &str, key: &str) -> Option<usize> {
    let (table, key) = match key.split_once('.') {
        Some((t, k)) => (Some(t), k),
        None => (None, key),
    };
    let mut section: Option<&str> = None;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim_start();
        if let Some(h) = t.strip_prefix('[') {
            section = h.split(']').next().map(str::trim);
            if table.is_none() && section == Some(key) {
                return Some(i + 1);
            }
            continue;
        }
        let is_key = t
            .strip_prefix(key)
            .is_some_and(|rest| rest.trim_start().starts_with('='));
        if is_key && (table.is_none() || section == table) {
            return Some(i + 1);
        }
    }
    None
}
/// The line (1-based) of the `n`-th (from 0) `key = …` in `text`, on a
/// line of its own or inside an inline table: where the `n`-th step of an
/// array of tables (`[[light]]`) sets it.
fn nth_line_of(text: &str, key: &str, n: usize) -> Option<usize> {
    let mut seen = 0;
    for (i, l) in text.lines().enumerate() {
        let code = l.split('#').next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find(key) {
            let before = rest[..at].chars().next_back();
            let after = rest[at + key.len()..].trim_start();
            let whole = before.is_none_or(|c| !(c.is_ascii_alphanumeric() || c == '_'));
            if whole && after.starts_with('=') {
                if seen == n {
                    return Some(i + 1);
                }
                seen += 1;
            }
            rest = &rest[at + key.len()..];
        }
    }
    None
}
