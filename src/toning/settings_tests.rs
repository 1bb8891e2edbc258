//! The settings' checks: what flags and API parameters are refused, and
//! what they resolve to.

use super::*;

#[cfg(feature = "cli")]
#[test]
fn defaults_of_flags_and_api_are_the_same() {
    use clap::Parser;
    #[derive(Parser)]
    struct Flags {
        #[command(flatten)]
        settings: ToneSettings,
    }
    let flags = Flags::try_parse_from(["x"]).unwrap();
    assert_eq!(flags.settings, ToneSettings::default());
    let api: ToneSettings = serde_json::from_str("{}").unwrap();
    assert_eq!(api, ToneSettings::default());
}

#[test]
fn unknown_and_bad_parameters_are_refused_by_name() {
    let e = serde_json::from_str::<ToneSettings>(r#"{"kee": 0.2}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field `kee`"), "{e}");
    let mut s = ToneSettings::default();
    s.params.set("white_fraction", 1.5);
    let e = s.resolve().unwrap_err().to_string();
    assert!(e.contains("white_fraction") && e.contains("1.5"), "{e}");
    let mut s = ToneSettings::default();
    s.params.set("key", "bright");
    assert!(s.resolve().unwrap_err().to_string().contains("key"));
    let s = ToneSettings {
        operator: "reinhard-glob".into(),
        ..Default::default()
    };
    let e = s.resolve().unwrap_err().to_string();
    assert!(
        e.contains("unknown operator") && e.contains("reinhard02"),
        "{e}"
    );
    let mut s = ToneSettings::default();
    s.params.set("kee", 0.2);
    let e = s.resolve().unwrap_err().to_string();
    assert!(e.contains("unknown parameter \"kee\""), "{e}");
    let s = ToneSettings {
        gamma: Some(f64::NAN),
        ..Default::default()
    };
    assert!(s.resolve().unwrap_err().to_string().contains("gamma"));
}

/// Found by a hostile client: `bloom_radius=9` without `bloom` was
/// accepted and did nothing.
#[test]
fn a_bloom_refinement_without_a_bloom_is_refused() {
    let s = ToneSettings {
        bloom_radius: Some(9),
        ..Default::default()
    };
    let e = s.resolve().unwrap_err().to_string();
    assert!(e.contains("bloom_radius: refines a bloom"), "{e}");
    let s = ToneSettings {
        bloom: 0.5,
        bloom_radius: Some(9),
        ..Default::default()
    };
    s.resolve().unwrap();
    // Out of range is refused either way.
    let s = ToneSettings {
        bloom_radius: Some(0),
        ..Default::default()
    };
    assert!(s
        .resolve()
        .unwrap_err()
        .to_string()
        .contains("bloom_radius"));
}

/// Found by a hostile client: `white=-1` was ignored under the default
/// operator but refused under reinhard02.
#[test]
fn a_value_is_checked_and_applies_to_its_operator_whatever_the_operator() {
    fn with(
        op: &str,
        given: &[(&str, &str)],
        preset: Option<Preset>,
    ) -> std::result::Result<(), String> {
        let mut s = ToneSettings {
            operator: op.to_owned(),
            preset,
            ..Default::default()
        };
        for (n, v) in given {
            s.params.set(n, v);
        }
        s.resolve().map(|_| ()).map_err(|e| e.to_string())
    }
    for op in ["reinhard-global", "reinhard-auto-key", "reinhard02"] {
        for bad in ["-1", "0", "inf", "NaN"] {
            for name in ["white", "log_average", "white_fraction"] {
                let e = with(op, &[(name, bad)], None).unwrap_err();
                assert!(e.starts_with(&format!("{name}:")), "{op} {bad}: {e}");
            }
        }
    }
    let e = with("reinhard-global", &[("white", "4")], None).unwrap_err();
    assert!(
        e.contains("white: applies to operator reinhard02 only, not reinhard-global"),
        "{e}"
    );
    let e = with("reinhard02", &[("white_fraction", "0.5")], None).unwrap_err();
    assert!(
        e.contains("applies to operator reinhard-global only"),
        "{e}"
    );
    let e = with("reinhard-auto-key", &[("log_average", "0.2")], None).unwrap_err();
    assert!(e.contains("reinhard-global and reinhard02"), "{e}");
    let e = with("reinhard-global", &[("key", "auto")], None).unwrap_err();
    assert!(e.contains("reinhard-auto-key only"), "{e}");
    let e = with(
        "reinhard-global",
        &[("white", "4")],
        Some(Preset::Reinhard02),
    )
    .unwrap_err();
    assert!(e.contains("preset reinhard02"), "{e}");
    with("reinhard02", &[("white", "4")], None).unwrap();
    with("reinhard-global", &[("white_fraction", "0.5")], None).unwrap();
    with("reinhard-global", &[("log_average", "0.2")], None).unwrap();
}

#[test]
fn values_the_gpu_cannot_carry_are_refused_by_name() {
    type Set = fn(&mut ToneSettings);
    let cases: [(&str, Set); 7] = [
        ("bloom", |s| s.bloom = 1e39),
        ("brightness", |s| s.brightness = 3.5e38),
        ("contrast", |s| s.contrast = 4.5),
        ("saturation", |s| s.saturation = 1e6),
        ("gamma", |s| s.gamma = Some(1e-40)),
        ("gamma", |s| s.gamma = Some(3.5)),
        ("bloom_sigma", |s| {
            s.bloom = 0.5;
            s.bloom_sigma = Some(1e7)
        }),
    ];
    for (name, set) in cases {
        let mut s = ToneSettings::default();
        set(&mut s);
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains(&format!("{name}: must be")), "{name}: {e}");
    }
    // The ends of the ranges are taken.
    let s = ToneSettings {
        bloom: 100.0,
        contrast: 4.0,
        gamma: Some(3.0),
        ..ToneSettings::default()
    };
    assert!(s.resolve().is_ok());
}

#[test]
fn a_preset_beside_another_operator_is_refused() {
    let with = |operator: &str| ToneSettings {
        preset: Some(Preset::Reinhard02),
        operator: operator.to_owned(),
        ..ToneSettings::default()
    };
    let e = with("agx").operator().unwrap_err().to_string();
    assert!(
        e.contains("operator") && e.contains("preset reinhard02") && e.contains("agx"),
        "{e}"
    );
    // Naming the preset's own operator, or none, is no conflict.
    assert!(with("reinhard02").operator().is_ok());
    assert!(with("reinhard-global").operator().is_ok());
}

/// The preset is pfstmo_reinhard02's operator with the key given, and
/// the key alone.
#[test]
fn the_preset_takes_a_key_and_nothing_else() {
    let mut s = ToneSettings {
        preset: Some(Preset::Reinhard02),
        ..Default::default()
    };
    s.params.set("key", 0.3);
    let op = s.resolve().unwrap().operator;
    assert_eq!(op, crate::operators::reinhard02_preset(0.3).unwrap());
    assert!(op.values().flag("pfs_compatible"));
    s.params.set("key", "auto");
    let e = s.resolve().unwrap_err().to_string();
    assert!(e.contains("preset reinhard02 needs a number"), "{e}");
}
