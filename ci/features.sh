#!/usr/bin/env bash
# Every feature set a user can ask for keeps building, without a warning:
# `cargo check` of the library with no feature (operators, scene types,
# plans) and with each feature alone (with what it implies): `reference`
# (the CPU reference, the metrics, the file formats and the request
# parsers: what the fuzz crate builds), `embed` (the ToneMapper alone), and
# the service's. All of them together is the default, which the tests
# build. ARCHITECTURE.md says what each feature adds. FEATURES_CHECK=0
# skips it.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${FEATURES_CHECK:-1}" = 0 ] && exit 0
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
for features in "" reference embed gpu history postgres s3 server; do
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
# The library without features, or with the CPU reference alone, stays
# the small tree the fuzz crate and a reference-and-metrics user build:
# none of the renderer's, the store's or the server's crates.
heavy_re='^(wgpu|naga|rusqlite|postgres|tokio|axum|hyper|object_store|reqwest|utoipa|clap) '
for features in "" reference; do
  tree=$(cargo tree --locked --no-default-features --features "$features" -e normal --prefix none)
  heavy=$(grep -oE "$heavy_re" <<<"$tree" | sort -u || true)
  if [ -n "$heavy" ]; then
    echo "features [${features:-none}] depends on: $(echo $heavy)" >&2
    status=1
  fi
done
# The lean embedding: wgpu (the application's backends) and the operators,
# nothing of the service, the files or the metrics, and at most 60 crates
# besides tonegate (README.md#embedding-in-an-application quotes the count).
tree=$(cargo tree --locked --no-default-features --features embed -e normal --prefix none \
  | sed 's/ (\*)$//' | sort -u | grep -v '^tonegate ')
count=$(wc -l <<<"$tree")
service=$(grep -oE '^(tokio|axum|hyper|rusqlite|postgres|object_store|reqwest|nv-flip|exr|image|png|rayon|toml|ash|glow) ' <<<"$tree" \
  | sort -u || true)
echo "features [embed]: $count crates besides tonegate"
if [ -n "$service" ] || [ "$count" -gt 60 ]; then
  echo "features [embed] depends on: $(echo $service) ($count crates, at most 60)" >&2
  status=1
fi
exit $status
