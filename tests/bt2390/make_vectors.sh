#!/usr/bin/env sh
# Regenerates tests/bt2390/vectors.json: the BT.2390 EETF as libplacebo's
# pl_tone_map_sample computes it (harness.c says what is sampled and how).
# Needs the Debian packages libplacebo-dev (4.208 on Debian 12), pkg-config and
# a C compiler (gcc). The harness is built in a temporary directory, never in
# the tree. -ffp-contract=off keeps the harness's own double arithmetic (the
# inputs) free of fused multiply-adds on any target; libplacebo's arithmetic is
# whatever Debian's build of it does.
set -eu
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
version=$(pkg-config --modversion libplacebo)
# The pinned version: Debian 12's. Another one may compute otherwise.
if [ "$version" != 4.208.0 ]; then
    echo "tests/bt2390: libplacebo $version, not the pinned 4.208.0 (Debian 12's libplacebo-dev)" >&2
    exit 1
fi
# shellcheck disable=SC2046
${CC:-cc} -std=c11 -O2 -ffp-contract=off -Wall -Wextra -o "$tmp/harness" \
    tests/bt2390/harness.c $(pkg-config --cflags --libs libplacebo) -lm
"$tmp/harness" "$version" >"$tmp/vectors.json"
python3 -c 'import json, sys; json.load(open(sys.argv[1]))' "$tmp/vectors.json"
mv "$tmp/vectors.json" tests/bt2390/vectors.json
echo "wrote tests/bt2390/vectors.json ($(wc -c <tests/bt2390/vectors.json) bytes, libplacebo $version)"
