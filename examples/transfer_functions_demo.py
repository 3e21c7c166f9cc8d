"""
Transfer functions
==================

pyvr's transfer-function demo: a torus under four colour/opacity pairs.

Run: .venv/bin/python examples/transfer_functions_demo.py  (writes out/transfer_functions_demo.png)
"""

import numpy as np

from _common import out_path, save_grid
from pyvr.camera import Camera
from pyvr.config import RenderConfig
from pyvr.datasets import compute_normal_volume, create_sample_volume
from pyvr.moderngl_renderer import VolumeRenderer
from pyvr.transferfunctions import ColorTransferFunction, OpacityTransferFunction
from pyvr.volume import Volume

data = create_sample_volume(128, "torus")
volume = Volume(data=data, normals=compute_normal_volume(data),
                min_bounds=np.array([-1.0, -1.0, -1.0], np.float32), max_bounds=np.array([1.0, 1.0, 1.0], np.float32))
renderer = VolumeRenderer(384, 384, config=RenderConfig.balanced())
renderer.load_volume(volume)
renderer.set_camera(Camera.isometric_view(distance=3.0))

pairs = {
    "viridis + linear(0, 0.1)": (ColorTransferFunction.from_colormap("viridis"), OpacityTransferFunction.linear(0.0, 0.1)),
    "plasma + peaks([0.3, 0.7])": (ColorTransferFunction.from_colormap("plasma"),
                                   OpacityTransferFunction.peaks(peaks=[0.3, 0.7], opacity=0.3, eps=0.05, base=0.0)),
    "coolwarm + one_step(0.5)": (ColorTransferFunction.from_colormap("coolwarm"),
                                 OpacityTransferFunction.one_step(step=0.5, low=0.0, high=0.15)),
    "jet + peaks([0.25, 0.75])": (ColorTransferFunction.from_colormap("jet"),
                                  OpacityTransferFunction.peaks(peaks=[0.25, 0.75], opacity=0.2, eps=0.1, base=0.02)),
}
images = []
for name, (ctf, otf) in pairs.items():
    renderer.set_transfer_functions(ctf, otf)
    images.append(renderer.render())
    lut = otf.to_lut(256)
    print(f"{name:28s} opacity LUT: mean {lut.mean():.3f}, max {lut.max():.2f}; colour at 0.5 {ctf.to_lut(256)[128]}")
print("wrote", save_grid(images, list(pairs), out_path("transfer_functions_demo.png"), cols=2))
