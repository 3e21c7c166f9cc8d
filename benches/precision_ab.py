"""float32 against float16 and 16-bit fixed-point storage on pyvr's
benchmark scene (256^3 double_sphere with normals, [-1,1]^3, 512x512, lit),
rendered alternately in one process so that all see the same machine load:
median of --frames frames per step, in ms, and each frame's largest
difference from the float32 frame, in 8-bit levels.

Run: .venv/bin/python benches/precision_ab.py [--frames 5]
"""

import argparse
import os
import sys
import time

import numpy as np

os.environ.setdefault("PYVR_BACKEND", "vulkan")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _report import write_table  # noqa: E402
from pyvr import RenderConfig, VolumeRenderer  # noqa: E402
from pyvr.camera import Camera  # noqa: E402
from pyvr.datasets import compute_normal_volume, create_sample_volume  # noqa: E402
from pyvr.lighting import Light  # noqa: E402
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction  # noqa: E402
from pyvr.volume import Volume  # noqa: E402

BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
STEPS = [0.01, 0.057, 0.113]
STORAGES = ["float32", "float16", "fixed16"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=5)
    args = ap.parse_args()
    ds = create_sample_volume(256, "double_sphere")
    vol = Volume(ds, compute_normal_volume(ds), *BOX)
    rs = {}
    for prec in STORAGES:
        r = VolumeRenderer(512, 512, light=Light.default())
        r.load_volume(vol, precision=prec)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.1))
        rs[prec] = r
    rows = []
    for h in STEPS:
        cfg = RenderConfig(step_size=h, max_steps=int(3.5 / h) + 2, early_ray_termination=False)
        ts = {k: [] for k in rs}
        images = {}
        for k, r in rs.items():
            r.set_config(cfg)
            images[k] = r.render(dtype=np.float32, premultiplied=True)
        for _ in range(args.frames):
            for k, r in rs.items():
                a = time.perf_counter()
                r.render(dtype=np.float32, premultiplied=True)
                ts[k].append(time.perf_counter() - a)
        ms = {k: 1e3 * float(np.median(ts[k])) for k in rs}
        diff = {k: float(np.abs(images[k] - images["float32"]).max() * 255) for k in rs}
        print(f"step {h:<6} " + "  ".join(f"{k} {ms[k]:6.1f} ms ({diff[k]:.3f} levels)" for k in rs), flush=True)
        rows.append([h, *(f"{ms[k]:.0f}" for k in rs),
                     *(f"{ms['float32'] / ms[k]:.2f}x" for k in STORAGES[1:]),
                     *(f"{diff[k]:.3f}" for k in STORAGES[1:])])
    write_table("precision_ab", f"benches/precision_ab.py --frames {args.frames}",
                ["step", *(f"{k} ms" for k in STORAGES), *(f"float32 / {k}" for k in STORAGES[1:]),
                 *(f"{k}: max difference from float32 (levels)" for k in STORAGES[1:])],
                rows, device=r.device,
                note="The lit benchmark scene, 512x512, no early termination; the storages rendered alternately, "
                f"median of {args.frames} frames.")


if __name__ == "__main__":
    main()
