use super::*;
use crate::gpu::{EnvFilter, HdrFormat, ReductionMethod};
use crate::scene::TaaVariant;

fn point(ms: f64, psnr: f64) -> Point {
    Point {
        scene: "s".into(),
        label: format!("{ms} {psnr}"),
        knobs: Knobs {
            hdr_format: HdrFormat::Rgba32Float,
            reduction: ReductionMethod::BlockPartials,
            env_filter: EnvFilter::Manual,
            bloom_downsample: None,
            spp: 1,
            taa: None,
            operator: None,
        },
        ms,
        psnr,
        ssim: 1.0,
        log_average_rel_error: 0.0,
        pareto: false,
    }
}

#[test]
fn the_front_keeps_exactly_the_undominated_points() {
    let mut p = vec![
        point(1.0, 30.0), // fastest
        point(2.0, 40.0), // front
        point(2.5, 35.0), // dominated by (2, 40)
        point(4.0, 50.0), // most accurate
        point(4.0, 45.0), // dominated by (4, 50)
        point(1.0, 30.0), // a tie with the first: both stay
    ];
    mark_pareto(&mut p);
    let front: Vec<bool> = p.iter().map(|p| p.pareto).collect();
    assert_eq!(front, [true, true, false, true, false, true]);
}

#[test]
fn the_sweep_covers_every_knob_and_bloom_only_where_there_is_bloom() {
    let text = std::fs::read_to_string("golden/scenes/night-auto-key-bloom.toml").unwrap();
    let bloom = Scene::parse(&text, std::path::Path::new("x.toml")).unwrap();
    let text = std::fs::read_to_string("golden/scenes/grid-static.toml").unwrap();
    let plain = Scene::parse(&text, std::path::Path::new("x.toml")).unwrap();
    let a = sweep(&bloom, &[1, 4, 16], &[2, 4, 8]);
    let b = sweep(&plain, &[1, 4, 16], &[2, 4, 8]);
    // Plus, at 1 spp, no AA, every history filter × feedback rule ×
    // clipping box, and the defaults with the tone-mapped blend and with
    // the sharpen.
    let taa = 1 + 2 * 2 * 3 + 2;
    assert_eq!(taa_knobs().len(), taa);
    // Formats × reductions (block, pingpong, tree, subgroup tree) ×
    // filters × ds × spp.
    assert_eq!(a.len(), 2 * 4 * 2 * 3 * 3 + taa);
    assert_eq!(b.len(), 2 * 4 * 2 * 3 + taa);
    assert_eq!(sweep(&plain, &[4, 16], &[2]).len(), 2 * 4 * 2 * 2);
    let edge = b
        .iter()
        .find(|k| k.taa.is_some_and(|t| t.variant == TaaVariant::EdgeAware))
        .unwrap();
    let scene = with_taa(&plain, edge.taa).unwrap();
    assert_eq!(
        crate::plan::StagePlan::for_scene(&scene, 1).names()[..3],
        ["sphere", "taa_sobel", "taa"]
    );
    let mut labels: Vec<String> = a.iter().map(Knobs::label).collect();
    labels.sort();
    labels.dedup();
    assert_eq!(labels.len(), a.len(), "labels name configurations uniquely");
}

/// An operator with a speed knob (aces2's gamut compression) adds it at
/// every spp; the configuration renders the scene with the knob's value
/// and says so in its label. Operators without one add nothing.
#[test]
fn the_sweep_offers_the_operators_speed_knobs() {
    let text = std::fs::read_to_string("golden/scenes/sky-aces2.toml").unwrap();
    let aces = Scene::parse(&text, std::path::Path::new("x.toml")).unwrap();
    let text = std::fs::read_to_string("golden/scenes/grid-static.toml").unwrap();
    let plain = Scene::parse(&text, std::path::Path::new("x.toml")).unwrap();
    let a = sweep(&aces, &[1, 4], &[2]);
    let b = sweep(&plain, &[1, 4], &[2]);
    assert_eq!(a.len(), b.len() + 2);
    assert!(b.iter().all(|k| k.operator.is_none()));
    let knobs: Vec<&Knobs> = a.iter().filter(|k| k.operator.is_some()).collect();
    assert_eq!(knobs.iter().map(|k| k.spp).collect::<Vec<_>>(), [1, 4]);
    assert!(
        knobs[0].label().ends_with("1spp gamut_compression=false"),
        "{}",
        knobs[0].label()
    );
    let variant = with_operator_knob(&aces, knobs[0].operator).unwrap();
    assert!(aces.operator.values().flag("gamut_compression"));
    assert!(!variant.operator.values().flag("gamut_compression"));
    assert_eq!(variant.operator.values().num("exposure"), 1.0);
    // A knob the operator does not take is refused, not ignored.
    let wrong = OperatorKnob {
        param: "gamut_compression",
        value: crate::operators::Value::Flag(false),
    };
    assert!(with_operator_knob(&plain, Some(wrong)).is_err());
}
