#!/usr/bin/env python3
"""Reference values for tonegate's ACES 2.0 SDR output transform.

Writes tests/aces2/vectors.json: what OpenColorIO (PyPI opencolorio, pinned in
requirements.txt) gives for the ACES 2.0 Output Transform "SDR 100 nits
(Rec.709)" on an sRGB display. Run it through make_vectors.sh; CI regenerates
the file when the lock's inputs change (ci/locks.sh) and requires it to be the committed one (ci/same_vectors.py).

The transform, from OCIO's built-in config CONFIG (ACES 2.0; the ACES 2.1
config, CONFIG_21, names the same built-in transforms, and the file records
that the two give bit-identical results):

    DisplayViewTransform(src  = "Linear Rec.709 (sRGB)",
                         display = "sRGB - Display",
                         view = "ACES 2.0 - SDR 100 nits (Rec.709)")

which OCIO expands to: linear Rec.709 -> ACES2065-1 (AP0) matrix; the ACES 2
preamble (AP0 -> AP1, clamp to [0, 1024], AP1 -> AP0); the
ACES2_OutputTransform fixed function (peak 100 cd/m2, Rec.709 limiting
primaries, D65; 1.0 out = 100 cd/m2); clamp to [0, 1]; Rec.709 -> XYZ -> Rec.709
(an identity pair); the sRGB encoding as OCIO's ExponentWithLinear(gamma 2.4,
offset 0.055, mirrored negatives) inverse. That curve's linear segment is
derived by continuity (break SRGB_BREAK_LINEAR, slope SRGB_SLOPE), not IEC
61966-2-1's rounded 0.0031308 and 12.92: they differ by up to 1e-5 near the
break.

Written for every input:
  encoded  the display code values (0..1) OCIO outputs
  linear   the display-linear Rec.709 values (1.0 = 100 cd/m2) before the sRGB
           encoding: the same processor's op chain with its last op (the sRGB
           encoding) removed, so nothing is inverted by hand

Both come from a CPU processor optimised with OPTIMIZATION_LOSSLESS, the most
exact of OCIO's choices: OPTIMIZATION_DEFAULT (VERY_GOOD) adds
FAST_LOG_EXP_POW, an SSE approximation of pow() in the sRGB encoding (up to
7e-6 off), and OPTIMIZATION_NONE applies every matrix separately in float32,
including the Rec.709 -> XYZ -> Rec.709 pair LOSSLESS composes (in double) and
drops as an identity (up to 3e-6 off after the encoding). The file records
how far those two are from the reference. OCIO evaluates in float32; the ACES
2 fixed function builds its hue, cusp, upper-hull-gamma and reach tables (363
entries each) when the processor is created.

Inputs are float32 values (the JSON float is the exact f32 value), generated
without floating-point library calls (powers of two, f32 constants, and
seeded random exponents and mantissas) so that they are the same bits on
every CPU.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
import PyOpenColorIO as ocio

OUT = Path(__file__).with_name("vectors.json")
CONFIG = "studio-config-v4.0.0_aces-v2.0_ocio-v2.5"
CONFIG_21 = "studio-config-v5.0.0_aces-v2.1_ocio-v2.6"
SOURCE = "Linear Rec.709 (sRGB)"
DISPLAY = "sRGB - Display"
VIEW = "ACES 2.0 - SDR 100 nits (Rec.709)"
REFERENCE = ocio.OPTIMIZATION_LOSSLESS
SRGB_GAMMA = 2.4
SRGB_OFFSET = 0.055
# The break and slope OCIO's ExponentWithLinear derives from gamma and offset.
SRGB_BREAK_ENCODED = SRGB_OFFSET / (SRGB_GAMMA - 1.0)
SRGB_BREAK_LINEAR = ((SRGB_BREAK_ENCODED + SRGB_OFFSET) / (1.0 + SRGB_OFFSET)) ** SRGB_GAMMA
SRGB_SLOPE = SRGB_BREAK_ENCODED / SRGB_BREAK_LINEAR


def f32(v):
    return float(np.float32(v))


def inputs():
    """(label, [r, g, b]) pairs; every value is an exact float32."""
    cases = [("black", [0.0, 0.0, 0.0])]
    for k in range(-12, 13):
        v = math.ldexp(1.0, k)
        cases.append((f"grey 2^{k}", [v, v, v]))
    grey18 = f32(0.18)
    for k in range(-3, 4):
        v = math.ldexp(grey18, k)  # exact: a power-of-two multiple of an f32
        cases.append((f"grey 0.18*2^{k}", [v, v, v]))
    hues = {"red": (1, 0, 0), "green": (0, 1, 0), "blue": (0, 0, 1),
            "cyan": (0, 1, 1), "magenta": (1, 0, 1), "yellow": (1, 1, 0)}
    for scale in [f32(0.01), grey18, 1.0, 4.0, 16.0]:
        for name, rgb in hues.items():
            cases.append((f"{name} x{scale:.9g}", [scale * c for c in rgb]))
    near = [[1.0, 0.1, 0.0], [0.1, 1.0, 0.05], [0.05, 0.1, 1.0], [1.0, 0.5, 0.0],
            [0.5, 0.0, 1.0], [0.0, 0.5, 1.0]]
    for rgb in near:
        cases.append(("near-primary", [f32(c) for c in rgb]))
    # ColorChecker 2005 dark skin and light skin (sRGB 115,82,68 and 194,150,130
    # decoded to linear, to 6 digits), and a mid skin tone, at three exposures.
    skins = [[0.171441, 0.084376, 0.057805], [0.539479, 0.304987, 0.223228],
             [0.45, 0.30, 0.22]]
    for rgb in skins:
        for k in (-2, 0, 2):
            cases.append((f"skin x2^{k}", [math.ldexp(f32(c), k) for c in rgb]))
    hdr = [[50, 0, 0], [0, 30, 5], [0, 0, 40], [20, 20, 0], [0, 100, 100], [200, 0, 200],
           [1000, 10, 0], [2000, 2000, 2000], [8, 1, 0.5], [0.5, 12, 0.125], [3, 0, 60]]
    for rgb in hdr:
        cases.append(("saturated HDR", [f32(c) for c in rgb]))
    negative = [[-0.1, 0.4, 0.2], [0.3, -0.02, 0.5], [0.5, 0.5, -0.05], [-1, -1, -1]]
    for rgb in negative:
        cases.append(("negative component", [f32(c) for c in rgb]))
    cases.append(("tiny", [f32(1e-6), f32(2e-6), f32(3e-6)]))
    cases.append(("tiny", [f32(1e-5), 0.0, f32(1e-5)]))
    # Log-uniform random colours, 2^-10 .. 2^6 per channel: a random exponent
    # and a random 23-bit mantissa, so the f32 is exact and libm-free.
    rng = np.random.default_rng(20260611)
    for _ in range(60):
        e = rng.integers(-10, 6, 3)
        m = rng.integers(0, 1 << 23, 3)
        cases.append(("random log-uniform",
                      [math.ldexp(1.0 + int(mi) / (1 << 23), int(ei)) for ei, mi in zip(e, m)]))
    for label, rgb in cases:
        assert all(f32(v) == v for v in rgb), (label, rgb)
    return cases


def number(x):
    x = float(x)
    if not math.isfinite(x):
        raise ValueError("non-finite reference value")
    return x


def processors(config):
    t = ocio.DisplayViewTransform(src=SOURCE, display=DISPLAY, view=VIEW)
    proc = config.getProcessor(t)
    ops = list(proc.createGroupTransform())
    last = ops[-1]
    assert isinstance(last, ocio.ExponentWithLinearTransform), last
    assert last.getDirection() == ocio.TRANSFORM_DIR_INVERSE, last
    assert list(last.getGamma())[:3] == [SRGB_GAMMA] * 3, last
    assert list(last.getOffset())[:3] == [SRGB_OFFSET] * 3, last
    assert last.getNegativeStyle() == ocio.NEGATIVE_MIRROR, last
    linear = ocio.GroupTransform()
    for op in ops[:-1]:
        linear.appendTransform(op)
    return proc, config.getProcessor(linear), ops


def run(proc, flags, rgb):
    out = np.array(rgb, dtype=np.float32)
    proc.getOptimizedCPUProcessor(flags).applyRGB(out)
    return out


def main():
    cases = inputs()
    rgb = np.array([c[1] for c in cases], dtype=np.float32)
    config = ocio.Config.CreateFromBuiltinConfig(CONFIG)
    proc, proc_linear, ops = processors(config)
    encoded = run(proc, REFERENCE, rgb)
    linear = run(proc_linear, REFERENCE, rgb)
    variants = {}
    for name, flags in [("OPTIMIZATION_NONE", ocio.OPTIMIZATION_NONE),
                        ("OPTIMIZATION_DEFAULT", ocio.OPTIMIZATION_DEFAULT)]:
        variants[name] = {
            "encoded_max_abs_diff": number(np.max(np.abs(
                run(proc, flags, rgb).astype(np.float64) - encoded))),
            "linear_max_abs_diff": number(np.max(np.abs(
                run(proc_linear, flags, rgb).astype(np.float64) - linear))),
        }
    proc_21, _, _ = processors(ocio.Config.CreateFromBuiltinConfig(CONFIG_21))
    same_21 = bool(np.array_equal(run(proc_21, REFERENCE, rgb), encoded))
    chain = list(proc.getOptimizedProcessor(REFERENCE).createGroupTransform())

    doc = {
        "generator": "tests/aces2/make_vectors.py",
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "opencolorio": ocio.__version__,
        "config": CONFIG,
        "config_aces21": CONFIG_21,
        "config_aces21_identical": same_21,
        "source": SOURCE,
        "display": DISPLAY,
        "view": VIEW,
        "optimization": "OPTIMIZATION_LOSSLESS",
        "variants_vs_reference": variants,
        "srgb_encoding": {
            "gamma": SRGB_GAMMA, "offset": SRGB_OFFSET,
            "break_linear": SRGB_BREAK_LINEAR, "break_encoded": SRGB_BREAK_ENCODED,
            "slope": SRGB_SLOPE,
            "note": "OCIO ExponentWithLinear inverse, mirrored: "
                    "e = sign(l) * (slope*|l| if |l| <= break_linear "
                    "else (1+offset)*|l|^(1/gamma) - offset)",
        },
        "op_chain_full": [str(op) for op in ops],
        "op_chain_reference": [str(op) for op in chain],
        "labels": [c[0] for c in cases],
        "inputs": [[float(v) for v in row] for row in rgb],
        "encoded": [[number(v) for v in row] for row in encoded],
        "linear": [[number(v) for v in row] for row in linear],
    }
    OUT.write_text(json.dumps(doc, separators=(",", ":")) + "\n")
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes, {len(cases)} colours)")


if __name__ == "__main__":
    main()
