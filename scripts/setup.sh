#!/usr/bin/env bash
# Installs everything pyvr's tests and demo need on a fresh Debian/Ubuntu
# machine that has Rust (cargo) and Python 3.11+: a software Vulkan driver
# when no GPU driver is present, Mesa's EGL (for the OpenGL reference
# renderer in the tests), Xvfb (a virtual display for the interface's window
# test), Chromium (the notebook view's browser test), the wheel
# (scripts/wheel.sh), and a virtual environment in .venv
# with that wheel installed as a user installs it.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" != 0 ] && command -v sudo >/dev/null; then SUDO="sudo"; fi

need=()
have_icd=false
for f in /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json; do
    [ -e "$f" ] && have_icd=true
done
$have_icd || need+=(mesa-vulkan-drivers)
# xvfb and xauth: the interface test opens a real (Tk) window on a virtual display;
# chromium and its driver: the notebook view's test drives JupyterLab in a headless browser.
for pkg in libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri xvfb xauth chromium chromium-driver; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
    echo "== installing system packages: ${need[*]}"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}" >/dev/null
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
    echo "== creating .venv"
    "$PY" -m venv .venv
fi

# pyvr as users install it: the wheel scripts/wheel.sh builds.
bash scripts/wheel.sh
wheel=$(ls "$PWD"/dist/*.whl)

# PATH without any folder holding cargo or rustc: the install must not be
# able to build anything from source.
no_rust_path() {
    local out="" dir
    IFS=: read -ra dirs <<<"$PATH"
    for dir in "${dirs[@]}"; do
        [ -x "$dir/cargo" ] || [ -x "$dir/rustc" ] || out="${out:+$out:}$dir"
    done
    echo "$out"
}
echo "== installing the wheel into .venv, with the extras the tests use (no Rust toolchain on PATH)"
.venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip
# An earlier install (a `maturin develop` one, or the old distribution name) would shadow the wheel.
.venv/bin/python -m pip uninstall -q -y pyvr pyvr-rs >/dev/null 2>&1 || true
# The test extra: moderngl (the reference renderer), the file-format readers the loader tests read and
# write, tqdm, imageio, jupyter_rfb and the kernel packages the animation and notebook tests use, dask,
# distributed and xarray for the out-of-core and cluster tests. ruff is the linter scripts/lint.sh runs.
PATH=$(no_rust_path) .venv/bin/python -m pip install -q --disable-pip-version-check --only-binary pyvr-rs \
    "$wheel[test]" ruff
