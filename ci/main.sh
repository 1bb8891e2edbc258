#!/usr/bin/env bash
# The main job on the built-in default (no downloads, no input files): the CI
# gate on the built-in suite, then the dashboard on its result.
#   1. `tonegate check`: every suite frame rendered on the GPU (lavapipe),
#      compared with its golden, the checks evaluated; JUnit and JSON in
#      out/check/, the run recorded in .tonegate/history.sqlite.
#   2. `tonegate serve`: the API and dashboard on that history, at
#      http://127.0.0.1:8080/ (TONEGATE_BIND to change it; Ctrl-C stops it).
# With --no-serve it stops after the check and exits with its code
# (0 pass, 1 fail, 2 could not run), which is what a CI gate wants.
set -euo pipefail
cd "$(dirname "$0")/.."
serve=1
args=()
for a in "$@"; do
  if [ "$a" = "--no-serve" ]; then serve=0; else args+=("$a"); fi
done
source ci/deps.sh
cargo build --release --locked
mkdir -p out/check
code=0
target/release/tonegate check --junit out/check/junit.xml --json out/check/report.json ${args[@]+"${args[@]}"} || code=$?
if [ "$serve" = 0 ]; then
  exit "$code"
fi
echo "check exited $code; serving the dashboard on its run (Ctrl-C to stop)"
exec target/release/tonegate serve --bind "${TONEGATE_BIND:-127.0.0.1:8080}"
