//! The golden set: complete, fresh, reproducible bit for bit, and small.
//! Goldens never update themselves: these tests only read golden/.

use std::path::{Path, PathBuf};
use tonegate::golden::{self, Problem};
use tonegate::progress::Silent;
use tonegate::scene::Scene;
use tonegate::suite::load_suite;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

fn suite() -> Vec<Scene> {
    load_suite(&root().join("suite.toml")).expect("golden/suite.toml loads")
}

#[test]
fn every_suite_scene_has_fresh_goldens() {
    let problems = golden::check_manifest(&root(), &suite()).expect("manifest readable");
    let text: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
    assert!(
        problems.is_empty(),
        "golden set is incomplete or stale:\n{}",
        text.join("\n")
    );
}

#[test]
fn goldens_re_render_bit_identically() {
    let problems = golden::verify(&root(), &suite(), &Silent).expect("verify runs");
    let text: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
    assert!(problems.is_empty(), "{}", text.join("\n"));
}

#[test]
fn golden_directory_stays_under_its_cap() {
    let bytes = golden::directory_bytes(&root());
    assert!(
        bytes > 0 && bytes < golden::MAX_GOLDEN_BYTES,
        "golden/ is {bytes} bytes"
    );
}

#[test]
fn suite_covers_what_the_gate_needs() {
    let scenes = suite();
    let has = |f: &dyn Fn(&Scene) -> bool| scenes.iter().any(f);
    // Every built-in operator has a scene of its own.
    for op in tonegate::operators::builtin() {
        assert!(
            has(&|s| s.operator.name() == op.name()),
            "no scene runs {}",
            op.name()
        );
    }
    assert!(has(&|s| s.operator.values().word("colour") == "ratio"));
    assert!(has(&|s| s.operator.values().word("colour") == "xyy"));
    assert!(has(&|s| s.bloom.is_some()) && has(&|s| s.bloom.is_none()));
    assert!(has(&|s| s.grade.is_some()));
    assert!(has(&|s| s.is_static()));
    for env in tonegate::env::BuiltinEnv::ALL {
        assert!(
            has(&|s| s.environment.builtin == Some(env)),
            "no scene uses {env}"
        );
    }
    for s in &scenes {
        assert!(!s.checks.is_empty(), "{} has no checks", s.name);
    }
    // Eye adaptation over a light change, of an operator that keys on the
    // log average and of one that keys on nothing, each held to its curve.
    let adapting = |keyed: bool| {
        has(&|s| {
            s.adaptation.is_some()
                && s.light.len() >= 2
                && s.operator.needs().log_average == keyed
                && s.checks
                    .iter()
                    .any(|c| matches!(c.check, tonegate::check::Check::MaxAdaptationError(_)))
        })
    };
    assert!(adapting(true) && adapting(false));
}

/// A scrap golden directory with one small scene, blessed into it.
fn scratch() -> (tempfile::TempDir, Vec<Scene>) {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"
name = "tiny"
size = [24, 16]
frames = 2
reference_spp = 4
[environment]
builtin = "grid"
size = [64, 32]
[rotation]
degrees_per_frame = 10.0
[[checks]]
min_psnr = 20.0
"#;
    let path = dir.path().join("tiny.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    golden::bless(dir.path(), std::slice::from_ref(&scene), &Silent).unwrap();
    (dir, vec![scene])
}

#[test]
fn a_missing_golden_fails_verification() {
    let (dir, scenes) = scratch();
    assert_eq!(
        golden::verify(dir.path(), &scenes, &Silent).unwrap(),
        vec![]
    );
    std::fs::remove_file(golden::frame_path(dir.path(), "tiny", 1)).unwrap();
    let problems = golden::verify(dir.path(), &scenes, &Silent).unwrap();
    assert!(
        problems.contains(&Problem::MissingFile {
            scene: "tiny".into(),
            file: "001.png".into()
        }),
        "{problems:?}"
    );
}

#[test]
fn a_changed_scene_makes_its_golden_stale() {
    let (dir, mut scenes) = scratch();
    scenes[0].fov_y = 50.0;
    let problems = golden::check_manifest(dir.path(), &scenes).unwrap();
    assert!(
        matches!(problems.as_slice(), [Problem::StaleScene { .. }]),
        "{problems:?}"
    );
    // Checks and description are not part of the render: they do not stale it.
    let (dir, mut scenes) = scratch();
    scenes[0].checks.clear();
    scenes[0].description = "changed".into();
    assert_eq!(golden::check_manifest(dir.path(), &scenes).unwrap(), vec![]);
}

/// Renaming an operator stales no golden: the render hash of a scene is
/// the one blessed before the operators had their present names. The
/// expected value is grid-static's hash in the manifest of 3182eae
/// (2026-11-24), blessed while its operator was still called `seed000`.
#[test]
fn an_operator_name_is_not_part_of_the_render_hash() {
    let scene = Scene::load(&root().join("scenes/grid-static.toml")).unwrap();
    assert_eq!(
        golden::render_hash(&scene).unwrap(),
        "f8c8bb495c0f4bd3c285903b6ca6d874f3d2c690d08f56053c4ca870d105def2"
    );
    let text = std::fs::read_to_string(root().join("scenes/night-auto-key-bloom.toml")).unwrap();
    let old = text
        .replace("kind = \"reinhard-auto-key\"", "kind = \"seed001\"")
        .replace("bright_pass = \"scaled\"", "bright_pass = \"seed001\"");
    assert_ne!(old, text, "the scene names its operator and bright pass");
    let path = std::path::Path::new("night.toml");
    let (new, old) = (
        Scene::parse(&text, path).unwrap(),
        Scene::parse(&old, path).unwrap(),
    );
    assert_eq!(
        golden::render_hash(&new).unwrap(),
        golden::render_hash(&old).unwrap()
    );
}

/// A renamed scene is blessed under its new name, and the old name's entry,
/// whose folder went with the rename, leaves the manifest; the frames are
/// the same bytes.
#[test]
fn blessing_a_renamed_scene_drops_the_old_entry() {
    let (dir, mut scenes) = scratch();
    let old = golden::frame_path(dir.path(), "tiny", 0);
    let bytes = std::fs::read(&old).unwrap();
    std::fs::rename(dir.path().join("tiny"), dir.path().join("small")).unwrap();
    scenes[0].name = "small".into();
    golden::bless(dir.path(), &scenes, &Silent).unwrap();
    let manifest = std::fs::read_to_string(dir.path().join("manifest.toml")).unwrap();
    assert!(manifest.contains("[scenes.small]"), "{manifest}");
    assert!(!manifest.contains("tiny"), "{manifest}");
    let renamed = std::fs::read(golden::frame_path(dir.path(), "small", 0)).unwrap();
    assert!(renamed == bytes, "the frame changed with the name");
    assert_eq!(
        golden::verify(dir.path(), &scenes, &Silent).unwrap(),
        vec![]
    );
}

#[test]
fn a_tampered_golden_is_caught_by_hash_and_by_pixels() {
    let (dir, scenes) = scratch();
    let path = golden::frame_path(dir.path(), "tiny", 0);
    let mut img = tonegate::io::read_png8(&path).unwrap();
    img.pixels[5][1] ^= 1;
    tonegate::io::write_png8(&path, &img).unwrap();
    let problems = golden::verify(dir.path(), &scenes, &Silent).unwrap();
    assert!(
        problems
            .iter()
            .any(|p| matches!(p, Problem::FileChanged { .. })),
        "{problems:?}"
    );
    assert!(
        problems.contains(&Problem::PixelsDiffer {
            scene: "tiny".into(),
            file: "000.png".into(),
            pixels: 1
        }),
        "{problems:?}"
    );
}

#[test]
fn an_unblessed_scene_is_reported_not_invented() {
    let (dir, mut scenes) = scratch();
    scenes[0].name = "other".into();
    let problems = golden::check_manifest(dir.path(), &scenes).unwrap();
    assert_eq!(
        problems,
        vec![Problem::NotInManifest {
            scene: "other".into()
        }]
    );
    assert!(!dir.path().join("other").exists());
}

#[test]
fn reference_does_not_depend_on_the_thread_count() {
    let scenes = suite();
    let scene = scenes.iter().find(|s| s.bloom.is_some()).unwrap();
    let env = tonegate::render::scene_environment(scene).unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let a = one.install(|| tonegate::reference::render_frame(scene, &env, 3, 4).unwrap());
    let b = three.install(|| tonegate::reference::render_frame(scene, &env, 3, 4).unwrap());
    assert_eq!(a.frame, b.frame);
    assert_eq!(a.display, b.display);
    assert_eq!(a.stats, b.stats);
}

/// A scene with eye adaptation has a golden adaptation curve beside its
/// frames: blessed from the reference, in the manifest, re-rendered
/// exactly by `verify`; an edited curve is caught, and a malformed one is
/// refused with the line that is wrong.
#[test]
fn an_adapting_scene_has_a_golden_curve_that_is_verified() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"
name = "lit"
size = [24, 16]
frames = 4
reference_spp = 2
[environment]
builtin = "interior"
size = [64, 32]
[rotation]
degrees_per_frame = 0.0
[adaptation]
up = 0.1
[[light]]
from_frame = 2
scale = 10.0
[[checks]]
max_adaptation_error = 1e-4
"#;
    let path = dir.path().join("lit.toml");
    std::fs::write(&path, text).unwrap();
    let scenes = vec![Scene::load(&path).unwrap()];
    golden::bless(dir.path(), &scenes, &Silent).unwrap();
    assert_eq!(
        golden::verify(dir.path(), &scenes, &Silent).unwrap(),
        vec![]
    );
    let curve = golden::read_adaptation_curve(dir.path(), "lit", 4).unwrap();
    // Frame 0 takes its measurement, which a static view repeats; the
    // light step pulls the curve up, not all the way at once.
    assert_eq!(curve[0], curve[1]);
    assert!(curve[2] > curve[1] && curve[3] > curve[2], "{curve:?}");
    assert!(curve[3] < 10.0 * curve[1], "{curve:?}");
    let file = dir.path().join("lit").join(golden::ADAPTATION_CURVE);
    let blessed = std::fs::read_to_string(&file).unwrap();
    // One digit changed: the manifest's hash and the re-render both see it.
    let edited = blessed.replacen("\n1,", "\n1,9", 1);
    std::fs::write(&file, &edited).unwrap();
    let problems = golden::verify(dir.path(), &scenes, &Silent).unwrap();
    assert!(
        problems.contains(&Problem::FileChanged {
            scene: "lit".into(),
            file: golden::ADAPTATION_CURVE.into()
        }) && problems.contains(&Problem::CurveDiffers {
            scene: "lit".into(),
            frames: 1
        }),
        "{problems:?}"
    );
    for (bad, says) in [
        (
            blessed.replace("frame,adapted_luminance", "n,l"),
            "first line",
        ),
        (blessed.replacen("\n2,", "\n7,", 1), "line 4"),
        (blessed.replacen("\n3,", "\n3,-", 1), "line 5"),
        (
            blessed.lines().take(3).collect::<Vec<_>>().join("\n"),
            "2 frames for a sequence of 4",
        ),
    ] {
        std::fs::write(&file, bad).unwrap();
        let e = golden::read_adaptation_curve(dir.path(), "lit", 4)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(says) && e.contains("adaptation.csv"),
            "{says}: {e}"
        );
    }
    std::fs::remove_file(&file).unwrap();
    let problems = golden::check_manifest(dir.path(), &scenes).unwrap();
    assert!(problems.contains(&Problem::MissingFile {
        scene: "lit".into(),
        file: golden::ADAPTATION_CURVE.into()
    }));
}
