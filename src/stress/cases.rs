//! The deterministic generator of the stiff and extreme inputs of
//! docs/stress.md. Each case says what it is and what the pipeline must do
//! with it.

use crate::image::HdrImage;

/// How the case reaches the renderers.
#[derive(Clone, Debug)]
pub enum Source {
    /// Straight to both renderers.
    Image(HdrImage),
    /// Written to a PFM file (which keeps NaN, ±Inf and negatives as they
    /// are) and read back through the loader's policy, as a user's file is.
    File { image: HdrImage, sanitize: bool },
    /// One pixel wider than the GPU adapter's texture limit (the width is
    /// found when the adapter is known).
    BeyondTextureLimit { height: u32 },
}

/// One stress case.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: &'static str,
    pub source: Source,
    /// Use rgba16float intermediates on the GPU (the f16 cases).
    pub f16: bool,
    /// The defined behaviour, as the report states it.
    pub behaviour: &'static str,
    /// Why this case may exceed the 1e-5 statistics bound, and the bound
    /// that holds instead.
    pub exception: Option<(&'static str, f64)>,
    /// The renderers that must refuse this input ("cpu", "gpu").
    pub refused_by: &'static [&'static str],
    /// Only through the pipelines whose plans measure statistics
    /// ([`measures_statistics`](super::measures_statistics)): the case is
    /// about their accumulation, and a pipeline that measures nothing would
    /// run stages the other cases already run, at this size's cost.
    pub statistics_only: bool,
}

/// Every case. `large` adds the ≥ 8 Mpx frame (about a second per renderer).
pub fn all(large: bool) -> Vec<Case> {
    let mut cases = vec![
        Case {
            name: "all_black",
            source: Source::Image(HdrImage::filled(64, 48, [0.0; 3])),
            f16: false,
            behaviour: "log-average = delta (1e-4): ln(delta + 0); min = max = 0; the automatic key's span is 0, so it falls back to 0.18; reinhard-auto-key's weights are all 0 (Σw = 0), so the weighted mean falls back to the plain log-average; the frame is black",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "uniform",
            source: Source::Image(HdrImage::filled(64, 48, [0.5, 0.5, 0.5])),
            f16: false,
            behaviour: "Lmax = Lmin, so A + B = 0 in the automatic key: it falls back to 0.18; every pixel maps to the same grey",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "single_bright_pixel",
            source: Source::Image({
                let mut img = HdrImage::filled(63, 47, [0.0; 3]);
                img.pixels[23 * 63 + 31] = [1.0e4, 1.0e4, 1.0e4];
                img
            }),
            f16: false,
            behaviour: "one 1e4 pixel in black: max = 1e4, log-average barely above delta; the pixel burns white, the rest stays black; bloom spreads the one pixel",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "span_1e-30_to_1e30",
            source: Source::Image(HdrImage::ramp(257, 33, 1.0e-30, 1.0e30)),
            f16: false,
            behaviour: "60 decades in one frame: statistics in f32 stay finite (ln of 1e30 is 69); the GPU never squares the white point (it divides L by it twice), so the burn term underflows to 0 where the f64 L/white² rounds to 0 in f32 as well",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "beyond_f16_with_f16",
            source: Source::Image(HdrImage::ramp(97, 31, 1.0e-2, 2.0e5)),
            f16: true,
            behaviour: "values up to 2e5 with rgba16float intermediates requested: f16 would store +Inf, so the GPU renderer promotes the intermediates to rgba32float and reports it",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "subnormals",
            source: Source::Image(HdrImage::from_fn(64, 32, |x, y| {
                let v = 1.0e-40f32 * (1 + x + 64 * y) as f32;
                [v, v, v]
            })),
            f16: false,
            behaviour: "f32 subnormal inputs (1e-40 ... 2e-37): ln(delta + Y) is ln(delta) to rounding, so the averages are unaffected; a pixel whose Y is under f32's smallest normal is toned to 0 by both renderers (color::SMALLEST_NORMAL), the branch an adapter that flushes subnormals takes too, so no division meets a flushed 0",
            exception: Some(("GPUs may flush subnormals to zero (Vulkan allows it): min and max then read 0 instead of ~1e-40; the relative error is taken against f32's smallest normal, 1.2e-38, so it stays under 2e-2 and has no effect on any output", 2e-2)),
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "negative_values",
            source: Source::File {
                image: HdrImage::from_fn(64, 32, |x, y| {
                    // Ringing of ±0.02 next to dark pixels dips below zero.
                    let v = 0.004 * x as f32;
                    let ring = if (x + y) % 7 == 0 { -0.02 } else { 0.0 };
                    [v + ring, v, v - 0.5 * ring]
                }),
                sanitize: false,
            },
            f16: false,
            behaviour: "negative components (lossy-EXR ringing) are clamped to 0 by the loader and counted; the pipeline never sees them",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "nan_inf_refused",
            source: Source::File {
                image: nan_inf(),
                sanitize: false,
            },
            f16: false,
            behaviour: "NaN and ±Inf are refused by the loader with their count and first coordinate; nothing is rendered",
            exception: None,
            refused_by: &["cpu", "gpu"],
            statistics_only: false,
        },
        Case {
            name: "nan_inf_sanitized",
            source: Source::File {
                image: nan_inf(),
                sanitize: true,
            },
            f16: false,
            behaviour: "with --sanitize, NaN and ±Inf become 0 and are counted; the rest renders normally",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "weights_sum_zero",
            // `reinhard-auto-key`'s weight w = 1 - exp(-Y) (the weighted
            // log-average of the modified Reinhard for training simulators,
            // docs/bibliography.md) is positive for every positive Y (even
            // subnormal, in f64), so Σw = 0 means a frame of zeros.
            source: Source::Image(HdrImage::filled(37, 23, [0.0; 3])),
            f16: false,
            behaviour: "Σw = 0 in reinhard-auto-key's weighted mean (every Y = 0): the documented fallback is the plain log-average, here delta",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "size_1x1",
            source: Source::Image(HdrImage::filled(1, 1, [2.0, 1.0, 0.5])),
            f16: false,
            behaviour: "a single pixel: every reduction and the bloom's downsample handle it (downsampled size rounds up to 1)",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "size_1xN",
            source: Source::Image(HdrImage::ramp(1, 257, 0.01, 100.0)),
            f16: false,
            behaviour: "one column of 257: no row or column dropped by either reduction",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "size_Nx1",
            source: Source::Image(HdrImage::ramp(257, 1, 0.01, 100.0)),
            f16: false,
            behaviour: "one row of 257: no row or column dropped by either reduction",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "size_prime_127x131",
            source: Source::Image(HdrImage::ramp(127, 131, 0.001, 1000.0)),
            f16: false,
            behaviour: "odd, prime sides: partial blocks and odd ping-pong levels are summed, not dropped",
            exception: None,
            refused_by: &[],
            statistics_only: false,
        },
        Case {
            name: "beyond_texture_limit",
            source: Source::BeyondTextureLimit { height: 2 },
            f16: false,
            behaviour: "wider than the adapter's max_texture_dimension_2d: the GPU renderer refuses it with the limit in the message; the CPU reference renders it",
            exception: None,
            refused_by: &["gpu"],
            statistics_only: false,
        },
    ];
    if large {
        cases.push(Case {
            name: "large_4096x2048",
            source: Source::Image(HdrImage::ramp(4096, 2048, 0.001, 5000.0)),
            f16: false,
            behaviour: "8.4 Mpx: f32 accumulation of 8.4 M log terms, kept within 1e-5 by compensated partial sums; through the pipelines that measure statistics",
            exception: None,
            refused_by: &[],
            statistics_only: true,
        });
    }
    cases
}

fn nan_inf() -> HdrImage {
    let mut img = HdrImage::ramp(48, 32, 0.01, 50.0);
    img.pixels[5 * 48 + 7] = [f32::NAN, 1.0, 1.0];
    img.pixels[9 * 48 + 20] = [f32::INFINITY, 0.0, 0.0];
    img.pixels[30 * 48 + 47] = [0.5, f32::NEG_INFINITY, 0.5];
    img
}
