//! WGSL sources: one file per stage in `shaders/`, shared code in
//! `shaders/shared/`, joined by `//#include shared/<file>.wgsl` lines.
//!
//! WGSL has no include; this is the smallest thing that keeps the shared code
//! in one place. `HDR_FORMAT` names the intermediate texture format.

use super::HdrFormat;

/// (path relative to shaders/, contents), embedded at build time.
const SOURCES: &[(&str, &str)] = &[
    (
        "shared/frame.wgsl",
        include_str!("../../shaders/shared/frame.wgsl"),
    ),
    (
        "shared/conventions.wgsl",
        include_str!("../../shaders/shared/conventions.wgsl"),
    ),
    (
        "shared/colour.wgsl",
        include_str!("../../shaders/shared/colour.wgsl"),
    ),
    (
        "shared/stats.wgsl",
        include_str!("../../shaders/shared/stats.wgsl"),
    ),
    (
        "shared/tone.wgsl",
        include_str!("../../shaders/shared/tone.wgsl"),
    ),
    (
        "shared/reinhard.wgsl",
        include_str!("../../shaders/shared/reinhard.wgsl"),
    ),
    (
        "shared/bright.wgsl",
        include_str!("../../shaders/shared/bright.wgsl"),
    ),
    (
        "shared/upsample.wgsl",
        include_str!("../../shaders/shared/upsample.wgsl"),
    ),
    (
        "shared/pq.wgsl",
        include_str!("../../shaders/shared/pq.wgsl"),
    ),
    (
        "shared/encode.wgsl",
        include_str!("../../shaders/shared/encode.wgsl"),
    ),
    (
        "shared/downsample.wgsl",
        include_str!("../../shaders/shared/downsample.wgsl"),
    ),
    (
        "shared/extent.wgsl",
        include_str!("../../shaders/shared/extent.wgsl"),
    ),
    (
        "shared/subgroup.wgsl",
        include_str!("../../shaders/shared/subgroup.wgsl"),
    ),
    ("sphere.wgsl", include_str!("../../shaders/sphere.wgsl")),
    (
        "adaptation.wgsl",
        include_str!("../../shaders/adaptation.wgsl"),
    ),
    (
        "luminance_stats.wgsl",
        include_str!("../../shaders/luminance_stats.wgsl"),
    ),
    ("tonemap.wgsl", include_str!("../../shaders/tonemap.wgsl")),
    (
        "bloom_bright.wgsl",
        include_str!("../../shaders/bloom_bright.wgsl"),
    ),
    (
        "bloom_downsample.wgsl",
        include_str!("../../shaders/bloom_downsample.wgsl"),
    ),
    (
        "bloom_blur.wgsl",
        include_str!("../../shaders/bloom_blur.wgsl"),
    ),
    (
        "bloom_composite.wgsl",
        include_str!("../../shaders/bloom_composite.wgsl"),
    ),
    (
        "grade_stats.wgsl",
        include_str!("../../shaders/grade_stats.wgsl"),
    ),
    ("grade.wgsl", include_str!("../../shaders/grade.wgsl")),
    ("encode.wgsl", include_str!("../../shaders/encode.wgsl")),
    (
        "taa_sobel.wgsl",
        include_str!("../../shaders/taa_sobel.wgsl"),
    ),
    ("taa.wgsl", include_str!("../../shaders/taa.wgsl")),
    ("floor.wgsl", include_str!("../../shaders/floor.wgsl")),
    ("flip.wgsl", include_str!("../../shaders/flip.wgsl")),
    ("compare.wgsl", include_str!("../../shaders/compare.wgsl")),
    ("fused.wgsl", include_str!("../../shaders/fused.wgsl")),
    (
        "subnormal_probe.wgsl",
        include_str!("../../shaders/subnormal_probe.wgsl"),
    ),
];

/// Whether stage `name` includes an operator's module.
pub fn takes_operator(name: &str) -> bool {
    raw(&format!("{name}.wgsl"))
        .is_some_and(|t| t.lines().any(|l| l.trim() == "//#include operator"))
}

/// The stage shaders (not the shared files).
pub fn stage_names() -> impl Iterator<Item = &'static str> {
    SOURCES
        .iter()
        .filter(|(p, _)| !p.starts_with("shared/"))
        .map(|(p, _)| p.trim_end_matches(".wgsl"))
}

fn raw(path: &str) -> Option<&'static str> {
    SOURCES.iter().find(|(p, _)| *p == path).map(|(_, s)| *s)
}

/// The complete source of stage `name` with includes expanded (each once),
/// `HDR_FORMAT` replaced, and the lines between `//#if subgroups` and
/// `//#endif` kept only when `subgroups` (the device has subgroup
/// operations: a module that uses them does not validate on one without).
/// Panics only on a missing file or an unclosed section, which the shader
/// tests catch at `cargo test` time.
pub fn compose(name: &str, format: HdrFormat, subgroups: bool) -> String {
    compose_with(name, format, subgroups, None)
}

/// [`compose`] with an operator's module (`ToneOperator::wgsl`) in place of
/// the stage's `//#include operator` line; its own includes are expanded
/// like the stage's.
pub fn compose_with(
    name: &str,
    format: HdrFormat,
    subgroups: bool,
    operator: Option<&str>,
) -> String {
    let mut out = String::new();
    let mut included: Vec<&'static str> = Vec::new();
    let path = format!("{name}.wgsl");
    let text = raw(&path).unwrap_or_else(|| panic!("shader {path} is not embedded"));
    let ctx = Expand {
        subgroups,
        operator,
    };
    ctx.expand(&path, text, &mut out, &mut included);
    out.replace("HDR_FORMAT", format.wgsl_name())
}

struct Expand<'o> {
    subgroups: bool,
    operator: Option<&'o str>,
}

impl Expand<'_> {
    fn expand(&self, path: &str, text: &str, out: &mut String, included: &mut Vec<&'static str>) {
        let mut skipping = false;
        let mut open = false;
        for line in text.lines() {
            match line.trim() {
                "//#if subgroups" => {
                    assert!(!open, "{path}: nested //#if");
                    open = true;
                    skipping = !self.subgroups;
                    continue;
                }
                "//#endif" => {
                    assert!(open, "{path}: //#endif without //#if");
                    open = false;
                    skipping = false;
                    continue;
                }
                _ if skipping => continue,
                _ => {}
            }
            match line.trim().strip_prefix("//#include ").map(str::trim) {
                Some("operator") => {
                    let op = self.operator.unwrap_or_else(|| {
                        panic!("{path} includes the operator, and none was given")
                    });
                    self.expand("operator", op, out, included);
                }
                Some(inc) => {
                    let known = SOURCES.iter().find(|(p, _)| *p == inc);
                    let (inc, body) =
                        *known.unwrap_or_else(|| panic!("{path}: unknown include {inc}"));
                    if !included.contains(&inc) {
                        included.push(inc);
                        self.expand(inc, body, out, included);
                    }
                }
                None => {
                    out.push_str(line);
                    out.push('\n');
                }
            }
        }
        assert!(!open, "{path}: //#if without //#endif");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stage_shader_validates_with_naga_for_both_formats() {
        for (format, subgroups) in [
            (HdrFormat::Rgba16Float, false),
            (HdrFormat::Rgba32Float, false),
            (HdrFormat::Rgba32Float, true),
        ] {
            let stages = stage_names().flat_map(|name| {
                let ops: Vec<Option<&'static str>> = if takes_operator(name) {
                    crate::operators::builtin()
                        .iter()
                        .map(|o| Some(o.wgsl()))
                        .collect()
                } else {
                    vec![None]
                };
                ops.into_iter().map(move |op| (name, op))
            });
            for (name, op) in stages {
                let src = compose_with(name, format, subgroups, op);
                let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| {
                    panic!("{name}.wgsl: {}", e.emit_to_string_with_path(&src, name))
                });
                let mut validator = naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::all(),
                );
                if let Err(e) = validator.validate(&module) {
                    panic!("{name}.wgsl: {}", e.emit_to_string_with_path(&src, name));
                }
            }
        }
    }

    #[test]
    fn includes_expand_once() {
        let src = compose("grade_stats", HdrFormat::Rgba32Float, false);
        assert_eq!(src.matches("fn kahan_add").count(), 1);
        assert!(!src.contains("//#include"));
        assert!(compose("sphere", HdrFormat::Rgba16Float, false).contains("rgba16float"));
    }

    #[test]
    fn subgroup_sections_appear_only_for_a_device_with_subgroups() {
        for stage in ["luminance_stats", "grade_stats"] {
            let without = compose(stage, HdrFormat::Rgba32Float, false);
            let with = compose(stage, HdrFormat::Rgba32Float, true);
            assert!(!without.contains("subgroupShuffleXor"), "{stage}");
            assert!(with.contains("subgroupShuffleXor"), "{stage}");
            assert!(!with.contains("//#if") && !with.contains("//#endif"));
            // Everything else is the same.
            assert!(with.len() > without.len());
            assert!(with.contains("fn tree_finish") && without.contains("fn tree_finish"));
        }
    }

    #[test]
    fn every_stage_of_the_plan_has_a_shader_and_a_reference() {
        // One stage, one name: the WGSL file, the CPU reference module and the label.
        let names: Vec<&str> = stage_names().collect();
        for stage in crate::plan::Stage::NAMES {
            assert!(names.contains(&stage), "no shaders/{stage}.wgsl");
        }
    }
}
