//! HDR-FLIP (Andersson et al. 2021) for linear images: LDR FLIP of each of a
//! range of exposures, tone-mapped, the maximum over the exposures, with the
//! range, tone mappers and rules of NVIDIA's tool.

use super::flip::{flip, Flip, DEFAULT_PPD};
use super::raster::Raster;
use super::MetricsError;
use crate::image::{HdrImage, Image};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The tone curve HDR-FLIP renders each exposure with (FLIP's three; not
/// tonegate's [`ToneMapper`](crate::gpu::ToneMapper) nor an operator).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FlipToneCurve {
    /// Narkowicz's ACES fit, pre-exposure 0.6 cancelled: FLIP's default.
    #[default]
    Aces,
    /// Hable's filmic curve (Uncharted 2).
    Hable,
    /// x/(1 + x) on luminance.
    Reinhard,
}

impl FlipToneCurve {
    /// FLIP's rational-curve coefficients (x(c0·x + c1) + c2) / (x(c3·x +
    /// c4) + c5), per channel; Reinhard is c1 = c4 = c5 = 1 on luminance.
    fn coefficients(self) -> [f32; 6] {
        match self {
            FlipToneCurve::Reinhard => [0.0, 1.0, 0.0, 0.0, 1.0, 1.0],
            FlipToneCurve::Aces => [
                0.6 * 0.6 * 2.51,
                0.6 * 0.03,
                0.0,
                0.6 * 0.6 * 2.43,
                0.6 * 0.59,
                0.14,
            ],
            FlipToneCurve::Hable => [0.231683, 0.013791, 0.0, 0.18, 0.3, 0.018],
        }
    }

    /// The linear value the curve maps to 0.85: the brightest exposure keeps
    /// the reference's maximum there (FLIP's `computeExposures`).
    fn x_at_085(self) -> f32 {
        let c = self.coefficients();
        let t = 0.85f32;
        let (a, b, c) = (c[0] - t * c[3], c[1] - t * c[4], c[2] - t * c[5]);
        if a == 0.0 {
            return -c / b;
        }
        let d1 = -0.5 * (b / a);
        d1 + (d1 * d1 - c / a).sqrt()
    }

    fn apply(self, p: [f32; 3]) -> [f32; 3] {
        if self == FlipToneCurve::Reinhard {
            let y = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            let f = 1.0 / (1.0 + y);
            return p.map(|c| c * f);
        }
        let c = self.coefficients();
        p.map(|x| ((x * x) * c[0] + x * c[1] + c[2]) / (x * x * c[3] + x * c[4] + c[5]))
    }
}

/// How HDR-FLIP exposes the pair; unset values are chosen as NVIDIA's tool
/// chooses them.
#[derive(Clone, Debug)]
pub struct HdrFlipOptions {
    pub ppd: f64,
    pub tone_mapper: FlipToneCurve,
    /// First exposure (stops); default log2(x₀.₈₅ / max luminance of the reference).
    pub start: Option<f64>,
    /// Last exposure (stops); default log2(x₀.₈₅ / median luminance of the reference).
    pub stop: Option<f64>,
    /// Exposures; default max(2, ⌈stop − start⌉).
    pub exposures: Option<u32>,
}

impl Default for HdrFlipOptions {
    fn default() -> Self {
        HdrFlipOptions {
            ppd: DEFAULT_PPD,
            tone_mapper: FlipToneCurve::Aces,
            start: None,
            stop: None,
            exposures: None,
        }
    }
}

/// The exposures HDR-FLIP rendered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExposureRange {
    pub start: f64,
    pub stop: f64,
    pub count: u32,
    pub tone_mapper: FlipToneCurve,
}

/// Max and median luminance (FLIP's weights, in f32 as FLIP computes them),
/// the median taken at index n/2 of the sorted values and kept at least
/// f32's epsilon, as FLIP does.
fn max_and_median(img: &HdrImage) -> (f32, f32) {
    let mut y: Vec<f32> = img
        .pixels
        .iter()
        .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
        .collect();
    let max = y.iter().copied().fold(f32::MIN, f32::max);
    let mid = y.len() / 2;
    let (_, median, _) = y.select_nth_unstable_by(mid, f32::total_cmp);
    (max, median.max(f32::EPSILON))
}

/// The exposure range for `opts`, from the reference's luminance. A
/// reference with no light at all (max 0, where FLIP's own range is +∞ and
/// its tool stops) takes the test's luminance instead; two black images
/// have no range and are reported as one exposure at 0.
fn exposure_range(
    test: &HdrImage,
    reference: &HdrImage,
    opts: &HdrFlipOptions,
) -> Result<ExposureRange, MetricsError> {
    let x = opts.tone_mapper.x_at_085();
    let (mut max, mut median) = max_and_median(reference);
    if max <= 0.0 {
        (max, median) = max_and_median(test);
    }
    let auto = |y: f32| f64::from((x / y).log2());
    let (start, stop) = if max <= 0.0 {
        (opts.start.unwrap_or(0.0), opts.stop.unwrap_or(0.0))
    } else {
        (
            opts.start.unwrap_or_else(|| auto(max)),
            opts.stop.unwrap_or_else(|| auto(median)),
        )
    };
    if !(start.is_finite() && stop.is_finite() && start <= stop) {
        return Err(MetricsError::BadParameter {
            name: "exposure",
            detail: format!(
                "HDR-FLIP needs finite exposures with start <= stop, got {start} .. {stop}"
            ),
        });
    }
    let count = match opts.exposures {
        Some(0) => {
            return Err(MetricsError::BadParameter {
                name: "exposures",
                detail: "HDR-FLIP needs at least one exposure".into(),
            })
        }
        Some(n) => n,
        // Two black images: nothing to expose.
        None if max <= 0.0 => 1,
        None => ((stop - start) as f32).ceil().max(2.0) as u32,
    };
    Ok(ExposureRange {
        start,
        stop,
        count,
        tone_mapper: opts.tone_mapper,
    })
}

/// The sRGB OETF of a linear value in [0, 1], rounded to 8 bits.
fn srgb8(v: f32) -> u8 {
    let v = f64::from(v.clamp(0.0, 1.0));
    let e = if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * libm::pow(v, 1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

/// HDR-FLIP (Andersson et al. 2021): LDR FLIP of each exposure's tone-mapped
/// rendering, the maximum over the exposures. Each rendering is handed to
/// nv-flip as 8-bit sRGB (the only input it takes); NVIDIA's tool keeps it
/// in float, so the two differ by that rounding (measured by the lock).
pub fn hdr_flip(
    test: &HdrImage,
    reference: &HdrImage,
    opts: &HdrFlipOptions,
) -> Result<(Flip, ExposureRange), MetricsError> {
    super::hdr_input::check_hdr_pair(test, reference)?;
    let range = exposure_range(test, reference, opts)?;
    let (width, height) = (test.width, test.height);
    let mut map = Image::filled(width, height, 0.0f32);
    let step = if range.count > 1 {
        (range.stop - range.start) / f64::from(range.count - 1)
    } else {
        0.0
    };
    for i in 0..range.count {
        let gain = 2.0f32.powf((range.start + f64::from(i) * step) as f32);
        let render = |img: &HdrImage| -> Vec<u8> {
            img.pixels
                .par_iter()
                .flat_map_iter(|p| {
                    let t = range.tone_mapper.apply(p.map(|c| c * gain));
                    t.map(srgb8)
                })
                .collect()
        };
        let (t, r) = (render(test), render(reference));
        let exposure = flip(
            Raster::new(width, height, 3, &t)?,
            Raster::new(width, height, 3, &r)?,
            opts.ppd,
        )?;
        for (m, e) in map.pixels.iter_mut().zip(&exposure.map.pixels) {
            *m = m.max(*e);
        }
    }
    Ok((Flip { map, ppd: opts.ppd }, range))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_all_black_frame_has_a_defined_hdr_flip() {
        let black = HdrImage::filled(16, 16, [0.0; 3]);
        let (f, range) = hdr_flip(&black, &black, &HdrFlipOptions::default()).unwrap();
        assert_eq!(range.count, 1);
        assert_eq!(f.mean(), 0.0);
        // A lit test against a black reference: the range comes from the test
        // and the error is large, not NaN and not a refusal.
        let lit = HdrImage::filled(16, 16, [2.0, 1.0, 0.5]);
        let (f, range) = hdr_flip(&lit, &black, &HdrFlipOptions::default()).unwrap();
        assert!(range.count >= 2 && range.start.is_finite(), "{range:?}");
        assert!(f.mean() > 0.3, "{}", f.mean());
    }

    #[test]
    fn the_exposure_range_follows_flips_rule() {
        // Half the pixels at 0.25, half at 4: max 4, median (index n/2) 4.
        let img = HdrImage::from_fn(8, 8, |x, _| if x < 4 { [0.25; 3] } else { [4.0; 3] });
        let r = exposure_range(&img, &img, &HdrFlipOptions::default()).unwrap();
        let x = FlipToneCurve::Aces.x_at_085();
        assert!(
            (r.start - f64::from((x / 4.0f32).log2())).abs() < 1e-6,
            "{r:?}"
        );
        assert_eq!(r.count, 2);
        let bad = HdrFlipOptions {
            start: Some(3.0),
            stop: Some(1.0),
            ..HdrFlipOptions::default()
        };
        assert!(exposure_range(&img, &img, &bad).is_err());
    }
}
