//! The gate on more than one implementation, here on a machine without a
//! GPU: lavapipe (Vulkan), Google's SwiftShader (Vulkan, the driver Debian's
//! `chromium` ships; it flushes subnormals) and llvmpipe through GL (EGL,
//! surfaceless), the Vulkan runs under the Khronos validation layer with
//! synchronization validation and the GL run under `KHR_debug`. Each run
//! writes its JUnit to out/adapters/. ci/deps.sh installs all of it.

use crate::common;
use std::path::PathBuf;

use common::SYNC_VALIDATION as SYNC;

/// `tonegate` with none of the loader's driver variables: the tests are
/// about what tonegate finds by itself.
fn tonegate() -> std::process::Command {
    common::bare_tonegate()
}

fn run(args: &[&str]) -> std::process::Output {
    tonegate().args(args).output().expect("tonegate runs")
}

fn out_dir() -> PathBuf {
    let d = common::repo().join("out/adapters");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `tonegate check` of the whole built-in suite (stress rows included) with
/// `args`, under the validation layer; returns the JSON report.
fn gate(name: &str, args: &[&str]) -> serde_json::Value {
    let out = out_dir();
    let (junit, json) = (
        out.join(format!("{name}.xml")),
        out.join(format!("{name}.json")),
    );
    let o = tonegate()
        .args(["check", "--no-history", "--junit"])
        .arg(&junit)
        .arg("--json")
        .arg(&json)
        .args(args)
        .env("WGPU_VALIDATION", "1")
        .env(SYNC.0, SYNC.1)
        .output()
        .expect("tonegate runs");
    validated(name, &o, &junit, &json)
}

/// A gate's run under the validation layer, judged: exit 0, no message
/// from the layer, no failure in its JUnit; its JSON report.
fn validated(
    name: &str,
    o: &std::process::Output,
    junit: &std::path::Path,
    json: &std::path::Path,
) -> serde_json::Value {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(0),
        "the gate on {name}:\n{}\n{stderr}",
        String::from_utf8_lossy(&o.stdout)
    );
    // The layer watched the run and reported nothing (the line is printed
    // only when validation was asked for; a missing layer is exit 2).
    assert!(
        stderr.contains("validation layer (WGPU_VALIDATION): 0 error(s)"),
        "{name}: {stderr}"
    );
    let xml = std::fs::read_to_string(junit).unwrap();
    assert!(
        xml.contains("<testcase") && !xml.contains("<failure"),
        "{name}: {xml}"
    );
    // An infinite PSNR is the literal 1e999, which serde_json's Value cannot hold.
    let text = std::fs::read_to_string(json)
        .unwrap()
        .replace("1e999", "1e308");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn suite_scenes() -> usize {
    std::fs::read_to_string(common::repo().join("golden/suite.toml"))
        .unwrap()
        .matches(".toml\"")
        .count()
}

/// The subnormal rows of the stress table: (bound, has the exception).
fn subnormal_rows(report: &serde_json::Value) -> Vec<(f64, bool)> {
    report["stress"]["cases"]
        .as_array()
        .expect("the gate ran the stress rows")
        .iter()
        .filter(|r| r["case"] == "subnormals" && r["renderer"] == "gpu")
        .map(|r| (r["bound"].as_f64().unwrap(), r.get("exception").is_some()))
        .collect()
}

fn assert_whole_gate(name: &str, report: &serde_json::Value) {
    let scenes = report["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), suite_scenes(), "{name}");
    let stress = report["stress"]["cases"].as_array().unwrap();
    assert!(
        stress.len() >= 64 && stress.iter().all(|r| r["passed"] == true),
        "{name}: stress rows"
    );
}

#[test]
fn adapters_lists_every_implementation_and_measures_subnormals() {
    let o = run(&["adapters", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let list = v["adapters"].as_array().unwrap();
    let find = |name: &str, backend: &str| {
        list.iter()
            .find(|a| a["name"].as_str().unwrap().contains(name) && a["backend"] == backend)
            .unwrap_or_else(|| panic!("no {name} on {backend} in {v}"))
    };
    let lavapipe = find("llvmpipe", "Vulkan");
    let gl = find("llvmpipe", "Gl");
    let swiftshader = find("SwiftShader", "Vulkan");
    // Measured by the probe shader, not known by name: llvmpipe keeps
    // subnormals on both APIs, SwiftShader flushes them.
    assert_eq!(lavapipe["flushes_subnormals"], false, "{lavapipe}");
    assert_eq!(gl["flushes_subnormals"], false, "{gl}");
    assert_eq!(swiftshader["flushes_subnormals"], true, "{swiftshader}");
    // The features that decide the configuration: GL has no subgroups and
    // no filterable f32, so `auto` and `--env-filter` must not count on them.
    let has =
        |a: &serde_json::Value, f: &str| a["features"].as_array().unwrap().iter().any(|x| x == f);
    assert!(has(lavapipe, "subgroups") && has(lavapipe, "timestamp-query"));
    assert!(!has(gl, "subgroups") && !has(gl, "float32-filterable"));
    assert!(
        lavapipe["limits"]["max_texture_dimension_2d"]
            .as_u64()
            .unwrap()
            >= 8192
    );
    assert!(v["extra_vulkan_drivers"]
        .as_array()
        .unwrap()
        .iter()
        .any(|p| p.as_str().unwrap().ends_with("vk_swiftshader_icd.json")));
}

#[test]
fn the_gate_passes_on_lavapipe_under_synchronization_validation() {
    // The same run as the check tests' gate on the default adapter.
    let run = common::lavapipe_gate();
    let report = validated("lavapipe-validation", &run.output, &run.junit, &run.json);
    assert_whole_gate("lavapipe", &report);
    assert_eq!(report["adapter"]["flushes_subnormals"], false);
    // llvmpipe keeps subnormals, so the flush exception does not apply:
    // the subnormal rows are held to the generic 1e-5.
    let rows = subnormal_rows(&report);
    assert!(!rows.is_empty());
    assert!(
        rows.iter()
            .all(|&(bound, excused)| bound == 1e-5 && !excused),
        "{rows:?}"
    );
}

#[test]
fn the_gate_passes_on_swiftshader_found_without_an_environment_variable() {
    let report = gate("swiftshader-validation", &["--adapter", "swiftshader"]);
    assert_whole_gate("swiftshader", &report);
    let adapter = &report["adapter"];
    assert!(
        adapter["name"].as_str().unwrap().contains("SwiftShader"),
        "{adapter}"
    );
    assert!(
        adapter["chosen"]
            .as_str()
            .unwrap()
            .contains("vk_swiftshader_icd.json"),
        "the report says where the driver was found: {adapter}"
    );
    // SwiftShader flushes, and only there the documented exception applies.
    assert_eq!(adapter["flushes_subnormals"], true);
    let rows = subnormal_rows(&report);
    assert!(rows.iter().any(|&(_, excused)| excused), "{rows:?}");
    assert!(rows
        .iter()
        .all(|&(bound, excused)| excused == (bound == 2e-2)));
}

#[test]
fn the_gate_passes_on_gl_through_egl() {
    let report = gate("gl-llvmpipe", &["--backend", "gl"]);
    assert_whole_gate("gl", &report);
    assert_eq!(report["adapter"]["backend"], "Gl");
    let config = &report["renderer"];
    assert_eq!(config["reduction_in_effect"], "block_partials", "{config}");
}

/// What GL lacks is handled as documented: the subgroup tree runs as the
/// shared-memory tree and says so; the hardware environment filter is
/// refused with the missing feature named.
#[test]
fn gl_takes_the_fallbacks_it_documents() {
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().to_str().unwrap();
    let scene = "golden/scenes/grid-static.toml";
    let o = run(&[
        "render",
        scene,
        "--out",
        dir,
        "--backend",
        "gl",
        "--reduction",
        "subgroup",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("frames.json")).unwrap())
            .unwrap();
    assert_eq!(frames["gpu_config"]["reduction"], "tree", "{frames}");
    assert!(
        frames["notes"]
            .to_string()
            .contains("no subgroup operations"),
        "{frames}"
    );
    let o = run(&[
        "render",
        scene,
        "--out",
        dir,
        "--backend",
        "gl",
        "--env-filter",
        "hardware",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("FLOAT32_FILTERABLE") && e.contains("--env-filter hardware"),
        "{e}"
    );
}

#[test]
fn an_unknown_backend_or_adapter_is_refused_with_what_there_is() {
    let o = run(&["check", "--no-history", "--backend", "glide"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("glide") && e.contains("vulkan, gl"), "{e}");
    let out = tempfile::tempdir().unwrap();
    let o = run(&[
        "render",
        "golden/scenes/grid-static.toml",
        "--out",
        out.path().to_str().unwrap(),
        "--adapter",
        "no-such-gpu",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("no-such-gpu") && e.contains("llvmpipe") && e.contains("SwiftShader"),
        "the refusal lists the adapters, the extra drivers' included: {e}"
    );
    // `hardware` where only software adapters are (lavapipe's driver
    // alone): said as such, not as a name that matched nothing.
    let o = tonegate()
        .args([
            "render",
            "golden/scenes/grid-static.toml",
            "--out",
            out.path().to_str().unwrap(),
            "--backend",
            "vulkan",
            "--adapter",
            "hardware",
        ])
        .env(
            "VK_ICD_FILENAMES",
            "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json",
        )
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("no hardware adapter was found") && e.contains("llvmpipe"),
        "{e}"
    );
    assert!(!e.contains("no adapter matches"), "{e}");
}

/// `bench` times both floors inside every measured frame and gives each
/// stage as the median of its per-frame ratios to them (a structure check:
/// speed is judged from `bench`'s numbers, not here).
#[test]
fn bench_reports_both_floors_timed_inside_each_frame() {
    for backend in ["vulkan", "gl"] {
        let o = run(&[
            "bench",
            "--size",
            "160x90",
            "--frames",
            "6",
            "--warmup",
            "1",
            "--json",
            "--backend",
            backend,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let (w, rw) = (
            r["floor_ms"].as_f64().unwrap(),
            r["floor_rw_ms"].as_f64().unwrap(),
        );
        assert!(w > 0.0 && rw > 0.0, "{backend}: {r}");
        assert!(
            r["frame_floor_multiple"].as_f64().unwrap()
                > r["display_floor_multiple"].as_f64().unwrap(),
            "{backend}: {r}"
        );
        let stages = r["stages"].as_array().unwrap();
        assert!(stages.iter().any(|s| s["name"] == "sphere"), "{r}");
        for s in stages {
            let (m, mrw) = (
                s["floor_multiple"].as_f64().unwrap(),
                s["rw_floor_multiple"].as_f64().unwrap(),
            );
            assert!(m > 0.0 && mrw > 0.0, "{backend}: {s}");
        }
    }
}

/// A GL context without compute shaders (what NVIDIA's driver gives wgpu:
/// desktop GL 3.3), forced on Mesa: `adapters` says what it lacks without
/// running the probe on it, and `check` refuses it with that reason before
/// any work, never as "a tonegate bug".
#[test]
fn a_gl_context_without_compute_is_refused_with_its_reason() {
    let no_compute = |args: &[&str]| {
        tonegate()
            .args(args)
            .env("MESA_GL_VERSION_OVERRIDE", "3.3")
            .env(
                "MESA_EXTENSION_OVERRIDE",
                "-GL_ARB_compute_shader -GL_ARB_shader_storage_buffer_object",
            )
            .output()
            .expect("tonegate runs")
    };
    let o = no_compute(&["adapters", "--backend", "gl", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let gl = v["adapters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["backend"] == "Gl")
        .unwrap_or_else(|| panic!("no GL adapter in {v}"));
    let error = gl["error"].as_str().unwrap_or_default();
    assert!(error.contains("no compute shaders"), "{gl}");
    assert!(!error.contains("tonegate bug"), "{gl}");
    // The probe could not run, so nothing is claimed about subnormals.
    assert!(gl["flushes_subnormals"].is_null(), "{gl}");
    for pick in [
        &["--backend", "gl"][..],
        &["--backend", "gl", "--adapter", "llvmpipe"],
    ] {
        let mut args = vec!["check", "--no-history", "--scene", "grid-static"];
        args.extend_from_slice(pick);
        let o = no_compute(&args);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{pick:?}: {e}");
        assert!(
            e.contains("cannot run tonegate") && e.contains("no compute shaders"),
            "{pick:?}: {e}"
        );
        assert!(
            !e.contains("tonegate bug") && !e.contains("buffer limit"),
            "{pick:?}: {e}"
        );
    }
    // The same adapter without the overrides is usable.
    let o = run(&["adapters", "--backend", "gl", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["adapters"]
        .as_array()
        .unwrap()
        .iter()
        .any(|a| a["backend"] == "Gl" && a["error"].is_null()));
}

/// The console shows the limits the page lists, and `--backend default`
/// lists what a GPU command chooses among: Vulkan's adapters, not GL's.
#[test]
fn the_listing_shows_its_limits_and_default_means_vulkan_here() {
    let o = run(&["adapters"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("Gl") && text.contains("Vulkan"), "{text}");
    let limits = text
        .lines()
        .filter(|l| l.trim_start().starts_with("limits: "))
        .count();
    assert!(limits >= 3, "{text}");
    assert!(
        text.contains("storage buffer")
            && text.contains("workgroup")
            && text.contains("divisions as written"),
        "{text}"
    );
    let o = run(&["adapters", "--backend", "default", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let backends: Vec<&str> = v["adapters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["backend"].as_str().unwrap())
        .collect();
    assert!(
        !backends.is_empty() && backends.iter().all(|b| *b == "Vulkan"),
        "{backends:?}"
    );
}
