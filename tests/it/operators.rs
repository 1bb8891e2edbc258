//! The operators locked to their reference implementations
//! (tests/operators/vectors.json, regenerated in CI from pinned versions by
//! tests/operators/make_vectors.sh when the lock's inputs change, ci/locks.sh,
//! and required to be the committed file):
//!
//! - `hable`: colour-hdri's `tonemapping_operator_filmic` at its defaults;
//! - `aces-narkowicz`: Narkowicz's published formula, written out in numpy;
//! - `aces-hill`, `agx`, `pbr-neutral`: three.js's own shader text
//!   (`tonemapping_pars_fragment`), evaluated in f64 by a GLSL-subset
//!   interpreter under node;
//! - `agx` with `look = "punchy"`: glsl-tone-map's `agxPunchy`, the same way;
//! - `pbr-neutral` also against the Khronos reference GLSL's numbers;
//! - `bt2390`: libplacebo's `pl_tone_map_sample` (tests/bt2390/vectors.json,
//!   regenerated in CI by tests/bt2390/make_vectors.sh from Debian's
//!   libplacebo-dev when its inputs change).
//!
//! Then every built-in operator's WGSL against its f64 curve, on lavapipe,
//! for the same inputs.

use serde_json::Value as Json;
use tonegate::operators::{pq_decode, pq_encode, Operator, Value};
use tonegate::reference::luminance_stats::LuminanceStats;

fn vectors() -> Json {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/operators/vectors.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("tests/operators/vectors.json"))
        .unwrap()
}

fn triples(v: &Json) -> Vec<Option<[f64; 3]>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|t| {
            t.as_array()
                .map(|a| [0, 1, 2].map(|k| a[k].as_f64().unwrap()))
        })
        .collect()
}

/// Our f64 curve and the reference's, both in f64 from the same f32 inputs,
/// differ only in the order of operations: a few ulps each. 1e-12 relative
/// (with 1e-15 absolute near 0) is about 4500 ulps of slack, and a changed
/// constant in its fifth digit is 1e-5.
const F64_REL: f64 = 1e-12;
const F64_ABS: f64 = 1e-15;

/// The worst |ours − theirs| / (F64_REL·|theirs| + F64_ABS) over the inputs
/// the reference defines; asserts it is at most 1.
fn lock(name: &str, op: &Operator, inputs: &[Option<[f64; 3]>], want: &Json) -> f64 {
    let tone = op.resolve(&LuminanceStats::default()).unwrap();
    let want = triples(want);
    assert_eq!(want.len(), inputs.len(), "{name}");
    let mut worst = 0.0f64;
    let mut compared = 0;
    for (i, (c, w)) in inputs.iter().zip(&want).enumerate() {
        let (Some(c), Some(w)) = (c, w) else { continue };
        let got = tone.pixel(*c);
        for k in 0..3 {
            let e = (got[k] - w[k]).abs() / (F64_REL * w[k].abs() + F64_ABS);
            assert!(e <= 1.0, "{name} input {i} {c:?}: {got:?} vs {w:?}");
            worst = worst.max(e);
        }
        compared += 1;
    }
    assert!(compared >= 70, "{name}: only {compared} inputs compared");
    worst
}

#[test]
fn each_operator_matches_its_reference_implementation() {
    let v = vectors();
    let inputs = triples(&v["inputs"]);
    let op = |name: &str, given: &[(&str, Value)]| Operator::named(name, given).unwrap();
    let p = &v["hable_params"];
    let hable = op(
        "hable",
        &[
            (
                "shoulder_strength",
                Value::Number(p["shoulder_strength"].as_f64().unwrap()),
            ),
            (
                "linear_strength",
                Value::Number(p["linear_strength"].as_f64().unwrap()),
            ),
            (
                "linear_angle",
                Value::Number(p["linear_angle"].as_f64().unwrap()),
            ),
            (
                "toe_strength",
                Value::Number(p["toe_strength"].as_f64().unwrap()),
            ),
            (
                "toe_numerator",
                Value::Number(p["toe_numerator"].as_f64().unwrap()),
            ),
            (
                "toe_denominator",
                Value::Number(p["toe_denominator"].as_f64().unwrap()),
            ),
            (
                "exposure_bias",
                Value::Number(p["exposure_bias"].as_f64().unwrap()),
            ),
            (
                "white_point",
                Value::Number(p["linear_whitepoint"].as_f64().unwrap()),
            ),
        ],
    );
    // colour-hdri's defaults are the operator's defaults.
    assert_eq!(hable, op("hable", &[]));
    let punchy = op("agx", &[("look", Value::Word("punchy"))]);
    let cases = [
        ("hable", hable, &v["hable"]),
        (
            "aces-narkowicz",
            op("aces-narkowicz", &[]),
            &v["aces_narkowicz"],
        ),
        ("aces-hill", op("aces-hill", &[]), &v["three_aces_filmic"]),
        ("agx", op("agx", &[]), &v["three_agx"]),
        ("agx punchy", punchy, &v["agx_punchy"]),
        ("pbr-neutral", op("pbr-neutral", &[]), &v["three_neutral"]),
        (
            "pbr-neutral (Khronos)",
            op("pbr-neutral", &[]),
            &v["khronos_neutral_reference"]["outputs"],
        ),
    ];
    for (name, op, want) in cases {
        let worst = lock(name, &op, &inputs, want);
        eprintln!("{name}: worst {worst:.3} of the f64 bound");
    }
}

/// A changed constant fails its lock: the lock can fail.
#[test]
fn a_changed_curve_fails_its_lock() {
    let v = vectors();
    let inputs = triples(&v["inputs"]);
    let brighter = Operator::named("aces-hill", &[("exposure", Value::Number(1.0001))]).unwrap();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        lock("aces-hill", &brighter, &inputs, &v["three_aces_filmic"])
    }));
    assert!(r.is_err(), "a 0.01 % exposure change passed the lock");
}

/// Every built-in operator's WGSL against its f64 curve, on the lock's
/// inputs (f32-exact) and a night sky, through the `tonemap` stage.
#[test]
fn every_operators_gpu_curve_matches_its_f64_curve() {
    use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext, GpuInput, GpuRenderer};
    use tonegate::image::HdrImage;
    use tonegate::plan::{Input, StagePlan};
    use tonegate::reference::{self, Pipeline};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap();
    let v = vectors();
    let inputs: Vec<[f32; 3]> = triples(&v["inputs"])
        .into_iter()
        .map(|c| c.unwrap().map(|x| x as f32))
        .collect();
    let night = tonegate::env::BuiltinEnv::Night.generate(64, 32);
    let img = HdrImage::from_fn(64, 34, |x, y| {
        let i = (x + 64 * y) as usize;
        if y < 32 {
            night.pixels[i]
        } else {
            inputs[(i - 64 * 32) % inputs.len()]
        }
    });
    let mut ops: Vec<Operator> = tonegate::operators::builtin()
        .into_iter()
        .map(|d| Operator::with(d, &[]).unwrap())
        .collect();
    ops.push(Operator::named("agx", &[("look", Value::Word("punchy"))]).unwrap());
    ops.push(Operator::named("hable", &[("exposure", Value::Number(4.0))]).unwrap());
    ops.push(Operator::named("aces2", &[("gamut_compression", Value::Flag(false))]).unwrap());
    ops.push(Operator::named("aces2", &[("exposure", Value::Number(16.0))]).unwrap());
    ops.push(
        Operator::named(
            "bt2390",
            &[
                ("source_black", Value::Number(0.005)),
                ("target_black", Value::Number(0.1)),
                ("target_peak", Value::Number(203.0)),
                ("knee_offset", Value::Number(1.0)),
                ("exposure", Value::Number(8.0)),
            ],
        )
        .unwrap(),
    );
    for op in &ops {
        let pipeline = Pipeline {
            operator: op,
            bloom: None,
            grade: None,
            encoding: tonegate::scene::Encoding::Srgb,
        };
        let plan = StagePlan::build(Input::Flat, op, None, None);
        let r = GpuRenderer::new(
            &ctx,
            plan.clone(),
            GpuInput::Flat(&img),
            &pipeline,
            GpuConfig::default(),
        )
        .unwrap();
        let out = r.render(true).unwrap();
        let toned = r.read_output("tonemap").unwrap().unwrap();
        let (_, cpu) = reference::render_flat(&img, &pipeline).unwrap();
        // f32 against f64: 1e-4 relative and 1e-6 absolute per value, the
        // bound the Reinhard stage is held to (tests/it/gpu.rs).
        let mut worst = 0.0f64;
        for (g, c) in toned.pixels.iter().zip(&cpu.toned.pixels) {
            for k in 0..3 {
                worst = worst.max((g[k] - c[k]).abs() / (1e-4 * c[k].abs() + 1e-6));
            }
        }
        assert!(
            worst <= 1.0,
            "{op:?}: GPU off the f64 curve by {worst:.2}x the bound"
        );
        // The encoded frames: at most 1 LSB apart anywhere.
        let frame = out.frame.unwrap();
        let diff = tonegate::metrics::frame_max_abs_diff(&frame, &cpu.frame).unwrap();
        assert!(diff <= 1, "{op:?}: frames {diff} LSB apart");
        eprintln!("{}: worst {worst:.3} of the bound, {diff} LSB", op.name());
    }
}

fn bt2390_vectors() -> Json {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/bt2390/vectors.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("tests/bt2390/vectors.json"))
        .unwrap()
}

fn floats(v: &Json) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// libplacebo evaluates the EETF in f32 (ε = 2⁻²⁴ per rounding). On PQ
/// signals (≤ 1) its dozen roundings stay within 4e-7 (measured worst
/// 1.4e-7, 2026-11-26); a knee or a peak changed in its fifth digit moves
/// the output by more.
const PQ_DOMAIN_TOL: f64 = 4e-7;
/// Given cd/m², libplacebo also converts to PQ and back in f32: its
/// `powf(y, m2)` carries y's rounding times m2 = 78.84 into the signal,
/// once on the way in and once out, so 2·m2·2⁻²⁴ = 9.4e-6 of signal
/// (measured worst 6.2e-6).
const NITS_DOMAIN_TOL: f64 = 2.0 * 78.84375 / 16_777_216.0;

/// The worst |PQ(ours) − PQ(libplacebo)| / tolerance over one case of
/// tests/bt2390/vectors.json, ours being `bt2390` with the case's levels
/// and knee, the exposure 1 and reference_white 1 (so an input is its cd/m²);
/// asserts it is at most 1. `scale` multiplies the target peak (the lock's
/// own test that it can fail).
fn bt2390_lock(case: &Json, inputs: &Json, domain: &str, scale: f64) -> f64 {
    let level = |k: &str| case[k].as_f64().unwrap();
    let (target_black, target_peak) = (level("output_min_nits"), level("output_max_nits") * scale);
    let op = Operator::named(
        "bt2390",
        &[
            ("reference_white", Value::Number(1.0)),
            ("source_black", Value::Number(level("input_min_nits"))),
            ("source_peak", Value::Number(level("input_max_nits"))),
            ("target_black", Value::Number(target_black)),
            ("target_peak", Value::Number(target_peak)),
            ("knee_offset", Value::Number(level("knee_offset"))),
        ],
    )
    .unwrap();
    let tone = op.resolve(&LuminanceStats::default()).unwrap();
    let (tol, to_nits): (f64, fn(f64) -> f64) = match domain {
        "pq" => (PQ_DOMAIN_TOL, pq_decode),
        _ => (NITS_DOMAIN_TOL, |x| x),
    };
    let outputs = floats(&case[domain]["output"]);
    let inputs = floats(&inputs[domain]);
    assert_eq!(inputs.len(), outputs.len());
    assert!(inputs.len() > 200);
    let mut worst = 0.0f64;
    for (x, want) in inputs.iter().zip(&outputs) {
        let display = tone.pixel([to_nits(*x); 3])[0];
        let ours = pq_encode(target_black + display * (target_peak - target_black));
        let theirs = if domain == "pq" {
            *want
        } else {
            pq_encode(*want)
        };
        let e = (ours - theirs).abs() / tol;
        assert!(
            e <= 1.0,
            "{} ({domain}) at {x}: ours {ours} against {theirs}",
            case["name"]
        );
        worst = worst.max(e);
    }
    worst
}

#[test]
fn bt2390_matches_libplacebo() {
    let v = bt2390_vectors();
    assert_eq!(v["libplacebo"], "4.208.0");
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 18);
    for case in cases {
        for domain in ["pq", "nits"] {
            let worst = bt2390_lock(case, &v["inputs"], domain, 1.0);
            eprintln!("{} ({domain}): worst {worst:.3} of the bound", case["name"]);
        }
    }
}

/// A target peak 0.01 % off fails the lock.
#[test]
fn a_changed_eetf_fails_its_lock() {
    let v = bt2390_vectors();
    let case = &v["cases"][0];
    for domain in ["pq", "nits"] {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            bt2390_lock(case, &v["inputs"], domain, 1.0001)
        }));
        assert!(r.is_err(), "{domain}: a 0.01 % target peak change passed");
    }
}
