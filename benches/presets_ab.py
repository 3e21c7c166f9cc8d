"""pyvr's preset benchmark (256^3 double_sphere with normals, 512x512,
camera at azimuth pi/4, elevation pi/6, distance 3; plasma + linear(0, 0.1))
timed for one pyvr package: the median ms per frame of each preset, as JSON.

Comparing two builds (say before and after a change) in one session:
build the other commit's extension into a folder of its own, e.g.

    git worktree add /tmp/base <commit>
    (cd /tmp/base && CARGO_TARGET_DIR=/tmp/base-target cargo build --release --features python)
    mkdir -p /tmp/basepkg && cp -r /tmp/base/python/pyvr /tmp/basepkg/
    cp /tmp/base-target/release/libpyvr_core.so /tmp/basepkg/pyvr/_core.abi3.so

then alternate runs so that both see the same machine load:

    .venv/bin/python benches/presets_ab.py /tmp/basepkg 12
    .venv/bin/python benches/presets_ab.py python 12

Run: .venv/bin/python benches/presets_ab.py PACKAGE_PARENT [frames] [preset,preset,...]
"""

import json
import os
import sys
import time
import warnings

sys.path.insert(0, os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "python"))

import numpy as np  # noqa: E402

import pyvr  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

PRESETS = ["preview", "fast", "balanced", "high_quality", "ultra_quality"]


def main():
    frames = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    presets = sys.argv[3].split(",") if len(sys.argv) > 3 else PRESETS
    warnings.simplefilter("ignore")
    d = create_sample_volume(256, "double_sphere")
    box = np.array([1.0, 1.0, 1.0], np.float32)
    vol = Volume(d, compute_normal_volume(d), min_bounds=-box, max_bounds=box)
    camera = Camera.from_spherical(target=np.zeros(3, np.float32), distance=3.0, azimuth=np.pi / 4,
                                   elevation=np.pi / 6, roll=0.0)
    out = {"package": os.path.dirname(pyvr.__file__)}
    for p in presets:
        r = VolumeRenderer(512, 512, config=getattr(RenderConfig, p)(), light=Light.default())
        r.load_volume(vol)
        r.set_camera(camera)
        r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.1))
        r.render()  # warm-up: pipelines, uploads
        times = []
        for _ in range(frames):
            t = time.perf_counter()
            r.render()
            times.append(time.perf_counter() - t)
        out[p] = round(1e3 * float(np.median(times)), 1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
