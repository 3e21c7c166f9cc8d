#!/usr/bin/env bash
# Runs every test: the Rust core (cargo test, including the GPU path against
# the f64 integrator), then the Python suite (API, closed forms, the moderngl
# reference) against the wheel installed in .venv, as users install it:
# once with this machine's Vulkan driver, every frame on the shader engine,
# and once with no Vulkan driver visible, where the native CPU engine
# renders every frame. Then the native march's portable path, lint, and
# the documentation site.
# Runs scripts/setup.sh first, which installs what is missing and rebuilds
# the wheel if its sources changed.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/progress.sh
# Mesa's Vulkan loader probes for a display and complains without this.
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
# What each stage cost, printed at the end.
costs=()
last=$SECONDS
cost() {
    costs+=("$1 $((SECONDS - last)) s")
    last=$SECONDS
}
bash scripts/setup.sh
cost "setup (packages, wheel, .venv):"
export PYVR_BACKEND=${PYVR_BACKEND:-vulkan}
quietly "cargo test: compiling the tests" cargo test --locked --no-run
echo "== cargo test"
cargo test --locked --quiet
cost "cargo test:"
# The suite must import the installed wheel, never the source tree.
.venv/bin/python - <<'PY'
import pathlib, sys
import pyvr
where = pathlib.Path(pyvr.__file__).resolve()
if "site-packages" not in where.parts:
    sys.exit(f"pyvr imports from {where}, not from the installed wheel")
print(f"== pytest against the installed wheel: pyvr-rs {pyvr.__version__} ({where.parent})")
PY
# On a GPU every frame is the shader's anyway; on a CPU adapter (lavapipe)
# the native march would take them, so it is switched off here.
echo "== pytest, this machine's Vulkan driver, every frame on the shader (PYVR_NATIVE_MARCH=0)"
PYVR_NATIVE_MARCH=0 .venv/bin/python -m pytest tests -q
cost "pytest, Vulkan driver:"
# A machine with no Vulkan driver at all: the native engine alone renders
# every frame (tests of the shader engine skip, saying why).
echo "== pytest, no Vulkan driver (VK_ICD_FILENAMES points at nothing): the native engine"
VK_ICD_FILENAMES=/nonexistent .venv/bin/python -m pytest tests -q
cost "pytest, no driver:"
# The native march's portable path (CPUs without AVX2, ARM) against the
# shader and the single texture, as the AVX2 path is held above.
echo "== pytest, the native march's portable path (PYVR_NATIVE_LANES=portable)"
PYVR_NATIVE_LANES=portable .venv/bin/python -m pytest tests/test_native_march.py tests/test_bricks.py -q
cost "pytest, portable lanes:"
# Style: rustfmt, clippy (warnings as errors) and ruff.
bash scripts/lint.sh
cost "lint:"
# The documentation site, warnings as errors (its gallery runs every example).
PYVR_SETUP_DONE=1 bash scripts/docs.sh
cost "docs:"
echo "== what each stage cost: $(printf '%s; ' "${costs[@]}")"
