#!/usr/bin/env bash
# Runs every test: the Rust core (cargo test, including the GPU path against
# the f64 integrator) and the Python suite (API, closed forms, and the
# moderngl reference cross-validation). Needs scripts/setup.sh to have run.
set -euo pipefail
cd "$(dirname "$0")/.."
export PYVR_BACKEND=${PYVR_BACKEND:-vulkan}
echo "== cargo test"
cargo test --quiet
echo "== pytest"
.venv/bin/python -m pytest tests -q
