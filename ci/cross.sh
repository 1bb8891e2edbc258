#!/usr/bin/env bash
# The Windows build: `cargo check` of the library and the binary for
# x86_64-pc-windows-gnu, where wgpu compiles its DX12 (and Vulkan and GL)
# backends, so that code which only builds on Linux is found here. The C
# and C++ dependencies (SQLite, FLIP) need MinGW-w64 from Debian.
# macOS (Metal) is not checked: those dependencies' build scripts need an
# Apple SDK, which no Debian package provides (docs/adapters.md).
#   CROSS_CHECK=0 skips it.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${CROSS_CHECK:-1}" = 0 ] && exit 0
need=()
command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || need+=(gcc-mingw-w64-x86-64)
command -v x86_64-w64-mingw32-g++ >/dev/null 2>&1 || need+=(g++-mingw-w64-x86-64)
if [ "${#need[@]}" -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "installing: ${need[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${need[@]}" >/dev/null
fi
rustup target list --installed | grep -qx x86_64-pc-windows-gnu \
  || rustup target add x86_64-pc-windows-gnu
# Its own target folder: a check for another target shares nothing with the
# host's build, and would otherwise evict it from an incremental cache.
cargo check --locked --target x86_64-pc-windows-gnu --lib --bins --target-dir target/cross
