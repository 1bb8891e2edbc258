use super::*;

/// A check with no spp or provenance, on `adapter` or every adapter.
pub fn spec(check: Check, adapter: Option<&str>) -> CheckSpec {
    CheckSpec {
        check,
        adapter: adapter.map(str::to_owned),
        options: Vec::new(),
        spp: None,
        set_by: None,
    }
}

/// Judged on `adapter` at the goldens' 16 spp.
pub fn on(adapter: &str) -> Judged<'_> {
    Judged {
        adapter,
        spp: 16,
        reference_spp: 16,
        options: &[],
    }
}

#[test]
fn labels_and_kinds_name_the_figure_the_side_and_the_bound() {
    let cases = [
        (Check::MinPsnr(50.0), "PSNR >= 50 dB", "min_psnr"),
        (Check::MinSsim(0.99), "SSIM >= 0.99", "min_ssim"),
        (Check::MaxMse(0.5), "MSE <= 0.5", "max_mse"),
        (Check::MaxAbsDiff(3), "max abs diff <= 3", "max_abs_diff"),
        (
            Check::MaxMeanAbsDiff(0.25),
            "mean abs diff <= 0.25 LSB",
            "max_mean_abs_diff",
        ),
        (
            Check::MaxFractionOver {
                lsb: 2,
                fraction: 0.001,
            },
            "fraction over 2 LSB <= 0.001",
            "max_fraction_over:2",
        ),
        (
            Check::MaxStageMs {
                stage: "sphere".into(),
                ms: 4.5,
            },
            "sphere <= 4.5 ms",
            "max_stage_ms:sphere",
        ),
        (Check::MinFps(24.0), "FPS >= 24", "min_fps"),
        (
            Check::MaxFlipMean(0.01),
            "FLIP mean <= 0.01",
            "max_flip_mean",
        ),
        (
            Check::MaxFlipPercentile {
                p: 0.99,
                value: 0.2,
            },
            "FLIP weighted percentile 0.99 <= 0.2",
            "max_flip_percentile:0.99",
        ),
    ];
    for (check, label, kind) in cases {
        assert_eq!(check.rule().label(), label);
        assert_eq!(check.kind(), kind);
    }
    let mut s = spec(Check::MinPsnr(40.0), Some("llvmpipe"));
    assert_eq!(s.label(), "PSNR >= 40 dB [llvmpipe]");
    s.adapter = None;
    assert_eq!(s.label(), "PSNR >= 40 dB");
}

#[test]
fn bounds_that_make_no_sense_are_refused() {
    for bad in [
        Check::MinSsim(1.5),
        Check::MinPsnr(f64::NAN),
        Check::MaxMeanAbsDiff(-0.5),
        Check::MaxFlipMean(1.5),
        Check::MaxFlipPercentile { p: 1.5, value: 0.1 },
        Check::MaxFractionOver {
            lsb: 1,
            fraction: 2.0,
        },
        Check::MaxStageMs {
            stage: "sphere".into(),
            ms: 0.0,
        },
    ] {
        let e = spec(bad.clone(), None).validate().unwrap_err();
        assert!(e.contains("bound out of range"), "{bad:?}: {e}");
    }
    let mut s = spec(Check::MinPsnr(f64::INFINITY), None);
    assert_eq!(s.validate(), Ok(()));
    s.spp = Some(0);
    assert!(s.validate().unwrap_err().contains("spp must be between 1"));
}

#[test]
fn nan_fails_either_side_and_the_bound_itself_passes() {
    let min = Check::MinPsnr(40.0);
    let max = Check::MaxMse(1.0);
    assert!(min.rule().fails(f64::NAN) && max.rule().fails(f64::NAN));
    assert!(!min.rule().fails(40.0) && !max.rule().fails(1.0));
    assert!(min.rule().fails(39.9) && max.rule().fails(1.1));
}

#[test]
fn an_adapter_bound_overrides_the_generic_one_of_its_kind_only() {
    let specs = vec![
        spec(Check::MinPsnr(40.0), None),
        spec(Check::MinPsnr(30.0), Some("llvmpipe")),
        spec(Check::MinSsim(0.9), None),
    ];
    assert!(not_applied(&specs, 0, on("llvmpipe (LLVM 15)"))
        .unwrap()
        .contains("overridden"));
    assert_eq!(not_applied(&specs, 1, on("llvmpipe (LLVM 15)")), None);
    assert_eq!(not_applied(&specs, 2, on("llvmpipe (LLVM 15)")), None);
    // On another adapter the generic bound holds and the override does not apply.
    assert_eq!(not_applied(&specs, 0, on("NVIDIA H100")), None);
    assert!(not_applied(&specs, 1, on("NVIDIA H100")).is_some());
}

#[test]
fn a_bound_applies_at_its_own_spp_only() {
    let mut plain = spec(Check::MinPsnr(20.0), None);
    plain.spp = Some(1);
    let specs = vec![plain, spec(Check::MinPsnr(50.0), None)];
    let at = |spp| Judged {
        adapter: "llvmpipe",
        spp,
        reference_spp: 16,
        options: &[],
    };
    assert_eq!(not_applied(&specs, 0, at(1)), None);
    assert!(not_applied(&specs, 1, at(1)).is_some());
    assert!(not_applied(&specs, 0, at(16)).is_some());
    assert_eq!(not_applied(&specs, 1, at(16)), None);
}

#[test]
fn an_options_bound_applies_with_its_options_only_and_overrides_the_generic_one() {
    use AccuracyOption::{HardwareFilter, Rgba16float};
    let mut f16 = spec(Check::MaxFlipMean(0.003), None);
    f16.options = vec![Rgba16float];
    let mut hw_nvidia = spec(Check::MaxFlipMean(0.002), Some("NVIDIA"));
    hw_nvidia.options = vec![HardwareFilter];
    let specs = vec![
        spec(Check::MaxFlipMean(0.001), None),
        f16,
        hw_nvidia,
        spec(Check::MaxFlipMean(0.0005), Some("NVIDIA")),
    ];
    let at = |adapter, options| Judged {
        adapter,
        spp: 16,
        reference_spp: 16,
        options,
    };
    let applied = |on: Judged| -> Vec<usize> {
        (0..specs.len())
            .filter(|&i| not_applied(&specs, i, on).is_none())
            .collect()
    };
    assert_eq!(applied(at("llvmpipe", &[])), vec![0]);
    assert_eq!(applied(at("llvmpipe", &[Rgba16float])), vec![1]);
    assert_eq!(applied(at("llvmpipe", &[HardwareFilter])), vec![0]);
    assert_eq!(applied(at("NVIDIA H100", &[])), vec![3]);
    assert_eq!(applied(at("NVIDIA H100", &[HardwareFilter])), vec![2]);
    // The generic f16 bound, not NVIDIA's f32 one: the option decides
    // what is rendered before the adapter does.
    assert_eq!(applied(at("NVIDIA H100", &[Rgba16float])), vec![1]);
    // Both options: the two one-option bounds are equally narrow; both hold.
    assert_eq!(
        applied(at("NVIDIA H100", &[Rgba16float, HardwareFilter])),
        vec![1, 2]
    );
    let why = not_applied(&specs, 1, at("llvmpipe", &[])).unwrap();
    assert!(why.contains("rgba16float") && why.contains("none"), "{why}");
    let why = not_applied(&specs, 0, at("llvmpipe", &[Rgba16float])).unwrap();
    assert!(why.contains("overridden"), "{why}");
    assert_eq!(
        specs[2].label(),
        "FLIP mean <= 0.002 [NVIDIA, hardware_filter]"
    );
    let parsed: CheckSpec =
        toml::from_str("max_flip_mean = 0.003\noptions = [\"rgba16float\"]").unwrap();
    assert_eq!(parsed.options, vec![Rgba16float]);
    assert!(toml::from_str::<CheckSpec>("max_flip_mean = 0.003\noptions = [\"f64\"]").is_err());
    // A repeated option would make the bound outrank itself without it.
    let twice: CheckSpec =
        toml::from_str("max_flip_mean = 0.003\noptions = [\"rgba16float\", \"rgba16float\"]")
            .unwrap();
    let why = twice.validate().unwrap_err();
    assert!(why.contains("rgba16float listed twice"), "{why}");
    assert!(parsed.validate().is_ok());
}
