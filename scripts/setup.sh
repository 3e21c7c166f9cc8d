#!/usr/bin/env bash
# Installs everything pyvr needs on a fresh Debian/Ubuntu machine that has
# Rust (cargo) and Python 3.11+: a software Vulkan driver when no GPU driver
# is present, Mesa's EGL (for the OpenGL reference renderer in the tests), Xvfb
# (a virtual display for the interface's window test),
# a virtual environment in .venv, and the release build of pyvr into it.
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
# xvfb and xauth: the interface test opens a real (Tk) window on a virtual display.
for pkg in libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri xvfb xauth; do
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
echo "== installing Python packages"
.venv/bin/python -m pip install -q --upgrade pip
# The file-format extras (nifti, nrrd, dicom, tiff, zarr) are what the loader tests read and write;
# tqdm, imageio(-ffmpeg), jupyter_rfb and the kernel packages are what the animation and notebook tests use;
# dask, distributed and xarray what the out-of-core and cluster tests use.
.venv/bin/python -m pip install -q "maturin>=1.7,<2" numpy scipy pillow matplotlib moderngl pytest hypothesis \
    nibabel pynrrd pydicom tifffile zarr tqdm imageio imageio-ffmpeg jupyter_rfb ipywidgets nbclient nbformat ipykernel \
    "dask[array]" distributed xarray ruff

echo "== building pyvr (release)"
start=$(date +%s)
# Into this .venv even when another virtual environment is active.
VIRTUAL_ENV="$PWD/.venv" .venv/bin/maturin develop --release -q
echo "== build took $(( $(date +%s) - start )) s"
