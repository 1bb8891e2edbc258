#!/usr/bin/env sh
# Regenerates tests/operators/vectors.json: colour-hdri and colour-science,
# pinned, in the repository's .venv (git-ignored), and three.js and
# glsl-tone-map, pinned by package-lock.json, in tests/operators/node_modules
# (git-ignored), run by node.
set -eu
cd "$(dirname "$0")/../.."
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/operators/requirements.txt
# npm ci installs exactly what package-lock.json names (integrity-checked),
# from npm's cache when it has them.
(cd tests/operators && npm ci --silent --prefer-offline --no-audit --no-fund)
.venv/bin/python tests/operators/make_vectors.py
