#!/usr/bin/env python3
"""Reference values for tonegate's metrics, from numpy and scikit-image.

Writes tests/skimage/vectors.json, which tests/metrics_skimage.rs checks the
Rust implementation against. Run it through make_vectors.sh, which pins the
versions (requirements.txt); the output is committed, and CI regenerates it
when the lock's inputs change (ci/locks.sh) and requires the committed one (ci/same_vectors.py says to what tolerance).

Every image pair is generated from a seeded numpy RNG or a formula, so the
file is reproducible. Images are stored inline as flat row-major, interleaved
u8 lists (the layout of tonegate's Raster).

Definitions (docs/metrics.md), all in float64:
  mse   = mean((test - ref)^2)               over all pixels and channels
  rmse  = sqrt(mse)
  mean_abs_diff = mean(|test - ref|)         over all pixels and channels
  psnr  = 10 log10(255^2 / mse)              +inf when mse == 0
  snr   = 10 log10(sum(ref^2) / sum((test - ref)^2))
          +inf when the images are identical, -inf when ref is all zero
          and they are not
  ssim  = skimage.metrics.structural_similarity(test, ref,
            gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
            data_range=255, channel_axis=-1)
  ssim_map (small cases only) = the `full=True` map averaged over channels
Non-finite values are written as the strings "inf" / "-inf" (Python's json
module would otherwise write the non-JSON token Infinity).
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
import scipy
import skimage
from scipy import ndimage
from skimage.metrics import (
    mean_squared_error,
    peak_signal_noise_ratio,
    structural_similarity,
)

OUT = Path(__file__).with_name("vectors.json")
# Cases whose full SSIM map is stored too (it locks the border handling,
# which the cropped mean never sees). Larger maps would bloat the file.
MAP_LIMIT_PIXELS = 1600

SSIM_ARGS = dict(
    gaussian_weights=True,
    sigma=1.5,
    use_sample_covariance=False,
    data_range=255,
    channel_axis=-1,
)


def as_u8(values):
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


def finite_or_str(x):
    x = float(x)
    if math.isnan(x):
        raise ValueError("NaN in a reference value")
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


def reference_metrics(test, ref):
    t = test.astype(np.float64)
    r = ref.astype(np.float64)
    diff = t - r
    sq_err = float(np.sum(diff * diff))
    energy = float(np.sum(r * r))
    mse = float(np.mean(diff * diff))
    if mse == 0.0:
        psnr = math.inf
    else:
        psnr = 10.0 * math.log10(255.0**2 / mse)
        # Cross-check the formula with scikit-image's own implementation.
        sk = peak_signal_noise_ratio(ref, test, data_range=255)
        assert abs(sk - psnr) < 1e-12, (sk, psnr)
    assert mean_squared_error(ref, test) == mse
    if sq_err == 0.0:
        snr = math.inf
    elif energy == 0.0:
        snr = -math.inf
    else:
        snr = 10.0 * math.log10(energy / sq_err)
    absdiff = np.abs(diff)
    return {
        "mse": mse,
        "rmse": math.sqrt(mse),
        "psnr": finite_or_str(psnr),
        "snr": finite_or_str(snr),
        "max_abs_diff": int(absdiff.max()),
        "mean_abs_diff": float(np.mean(absdiff)),
        "fraction_over_1lsb": float(np.mean(np.any(absdiff > 1, axis=-1))),
    }


def case(name, test, ref, note):
    assert test.shape == ref.shape and test.dtype == ref.dtype == np.uint8
    if test.ndim == 2:
        test = test[..., None]
        ref = ref[..., None]
    height, width, channels = test.shape
    entry = {
        "name": name,
        "note": note,
        "width": width,
        "height": height,
        "channels": channels,
        "test": test.ravel().tolist(),
        "reference": ref.ravel().tolist(),
    }
    entry.update(reference_metrics(test, ref))
    try:
        mssim, smap = structural_similarity(test, ref, full=True, **SSIM_ARGS)
        entry["ssim"] = float(mssim)
        if width * height <= MAP_LIMIT_PIXELS:
            entry["ssim_map"] = smap.mean(axis=-1).ravel().tolist()
    except ValueError as err:
        # scikit-image refuses images smaller than the 11x11 window; tonegate
        # must refuse them too (with an error, not a panic).
        entry["ssim"] = None
        entry["ssim_error"] = str(err)
    return entry


def smooth(height, width, channels, phase=0.0):
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    planes = []
    for c in range(channels):
        f = 0.05 + 0.03 * c
        planes.append(
            128
            + 80 * np.sin(f * x + phase + c)
            + 40 * np.cos(0.7 * f * y - 2 * c)
            + 0.4 * (x - y)
        )
    return as_u8(np.stack(planes, axis=-1))


def main():
    rng = np.random.default_rng(20240611)
    cases = []

    ref = smooth(24, 32, 3)
    cases.append(case("noise_rgb_32x24", as_u8(ref + rng.normal(0, 8, ref.shape)), ref,
                      "smooth RGB plus Gaussian noise sigma 8, clipped"))

    ref = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    blurred = as_u8(ndimage.gaussian_filter(ref.astype(np.float64), (1.0, 1.0, 0)))
    cases.append(case("blur_rgb_40x30", blurred, ref,
                      "uniform noise image against its Gaussian blur (sigma 1)"))

    ref = smooth(29, 37, 1)[..., 0]
    cases.append(case("shift_gray_37x29", np.roll(ref, (1, 2), axis=(0, 1)), ref,
                      "grey, odd sizes, shifted 1 down and 2 right (wrapping)"))

    ref = np.full((16, 16, 3), 100, np.uint8)
    cases.append(case("constant_both_rgb_16x16", np.full((16, 16, 3), 110, np.uint8), ref,
                      "two different constant images: zero variances"))

    ref = smooth(18, 20, 3, phase=1.0)
    cases.append(case("constant_vs_pattern_rgb_20x18", np.full(ref.shape, 128, np.uint8), ref,
                      "constant test image against a pattern"))

    ref = rng.integers(0, 256, (16, 24, 3), dtype=np.uint8)
    cases.append(case("identical_rgb_24x16", ref.copy(), ref,
                      "identical: PSNR and SNR +inf, SSIM exactly 1"))

    ref = np.zeros((12, 12), np.uint8)
    cases.append(case("black_reference_gray_12x12",
                      rng.integers(0, 4, (12, 12), dtype=np.uint8), ref,
                      "all-zero reference, test not: SNR -inf"))

    ref = np.zeros((12, 14, 3), np.uint8)
    cases.append(case("both_black_rgb_14x12", ref.copy(), ref,
                      "both all zero: identical, PSNR and SNR +inf"))

    ref = rng.integers(0, 256, (11, 11, 3), dtype=np.uint8)
    cases.append(case("tiny_rgb_11x11", rng.integers(0, 256, (11, 11, 3), dtype=np.uint8), ref,
                      "smallest size SSIM accepts: one pixel survives the crop"))

    ref = smooth(11, 11, 1)[..., 0]
    cases.append(case("tiny_gray_11x11", as_u8(ref + rng.normal(0, 5, ref.shape)), ref,
                      "smallest grey image"))

    ref = rng.integers(0, 256, (7, 7, 3), dtype=np.uint8)
    cases.append(case("tiny_rgb_7x7", rng.integers(0, 256, (7, 7, 3), dtype=np.uint8), ref,
                      "below the window: SSIM refused, other metrics defined"))

    ref = rng.integers(0, 256, (7, 7), dtype=np.uint8)
    cases.append(case("tiny_gray_7x7", ref ^ 1, ref, "below the window, grey"))

    ref = smooth(12, 10, 3)
    cases.append(case("narrow_rgb_10x12", as_u8(ref + 3.0), ref,
                      "one side under 11: SSIM refused"))

    ref = smooth(13, 11, 4, phase=0.5)
    cases.append(case("rgba_11x13", as_u8(ref + rng.normal(0, 12, ref.shape)), ref,
                      "four channels, alpha included in the channel mean"))

    ref = smooth(11, 60, 1, phase=2.0)[..., 0]
    cases.append(case("wide_gray_60x11", as_u8(ref * 0.9 + 10), ref,
                      "grey, only one row survives the crop; contrast change"))

    ref = smooth(50, 12, 3, phase=3.0)
    cases.append(case("tall_rgb_12x50", as_u8(ref // 8 * 8), ref,
                      "quantised to multiples of 8"))

    y, x = np.mgrid[0:15, 0:17]
    ref = np.where((x + y) % 2 == 0, 255, 0).astype(np.uint8)
    cases.append(case("checker_gray_17x15", 255 - ref, ref,
                      "0/255 checkerboard against its inverse: extreme values"))

    ref = smooth(48, 64, 3, phase=0.3)
    cases.append(case("medium_rgb_64x48", as_u8(ref + rng.normal(0, 6, ref.shape)), ref,
                      "medium RGB, noise sigma 6"))

    ref = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    cases.append(case("medium_uniform_noise_rgb_64x48",
                      rng.integers(0, 256, (48, 64, 3), dtype=np.uint8), ref,
                      "two unrelated uniform-noise images: SSIM near 0"))

    doc = {
        "generator": "tests/skimage/make_vectors.py",
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "scikit_image": skimage.__version__,
        "ssim_call": "structural_similarity(test, reference, gaussian_weights=True, "
        "sigma=1.5, use_sample_covariance=False, data_range=255, channel_axis=-1)",
        "cases": cases,
    }
    OUT.write_text(json.dumps(doc, separators=(",", ":")) + "\n")
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes, {len(cases)} cases)")


if __name__ == "__main__":
    main()
