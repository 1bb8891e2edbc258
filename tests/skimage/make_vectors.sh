#!/usr/bin/env sh
# Regenerates tests/skimage/vectors.json with the pinned numpy/scikit-image in
# a virtual environment at the repository root (.venv, git-ignored).
set -eu
cd "$(dirname "$0")/../.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/skimage/requirements.txt
.venv/bin/python tests/skimage/make_vectors.py
