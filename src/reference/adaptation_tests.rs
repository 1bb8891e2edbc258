use super::*;
use crate::reference::histogram::{bin_of, mask_weight, BINS};
use crate::scene::{Compensation, Mask, Speed};

const LN2: f64 = std::f64::consts::LN_2;

fn stats(l: f64) -> Metered {
    Metered {
        log_average: l.ln(),
        weighted_log_average: None,
        max: None,
    }
}

fn time_constants(up: f64, down: f64) -> Adaptation {
    Adaptation::new(up, down, 0.18).unwrap()
}

/// An infinite or NaN measurement leaves the state where it was, and a
/// first frame's is ln 1 (clamped into the range).
#[test]
fn a_non_finite_measurement_never_enters_the_state() {
    for a in [time_constants(0.4, 1.6), Adaptation::default()] {
        let before = adapt(stats(0.5), None, &a, 1.0 / 60.0);
        for bad in [f64::INFINITY, f64::NAN, 0.0] {
            let after = adapt(stats(bad), Some(&before), &a, 1.0 / 60.0);
            assert_eq!(after.log_average, before.log_average, "{bad}");
            assert_eq!(adapt(stats(bad), None, &a, 0.1).log_average, 0.0, "{bad}");
        }
    }
    let dim = Adaptation {
        max_ev: -2.0,
        ..Adaptation::default()
    };
    assert_eq!(
        adapt(stats(f64::NAN), None, &dim, 0.1).log_average,
        -2.0 * LN2
    );
}

#[test]
fn the_first_frame_takes_the_measurement_and_later_ones_close_the_gap_by_the_step() {
    let a = time_constants(0.5, 2.0);
    let dt = 1.0 / 60.0;
    let steps = a.steps(dt);
    let first = adapt(stats(0.01), None, &a, dt);
    assert_eq!(first.log_average, 0.01f64.ln());
    // Brighter: the up step; n frames leave (1 - α)^n of the gap.
    let mut s = first;
    for _ in 0..60 {
        s = adapt(stats(1.0), Some(&s), &a, dt);
    }
    let gap = 0.01f64.ln() * (1.0 - steps.0).powi(60);
    assert!(
        (s.log_average - gap).abs() < 1e-12,
        "{} {gap}",
        s.log_average
    );
    // One second at τ = 0.5 s leaves e^-2 of the gap.
    assert!((gap / 0.01f64.ln() - (-2f64).exp()).abs() < 1e-12);
    // Darker: the slower down step.
    let down = adapt(stats(0.01), Some(&s), &a, dt);
    let up = adapt(stats(s.log_average.exp().powi(2) * 50.0), Some(&s), &a, dt);
    assert!((down.log_average - s.log_average).abs() < (up.log_average - s.log_average).abs());
    assert!((steps.1 - (-(-1.0f64 / 120.0).exp_m1())).abs() < 1e-15);
}

/// Under the stops rule the value moves at most `stops_up` a second while
/// far from the target, and by the fraction speed·Δt / transition of the
/// gap within it, never past it.
#[test]
fn the_stops_rule_moves_linearly_far_off_then_exponentially_and_never_overshoots() {
    let a = Adaptation {
        speed: Speed::Stops,
        stops_up: crate::scene::Positive::try_from(6.0).unwrap(),
        stops_down: crate::scene::Positive::try_from(2.0).unwrap(),
        transition: 1.0,
        ..Adaptation::default()
    };
    let dt = 0.1;
    // 5 stops below: 0.6 stops up in one frame.
    let b = a.follow(0.0, 5.0 * LN2, dt);
    assert!((b / LN2 - 0.6).abs() < 1e-12, "{}", b / LN2);
    // Darker, 5 stops: 0.2 stops down.
    let d = a.follow(0.0, -5.0 * LN2, dt);
    assert!((d / LN2 + 0.2).abs() < 1e-12, "{}", d / LN2);
    // Half a stop below, inside the 1-stop transition: 0.6 of the gap.
    let n = a.follow(0.0, 0.5 * LN2, dt);
    assert!((n / LN2 - 0.3).abs() < 1e-12, "{}", n / LN2);
    // A frame long enough to pass the target stops on it.
    assert_eq!(a.follow(0.0, 0.5 * LN2, 10.0), 0.5 * LN2);
    let linear = Adaptation {
        transition: 0.0,
        ..a
    };
    assert!((linear.follow(0.0, 0.5 * LN2, dt) / LN2 - 0.5).abs() < 1e-12);
}

/// The target is the measurement less the compensation, within the range.
#[test]
fn the_target_is_compensated_then_clamped_to_the_ev_range() {
    let curve = Compensation::try_from(vec![[-4.0, 2.0], [4.0, -2.0]]).unwrap();
    let a = Adaptation {
        min_ev: -6.0,
        max_ev: 6.0,
        compensation: curve,
        ..Adaptation::default()
    };
    assert_eq!(curve.at(-10.0), 2.0);
    assert_eq!(curve.at(0.0), 0.0);
    assert_eq!(curve.at(2.0), -1.0);
    assert_eq!(curve.at(9.0), -2.0);
    // 2 EV metered, -1 stop (darker): the target is 3 EV.
    assert!((a.target(2.0 * LN2) / LN2 - 3.0).abs() < 1e-12);
    assert_eq!(a.target(-20.0 * LN2), -6.0 * LN2);
    assert_eq!(a.target(20.0 * LN2), 6.0 * LN2);
    assert!(Compensation::try_from(vec![[1.0, 0.0], [1.0, 1.0]]).is_err());
    assert!(Compensation::try_from(vec![[0.0, 17.0]]).is_err());
    assert!(Compensation::try_from(vec![[0.0, 0.0]; 9]).is_err());
}

#[test]
fn operators_that_key_on_nothing_get_key_over_the_adapted_luminance() {
    let a = time_constants(0.5, 2.0);
    let s = adapt(stats(0.09), None, &a, 0.1);
    let none = StatsNeeds::default();
    assert!((s.exposure(&a, none) - 2.0).abs() < 1e-12);
    let reinhard = StatsNeeds {
        log_average: true,
        ..none
    };
    assert_eq!(s.exposure(&a, reinhard), 1.0);
    let measured = LuminanceStats {
        log_average: Some(5.0),
        ..Default::default()
    };
    assert!((s.statistics(&measured).log_average.unwrap() - 0.09).abs() < 1e-15);
}

/// Bins cover [min_ev, max_ev) evenly; below (zero too) is the first, above
/// the last, and a NaN, infinite or negative luminance is not binned.
#[test]
fn luminance_is_binned_by_its_log2_and_bad_values_are_skipped() {
    let a = Adaptation::bevy();
    assert_eq!((a.min_ev, a.max_ev), (-8.0, 8.0));
    assert_eq!(bin_of(1.0, &a), Some(32));
    assert_eq!(bin_of(2f64.powf(-8.0), &a), Some(0));
    assert_eq!(bin_of(2f64.powf(7.99), &a), Some(63));
    assert_eq!(bin_of(2f64.powf(0.25), &a), Some(33));
    assert_eq!(bin_of(0.0, &a), Some(0));
    assert_eq!(bin_of(1e30, &a), Some(BINS - 1));
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1.0] {
        assert_eq!(bin_of(bad, &a), None, "{bad}");
    }
}

#[test]
fn the_centre_mask_weighs_1_at_the_corners_and_16_at_the_centre() {
    let (w, h) = (64, 36);
    assert_eq!(mask_weight(Mask::Centre, 0, 0, w, h), 1);
    assert_eq!(mask_weight(Mask::Centre, w - 1, h - 1, w, h), 1);
    assert_eq!(mask_weight(Mask::Centre, w / 2, h / 2, w, h), 16);
    assert_eq!(mask_weight(Mask::Centre, w / 2, 0, w, h), 4);
    assert_eq!(mask_weight(Mask::Uniform, w / 2, h / 2, w, h), 1);
    // Symmetric about the centre on both axes.
    for x in 0..w {
        assert_eq!(
            mask_weight(Mask::Centre, x, 5, w, h),
            mask_weight(Mask::Centre, w - 1 - x, 5, w, h)
        );
    }
}

/// With 10 %…90 % kept, a bright tenth of the weight (a sun) moves the
/// metered EV by nothing, and without the filter it pulls it up.
#[test]
fn the_percentile_filter_drops_the_brightest_and_darkest_weight() {
    let a = Adaptation::bevy();
    let mut bins = [0u64; BINS];
    bins[20] = 90;
    let calm = Histogram { bins }.metered_ev(&a).unwrap();
    assert_eq!(calm, Histogram::centre(20, &a));
    bins[63] = 10;
    let sun = Histogram { bins }.metered_ev(&a).unwrap();
    assert_eq!(sun, calm);
    let unfiltered = Adaptation {
        low: 0.0,
        high: 1.0,
        ..a
    };
    let pulled = Histogram { bins }.metered_ev(&unfiltered).unwrap();
    assert!(pulled > calm + 1.0, "{pulled} {calm}");
    // A bin cut by the filter counts in part: 50 dark, 50 bright, 10 % off
    // each end leaves 40 and 40.
    let mut two = [0u64; BINS];
    two[0] = 50;
    two[10] = 50;
    let mid = Histogram { bins: two }.metered_ev(&a).unwrap();
    let want = (Histogram::centre(0, &a) + Histogram::centre(10, &a)) / 2.0;
    assert!((mid - want).abs() < 1e-12, "{mid} {want}");
    assert_eq!(Histogram { bins: [0; BINS] }.metered_ev(&a), None);
}

/// The white point follows the largest luminance by the same rule; a
/// non-finite one leaves it, and before any finite one each frame keeps
/// its own.
#[test]
fn the_white_point_follows_the_largest_luminance_and_skips_a_non_finite_one() {
    let a = Adaptation::default();
    let with_max = |max: f64| Metered {
        max: Some(max.ln()),
        ..stats(0.5)
    };
    let dt = 1.0 / 60.0;
    assert_eq!(adapt(with_max(f64::INFINITY), None, &a, dt).max, None);
    let first = adapt(with_max(100.0), None, &a, dt);
    assert_eq!(first.max, Some(100f64.ln()));
    let spike = adapt(with_max(1e6), Some(&first), &a, dt);
    let moved = (spike.max.unwrap() - first.max.unwrap()) / LN2;
    assert!((moved - a.stops_up.get() * dt).abs() < 1e-12, "{moved}");
    let held = adapt(with_max(f64::INFINITY), Some(&spike), &a, dt);
    assert_eq!(held.max, spike.max);
    let measured = LuminanceStats {
        max: Some(7.0),
        ..Default::default()
    };
    assert_eq!(
        first.statistics(&measured).max,
        Some(first.max.unwrap().exp())
    );
    let unadapted = Adapted { max: None, ..first };
    assert_eq!(unadapted.statistics(&measured).max, Some(7.0));
}
