#!/usr/bin/env python3
"""Generates the DWAA/DWAB fixtures for tests/io_exr.rs.

Why a script: the `exr` crate cannot be trusted to write DWA files that test its
own DWA reader (and its docs say it cannot write them), so these come from the
reference implementation, OpenEXR's C++ library through its Python binding.

Generated once, committed; rerun only to change the fixtures:

    python3 -m venv /tmp/dwa-venv
    /tmp/dwa-venv/bin/pip install OpenEXR==3.5.3 numpy==2.4.6
    /tmp/dwa-venv/bin/python tests/data/make_dwa.py

Outputs (all 40x36, HALF R, G, B; 36 rows = one full DWAA block of 32 lines plus
a partial one; 40 columns = 5 DCT blocks of 8):
  dwaa_rgb_half.exr, dwab_rgb_half.exr           - the lossy files under test
  dwa_openexr_decoded.exr
      - what OpenEXR itself decodes from them, stored ZIP-compressed (lossless),
        so the Rust test can compare its decoder with the reference decoder and
        not only with the lossy source. DWA codes each 8x8 block on its own, so
        DWAA (32-line chunks) and DWAB (256-line chunks) decode to the same
        pixels; the script checks that and stores one file.
  zstd_rgb_half.exr - 8x8, ZSTD (OpenEXR 3.4+): a compression the exr crate
        cannot read, for the "unsupported compression is an error" test

The source function must match `dwa_source` in tests/io_exr.rs.
"""

import math
import os

import numpy as np
import OpenEXR

WIDTH, HEIGHT = 40, 36
HERE = os.path.dirname(os.path.abspath(__file__))


def source(x, y):
    """Smooth HDR content: R spans 2^-4..2^3.8, G a ramp, B a gentle wave."""
    r = 2.0 ** ((x - 20) / 5.0)
    g = 0.25 + 0.75 * (y / (HEIGHT - 1))
    b = 0.5 + 0.4 * math.sin(x * 0.3) * math.cos(y * 0.2)
    return r, g, b


def planes(width, height):
    out = np.zeros((3, height, width), dtype=np.float64)
    for y in range(height):
        for x in range(width):
            out[:, y, x] = source(x, y)
    return {name: out[i].astype(np.float16) for i, name in enumerate("RGB")}


def write(path, compression, channels):
    header = {"compression": compression, "type": OpenEXR.scanlineimage}
    # OpenEXR.File replaces the dict's arrays with Channel objects: pass a copy.
    with OpenEXR.File(header, dict(channels)) as f:
        f.write(path)


def decoded(path):
    with OpenEXR.File(path, separate_channels=True) as f:
        return {name: f.channels()[name].pixels.copy() for name in "RGB"}


def main():
    channels = planes(WIDTH, HEIGHT)
    references = []
    for name, compression in (
        ("dwaa", OpenEXR.DWAA_COMPRESSION),
        ("dwab", OpenEXR.DWAB_COMPRESSION),
    ):
        lossy = os.path.join(HERE, f"{name}_rgb_half.exr")
        write(lossy, compression, channels)
        reference = decoded(lossy)
        references.append(reference)
        err = max(
            float(np.max(np.abs(reference[c].astype(np.float64) - channels[c].astype(np.float64))
                         / np.abs(channels[c].astype(np.float64))))
            for c in "RGB"
        )
        print(f"{name}: {os.path.getsize(lossy)} bytes, max relative error vs source {err:.3e}")

    for c in "RGB":
        assert np.array_equal(references[0][c], references[1][c]), "DWAA and DWAB decode differently"
    write(os.path.join(HERE, "dwa_openexr_decoded.exr"), OpenEXR.ZIP_COMPRESSION, references[0])

    write(os.path.join(HERE, "zstd_rgb_half.exr"), OpenEXR.ZSTD_COMPRESSION, planes(8, 8))


if __name__ == "__main__":
    main()
