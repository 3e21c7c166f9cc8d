"""float32 against float16 storage on pyvr's benchmark scene (256^3
double_sphere with normals, [-1,1]^3, 512x512, lit), rendered alternately in
one process so that both see the same machine load: median and best of 6
frames per step, in ms.

Run: .venv/bin/python benches/precision_ab.py
"""

import os, time, numpy as np
os.environ.setdefault("PYVR_BACKEND","vulkan")
from pyvr import RenderConfig, VolumeRenderer
from pyvr.camera import Camera
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.lighting import Light
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume
BOX = (np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32))
ds = create_sample_volume(256, "double_sphere")
vol = Volume(ds, compute_normal_volume(ds), *BOX)
rs = {}
for prec in ["float32", "float16"]:
    r = VolumeRenderer(512, 512, light=Light.default())
    r.load_volume(vol, precision=prec); r.set_camera(Camera.isometric_view(distance=3.0))
    r.set_transfer_functions(ColorTransferFunction.from_colormap("plasma"), OpacityTransferFunction.linear(0.0, 0.1))
    rs[prec] = r
for h in [0.057, 0.08, 0.113]:
    cfg = RenderConfig(step_size=h, max_steps=int(3.5/h)+2, early_ray_termination=False)
    ts = {k: [] for k in rs}
    for r in rs.values(): r.set_config(cfg); r.render()
    for _ in range(6):
        for k, r in rs.items():
            a = time.perf_counter(); r.render(dtype=np.float32, premultiplied=True); ts[k].append(time.perf_counter() - a)
    row = "  ".join(f"{k} {np.median(v) * 1e3:6.1f} (best {min(v) * 1e3:6.1f})" for k, v in ts.items())
    print(f"step {h:<6} {row}  float32/float16 {np.median(ts['float32']) / np.median(ts['float16']):.2f}x", flush=True)
