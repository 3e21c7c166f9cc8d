"""float32 against float16 storage on pyvr's benchmark scene (256^3
double_sphere with normals, [-1,1]^3, 512x512, lit), rendered alternately in
one process so that both see the same machine load: median and best of
--frames frames per step, in ms.

Run: .venv/bin/python benches/precision_ab.py [--frames 6]
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
STEPS = [0.057, 0.08, 0.113]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=6)
    args = ap.parse_args()
    ds = create_sample_volume(256, "double_sphere")
    vol = Volume(ds, compute_normal_volume(ds), *BOX)
    rs = {}
    for prec in ["float32", "float16"]:
        r = VolumeRenderer(512, 512, light=Light.default())
        r.load_volume(vol, precision=prec)
        r.set_camera(Camera.isometric_view(distance=3.0))
        r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.1))
        rs[prec] = r
    rows = []
    for h in STEPS:
        cfg = RenderConfig(step_size=h, max_steps=int(3.5 / h) + 2, early_ray_termination=False)
        ts = {k: [] for k in rs}
        for r in rs.values():
            r.set_config(cfg)
            r.render()
        for _ in range(args.frames):
            for k, r in rs.items():
                a = time.perf_counter()
                r.render(dtype=np.float32, premultiplied=True)
                ts[k].append(time.perf_counter() - a)
        m32, m16 = (1e3 * float(np.median(ts[k])) for k in ("float32", "float16"))
        print(f"step {h:<6} float32 {m32:6.1f} ms  float16 {m16:6.1f} ms  float32/float16 {m32 / m16:.2f}x", flush=True)
        rows.append([h, f"{m32:.0f}", f"{m16:.0f}", f"{m32 / m16:.2f}x"])
    write_table("precision_ab", f"benches/precision_ab.py --frames {args.frames}",
                ["step", "float32 ms", "float16 ms", "float32 / float16"], rows, device=r.device,
                note="The lit benchmark scene, 512x512, no early termination; both storages rendered alternately, "
                f"median of {args.frames} frames.")


if __name__ == "__main__":
    main()
