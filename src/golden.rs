//! Goldens: the CPU reference's 8-bit frames of the built-in suite, and their
//! manifest. Goldens never update themselves: only `tonegate golden bless`
//! writes them, and a missing or stale golden is an error everywhere else.

use crate::image::Frame;
use crate::progress::Progress;
use crate::reference::REFERENCE_VERSION;
use crate::render::{scene_environment, RenderError, SceneRenderer};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// File name of the manifest inside the golden directory.
pub const MANIFEST: &str = "manifest.toml";
/// File name, inside a scene's folder, of the adaptation curve of a scene
/// with eye adaptation: the luminance each frame was adapted to.
pub const ADAPTATION_CURVE: &str = "adaptation.csv";
/// Cap on everything under golden/ (kept small so the repository stays light).
pub const MAX_GOLDEN_BYTES: u64 = 20 * 1024 * 1024;

#[derive(Debug, thiserror::Error)]
pub enum GoldenError {
    /// The manifest is missing or unreadable.
    #[error("{path}: cannot read the golden manifest ({detail}); run `tonegate golden bless` to create it")]
    Manifest { path: PathBuf, detail: String },
    /// Writing a golden or the manifest failed.
    #[error("{path}: cannot write: {detail}")]
    Write { path: PathBuf, detail: String },
    /// The scene's environment file could not be read for its hash.
    #[error("scene {scene}: {detail}")]
    Environment { scene: String, detail: String },
    /// The reference could not render a scene.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A golden frame could not be read.
    #[error("{path}: cannot read golden frame: {detail}")]
    Frame { path: PathBuf, detail: String },
    /// A golden adaptation curve could not be read.
    #[error("{path}: cannot read the golden adaptation curve: {detail}")]
    Curve { path: PathBuf, detail: String },
}

/// What the manifest records about one scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneEntry {
    /// `render_hash` of the scene when it was blessed.
    pub scene_hash: String,
    pub reference_version: u32,
    pub spp: u32,
    pub frames: u32,
    pub size: [u32; 2],
    /// The scene as it was blessed, for humans reading a diff.
    pub parameters: toml::Value,
    /// File name → SHA-256 of its bytes.
    pub files: BTreeMap<String, String>,
}

/// golden/manifest.toml.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub scenes: BTreeMap<String, SceneEntry>,
}

/// One thing wrong with the golden set.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "problem", rename_all = "snake_case")]
pub enum Problem {
    NotInManifest {
        scene: String,
    },
    StaleScene {
        scene: String,
        blessed: String,
        now: String,
    },
    StaleReference {
        scene: String,
        blessed: u32,
        now: u32,
    },
    MissingFile {
        scene: String,
        file: String,
    },
    FileChanged {
        scene: String,
        file: String,
    },
    PixelsDiffer {
        scene: String,
        file: String,
        pixels: usize,
    },
    CurveDiffers {
        scene: String,
        frames: usize,
    },
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Problem::NotInManifest { scene } => write!(f, "{scene}: no golden (not in the manifest); bless it with `tonegate golden bless {scene}`"),
            Problem::StaleScene { scene, .. } => write!(f, "{scene}: stale golden: the scene changed since it was blessed; review and re-bless"),
            Problem::StaleReference { scene, blessed, now } => write!(f, "{scene}: stale golden: blessed with reference version {blessed}, now {now}"),
            Problem::MissingFile { scene, file } => write!(f, "{scene}: golden frame {file} is missing"),
            Problem::FileChanged { scene, file } => write!(f, "{scene}: golden frame {file} does not match its manifest SHA-256"),
            Problem::PixelsDiffer { scene, file, pixels } => write!(f, "{scene}: re-rendered {file} differs from the golden in {pixels} pixels"),
            Problem::CurveDiffers { scene, frames } => write!(f, "{scene}: the re-rendered adaptation curve differs from {ADAPTATION_CURVE} in {frames} frames"),
        }
    }
}

/// Hash of everything that changes a scene's rendered frames: the scene minus
/// its checks and description, plus the bytes of an environment file. A
/// scene's TAA knobs are left out too: its goldens are the accumulation
/// reference, which no TAA setting changes.
pub fn render_hash(scene: &Scene) -> Result<String, GoldenError> {
    let mut s = scene.clone();
    s.checks.clear();
    s.expectations.clear();
    s.description.clear();
    s.taa = None;
    let mut h = Sha256::new();
    h.update(first_spellings(&serde_json::to_string(&s).unwrap_or_default()).as_bytes());
    if let Some(path) = &scene.environment.path {
        let bytes = std::fs::read(path).map_err(|e| GoldenError::Environment {
            scene: scene.name.clone(),
            detail: format!("{}: {e}", path.display()),
        })?;
        h.update(Sha256::digest(&bytes));
    }
    Ok(hex::encode(h.finalize()))
}

/// The scene's JSON with the operators and the bright pass spelled as
/// they were when the first goldens were blessed (`seed000`, `seed001`): a
/// name is not a parameter of the render, so renaming one must not stale a
/// golden blessed before (docs/operators.md). A string value cannot hold
/// these patterns: its quotes are escaped.
fn first_spellings(json: &str) -> String {
    // A built-in operator's first alias is the name it had then.
    let mut out = json.to_owned();
    for op in crate::operators::builtin() {
        if let Some(first) = op.aliases().first() {
            out = out.replace(
                &format!(r#""kind":"{}""#, op.name()),
                &format!(r#""kind":"{first}""#),
            );
        }
    }
    out.replace(r#""bright_pass":"scaled""#, r#""bright_pass":"seed001""#)
}

/// File name of frame `n`.
pub fn frame_file(n: u32) -> String {
    format!("{n:03}.png")
}

pub fn frame_path(root: &Path, scene: &str, n: u32) -> PathBuf {
    root.join(scene).join(frame_file(n))
}

pub fn load_manifest(root: &Path) -> Result<Manifest, GoldenError> {
    let path = root.join(MANIFEST);
    let manifest_error = |e: std::io::Error| GoldenError::Manifest {
        path: path.clone(),
        detail: e.to_string(),
    };
    let mut text = String::new();
    std::io::Read::read_to_string(
        &mut crate::io::open_regular(&path).map_err(manifest_error)?,
        &mut text,
    )
    .map_err(manifest_error)?;
    toml::from_str(&text).map_err(|e| GoldenError::Manifest {
        path,
        detail: e.to_string(),
    })
}

fn sha256_file(path: &Path) -> Option<String> {
    std::fs::read(path)
        .ok()
        .map(|b| hex::encode(Sha256::digest(&b)))
}

/// The adaptation curve's text: a header, then `frame,luminance` a line,
/// each value printed so that it reads back to the same f64.
fn curve_text(curve: &[f64]) -> String {
    let mut text = String::from("frame,adapted_luminance\n");
    for (n, v) in curve.iter().enumerate() {
        text.push_str(&format!("{n},{v:e}\n"));
    }
    text
}

/// Reads the golden adaptation curve of `scene`: the luminance each of its
/// `frames` frames was adapted to.
pub fn read_adaptation_curve(
    root: &Path,
    scene: &str,
    frames: u32,
) -> Result<Vec<f64>, GoldenError> {
    let path = root.join(scene).join(ADAPTATION_CURVE);
    let bad = |detail: String| GoldenError::Curve {
        path: path.clone(),
        detail,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    let mut lines = text.lines();
    if lines.next() != Some("frame,adapted_luminance") {
        return Err(bad("the first line is not `frame,adapted_luminance`".into()));
    }
    let mut curve = Vec::with_capacity(frames as usize);
    for (i, line) in lines.enumerate() {
        let value = line
            .split_once(',')
            .filter(|(n, _)| n.parse::<usize>().ok() == Some(i))
            .and_then(|(_, v)| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v > 0.0)
            .ok_or_else(|| {
                bad(format!(
                    "line {}: not `{i},<luminance > 0>`: {line:?}",
                    i + 2
                ))
            })?;
        curve.push(value);
    }
    if curve.len() != frames as usize {
        return Err(bad(format!(
            "{} frames for a sequence of {frames}",
            curve.len()
        )));
    }
    Ok(curve)
}

/// Reads golden frame `n` of `scene`.
pub fn read_frame(root: &Path, scene: &str, n: u32) -> Result<Frame, GoldenError> {
    let path = frame_path(root, scene, n);
    crate::io::read_frame_png(&path).map_err(|e| GoldenError::Frame {
        path,
        detail: e.to_string(),
    })
}

/// The manifest-level checks, without rendering: every scene blessed, not
/// stale, every file present with its recorded SHA-256.
pub fn check_manifest(root: &Path, scenes: &[Scene]) -> Result<Vec<Problem>, GoldenError> {
    let manifest = load_manifest(root)?;
    let mut problems = Vec::new();
    for scene in scenes {
        let name = scene.name.clone();
        let Some(entry) = manifest.scenes.get(&name) else {
            problems.push(Problem::NotInManifest { scene: name });
            continue;
        };
        let now = render_hash(scene)?;
        if entry.scene_hash != now {
            problems.push(Problem::StaleScene {
                scene: name.clone(),
                blessed: entry.scene_hash.clone(),
                now,
            });
        }
        if entry.reference_version != REFERENCE_VERSION {
            problems.push(Problem::StaleReference {
                scene: name.clone(),
                blessed: entry.reference_version,
                now: REFERENCE_VERSION,
            });
        }
        // Every frame, and the adaptation curve of a scene that adapts:
        // present, and as blessed.
        let curve = scene.adaptation.map(|_| ADAPTATION_CURVE.to_owned());
        for file in (0..scene.frames).map(frame_file).chain(curve) {
            let path = root.join(&name).join(&file);
            match (entry.files.get(&file), sha256_file(&path)) {
                (_, None) | (None, _) => problems.push(Problem::MissingFile {
                    scene: name.clone(),
                    file,
                }),
                (Some(want), Some(got)) if *want != got => problems.push(Problem::FileChanged {
                    scene: name.clone(),
                    file,
                }),
                _ => {}
            }
        }
    }
    Ok(problems)
}

/// Renders `scenes` with the reference and writes their goldens and manifest
/// entries (other scenes' entries are kept). The only writer of goldens.
pub fn bless(root: &Path, scenes: &[Scene], progress: &dyn Progress) -> Result<(), GoldenError> {
    let mut manifest = load_manifest(root).unwrap_or_default();
    let total: u64 = scenes.iter().map(|s| s.frames as u64).sum();
    progress.start("bless", total, "frames");
    for scene in scenes {
        progress.working_on(&scene.name);
        let env = scene_environment(scene)?;
        let reference = SceneRenderer::cpu(scene, &env, scene.reference_spp);
        let dir = root.join(&scene.name);
        std::fs::create_dir_all(&dir).map_err(|e| GoldenError::Write {
            path: dir.clone(),
            detail: e.to_string(),
        })?;
        let mut files = BTreeMap::new();
        let mut curve = Vec::new();
        for n in 0..scene.frames {
            let rendered = reference.frame(n)?;
            curve.extend(rendered.log_average());
            let frame = rendered.image;
            let path = frame_path(root, &scene.name, n);
            crate::io::write_frame_png(&path, &frame).map_err(|e| GoldenError::Write {
                path: path.clone(),
                detail: e.to_string(),
            })?;
            let sha = sha256_file(&path).ok_or_else(|| GoldenError::Write {
                path: path.clone(),
                detail: "written file cannot be read back".into(),
            })?;
            files.insert(frame_file(n), sha);
            progress.advance(1);
        }
        if scene.adaptation.is_some() {
            let path = dir.join(ADAPTATION_CURVE);
            let write_err = |detail: String| GoldenError::Write {
                path: path.clone(),
                detail,
            };
            std::fs::write(&path, curve_text(&curve)).map_err(|e| write_err(e.to_string()))?;
            let sha = sha256_file(&path)
                .ok_or_else(|| write_err("written file cannot be read back".into()))?;
            files.insert(ADAPTATION_CURVE.to_owned(), sha);
        }
        // Frames of a longer earlier sequence, or the curve of a scene that
        // no longer adapts, would be left behind: remove them.
        if let Ok(entries) = std::fs::read_dir(&dir) {
            for e in entries.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                let golden = name.ends_with(".png") || name == ADAPTATION_CURVE;
                if golden && !files.contains_key(&name) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        let parameters = toml::Value::try_from(scene).map_err(|e| GoldenError::Write {
            path: root.join(MANIFEST),
            detail: e.to_string(),
        })?;
        manifest.scenes.insert(
            scene.name.clone(),
            SceneEntry {
                scene_hash: render_hash(scene)?,
                reference_version: REFERENCE_VERSION,
                spp: scene.reference_spp,
                frames: scene.frames,
                size: [scene.size.width, scene.size.height],
                parameters,
                files,
            },
        );
    }
    progress.finish();
    // An entry whose folder is gone (the scene was renamed or removed, its
    // folder with it) describes no golden: it goes, not to be found again.
    manifest.scenes.retain(|name, _| root.join(name).is_dir());
    write_manifest(root, &manifest)
}

fn write_manifest(root: &Path, manifest: &Manifest) -> Result<(), GoldenError> {
    let path = root.join(MANIFEST);
    let err = |detail: String| GoldenError::Write {
        path: path.clone(),
        detail,
    };
    let body = toml::to_string(manifest).map_err(|e| err(e.to_string()))?;
    let text = format!("# Written by `tonegate golden bless`; do not edit by hand.\n{body}");
    let tmp = root.join(format!(".{MANIFEST}.tmp"));
    std::fs::write(&tmp, text).map_err(|e| err(e.to_string()))?;
    std::fs::rename(&tmp, &path).map_err(|e| err(e.to_string()))
}

/// The manifest checks, then a full re-render of every frame, which must
/// match the golden pixel for pixel.
pub fn verify(
    root: &Path,
    scenes: &[Scene],
    progress: &dyn Progress,
) -> Result<Vec<Problem>, GoldenError> {
    let mut problems = check_manifest(root, scenes)?;
    let total: u64 = scenes.iter().map(|s| s.frames as u64).sum();
    progress.start("verify", total, "frames");
    for scene in scenes {
        progress.working_on(&scene.name);
        let env = scene_environment(scene)?;
        let reference = SceneRenderer::cpu(scene, &env, scene.reference_spp);
        // The blessed curve, when it can be read (else already reported).
        let curve = scene
            .adaptation
            .and_then(|_| read_adaptation_curve(root, &scene.name, scene.frames).ok());
        let mut curve_differs = 0;
        for n in 0..scene.frames {
            progress.advance(1);
            let rendered = reference.frame(n)?;
            if let (Some(c), Some(v)) = (&curve, rendered.log_average()) {
                curve_differs += usize::from(c[n as usize] != v);
            }
            let Ok(golden) = read_frame(root, &scene.name, n) else {
                continue; // already reported as missing
            };
            let frame = rendered.image;
            let pixels = match (&golden, &frame) {
                (Frame::Rgb8(g), Frame::Rgb8(f)) if (g.width, g.height) == (f.width, f.height) => {
                    differing(&g.pixels, &f.pixels)
                }
                (Frame::Pq16(g), Frame::Pq16(f)) if (g.width, g.height) == (f.width, f.height) => {
                    differing(&g.pixels, &f.pixels)
                }
                // Another size or depth: every pixel differs.
                _ => frame.width() as usize * frame.height() as usize,
            };
            if pixels > 0 {
                problems.push(Problem::PixelsDiffer {
                    scene: scene.name.clone(),
                    file: frame_file(n),
                    pixels,
                });
            }
        }
        if curve_differs > 0 {
            problems.push(Problem::CurveDiffers {
                scene: scene.name.clone(),
                frames: curve_differs,
            });
        }
    }
    progress.finish();
    Ok(problems)
}

/// Total bytes of the files under `root`.
pub fn directory_bytes(root: &Path) -> u64 {
    let mut total = 0;
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            match e.file_type() {
                Ok(t) if t.is_dir() => stack.push(e.path()),
                Ok(_) => total += e.metadata().map(|m| m.len()).unwrap_or(0),
                Err(_) => {}
            }
        }
    }
    total
}

/// How many pixels of two same-sized images differ.
fn differing<P: PartialEq>(a: &[P], b: &[P]) -> usize {
    a.iter().zip(b).filter(|(a, b)| a != b).count()
}
