#!/usr/bin/env bash
# Builds the documentation site into docs/_build/html with warnings as
# errors: the user guide (docs/*.md), the API reference from the installed
# wheel's docstrings, and the gallery, which runs every example in
# examples/ and shows the pictures it writes (a few minutes on 2 cores).
# Runs scripts/setup.sh first, so it works from a fresh clone.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
[ "${PYVR_SETUP_DONE:-}" = 1 ] || bash scripts/setup.sh
wheel=$(ls "$PWD"/dist/*.whl)
echo "== installing the documentation tools (the docs extra)"
.venv/bin/python -m pip install -q --disable-pip-version-check "$wheel[docs]"
rm -rf docs/_build docs/gallery
start=$(date +%s)
echo "== sphinx-build (warnings are errors; runs every example)"
PYVR_OUT="$PWD/docs/_build/example-output" .venv/bin/python -m sphinx -W --keep-going -q -b html docs docs/_build/html
echo "== docs/_build/html/index.html built in $(( $(date +%s) - start )) s"
