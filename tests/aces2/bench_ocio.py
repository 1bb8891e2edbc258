#!/usr/bin/env python3
"""Times OpenColorIO's CPU processor on the transform tests/aces2 locks.

    .venv/bin/python tests/aces2/bench_ocio.py [--pfm DIR]

Not a test and not run by CI: a baseline for tonegate's own benchmark. A
2048x1024 float32 RGB image (packed, 3 channels) goes through
CPUProcessor.apply(PackedImageDesc) for the ACES 2.0 SDR 100 nits (Rec.709)
view on the sRGB display, 5 times per case; the median wall time is printed,
with processor creation (which builds the ACES 2 tables) timed separately.
OCIO's CPUProcessor.apply runs on the calling thread only.

--pfm DIR also writes the two images as DIR/random.pfm and DIR/ramp.pfm
(float32, little-endian, bottom row first), so that `tonegate tonemap` can
be timed on the same pixels.
"""

import os
import statistics
import sys
import time

import numpy as np
import PyOpenColorIO as ocio

sys.dont_write_bytecode = True  # no __pycache__ next to make_vectors.py
from make_vectors import CONFIG, DISPLAY, SOURCE, VIEW  # noqa: E402

WIDTH, HEIGHT, RUNS = 2048, 1024, 5


def images():
    rng = np.random.default_rng(7)
    random = np.exp2(rng.uniform(-10.0, 6.0, (HEIGHT, WIDTH, 3))).astype(np.float32)
    ramp = np.exp2(np.linspace(-12.0, 8.0, WIDTH, dtype=np.float64))
    grey = np.broadcast_to(ramp[None, :, None], (HEIGHT, WIDTH, 3)).astype(np.float32)
    return {"random log-uniform 2^-10..2^6": random, "grey ramp 2^-12..2^8": grey}


def write_pfm(path, image):
    with open(path, "wb") as f:
        f.write(f"PF\n{WIDTH} {HEIGHT}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--pfm":
        pics = images()
        for (label, image), name in zip(pics.items(), ["random", "ramp"]):
            write_pfm(os.path.join(sys.argv[2], f"{name}.pfm"), image)
            print(f"wrote {name}.pfm: {label}")
    print(f"opencolorio {ocio.__version__}, {os.cpu_count()} CPUs, "
          f"{WIDTH}x{HEIGHT} RGB float32, median of {RUNS}")
    start = time.perf_counter()
    config = ocio.Config.CreateFromBuiltinConfig(CONFIG)
    proc = config.getProcessor(ocio.DisplayViewTransform(src=SOURCE, display=DISPLAY, view=VIEW))
    print(f"config + processor: {time.perf_counter() - start:.3f} s")
    for name, flags in [("OPTIMIZATION_DEFAULT", ocio.OPTIMIZATION_DEFAULT),
                        ("OPTIMIZATION_LOSSLESS", ocio.OPTIMIZATION_LOSSLESS),
                        ("OPTIMIZATION_NONE", ocio.OPTIMIZATION_NONE)]:
        start = time.perf_counter()
        cpu = proc.getOptimizedCPUProcessor(flags)
        created = time.perf_counter() - start
        for label, image in images().items():
            times = []
            for _ in range(RUNS):
                work = image.copy()
                desc = ocio.PackedImageDesc(work, WIDTH, HEIGHT, 3)
                start = time.perf_counter()
                cpu.apply(desc)
                times.append(time.perf_counter() - start)
            median = statistics.median(times)
            print(f"{name:22s} {label:30s} median {median * 1e3:8.1f} ms "
                  f"({WIDTH * HEIGHT / median / 1e6:5.2f} Mpixel/s; "
                  f"min {min(times) * 1e3:.1f}, max {max(times) * 1e3:.1f}; "
                  f"CPU processor {created * 1e3:.1f} ms)")


if __name__ == "__main__":
    main()
