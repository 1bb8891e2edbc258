#!/usr/bin/env bash
# Runs every fuzz target (fuzz/fuzz_targets) for SECONDS each (default 600)
# and fails on any crash, hang (10 s on one input), or allocation over
# 512 MiB (the largest legitimate one is the pixel buffer of an image at the
# server's 8 Mi pixel limit, 96 MiB, plus the decoder's working set).
#   ci/fuzz.sh [SECONDS] [TARGET ...]
#   FUZZ_RUNS=N ci/fuzz.sh [TARGET ...]
# With FUZZ_RUNS (CI's smoke run, .ci/run), each target runs N inputs
# grown from the committed seeds alone with a fixed seed (FUZZ_SEED, default
# 1), so its reach does not depend on the machine's speed or on inputs left
# by earlier runs. It is not bit-reproducible: hash-map order in the code
# under test moves coverage a little between runs (cov differed by up to 8 %
# in two runs here). Whatever it finds is left in fuzz/artifacts/T/.
# Needs the nightly toolchain; installs cargo-fuzz when missing. Inputs the
# fuzzer finds go to fuzz/target/corpus (not committed); the seeds in
# fuzz/corpus are read only. A crash leaves its input in fuzz/artifacts/T/:
# commit it under fuzz/regressions/T/ with the fix, and `cargo test`
# (tests/fuzz_regressions.rs) replays it from then on.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -n "${FUZZ_RUNS:-}" ]; then
  budget="-runs=$FUZZ_RUNS -seed=${FUZZ_SEED:-1}"
  column=runs
  spent=$FUZZ_RUNS
else
  seconds=${1:-600}
  shift || true
  budget="-max_total_time=$seconds"
  column=seconds
  spent=$seconds
fi
all="exr exr_structured radiance pfm png scene_toml suite_toml tonemap_params multipart runs_json"
targets=${*:-$all}

if ! cargo +nightly --version >/dev/null 2>&1; then
  echo "fuzz: the nightly toolchain is missing (rustup toolchain install nightly)" >&2
  exit 2
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
  cargo install cargo-fuzz --locked --version 0.13.2
fi

dict_of() {
  case $1 in
    exr|exr_structured) echo exr ;;
    scene_toml|suite_toml) echo toml ;;
    runs_json) echo json ;;
    tonemap_params) echo tonemap ;;
    *) echo "$1" ;;
  esac
}

# -O: optimised like the product's release build, overflow checks off as
# there (the exr crate's B44 decoder relies on wrapping arithmetic, as the
# C++ it ports does: fuzz/regressions/exr/b44-unpack14-subtract-overflow.exr
# panics in exr 1.74.2's `unpack14` with them on). FUZZ_BUILD_FLAGS adds flags,
# e.g. -a for debug assertions and overflow checks in our own code too.
build_flags="-O ${FUZZ_BUILD_FLAGS:-}"
cargo +nightly fuzz build $build_flags
mkdir -p fuzz/target/logs
status=0
printf '%-16s %10s %8s %8s %8s  %s\n' target $column execs cov ft result
for t in $targets; do
  if [ -n "${FUZZ_RUNS:-}" ]; then
    found=$(mktemp -d)
  else
    found="fuzz/target/corpus/$t"
    mkdir -p "$found"
  fi
  log="fuzz/target/logs/$t.log"
  if cargo +nightly fuzz run $build_flags "$t" "$found" "fuzz/corpus/$t" -- \
      $budget -timeout=10 -malloc_limit_mb=512 -rss_limit_mb=2048 \
      -dict="fuzz/dict/$(dict_of "$t").dict" -print_final_stats=1 >"$log" 2>&1; then
    result=ok
  else
    result="CRASH (see $log and fuzz/artifacts/$t/)"
    status=1
  fi
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
  if [ -n "${FUZZ_RUNS:-}" ]; then
    rm -rf "$found"
  fi
  printf '%-16s %10s %8s %8s %8s  %s\n' "$t" "$spent" "${execs:-?}" "${cov:-?}" "${ft:-?}" "$result"
done
exit $status
