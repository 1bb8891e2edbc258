#!/usr/bin/env bash
# Installs what the tests need on a fresh Debian machine, then runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/deps.sh
cargo fmt --all -- --check
# The scikit-image lock: regenerate the metric vectors with the pinned versions
# in a venv (.venv) and require the committed file to be exactly what they give.
committed=$(mktemp)
cp tests/skimage/vectors.json "$committed"
if ! tests/skimage/make_vectors.sh >/dev/null || ! cmp -s "$committed" tests/skimage/vectors.json; then
  cp "$committed" tests/skimage/vectors.json
  echo "tests/skimage/vectors.json is not what the pinned scikit-image produces (or it could not run)" >&2
  exit 1
fi
rm -f "$committed"
cargo test --locked --all-targets "$@"
cargo test --locked --doc
