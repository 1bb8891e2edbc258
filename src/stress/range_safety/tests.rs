use super::chain::{report, stress_inputs, tone_program, Chain, Input};
use super::interp::{Program, Rewrites, Val};
use crate::operators::Operator;

#[test]
fn every_stress_pipeline_is_range_safe_over_the_stress_inputs() {
    let inputs = stress_inputs();
    assert!(inputs.len() >= 12, "{} stress inputs", inputs.len());
    let pipelines = super::super::pipelines();
    // Every operator, and bloom and grade, are in the chains.
    assert!(pipelines.len() >= crate::operators::builtin().len());
    assert!(pipelines
        .iter()
        .any(|(_, s)| s.bloom.is_some() && s.grade.is_some()));
    let mut problems = Vec::new();
    for (name, scene) in &pipelines {
        problems.extend(Chain::new(name, scene).problems(&inputs));
    }
    report(problems);
}

/// The white point of `subnormals/reinhard02` on the NVIDIA H200 (Vulkan,
/// driver 580.159.04, 2026-11-27), and a pixel just under it.
const H200_WHITE: f32 = 3.6864e-34;
const H200_L: f32 = 3.6e-34;

#[test]
fn the_evaluator_finds_each_rewrite_where_it_leaves_the_range() {
    let p = Program::new(
        "fn burn(l: f32, white: f32) -> f32 { return (l / white) / white; }\n\
         fn ratio(p: f32, q: f32) -> f32 { return p / q; }\n\
         fn cancel(x: f32) -> f32 { return x * x - x * x; }\n"
            .to_owned(),
    );
    let burn = || vec![Val::F(H200_L), Val::F(H200_WHITE)];
    // As written, and through reciprocals, (L/white)/white is finite...
    for rw in [
        Rewrites::NONE,
        Rewrites {
            reciprocal: true,
            flush: true,
            ..Rewrites::NONE
        },
    ] {
        let (v, fault) = p.call("burn", burn(), rw);
        assert!(fault.is_none(), "{rw}: {fault:?}");
        assert!(v.expect("a value").f().is_finite());
    }
    // ...and L/(white·white) is not: white² underflows, flushed or not.
    for flush in [false, true] {
        let rw = Rewrites {
            reassociate: true,
            flush,
            ..Rewrites::NONE
        };
        let fault = p.call("burn", burn(), rw).1.expect("white² underflows");
        assert!(fault.what.contains("inf"), "{}", fault.what);
        assert!(fault.line.contains("(l / white) / white"), "{}", fault.line);
    }
    // p·(1/q) with 1/q subnormal and flushed is 0, not 2^-27.
    let args = || vec![Val::F(2f32.powi(100)), Val::F(2f32.powi(127))];
    let as_written = p
        .call("ratio", args(), Rewrites::NONE)
        .0
        .expect("a value")
        .f();
    assert_eq!(as_written, 2f32.powi(-27));
    let rw = Rewrites {
        reciprocal: true,
        flush: true,
        ..Rewrites::NONE
    };
    assert_eq!(p.call("ratio", args(), rw).0.expect("a value").f(), 0.0);
    // A fused multiply-add keeps the rounding error of x·x: x·x − x·x is
    // not 0 under it.
    let x = 1.0f32 + f32::EPSILON;
    let rw = Rewrites {
        fma: true,
        ..Rewrites::NONE
    };
    assert_eq!(
        p.call("cancel", vec![Val::F(x)], Rewrites::NONE).0,
        Some(Val::F(0.0))
    );
    assert_ne!(p.call("cancel", vec![Val::F(x)], rw).0, Some(Val::F(0.0)));
}

#[test]
fn the_shaders_curve_holds_where_the_h200s_went_non_finite() {
    let op = Operator::named("reinhard02", &[]).expect("built in");
    let prog = tone_program(&op);
    for rw in Rewrites::every() {
        let (v, fault) = prog.call(
            "reinhard_curve",
            vec![Val::F(H200_L), Val::F(H200_WHITE)],
            rw,
        );
        assert!(fault.is_none(), "{rw}: {fault:?}");
        let v = v.expect("a value").f();
        // White clamped to 2^-63: the pixel is black, on every rewrite.
        assert!((0.0..1e-20).contains(&v), "{rw}: {v}");
    }
}

/// Values of a number parameter across its declared range: its ends where
/// they are finite, and decades from 1e-30 to 1e30 inside it.
fn sweep(range: crate::operators::Range) -> Vec<f64> {
    let mut v: Vec<f64> = (-30..=30).step_by(5).map(|e| 10f64.powi(e)).collect();
    v.extend([0.0, 0.5, 1.0, 2.0]);
    v.push(range.min);
    if range.max.is_finite() {
        v.push(range.max);
        v.push((range.min + range.max) / 2.0);
    }
    v.retain(|x| range.contains(*x));
    v
}

#[test]
fn every_operator_parameter_across_its_range_is_range_safe() {
    use crate::operators::{Kind, Value};
    let inputs: Vec<Input> = stress_inputs()
        .into_iter()
        .filter(|i| {
            [
                "span_1e-30_to_1e30",
                "subnormals",
                "single_bright_pixel",
                "uniform",
            ]
            .contains(&i.name)
        })
        .map(|mut i| {
            i.pixels.truncate(24);
            i
        })
        .collect();
    let mut problems = Vec::new();
    for def in crate::operators::builtin() {
        for p in def.params() {
            let values: Vec<Value> = match p.kind {
                Kind::Number(r) | Kind::NumberOrAuto(r) => {
                    sweep(r).into_iter().map(Value::Number).collect()
                }
                Kind::Flag => vec![Value::Flag(false), Value::Flag(true)],
                Kind::Word(words) => words.iter().map(|w| Value::Word(w)).collect(),
            };
            for v in values {
                let Ok(op) = crate::operators::Operator::with(def.clone(), &[(p.name, v)]) else {
                    continue;
                };
                let mut scene = super::super::pipelines()
                    .into_iter()
                    .find(|(n, _)| *n == def.name().replace('-', "_"))
                    .map(|(_, s)| s)
                    .unwrap_or_else(|| super::super::pipelines().remove(0).1);
                scene.operator = op;
                let label = format!("{} {}={v}", def.name(), p.name);
                problems.extend(Chain::new(&label, &scene).problems(&inputs));
            }
        }
    }
    report(problems);
}

#[test]
fn the_reinhard_operators_hold_at_the_corners_of_their_ranges() {
    use crate::operators::{Kind, Value};
    let inputs: Vec<Input> = stress_inputs()
        .into_iter()
        .filter(|i| ["span_1e-30_to_1e30", "subnormals"].contains(&i.name))
        .map(|mut i| {
            i.pixels.truncate(16);
            i
        })
        .collect();
    let mut problems = Vec::new();
    for (name, scene) in super::super::pipelines() {
        let def = scene.operator.definition_arc();
        // The number parameters that set the curve's scale together.
        let params: Vec<(&str, crate::operators::Range)> = def
            .params()
            .iter()
            .filter_map(|p| match p.kind {
                Kind::Number(r) | Kind::NumberOrAuto(r)
                    if ["key", "log_average", "white", "max_luminance", "exposure"]
                        .contains(&p.name) =>
                {
                    Some((p.name, r))
                }
                _ => None,
            })
            .collect();
        for corner in 0u32..(1 << params.len()) {
            let given: Vec<(&str, Value)> = params
                .iter()
                .enumerate()
                .map(|(i, (n, r))| {
                    let hi = if r.max.is_finite() { r.max } else { 1e30 };
                    let lo = if r.min > 0.0 { r.min } else { 1e-30 };
                    (
                        *n,
                        Value::Number(if corner & (1 << i) != 0 { hi } else { lo }),
                    )
                })
                .collect();
            let Ok(op) = crate::operators::Operator::with(def.clone(), &given) else {
                continue;
            };
            let mut scene = scene.clone();
            scene.operator = op;
            let label = format!("{name} {given:?}");
            problems.extend(Chain::new(&label, &scene).problems(&inputs));
        }
    }
    report(problems);
}
