#!/usr/bin/env python3
"""Reference values for tonegate's perceptual and HDR metrics.

Writes tests/perceptual/vectors.json, which tests/metrics_perceptual.rs checks
the Rust implementations against. Run it through make_vectors.sh, which pins
the versions (requirements.txt); CI regenerates the file when the
lock's inputs change (ci/locks.sh) and requires it to be the committed one (floats to the last bits numpy's per-CPU SIMD loops move:
ci/same_vectors.py).

The references, each computed independently of tonegate:
  FLIP, HDR-FLIP  NVIDIA's flip-evaluator (its C++ through nanobind)
  PU21            the paper's formula, written out below in numpy
                  (Mantiuk & Azimi 2021, banding_glare parameters of the
                  authors' pu21_encoder), PSNR against peak 256 over the RGB
                  channels, SSIM with scikit-image on the encoded luminance
                  (pfstools weights) with data_range 256
  delta E ITP     colour-science: RGB_to_RGB (BT.709 -> BT.2020),
                  RGB_to_ICtCp (PQ, absolute cd/m2), delta_E_ITP

Images are generated from seeded numpy RNGs and formulas. LDR images are
stored as u8 lists; HDR images as float32 values (the JSON float is the exact
f32 value), row-major RGB.
"""

import json
import math
import sys
from pathlib import Path

import colour
import flip_evaluator
import numpy as np
import skimage
from skimage.metrics import structural_similarity

OUT = Path(__file__).with_name("vectors.json")
PU21 = [0.353487901, 0.3734658629, 8.277049286e-05, 0.9062562627,
        0.09150303166, 0.9099517204, 596.3148142]
PEAK = 100.0


def pu21(y):
    p = PU21
    y = np.clip(y, 0.005, 10000.0)
    t = y ** p[3]
    return p[6] * (((p[0] + p[1] * t) / (1.0 + p[2] * t)) ** p[4] - p[5])


def number(x):
    x = float(x)
    if math.isnan(x):
        raise ValueError("NaN in a reference value")
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


def ldr_case(name, test, ref, note):
    assert test.shape == ref.shape and test.dtype == ref.dtype == np.uint8
    height, width, _ = test.shape
    fmap, mean, _ = flip_evaluator.evaluate(
        ref.astype(np.float32) / 255.0, test.astype(np.float32) / 255.0, "LDR",
        applyMagma=False)
    fmap = fmap.reshape(height, width).astype(np.float64)
    return {
        "name": name, "note": note, "width": width, "height": height,
        "test": test.ravel().tolist(), "reference": ref.ravel().tolist(),
        "flip_mean": float(fmap.mean()),
        "flip_median": float(np.median(fmap)),
        "flip_max": float(fmap.max()),
        "flip_map": fmap.ravel().tolist(),
    }


def ictcp(rgb709):
    rgb2020 = colour.RGB_to_RGB(rgb709.astype(np.float64) * PEAK, "ITU-R BT.709",
                                "ITU-R BT.2020")
    return colour.RGB_to_ICtCp(rgb2020)


def hdr_case(name, test, ref, note, flip=True):
    assert test.shape == ref.shape and test.dtype == ref.dtype == np.float32
    height, width, _ = test.shape
    entry = {
        "name": name, "note": note, "width": width, "height": height,
        "test": [float(v) for v in test.ravel()],
        "reference": [float(v) for v in ref.ravel()],
        "peak": PEAK,
    }
    if flip:
        fmap, _, params = flip_evaluator.evaluate(ref, test, "HDR", applyMagma=False)
        fmap = fmap.reshape(height, width).astype(np.float64)
        entry.update({
            "hdr_flip_mean": float(fmap.mean()),
            "hdr_flip_map": fmap.ravel().tolist(),
            "hdr_flip_start": float(params["startExposure"]),
            "hdr_flip_stop": float(params["stopExposure"]),
            "hdr_flip_exposures": int(params["numExposures"]),
        })
    t = test.astype(np.float64) * PEAK
    r = ref.astype(np.float64) * PEAK
    d = pu21(t) - pu21(r)
    mse = float(np.mean(d * d))
    entry["pu21_psnr"] = number(math.inf if mse == 0.0 else 10.0 * math.log10(256.0 ** 2 / mse))
    w = np.array([0.212656, 0.715158, 0.072186])
    pt, pr = pu21(t @ w), pu21(r @ w)
    entry["pu21_ssim"] = float(structural_similarity(
        pt, pr, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
        data_range=256.0))
    de = colour.difference.delta_E_ITP(ictcp(test), ictcp(ref))
    entry["delta_e_itp_mean"] = float(np.mean(de))
    entry["delta_e_itp_max"] = float(np.max(de))
    return entry


def smooth(height, width, phase=0.0):
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    planes = [128 + 80 * np.sin((0.05 + 0.03 * c) * x + phase + c)
              + 40 * np.cos(0.7 * (0.05 + 0.03 * c) * y - 2 * c) + 0.4 * (x - y)
              for c in range(3)]
    return np.clip(np.round(np.stack(planes, axis=-1)), 0, 255).astype(np.uint8)


def hdr_scene(height, width, stops, phase=0.0):
    """Linear RGB spanning `stops` stops around 1.0."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    e = stops * (x / max(width - 1, 1) - 0.5)
    planes = [np.exp2(e + 0.5 * np.sin(0.3 * y + c + phase)) * (0.6 + 0.2 * c)
              for c in range(3)]
    return np.stack(planes, axis=-1).astype(np.float32)


def main():
    rng = np.random.default_rng(20261123)
    ldr = []
    ref = smooth(24, 32)
    ldr.append(ldr_case("noise_32x24", np.clip(ref + rng.normal(0, 8, ref.shape), 0, 255)
                        .round().astype(np.uint8), ref, "smooth RGB plus noise sigma 8"))
    ref = smooth(30, 40, 1.0)
    ldr.append(ldr_case("bright_2pct_40x30", np.clip(np.round(ref * 1.02), 0, 255)
                        .astype(np.uint8), ref, "2 % brighter"))
    ref = rng.integers(0, 256, (24, 24, 3), dtype=np.uint8)
    ldr.append(ldr_case("identical_24x24", ref.copy(), ref, "identical: FLIP 0"))
    ref = np.zeros((20, 20, 3), np.uint8)
    ldr.append(ldr_case("both_black_20x20", ref.copy(), ref, "both black"))
    test = ref.copy()
    test[10, 10] = 255
    ldr.append(ldr_case("one_bright_pixel_20x20", test, ref, "one white pixel in black"))
    ref = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    ldr.append(ldr_case("unrelated_noise_64x48", rng.integers(0, 256, ref.shape, dtype=np.uint8),
                        ref, "two unrelated noise images"))

    hdr = []
    ref = hdr_scene(24, 32, 12)
    hdr.append(hdr_case("noise_32x24", (ref * np.exp(rng.normal(0, 0.05, ref.shape)))
                        .astype(np.float32), ref, "12 stops, 5 % multiplicative noise"))
    ref = hdr_scene(30, 40, 8, 1.0)
    hdr.append(hdr_case("bright_2pct_40x30", (ref * 1.02).astype(np.float32), ref,
                        "2 % brighter"))
    hdr.append(hdr_case("identical_24x24", ref[:24, :24].copy(), ref[:24, :24].copy(),
                        "identical"))
    black = np.zeros((20, 20, 3), np.float32)
    # flip-evaluator cannot take an all-black reference (its exposure range is
    # infinite and its tool exits); tonegate's defined answer is tested in Rust.
    hdr.append(hdr_case("both_black_20x20", black.copy(), black, "both black", flip=False))
    test = black.copy()
    test[10, 10] = [50.0, 40.0, 30.0]
    hdr.append(hdr_case("one_bright_pixel_20x20", test, black,
                        "one bright pixel in black (reference black: no FLIP)", flip=False))
    test = black + np.float32(0.01)
    test[10, 10] = [50.0, 40.0, 30.0]
    hdr.append(hdr_case("one_bright_pixel_in_dim_20x20", test, black + np.float32(0.01),
                        "one bright pixel on a dim background"))
    ref = hdr_scene(32, 32, 20, 2.0)
    hdr.append(hdr_case("hue_shift_32x32", (ref * np.array([1.05, 1.0, 0.95])).astype(np.float32),
                        ref, "20 stops, red up 5 % and blue down 5 %"))

    pu_points = [0.0, 0.001, 0.005, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0, 5000.0, 8196.0,
                 10000.0, 20000.0]
    doc = {
        "generator": "tests/perceptual/make_vectors.py",
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scikit_image": skimage.__version__,
        "flip_evaluator": "1.7",
        "colour_science": colour.__version__,
        "pu21_points": [[y, float(pu21(np.float64(y)))] for y in pu_points],
        "ldr": ldr,
        "hdr": hdr,
    }
    OUT.write_text(json.dumps(doc, separators=(",", ":")) + "\n")
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes, {len(ldr)} LDR and {len(hdr)} HDR cases)")


if __name__ == "__main__":
    main()
