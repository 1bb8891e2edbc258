#!/usr/bin/env bash
# FLIP on a Full HD pair: tonegate (criterion, benches/perceptual.rs) and
# NVIDIA's flip-evaluator on the same pair, in one run. Needs the .venv that
# tests/perceptual/make_vectors.sh makes (flip-evaluator pinned there).
set -euo pipefail
cd "$(dirname "$0")/.."
pair=$(mktemp -d)
trap 'rm -rf "$pair"' EXIT
TONEGATE_FLIP_PAIR="$pair" cargo bench --bench perceptual -- --noplot 1920x1080 2>&1 \
  | grep -E "^1920x1080/|time:"
.venv/bin/python - "$pair" <<'PY'
import sys, time
import numpy as np
import flip_evaluator
d = sys.argv[1]
load = lambda n: np.fromfile(f"{d}/{n}.rgb", np.uint8).reshape(1080, 1920, 3).astype(np.float32) / 255
t, r = load("test"), load("reference")
flip_evaluator.evaluate(r, t, "LDR", applyMagma=False)  # warm-up
times = []
for _ in range(10):
    s = time.perf_counter()
    _, mean, _ = flip_evaluator.evaluate(r, t, "LDR", applyMagma=False)
    times.append(time.perf_counter() - s)
print(f"flip-evaluator 1920x1080: median {1e3 * float(np.median(times)):.1f} ms over 10 (mean FLIP {mean:.6f})")
PY
