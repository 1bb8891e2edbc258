#!/usr/bin/env bash
# The main job on the built-in default: the CI gate on the built-in suite (no
# downloads, no input files). Every frame is rendered on the GPU (lavapipe),
# compared with its golden and the checks evaluated; JUnit and JSON go to
# out/check/, the run into .tonegate/history.sqlite. Exit 0 pass, 1 fail, 2 error.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/deps.sh
cargo build --release --locked
mkdir -p out/check
exec target/release/tonegate check --junit out/check/junit.xml --json out/check/report.json "$@"
