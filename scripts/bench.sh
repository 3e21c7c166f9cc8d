#!/usr/bin/env bash
# Set up (see setup.sh), add the benchmark-only peer (VTK's wheel, ~140 MB),
# then measure the speed/accuracy trade against the peers
# (benches/accuracy.py): prints a table per scene and writes
# out/accuracy.json and out/accuracy.png. Arguments go to the benchmark.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
bash scripts/setup.sh
.venv/bin/python -c "import vtk" 2>/dev/null || .venv/bin/python -m pip install -q vtk
.venv/bin/python benches/accuracy.py "$@"
