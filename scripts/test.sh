#!/usr/bin/env bash
# Runs every test: the Rust core (cargo test, including the GPU path against
# the f64 integrator) and the Python suite (API, closed forms, and the
# moderngl reference cross-validation). Runs scripts/setup.sh first, which
# installs what is missing and rebuilds pyvr if its sources changed.
set -euo pipefail
cd "$(dirname "$0")/.."
# Mesa's Vulkan loader probes for a display and complains without this.
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
bash scripts/setup.sh
export PYVR_BACKEND=${PYVR_BACKEND:-vulkan}
echo "== cargo test"
cargo test --quiet
echo "== pytest"
.venv/bin/python -m pytest tests -q
# On a machine whose only adapter is a CPU the native march renders the
# frames it covers: the suite runs again with every frame on the shader,
# which is what a GPU runs.
if .venv/bin/python -c "import sys; from pyvr.renderer import device_limits; sys.exit(not device_limits()['native_march'])"; then
    echo "== pytest, every frame on the shader (PYVR_NATIVE_MARCH=0)"
    PYVR_NATIVE_MARCH=0 .venv/bin/python -m pytest tests -q
    # A machine with no Vulkan driver at all: the native engine alone
    # renders every frame (tests of the shader engine skip, saying why).
    echo "== pytest, no GPU adapter (VK_ICD_FILENAMES points at nothing)"
    VK_ICD_FILENAMES=/nonexistent .venv/bin/python -m pytest tests -q
fi
# The native march's portable path (CPUs without AVX2, ARM) against the
# shader and the single texture, as the AVX2 path is held above.
echo "== pytest, the native march's portable path (PYVR_NATIVE_LANES=portable)"
PYVR_NATIVE_LANES=portable .venv/bin/python -m pytest tests/test_native_march.py tests/test_bricks.py -q
# Style: rustfmt, clippy (warnings as errors) and ruff.
bash scripts/lint.sh
