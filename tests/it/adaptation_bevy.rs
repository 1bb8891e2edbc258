//! An independent check of histogram metering: bevy's `AutoExposure` as
//! its documentation describes it (a 64-bin log2 luminance histogram over
//! an EV range, the darkest and brightest fractions of the pixels ignored,
//! the exposure moving in stops per second, linearly until it is within
//! the transition distance of its target and exponentially after),
//! written here in f64 from that description alone, run on the tunnel
//! exit's frames beside tonegate's histogram mode with the same
//! parameters (`Adaptation::bevy()`).

use crate::adaptation_scenes::{run, tunnel};
use tonegate::image::HdrImage;
use tonegate::operators::Operator;
use tonegate::scene::Adaptation;

/// bevy's defaults, restated from its documentation.
const RANGE: (f64, f64) = (-8.0, 8.0);
const FILTER: (f64, f64) = (0.10, 0.90);
const SPEED_BRIGHTEN: f64 = 3.0;
const SPEED_DARKEN: f64 = 1.0;
const TRANSITION: f64 = 1.5;

/// The metered EV of one frame: every pixel's log2 luminance placed in one
/// of 64 equal bins over the range (the ends take what lies beyond), each
/// pixel then stands at its bin's centre; sorted, the darkest and
/// brightest fractions of the pixel count are ignored (a pixel straddling
/// a cut counts in part) and the rest averaged.
fn metered(img: &HdrImage, weights: [f64; 3]) -> f64 {
    let width = (RANGE.1 - RANGE.0) / 64.0;
    let mut evs: Vec<f64> = img
        .pixels
        .iter()
        .map(|p| {
            let y = tonegate::color::luminance_with(p.map(f64::from), weights);
            let bin = ((y.log2() - RANGE.0) / width).floor().clamp(0.0, 63.0);
            RANGE.0 + (bin + 0.5) * width
        })
        .collect();
    evs.sort_by(f64::total_cmp);
    let n = evs.len() as f64;
    let (from, to) = (FILTER.0 * n, FILTER.1 * n);
    let (mut sum, mut count) = (0.0, 0.0);
    for (i, ev) in evs.iter().enumerate() {
        let share = (i as f64 + 1.0).min(to) - (i as f64).max(from);
        if share > 0.0 {
            sum += share * ev;
            count += share;
        }
    }
    sum / count
}

/// The exposure's EV after each frame, the first at its target.
fn bevy_curve(frames: &[&HdrImage], weights: [f64; 3], dt: f64) -> Vec<f64> {
    let mut ev: Option<f64> = None;
    let mut out = Vec::new();
    for img in frames {
        let target = metered(img, weights).clamp(RANGE.0, RANGE.1);
        let next = match ev {
            None => target,
            Some(ev) => {
                let delta = target - ev;
                let speed = if delta > 0.0 {
                    SPEED_BRIGHTEN
                } else {
                    SPEED_DARKEN
                } * dt;
                if delta.abs() > TRANSITION {
                    ev + speed * delta.signum()
                } else {
                    ev + delta * speed / TRANSITION
                }
            }
        };
        ev = Some(next);
        out.push(next);
    }
    out
}

#[test]
fn tonegate_histogram_mode_follows_bevys_rule_written_from_its_description() {
    let (inputs, frames) = tunnel();
    let a = Adaptation::bevy();
    let run = run(&inputs, &frames, a, "agx", |_| false);
    let weights = Operator::named("agx", &[]).unwrap().luminance().weights;
    let images: Vec<&HdrImage> = frames.iter().map(|&k| &inputs[k].image).collect();
    let bevy = bevy_curve(&images, weights, 1.0 / 60.0);
    // Two f64 computations of the same sums in other orders: 1e-9 EV
    // covers their rounding (9,216 terms, 2⁻⁵² each, of at most 8 EV).
    // The GPU against it: its derived bound against tonegate's f64 curve
    // (tests/it/adaptation_scenes.rs) plus that.
    let mut worst = (0f64, 0f64);
    for (n, want) in bevy.iter().enumerate() {
        let want = *want;
        let (f64_err, gpu_err) = ((run.cpu[n] - want).abs(), (run.gpu[n] - want).abs());
        assert!(
            f64_err <= 1e-9,
            "frame {n}: tonegate f64 {} bevy's rule {want}",
            run.cpu[n]
        );
        assert!(
            gpu_err <= run.bound[n] + 1e-9,
            "frame {n}: GPU {} bevy's rule {want}",
            run.gpu[n]
        );
        worst = (worst.0.max(f64_err), worst.1.max(gpu_err));
    }
    for n in (110..300).step_by(10) {
        println!(
            "bevy frame {n:3}: bevy's rule {:+.4} EV, tonegate f64 {:+.4}, GPU {:+.4}",
            bevy[n], run.cpu[n], run.gpu[n]
        );
    }
    println!(
        "bevy: worst |tonegate f64 - bevy| {:.2e} EV, |GPU - bevy| {:.2e} EV",
        worst.0, worst.1
    );
    // It can tell: bevy's rule at 1.5 times the speed is another curve.
    let faster: Vec<f64> = bevy_curve(&images, weights, 1.5 / 60.0);
    assert!((120..300).any(|n| (faster[n] - run.cpu[n]).abs() > 0.1));
}
