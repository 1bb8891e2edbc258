#!/usr/bin/env bash
# The metric and operator locks: each tests/<lock>/vectors.json is what a
# pinned reference tool computes, and the tests hold tonegate to it. This
# regenerates a lock's vectors with its pinned versions (in .venv, or
# node_modules, or a C harness) and requires the committed file to be what
# they give: the same keys, sizes and integers, floats to the CPU-dependent
# last bits that ci/same_vectors.py allows (and says why).
#   tests/skimage     MSE, PSNR, SNR, SSIM, mean |diff| against numpy and scikit-image
#   tests/perceptual  FLIP, HDR-FLIP (flip-evaluator), PU21, delta E ITP (colour-science)
#   tests/operators   Hable (colour-hdri), ACES Narkowicz (his formula), three.js's
#                     ACES fitted, AgX and PBR Neutral, AgX punchy (glsl-tone-map),
#                     Khronos PBR Neutral (its reference GLSL)
#   tests/bt2390      BT.2390's EETF (libplacebo's pl_tone_map_sample, Debian's
#                     libplacebo-dev, through a small C harness)
#   tests/display     PQ and HLG output: light, signals, 16-bit codes (colour-science)
#   tests/aces2       ACES 2.0's SDR output transform (OpenColorIO 2.6 from PyPI)
#
# Regenerating takes minutes (pip, npm, a C build) and the vectors change
# only when a lock does, so a lock is regenerated when its inputs changed:
# tests/<lock>/inputs.sha256 is the hash of every tracked file of the lock
# (its scripts, its pinned versions, its vectors) and of the comparison,
# written when the vectors were last proven. A lock whose files hash to its
# stamp was proven with exactly these files and is not run again.
#   ci/locks.sh                 prove the locks whose inputs changed
#   LOCKS=1 ci/locks.sh         prove every lock
#   ci/locks.sh --stamp [LOCK]  prove the lock(s) and write their stamps
# A lock whose inputs changed but whose stamp was not rewritten fails, after
# it is proven, so that the next run does not prove it again unasked.
set -euo pipefail
cd "$(dirname "$0")/.."

all="skimage perceptual operators bt2390 display aces2"
stamp=no
if [ "${1:-}" = --stamp ]; then
  stamp=yes
  shift
fi
locks=${*:-$all}

# The hash of a lock's inputs: each tracked file under tests/<lock>/ but the
# stamp, and ci/same_vectors.py (which decides "the same"), by path and
# content. Files a generator leaves (node_modules) are not tracked.
inputs_hash() {
  local lock=$1 files
  if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    files=$(git ls-files "tests/$lock" | grep -v '/inputs\.sha256$')
  else
    files=$(find "tests/$lock" -type f ! -name inputs.sha256 ! -path '*/node_modules/*' | sort)
  fi
  # shellcheck disable=SC2086
  { sha256sum $files ci/same_vectors.py; } | sha256sum | cut -d' ' -f1
}

# Regenerates the lock's vectors and compares them with the committed file,
# which is put back whatever this CPU's last bits are: the tests read it.
prove() {
  local lock=$1 committed same=yes rel=()
  committed=$(mktemp)
  cp "tests/$lock/vectors.json" "$committed"
  # OpenColorIO's f32 through glibc's per-CPU libm variants: 1e-6 relative
  # (about 17 f32 ulps) for another CPU's last bits, 40 times under the
  # lock's own bound (F32_REFERENCE, tests/it/aces2.rs).
  [ "$lock" = aces2 ] && rel=(--rel 1e-6)
  "tests/$lock/make_vectors.sh" >/dev/null \
    && python3 ci/same_vectors.py "$committed" "tests/$lock/vectors.json" "${rel[@]}" || same=no
  cp "$committed" "tests/$lock/vectors.json"
  rm -f "$committed"
  [ "$same" = yes ]
}

status=0
for lock in $locks; do
  [ -f "tests/$lock/make_vectors.sh" ] || { echo "ci/locks.sh: no lock tests/$lock" >&2; exit 2; }
  hash=$(inputs_hash "$lock")
  stamped=$(cat "tests/$lock/inputs.sha256" 2>/dev/null || true)
  if [ "$stamp" = no ] && [ "${LOCKS:-0}" != 1 ] && [ "$hash" = "$stamped" ]; then
    echo "lock $lock: inputs unchanged since proven (LOCKS=1 proves it again)"
    continue
  fi
  start=$SECONDS
  if ! prove "$lock"; then
    echo "tests/$lock/vectors.json is not what the pinned tools produce (or they could not run)" >&2
    status=1
    continue
  fi
  echo "lock $lock: the pinned tools produce the committed vectors ($((SECONDS - start)) s)"
  if [ "$stamp" = yes ]; then
    echo "$hash" >"tests/$lock/inputs.sha256"
    echo "lock $lock: wrote tests/$lock/inputs.sha256"
  elif [ "$hash" != "$stamped" ]; then
    echo "tests/$lock changed since its stamp: commit the new one (ci/locks.sh --stamp $lock)" >&2
    status=1
  fi
done
exit $status
