"""
Basic rendering
===============

pyvr's basic example: a 128^3 sphere without normals, balanced preset.

Run: .venv/bin/python examples/basic_rendering.py  (writes out/basic_rendering.png)
"""

import time

from _common import out_path
from pyvr.camera import Camera
from pyvr.config import RenderConfig
from pyvr.datasets import create_sample_volume
from pyvr.lighting import Light
from pyvr.moderngl_renderer import VolumeRenderer
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

volume = Volume(data=create_sample_volume(128, "sphere"))
renderer = VolumeRenderer(width=512, height=512, config=RenderConfig.balanced(), light=Light.default())
renderer.load_volume(volume)
renderer.set_camera(Camera.front_view(distance=3.0))
renderer.set_transfer_functions(ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.1))

start = time.perf_counter()
image = renderer.render()  # (512, 512, 4) uint8, row 0 = bottom
elapsed = (time.perf_counter() - start) * 1e3
print(f"volume {volume.shape}, image {image.shape} {image.dtype}, {elapsed:.0f} ms on {renderer.device}")

# pyvr's examples show the array with imshow(origin="lower"); this writes it top-first.
renderer.render_to_pil(image).save(out_path("basic_rendering.png"))
print("wrote", out_path("basic_rendering.png"))
