//! `aces2` locked to OpenColorIO 2.6's ACES 2.0 SDR output transform
//! (tests/aces2/vectors.json, regenerated in CI by tests/aces2/make_vectors.sh
//! from the pinned PyPI opencolorio when the lock's inputs change,
//! ci/locks.sh, and required to be the committed file).

use serde_json::Value as Json;
use tonegate::operators::{Operator, Value};
use tonegate::reference::luminance_stats::LuminanceStats;

fn vectors() -> Json {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/aces2/vectors.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("tests/aces2/vectors.json")).unwrap()
}

fn rows(v: &Json) -> Vec<[f64; 3]> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|t| [0, 1, 2].map(|k| t[k].as_f64().unwrap()))
        .collect()
}

/// OpenColorIO evaluates the transform in f32: about a hundred roundings of
/// 2⁻²⁴ per pixel, several of them amplified on the way out by the
/// powers 1/0.42 (the cone response's inverse) and 1/(c·z) = 1.26 (J to
/// A), and by the gamut compression's slopes near the hull. 4e-5 is about
/// 670 f32 ulps; the final matrix mixes the three channels, so a channel's
/// error scales with the pixel's largest value, not its own. Measured
/// worst (2026-11-26): 0.42 of this bound. An exposure 0.1 % off fails by
/// far (`a_changed_transform_fails_its_lock`).
const F32_REFERENCE: f64 = 4e-5;

/// The worst |ours − OCIO| / (F32_REFERENCE · max|OCIO| + 1e-12) over the
/// vectors, display-linear; asserts it is at most 1.
fn lock(op: &Operator) -> f64 {
    let v = vectors();
    let inputs = rows(&v["inputs"]);
    let want = rows(&v["linear"]);
    let labels = v["labels"].as_array().unwrap();
    assert_eq!(inputs.len(), 155);
    let tone = op.resolve(&LuminanceStats::default()).unwrap();
    let mut worst = 0.0f64;
    for (i, (c, w)) in inputs.iter().zip(&want).enumerate() {
        let got = tone.pixel(*c);
        let scale = w.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for k in 0..3 {
            let e = (got[k] - w[k]).abs() / (F32_REFERENCE * scale + 1e-12);
            assert!(
                e <= 1.0,
                "{} {c:?}: {got:?} against OCIO's {w:?}",
                labels[i]
            );
            worst = worst.max(e);
        }
    }
    worst
}

#[test]
fn aces2_matches_opencolorio() {
    let v = vectors();
    assert_eq!(v["opencolorio"], "2.6.0");
    assert_eq!(v["view"], "ACES 2.0 - SDR 100 nits (Rec.709)");
    let worst = lock(&Operator::named("aces2", &[]).unwrap());
    eprintln!("aces2 against OpenColorIO 2.6.0: worst {worst:.3} of the bound");
}

#[test]
fn a_changed_transform_fails_its_lock() {
    let op = Operator::named("aces2", &[("exposure", Value::Number(1.001))]).unwrap();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| lock(&op)));
    assert!(r.is_err(), "a 0.1 % exposure change passed the lock");
}

/// The two matrices tonegate writes as constants are the ones in
/// OpenColorIO's optimised chain (which composes Rec.709 → AP0 → AP1).
#[test]
fn aces2s_matrices_are_opencolorios() {
    use tonegate::operators::aces2::{AP1_TO_AP0, REC709_TO_AP1};
    let v = vectors();
    let chain = v["op_chain_reference"].as_array().unwrap();
    let matrix = |text: &str| -> Vec<f64> {
        let m = text
            .split("matrix=[")
            .nth(1)
            .unwrap()
            .split(']')
            .next()
            .unwrap();
        m.split(", ").map(|x| x.parse().unwrap()).collect()
    };
    for (i, ours) in [(0, REC709_TO_AP1), (2, AP1_TO_AP0)] {
        let theirs = matrix(chain[i].as_str().unwrap());
        for r in 0..3 {
            for c in 0..3 {
                assert_eq!(ours[r][c], theirs[4 * r + c], "op {i} [{r}][{c}]");
            }
        }
    }
    assert!(chain[3].as_str().unwrap().contains(
        "style=ACES2_OutputTransform, params=[100, 0.64, 0.33, 0.3, 0.6, 0.15, 0.06, 0.3127, 0.329]"
    ));
}

/// Gamut compression off changes only colours the compression moves: a
/// grey is the same either way, a saturated HDR red is not, and neither
/// leaves [0, 1].
#[test]
fn aces2_without_gamut_compression_keeps_greys() {
    let stats = LuminanceStats::default();
    let on = Operator::named("aces2", &[])
        .unwrap()
        .resolve(&stats)
        .unwrap();
    let off = Operator::named("aces2", &[("gamut_compression", Value::Flag(false))])
        .unwrap()
        .resolve(&stats)
        .unwrap();
    for g in [0.01, 0.18, 1.0, 10.0] {
        let (a, b) = (on.pixel([g; 3]), off.pixel([g; 3]));
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-12, "grey {g}: {a:?} {b:?}");
        }
    }
    let (a, b) = (on.pixel([50.0, 0.0, 0.0]), off.pixel([50.0, 0.0, 0.0]));
    assert!((0..3).any(|k| (a[k] - b[k]).abs() > 1e-3), "{a:?} {b:?}");
    assert!(a.iter().chain(&b).all(|x| (0.0..=1.0).contains(x)));
}
