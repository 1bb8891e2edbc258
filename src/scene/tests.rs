use super::file::line_of;
use super::*;
use crate::check::Check;
use crate::operators::Operator;
use crate::operators::Value;
use std::path::Path;

const MINIMAL: &str = r#"
name = "t"
size = [32, 18]
frames = 2
[environment]
builtin = "sky"
size = [64, 32]
[rotation]
degrees_per_frame = 5.0
"#;

fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::parse(text, Path::new("scene.toml"))
}

#[test]
fn minimal_scene_takes_defaults() {
    let s = parse(MINIMAL).unwrap();
    assert_eq!(s.operator, Operator::default());
    assert_eq!(s.reference_spp, 16);
    assert_eq!(s.fov_y, 60.0);
    assert_eq!(s.rotation.axis, [1.0, 0.0, 0.0]);
    assert_eq!(s.encoding, Encoding::Srgb);
}

#[test]
fn unknown_key_names_key_file_and_line() {
    let text = MINIMAL.replace("frames = 2", "frames = 2\nfrobnicate = 1");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("scene.toml") && e.contains("frobnicate") && e.contains("line 5"),
        "{e}"
    );
}

#[test]
fn unknown_key_in_operator_is_refused() {
    let text = format!("{MINIMAL}\n[operator]\nkind = \"seed000\"\nkee = 0.2\n");
    let e = parse(&text).unwrap_err().to_string();
    assert!(e.contains("kee") && e.contains("line"), "{e}");
}

#[test]
fn out_of_range_values_name_their_line() {
    let text = format!("{MINIMAL}\n[operator]\nkind = \"reinhard02\"\nkey = -1.0\n");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("must be in [1e-6, 100]") && e.contains("line 13"),
        "{e}"
    );
    let text = MINIMAL.replace("size = [32, 18]", "size = [0, 18]");
    let e = parse(&text).unwrap_err().to_string();
    assert!(e.contains("at least 1x1") && e.contains("line 3"), "{e}");
    let text = MINIMAL.replace("frames = 2", "frames = 0");
    let e = parse(&text).unwrap_err().to_string();
    assert!(e.contains("frames") && e.contains("line 4"), "{e}");
    let text = format!("{MINIMAL}\n[operator]\nkind = \"seed000\"\nwhite_fraction = 1.5\n");
    assert!(parse(&text)
        .unwrap_err()
        .to_string()
        .contains("white_fraction"));
    let text = format!("{MINIMAL}\n[operator]\nkind = \"seed001\"\nwhite = 2.0\n");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("white: applies to operator reinhard02 only, not reinhard-auto-key")
            && e.contains("line 11"),
        "{e}"
    );
    let text = format!("{MINIMAL}\n[operator]\nkind = \"seed000\"\nkey = \"auto\"\n");
    assert!(parse(&text)
        .unwrap_err()
        .to_string()
        .contains("needs a number"));
}

#[test]
fn absurd_output_size_is_refused() {
    let text = MINIMAL.replace("size = [32, 18]", "size = [100000, 100000]");
    assert!(parse(&text)
        .unwrap_err()
        .to_string()
        .contains("exceeds the limit"));
}

#[test]
fn operator_variants_and_auto_key_parse() {
    let text =
        format!("{MINIMAL}\n[operator]\nkind = \"seed001\"\nkey = \"auto\"\ncolour = \"xyy\"\n");
    let s = parse(&text).unwrap();
    assert_eq!(
        s.operator,
        Operator::named(
            "reinhard-auto-key",
            &[("key", Value::Auto), ("colour", Value::Word("xyy"))]
        )
        .unwrap()
    );
    let text = format!("{MINIMAL}\n[operator]\nkind = \"seed001\"\nkey = 0.3\n");
    let s = parse(&text).unwrap();
    assert_eq!(s.operator.name(), "reinhard-auto-key");
    assert_eq!(s.operator.values().number("key"), Some(0.3));
}

/// Scene files written with the operators' and the bright pass's first
/// names (after the papers they came from) still parse, to the same
/// operator; a scene is written back with the names that say what it is.
#[test]
fn the_first_names_of_operators_and_bright_passes_still_parse() {
    let bloom = "[bloom]\nbright_pass = \"BP\"\nthreshold = 1.0\nsigma = 1.5\nstrength = 0.5\n";
    for (old, new) in [
        ("seed000", "reinhard-global"),
        ("seed001", "reinhard-auto-key"),
    ] {
        let scene = |kind: &str, pass: &str| {
            let text = format!(
                "{MINIMAL}\n[operator]\nkind = \"{kind}\"\n{}",
                bloom.replace("BP", pass)
            );
            parse(&text).unwrap_or_else(|e| panic!("{kind}: {e}"))
        };
        let (a, b) = (scene(old, "seed001"), scene(new, "scaled"));
        assert_eq!(a.operator, b.operator, "{old} and {new}");
        assert_eq!(a.bloom, b.bloom, "{old}'s bloom");
        assert_eq!(a.hash(), b.hash(), "{old}: the same scene");
        let written = toml::to_string(&a).unwrap();
        assert!(
            written.contains(&format!("kind = \"{new}\""))
                && written.contains("bright_pass = \"scaled\""),
            "{written}"
        );
    }
}

#[test]
fn checks_parse_with_adapter_overrides() {
    let text = format!(
            "{MINIMAL}\n[[checks]]\nmin_psnr = 30.0\n[[checks]]\nmin_ssim = 0.9\nadapter = \"llvmpipe\"\nset_by = \"measured\"\n[[checks]]\nmax_fraction_over = {{ lsb = 1, fraction = 0.01 }}\n"
        );
    let s = parse(&text).unwrap();
    assert_eq!(s.checks.len(), 3);
    assert_eq!(s.checks[0].check, Check::MinPsnr(30.0));
    assert_eq!(s.checks[1].adapter.as_deref(), Some("llvmpipe"));
}

#[test]
fn the_mean_abs_diff_check_parses_and_refuses_a_negative_bound() {
    let text = format!("{MINIMAL}\n[[checks]]\nmax_mean_abs_diff = 0.25\n");
    let s = parse(&text).unwrap();
    assert_eq!(s.checks[0].check, Check::MaxMeanAbsDiff(0.25));
    let text = format!("{MINIMAL}\n[[checks]]\nmax_mean_abs_diff = -1.0\n");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("bound out of range") && e.contains("checks"),
        "{e}"
    );
}

#[test]
fn taa_keys_parse_and_bad_values_name_their_key() {
    let text =
        format!("{MINIMAL}\n[taa]\nvariant = \"edge_aware\"\nsharpen = 0.25\nreset_frames = [1]\n");
    let s = parse(&text).unwrap();
    let t = s.taa_active().unwrap();
    assert_eq!(t.variant, TaaVariant::EdgeAware);
    assert_eq!((t.feedback_min.get(), t.feedback_max.get()), (0.88, 0.97));
    assert!(t.resets_at(0) && t.resets_at(1));
    assert_eq!(s.default_spp(), 1);
    let off = parse(&format!("{MINIMAL}\n[taa]\nvariant = \"off\"\n")).unwrap();
    assert!(off.taa_active().is_none() && off.default_spp() == 1);
    assert_eq!(parse(MINIMAL).unwrap().default_spp(), 16);
    for (extra, needle) in [
        ("variant = \"fxaa\"", "fxaa"),
        ("feedback_max = 1.0", "feedback_max"),
        ("sharpen = 2.0", "sharpen"),
        ("feedback_min = 0.99", "feedback_min 0.99 exceeds"),
        ("reset_frames = [2]", "past the sequence's last frame 1"),
        ("jitter = 8", "jitter"),
    ] {
        let e = parse(&format!("{MINIMAL}\n[taa]\n{extra}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle) && e.contains("line"), "{extra}: {e}");
    }
    let one = MINIMAL.replace("frames = 2", "frames = 2\nreference_spp = 1");
    let e = parse(&format!("{one}\n[taa]\n")).unwrap_err().to_string();
    assert!(
        e.contains("reference_spp") && e.contains("at least 2"),
        "{e}"
    );
}

#[test]
fn hash_ignores_formatting_but_not_parameters() {
    let a = parse(MINIMAL).unwrap();
    let b = parse(&MINIMAL.replace("frames = 2", "frames   =   2 # two")).unwrap();
    let c = parse(&MINIMAL.replace("frames = 2", "frames = 3")).unwrap();
    assert_eq!(a.hash(), b.hash());
    assert_ne!(a.hash(), c.hash());
}

#[test]
fn environment_needs_exactly_one_source() {
    let text = MINIMAL.replace("builtin = \"sky\"", "");
    assert!(parse(&text)
        .unwrap_err()
        .to_string()
        .contains("exactly one"));
    let text = MINIMAL.replace("builtin = \"sky\"", "builtin = \"moon\"");
    assert!(parse(&text).unwrap_err().to_string().contains("moon"));
}

#[test]
fn size_parses_from_command_line_form() {
    assert_eq!(
        "320x180".parse::<Size>(),
        Ok(Size {
            width: 320,
            height: 180
        })
    );
    assert!("320".parse::<Size>().is_err());
    assert!("0x5".parse::<Size>().is_err());
}

#[test]
fn pq_frames_need_an_operator_with_display_levels() {
    let text = MINIMAL.replace("frames = 2", "frames = 2\nencoding = \"pq\"");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("encoding") && e.contains("line") && e.contains("bt2390"),
        "{e}"
    );
    let ok = format!("{text}\n[operator]\nkind = \"bt2390\"\ntarget_peak = 400.0\n");
    let s = parse(&ok).unwrap();
    assert_eq!((s.encoding, s.encoding.bits()), (Encoding::Pq, 16));
    assert_eq!(Encoding::Srgb.bits(), 8);
}

#[test]
fn a_key_of_a_table_is_found_in_its_own_table() {
    // The environment's `size` is on line 7 (the text starts with a newline);
    // the frame's `size` on line 3 is not it.
    let text = MINIMAL.replace("builtin = \"sky\"", "path = \"sky.hdr\"");
    let e = parse(&text).unwrap_err().to_string();
    assert!(e.contains("line 7, key `environment.size`"), "{e}");
    assert_eq!(line_of(MINIMAL, "size"), Some(3));
    assert_eq!(line_of(MINIMAL, "environment.size"), Some(7));
    assert_eq!(line_of(MINIMAL, "environment"), Some(5));
    assert_eq!(line_of(MINIMAL, "rotation.size"), None);
}

#[test]
fn bloom_and_grade_beyond_what_the_gpu_carries_are_refused_at_their_line() {
    let text = format!("{MINIMAL}[grade]\ncontrast = 1e39\n");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("line 11, key `grade.contrast`: must be at most 4, got 1e39"),
        "{e}"
    );
    let text = format!("{MINIMAL}[bloom]\nthreshold = 1.0\nsigma = 3.0\nstrength = 101.0\n");
    let e = parse(&text).unwrap_err().to_string();
    assert!(
        e.contains("key `bloom.strength`: must be at most 100"),
        "{e}"
    );
    let text = format!("{MINIMAL}[grade]\ncontrast = 4.0\n");
    assert!(parse(&text).is_ok());
    let text = format!("{MINIMAL}[bloom]\nthreshold = 1.0\nsigma = 3.0\nstrength = 100.0\n");
    assert!(parse(&text).is_ok());
}

#[test]
fn adaptation_light_steps_and_fps_parse_with_defaults_and_bad_ones_name_their_key() {
    let text = MINIMAL.replace("frames = 2", "frames = 3\nfps = 24.0")
        + "\n[adaptation]\nup = 0.3\n[[light]]\nfrom_frame = 1\nscale = 20.0\n";
    let s = parse(&text).unwrap();
    let a = s.adaptation.unwrap();
    assert_eq!(
        (a.up.get(), a.down.get(), a.key.get()),
        (0.3, DEFAULT_DOWN, 0.18)
    );
    assert_eq!((s.light(0), s.light(1), s.light(2)), (1.0, 20.0, 20.0));
    assert_eq!(s.brightest_light(), 20.0);
    assert!((s.frame_seconds() - 1.0 / 24.0).abs() < 1e-15);
    assert_eq!(parse(MINIMAL).unwrap().frame_seconds(), 1.0 / 60.0);
    let refused = [
        (text.replace("up = 0.3", "up = 0.0"), "up"),
        (text.replace("up = 0.3", "rate = 0.3"), "rate"),
        (
            text.replace("from_frame = 1", "from_frame = 3"),
            "past the sequence's last frame 2",
        ),
        (
            text.replace("scale = 20.0", "scale = 1e12"),
            "must be in [1e-10, 1e10]",
        ),
        (
            format!("{text}[[light]]\nfrom_frame = 1\nscale = 2.0\n"),
            "increasing frame order",
        ),
        (text.replace("fps = 24.0", "fps = -24.0"), "fps"),
    ];
    for (bad, says) in refused {
        let e = parse(&bad).unwrap_err().to_string();
        assert!(e.contains(says) && e.contains("line"), "{says}: {e}");
    }
    // A step out of order is named at its own line, not the first step's.
    let late = format!("{text}[[light]]\nfrom_frame = 1\nscale = 2.0\n");
    let second = late
        .lines()
        .enumerate()
        .filter(|(_, l)| l.starts_with("from_frame"))
        .last()
        .unwrap()
        .0
        + 1;
    let e = parse(&late).unwrap_err().to_string();
    assert!(
        e.contains(&format!("line {second}, key `from_frame`")),
        "{e}"
    );
    // The curve's check needs a curve.
    let e = parse(&format!(
        "{MINIMAL}\n[[checks]]\nmax_adaptation_error = 1e-4\n"
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("has no [adaptation]"), "{e}");
    let with = parse(&format!(
        "{text}\n[[checks]]\nmax_adaptation_error = 1e-4\n"
    ))
    .unwrap();
    assert!(matches!(with.checks[0].check, Check::MaxAdaptationError(v) if v == 1e-4));
}

#[test]
fn a_scene_without_adaptation_or_light_hashes_as_before_they_existed() {
    // The new keys are left out of the canonical form when absent, so no
    // existing scene's golden goes stale.
    let s = parse(MINIMAL).unwrap();
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("adaptation") && !json.contains("light") && !json.contains("fps"));
}

/// An unknown key inside `[operator]` is named at its own line, not at the
/// table's header; one of the scene's own keys put there by mistake is
/// told where it goes.
#[test]
fn an_unknown_operator_key_is_named_at_its_line() {
    let text = format!("{MINIMAL}\n[operator]\nkind = \"agx\"\nbogus = 3\n");
    let line = text.lines().position(|l| l.starts_with("bogus")).unwrap() + 1;
    let e = parse(&text).unwrap_err().to_string();
    assert!(e.contains(&format!("line {line}")), "{e}");
    assert!(e.contains("unknown field `bogus`"), "{e}");
    let misplaced = format!("{MINIMAL}\n[operator]\nkind = \"agx\"\nfps = 24.0\n");
    let e = parse(&misplaced).unwrap_err().to_string();
    assert!(e.contains("goes above its first [table]"), "{e}");
}
