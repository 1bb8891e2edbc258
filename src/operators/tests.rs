use super::registry::admissible;
use super::*;

fn stats() -> LuminanceStats {
    LuminanceStats {
        log_average: Some(0.5),
        weighted_log_average: Some(0.8),
        min: Some(0.01),
        max: Some(100.0),
        weight_sum: Some(1.0),
    }
}

/// A scene's operator is written back as it was written before operators
/// were one type: `kind` first, then the parameters in the order the enum
/// had them, unset optional ones left out (the goldens' scene hashes are
/// of this JSON).
#[test]
fn operators_serialize_as_the_scene_schema_always_had_them() {
    let json = |op: &Operator| serde_json::to_string(op).unwrap();
    assert_eq!(
        json(&Operator::default()),
        r#"{"kind":"reinhard-global","key":0.18,"white_fraction":0.8,"colour":"ratio"}"#
    );
    let op = Operator::named(
        "reinhard-global",
        &[
            ("max_luminance", Value::Number(40.0)),
            ("log_average", Value::Number(0.2)),
        ],
    )
    .unwrap();
    assert_eq!(
        json(&op),
        r#"{"kind":"reinhard-global","key":0.18,"white_fraction":0.8,"log_average":0.2,"max_luminance":40.0,"colour":"ratio"}"#
    );
    assert_eq!(
        json(&Operator::named("seed001", &[]).unwrap()),
        r#"{"kind":"reinhard-auto-key","key":"auto","colour":"ratio"}"#
    );
    assert_eq!(
        json(&reinhard02_preset(0.18).unwrap()),
        r#"{"kind":"reinhard02","key":0.18,"colour":"ratio","pfs_compatible":true}"#
    );
    // And reads back to the same operator.
    for op in [Operator::default(), op, reinhard02_preset(0.3).unwrap()] {
        let back: Operator = serde_json::from_str(&json(&op)).unwrap();
        assert_eq!(back, op);
    }
}

#[test]
fn each_reinhard_variant_resolves_its_white_point() {
    let p = Operator::default().resolve(&stats()).unwrap();
    assert_eq!(p.params.get("scale"), Some(0.36));
    assert!((p.params.get("white").unwrap() - (0.64f64 * 100.0).sqrt()).abs() < 1e-12);
    let p = Operator::named("reinhard-auto-key", &[])
        .unwrap()
        .resolve(&stats())
        .unwrap();
    let a = reinhard::automatic_key(0.01, 0.8, 100.0);
    assert_eq!(p.params.get("key"), Some(a));
    assert!((p.params.get("white").unwrap() - a * 100.0 / 0.8).abs() < 1e-12);
    let p = Operator::named("reinhard02", &[("white", Value::Number(3.0))])
        .unwrap()
        .resolve(&stats())
        .unwrap();
    assert_eq!(p.params.get("white"), Some(3.0));
    // A black frame: no white point (nothing burns), and no NaN.
    let black = LuminanceStats {
        log_average: Some(1e-4),
        max: Some(0.0),
        ..Default::default()
    };
    let p = Operator::default().resolve(&black).unwrap();
    assert_eq!(p.params.get("white"), None);
    assert!(p.params.sane());
    assert_eq!(p.pixel([0.0; 3]), [0.0; 3]);
    // A statistic the operator needs and the plan did not measure.
    assert!(Operator::default()
        .resolve(&LuminanceStats::default())
        .is_err());
}

#[test]
fn values_are_held_to_their_ranges_and_their_operator() {
    use super::OperatorError as E;
    let e =
        Operator::named("reinhard-global", &[("white_fraction", Value::Number(1.5))]).unwrap_err();
    assert!(
        matches!(&e, E::BadValue { operator: "reinhard-global", parameter, .. } if parameter == "white_fraction"),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "white_fraction: must be in [1e-6, 1], got 1.5"
    );
    let e = Operator::named("reinhard02", &[("key", Value::Number(f64::NAN))]).unwrap_err();
    assert!(
        e.to_string().starts_with("key: must be in [1e-6, 100]"),
        "{e}"
    );
    let e = Operator::named("reinhard-global", &[("key", Value::Auto)]).unwrap_err();
    assert!(
        e.to_string()
            .contains("\"auto\" applies to operator reinhard-auto-key only"),
        "{e}"
    );
    let e = Operator::named("reinhard-auto-key", &[("white", Value::Number(2.0))]).unwrap_err();
    assert_eq!(
        e,
        E::NotTaken {
            operator: "reinhard-auto-key",
            parameter: "white".into(),
            takers: vec!["reinhard02"],
        }
    );
    assert_eq!(
        e.to_string(),
        "white: applies to operator reinhard02 only, not reinhard-auto-key"
    );
    let e = Operator::named("reinhard-auto-key", &[("gain", Value::Number(2.0))]).unwrap_err();
    assert!(
        matches!(&e, E::UnknownParameter { operator: "reinhard-auto-key", parameter, takes } if parameter == "gain" && takes.contains(&"key")),
        "{e:?}"
    );
    assert!(e.to_string().contains("unknown parameter \"gain\""), "{e}");
    let e = Operator::named("drago", &[]).unwrap_err();
    assert!(
        matches!(&e, E::UnknownOperator { name, known } if name == "drago" && known.contains(&"reinhard02")),
        "{e:?}"
    );
    assert!(e.to_string().contains("unknown operator \"drago\""), "{e}");
    let e = Operator::named("reinhard-global", &[("colour", Value::Word("lab"))]).unwrap_err();
    assert!(e.to_string().contains("one of ratio, xyy"), "{e}");
    // The operator's own check, by name.
    let e = Operator::named(
        "bt2390",
        &[
            ("source_black", Value::Number(10.0)),
            ("source_peak", Value::Number(5.0)),
        ],
    )
    .unwrap_err();
    assert!(
        matches!(&e, E::Refused { operator: "bt2390", reason } if reason.contains("source_black")),
        "{e:?}"
    );
}

#[test]
fn text_values_are_read_by_the_parameter_they_name() {
    let def = find("reinhard-auto-key").unwrap();
    let op = Operator::from_text(def.clone(), &[("key".into(), "auto".into())]).unwrap();
    assert!(op.values().is_auto("key"));
    let op = Operator::from_text(def.clone(), &[("colour".into(), "xyy".into())]).unwrap();
    assert_eq!(op.values().word("colour"), "xyy");
    let e = Operator::from_text(def.clone(), &[("key".into(), "bright".into())])
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("key: expected"), "{e}");
    // A bad value is named as bad even under an operator it does not apply to.
    let e = Operator::from_text(def, &[("white".into(), "-1".into())])
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("white: must be"), "{e}");
}

struct Clash(&'static str, &'static [Param]);

impl ToneOperator for Clash {
    fn name(&self) -> &'static str {
        self.0
    }
    fn summary(&self) -> &'static str {
        "a test operator"
    }
    fn params(&self) -> &'static [Param] {
        self.1
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        &[]
    }
    fn resolve(&self, _: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        Err(Unmeasured("nothing"))
    }
    fn wgsl(&self) -> &'static str {
        ""
    }
    fn gpu_config(&self, _: &Values) -> Vec<f32> {
        Vec::new()
    }
}

#[test]
fn registering_refuses_taken_names_and_clashing_parameters() {
    let known = builtin();
    let e = admissible(&known, &Clash("seed000", &[])).unwrap_err();
    assert_eq!(
        e,
        super::OperatorError::NameTaken {
            name: "seed000",
            by: "reinhard-global"
        }
    );
    let e = e.to_string();
    assert!(e.contains("taken (by reinhard-global)"), "{e}");
    let flag_key: &'static [Param] = &[Param {
        name: "key",
        doc: "",
        kind: Kind::Flag,
        default: Value::Flag(false),
    }];
    let e = admissible(&known, &Clash("mine", flag_key))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("parameter key is a number in operator reinhard-global"),
        "{e}"
    );
    let reserved: &'static [Param] = &[Param {
        name: "bloom",
        doc: "",
        kind: Kind::Number(Range::POSITIVE),
        default: Value::Unset,
    }];
    assert!(admissible(&known, &Clash("mine", reserved)).is_err());
    let bad_default: &'static [Param] = &[Param {
        name: "gain",
        doc: "",
        kind: Kind::Number(Range::POSITIVE),
        default: Value::Number(-1.0),
    }];
    assert!(admissible(&known, &Clash("mine", bad_default)).is_err());
    admissible(&known, &Clash("mine", &[])).unwrap();
}

#[test]
fn hable_refuses_constants_its_curve_cannot_use() {
    let hable = |given: &[(&str, Value)]| Operator::named("hable", given);
    // E/F ≠ DE/DF: 0 no longer maps to 0.
    let e = hable(&[("toe_numerator", Value::Number(0.05))]);
    assert!(hable(&[]).is_ok());
    // A constant f32 would carry as 0 is refused by name.
    let e2 = hable(&[
        ("toe_strength", Value::Number(1e-200)),
        ("toe_denominator", Value::Number(1e-200)),
    ])
    .unwrap_err()
    .to_string();
    assert!(e2.contains("toe_strength: must be in [1e-6, 1000]"), "{e2}");
    let e3 = hable(&[("shoulder_strength", Value::Number(1e6))])
        .unwrap_err()
        .to_string();
    assert!(
        e3.contains("shoulder_strength: must be in [1e-6, 1000]"),
        "{e3}"
    );
    // Any E with the other defaults still maps 0 to 0 (DE/DF = E/F).
    assert!(e.is_ok());
}

/// Every operator with an `exposure` parameter says where its uniform holds
/// it, and that word, written for a new exposure, is what `gpu_config`
/// writes for it, with every other word unchanged; an operator without one
/// says nothing.
#[test]
fn the_exposure_word_is_where_gpu_config_puts_the_exposure() {
    for name in names() {
        let op = Operator::named(name, &[]).unwrap();
        let d = op.definition();
        let has = d.params().iter().any(|p| p.name == "exposure");
        let Some(word) = d.gpu_exposure_word() else {
            assert!(!has, "{} has an exposure and no exposure word", op.name());
            continue;
        };
        assert!(has, "{} has an exposure word and no exposure", op.name());
        let base = d.gpu_config(op.values());
        for e in [1e-6, 0.25, 1.0, 3.7, 1e6] {
            let with = op.with_value("exposure", Value::Number(e)).unwrap();
            let mut expected = base.clone();
            expected[word.index] = word.word(e);
            assert_eq!(
                d.gpu_config(with.values()),
                expected,
                "{} at exposure {e}",
                op.name()
            );
        }
    }
}
