#!/usr/bin/env bash
# Builds what users install, into dist/: one abi3 wheel (CPython >= 3.11)
# for Linux x86-64 and the sdist. The wheel is linked by zig against glibc
# 2.17, so it installs on any Linux with glibc 2.17 or newer (tag
# manylinux_2_17, which `auditwheel show` confirms below), whatever glibc
# this machine has. Its only shared-library needs are glibc's; the Vulkan
# loader is opened at run time when present. The build tools (maturin, zig
# from the `ziglang` package, auditwheel) live in .venv-build.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/progress.sh
PY=${PYTHON:-python3}
if [ ! -x .venv-build/bin/python ]; then
    echo "== creating .venv-build (maturin, zig, auditwheel)"
    "$PY" -m venv .venv-build
fi
.venv-build/bin/python -m pip install -q --disable-pip-version-check "maturin>=1.7,<2" "ziglang>=0.13,<0.18" "auditwheel>=6"
rm -rf dist
# maturin finds zig on PATH (the ziglang package's launcher in .venv-build/bin).
export PATH="$PWD/.venv-build/bin:$PATH"
quietly "building the wheel (release; a few minutes from scratch, seconds when nothing changed)" \
    maturin build --release --locked --zig --compatibility manylinux_2_17 --out dist
quietly "building the sdist" maturin sdist --out dist
wheel=$(ls dist/*.whl)
auditwheel show "$wheel" | grep -E 'consistent with|^"manylinux' | tr -s ' \n' ' '
echo
echo "== dist/: $(cd dist && ls -s --block-size=K --format=single-column *.whl *.tar.gz | tr '\n' ' ')"
