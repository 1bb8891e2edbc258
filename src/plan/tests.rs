use super::*;
use crate::operators::Value;
use crate::scene::{Bloom, Factor, NonNegative, Positive, Radius};

fn bloom(bright_pass: BrightPass, strength: f64) -> Bloom {
    Bloom {
        bright_pass,
        threshold: NonNegative::try_from(1.0).unwrap(),
        downsample: Factor::try_from(2).unwrap(),
        radius: Radius::try_from(4).unwrap(),
        sigma: Positive::try_from(2.0).unwrap(),
        strength: NonNegative::try_from(strength).unwrap(),
    }
}

fn reinhard02(white: Option<f64>, log_average: Option<f64>) -> Operator {
    let mut given = Vec::new();
    if let Some(w) = white {
        given.push(("white", Value::Number(w)));
    }
    if let Some(l) = log_average {
        given.push(("log_average", Value::Number(l)));
    }
    Operator::named("reinhard02", &given).unwrap()
}

#[test]
fn taa_stages_come_first_and_only_when_asked() {
    let params = |variant| TaaParams {
        variant,
        ..TaaParams::default()
    };
    let op = Operator::default();
    let sphere = StagePlan::build(Input::Sphere { spp: 1 }, &op, None, None);
    let clip = sphere.clone().with_taa(params(TaaVariant::Clip));
    assert_eq!(
        clip.names(),
        ["sphere", "taa", "luminance_stats", "tonemap", "encode"]
    );
    let edge = sphere.clone().with_taa(params(TaaVariant::EdgeAware));
    assert_eq!(&edge.names()[..3], ["sphere", "taa_sobel", "taa"]);
    assert_eq!(edge.clone().with_taa(params(TaaVariant::Clip)), edge);
    assert_eq!(sphere.clone().with_taa(params(TaaVariant::Off)), sphere);
    // A flat plan (an application's jittered frames, with motion vectors)
    // starts with them.
    let flat = StagePlan::build(Input::Flat, &op, None, None);
    assert_eq!(
        flat.clone().with_taa(params(TaaVariant::EdgeAware)).names(),
        ["taa_sobel", "taa", "luminance_stats", "tonemap", "encode"]
    );
    assert_eq!(flat.clone().with_taa(params(TaaVariant::Off)), flat);
}

#[test]
fn fixed_parameters_need_no_statistics() {
    let plan = StagePlan::build(Input::Flat, &reinhard02(Some(4.0), Some(0.5)), None, None);
    assert_eq!(plan.names(), ["tonemap", "encode"]);
}

#[test]
fn flat_images_have_no_sphere_stage() {
    let plan = StagePlan::build(Input::Flat, &Operator::default(), None, None);
    assert!(!plan.contains("sphere"));
    let plan = StagePlan::build(Input::Sphere { spp: 1 }, &Operator::default(), None, None);
    assert_eq!(plan.stages[0], Stage::Sphere { spp: 1 });
}

#[test]
fn weighted_sums_and_min_only_when_the_auto_key_needs_them() {
    let needs = stats_needs(&Operator::default(), None);
    assert!(needs.log_average && needs.max && !needs.weighted_log_average && !needs.min);
    let auto = Operator::named("reinhard-auto-key", &[]).unwrap();
    let needs = stats_needs(&auto, None);
    assert!(needs.weighted_log_average && needs.min && needs.max && !needs.log_average);
    let fixed = Operator::named("reinhard-auto-key", &[("key", Value::Number(0.2))]).unwrap();
    assert!(!stats_needs(&fixed, None).min);
    // Lwhite unset needs the max; an absolute one does not.
    assert!(stats_needs(&reinhard02(None, None), None).max);
    assert!(!stats_needs(&reinhard02(Some(3.0), None), None).max);
    // The `scaled` bright pass normalises by Lmax.
    assert!(
        stats_needs(
            &reinhard02(Some(3.0), None),
            Some(&bloom(BrightPass::Scaled, 0.2))
        )
        .max
    );
}

#[test]
fn bloom_and_grade_appear_only_when_active() {
    let op = Operator::default();
    let off = StagePlan::build(
        Input::Flat,
        &op,
        Some(&bloom(BrightPass::Scaled, 0.0)),
        None,
    );
    assert!(!off.names().iter().any(|n| n.starts_with("bloom")));
    let on = StagePlan::build(
        Input::Flat,
        &op,
        Some(&bloom(BrightPass::Threshold, 0.3)),
        None,
    );
    assert_eq!(
        on.names(),
        [
            "luminance_stats",
            "tonemap",
            "bloom_bright",
            "bloom_downsample",
            "bloom_blur",
            "bloom_composite",
            "encode"
        ]
    );
    let neutral = Grade {
        brightness: NonNegative::try_from(1.0).unwrap(),
        contrast: NonNegative::try_from(1.0).unwrap(),
        saturation: NonNegative::try_from(1.0).unwrap(),
    };
    assert!(!StagePlan::build(Input::Flat, &op, None, Some(&neutral)).contains("grade"));
    let saturate = Grade {
        saturation: NonNegative::try_from(1.2).unwrap(),
        ..neutral.clone()
    };
    let plan = StagePlan::build(Input::Flat, &op, None, Some(&saturate));
    assert!(plan.contains("grade") && !plan.contains("grade_stats"));
    let contrast = Grade {
        contrast: NonNegative::try_from(1.2).unwrap(),
        ..neutral
    };
    assert!(StagePlan::build(Input::Flat, &op, None, Some(&contrast)).contains("grade_stats"));
}

/// The adaptation stage of `op` with `adaptation` at 60 frames a second.
fn adaptation_stage(op: &Operator, adaptation: crate::scene::Adaptation) -> AdaptationStage {
    AdaptationStage {
        adaptation,
        frame_seconds: 1.0 / 60.0,
        operator_needs: op.needs(),
    }
}

#[test]
fn adaptation_goes_after_the_statistics_which_then_measure_the_log_average() {
    let stage = |op: &Operator| {
        adaptation_stage(op, crate::scene::Adaptation::new(0.4, 1.6, 0.18).unwrap())
    };
    // An operator that measures nothing gets the statistics it then needs.
    let agx = Operator::named("agx", &[]).unwrap();
    let plan =
        StagePlan::build(Input::Sphere { spp: 4 }, &agx, None, None).with_adaptation(stage(&agx));
    assert_eq!(
        plan.names(),
        [
            "sphere",
            "luminance_stats",
            "adaptation",
            "tonemap",
            "encode"
        ]
    );
    assert!(matches!(
        plan.stages()[1],
        Stage::LuminanceStats(StatsNeeds {
            log_average: true,
            weighted_log_average: false,
            min: false,
            max: false
        })
    ));
    assert!(!plan.adaptation().unwrap().operator_needs.any());
    // One that measures already keeps its needs, the log average added.
    let auto = Operator::named("reinhard-auto-key", &[]).unwrap();
    let plain = StagePlan::build(Input::Flat, &auto, None, None);
    let adapted = plain.clone().with_adaptation(stage(&auto));
    assert_eq!(
        adapted.names(),
        ["luminance_stats", "adaptation", "tonemap", "encode"]
    );
    let needs = |p: &StagePlan| match p.stages()[0] {
        Stage::LuminanceStats(n) => n,
        _ => unreachable!(),
    };
    assert_eq!(
        needs(&adapted),
        StatsNeeds {
            log_average: true,
            ..needs(&plain)
        }
    );
    // Once only.
    assert_eq!(adapted.clone().with_adaptation(stage(&auto)), adapted);
}

#[test]
fn histogram_metering_adds_its_stage_and_leaves_the_statistics_to_the_operator() {
    let stage = |op: &Operator| adaptation_stage(op, crate::scene::Adaptation::default());
    let agx = Operator::named("agx", &[]).unwrap();
    let plan =
        StagePlan::build(Input::Sphere { spp: 4 }, &agx, None, None).with_adaptation(stage(&agx));
    assert_eq!(
        plan.names(),
        ["sphere", "histogram", "adaptation", "tonemap", "encode"]
    );
    let auto = Operator::named("reinhard-auto-key", &[]).unwrap();
    let plain = StagePlan::build(Input::Flat, &auto, None, None);
    let adapted = plain.clone().with_adaptation(stage(&auto));
    assert_eq!(
        adapted.names(),
        [
            "luminance_stats",
            "histogram",
            "adaptation",
            "tonemap",
            "encode"
        ]
    );
    assert_eq!(adapted.stages()[0], plain.stages()[0]);
    assert_eq!(adapted.clone().with_adaptation(stage(&auto)), adapted);
}
