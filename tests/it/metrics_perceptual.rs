//! The perceptual and HDR metrics locked against their reference
//! implementations (tests/perceptual/vectors.json, regenerated in CI from the
//! pinned versions by tests/perceptual/make_vectors.sh when the lock's
//! inputs change, ci/locks.sh):
//! FLIP and HDR-FLIP against NVIDIA's flip-evaluator 1.7, PU21 against the
//! paper's formula in numpy (and scikit-image's SSIM), ΔE_ITP against
//! colour-science.

use serde::Deserialize;
use serde_json::value::RawValue;
use tonegate::image::{HdrImage, Image};
use tonegate::metrics::flip::{flip, DEFAULT_PPD};
use tonegate::metrics::hdr_flip::{hdr_flip, HdrFlipOptions};
use tonegate::metrics::itp::delta_e_itp;
use tonegate::metrics::pu21::{encode, pu21};
use tonegate::metrics::{MetricsError, Raster};

// ---- tolerances, each with where it comes from ---------------------------

/// FLIP per pixel. nv-flip builds NVIDIA's C++ FLIP 1.2, flip-evaluator 1.7.
/// On these cases the maps agree to 1e-16; on a Full HD noise pair the two
/// versions differed by at most 5.2e-4 (they order some filter sums
/// differently), measured when this lock was written. Values are in [0, 1].
const FLIP_PIXEL: f64 = 1e-3;
/// FLIP mean: the same difference averaged (9.6e-6 on that Full HD pair).
const FLIP_MEAN: f64 = 1e-4;
/// HDR-FLIP per pixel: each exposure reaches nv-flip as 8-bit sRGB (the only
/// input it takes) while flip-evaluator keeps it in float, so a pixel can
/// differ by FLIP's response to half an 8-bit step of its tone-mapped value:
/// 1.5e-2 at worst on these cases.
const HDR_FLIP_PIXEL: f64 = 0.05;
/// HDR-FLIP mean: that rounding averaged over a frame, 9.4e-4 at worst here
/// (about 2 % of those cases' HDR-FLIP).
const HDR_FLIP_MEAN: f64 = 2e-3;
/// HDR-FLIP's exposure range: f32 arithmetic on both sides.
const EXPOSURE: f64 = 1e-5;
/// PU21 values: tonegate interpolates the formula between 1024 points per
/// binade; its own test bounds that by 1e-5 PU units.
const PU21_VALUE: f64 = 1e-5;
/// PU21-PSNR (dB): the table error above on both images' values, through
/// 10·log10 of their squared difference.
const PU21_PSNR: f64 = 1e-4;
/// PU21-SSIM: the table error on values spanning 0..600; SSIM itself is the
/// scikit-image lock's 1e-6 (tests/metrics_skimage.rs).
const PU21_SSIM: f64 = 1e-6;
/// ΔE_ITP, relative: both sides evaluate the same f64 formulas (matrices
/// from the same primaries, PQ with pow); only pow's last bits differ.
const ITP_REL: f64 = 1e-9;

// ---- the vectors ----------------------------------------------------------

#[derive(Deserialize)]
struct Vectors {
    pu21_points: Vec<[f64; 2]>,
    ldr: Vec<LdrCase>,
    hdr: Vec<HdrCase>,
}

#[derive(Deserialize)]
struct LdrCase {
    name: String,
    width: u32,
    height: u32,
    test: Vec<u8>,
    reference: Vec<u8>,
    flip_mean: f64,
    flip_median: f64,
    flip_max: f64,
    flip_map: Vec<f64>,
}

#[derive(Deserialize)]
struct HdrCase {
    name: String,
    width: u32,
    height: u32,
    test: Vec<f32>,
    reference: Vec<f32>,
    peak: f64,
    hdr_flip_mean: Option<f64>,
    hdr_flip_map: Option<Vec<f64>>,
    hdr_flip_start: Option<f64>,
    hdr_flip_stop: Option<f64>,
    hdr_flip_exposures: Option<u32>,
    pu21_psnr: Box<RawValue>,
    pu21_ssim: f64,
    delta_e_itp_mean: f64,
    delta_e_itp_max: f64,
}

fn load() -> Vectors {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/perceptual/vectors.json");
    let text = std::fs::read_to_string(path).expect("tests/perceptual/vectors.json");
    serde_json::from_str(&text).expect("vectors parse")
}

fn number(raw: &RawValue) -> f64 {
    match raw.get() {
        "\"inf\"" => f64::INFINITY,
        "\"-inf\"" => f64::NEG_INFINITY,
        text => text.parse().unwrap_or_else(|e| panic!("{text}: {e}")),
    }
}

fn image(width: u32, height: u32, values: &[f32]) -> HdrImage {
    Image {
        width,
        height,
        pixels: values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// The worst deviation of one quantity, reported at the end.
#[derive(Default)]
struct Worst {
    value: f64,
    at: String,
}

impl Worst {
    fn check(&mut self, what: &str, case: &str, got: f64, want: f64, tolerance: f64) {
        let d = if got == want { 0.0 } else { (got - want).abs() };
        assert!(
            d <= tolerance,
            "{case}: {what} is {got}, the reference says {want} (|Δ| {d:e} > {tolerance:e})"
        );
        if d > self.value {
            self.value = d;
            self.at = case.to_owned();
        }
    }

    fn report(&self, what: &str, tolerance: f64) {
        eprintln!(
            "{what}: worst |Δ| {:e} ({}), tolerance {tolerance:e}",
            self.value, self.at
        );
    }
}

#[test]
fn ldr_flip_matches_flip_evaluator() {
    let (mut pixel, mut mean, mut median, mut max) = Default::default();
    let v = load();
    assert!(v.ldr.len() >= 6);
    for c in &v.ldr {
        let t = Raster::new(c.width, c.height, 3, &c.test).unwrap();
        let r = Raster::new(c.width, c.height, 3, &c.reference).unwrap();
        let f = flip(t, r, DEFAULT_PPD).unwrap();
        let s = f.stats();
        for (got, want) in f.map.pixels.iter().zip(&c.flip_map) {
            Worst::check(
                &mut pixel,
                "map",
                &c.name,
                f64::from(*got),
                *want,
                FLIP_PIXEL,
            );
        }
        Worst::check(&mut mean, "mean", &c.name, s.mean, c.flip_mean, FLIP_MEAN);
        Worst::check(
            &mut median,
            "median",
            &c.name,
            s.median,
            c.flip_median,
            FLIP_PIXEL,
        );
        Worst::check(&mut max, "max", &c.name, s.max, c.flip_max, FLIP_PIXEL);
        if c.flip_mean == 0.0 {
            assert_eq!(
                s.mean, 0.0,
                "{}: identical images have FLIP 0 exactly",
                c.name
            );
        }
    }
    pixel.report("FLIP per pixel", FLIP_PIXEL);
    mean.report("FLIP mean", FLIP_MEAN);
    median.report("FLIP median", FLIP_PIXEL);
    max.report("FLIP max", FLIP_PIXEL);
}

#[test]
fn hdr_flip_matches_flip_evaluator() {
    let (mut pixel, mut mean, mut range) = Default::default();
    let v = load();
    let mut compared = 0;
    for c in &v.hdr {
        let (Some(map), Some(want_mean)) = (&c.hdr_flip_map, c.hdr_flip_mean) else {
            continue; // flip-evaluator cannot take it (an all-black reference)
        };
        let t = image(c.width, c.height, &c.test);
        let r = image(c.width, c.height, &c.reference);
        let (f, got) = hdr_flip(&t, &r, &HdrFlipOptions::default()).unwrap();
        Worst::check(
            &mut range,
            "start",
            &c.name,
            got.start,
            c.hdr_flip_start.unwrap(),
            EXPOSURE,
        );
        Worst::check(
            &mut range,
            "stop",
            &c.name,
            got.stop,
            c.hdr_flip_stop.unwrap(),
            EXPOSURE,
        );
        assert_eq!(Some(got.count), c.hdr_flip_exposures, "{}", c.name);
        for (g, w) in f.map.pixels.iter().zip(map) {
            Worst::check(
                &mut pixel,
                "map",
                &c.name,
                f64::from(*g),
                *w,
                HDR_FLIP_PIXEL,
            );
        }
        Worst::check(
            &mut mean,
            "mean",
            &c.name,
            f.mean(),
            want_mean,
            HDR_FLIP_MEAN,
        );
        compared += 1;
    }
    assert!(compared >= 4, "only {compared} HDR-FLIP cases");
    pixel.report("HDR-FLIP per pixel", HDR_FLIP_PIXEL);
    mean.report("HDR-FLIP mean", HDR_FLIP_MEAN);
    range.report("HDR-FLIP exposures", EXPOSURE);
}

#[test]
fn pu21_matches_the_formula_and_its_metrics() {
    let v = load();
    let mut value = Worst::default();
    for [y, want] in &v.pu21_points {
        Worst::check(
            &mut value,
            "PU21",
            &format!("Y = {y}"),
            encode(*y),
            *want,
            PU21_VALUE,
        );
    }
    let (mut psnr, mut ssim) = Default::default();
    for c in &v.hdr {
        let t = image(c.width, c.height, &c.test);
        let r = image(c.width, c.height, &c.reference);
        let p = pu21(&t, &r, c.peak).unwrap();
        let want = number(&c.pu21_psnr);
        if want.is_infinite() {
            assert_eq!(p.psnr, want, "{}", c.name);
        } else {
            Worst::check(&mut psnr, "PU21-PSNR", &c.name, p.psnr, want, PU21_PSNR);
        }
        Worst::check(
            &mut ssim,
            "PU21-SSIM",
            &c.name,
            p.ssim.mean,
            c.pu21_ssim,
            PU21_SSIM,
        );
    }
    value.report("PU21 value", PU21_VALUE);
    psnr.report("PU21-PSNR", PU21_PSNR);
    ssim.report("PU21-SSIM", PU21_SSIM);
}

#[test]
fn delta_e_itp_matches_colour_science() {
    let (mut mean, mut max) = Default::default();
    for c in &load().hdr {
        let t = image(c.width, c.height, &c.test);
        let r = image(c.width, c.height, &c.reference);
        let d = delta_e_itp(&t, &r, c.peak).unwrap();
        let rel = |w: f64| ITP_REL * w.abs().max(1.0);
        Worst::check(
            &mut mean,
            "mean",
            &c.name,
            d.mean,
            c.delta_e_itp_mean,
            rel(c.delta_e_itp_mean),
        );
        Worst::check(
            &mut max,
            "max",
            &c.name,
            d.max,
            c.delta_e_itp_max,
            rel(c.delta_e_itp_max),
        );
    }
    mean.report("delta E ITP mean", ITP_REL);
    max.report("delta E ITP max", ITP_REL);
}

#[test]
fn nan_is_refused_by_every_hdr_metric() {
    let good = HdrImage::filled(16, 16, [1.0; 3]);
    let mut bad = good.clone();
    bad.pixels[3][0] = f32::NAN;
    let refused = |r: Result<(), MetricsError>| {
        assert!(
            matches!(r, Err(MetricsError::NonFinite { x: 3, y: 0, .. })),
            "{r:?}"
        );
    };
    refused(pu21(&bad, &good, 100.0).map(|_| ()));
    refused(delta_e_itp(&good, &bad, 100.0).map(|_| ()));
    refused(hdr_flip(&bad, &good, &HdrFlipOptions::default()).map(|_| ()));
}
