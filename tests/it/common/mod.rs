//! A seeded history for the API and dashboard tests: two real check runs on
//! lavapipe (one passing, one with a 2 % too-bright tone mapper, so it fails
//! and keeps failing frames' images) and one tradeoff run, on a two-scene
//! copy of the built-in suite.
#![allow(dead_code)]

pub mod cdp;
pub mod postgres;
pub mod runs;
pub mod seaweed;
pub mod server;

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn tonegate(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(args)
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .output()
        .expect("tonegate runs")
}

/// Copies golden/ (suite, scenes, goldens, manifest) into `to`.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

pub struct Seeded {
    pub db: PathBuf,
    pub suite: PathBuf,
    /// Run ids: passed check, failed check, tradeoff.
    pub passed: i64,
    pub failed: i64,
    pub tradeoff: i64,
}

/// The two-scene suite and an empty history (no runs).
pub fn seed_empty(dir: &Path) -> Seeded {
    copy_dir(&repo().join("golden"), &dir.join("golden"));
    let suite = dir.join("golden/mini.toml");
    std::fs::write(
        &suite,
        "scenes = [\"scenes/grid-static.toml\", \"scenes/sky-reinhard-global.toml\"]\n",
    )
    .unwrap();
    Seeded {
        db: dir.join("history.sqlite"),
        suite,
        passed: 0,
        failed: 0,
        tradeoff: 0,
    }
}

pub fn seed(dir: &Path) -> Seeded {
    let Seeded { db, suite, .. } = seed_empty(dir);
    let (s, d) = (suite.to_str().unwrap(), db.to_str().unwrap());
    let o = tonegate(&["check", "--suite", s, "--db", d]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = tonegate(&["check", "--suite", s, "--db", d, "--fault-gain", "1.02"]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let out = dir.join("tradeoff");
    let o = tonegate(&[
        "tradeoff",
        "grid-static",
        "--suite",
        s,
        "--db",
        d,
        "--frames",
        "0",
        "--reference-spp",
        "16",
        "--repeats",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    Seeded {
        db,
        suite,
        passed: 1,
        failed: 2,
        tradeoff: 3,
    }
}

/// A small HDR image (a gradient sky with a bright sun) as Radiance bytes.
pub fn hdr_bytes(dir: &Path, width: u32, height: u32) -> Vec<u8> {
    let img = tonegate::image::HdrImage::from_fn(width, height, |x, y| {
        let g = 0.05 + 2.0 * x as f32 / width as f32;
        let sun = if (x as i64 - 10).pow(2) + (y as i64 - 8).pow(2) < 9 {
            500.0
        } else {
            0.0
        };
        [g + sun, 0.5 * g + sun, 0.2 + y as f32 / height as f32 + sun]
    });
    let path = dir.join(format!("in-{width}x{height}.hdr"));
    tonegate::io::write_image_hdr(&path, &img).unwrap();
    std::fs::read(path).unwrap()
}

/// A GPU renderer of `scene`'s 1-spp plan (its TAA stages included, when it
/// has them) over `env`, on `ctx`.
pub fn scene_renderer<'a>(
    ctx: &'a tonegate::gpu::GpuContext,
    scene: &tonegate::scene::Scene,
    env: &tonegate::image::HdrImage,
    config: tonegate::gpu::GpuConfig,
) -> tonegate::gpu::GpuRenderer<'a> {
    tonegate::gpu::GpuRenderer::new(
        ctx,
        tonegate::plan::StagePlan::for_scene(scene, 1),
        tonegate::gpu::GpuInput::Sphere {
            env,
            camera: tonegate::reference::scene_camera(scene),
            spp: 1,
            light: scene.brightest_light() as f32,
        },
        &tonegate::reference::Pipeline::of_scene(scene),
        config,
    )
    .unwrap()
}

/// The whole built-in gate (every scene and the stress rows) on lavapipe,
/// the default adapter, under the Khronos validation layer with
/// synchronization validation, recording into a history of its own: run
/// once per test binary, for every test that asserts on it (the gate's
/// console, JUnit, JSON and record; the adapter's validation), rather than
/// once per test. Its files are in out/adapters/.
pub struct LavapipeGate {
    pub output: std::process::Output,
    pub db: PathBuf,
    pub junit: PathBuf,
    pub json: PathBuf,
}

/// `VK_LAYER_ENABLES` for synchronization validation.
pub const SYNC_VALIDATION: (&str, &str) = (
    "VK_LAYER_ENABLES",
    "VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT",
);

/// `tonegate` with none of the loader's driver variables and no history
/// from the environment: what tonegate finds by itself.
pub fn bare_tonegate() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_tonegate"));
    c.current_dir(repo()).env_remove("TONEGATE_DB");
    for v in ["VK_ICD_FILENAMES", "VK_DRIVER_FILES", "VK_ADD_DRIVER_FILES"] {
        c.env_remove(v);
    }
    c
}

pub fn lavapipe_gate() -> &'static LavapipeGate {
    static GATE: std::sync::OnceLock<LavapipeGate> = std::sync::OnceLock::new();
    GATE.get_or_init(|| {
        let out = repo().join("out/adapters");
        std::fs::create_dir_all(&out).unwrap();
        let file = |ext: &str| out.join(format!("lavapipe-validation.{ext}"));
        let (db, junit, json) = (file("sqlite"), file("xml"), file("json"));
        // A history of this run alone.
        for f in [&db, &junit, &json, &file("sqlite-wal"), &file("sqlite-shm")] {
            let _ = std::fs::remove_file(f);
        }
        let output = bare_tonegate()
            .arg("check")
            .arg("--db")
            .arg(&db)
            .arg("--junit")
            .arg(&junit)
            .arg("--json")
            .arg(&json)
            .env("WGPU_VALIDATION", "1")
            .env(SYNC_VALIDATION.0, SYNC_VALIDATION.1)
            .output()
            .expect("tonegate runs");
        LavapipeGate {
            output,
            db,
            junit,
            json,
        }
    })
}

/// The base address (`http://host:port`) a `tonegate serve` child prints on
/// the first line of its stdout (which must be piped); panics with the line
/// when it names none.
pub fn served_base(child: &mut std::process::Child) -> String {
    let mut line = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(child.stdout.take().expect("serve's stdout is piped")),
        &mut line,
    )
    .unwrap();
    line.split("http://")
        .nth(1)
        .and_then(|s| s.split('/').next())
        .map(|a| format!("http://{a}"))
        .unwrap_or_else(|| panic!("no address in {line:?}"))
}
