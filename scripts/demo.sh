#!/usr/bin/env bash
# Set up (see setup.sh), then run the main job: pyvr's benchmark scene
# (256^3 double_sphere with normals, 512x512) at every preset; writes
# out/benchmark_<preset>.png and prints ms per frame.
set -euo pipefail
cd "$(dirname "$0")/.."
# Mesa's Vulkan loader probes for a display and complains without this.
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
bash scripts/setup.sh
.venv/bin/python examples/benchmark.py "$@"
