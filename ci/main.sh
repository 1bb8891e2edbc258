#!/usr/bin/env bash
# The main job on the built-in default: render the built-in suite (no downloads,
# no input files) and compare every frame with its golden.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/deps.sh
cargo build --release --locked
exec target/release/tonegate suite "$@"
