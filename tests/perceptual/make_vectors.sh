#!/usr/bin/env sh
# Regenerates tests/perceptual/vectors.json with the pinned flip-evaluator,
# colour-science and scikit-image, in the repository's .venv (git-ignored).
set -eu
cd "$(dirname "$0")/../.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/perceptual/requirements.txt
.venv/bin/python tests/perceptual/make_vectors.py
