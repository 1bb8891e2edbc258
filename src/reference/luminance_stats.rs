//! `luminance_stats`: log-average, weighted log-average, min and max of Y.

use crate::image::LinearImage;
use crate::operators::StatsNeeds;
use crate::par::*;

pub use crate::operators::LuminanceStats;

/// Neumaier's compensated sum: the error stays O(ε) instead of O(n·ε), which is
/// what keeps 8 M log terms within 1e-12 of the exact sum.
#[derive(Clone, Copy, Debug, Default)]
pub struct CompensatedSum {
    sum: f64,
    compensation: f64,
}

impl CompensatedSum {
    pub fn add(&mut self, x: f64) {
        let t = self.sum + x;
        if self.sum.abs() >= x.abs() {
            self.compensation += (self.sum - t) + x;
        } else {
            self.compensation += (x - t) + self.sum;
        }
        self.sum = t;
    }

    pub fn merge(&mut self, other: CompensatedSum) {
        self.add(other.sum);
        self.add(other.compensation);
    }

    pub fn value(self) -> f64 {
        self.sum + self.compensation
    }
}

#[derive(Clone, Copy, Debug)]
struct Partial {
    log_sum: CompensatedSum,
    weighted_log_sum: CompensatedSum,
    weight_sum: CompensatedSum,
    min: f64,
    max: f64,
}

impl Partial {
    fn new() -> Self {
        Partial {
            log_sum: CompensatedSum::default(),
            weighted_log_sum: CompensatedSum::default(),
            weight_sum: CompensatedSum::default(),
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }
}

/// Measures `needs` over `img` with luminance `weights` and log offset `delta`.
///
/// Rows are reduced in parallel and combined in row order, so the result is
/// bit-identical whatever the thread count. The weight w = 1 − e^(−Y) is
/// computed as −expm1(−Y), which keeps its precision for tiny Y. When Σw = 0
/// (an all-black frame) the weighted mean is undefined; it falls back to the
/// plain log-average, which is then δ.
pub fn luminance_stats(
    img: &LinearImage,
    needs: StatsNeeds,
    weights: [f64; 3],
    delta: f64,
) -> LuminanceStats {
    luminance_stats_of(&img.pixels, img.width, |c| c, needs, weights, delta)
}

/// [`luminance_stats`] of `width`-wide rows of any pixel type that `to_f64`
/// widens (exactly, for f32 samples): the same sums in the same order, so
/// the same bits as the statistics of the widened image, without it.
pub fn luminance_stats_of<P: Copy + Sync>(
    pixels: &[P],
    width: u32,
    to_f64: impl Fn(P) -> [f64; 3] + Sync,
    needs: StatsNeeds,
    weights: [f64; 3],
    delta: f64,
) -> LuminanceStats {
    let width = width.max(1) as usize;
    let rows: Vec<Partial> = pixels
        .par_chunks(width)
        .map(|row| {
            let mut p = Partial::new();
            for &c in row {
                let y = crate::color::luminance_with(to_f64(c), weights);
                if needs.log_average || needs.weighted_log_average {
                    let l = libm::log(delta + y);
                    // Also kept for the weighted mean's Σw = 0 fallback.
                    p.log_sum.add(l);
                    if needs.weighted_log_average {
                        let w = -libm::expm1(-y);
                        p.weighted_log_sum.add(w * l);
                        p.weight_sum.add(w);
                    }
                }
                p.min = p.min.min(y);
                p.max = p.max.max(y);
            }
            p
        })
        .collect();
    let mut total = Partial::new();
    for r in rows {
        total.log_sum.merge(r.log_sum);
        total.weighted_log_sum.merge(r.weighted_log_sum);
        total.weight_sum.merge(r.weight_sum);
        total.min = total.min.min(r.min);
        total.max = total.max.max(r.max);
    }
    let n = pixels.len().max(1) as f64;
    let log_average = libm::exp(total.log_sum.value() / n);
    let weight_sum = total.weight_sum.value();
    let weighted = if weight_sum > 0.0 {
        libm::exp(total.weighted_log_sum.value() / weight_sum)
    } else {
        log_average
    };
    LuminanceStats {
        log_average: needs.log_average.then_some(log_average),
        weighted_log_average: needs.weighted_log_average.then_some(weighted),
        min: needs.min.then_some(total.min),
        max: needs.max.then_some(total.max),
        weight_sum: needs.weighted_log_average.then_some(weight_sum),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::BT709;

    const ALL: StatsNeeds = StatsNeeds {
        log_average: true,
        weighted_log_average: true,
        min: true,
        max: true,
    };

    #[test]
    fn matches_the_definitions_on_a_small_image() {
        let img = LinearImage::from_fn(3, 2, |x, y| {
            let v = 0.1 + x as f64 + 2.0 * y as f64;
            [v, v, v]
        });
        let s = luminance_stats(&img, ALL, BT709, 1e-4);
        let ys: Vec<f64> = img.pixels.iter().map(|p| p[0]).collect();
        let log_avg = (ys.iter().map(|y| (1e-4 + y).ln()).sum::<f64>() / 6.0).exp();
        let (sw, swl) = ys.iter().fold((0.0, 0.0), |(sw, swl), y| {
            let w = 1.0 - (-y).exp();
            (sw + w, swl + w * (1e-4 + y).ln())
        });
        assert!((s.log_average.unwrap() / log_avg - 1.0).abs() < 1e-14);
        assert!((s.weighted_log_average.unwrap() / (swl / sw).exp() - 1.0).abs() < 1e-14);
        // The weights sum to 1 only to rounding, hence the relative tolerance.
        assert!(
            (s.min.unwrap() / 0.1 - 1.0).abs() < 1e-14
                && (s.max.unwrap() / 4.1 - 1.0).abs() < 1e-14
        );
    }

    #[test]
    fn only_what_is_needed_is_reported() {
        let img = LinearImage::filled(2, 2, [1.0, 1.0, 1.0]);
        let s = luminance_stats(
            &img,
            StatsNeeds {
                max: true,
                ..Default::default()
            },
            BT709,
            1e-4,
        );
        assert!(s.log_average.is_none() && s.min.is_none() && s.weighted_log_average.is_none());
        assert!((s.max.unwrap() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn all_black_falls_back_to_the_plain_mean() {
        let img = LinearImage::filled(4, 3, [0.0, 0.0, 0.0]);
        let s = luminance_stats(&img, ALL, BT709, 1e-4);
        assert_eq!(s.weight_sum, Some(0.0));
        assert!((s.weighted_log_average.unwrap() - 1e-4).abs() < 1e-18);
    }

    #[test]
    fn thread_count_does_not_change_a_bit() {
        let img = LinearImage::from_fn(257, 131, |x, y| {
            let v = ((x * 7919 + y * 104729) % 1000) as f64 * 0.37 + 1e-3;
            [v, v * 0.5, v * 2.0]
        });
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let a = one.install(|| luminance_stats(&img, ALL, BT709, 1e-4));
        let b = four.install(|| luminance_stats(&img, ALL, BT709, 1e-4));
        assert_eq!(a, b);
    }

    #[test]
    fn compensated_sum_beats_naive_summation() {
        let mut s = CompensatedSum::default();
        s.add(1.0);
        for _ in 0..1_000_000 {
            s.add(1e-16);
        }
        assert!((s.value() - (1.0 + 1e-10)).abs() < 1e-22);
    }
}
