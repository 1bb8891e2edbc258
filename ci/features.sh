#!/usr/bin/env bash
# Every feature set a user can ask for keeps building, without a warning:
# `cargo check` of the library with no feature (the CPU reference, the
# metrics, the file formats and the request parsers: what the fuzz crate
# builds) and with each feature alone (with what it implies). All of them
# together is the default, which the tests build. ARCHITECTURE.md says what
# each feature adds. FEATURES_CHECK=0 skips it.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${FEATURES_CHECK:-1}" = 0 ] && exit 0
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
for features in "" gpu history postgres s3 server; do
  start=$SECONDS
  if cargo check --locked --quiet --lib --no-default-features --features "$features" >"$log" 2>&1 \
      && ! grep -q '^warning' "$log"; then
    echo "features [${features:-none}]: ok ($((SECONDS - start)) s)"
  else
    cat "$log" >&2
    echo "features [${features:-none}]: FAILED" >&2
    status=1
  fi
done
# The library without features stays the small tree the fuzz crate and a
# reference-and-metrics user build: none of the renderer's, the store's or
# the server's crates.
tree=$(cargo tree --locked --no-default-features -e normal --prefix none)
heavy=$(grep -oE '^(wgpu|naga|rusqlite|postgres|tokio|axum|hyper|object_store|reqwest|utoipa|clap) ' <<<"$tree" \
  | sort -u || true)
if [ -n "$heavy" ]; then
  echo "features [none] depends on: $(echo $heavy)" >&2
  status=1
fi
exit $status
