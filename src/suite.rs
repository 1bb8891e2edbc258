//! A suite file: the ordered scene files the gate runs, how it treats
//! performance, and whether it runs the stress suite too.

use crate::scene::{Scene, SceneError};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

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

impl Suite {
    /// The scenes named (all when `names` is empty), in the suite's order;
    /// an unknown name is an error that lists the suite's scenes.
    pub fn select(&self, names: &[String]) -> Result<Vec<Scene>, String> {
        if let Some(missing) = names
            .iter()
            .find(|n| !self.scenes.iter().any(|s| &&s.name == n))
        {
            return Err(format!(
                "no scene {missing:?} in the suite; it has: {}",
                self.scenes
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        // A scene that compares with another (`min_psnr_gain_over`) brings
        // it along; `parse_suite` made sure it comes earlier.
        let mut wanted: Vec<&str> = names.iter().map(String::as_str).collect();
        for s in self.scenes.iter().rev() {
            if names.is_empty() || wanted.contains(&s.name.as_str()) {
                wanted.extend(s.checks.iter().filter_map(|c| c.check.baseline()));
            }
        }
        Ok(self
            .scenes
            .iter()
            .filter(|s| names.is_empty() || wanted.contains(&s.name.as_str()))
            .cloned()
            .collect())
    }
}

/// Loads every scene a suite file lists (paths relative to the suite file).
pub fn load_suite(path: &Path) -> Result<Vec<Scene>, SceneError> {
    load_suite_file(path).map(|s| s.scenes)
}

/// Loads a suite file with its performance policy.
pub fn load_suite_file(path: &Path) -> Result<Suite, SceneError> {
    parse_suite(&crate::scene::read_text(path)?, path)
}

/// Parses suite text and loads the scenes it lists, relative to `path`'s folder.
pub fn parse_suite(text: &str, path: &Path) -> Result<Suite, SceneError> {
    let suite: SuiteFile = toml::from_str(text).map_err(|e| SceneError::Parse {
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
        for c in &scene.checks {
            if let crate::check::Check::MinPsnrGainOver(g) = &c.check {
                if g.frame_db.is_some() && g.from_frame >= scene.frames {
                    return Err(SceneError::Invalid {
                        path: path.to_owned(),
                        message: format!(
                            "scene {:?}: min_psnr_gain_over: from_frame {} is past the last frame {}",
                            scene.name,
                            g.from_frame,
                            scene.frames - 1
                        ),
                    });
                }
            }
        }
        for baseline in scene.checks.iter().filter_map(|c| c.check.baseline()) {
            let invalid = |message: String| SceneError::Invalid {
                path: path.to_owned(),
                message: format!("scene {:?}: min_psnr_gain_over: {message}", scene.name),
            };
            let Some(base) = scenes.iter().find(|s| s.name == baseline) else {
                return Err(invalid(format!(
                    "scene {baseline:?} must be listed before this one in the suite"
                )));
            };
            if base.sequence_key() != scene.sequence_key()
                || base.default_spp() != scene.default_spp()
            {
                return Err(invalid(format!(
                    "scene {baseline:?} renders another sequence (environment, size, rotation, operator, frames or samples per pixel differ): its frames cannot be compared with this scene's"
                )));
            }
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

    fn scene(name: &str, omega: f64, checks: &str) -> String {
        format!(
            r#"name = "{name}"
size = [32, 18]
frames = 2
[environment]
builtin = "grid"
size = [64, 32]
[rotation]
degrees_per_frame = {omega}
[taa]
variant = "clip"
[[checks]]
min_psnr = 1.0
{checks}"#
        )
    }

    /// Writes the scenes and a suite listing them in order; parses it.
    fn suite(scenes: &[(&str, String)]) -> Result<Suite, SceneError> {
        let dir = tempfile::tempdir().unwrap();
        let mut list = String::from("scenes = [\n");
        for (name, text) in scenes {
            std::fs::write(dir.path().join(format!("{name}.toml")), text).unwrap();
            list.push_str(&format!("  \"{name}.toml\",\n"));
        }
        list.push_str("]\n");
        let path = dir.path().join("suite.toml");
        std::fs::write(&path, &list).unwrap();
        load_suite_file(&path)
    }

    #[test]
    fn a_gain_check_needs_its_scene_earlier_and_on_the_same_sequence() {
        let gain = "[[checks]]\nmin_psnr_gain_over = { scene = \"base\", db = 1.0 }\n";
        let ok = suite(&[
            ("base", scene("base", 0.5, "")),
            ("taa", scene("taa", 0.5, gain)),
        ])
        .unwrap();
        // Selecting the comparing scene brings its baseline along, first.
        let picked = ok.select(&["taa".into()]).unwrap();
        let names: Vec<&str> = picked.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["base", "taa"]);
        let e = suite(&[
            ("taa", scene("taa", 0.5, gain)),
            ("base", scene("base", 0.5, "")),
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("\"base\" must be listed before this one"), "{e}");
        let e = suite(&[
            ("base", scene("base", 1.0, "")),
            ("taa", scene("taa", 0.5, gain)),
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("renders another sequence"), "{e}");
        // A baseline without TAA renders at its reference spp, not at 1.
        let plain = scene("base", 0.5, "").replace("[taa]\nvariant = \"clip\"\n", "");
        let e = suite(&[("base", plain), ("taa", scene("taa", 0.5, gain))])
            .unwrap_err()
            .to_string();
        assert!(e.contains("samples per pixel"), "{e}");
        let late = "[[checks]]\nmin_psnr_gain_over = { scene = \"base\", db = 1.0, frame_db = 0.0, from_frame = 2 }\n";
        let e = suite(&[
            ("base", scene("base", 0.5, "")),
            ("taa", scene("taa", 0.5, late)),
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("from_frame 2 is past the last frame 1"), "{e}");
    }
}
