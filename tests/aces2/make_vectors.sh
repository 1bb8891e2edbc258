#!/usr/bin/env sh
# Regenerates tests/aces2/vectors.json with the pinned OpenColorIO (PyPI
# opencolorio) and numpy, in the repository's .venv (git-ignored).
set -eu
cd "$(dirname "$0")/../.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/aces2/requirements.txt
.venv/bin/python tests/aces2/make_vectors.py
