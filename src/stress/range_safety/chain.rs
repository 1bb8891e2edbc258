//! What the proof evaluates: the stress inputs, the host's constants and
//! uniforms, and one scene's chain of stages from statistics to display
//! codes, under each rewrite.

use super::super::cases::Source;
use super::interp::{Program, Rewrites, Val};
use crate::gpu::{shaders, HdrFormat};
use crate::image::HdrImage;
use crate::operators::Operator;
use std::collections::HashSet;

/// The stress suite's inputs as the renderers receive them (after the
/// loader's policy), each cut to at most `MAX_PIXELS` distinct pixels: the
/// darkest and brightest, then an even stride. The frame beyond the
/// texture limit and the ≥ 8 Mpx ramp repeat values the others have.
const MAX_PIXELS: usize = 96;

pub(super) struct Input {
    pub(super) name: &'static str,
    pub(super) image: HdrImage,
    pub(super) pixels: Vec<[f32; 3]>,
}

pub(super) fn stress_inputs() -> Vec<Input> {
    super::super::cases::all(false)
        .iter()
        .filter(|c| !matches!(c.source, Source::BeyondTextureLimit { .. }))
        .filter_map(|c| {
            let (image, _) = super::super::load(c, 64).ok()?;
            let pixels = sample(&image);
            Some(Input {
                name: c.name,
                image,
                pixels,
            })
        })
        .collect()
}

pub(super) fn sample(img: &HdrImage) -> Vec<[f32; 3]> {
    let mut seen = HashSet::new();
    let distinct: Vec<[f32; 3]> = img
        .pixels
        .iter()
        .filter(|p| seen.insert(p.map(f32::to_bits)))
        .copied()
        .collect();
    if distinct.len() <= MAX_PIXELS {
        return distinct;
    }
    let y = |p: &[f32; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let lo = distinct
        .iter()
        .copied()
        .min_by(|a, b| y(a).total_cmp(&y(b)))
        .expect("non-empty");
    let hi = distinct
        .iter()
        .copied()
        .max_by(|a, b| y(a).total_cmp(&y(b)))
        .expect("non-empty");
    let step = distinct.len().div_ceil(MAX_PIXELS - 2);
    let mut out = vec![lo, hi];
    out.extend(distinct.iter().step_by(step));
    out
}

/// The `tonemap` stage's module for `op`, with the host's override
/// constants and `OperatorConfig` uniform.
pub(super) fn tone_program(op: &Operator) -> Program {
    let def = op.definition();
    let source = shaders::compose_with("tonemap", HdrFormat::Rgba32Float, false, Some(def.wgsl()));
    let mut p = Program::new(source);
    let mut constants = def.gpu_constants(op.values());
    constants.push(("FAULT_GAIN", 1.0));
    p.overrides(&constants);
    let config = p.struct_from_words("OperatorConfig", &def.gpu_config(op.values()));
    p.global("config", config.clone());
    p
}

/// The GPU's statistics for `img` under `op`'s luminance, as the
/// `luminance_stats` stage hands them to `operator_resolve` (f32).
pub(super) fn stats_words(op: &Operator, img: &HdrImage) -> Vec<f32> {
    let lum = op.definition().luminance(op.values());
    let s = super::super::independent_stats(&img.to_linear(), lum.weights, lum.delta);
    let f = |v: Option<f64>| v.unwrap_or(0.0) as f32;
    vec![
        f(s.log_average),
        f(s.weighted_log_average),
        f(s.min),
        f(s.max),
        f(s.weight_sum),
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ]
}

/// One stage's module with its override constants.
fn stage_program(stage: &str, constants: &[(&str, f64)]) -> Program {
    let mut p = Program::new(shaders::compose(stage, HdrFormat::Rgba32Float, false));
    p.overrides(constants);
    p
}

/// What one scene's stages are evaluated with: the tone-mapping stage and
/// the statistics, bloom, grade and encode stages it uses.
pub(super) struct Chain {
    label: String,
    op: Operator,
    tone: Program,
    config: Val,
    stats: Program,
    bright: Option<(Program, bool)>,
    composite: Option<Program>,
    grade: Option<Program>,
    encode: Program,
}

impl Chain {
    pub(super) fn new(label: &str, scene: &crate::scene::Scene) -> Chain {
        let op = scene.operator.clone();
        let def = op.definition();
        let lum = def.luminance(op.values());
        let tone = tone_program(&op);
        let config = tone.struct_from_words("OperatorConfig", &def.gpu_config(op.values()));
        let stats = stage_program(
            "luminance_stats",
            &crate::gpu::stats_constants(def.needs(op.values()), lum.weights, lum.delta),
        );
        let bright = scene.bloom.as_ref().map(|b| {
            let from_toned = b.bright_pass == crate::scene::BrightPass::Threshold;
            (
                stage_program(
                    "bloom_bright",
                    &crate::gpu::bright_constants(b, lum.weights),
                ),
                from_toned,
            )
        });
        let composite = scene
            .bloom
            .as_ref()
            .map(|b| stage_program("bloom_composite", &[("STRENGTH", b.strength.get())]));
        let grade = scene
            .grade
            .as_ref()
            .map(|g| stage_program("grade", &crate::gpu::grade_constants(g)));
        let encode = stage_program(
            "encode",
            &crate::gpu::encode_constants(scene.encoding, def.display_levels(op.values())),
        );
        Chain {
            label: label.to_owned(),
            op,
            tone,
            config,
            stats,
            bright,
            composite,
            grade,
            encode,
        }
    }

    /// The display codes of `input`'s pixels under `rw`, or the first
    /// non-finite intermediate, named by stage and WGSL line.
    pub(super) fn codes(&self, input: &Input, rw: Rewrites) -> Result<Vec<Vec<u32>>, String> {
        let at = |stage: &str, c: Option<&[f32; 3]>, f: super::interp::Fault| {
            let pixel = c.map(|c| format!(" pixel {c:?}")).unwrap_or_default();
            format!(
                "{} on {}{pixel}: {stage}, line {}: `{}`: {}",
                self.label, input.name, f.line_number, f.line, f.what
            )
        };
        for c in &input.pixels {
            if let (_, Some(f)) = self.stats.call("pixel_partial", vec![Val::vec3(*c)], rw) {
                return Err(at("luminance_stats", Some(c), f));
            }
        }
        let words = stats_words(&self.op, &input.image);
        let max_y = words[3];
        let stats = self.tone.struct_from_words("Stats", &words);
        let (r, fault) = self
            .tone
            .call("operator_resolve", vec![stats, self.config.clone()], rw);
        if let Some(f) = fault {
            return Err(at("tonemap (resolve)", None, f));
        }
        let r = r.expect("operator_resolve returns the resolved vec4");
        let mut toned = Vec::new();
        for c in &input.pixels {
            match self.tone.call("toned", vec![Val::vec3(*c), r.clone()], rw) {
                (_, Some(f)) => return Err(at("tonemap", Some(c), f)),
                (v, None) => toned.push(v.expect("a colour")),
            }
        }
        let mut out = toned.clone();
        if let (Some((bright, from_toned)), Some(composite)) = (&self.bright, &self.composite) {
            // The bloom at a pixel is a blur of bright-pass values (weights
            // that sum to 1), so it lies between their least and greatest:
            // the greatest is added to every pixel, the worst case.
            let mut top = [0.0f32; 3];
            for (c, t) in input.pixels.iter().zip(&toned) {
                let src = if *from_toned {
                    t.clone()
                } else {
                    Val::vec3(*c)
                };
                match bright.call("bright_pixel", vec![src, Val::F(max_y)], rw) {
                    (_, Some(f)) => return Err(at("bloom_bright", Some(c), f)),
                    (v, None) => {
                        for (t, x) in top.iter_mut().zip(v.expect("a colour").floats()) {
                            *t = t.max(x);
                        }
                    }
                }
            }
            for (o, c) in out.iter_mut().zip(&input.pixels) {
                match composite.call("bloom_add", vec![o.clone(), Val::vec3(top)], rw) {
                    (_, Some(f)) => return Err(at("bloom_composite", Some(c), f)),
                    (v, None) => *o = v.expect("a colour"),
                }
            }
        }
        if let Some(grade) = &self.grade {
            let n = out.len().max(1) as f64;
            let mean = out
                .iter()
                .map(|v| {
                    let f = v.floats();
                    0.2125 * f[0] as f64 + 0.7154 * f[1] as f64 + 0.0721 * f[2] as f64
                })
                .sum::<f64>()
                / n;
            for (o, c) in out.iter_mut().zip(&input.pixels) {
                match grade.call("grade_pixel", vec![o.clone(), Val::F(mean as f32)], rw) {
                    (_, Some(f)) => return Err(at("grade", Some(c), f)),
                    (v, None) => *o = v.expect("a colour"),
                }
            }
        }
        let mut codes = Vec::new();
        for (o, c) in out.iter().zip(&input.pixels) {
            let mut px = Vec::new();
            for v in o.floats() {
                match self.encode.call("encode_channel", vec![Val::F(v)], rw) {
                    (_, Some(f)) => return Err(at("encode", Some(c), f)),
                    (Some(Val::U(code)), None) => px.push(code),
                    (other, None) => panic!("encode_channel returned {other:?}"),
                }
            }
            codes.push(px);
        }
        Ok(codes)
    }

    /// Every problem over `inputs` and every rewrite: a non-finite
    /// intermediate, or a display code more than [`MAX_CODE_DELTA`] from
    /// the code as written.
    pub(super) fn problems(&self, inputs: &[Input]) -> Vec<String> {
        let mut problems = Vec::new();
        for input in inputs {
            let written = match self.codes(input, Rewrites::NONE) {
                Ok(c) => c,
                Err(e) => {
                    problems.push(format!("{e} (as written)"));
                    continue;
                }
            };
            for rw in Rewrites::every().skip(1) {
                match self.codes(input, rw) {
                    Err(e) => problems.push(e),
                    Ok(codes) => {
                        let worst = codes
                            .iter()
                            .zip(&written)
                            .enumerate()
                            .flat_map(|(i, (a, b))| {
                                a.iter().zip(b).map(move |(a, b)| (a.abs_diff(*b), i))
                            })
                            .max();
                        if let Some((delta, i)) = worst.filter(|(d, _)| *d > MAX_CODE_DELTA) {
                            problems.push(format!(
                                "{} on {} pixel {:?}: codes {:?} with {rw}, {:?} as written ({delta} apart)",
                                self.label, input.name, input.pixels[i], codes[i], written[i]
                            ));
                        }
                    }
                }
            }
        }
        problems
    }
}

/// How far a display code under a rewrite may be from the code as
/// written: one. A rewrite changes the last bits of an f32, and a value
/// that close to a step between two codes may land on either side of it.
pub(super) const MAX_CODE_DELTA: u32 = 1;

pub(super) fn report(problems: Vec<String>) {
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}
