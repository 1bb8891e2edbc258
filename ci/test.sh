#!/usr/bin/env bash
# Installs what the tests need on a fresh Debian machine, then runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
source ci/deps.sh
cargo fmt --all -- --check
cargo test --locked --all-targets "$@"
cargo test --locked --doc
