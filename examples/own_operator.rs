//! Your own tone-mapping operator, in your own crate, with tonegate's whole
//! harness: it implements `tonegate::operators::ToneOperator` once (its
//! parameters, its f64 curve, its WGSL), is registered, and from then on a
//! scene file names it like a built-in operator; its CPU reference renders
//! the frames goldens are made of, the GPU runs its WGSL and is compared
//! with that reference, and the stress suite's extreme inputs go through
//! both renderers.
//!
//! The operator here is the simple exponential curve 1 − e^(−exposure·x),
//! per channel. Run it with `cargo run --example own_operator` (lavapipe,
//! `mesa-vulkan-drivers`, is the default adapter); it exits 1 if the GPU
//! drifts from the reference or a stress row fails.

use std::process::ExitCode;
use std::sync::Arc;
use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext, ReductionMethod};
use tonegate::operators::{
    self, Curve, Kind, LuminanceStats, Param, Range, Resolution, ToneOperator, Unmeasured, Value,
    Values,
};
use tonegate::render::{scene_environment, SceneRenderer};
use tonegate::scene::Scene;

/// 1 − e^(−exposure·x) per channel: no statistics, one parameter.
struct Exponential;

const PARAMS: &[Param] = &[Param {
    // A parameter shares its flag with other operators' of the same name
    // and type: `exposure` is the fixed curves' own.
    name: "exposure",
    doc: "Gain on the linear input before the curve",
    kind: Kind::Number(Range::POSITIVE),
    default: Value::Number(1.0),
}];

struct ExponentialCurve {
    exposure: f64,
}

impl Curve for ExponentialCurve {
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        // −expm1(−x) is 1 − e^(−x) without cancellation near 0.
        c.map(|x| -(-self.exposure * x).exp_m1())
    }
}

/// The same curve for the GPU: the three items every operator's WGSL
/// defines (the `ToneOperator` documentation says what they receive).
const WGSL: &str = r#"
struct OperatorConfig {
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    return 1.0 - exp(-r.x * c);
}
"#;

impl ToneOperator for Exponential {
    fn name(&self) -> &'static str {
        "exponential"
    }
    fn summary(&self) -> &'static str {
        "1 − e^(−exposure·x) per channel (an example of a caller's own operator)"
    }
    fn params(&self) -> &'static [Param] {
        PARAMS
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        &["exposure"]
    }
    fn resolve(&self, v: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        let exposure = v.num("exposure");
        Ok(Resolution {
            values: vec![("exposure", exposure)],
            curve: Box::new(ExponentialCurve { exposure }),
        })
    }
    fn wgsl(&self) -> &'static str {
        WGSL
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        vec![v.num("exposure") as f32]
    }
}

/// A scene names the operator as it would a built-in one.
const SCENE: &str = r#"
name = "sky-exponential"
size = [160, 90]
frames = 4

[environment]
builtin = "sky"
size = [512, 256]

[rotation]
degrees_per_frame = 6.0

[operator]
kind = "exponential"
exposure = 0.5
"#;

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("own_operator: {e}");
            ExitCode::from(2)
        }
    }
}

fn run() -> Result<bool, Box<dyn std::error::Error>> {
    operators::register(Arc::new(Exponential))?;
    let scene = Scene::parse(SCENE, std::path::Path::new("sky-exponential.toml"))?;
    let env = scene_environment(&scene)?;
    let ctx = GpuContext::new(&AdapterChoice::default())?;
    let spp = 4;
    // The reference (what `tonegate golden bless` stores) and the GPU.
    let cpu = SceneRenderer::cpu(&scene, &env, spp);
    let gpu = SceneRenderer::gpu(&scene, &env, &ctx, GpuConfig::default(), spp)?;
    let mut ok = true;
    for n in 0..scene.frames {
        let (want, got) = (cpu.frame(n)?, gpu.frame(n)?);
        let (m, _) = tonegate::metrics::compare_frames(&got.image, &want.image)?;
        let over = tonegate::metrics::frame_fraction_over(&got.image, &want.image, 1)?;
        // The gate's GPU-vs-CPU accuracy bounds (docs/tolerances.md).
        let passed = m.psnr >= 50.0 && over <= 0.001;
        ok &= passed;
        println!(
            "frame {n}: GPU against the f64 reference {:.2} dB, {:.4} of pixels over 1 LSB, {}",
            m.psnr,
            over,
            if passed { "ok" } else { "FAILED" }
        );
    }
    // The extreme inputs: the operator is one of the stress suite's
    // pipelines, on both renderers.
    let cases: Vec<_> = tonegate::stress::cases::all(false)
        .into_iter()
        .filter(|c| {
            [
                "all_black",
                "single_bright_pixel",
                "span_1e-30_to_1e30",
                "beyond_f16_with_f16",
                "subnormals",
            ]
            .contains(&c.name)
        })
        .collect();
    let report = tonegate::stress::run(&cases, Some(&ctx), ReductionMethod::Auto);
    for row in report.cases.iter().filter(|r| r.pipeline == "exponential") {
        ok &= row.passed;
        println!(
            "stress {} on {}: {} ({})",
            row.case,
            row.renderer,
            if row.passed { "ok" } else { "FAILED" },
            row.observed
        );
    }
    println!("adapter: {}", ctx.adapter.name);
    Ok(ok)
}
