//! The per-frame figures checks, summaries and reports read: one row each,
//! with which end is good and how a value and a bound are shown.

use crate::metrics::Metrics;

/// A per-frame figure of a frame against its golden: one row of the table
/// checks, summaries and reports read.
pub struct FrameMetric {
    /// The name in reports and summaries (`psnr`).
    pub name: &'static str,
    /// What labels call it (`PSNR`).
    pub title: &'static str,
    /// Unit after a bound in a label (` dB`).
    pub bound_unit: &'static str,
    /// Which end of the scale is good.
    pub higher_is_better: bool,
    /// The value of one frame.
    pub read: fn(&Metrics) -> f64,
    /// A measured value as details print it (`PSNR 51.23 dB`).
    pub show: fn(f64) -> String,
    /// Whether a bound on this figure makes sense (NaN never does).
    pub valid_bound: fn(f64) -> bool,
}

fn not_nan(v: f64) -> bool {
    !v.is_nan()
}

pub const PSNR: FrameMetric = FrameMetric {
    name: "psnr",
    title: "PSNR",
    bound_unit: " dB",
    higher_is_better: true,
    read: |m| m.psnr,
    show: |v| format!("PSNR {v:.2} dB"),
    valid_bound: not_nan,
};
pub const SSIM: FrameMetric = FrameMetric {
    name: "ssim",
    title: "SSIM",
    bound_unit: "",
    higher_is_better: true,
    read: |m| m.ssim,
    show: |v| format!("SSIM {v:.5}"),
    valid_bound: |v| v.is_finite() && (-1.0..=1.0).contains(&v),
};
pub const SNR: FrameMetric = FrameMetric {
    name: "snr",
    title: "SNR",
    bound_unit: " dB",
    higher_is_better: true,
    read: |m| m.snr,
    show: |v| format!("SNR {v:.2} dB"),
    valid_bound: not_nan,
};
pub const MSE: FrameMetric = FrameMetric {
    name: "mse",
    title: "MSE",
    bound_unit: "",
    higher_is_better: false,
    read: |m| m.mse,
    show: |v| format!("MSE {v:.4}"),
    valid_bound: not_nan,
};
pub const RMSE: FrameMetric = FrameMetric {
    name: "rmse",
    title: "RMSE",
    bound_unit: "",
    higher_is_better: false,
    read: |m| m.rmse,
    show: |v| format!("RMSE {v:.4}"),
    valid_bound: not_nan,
};
pub const MAX_ABS_DIFF: FrameMetric = FrameMetric {
    name: "max_abs_diff",
    title: "max abs diff",
    bound_unit: "",
    higher_is_better: false,
    read: |m| f64::from(m.max_abs_diff),
    show: |v| format!("max abs diff {v} LSB"),
    valid_bound: |_| true,
};
pub const MEAN_ABS_DIFF: FrameMetric = FrameMetric {
    name: "mean_abs_diff",
    title: "mean abs diff",
    bound_unit: " LSB",
    higher_is_better: false,
    read: |m| m.mean_abs_diff,
    show: |v| format!("mean abs diff {v:.4} LSB"),
    valid_bound: |v| (0.0..=255.0).contains(&v),
};
pub const FRACTION_OVER_1LSB: FrameMetric = FrameMetric {
    name: "fraction_over_1lsb",
    title: "fraction over 1 LSB",
    bound_unit: "",
    higher_is_better: false,
    read: |m| m.fraction_over_1lsb,
    show: |v| format!("fraction over 1 LSB {v:.5}"),
    valid_bound: |v| (0.0..=1.0).contains(&v),
};

pub const FLIP_MEAN: FrameMetric = FrameMetric {
    name: "flip_mean",
    title: "FLIP mean",
    bound_unit: "",
    higher_is_better: false,
    read: |m| m.flip_mean,
    show: |v| format!("FLIP mean {v:.5}"),
    valid_bound: |v| (0.0..=1.0).contains(&v),
};

/// Every per-frame figure, in report order: what a sequence is summarised by
/// (best / worst / mean) and what checks read.
pub const FRAME_METRICS: [&FrameMetric; 9] = [
    &PSNR,
    &SSIM,
    &SNR,
    &MSE,
    &RMSE,
    &MAX_ABS_DIFF,
    &MEAN_ABS_DIFF,
    &FRACTION_OVER_1LSB,
    &FLIP_MEAN,
];
