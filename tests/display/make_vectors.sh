#!/usr/bin/env sh
# Regenerates tests/display/vectors.json: the HDR output's light, PQ and HLG
# signals and 16-bit code values as colour-science computes them, pinned, in
# the repository's .venv (git-ignored).
set -eu
cd "$(dirname "$0")/../.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/display/requirements.txt
.venv/bin/python -W ignore tests/display/make_vectors.py
