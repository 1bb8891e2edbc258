use super::*;
use crate::conventions::{reprojection, rotation_matrix};

/// The thesis's TAA: bilinear history, luminance feedback, linear blend.
fn params(variant: TaaVariant) -> TaaParams {
    TaaParams {
        variant,
        feedback: FeedbackRule::Luminance,
        feedback_min: 0.88,
        feedback_max: 0.97,
        blend: BlendSpace::Linear,
        sharpen: 0.0,
        history_filter: HistoryFilter::Bilinear,
        ..TaaParams::default()
    }
}

/// A history of `colour` whose every pixel has averaged `frames` frames.
fn history(colour: LinearImage, frames: f64) -> TaaHistory {
    let confidence = Image {
        width: colour.width,
        height: colour.height,
        pixels: vec![frames; colour.pixel_count()],
    };
    TaaHistory { colour, confidence }
}

#[test]
fn clipping_moves_toward_the_centre_where_clamping_would_snap_to_a_corner() {
    let (lo, hi) = ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    assert_eq!(clip_to_box([0.2, 0.5, 0.9], lo, hi), [0.2, 0.5, 0.9]);
    // (3, 0.5, 0.5) lies on the line through the centre along x: the
    // clip lands on the face at x = 1; so does a clamp.
    assert_eq!(clip_to_box([3.0, 0.5, 0.5], lo, hi), [1.0, 0.5, 0.5]);
    // Off-axis, the clip keeps the direction from the centre; a clamp
    // would give (1, 1, 0.5), a colour that was never there.
    let c = clip_to_box([2.5, 1.5, 0.5], lo, hi);
    assert!(
        (c[0] - 1.0).abs() < 1e-15 && (c[1] - 0.75).abs() < 1e-15 && c[2] == 0.5,
        "{c:?}"
    );
    // A flat box takes its only colour.
    assert_eq!(clip_to_box([2.0, 2.0, 2.0], [1.0; 3], [1.0; 3]), [1.0; 3]);
}

#[test]
fn feedback_is_highest_when_history_agrees_and_ignores_exposure() {
    let p = params(TaaVariant::Clip);
    assert_eq!(feedback([1.0; 3], [1.0; 3], &p), 0.97);
    assert!((feedback([1.0; 3], [0.0; 3], &p) - 0.88).abs() < 1e-15);
    let a = feedback([1.0; 3], [1.5; 3], &p);
    let b = feedback([1e3; 3], [1.5e3; 3], &p);
    assert!((a - b).abs() < 1e-12 && a > 0.88 && a < 0.97);
    assert_eq!(feedback([0.0; 3], [0.0; 3], &p), 0.97);
}

fn camera() -> Camera {
    Camera {
        width: 16,
        height: 12,
        fov_y_deg: 60.0,
    }
}

fn still() -> Mat3 {
    let r = rotation_matrix([1.0, 0.0, 0.0], 0.2);
    reprojection(&r, &r)
}

#[test]
fn a_reset_passes_the_current_frame_through() {
    let cur = LinearImage::from_fn(16, 12, |x, y| [x as f64, y as f64, 1.0]);
    let out = taa(
        &cur,
        None,
        &TaaFrame {
            history: None,
            reprojection: Reprojection::Rotation {
                camera: camera(),
                matrix: still(),
            },
        },
        &params(TaaVariant::Clip),
    );
    assert_eq!(out.history.colour.pixels, cur.pixels);
    assert!(out.history.confidence.pixels.iter().all(|&n| n == 1.0));
}

#[test]
fn a_history_inside_the_box_converges_and_one_outside_is_clipped() {
    // Current frame flat 1.0: the box is the point 1.0 in `clip`, so any
    // history is clipped onto it.
    let cur = LinearImage::filled(16, 12, [1.0; 3]);
    let hist = history(LinearImage::filled(16, 12, [5.0; 3]), 4.0);
    let frame = TaaFrame {
        history: Some(&hist),
        reprojection: Reprojection::Rotation {
            camera: camera(),
            matrix: still(),
        },
    };
    let out = taa(&cur, None, &frame, &params(TaaVariant::Clip));
    assert!(out
        .history
        .colour
        .pixels
        .iter()
        .all(|p| (p[0] - 1.0).abs() < 1e-12));
    // A checkerboard current frame: the box spans [0, 1], a grey history
    // is inside it and keeps 97 % of its weight (equal luminance).
    let cur = LinearImage::from_fn(16, 12, |x, y| [((x + y) % 2) as f64; 3]);
    let hist = history(LinearImage::filled(16, 12, [0.5; 3]), 4.0);
    let frame = TaaFrame {
        history: Some(&hist),
        reprojection: Reprojection::Rotation {
            camera: camera(),
            matrix: still(),
        },
    };
    let out = taa(&cur, None, &frame, &params(TaaVariant::Clip));
    let p = out.history.colour.get(5, 5);
    let c = cur.get(5, 5)[0];
    let k = feedback([c; 3], [0.5; 3], &params(TaaVariant::Clip));
    assert!((p[0] - (c + (0.5 - c) * k)).abs() < 1e-12, "{p:?}");
}

#[test]
fn edge_aware_rejects_history_where_there_is_no_edge() {
    // A smooth ramp: no edge anywhere, so the box shrinks to the current
    // colour and a stale history is dropped; `clip` keeps some of it.
    let cur = LinearImage::from_fn(16, 12, |x, _| [1.0 + 0.001 * x as f64; 3]);
    let hist = history(
        LinearImage::from_fn(16, 12, |x, _| [1.0 + 0.001 * x as f64 + 0.0015; 3]),
        4.0,
    );
    let frame = TaaFrame {
        history: Some(&hist),
        reprojection: Reprojection::Rotation {
            camera: camera(),
            matrix: still(),
        },
    };
    let s = super::super::taa_sobel::taa_sobel(&cur);
    let edge = taa(&cur, Some(&s), &frame, &params(TaaVariant::EdgeAware));
    let clip = taa(&cur, None, &frame, &params(TaaVariant::Clip));
    let (e, c, now) = (
        edge.history.colour.get(8, 6)[0],
        clip.history.colour.get(8, 6)[0],
        cur.get(8, 6)[0],
    );
    assert!(
        (e - now).abs() < (c - now).abs(),
        "edge-aware {e}, clip {c}, current {now}"
    );
}

#[test]
fn history_off_the_film_is_rejected() {
    let cam = camera();
    let cur = LinearImage::filled(16, 12, [1.0; 3]);
    // A coloured history: clipped toward the grey box centre, it cannot
    // land on the current grey value.
    let hist = history(LinearImage::filled(16, 12, [3.0, 0.0, 3.0]), 4.0);
    // A large turn about x: the top rows saw the sphere above the film.
    let m = reprojection(
        &rotation_matrix([1.0, 0.0, 0.0], 0.0),
        &rotation_matrix([1.0, 0.0, 0.0], 0.5),
    );
    let mut p = params(TaaVariant::Clip);
    p.feedback_min = 0.5;
    // With the box a point at 1.0 the clipped history is 1.0 anyway;
    // widen it with a checkerboard to see the rejection itself.
    let cur2 = LinearImage::from_fn(16, 12, |x, y| [((x + y) % 2) as f64 + 0.5; 3]);
    let out = taa(
        &cur2,
        None,
        &TaaFrame {
            history: Some(&hist),
            reprojection: Reprojection::Rotation {
                camera: cam,
                matrix: m,
            },
        },
        &p,
    );
    let rejected: Vec<bool> = (0..12u32)
        .map(|j| reproject(&cam, &m, 8, j).is_none())
        .collect();
    assert!(rejected.iter().any(|&r| r) && rejected.iter().any(|&r| !r));
    for (j, r) in rejected.iter().enumerate() {
        let got = out.history.colour.get(8, j as u32);
        let now = cur2.get(8, j as u32);
        assert_eq!(got == now, *r, "row {j}: {got:?} vs {now:?}");
        // The frame count starts again at 1 where the history was lost.
        let frames = out.history.confidence.get(8, j as u32);
        assert_eq!(frames, if *r { 1.0 } else { 5.0 }, "row {j}");
    }
    let _ = cur;
}

/// Motion vectors that say where the rotation moved each pixel resolve as
/// the rotation does; in the bevy convention (UV units, current minus
/// previous) as in pixels toward the previous frame; and a vector that
/// leaves the film, or is NaN, drops the history.
#[test]
fn motion_vectors_resolve_as_the_reprojection_they_describe() {
    let cam = camera();
    let m = reprojection(
        &rotation_matrix([0.0, 1.0, 0.0], 0.0),
        &rotation_matrix([0.0, 1.0, 0.0], 0.08),
    );
    let cur = LinearImage::from_fn(16, 12, |x, y| [((x * 7 + y * 3) % 5) as f64 + 0.25; 3]);
    let hist = history(
        LinearImage::from_fn(16, 12, |x, y| [(x + 2 * y) as f64 * 0.3; 3]),
        3.0,
    );
    let p = params(TaaVariant::Clip);
    let rotation = Reprojection::Rotation {
        camera: cam,
        matrix: m,
    };
    let offset = |i: u32, j: u32| {
        let (px, py) = reproject(&cam, &m, i, j).unwrap_or((f64::NAN, f64::NAN));
        [px - (i as f64 + 0.5), py - (j as f64 + 0.5)]
    };
    let pixels = Image::from_fn(16, 12, offset);
    let uv = Image::from_fn(16, 12, |i, j| {
        let [dx, dy] = offset(i, j);
        [-dx / 16.0, -dy / 12.0]
    });
    let run = |reprojection| {
        let frame = TaaFrame {
            history: Some(&hist),
            reprojection,
        };
        taa(&cur, None, &frame, &p)
    };
    let want = run(rotation);
    for (name, vectors, scale) in [("pixels", &pixels, [1.0, 1.0]), ("uv", &uv, [-16.0, -12.0])] {
        let got = run(Reprojection::Motion { vectors, scale });
        assert_eq!(got.history.confidence, want.history.confidence, "{name}");
        for (g, w) in got
            .history
            .colour
            .pixels
            .iter()
            .zip(&want.history.colour.pixels)
        {
            for c in 0..3 {
                // The point rebuilt from its offset is within an ulp or two
                // of the rotation's.
                assert!(
                    (g[c] - w[c]).abs() <= 1e-12 * (1.0 + w[c].abs()),
                    "{name}: {g:?} vs {w:?}"
                );
            }
        }
    }
    // Off the film and NaN: no history, the current frame passes through.
    let away = Image::from_fn(16, 12, |i, _| match i {
        0 => [-1.0, 0.0],
        1 => [f64::NAN, 0.0],
        _ => [0.0, 0.0],
    });
    let out = run(Reprojection::Motion {
        vectors: &away,
        scale: [1.0, 1.0],
    });
    for j in 0..12 {
        for i in 0..3 {
            let kept = out.history.confidence.get(i, j) > 1.0;
            assert_eq!(kept, i == 2, "pixel ({i}, {j})");
        }
    }
}

#[test]
fn catmull_rom_reproduces_the_texels_and_a_ramp_and_keeps_an_edge_sharper() {
    let ramp = LinearImage::from_fn(8, 8, |x, _| [x as f64; 3]);
    for &(px, py) in &[(3.5, 3.5), (3.25, 4.5), (4.8, 2.2)] {
        let b = history_at(&ramp, px, py, HistoryFilter::Bilinear)[0];
        let c = history_at(&ramp, px, py, HistoryFilter::CatmullRom)[0];
        assert!(
            (b - (px - 0.5)).abs() < 1e-12 && (c - (px - 0.5)).abs() < 1e-12,
            "{b} {c}"
        );
    }
    for t in [0.0, 0.3, 0.75] {
        let w = catmull_rom_weights(t);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }
    // A step between columns 3 and 4, read a quarter texel to either
    // side of the middle: Catmull-Rom stays nearer the side it is on
    // (bilinear's 0.25 / 0.75 are a blur), and never below 0.
    let step = LinearImage::from_fn(8, 8, |x, _| [if x < 4 { 0.0 } else { 1.0 }; 3]);
    for px in [3.75, 4.25] {
        let b = history_at(&step, px, 4.5, HistoryFilter::Bilinear)[0];
        let c = history_at(&step, px, 4.5, HistoryFilter::CatmullRom)[0];
        assert!(
            (c - 0.5).abs() > (b - 0.5).abs() && c >= 0.0,
            "bilinear {b}, catmull-rom {c}"
        );
    }
}

#[test]
fn sharpen_at_strength_one_is_the_seed_kernel_and_a_quarter_the_normalised_one() {
    let b = LinearImage::from_fn(5, 5, |x, y| [(x * 3 + y * 7 % 5) as f64 + 1.0; 3]);
    let s1 = sharpen(&b, 1.0);
    let q = sharpen(&b, 0.25);
    let (c, n, s, e, w) = (
        b.get(2, 2)[0],
        b.get(2, 1)[0],
        b.get(2, 3)[0],
        b.get(3, 2)[0],
        b.get(1, 2)[0],
    );
    let (lo, hi) = (c.min(n).min(s).min(e).min(w), c.max(n).max(s).max(e).max(w));
    assert_eq!(s1.get(2, 2)[0], (5.0 * c - n - s - e - w).clamp(lo, hi));
    assert!((q.get(2, 2)[0] - (2.0 * c - 0.25 * (n + s + e + w)).clamp(lo, hi)).abs() < 1e-12);
    // A bright line among dark pixels: the full kernel would give the
    // dark neighbour 0.1·5 − 10 < 0; the limit keeps it at its own range.
    let line = LinearImage::from_fn(5, 5, |x, _| [if x == 2 { 10.0 } else { 0.1 }; 3]);
    let out = sharpen(&line, 1.0);
    assert_eq!(out.get(1, 2)[0], 0.1);
    assert_eq!(out.get(2, 2)[0], 10.0);
}

#[test]
fn the_motion_rule_weighs_the_current_frame_by_motion_and_frame_count() {
    let p = TaaParams::default();
    assert_eq!(p.feedback, FeedbackRule::Motion);
    // Static with a full history: the smallest weight.
    assert_eq!(motion_weight(100.0, 0.0, &p), p.current_min);
    // A young history averages its frames equally: 1/k of the k-th frame.
    assert_eq!(motion_weight(2.0, 0.0, &p), 0.5);
    assert_eq!(motion_weight(5.0, 0.0, &p), 0.2);
    // Moving: a base plus a term per pixel, up to the most.
    assert!((motion_weight(100.0, 1.0, &p) - (p.current_moving + p.current_per_px)).abs() < 1e-15);
    assert_eq!(motion_weight(100.0, 50.0, &p), p.current_max);
    // Under the static threshold a point counts as still.
    assert_eq!(motion_weight(100.0, 0.5 * p.static_px, &p), p.current_min);
}

#[test]
fn a_static_history_is_the_plain_mean_of_its_frames_and_counts_them() {
    // Frames of a checkerboard whose levels change frame to frame but stay
    // inside the box (so nothing is clipped): with the motion rule the
    // history is the exact mean of the frames so far, the frame count
    // grows by one per frame, and the tone-mapped blend is not used on a
    // static pixel.
    let p = TaaParams {
        blend: BlendSpace::Tonemapped,
        ..TaaParams::default()
    };
    let frame = |k: usize| {
        LinearImage::from_fn(16, 12, move |x, y| {
            let hi = [3.0, 5.0, 6.0, 6.0][k];
            [if (x + y) % 2 == 0 { 0.5 } else { hi }; 3]
        })
    };
    let mut hist: Option<TaaHistory> = None;
    for k in 0..4 {
        let out = taa(
            &frame(k),
            None,
            &TaaFrame {
                history: hist.as_ref(),
                reprojection: Reprojection::Rotation {
                    camera: camera(),
                    matrix: still(),
                },
            },
            &p,
        );
        hist = Some(out.history);
    }
    let h = hist.unwrap();
    // Pixel (5, 6) is odd: its levels were 3, 5, 6, 6 (each at least the
    // mean before it, so the box never clips it).
    assert!(
        (h.colour.get(5, 6)[0] - 5.0).abs() < 1e-12,
        "{:?}",
        h.colour.get(5, 6)
    );
    assert!((h.colour.get(6, 6)[0] - 0.5).abs() < 1e-12);
    assert!(h.confidence.pixels.iter().all(|&n| n == 4.0));
    // The count stops at its cap.
    let full = history(LinearImage::filled(16, 12, [1.0; 3]), CONFIDENCE_CAP);
    let out = taa(
        &LinearImage::filled(16, 12, [1.0; 3]),
        None,
        &TaaFrame {
            history: Some(&full),
            reprojection: Reprojection::Rotation {
                camera: camera(),
                matrix: still(),
            },
        },
        &p,
    );
    assert!(out
        .history
        .confidence
        .pixels
        .iter()
        .all(|&n| n == CONFIDENCE_CAP));
}

#[test]
fn the_tonemapped_blend_keeps_a_bright_sample_from_dominating() {
    let (c, h) = ([100.0; 3], [1.0; 3]);
    let linear = blend(c, h, 0.5, BlendSpace::Linear)[0];
    let tm = blend(c, h, 0.5, BlendSpace::Tonemapped)[0];
    assert_eq!(linear, 50.5);
    // Weights 0.5/101 and 0.5/2: the mean leans to the dark sample.
    let expected = (100.0 / 101.0 + 1.0 / 2.0) / (1.0 / 101.0 + 1.0 / 2.0);
    assert!((tm - expected).abs() < 1e-12 && tm < 3.0, "{tm}");
    // Equal colours blend to themselves either way.
    assert_eq!(blend(h, h, 0.3, BlendSpace::Tonemapped), h);
}

#[test]
fn variance_clipping_works_in_ycocg_around_the_neighbourhood_mean() {
    for c in [[1.0, 2.0, 3.0], [0.0, 0.5, 7.0], [1e3, 1e-3, 5.0]] {
        let back = from_ycocg(to_ycocg(c));
        for k in 0..3 {
            assert!(
                (back[k] - c[k]).abs() < 1e-12 * c[k].abs().max(1.0),
                "{c:?} {back:?}"
            );
        }
    }
    // Grey checkerboard 0/2: Y mean 1, σ 1, no chroma. A grey history
    // inside mean ± σ stays; one beyond is clipped onto Y = 2 (γ = 1) or
    // Y = 1.5 (γ = 0.5); a coloured history loses its colour (the box is
    // flat in Co and Cg) and lands on the mean.
    let cur = LinearImage::from_fn(16, 12, |x, y| [((x + y) % 2) as f64 * 2.0; 3]);
    // At (5, 5) the 3×3 holds five 0s and four 2s: mean 8/9.
    let (m, s) = (8.0 / 9.0, (4.0 * 4.0 / 9.0 - (8.0 / 9.0f64).powi(2)).sqrt());
    assert_eq!(clip_variance(&cur, 5, 5, [1.2; 3], 1.0), [1.2; 3]);
    let hi = clip_variance(&cur, 5, 5, [5.0; 3], 1.0)[0];
    assert!((hi - (m + s)).abs() < 1e-12, "{hi}");
    let half = clip_variance(&cur, 5, 5, [5.0; 3], 0.5)[0];
    assert!((half - (m + 0.5 * s)).abs() < 1e-12, "{half}");
    let coloured = clip_variance(&cur, 5, 5, [3.0, 0.0, 0.0], 1.0);
    for k in 0..3 {
        assert!((coloured[k] - m).abs() < 1e-12, "{coloured:?}");
    }
}
